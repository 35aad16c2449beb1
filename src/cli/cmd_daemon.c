/*
 * slctl query, command and circe: commands through the daemon's control socket. The library
 * checks every argument against the protocol's ranges before anything is sent and says which one
 * it refused; here the command line is mapped onto its calls.
 */
#include "cli/cmd_daemon.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "cli/slctl.h"

#define REPLY_SIZE              (SL_REPLY_LINE_MAX + 1)
#define ADDRESS_DIGITS          (SL_CIRCE_ADDRESS_SIZE - 1)

/* Reports the result of a command; returns the exit code. */
static int command_result(int r, const char *reply)
{
        if (r >= 0) {
                if (reply[0])
                        printf("%s\n", reply);
                return SLCTL_EXIT_OK;
        }
        fflush(stdout);
        fprintf(stderr, "slctl: %s\n", reply[0] ? reply : sl_strerror(r));
        return r == -ECONNREFUSED ? SLCTL_EXIT_NOT_RUNNING : SLCTL_EXIT_ERROR;
}

/* --wait MS onto the handle. Returns -1, or an exit code after a message. */
static int apply_wait(struct slctl *s, const char *text)
{
        long ms;

        if (!text)
                return -1;
        if (args_number(text, &ms) < 0 || ms > SL_WAIT_MAX_MS)
                return slctl_error(s, "bad --wait \"%s\": 0..%d ms expected", text, SL_WAIT_MAX_MS);
        sl_set_command_wait(s->c, (int)ms);
        return -1;
}

/* Parses the number of option name. Returns -1, or SLCTL_EXIT_ERROR after a message. */
static int number_option(struct slctl *s, const char *name, const char *text, long *ret)
{
        int r = args_number(text, ret);

        if (r == -ERANGE)
                return slctl_error(s, "bad --%s \"%s\": too large", name, text);
        if (r < 0)
                return slctl_error(s, "bad --%s \"%s\": a decimal number expected", name, text);
        return -1;
}

/*
 * The command line of a request to a peer (query, ping): [--timeout MS] [--wait MS] and npos
 * words (usage says which), then the handle opened with the wait. Returns -1 with *ret_timeout_ms
 * (0: the daemon's), or an exit code after a message.
 */
static int peer_request_args(struct slctl *s, int argc, char **argv, int npos, const char *usage,
                             struct args *a, long *ret_timeout_ms)
{
        static const struct args_opt opts[] = { { "timeout", 1 }, { "wait", 1 }, { NULL, 0 } };
        long timeout_ms = 0;
        int code;

        code = slctl_args(s, argc, argv, opts, a);
        if (code >= 0)
                return code;
        if (a->npos != npos)
                return slctl_usage(s, "%s", usage);
        if (a->given[0]) {
                code = number_option(s, "timeout", a->value[0], &timeout_ms);
                if (code >= 0)
                        return code;
                if (timeout_ms == 0 || timeout_ms > SL_QUERY_TIMEOUT_MAX_MS)
                        return slctl_error(s, "bad --timeout %ld: 1..%d ms expected", timeout_ms,
                                           SL_QUERY_TIMEOUT_MAX_MS);
        }
        code = slctl_open(s, 0);
        if (code >= 0)
                return code;
        *ret_timeout_ms = timeout_ms;
        return apply_wait(s, a->value[1]);
}

int cmd_daemon_query(struct slctl *s, int argc, char **argv)
{
        char reply[REPLY_SIZE];
        long timeout_ms = 0;
        struct args a;
        int code, r;

        code = peer_request_args(s, argc, argv, 3, "give LINK PEER NAME", &a, &timeout_ms);
        if (code >= 0)
                return code;
        r = sl_query(s->c, a.pos[0], a.pos[1], a.pos[2], (int)timeout_ms, reply, sizeof(reply));
        if (r >= 0) {
                printf("%s\n", reply);
                return SLCTL_EXIT_OK;
        }
        return command_result(r, reply);
}

/* ---- ping (SharedLink P0 / G0) ------------------------------------------------------------- */

#define NS_PER_MS               1000000.0

int cmd_daemon_ping(struct slctl *s, int argc, char **argv)
{
        char reply[REPLY_SIZE] = "";
        long timeout_ms = 0;
        uint64_t rtt_ns = 0;
        struct args a;
        int code, r;

        code = peer_request_args(s, argc, argv, 2, "give LINK PEER", &a, &timeout_ms);
        if (code >= 0)
                return code;
        r = sl_ping(s->c, a.pos[0], a.pos[1], (int)timeout_ms, &rtt_ns, reply, sizeof(reply));
        if (r < 0)
                return command_result(r, reply);
        printf("G0 from %s on %s: time=%.3f ms\n", a.pos[1], a.pos[0], (double)rtt_ns / NS_PER_MS);
        return SLCTL_EXIT_OK;
}

/* ---- command (Pronto4 module commands) ---------------------------------------------------- */

/* Joins words[0..n) with single spaces into buf; 0, or -EMSGSIZE when they do not fit. */
static int join_words(char *const *words, int n, char *buf, size_t size)
{
        size_t len = 0;

        buf[0] = '\0';
        for (int i = 0; i < n; i++) {
                int w = snprintf(buf + len, size - len, "%s%s", i ? " " : "", words[i]);

                if (w < 0 || (size_t)w >= size - len)
                        return -EMSGSIZE;
                len += (size_t)w;
        }
        return 0;
}

/*
 * sl_command's EOPNOTSUPP (it has no reply text): a link of another protocol, or a SharedLink link
 * without a pronto4 peer. The tables say which protocol the link speaks.
 */
static int command_unsupported(struct slctl *s, const char *link)
{
        struct sl_link_info info = { .size = sizeof(info) };
        int n = sl_link_count(s->c);

        for (int i = 0; i < n; i++) {
                if (sl_link_info(s->c, i, &info) < 0 || strcmp(info.name, link) != 0)
                        continue;
                if (strcmp(info.protocol, "sharedlink") != 0)
                        return slctl_error(s, "link %s speaks %s: command is for sharedlink links "
                                           "(%s)", link, info.protocol, sl_strerror(-EOPNOTSUPP));
                break;
        }
        return slctl_error(s, "link %s has no pronto4 peer", link);
}

int cmd_daemon_command(struct slctl *s, int argc, char **argv)
{
        static const struct args_opt opts[] = { { "wait", 1 }, { NULL, 0 } };
        char text[SL_COMMAND_TEXT_MAX + 1];
        struct args a;
        int code, r;

        code = slctl_args(s, argc, argv, opts, &a);
        if (code >= 0)
                return code;
        if (a.npos < 2)
                return slctl_usage(s, "give LINK MODULE [TEXT...]");
        if (join_words(a.pos + 2, a.npos - 2, text, sizeof(text)) < 0)
                return slctl_error(s, "command text longer than %d bytes", SL_COMMAND_TEXT_MAX);
        code = slctl_open(s, 0);
        if (code >= 0)
                return code;
        code = apply_wait(s, a.value[0]);
        if (code >= 0)
                return code;
        r = sl_command(s->c, a.pos[0], a.pos[1], text);
        if (r == -EINVAL)
                return slctl_error(s, "bad module \"%s\" or text \"%s\": the module is 1..63 "
                                   "letters, digits, _ . -; the text at most %d bytes of printable "
                                   "ASCII without | [ ], words separated by single spaces, at most "
                                   "%d words", a.pos[1], text, SL_COMMAND_TEXT_MAX,
                                   SL_COMMAND_WORDS_MAX);
        if (r == -EOPNOTSUPP)
                return command_unsupported(s, a.pos[0]);
        if (r == -ENOTCONN)
                return slctl_error(s, "link %s is down (--wait MS waits for it)", a.pos[0]);
        return command_result(r, "");
}

/* ---- circe --------------------------------------------------------------------------------- */

enum circe_opt {
        C_WAIT, C_JOIN, C_LEAVE, C_ROLES, C_ASSIGN, C_DEST, C_CAPS, C_CURRENT, C_NEXT, C_START,
        C_PRIMARY, C_SECONDARY, C_FAULTS, C_REFUSALS, C_ELIMINATED, C_PLACEMENT, C_KEYS,
        C_SENSOR_TIME, C_COUNT
};

static const struct args_opt circe_opts[] = {
        [C_WAIT] = { "wait", 1 }, [C_JOIN] = { "join", 0 }, [C_LEAVE] = { "leave", 0 },
        [C_ROLES] = { "roles", 1 }, [C_ASSIGN] = { "assign", 1 }, [C_DEST] = { "dest", 1 },
        [C_CAPS] = { "capabilities", 1 }, [C_CURRENT] = { "current", 1 },
        [C_NEXT] = { "next", 1 }, [C_START] = { "start-timer", 0 },
        [C_PRIMARY] = { "primary", 1 }, [C_SECONDARY] = { "secondary", 1 },
        [C_FAULTS] = { "faults", 1 }, [C_REFUSALS] = { "refusals", 1 },
        [C_ELIMINATED] = { "eliminated", 1 }, [C_PLACEMENT] = { "placement", 1 },
        [C_KEYS] = { "keys", 1 }, [C_SENSOR_TIME] = { "sensor-time", 1 },
        [C_COUNT] = { NULL, 0 },
};

_Static_assert(C_COUNT <= ARGS_OPTS_MAX, "circe options fit struct args");

#define BIT(o)                  (1u << (o))
#define VISUALIZE_OPTS          (BIT(C_CURRENT) | BIT(C_NEXT) | BIT(C_START) | BIT(C_PRIMARY) | \
                                 BIT(C_SECONDARY) | BIT(C_FAULTS) | BIT(C_REFUSALS) | \
                                 BIT(C_ELIMINATED) | BIT(C_PLACEMENT))
/* Options whose value is a decimal number (parsed before anything else happens). */
#define NUMBER_OPTS             (BIT(C_WAIT) | BIT(C_ROLES) | BIT(C_CAPS) | BIT(C_CURRENT) | \
                                 BIT(C_NEXT) | BIT(C_PRIMARY) | BIT(C_SECONDARY) | \
                                 BIT(C_FAULTS) | BIT(C_REFUSALS) | BIT(C_ELIMINATED) | \
                                 BIT(C_PLACEMENT) | BIT(C_KEYS) | BIT(C_SENSOR_TIME))

/* A parsed circe command line. */
struct circe_call {
        const char *link;
        const struct args *a;
        long num[C_COUNT];              /* the NUMBER_OPTS that were given */
};

/* One CIRCE operation: its words, the options it takes and needs (besides --wait). */
struct circe_op {
        const char *name;
        int npos;                       /* positional words after LINK and the operation */
        unsigned opts;                  /* BIT(C_*) it takes */
        unsigned needs;                 /* BIT(C_*) it must have */
        int (*run)(struct slctl *s, const struct circe_call *k, char *reply, size_t size);
};

/* The address as typed, in upper case (the wire wants upper case; people type either). */
static const char *upper_address(const char *text, char *buf)
{
        if (strlen(text) != ADDRESS_DIGITS)
                return text;    /* the library refuses it, with the reason */
        for (int i = 0; i < ADDRESS_DIGITS; i++)
                buf[i] = (text[i] >= 'a' && text[i] <= 'f') ? (char)(text[i] - 'a' + 'A') : text[i];
        buf[ADDRESS_DIGITS] = '\0';
        return buf;
}

/* A number option as an int: ARGS_DIGITS_MAX digits at most, so it fits. */
static int num_int(const struct circe_call *k, enum circe_opt o)
{
        return (int)k->num[o];
}

static int run_alert(struct slctl *s, const struct circe_call *k, char *reply, size_t size)
{
        char addr[SL_CIRCE_ADDRESS_SIZE];

        return sl_circe_alert(s->c, k->link, upper_address(k->a->pos[2], addr), reply, size);
}

static int run_network_setup(struct slctl *s, const struct circe_call *k, char *reply,
                             size_t size)
{
        char addr[SL_CIRCE_ADDRESS_SIZE];

        return sl_circe_network_setup(s->c, k->link, upper_address(k->a->pos[2], addr),
                                      k->a->given[C_JOIN], num_int(k, C_ROLES), reply, size);
}

static int run_device_setup(struct slctl *s, const struct circe_call *k, char *reply,
                            size_t size)
{
        char assign[SL_CIRCE_ADDRESS_SIZE], dest[SL_CIRCE_ADDRESS_SIZE];
        const struct args *a = k->a;

        return sl_circe_device_setup(s->c, k->link, upper_address(a->value[C_ASSIGN], assign),
                                     a->given[C_DEST],
                                     a->given[C_DEST] ? upper_address(a->value[C_DEST], dest) :
                                     NULL, a->given[C_CAPS], num_int(k, C_CAPS), reply, size);
}

/* Prints "ADDR succeeded|timed-out" as results come. */
static int print_sync(const char *addr, int succeeded, void *arg)
{
        (void)arg;
        printf("%s %s\n", addr, succeeded ? "succeeded" : "timed-out");
        fflush(stdout);
        return 0;
}

static int run_sync_clocks(struct slctl *s, const struct circe_call *k, char *reply, size_t size)
{
        return sl_circe_sync_clocks(s->c, k->link, print_sync, NULL, reply, size);
}

static int run_visualize(struct slctl *s, const struct circe_call *k, char *reply, size_t size)
{
        const struct args *a = k->a;
        struct sl_circe_visualize v = {
                .size = sizeof(v),
                .has_current = a->given[C_CURRENT], .current = num_int(k, C_CURRENT),
                .has_next = a->given[C_NEXT], .next = num_int(k, C_NEXT),
                .start_timer = a->given[C_START],
                .has_primary = a->given[C_PRIMARY], .primary_ms = k->num[C_PRIMARY],
                .has_secondary = a->given[C_SECONDARY], .secondary_ms = k->num[C_SECONDARY],
                .has_faults = a->given[C_FAULTS], .faults = num_int(k, C_FAULTS),
                .has_refusals = a->given[C_REFUSALS], .refusals = num_int(k, C_REFUSALS),
                .has_eliminated = a->given[C_ELIMINATED], .eliminated = num_int(k, C_ELIMINATED),
                .has_placement = a->given[C_PLACEMENT], .placement = num_int(k, C_PLACEMENT),
        };
        /* As many entries as the list can have: a request line holds fewer than that. */
        const char *dests[SL_REQUEST_LINE_MAX / 2 + 1];
        char store[SL_REQUEST_LINE_MAX + 1];
        unsigned n = 0;

        snprintf(store, sizeof(store), "%s", a->pos[2]);
        for (char *p = store, *comma;; p = comma + 1) {
                comma = strchr(p, ',');
                if (comma)
                        *comma = '\0';
                /* In place: an address of six digits keeps its length in upper case. */
                dests[n++] = upper_address(p, p);
                if (!comma || n == sizeof(dests) / sizeof(dests[0]))
                        break;
        }
        v.dests = dests;
        v.dest_count = n;
        return sl_circe_visualize(s->c, k->link, &v, reply, size);
}

static int run_emulate(struct slctl *s, const struct circe_call *k, char *reply, size_t size)
{
        char addr[SL_CIRCE_ADDRESS_SIZE];

        return sl_circe_emulate_action(s->c, k->link, upper_address(k->a->pos[3], addr),
                                       k->a->given[C_KEYS], num_int(k, C_KEYS),
                                       k->a->given[C_SENSOR_TIME], k->num[C_SENSOR_TIME], reply,
                                       size);
}

static const struct circe_op circe_ops[] = {
        { "alert", 1, 0, 0, run_alert },
        { "network-setup", 1, BIT(C_JOIN) | BIT(C_LEAVE) | BIT(C_ROLES), BIT(C_ROLES),
          run_network_setup },
        { "device-setup", 0, BIT(C_ASSIGN) | BIT(C_DEST) | BIT(C_CAPS), BIT(C_ASSIGN),
          run_device_setup },
        { "sync-clocks", 0, 0, 0, run_sync_clocks },
        { "visualize", 1, VISUALIZE_OPTS, 0, run_visualize },
        { "emulate", 2, BIT(C_KEYS) | BIT(C_SENSOR_TIME), 0, run_emulate },
};

/* Checks the command line of op. Returns -1, or an exit code after a message. */
static int circe_check(struct slctl *s, const struct circe_op *op, struct circe_call *k)
{
        const struct args *a = k->a;

        if (a->npos != 2 + op->npos)
                return slctl_usage(s, "%s: %s arguments", op->name,
                                   a->npos < 2 + op->npos ? "missing" : "too many");
        for (int o = 0; o < C_COUNT; o++) {
                if (a->given[o] && o != C_WAIT && !(op->opts & BIT(o)))
                        return slctl_usage(s, "%s does not take --%s", op->name,
                                           circe_opts[o].name);
                if (!a->given[o] && (op->needs & BIT(o)))
                        return slctl_usage(s, "%s needs --%s", op->name, circe_opts[o].name);
        }
        if ((op->opts & BIT(C_JOIN)) && a->given[C_JOIN] == a->given[C_LEAVE])
                return slctl_usage(s, "%s needs one of --join and --leave", op->name);
        if (op->run == run_emulate && strcmp(a->pos[2], "action") != 0)
                return slctl_usage(s, "emulate knows one thing: emulate action ADDR");
        for (int o = 0; o < C_COUNT; o++) {
                int code;

                if (!a->given[o] || !(NUMBER_OPTS & BIT(o)))
                        continue;
                code = number_option(s, circe_opts[o].name, a->value[o], &k->num[o]);
                if (code >= 0)
                        return code;
        }
        return -1;
}

int cmd_daemon_circe(struct slctl *s, int argc, char **argv)
{
        const struct circe_op *op = NULL;
        struct circe_call k = { 0 };
        char reply[REPLY_SIZE];
        struct args a;
        int code, r;

        code = slctl_args(s, argc, argv, circe_opts, &a);
        if (code >= 0)
                return code;
        if (a.npos < 2)
                return slctl_usage(s, "give LINK and an operation (alert, network-setup, "
                                   "device-setup, sync-clocks, visualize, emulate)");
        for (size_t i = 0; i < sizeof(circe_ops) / sizeof(circe_ops[0]); i++)
                if (strcmp(circe_ops[i].name, a.pos[1]) == 0)
                        op = &circe_ops[i];
        if (!op)
                return slctl_usage(s, "unknown operation \"%s\" (alert, network-setup, "
                                   "device-setup, sync-clocks, visualize, emulate)", a.pos[1]);
        k.link = a.pos[0];
        k.a = &a;
        code = circe_check(s, op, &k);
        if (code >= 0)
                return code;
        code = slctl_open(s, 0);
        if (code >= 0)
                return code;
        code = apply_wait(s, a.value[C_WAIT]);
        if (code >= 0)
                return code;
        reply[0] = '\0';
        r = op->run(s, &k, reply, sizeof(reply));
        return command_result(r, reply);
}
