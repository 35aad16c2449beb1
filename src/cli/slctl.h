/*
 * slctl: what every command shares. Commands live in cmd_vars.c (list, get, set, watch),
 * cmd_info.c (events, stats), cmd_daemon.c (query, command, circe) and cmd_record.c (record);
 * main.c parses the global options, dispatches, and holds the command table and help texts.
 * Built only on <sharedlink.h>.
 *
 * A command is `int cmd(struct slctl *s, int argc, char **argv)` with argv[0] its own name, and
 * returns the process exit code (DESIGN.md 2.7).
 */
#ifndef SLCTL_H
#define SLCTL_H

#include <sharedlink.h>

#include "cli/args.h"

#define SLCTL_EXIT_OK           0
#define SLCTL_EXIT_ERROR        1       /* error from the daemon, or bad input */
#define SLCTL_EXIT_USAGE        2       /* the command line itself is wrong */
#define SLCTL_EXIT_NOT_RUNNING  3       /* the daemon is not running */

#define SLCTL_READ_TRIES        16      /* sl_read -EAGAIN (a writer kept the slot busy) */
/* sl_write -EAGAIN: .out is being recreated (a client truncated or scribbled over it; the
 * library rang the daemon) or a dead writer's slot awaits repair. The daemon answers a ring
 * within about 100 ms; a one-shot command waits that out rather than fail, up to this long. */
#define SLCTL_WRITE_BUSY_MS     3000

struct slctl {
        const char *instance;           /* -i, $SHAREDLINK_INSTANCE, or "default" */
        const char *command;            /* argv[0] of the command, for messages */
        const char *help;               /* the command's help text, for --help */
        struct sl_client *c;            /* after slctl_open */
};

/* Prints "slctl: <message>" on stderr; returns SLCTL_EXIT_ERROR. */
int slctl_error(struct slctl *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Prints the usage error and where to find help on stderr; returns SLCTL_EXIT_USAGE. */
int slctl_usage(struct slctl *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Prints that the daemon is not running (why) on stderr; returns SLCTL_EXIT_NOT_RUNNING. */
int slctl_not_running(struct slctl *s, const char *why);

/* Prints the running command's help text on stdout; returns SLCTL_EXIT_OK. */
int slctl_print_help(struct slctl *s);

/*
 * Parses the command's options (argv[1..]) into *ret. Returns -1 when the command should go on,
 * else the exit code to return at once (help printed: 0; a usage error printed: 2).
 */
int slctl_args(struct slctl *s, int argc, char **argv, const struct args_opt *opts,
               struct args *ret);

/*
 * Opens the instance into s->c. Returns -1 on success, else the exit code after a message: 3 when
 * the tables are missing or their daemon is gone (unless allow_dead: then only missing tables),
 * 1 for other errors.
 */
int slctl_open(struct slctl *s, int allow_dead);

/*
 * Parses the values of --count (NULL: not given; else 1 up) and --timeout (milliseconds) into
 * *count (0: none) and *timeout_ms (-1: none). Returns -1, or SLCTL_EXIT_ERROR after a message.
 */
int slctl_count_timeout(struct slctl *s, const char *count_text, const char *timeout_text,
                        long *count, long *timeout_ms);

/*
 * Makes SIGINT end the process even when it was started with SIGINT ignored: a non-interactive
 * shell starts background jobs that way, and "watch until interrupted" must still stop on
 * `kill -INT`. For the commands that run until interrupted (watch, events --follow).
 */
void slctl_interruptible(void);

/* sl_write, waiting out -EAGAIN for up to SLCTL_WRITE_BUSY_MS. */
int slctl_write(struct slctl *s, int id, const char *value);

/* sl_read with retries on -EAGAIN. */
int slctl_read(struct slctl *s, int id, char *buf, size_t size, struct sl_meta *meta);

/* Formats an age in ns ("0.120s", "-" for never) into buf. */
void slctl_format_age(char *buf, size_t size, uint64_t age_ns, int known);

#endif
