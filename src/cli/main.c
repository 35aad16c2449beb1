/*
 * slctl: look at and drive a running sharedlinkd (DESIGN.md 2.7). The command table with the
 * help texts, the global options and the dispatch. What the commands share is in slctl.c; the
 * commands themselves in cmd_*.c, which know nothing of this table (a command's --help prints
 * the text that main() put in struct slctl), so the modules depend one way only.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/cmd_daemon.h"
#include "cli/cmd_info.h"
#include "cli/cmd_record.h"
#include "cli/cmd_vars.h"
#include "cli/slctl.h"

#ifndef SHAREDLINK_VERSION
#define SHAREDLINK_VERSION "unknown"
#endif

struct command {
        const char *name;
        int (*run)(struct slctl *s, int argc, char **argv);
        const char *synopsis;           /* one line for the overview */
        const char *help;               /* what `slctl NAME --help` prints */
};

static const struct command commands[] = {
        { "list", cmd_vars_list, "list [--json]",
          "Usage: slctl [-i INSTANCE] list [--json]\n"
          "\n"
          "Lists every variable of the instance, one per line:\n"
          "  NAME DIR LINK PEER TYPE AGE FLAGS VALUE\n"
          "DIR is \"in\" (published by the daemon, read only) or \"out\" (written by clients,\n"
          "sent by the daemon). AGE is the time since the last update (\"-\": never). FLAGS are\n"
          "valid, stale, outbound, repaired, adhoc, comma-separated (\"-\": none). LINK and PEER\n"
          "are \"-\" when the variable has none. VALUE comes last: it may contain spaces.\n"
          "\n"
          "  --json   one JSON object: {\"instance\": ..., \"variables\": [{\"name\",\n"
          "           \"direction\", \"link\", \"peer\", \"type\", \"position\", \"value\",\n"
          "           \"valid\", \"stale\", \"outbound\", \"repaired\", \"adhoc\", \"age_ns\",\n"
          "           \"sequence\", \"updated_real_ns\"}, ...]} (link, peer, position,\n"
          "           age_ns: null when none)\n" },
        { "get", cmd_vars_get, "get [--strict] NAME...",
          "Usage: slctl [-i INSTANCE] get [--strict] NAME...\n"
          "\n"
          "Prints the value of each variable, one per line, in the order given. A variable\n"
          "that was never set prints an empty line; a stale one (link down, peer silent) prints\n"
          "its last value. An unknown name is an error (exit 1, nothing printed).\n"
          "\n"
          "  --strict   fail (exit 1, nothing printed) when a value is not valid or is stale\n"
          "\n"
          "Example: slctl get AutoGpsLat AutoGpsLon\n" },
        { "set", cmd_vars_set, "set NAME VALUE",
          "Usage: slctl [-i INSTANCE] set NAME VALUE\n"
          "\n"
          "Writes VALUE to the outbound variable NAME; the daemon sends it to the peer. Values\n"
          "are printable ASCII without | [ ], at most 63 bytes. Only outbound variables (DIR\n"
          "\"out\" in `slctl list`) can be written, and only by the daemon's group.\n"
          "A value that starts with '-' followed by a digit is taken as a value; use -- before\n"
          "any other value that starts with '-'.\n"
          "\n"
          "Example: slctl set CmdThrottle 0.25\n" },
        { "watch", cmd_vars_watch, "watch [--count N] [--timeout MS] [NAME...]",
          "Usage: slctl [-i INSTANCE] watch [--count N] [--timeout MS] [NAME...]\n"
          "\n"
          "Prints the current value of each variable (all of them when no NAME is given), then\n"
          "one line per change of value or of state (valid, stale) until interrupted:\n"
          "  TIME NAME VALUE [stale]        TIME NAME [invalid]\n"
          "A refresh that rewrites the same value is not a change. TIME is when the value was\n"
          "updated (local time, ISO 8601 with milliseconds); a change of state alone (e.g.\n"
          "becoming stale) carries the time it was seen. The [stale] and [invalid] markers\n"
          "cannot be part of a value (values never contain [ ]).\n"
          "Variables created while watching (ad hoc names) are followed too when no NAME is\n"
          "given.\n"
          "\n"
          "  --count N      stop after N changes (the initial values do not count)\n"
          "  --timeout MS   stop after MS milliseconds; with --count, not reaching N changes\n"
          "                 in time is an error (exit 1)\n" },
        { "events", cmd_info_events, "events [--follow] [--new] [--count N] [--timeout MS]",
          "Usage: slctl [-i INSTANCE] events [--follow] [--new] [--count N] [--timeout MS]\n"
          "\n"
          "Prints the events the daemon keeps in its ring (CIRCE actions, devices coming and\n"
          "going, link state changes, query answers...), oldest first, one per line:\n"
          "  SEQ LINK TYPE key=value ...\n"
          "e.g. \"17 agility action device=E1E1E1 sensor_time=5000\". LINK is \"-\" for daemon\n"
          "events. When events were overwritten before they could be read, a line\n"
          "\"- - overrun lost=N\" comes first; after a daemon restart, \"- - restart\".\n"
          "A cut text ends with \"truncated=1\".\n"
          "\n"
          "  --follow       keep waiting for new events after the retained ones\n"
          "  --new          skip the retained events: only events from now on\n"
          "  --count N      stop after N events\n"
          "  --timeout MS   with --follow: stop after MS milliseconds; with --count, not\n"
          "                 reaching N events in time is an error (exit 1)\n" },
        { "stats", cmd_info_stats, "stats [--json] [--all]",
          "Usage: slctl [-i INSTANCE] stats [--json] [--all]\n"
          "\n"
          "Prints the daemon (pid, running or not, epoch, heartbeat age, start time, its own\n"
          "counters) and, per link, its protocol, state (and for how long) and its counters by\n"
          "name: frames, bytes, and errors by reason. Only the counters that apply are shown:\n"
          "the daemon's own, and for a link those its protocol can move; the non-zero ones\n"
          "come first. Works on the tables a crashed daemon left behind too (they say \"not\n"
          "running\"; the exit code is then 3).\n"
          "\n"
          "  --all    every counter everywhere (non-zero first), also those of the other\n"
          "           protocol, which stay 0\n"
          "  --json   one JSON object, always with every counter: {\"instance\", \"daemon\":\n"
          "           {\"pid\", \"alive\",\n"
          "           \"epoch\" (hex string), \"heartbeat_age_ns\", \"heartbeat_interval_ms\",\n"
          "           \"started_real_ns\", \"counters\": {name: n}}, \"links\": [{\"name\",\n"
          "           \"protocol\", \"state\", \"state_name\" (its first 31 bytes),\n"
          "           \"state_text\" (whole), \"state_age_ns\", \"counters\": {name: n}}]}\n" },
        { "query", cmd_daemon_query, "query [--timeout MS] [--wait MS] LINK PEER NAME",
          "Usage: slctl [-i INSTANCE] query [--timeout MS] [--wait MS] LINK PEER NAME\n"
          "\n"
          "Asks the SharedLink node PEER (an address A..P) on LINK for the value of its variable\n"
          "NAME (a Q frame) and prints the answer.\n"
          "\n"
          "  --timeout MS   how long the peer has to answer (default: the daemon's, 1000 ms;\n"
          "                 at most 60000)\n"
          "  --wait MS      if LINK is down, wait up to MS for it instead of failing at once\n"
          "\n"
          "Example: slctl query vehicle A AutoGpsLat\n" },
        { "ping", cmd_daemon_ping, "ping [--timeout MS] [--wait MS] LINK PEER",
          "Usage: slctl [-i INSTANCE] ping [--timeout MS] [--wait MS] LINK PEER\n"
          "\n"
          "Sends the ping P0 to the SharedLink node PEER (an address A..P) on LINK and prints\n"
          "the round trip until its G0, measured by the daemon: \"G0 from PEER on LINK:\n"
          "time=0.412 ms\". No G0 in time, a link that is down (or goes down while waiting) or\n"
          "a PEER the link does not have is an error (exit 1).\n"
          "\n"
          "  --timeout MS   how long the peer has to answer (default: the daemon's, 1000 ms;\n"
          "                 at most 60000)\n"
          "  --wait MS      if LINK is down, wait up to MS for it instead of failing at once\n"
          "\n"
          "Example: slctl ping vehicle A\n" },
        { "command", cmd_daemon_command, "command [--wait MS] LINK MODULE [TEXT...]",
          "Usage: slctl [-i INSTANCE] command [--wait MS] LINK MODULE [TEXT...]\n"
          "\n"
          "Sends the module command E<MODULE>|D<TEXT> to the pronto4 peer(s) of the SharedLink\n"
          "link LINK (docs/pronto4.md 9). The TEXT words are joined with single spaces. MODULE:\n"
          "1..63 letters, digits, _ . -; TEXT: at most 63 bytes of printable ASCII without\n"
          "| [ ], at most 28 words; put -- before a TEXT that starts with '-'. The bare module\n"
          "requests MUI, MUO, ML and MW take no TEXT and go out as they are (\"MUI\"). Fails\n"
          "when LINK is down or has no pronto4 peer.\n"
          "\n"
          "  --wait MS      if LINK is down, wait up to MS for it instead of failing at once\n"
          "\n"
          "Example: slctl command vehicle ServoPod \"0,TELEOP START\"\n" },
        { "record", cmd_record, "record [--duration S] [--count N] LINK FILE|-",
          "Usage: slctl [-i INSTANCE] record [--duration S] [--count N] LINK FILE|-\n"
          "\n"
          "Records what the link LINK receives and sends into FILE (\"-\": standard output),\n"
          "one line per chunk read from or written to its device (a UDP datagram is one\n"
          "chunk), with CLOCK_MONOTONIC times since the start (docs/recording.md), until the\n"
          "link is stopped, the daemon stops, a limit below is reached, or SIGINT or SIGTERM\n"
          "comes. After such a signal the lines already on their way are still written, for\n"
          "up to 300 ms; a second signal ends it at once. FILE is created at the first line\n"
          "(an unknown link leaves no file) and holds only whole lines. At the end it prints\n"
          "\"slctl: recorded N chunks (B bytes), D dropped by the daemon, to FILE\" on\n"
          "standard error and exits 0. The daemon never waits for a slow recorder: what does\n"
          "not fit its queue is dropped and marked in the file with \"# dropped N chunks\".\n"
          "A recording is played back by a link with \"transport: replay\" and \"file: FILE\".\n"
          "Allowed to whoever may send commands: root, the daemon's user and its group.\n"
          "Exit status: 0 when stopped as above, 1 for an error (unknown link, FILE not\n"
          "writable, permission denied), 2 for a usage error, 3 when the daemon is not running.\n"
          "\n"
          "  --duration S   stop after S seconds (1..31536000)\n"
          "  --count N      stop after N chunks\n"
          "\n"
          "Example: slctl record vehicle /tmp/vehicle.rec\n" },
        { "circe", cmd_daemon_circe, "circe LINK OPERATION ...",
          "Usage:\n"
          "  slctl [-i INSTANCE] circe LINK alert ADDR\n"
          "  slctl [-i INSTANCE] circe LINK network-setup ADDR (--join|--leave) --roles N\n"
          "  slctl [-i INSTANCE] circe LINK device-setup --assign ADDR [--dest ADDR]\n"
          "                                [--capabilities N]\n"
          "  slctl [-i INSTANCE] circe LINK sync-clocks\n"
          "  slctl [-i INSTANCE] circe LINK visualize ADDR[,ADDR...] [--current N] [--next N]\n"
          "        [--start-timer] [--primary MS] [--secondary MS] [--faults N] [--refusals N]\n"
          "        [--eliminated 0|1] [--placement N]\n"
          "  slctl [-i INSTANCE] circe LINK emulate action ADDR [--keys N] [--sensor-time MS]\n"
          "\n"
          "Sends a CIRCE operation through the controller link LINK (emulate: through a link in\n"
          "the mediator role, as if device ADDR had reported an action). ADDR is a device\n"
          "address, six hex digits (FFFFFF is reserved). Ranges: competitor numbers 0..999,\n"
          "times 0..999999 ms, faults and refusals 0..99, placement 0..999; bit masks:\n"
          "  --roles          1 keypad, 2 start timer, 4 finish timer, 8/16/32 intermediate\n"
          "                   timer 1/2/3, 64 display (0..127)\n"
          "  --capabilities   1 control keypad, 2 numeric keypad, 4 start sensor, 8 finish\n"
          "                   sensor, 16 intermediate sensor, 32 time sensor, 64 display\n"
          "  --keys           1..256 keys 1..9, 512 enter current, 1024 enter next, 2048 key 0,\n"
          "                   4096 pass finish, 8192 pass start, 16384 reset run, 32768 ready\n"
          "\n"
          "  alert           make the device signal itself\n"
          "  network-setup   make the device join or leave the network with these roles\n"
          "  device-setup    give address --assign to the device at --dest (default: the\n"
          "                  unconfigured one, 000000), optionally with --capabilities\n"
          "  sync-clocks     synchronise the devices' clocks; prints one line per device:\n"
          "                  \"ADDR succeeded\" or \"ADDR timed-out\"\n"
          "  visualize       show these fields on the displays ADDR,...; at least one field\n"
          "  emulate action  (mediator role) report a gate passage or key press of device ADDR\n"
          "\n"
          "  --wait MS       if LINK is not connected, wait up to MS for it instead of failing\n"
          "\n"
          "Example: slctl circe agility visualize D15D15 --current 12 --start-timer\n" },
};

#define NCOMMANDS (sizeof(commands) / sizeof(commands[0]))

static const char overview_tail[] =
        "\n"
        "Options:\n"
        "  -i INSTANCE    the daemon's instance (default: $SHAREDLINK_INSTANCE, else \"default\")\n"
        "  -h, --help     this help; `slctl COMMAND --help` (or `slctl help COMMAND`) for one\n"
        "                 command\n"
        "  --version      print the version\n"
        "\n"
        "Environment:\n"
        "  SHAREDLINK_INSTANCE      default instance\n"
        "  SHAREDLINK_RUNTIME_DIR   where the daemon's control socket is (query, command,\n"
        "                           circe); unset: the path the daemon publishes in its\n"
        "                           tables, else " SL_RUNTIME_DIR_DEFAULT "\n"
        "\n"
        "Exit status: 0 ok; 1 error from the daemon or bad input (message on stderr); 2 usage;\n"
        "3 the daemon is not running.\n";

static const struct command *find_command(const char *name)
{
        for (size_t i = 0; i < NCOMMANDS; i++)
                if (strcmp(commands[i].name, name) == 0)
                        return &commands[i];
        return NULL;
}

/* Prints the help of a command (NULL: the overview) on stdout; returns SLCTL_EXIT_OK. */
static int help(const char *command)
{
        const struct command *cmd = command ? find_command(command) : NULL;

        if (cmd) {
                fputs(cmd->help, stdout);
                return SLCTL_EXIT_OK;
        }
        printf("Usage: slctl [-i INSTANCE] COMMAND [ARGUMENTS]\n"
               "\n"
               "Shows and changes the shared variables of a running sharedlinkd, follows its\n"
               "events, and sends commands through its links.\n"
               "\n"
               "Commands:\n");
        for (size_t i = 0; i < NCOMMANDS; i++)
                printf("  %s\n", commands[i].synopsis);
        fputs(overview_tail, stdout);
        return SLCTL_EXIT_OK;
}


static int version(void)
{
        printf("slctl (sharedlink) %s\n", SHAREDLINK_VERSION);
        return SLCTL_EXIT_OK;
}

int main(int argc, char **argv)
{
        struct slctl s = { 0 };
        const struct command *cmd;
        int i, code;

        for (i = 1; i < argc && argv[i][0] == '-'; i++) {
                if (strcmp(argv[i], "-h") == 0 || strcmp(argv[i], "--help") == 0)
                        return help(NULL);
                if (strcmp(argv[i], "--version") == 0)
                        return version();
                if (strcmp(argv[i], "-i") == 0) {
                        if (++i == argc || !*argv[i])
                                return slctl_usage(NULL, "-i needs an instance name");
                        s.instance = argv[i];
                } else if (strncmp(argv[i], "-i", 2) == 0) {
                        s.instance = argv[i] + 2;
                } else {
                        return slctl_usage(NULL, "unknown option %s", argv[i]);
                }
        }
        if (i == argc)
                return slctl_usage(NULL, "no command given");
        if (strcmp(argv[i], "help") == 0) {
                if (i + 1 < argc && !find_command(argv[i + 1]))
                        return slctl_usage(NULL, "no command called \"%s\"", argv[i + 1]);
                return help(i + 1 < argc ? argv[i + 1] : NULL);
        }
        cmd = find_command(argv[i]);
        if (!cmd)
                return slctl_usage(NULL, "unknown command \"%s\"", argv[i]);
        if (!s.instance || !*s.instance)
                s.instance = getenv("SHAREDLINK_INSTANCE");
        if (!s.instance || !*s.instance)
                s.instance = "default";
        s.command = cmd->name;
        s.help = cmd->help;
        code = cmd->run(&s, argc - i, argv + i);
        sl_close(s.c);
        if (fflush(stdout) != 0 || ferror(stdout)) {
                fprintf(stderr, "slctl: writing the output failed\n");
                if (code == SLCTL_EXIT_OK)
                        code = SLCTL_EXIT_ERROR;
        }
        return code;
}
