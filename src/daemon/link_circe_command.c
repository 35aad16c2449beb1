/*
 * CIRCE control commands (link_circe_command.h).
 */
#include "daemon/link_circe_command.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#define NUMBER_DIGITS_MAX       9u      /* every CIRCE number fits (999999 is the largest) */
#define MAX_ROLES               127u
#define MAX_CAPABILITIES        127u
#define MAX_COMPETITOR          999u
#define MAX_TIME_MS             999999u
#define MAX_COUNT               99u
#define MAX_PLACEMENT           999u
#define MAX_KEYS                65535u

static int fail(char *err, size_t errsz, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

static int fail(char *err, size_t errsz, const char *fmt, ...)
{
        va_list ap;

        if (errsz) {
                va_start(ap, fmt);
                vsnprintf(err, errsz, fmt, ap);
                va_end(ap);
        }
        return -EINVAL;
}

/* Decimal digits only, at most max; 0 or -EINVAL. */
static int parse_number(const char *s, unsigned long max, unsigned long *ret)
{
        unsigned long v = 0;
        size_t n = strlen(s);

        if (n == 0 || n > NUMBER_DIGITS_MAX)
                return -EINVAL;
        for (size_t i = 0; i < n; i++) {
                if (s[i] < '0' || s[i] > '9')
                        return -EINVAL;
                v = v * 10 + (unsigned long)(s[i] - '0');
        }
        if (v > max)
                return -EINVAL;
        *ret = v;
        return 0;
}

static int number_arg(const char *what, const char *s, unsigned long max, unsigned long *ret,
                      char *err, size_t errsz)
{
        if (parse_number(s, max, ret) < 0)
                return fail(err, errsz, "bad %s \"%s\": a decimal number 0..%lu expected", what, s,
                            max);
        return 0;
}

/* Six hex digits (either case), not FFFFFF. */
static int address_arg(const char *what, const char *s, size_t len, uint32_t *ret, char *err,
                       size_t errsz)
{
        char up[CIRCE_ADDRESS_LEN + 1];

        if (len == CIRCE_ADDRESS_LEN) {
                for (size_t i = 0; i < len; i++)
                        up[i] = (s[i] >= 'a' && s[i] <= 'f') ? (char)(s[i] - 'a' + 'A') : s[i];
                up[len] = '\0';
                if (circe_address_parse(up, len, ret) == 0)
                        return 0;
        }
        return fail(err, errsz, "bad %s \"%.*s\": six hex digits expected (FFFFFF is reserved)",
                    what, (int)(len > 16 ? 16 : len), s);
}

const char *link_circe_command_name(enum link_circe_cmd_kind kind)
{
        switch (kind) {
        case LINK_CIRCE_CMD_ALERT:
                return "alert";
        case LINK_CIRCE_CMD_NETWORK_SETUP:
                return "network-setup";
        case LINK_CIRCE_CMD_DEVICE_SETUP:
                return "device-setup";
        case LINK_CIRCE_CMD_SYNC_CLOCKS:
                return "sync-clocks";
        case LINK_CIRCE_CMD_VISUALIZE:
                return "visualize";
        case LINK_CIRCE_CMD_EMULATE_ACTION:
                return "emulate action";
        }
        return "?";
}

bool link_circe_command_for_controller(enum link_circe_cmd_kind kind)
{
        return kind != LINK_CIRCE_CMD_EMULATE_ACTION;
}

static int expect_args(const char *op, int got, int min, int max, const char *usage, char *err,
                       size_t errsz)
{
        if (got < min || got > max)
                return fail(err, errsz, "%s: %s arguments; usage: %s",  op,
                            got < min ? "missing" : "too many", usage);
        return 0;
}

static int parse_alert(char *const *a, int n, struct link_circe_cmd *c, char *err, size_t errsz)
{
        int r = expect_args("alert", n, 1, 1, "alert ADDR", err, errsz);

        if (r < 0)
                return r;
        c->msg.op = CIRCE_OP_ALERT;
        return address_arg("address", a[0], strlen(a[0]), &c->msg.u.alert.dest, err, errsz);
}

static int parse_network_setup(char *const *a, int n, struct link_circe_cmd *c, char *err,
                               size_t errsz)
{
        struct circe_network_setup *s = &c->msg.u.network_setup;
        unsigned long roles;
        int r = expect_args("network-setup", n, 3, 3, "network-setup ADDR join|leave ROLES", err,
                            errsz);

        if (r < 0)
                return r;
        c->msg.op = CIRCE_OP_NETWORK_SETUP;
        r = address_arg("address", a[0], strlen(a[0]), &s->dest, err, errsz);
        if (r < 0)
                return r;
        if (strcmp(a[1], "join") == 0)
                s->set_membership = true;
        else if (strcmp(a[1], "leave") == 0)
                s->set_membership = false;
        else
                return fail(err, errsz, "bad membership \"%s\": join or leave expected", a[1]);
        r = number_arg("roles", a[2], MAX_ROLES, &roles, err, errsz);
        s->roles = (uint8_t)roles;
        return r;
}

static int parse_device_setup(char *const *a, int n, struct link_circe_cmd *c, char *err,
                              size_t errsz)
{
        struct circe_device_setup *s = &c->msg.u.device_setup;
        unsigned long caps;
        int r = expect_args("device-setup", n, 1, 3,
                            "device-setup ASSIGN [DEST|-] [CAPABILITIES|-]", err, errsz);

        if (r < 0)
                return r;
        c->msg.op = CIRCE_OP_DEVICE_SETUP;
        r = address_arg("address to assign", a[0], strlen(a[0]), &s->assign, err, errsz);
        if (r < 0)
                return r;
        if (n >= 2 && strcmp(a[1], "-") != 0) {
                r = address_arg("destination", a[1], strlen(a[1]), &s->dest, err, errsz);
                if (r < 0)
                        return r;
                s->has_dest = true;
        }
        if (n >= 3 && strcmp(a[2], "-") != 0) {
                r = number_arg("capabilities", a[2], MAX_CAPABILITIES, &caps, err, errsz);
                if (r < 0)
                        return r;
                s->has_capabilities = true;
                s->capabilities = (uint8_t)caps;
        }
        return 0;
}

static int parse_destinations(const char *list, struct circe_visualize *v, char *err,
                              size_t errsz)
{
        const char *p = list;

        for (;;) {
                const char *comma = strchr(p, ',');
                size_t len = comma ? (size_t)(comma - p) : strlen(p);
                int r;

                if (v->dest_count >= CIRCE_VISUALIZE_DEST_MAX)
                        return fail(err, errsz, "visualize: more than %u destinations",
                                    CIRCE_VISUALIZE_DEST_MAX);
                r = address_arg("destination", p, len, &v->dests[v->dest_count], err, errsz);
                if (r < 0)
                        return r;
                v->dest_count++;
                if (!comma)
                        return 0;
                p = comma + 1;
        }
}

/* The display fields of visualize, as KEY=VALUE words. */
enum vis_key {
        VK_CURRENT, VK_NEXT, VK_START, VK_PRIMARY, VK_SECONDARY, VK_FAULTS, VK_REFUSALS,
        VK_ELIMINATED, VK_PLACEMENT, VK_COUNT
};

static const struct {
        const char *name;               /* "current" for current=N */
        unsigned long max;
} vis_keys[VK_COUNT] = {
        [VK_CURRENT] = { "current", MAX_COMPETITOR },
        [VK_NEXT] = { "next", MAX_COMPETITOR },
        [VK_START] = { "start-timer", 0 },
        [VK_PRIMARY] = { "primary", MAX_TIME_MS },
        [VK_SECONDARY] = { "secondary", MAX_TIME_MS },
        [VK_FAULTS] = { "faults", MAX_COUNT },
        [VK_REFUSALS] = { "refusals", MAX_COUNT },
        [VK_ELIMINATED] = { "eliminated", 1 },
        [VK_PLACEMENT] = { "placement", MAX_PLACEMENT },
};

static void vis_set(struct circe_visualize *v, enum vis_key k, unsigned long x)
{
        switch (k) {
        case VK_CURRENT:
                v->has_current = true;
                v->current = (uint16_t)x;
                break;
        case VK_NEXT:
                v->has_next = true;
                v->next = (uint16_t)x;
                break;
        case VK_START:
                v->start_timer = true;
                break;
        case VK_PRIMARY:
                v->has_primary = true;
                v->primary_ms = (uint32_t)x;
                break;
        case VK_SECONDARY:
                v->has_secondary = true;
                v->secondary_ms = (uint32_t)x;
                break;
        case VK_FAULTS:
                v->has_faults = true;
                v->faults = (uint8_t)x;
                break;
        case VK_REFUSALS:
                v->has_refusals = true;
                v->refusals = (uint8_t)x;
                break;
        case VK_ELIMINATED:
                v->has_eliminated = true;
                v->eliminated = x != 0;
                break;
        case VK_PLACEMENT:
                v->has_placement = true;
                v->placement = (uint16_t)x;
                break;
        case VK_COUNT:
                break;
        }
}

static int parse_visualize(char *const *a, int n, struct link_circe_cmd *c, char *err,
                           size_t errsz)
{
        struct circe_visualize *v = &c->msg.u.visualize;
        bool seen[VK_COUNT] = { false };
        int given = 0, r;

        if (n < 1)
                return fail(err, errsz, "visualize: missing destination; usage: visualize "
                            "ADDR[,ADDR...] [current=N] [next=N] [start-timer] [primary=MS] ...");
        c->msg.op = CIRCE_OP_VISUALIZE;
        r = parse_destinations(a[0], v, err, errsz);
        if (r < 0)
                return r;
        for (int i = 1; i < n; i++) {
                const char *eq = strchr(a[i], '=');
                size_t klen = eq ? (size_t)(eq - a[i]) : strlen(a[i]);
                unsigned long x = 0;
                int k;

                for (k = 0; k < VK_COUNT; k++)
                        if (strlen(vis_keys[k].name) == klen &&
                            strncmp(vis_keys[k].name, a[i], klen) == 0)
                                break;
                if (k == VK_COUNT)
                        return fail(err, errsz, "visualize: unknown field \"%.*s\" (current, "
                                    "next, start-timer, primary, secondary, faults, refusals, "
                                    "eliminated, placement)", (int)(klen > 24 ? 24 : klen), a[i]);
                if (seen[k])
                        return fail(err, errsz, "visualize: %s given twice", vis_keys[k].name);
                if (k == VK_START) {
                        if (eq)
                                return fail(err, errsz, "visualize: start-timer takes no value");
                } else {
                        if (!eq)
                                return fail(err, errsz, "visualize: %s needs a value (%s=N)",
                                            vis_keys[k].name, vis_keys[k].name);
                        r = number_arg(vis_keys[k].name, eq + 1, vis_keys[k].max, &x, err,
                                       errsz);
                        if (r < 0)
                                return r;
                }
                seen[k] = true;
                vis_set(v, (enum vis_key)k, x);
                given++;
        }
        if (given == 0)
                return fail(err, errsz, "visualize: give at least one display field");
        return 0;
}

static int parse_action(char *const *a, int n, struct link_circe_cmd *c, char *err, size_t errsz)
{
        unsigned long x;
        int r;

        if (n < 2 || strcmp(a[0], "action") != 0)
                return fail(err, errsz, "usage: emulate action ADDR [keys=N] [sensor-time=MS]");
        c->keys = -1;
        c->sensor_time_ms = -1;
        r = address_arg("device", a[1], strlen(a[1]), &c->address, err, errsz);
        if (r < 0)
                return r;
        for (int i = 2; i < n; i++) {
                if (strncmp(a[i], "keys=", 5) == 0) {
                        if (c->keys >= 0)
                                return fail(err, errsz, "emulate action: keys given twice");
                        r = number_arg("keys", a[i] + 5, MAX_KEYS, &x, err, errsz);
                        if (r < 0)
                                return r;
                        c->keys = (long)x;
                } else if (strncmp(a[i], "sensor-time=", 12) == 0) {
                        if (c->sensor_time_ms >= 0)
                                return fail(err, errsz, "emulate action: sensor-time given twice");
                        r = number_arg("sensor-time", a[i] + 12, MAX_TIME_MS, &x, err, errsz);
                        if (r < 0)
                                return r;
                        c->sensor_time_ms = (long)x;
                } else {
                        return fail(err, errsz, "emulate action: unknown argument \"%.24s\" "
                                    "(keys=N, sensor-time=MS)", a[i]);
                }
        }
        return 0;
}

int link_circe_command_parse(int argc, char *const *argv, struct link_circe_cmd *ret, char *err,
                             size_t errsz)
{
        struct link_circe_cmd c;
        const char *op;
        int n, r;

        if (errsz)
                err[0] = '\0';
        if (argc < 3 || strcmp(argv[0], "circe") != 0)
                return fail(err, errsz, "usage: circe LINK OPERATION [ARGUMENTS...] [wait=MS]");
        memset(&c, 0, sizeof(c));
        c.keys = -1;
        c.sensor_time_ms = -1;
        op = argv[2];
        n = argc - 3;
        if (strcmp(op, "alert") == 0) {
                c.kind = LINK_CIRCE_CMD_ALERT;
                r = parse_alert(argv + 3, n, &c, err, errsz);
        } else if (strcmp(op, "network-setup") == 0) {
                c.kind = LINK_CIRCE_CMD_NETWORK_SETUP;
                r = parse_network_setup(argv + 3, n, &c, err, errsz);
        } else if (strcmp(op, "device-setup") == 0) {
                c.kind = LINK_CIRCE_CMD_DEVICE_SETUP;
                r = parse_device_setup(argv + 3, n, &c, err, errsz);
        } else if (strcmp(op, "sync-clocks") == 0) {
                c.kind = LINK_CIRCE_CMD_SYNC_CLOCKS;
                c.msg.op = CIRCE_OP_SYNC_CLOCKS;
                r = expect_args("sync-clocks", n, 0, 0, "sync-clocks", err, errsz);
        } else if (strcmp(op, "visualize") == 0) {
                c.kind = LINK_CIRCE_CMD_VISUALIZE;
                r = parse_visualize(argv + 3, n, &c, err, errsz);
        } else if (strcmp(op, "emulate") == 0) {
                c.kind = LINK_CIRCE_CMD_EMULATE_ACTION;
                r = parse_action(argv + 3, n, &c, err, errsz);
        } else {
                return fail(err, errsz, "unknown CIRCE operation \"%.32s\" (alert, network-setup, "
                            "device-setup, sync-clocks, visualize, emulate)", op);
        }
        if (r < 0)
                return r;
        *ret = c;
        return 0;
}
