/*
 * sharedlink-agility's class file (agilityd_config.h), read with the toolkit's key tables: one
 * table per mapping, a handler for the address lists and the bind address, a check where keys
 * depend on each other (the gates, the class), and a last check over the whole file (roles
 * that collide).
 */
#include "agility/agilityd_config.h"

#include <arpa/inet.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sharedlink.h>

#include "svc/conf.h"
#include "svc/io.h"

#define ADDRESS_DIGITS          6
#define ADDRESS_MAX             0xFFFFFEu       /* FFFFFF is the broadcast address */
#define PORT_MAX                65535u
#define COURSE_TIME_MAX         (AGILITY_DISPLAY_TIME_MAX)      /* what a display can show */
#define MIN_DELAY_MAX           60000u

_Static_assert(sizeof(unsigned) == sizeof(uint32_t), "CONF_UINT fields");

#define CFG                     struct agilityd_config

void agilityd_address_format(uint32_t addr, char *buf)
{
        snprintf(buf, SL_CIRCE_ADDRESS_SIZE, "%06X", (unsigned)(addr & 0xFFFFFFu));
}

int agilityd_address_parse(const char *s, uint32_t *ret)
{
        uint32_t v = 0;

        if (strlen(s) != ADDRESS_DIGITS)
                return -EINVAL;
        for (int i = 0; i < ADDRESS_DIGITS; i++) {
                char ch = s[i];
                unsigned d;

                if (ch >= '0' && ch <= '9')
                        d = (unsigned)(ch - '0');
                else if (ch >= 'A' && ch <= 'F')
                        d = (unsigned)(ch - 'A') + 10u;
                else if (ch >= 'a' && ch <= 'f')
                        d = (unsigned)(ch - 'a') + 10u;
                else
                        return -EINVAL;
                v = v << 4 | d;
        }
        if (v == 0 || v > ADDRESS_MAX)
                return -EINVAL;
        *ret = v;
        return 0;
}

/* ---- values with rules of their own ---------------------------------------------------------- */

static int get_address(struct conf *c, const char *key, const struct conf_node *n, uint32_t *ret)
{
        char s[ADDRESS_DIGITS + 2];
        int r = conf_need_scalar(c, key, n, "a device address");

        if (r < 0)
                return r;
        if (n->len != ADDRESS_DIGITS || conf_get_string(c, key, n, s, sizeof(s)) < 0 ||
            agilityd_address_parse(s, ret) < 0)
                return conf_fail(c, n, "%s: %s is not a device address (six hex digits, not "
                                 "000000 or FFFFFF)", key, conf_quote_node(c, n));
        return 0;
}

/* A list of addresses into out[cap], *count set; a repeated address is refused. */
static int get_addresses(struct conf *c, const char *key, const struct conf_node *n,
                         uint32_t *out, unsigned cap, unsigned *count)
{
        int r = conf_need_kind(c, key, n, CONF_NODE_SEQUENCE);

        if (r < 0)
                return r;
        *count = 0;
        for (const struct conf_node *item = conf_child(c, n->first); item;
             item = conf_next(c, item)) {
                if (*count >= cap)
                        return conf_fail(c, item, "%s: more than %u entries", key, cap);
                r = get_address(c, key, item, &out[*count]);
                if (r < 0)
                        return r;
                for (unsigned i = 0; i < *count; i++)
                        if (out[i] == out[*count])
                                return conf_fail(c, item, "%s: %s is listed twice", key,
                                                 conf_quote_node(c, item));
                (*count)++;
        }
        return 0;
}

static int parse_keypads(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                         void *obj)
{
        CFG *cfg = obj;

        return get_addresses(c, k->name, n, cfg->cls.keypads, AGILITY_KEYPADS_MAX,
                             &cfg->cls.keypad_count);
}

static int parse_displays(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                          void *obj)
{
        CFG *cfg = obj;

        return get_addresses(c, k->name, n, cfg->displays, AGILITYD_DISPLAYS_MAX,
                             &cfg->display_count);
}

/* Which gate keys the file wrote: the check of gates: needs to know. */
struct gates_seen {
        bool start, finish, start_finish, min_delay, intermediate;
        unsigned intermediates;
};

/* The gates mapping reads into the class; what it saw is kept beside the config while the
 * file is read (one read at a time per config object: this is its scratch). */
struct cfg_read {
        CFG cfg;
        struct gates_seen seen;
};

static int parse_gate(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                      void *obj)
{
        struct cfg_read *rd = obj;
        struct agility_class *cls = &rd->cfg.cls;

        if (strcmp(k->name, "start") == 0) {
                rd->seen.start = true;
                return get_address(c, k->name, n, &cls->start);
        }
        if (strcmp(k->name, "finish") == 0) {
                rd->seen.finish = true;
                return get_address(c, k->name, n, &cls->finish);
        }
        rd->seen.start_finish = true;
        cls->combined = true;
        return get_address(c, k->name, n, &cls->start);
}

static int parse_intermediate(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                              void *obj)
{
        struct cfg_read *rd = obj;

        rd->seen.intermediate = true;
        return get_addresses(c, k->name, n, rd->cfg.cls.intermediate, AGILITY_INTERMEDIATES_MAX,
                             &rd->seen.intermediates);
}

static int check_min_delay(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                           void *obj)
{
        (void)c;
        (void)k;
        (void)n;
        ((struct cfg_read *)obj)->seen.min_delay = true;
        return 0;
}

static int check_gates(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                       void *obj)
{
        struct cfg_read *rd = obj;
        const struct gates_seen *s = &rd->seen;

        (void)k;
        if (s->start_finish && (s->start || s->finish))
                return conf_fail(c, n, "gates: start_finish (one combined gate) excludes start "
                                 "and finish");
        if (!s->start_finish && s->min_delay)
                return conf_fail(c, n, "gates: min_delay_ms is for a combined start_finish gate");
        if (!s->start_finish && (!s->start || !s->finish))
                return conf_fail(c, n, "gates: needs start and finish, or start_finish");
        return 0;
}

static int check_class(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                       void *obj)
{
        const struct agility_class *cls = &((CFG *)obj)->cls;

        (void)k;
        if (!((CFG *)obj)->class_name[0])
                return conf_fail(c, n, "class: needs a name");
        if (cls->max_course_time_ms && cls->max_course_time_ms < cls->standard_course_time_ms)
                return conf_fail(c, n, "class: max_course_time_ms (%u) is less than "
                                 "standard_course_time_ms (%u)", cls->max_course_time_ms,
                                 cls->standard_course_time_ms);
        return 0;
}

/* "host:port", "[v6]:port" or ":port"; the host a numeric address (no name lookup at start). */
static int parse_http(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                      void *obj)
{
        CFG *cfg = obj;
        char s[AGILITYD_HOST_MAX + 16], host[AGILITYD_HOST_MAX];
        unsigned char addr[sizeof(struct in6_addr)];
        const char *colon, *port;
        char *end;
        unsigned long p;
        size_t hl;
        int r = conf_get_string(c, k->name, n, s, sizeof(s));

        if (r < 0)
                return r;
        colon = strrchr(s, ':');
        if (!colon)
                return conf_fail(c, n, "http: %s: expected \"host:port\"", conf_quote_node(c, n));
        port = colon + 1;
        hl = (size_t)(colon - s);
        if (hl >= 2 && s[0] == '[' && s[hl - 1] == ']') {
                memcpy(host, s + 1, hl - 2);
                host[hl - 2] = '\0';
        } else {
                memcpy(host, s, hl);
                host[hl] = '\0';
        }
        errno = 0;
        p = strtoul(port, &end, 10);
        if (!port[0] || *end || port[0] < '0' || port[0] > '9' || errno || p > PORT_MAX)
                return conf_fail(c, n, "http: %s: the port must be 0..%u (0: any free port)",
                                 conf_quote_node(c, n), PORT_MAX);
        if (!host[0])
                snprintf(host, sizeof(host), "%s", AGILITYD_HTTP_HOST_DEFAULT);
        if (inet_pton(AF_INET, host, addr) != 1 && inet_pton(AF_INET6, host, addr) != 1)
                return conf_fail(c, n, "http: %s: the host must be a numeric IPv4 or IPv6 "
                                 "address", conf_quote_node(c, n));
        snprintf(cfg->http_host, sizeof(cfg->http_host), "%s", host);
        cfg->http_port = (uint16_t)p;
        return 0;
}

/* ---- tables ---------------------------------------------------------------------------------- */

static const struct conf_key class_keys[] = {
        CONF_KEY_STRING("name", CFG, class_name),
        CONF_KEY_UINT("standard_course_time_ms", CFG, cls.standard_course_time_ms, 0,
                      COURSE_TIME_MAX),
        CONF_KEY_UINT("max_course_time_ms", CFG, cls.max_course_time_ms, 0, COURSE_TIME_MAX),
        CONF_KEY_UINT("intermediates", CFG, cls.intermediates, 0, AGILITY_INTERMEDIATES_MAX),
};

/* The gates' fields live in cfg.cls, at the start of struct cfg_read: the same offsets. */
static const struct conf_key gates_keys[] = {
        CONF_KEY_CUSTOM("start", parse_gate),
        CONF_KEY_CUSTOM("finish", parse_gate),
        CONF_KEY_CUSTOM("start_finish", parse_gate),
        CONF_KEY_CUSTOM("intermediate", parse_intermediate),
        { .name = "min_delay_ms", .type = CONF_UINT, CONF_FIELD(CFG, cls.min_delay_ms),
          .min = 0, .max = MIN_DELAY_MAX, .check = check_min_delay },
};

static const struct conf_key root_keys[] = {
        CONF_KEY_STRING("instance", CFG, instance),
        CONF_KEY_STRING("link", CFG, link),
        CONF_KEY_MAPPING("class", class_keys, check_class),
        CONF_KEY_MAPPING("gates", gates_keys, check_gates),
        CONF_KEY_CUSTOM("keypads", parse_keypads),
        CONF_KEY_CUSTOM("displays", parse_displays),
        CONF_KEY_PATH("competitors", CFG, competitors_path),
        CONF_KEY_PATH("database", CFG, database),
        CONF_KEY_CUSTOM("http", parse_http),
};

/* What no single mapping can see: required keys, gates against the class, roles that collide. */
static int check_file(struct conf *c, const struct conf_node *root, struct cfg_read *rd)
{
        CFG *cfg = &rd->cfg;
        const struct agility_class *cls = &cfg->cls;
        char a[SL_CIRCE_ADDRESS_SIZE];
        static const char *const required[] = { "link", "class", "gates", "competitors",
                                                "database" };
        const char *const have[] = { cfg->link, cfg->class_name,
                                     cls->start ? "gates" : "", cfg->competitors_path,
                                     cfg->database };

        for (size_t i = 0; i < sizeof(required) / sizeof(required[0]); i++)
                if (!have[i][0])
                        return conf_fail(c, root, "%s: missing (see sharedlink-agility(8))",
                                         required[i]);
        if (rd->seen.intermediates != cls->intermediates)
                return conf_fail(c, root, "gates: intermediate lists %u gates, class: "
                                 "intermediates is %u", rd->seen.intermediates,
                                 cls->intermediates);
        if (cls->combined && !rd->seen.min_delay)
                cfg->cls.min_delay_ms = AGILITY_MIN_DELAY_DEFAULT_MS;
        /* A device is one gate at most; a keypad may also be a gate (a hand-held start), a
         * display is nothing else. */
        {
                uint32_t gates[AGILITY_GATES_MAX];
                unsigned n = 0;

                gates[n++] = cls->start;
                if (!cls->combined)
                        gates[n++] = cls->finish;
                for (unsigned i = 0; i < cls->intermediates; i++)
                        gates[n++] = cls->intermediate[i];
                for (unsigned i = 0; i < n; i++) {
                        for (unsigned j = 0; j < i; j++)
                                if (gates[i] == gates[j]) {
                                        agilityd_address_format(gates[i], a);
                                        return conf_fail(c, root, "gates: %s is two gates", a);
                                }
                        for (unsigned j = 0; j < cfg->display_count; j++)
                                if (gates[i] == cfg->displays[j]) {
                                        agilityd_address_format(gates[i], a);
                                        return conf_fail(c, root, "displays: %s is a gate", a);
                                }
                }
                for (unsigned i = 0; i < cls->keypad_count; i++)
                        for (unsigned j = 0; j < cfg->display_count; j++)
                                if (cls->keypads[i] == cfg->displays[j]) {
                                        agilityd_address_format(cls->keypads[i], a);
                                        return conf_fail(c, root, "displays: %s is a keypad",
                                                         a);
                                }
        }
        return 0;
}

static void defaults(CFG *cfg)
{
        memset(cfg, 0, sizeof(*cfg));
        snprintf(cfg->http_host, sizeof(cfg->http_host), "%s", AGILITYD_HTTP_HOST_DEFAULT);
        cfg->http_port = AGILITYD_HTTP_PORT_DEFAULT;
}

int agilityd_config_parse(const char *name, const char *text, size_t len,
                          struct agilityd_config *ret, char *err, size_t err_size)
{
        struct conf *c = malloc(sizeof(*c));
        struct cfg_read *rd = malloc(sizeof(*rd));
        const struct conf_node *root;
        uint32_t root_index = CONF_NONE;
        int r;

        if (err_size)
                err[0] = '\0';
        if (!c || !rd) {
                snprintf(err, err_size, "%s: out of memory", name);
                free(c);
                free(rd);
                return -ENOMEM;
        }
        memset(&rd->seen, 0, sizeof(rd->seen));
        defaults(&rd->cfg);
        r = conf_init(c, name, text, len, AGILITYD_FILE_MAX);
        if (r == 0)
                r = conf_tree_build(c, &root_index);
        root = r == 0 ? conf_child(c, root_index) : NULL;
        if (r == 0 && (!root || conf_is_null(root)))
                r = conf_fail_at(c, 0, 0, "empty file: link, class, gates, competitors and "
                                 "database are needed");
        if (r == 0)
                r = conf_table_read(c, root, "configuration", "at top level", root_keys,
                                    sizeof(root_keys) / sizeof(root_keys[0]), rd);
        if (r == 0)
                r = check_file(c, root, rd);
        if (r == 0)
                *ret = rd->cfg;
        else
                snprintf(err, err_size, "%s", c->err.message);
        conf_free(c);
        free(c);
        free(rd);
        return r;
}

int agilityd_config_load(const char *path, struct agilityd_config *ret, char *err,
                         size_t err_size)
{
        char *text;
        size_t len;
        int r = io_read_file(path, AGILITYD_FILE_MAX, &text, &len);

        if (r < 0) {
                snprintf(err, err_size, "%s: %s", path,
                         r == -EFBIG ? "file too large" : strerror(-r));
                return r;
        }
        r = agilityd_config_parse(path, text, len, ret, err, err_size);
        free(text);
        if (r < 0)
                return r;
        r = io_read_file(ret->competitors_path, AGILITYD_CSV_MAX, &text, &len);
        if (r < 0) {
                snprintf(err, err_size, "%s: %s", ret->competitors_path,
                         r == -EFBIG ? "file too large" : strerror(-r));
                return r;
        }
        r = agility_competitors_parse(ret->competitors_path, text, len, ret->competitors,
                                      AGILITY_COMPETITORS_MAX, &ret->competitor_count, err,
                                      err_size);
        free(text);
        return r;
}
