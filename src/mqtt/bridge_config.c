/*
 * sharedlink-mqtt configuration parser (see bridge_config.h and conf/sharedlink-mqtt.yaml).
 *
 * The same decisions as sharedlinkd's parser, so that one file style serves both programs:
 * numbers and booleans are plain scalars (decimal digits, no leading zeros; true/false only),
 * a plain empty value, "~" or "null" is a missing value, never a default; anchors, aliases,
 * tags and a second document are refused; strings may not hold control characters. The schema is
 * small and flat, so it is read straight from libyaml's events (no tree): each mapping is a
 * table of keys, each key seen at most once.
 */
#include "mqtt/bridge_config.h"

#include <errno.h>
#include <fcntl.h>
#include <fnmatch.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml.h>

#define QUOTE_MAX               40u     /* bytes of user text echoed in a message */
#define QUOTE_BUF               (QUOTE_MAX * 4u + 8u)
#define KEYS_MAX                32u     /* keys of one mapping (a bitmask of those seen) */
#define PORT_MAX                65535u
#define KEEPALIVE_MIN           5u      /* seconds; libmosquitto refuses less */
#define KEEPALIVE_MAX           65535u
#define NUMBER_ECHO_MAX         24u     /* digits of an out-of-range number echoed */
#define QOS_MAX                 2u
#define PASSWORD_FILE_MAX       4096u   /* bytes read from password_file */

struct pctx {
        yaml_parser_t parser;
        yaml_event_t ev;
        int have_ev;
        const char *name;
        const char *text;
        size_t len;
        char *err;
        size_t err_size;
        char quote[QUOTE_BUF];
};

struct key {
        const char *name;
        int (*parse)(struct pctx *c, struct bridge_config *cfg);   /* value event in c->ev */
};

static int fail_at(struct pctx *c, const yaml_mark_t *m, const char *fmt, ...)
        __attribute__((format(printf, 3, 4)));

static int fail_at(struct pctx *c, const yaml_mark_t *m, const char *fmt, ...)
{
        va_list ap;
        size_t n = 0;
        int k;

        if (c->err_size == 0 || c->err[0])
                return -EINVAL;         /* the first error wins */
        if (m)
                k = snprintf(c->err, c->err_size, "%s:%zu:%zu: ", c->name, m->line + 1,
                             m->column + 1);
        else
                k = snprintf(c->err, c->err_size, "%s: ", c->name);
        if (k > 0)
                n = (size_t)k < c->err_size ? (size_t)k : c->err_size - 1;
        va_start(ap, fmt);
        vsnprintf(c->err + n, c->err_size - n, fmt, ap);
        va_end(ap);
        return -EINVAL;
}

/* User text: quoted, at most QUOTE_MAX bytes, everything but printable ASCII escaped. */
static const char *quote(struct pctx *c, const char *s, size_t len)
{
        size_t o = 0;

        c->quote[o++] = '"';
        for (size_t i = 0; i < len && i < QUOTE_MAX; i++) {
                unsigned char ch = (unsigned char)s[i];

                if (ch == '"' || ch == '\\') {
                        c->quote[o++] = '\\';
                        c->quote[o++] = (char)ch;
                } else if (ch < 0x20 || ch >= 0x7f) {
                        o += (size_t)snprintf(c->quote + o, QUOTE_BUF - o, "\\x%02X", ch);
                } else {
                        c->quote[o++] = (char)ch;
                }
        }
        c->quote[o++] = '"';
        if (len > QUOTE_MAX) {
                memcpy(c->quote + o, "...", 3);
                o += 3;
        }
        c->quote[o] = '\0';
        return c->quote;
}

/* Reader errors carry a byte offset, not a mark: count lines and UTF-8 characters up to it. */
static yaml_mark_t offset_mark(const struct pctx *c, size_t offset)
{
        yaml_mark_t m = { 0 };

        for (size_t i = 0; i < offset && i < c->len; i++) {
                unsigned char ch = (unsigned char)c->text[i];

                if (ch == '\n') {
                        m.line++;
                        m.column = 0;
                } else if ((ch & 0xC0) != 0x80 && ch != '\r') {
                        m.column++;
                }
        }
        return m;
}

static int yaml_failure(struct pctx *c)
{
        const yaml_parser_t *p = &c->parser;
        const char *problem = p->problem ? p->problem : "syntax error";
        yaml_mark_t m;

        if (p->error == YAML_MEMORY_ERROR) {
                fail_at(c, NULL, "out of memory");
                return -ENOMEM;
        }
        if (p->error == YAML_READER_ERROR) {
                m = offset_mark(c, p->problem_offset);
                return fail_at(c, &m, "%s", problem);
        }
        if (p->context)
                return fail_at(c, &p->problem_mark, "%s (%s)", problem, p->context);
        return fail_at(c, &p->problem_mark, "%s", problem);
}

/* The next event into c->ev; anchors, aliases and tags are refused here, once for all. */
static int next(struct pctx *c)
{
        const yaml_char_t *anchor = NULL, *tag = NULL;

        if (c->have_ev)
                yaml_event_delete(&c->ev);
        c->have_ev = 0;
        if (!yaml_parser_parse(&c->parser, &c->ev))
                return yaml_failure(c);
        c->have_ev = 1;
        switch (c->ev.type) {
        case YAML_ALIAS_EVENT:
                return fail_at(c, &c->ev.start_mark, "anchors and aliases are not supported");
        case YAML_SCALAR_EVENT:
                anchor = c->ev.data.scalar.anchor;
                tag = c->ev.data.scalar.tag;
                break;
        case YAML_SEQUENCE_START_EVENT:
                anchor = c->ev.data.sequence_start.anchor;
                tag = c->ev.data.sequence_start.tag;
                break;
        case YAML_MAPPING_START_EVENT:
                anchor = c->ev.data.mapping_start.anchor;
                tag = c->ev.data.mapping_start.tag;
                break;
        default:
                break;
        }
        if (anchor)
                return fail_at(c, &c->ev.start_mark, "anchors and aliases are not supported");
        if (tag)
                return fail_at(c, &c->ev.start_mark, "tags are not supported");
        return 0;
}

static int is_scalar(const struct pctx *c)
{
        return c->ev.type == YAML_SCALAR_EVENT;
}

static int is_plain(const struct pctx *c)
{
        return is_scalar(c) && c->ev.data.scalar.style == YAML_PLAIN_SCALAR_STYLE;
}

static const char *scalar(const struct pctx *c)
{
        return (const char *)c->ev.data.scalar.value;
}

static int is_null(const struct pctx *c)
{
        const char *s = scalar(c);

        return is_plain(c) && (!*s || !strcmp(s, "~") || !strcmp(s, "null") ||
                               !strcmp(s, "Null") || !strcmp(s, "NULL"));
}

static const char *describe(struct pctx *c)
{
        if (c->ev.type == YAML_SEQUENCE_START_EVENT)
                return "a list";
        if (c->ev.type == YAML_MAPPING_START_EVENT)
                return "a mapping";
        return quote(c, scalar(c), c->ev.data.scalar.length);
}

static int need_scalar(struct pctx *c, const char *what, const char *kind)
{
        if (is_scalar(c) && is_null(c))
                return fail_at(c, &c->ev.start_mark, "%s: missing value", what);
        if (!is_scalar(c))
                return fail_at(c, &c->ev.start_mark, "%s: expected %s, got %s", what, kind,
                               describe(c));
        return 0;
}

/* A string of printable characters (UTF-8 allowed), shorter than size; min_len 1 refuses "". */
static int get_string(struct pctx *c, const char *what, char *buf, size_t size)
{
        const char *s;
        size_t len;
        int r = need_scalar(c, what, "a string");

        if (r < 0)
                return r;
        s = scalar(c);
        len = c->ev.data.scalar.length;
        for (size_t i = 0; i < len; i++)
                if ((unsigned char)s[i] < 0x20 || s[i] == 0x7f)
                        return fail_at(c, &c->ev.start_mark, "%s: control character in %s",
                                       what, quote(c, s, len));
        if (len == 0)
                return fail_at(c, &c->ev.start_mark, "%s: must not be empty", what);
        if (len >= size)
                return fail_at(c, &c->ev.start_mark, "%s: longer than %zu bytes", what,
                               size - 1);
        memcpy(buf, s, len + 1);
        return 0;
}

static int get_uint(struct pctx *c, const char *what, unsigned min, unsigned max,
                    unsigned *ret)
{
        const char *s;
        size_t len;
        uint64_t v = 0;
        int r = need_scalar(c, what, "a number");

        if (r < 0)
                return r;
        s = scalar(c);
        len = c->ev.data.scalar.length;
        if (!is_plain(c) || len == 0)
                return fail_at(c, &c->ev.start_mark, "%s: expected a number, got %s", what,
                               describe(c));
        for (size_t i = 0; i < len; i++) {
                if (s[i] < '0' || s[i] > '9')
                        return fail_at(c, &c->ev.start_mark, "%s: expected a number, got %s",
                                       what, describe(c));
                if (v <= UINT32_MAX)
                        v = v * 10u + (uint64_t)(s[i] - '0');
        }
        if (len > 1 && s[0] == '0')
                return fail_at(c, &c->ev.start_mark, "%s: leading zeros are not allowed in %s",
                               what, describe(c));
        if (v < min || v > max)         /* only digits get here: echoed as written */
                return fail_at(c, &c->ev.start_mark, "%s: %.*s%s out of range %u..%u", what,
                               (int)(len > NUMBER_ECHO_MAX ? NUMBER_ECHO_MAX : len), s,
                               len > NUMBER_ECHO_MAX ? "..." : "", min, max);
        *ret = (unsigned)v;
        return 0;
}

static int get_int(struct pctx *c, const char *what, unsigned min, unsigned max, int *ret)
{
        unsigned v;
        int r = get_uint(c, what, min, max, &v);

        if (r == 0)
                *ret = (int)v;
        return r;
}

static int get_bool(struct pctx *c, const char *what, bool *ret)
{
        static const char *const yes[] = { "true", "True", "TRUE" };
        static const char *const no[] = { "false", "False", "FALSE" };
        int r = need_scalar(c, what, "true or false");

        if (r < 0)
                return r;
        for (size_t i = 0; i < 3 && is_plain(c); i++) {
                if (!strcmp(scalar(c), yes[i])) {
                        *ret = true;
                        return 0;
                }
                if (!strcmp(scalar(c), no[i])) {
                        *ret = false;
                        return 0;
                }
        }
        return fail_at(c, &c->ev.start_mark, "%s: expected true or false, got %s", what,
                       describe(c));
}

/* A list of name globs; an MQTT wildcard or a control character in one is refused. */
static int get_globs(struct pctx *c, const char *what, struct bridge_globs *g)
{
        int r;

        if (c->ev.type != YAML_SEQUENCE_START_EVENT)
                return fail_at(c, &c->ev.start_mark, "%s: expected a list, got %s", what,
                               describe(c));
        g->count = 0;
        for (;;) {
                if ((r = next(c)) < 0)
                        return r;
                if (c->ev.type == YAML_SEQUENCE_END_EVENT)
                        return 0;
                if (g->count >= BRIDGE_GLOBS_MAX)
                        return fail_at(c, &c->ev.start_mark, "%s: more than %u entries", what,
                                       BRIDGE_GLOBS_MAX);
                r = get_string(c, what, g->glob[g->count], sizeof(g->glob[0]));
                if (r < 0)
                        return r;
                if (strpbrk(g->glob[g->count], "+#/"))
                        return fail_at(c, &c->ev.start_mark, "%s: %s: '+', '#' and '/' are not "
                                       "allowed (globs match variable names: * ? [...])", what,
                                       quote(c, scalar(c), c->ev.data.scalar.length));
                g->count++;
        }
}

/* A topic level or prefix: non-empty levels without MQTT wildcards, no leading '$' or '/'. */
static int check_topic_part(struct pctx *c, const char *what, const char *s)
{
        size_t len = strlen(s);

        if (strpbrk(s, "+#"))
                return fail_at(c, &c->ev.start_mark, "%s: %s: MQTT wildcards '+' and '#' are "
                               "not allowed in a topic", what, quote(c, s, len));
        if (s[0] == '$')
                return fail_at(c, &c->ev.start_mark, "%s: %s: topics starting with '$' are "
                               "reserved to the broker", what, quote(c, s, len));
        if (s[0] == '/' || s[len - 1] == '/' || strstr(s, "//"))
                return fail_at(c, &c->ev.start_mark, "%s: %s: empty topic level", what,
                               quote(c, s, len));
        return 0;
}

/* ---- keys ------------------------------------------------------------------------------------ */

static int parse_mapping(struct pctx *c, struct bridge_config *cfg, const char *what,
                         const struct key *keys, size_t n_keys);

static int k_instance(struct pctx *c, struct bridge_config *cfg)
{
        int r = get_string(c, "instance", cfg->instance, sizeof(cfg->instance));

        if (r == 0 && strpbrk(cfg->instance, "/+#"))
                return fail_at(c, &c->ev.start_mark, "instance: %s: '/', '+' and '#' are not "
                               "allowed", quote(c, cfg->instance, strlen(cfg->instance)));
        return r;
}

static int k_prefix(struct pctx *c, struct bridge_config *cfg)
{
        int r = get_string(c, "prefix", cfg->prefix, sizeof(cfg->prefix));

        return r < 0 ? r : check_topic_part(c, "prefix", cfg->prefix);
}

static int k_host(struct pctx *c, struct bridge_config *cfg)
{
        return get_string(c, "host", cfg->host, sizeof(cfg->host));
}

static int k_port(struct pctx *c, struct bridge_config *cfg)
{
        return get_int(c, "port", 1, PORT_MAX, &cfg->port);
}

static int k_client_id(struct pctx *c, struct bridge_config *cfg)
{
        return get_string(c, "client_id", cfg->client_id, sizeof(cfg->client_id));
}

static int k_keepalive(struct pctx *c, struct bridge_config *cfg)
{
        return get_int(c, "keepalive_s", KEEPALIVE_MIN, KEEPALIVE_MAX, &cfg->keepalive_s);
}

static int k_username(struct pctx *c, struct bridge_config *cfg)
{
        return get_string(c, "username", cfg->username, sizeof(cfg->username));
}

static int k_password(struct pctx *c, struct bridge_config *cfg)
{
        return get_string(c, "password", cfg->password, sizeof(cfg->password));
}

static int k_password_file(struct pctx *c, struct bridge_config *cfg)
{
        return get_string(c, "password_file", cfg->password_file, sizeof(cfg->password_file));
}

static int k_reconnect_min(struct pctx *c, struct bridge_config *cfg)
{
        return get_uint(c, "reconnect_min_ms", 1, BRIDGE_RECONNECT_LIMIT, &cfg->reconnect_min_ms);
}

static int k_reconnect_max(struct pctx *c, struct bridge_config *cfg)
{
        return get_uint(c, "reconnect_max_ms", 1, BRIDGE_RECONNECT_LIMIT, &cfg->reconnect_max_ms);
}

static int k_max_inflight(struct pctx *c, struct bridge_config *cfg)
{
        return get_uint(c, "max_inflight", 1, BRIDGE_INFLIGHT_MAX, &cfg->max_inflight);
}

static int k_ca_file(struct pctx *c, struct bridge_config *cfg)
{
        cfg->tls = true;
        return get_string(c, "ca_file", cfg->ca_file, sizeof(cfg->ca_file));
}

static int k_ca_path(struct pctx *c, struct bridge_config *cfg)
{
        cfg->tls = true;
        return get_string(c, "ca_path", cfg->ca_path, sizeof(cfg->ca_path));
}

static int k_cert_file(struct pctx *c, struct bridge_config *cfg)
{
        cfg->tls = true;
        return get_string(c, "cert_file", cfg->cert_file, sizeof(cfg->cert_file));
}

static int k_key_file(struct pctx *c, struct bridge_config *cfg)
{
        cfg->tls = true;
        return get_string(c, "key_file", cfg->key_file, sizeof(cfg->key_file));
}

static int k_insecure(struct pctx *c, struct bridge_config *cfg)
{
        return get_bool(c, "insecure", &cfg->tls_insecure);
}

static const struct key tls_keys[] = {
        { "ca_file", k_ca_file },
        { "ca_path", k_ca_path },
        { "cert_file", k_cert_file },
        { "key_file", k_key_file },
        { "insecure", k_insecure },
};

static int k_tls(struct pctx *c, struct bridge_config *cfg)
{
        yaml_mark_t at = c->ev.start_mark;     /* checks of the whole mapping point at it */
        int r = parse_mapping(c, cfg, "tls", tls_keys, sizeof(tls_keys) / sizeof(tls_keys[0]));

        cfg->tls = true;
        if (r == 0 && !cfg->ca_file[0] && !cfg->ca_path[0])
                return fail_at(c, &at, "tls: needs ca_file or ca_path");
        if (r == 0 && !cfg->cert_file[0] != !cfg->key_file[0])
                return fail_at(c, &at, "tls: cert_file and key_file go together");
        return r;
}

static const struct key broker_keys[] = {
        { "host", k_host },
        { "port", k_port },
        { "client_id", k_client_id },
        { "keepalive_s", k_keepalive },
        { "username", k_username },
        { "password", k_password },
        { "password_file", k_password_file },
        { "reconnect_min_ms", k_reconnect_min },
        { "reconnect_max_ms", k_reconnect_max },
        { "max_inflight", k_max_inflight },
        { "tls", k_tls },
};

static int k_broker(struct pctx *c, struct bridge_config *cfg)
{
        yaml_mark_t at = c->ev.start_mark;
        int r = parse_mapping(c, cfg, "broker", broker_keys,
                              sizeof(broker_keys) / sizeof(broker_keys[0]));

        if (r < 0)
                return r;
        if (cfg->reconnect_min_ms > cfg->reconnect_max_ms)
                return fail_at(c, &at, "broker: reconnect_min_ms (%u) is more than "
                               "reconnect_max_ms (%u)", cfg->reconnect_min_ms,
                               cfg->reconnect_max_ms);
        if (cfg->password[0] && cfg->password_file[0])
                return fail_at(c, &at, "broker: password and password_file exclude each other");
        if ((cfg->password[0] || cfg->password_file[0]) && !cfg->username[0])
                return fail_at(c, &at, "broker: a password needs a username");
        return 0;
}

static int k_publish(struct pctx *c, struct bridge_config *cfg)
{
        return get_globs(c, "publish", &cfg->publish);
}

static int k_writable(struct pctx *c, struct bridge_config *cfg)
{
        return get_globs(c, "writable", &cfg->writable);
}

static int k_qos(struct pctx *c, struct bridge_config *cfg)
{
        return get_int(c, "qos", 0, QOS_MAX, &cfg->qos);
}

static int k_retain(struct pctx *c, struct bridge_config *cfg)
{
        return get_bool(c, "retain", &cfg->retain);
}

static int k_meta(struct pctx *c, struct bridge_config *cfg)
{
        int r = need_scalar(c, "meta", "json or none");

        if (r < 0)
                return r;
        if (!strcmp(scalar(c), "json"))
                cfg->meta = BRIDGE_META_JSON;
        else if (!strcmp(scalar(c), "none"))
                cfg->meta = BRIDGE_META_NONE;
        else
                return fail_at(c, &c->ev.start_mark, "meta: expected json or none, got %s",
                               describe(c));
        return 0;
}

static int k_events(struct pctx *c, struct bridge_config *cfg)
{
        return get_bool(c, "events", &cfg->events);
}

/* Events need an acknowledgement before the cursor moves: QoS 0 is refused. */
static int k_events_qos(struct pctx *c, struct bridge_config *cfg)
{
        return get_int(c, "events_qos", 1, QOS_MAX, &cfg->events_qos);
}

static int k_events_window(struct pctx *c, struct bridge_config *cfg)
{
        return get_uint(c, "events_window", BRIDGE_WINDOW_MIN, BRIDGE_WINDOW_MAX, &cfg->events_window);
}

static int k_cursor_file(struct pctx *c, struct bridge_config *cfg)
{
        int r = get_string(c, "cursor_file", cfg->cursor_file, sizeof(cfg->cursor_file));

        if (r == 0 && cfg->cursor_file[0] != '/')
                return fail_at(c, &c->ev.start_mark, "cursor_file: must be an absolute path");
        return r;
}

static int k_cursor_sync(struct pctx *c, struct bridge_config *cfg)
{
        return get_uint(c, "cursor_sync_ms", 0, BRIDGE_CURSOR_SYNC_LIMIT, &cfg->cursor_sync_ms);
}

static int k_drain(struct pctx *c, struct bridge_config *cfg)
{
        return get_uint(c, "drain_ms", 0, BRIDGE_RECONNECT_LIMIT, &cfg->drain_ms);
}

static int k_set_qos(struct pctx *c, struct bridge_config *cfg)
{
        return get_int(c, "set_qos", 0, QOS_MAX, &cfg->set_qos);
}

static const struct key root_keys[] = {
        { "instance", k_instance },
        { "prefix", k_prefix },
        { "broker", k_broker },
        { "publish", k_publish },
        { "qos", k_qos },
        { "retain", k_retain },
        { "meta", k_meta },
        { "events", k_events },
        { "events_qos", k_events_qos },
        { "events_window", k_events_window },
        { "cursor_file", k_cursor_file },
        { "cursor_sync_ms", k_cursor_sync },
        { "drain_ms", k_drain },
        { "writable", k_writable },
        { "set_qos", k_set_qos },
};

_Static_assert(sizeof(root_keys) / sizeof(root_keys[0]) <= KEYS_MAX, "seen-key bitmask");
_Static_assert(sizeof(broker_keys) / sizeof(broker_keys[0]) <= KEYS_MAX, "seen-key bitmask");

/* A mapping whose start event is in c->ev; on return c->ev is its end event. */
static int parse_mapping(struct pctx *c, struct bridge_config *cfg, const char *what,
                         const struct key *keys, size_t n_keys)
{
        uint32_t seen = 0;
        int r;

        if (c->ev.type != YAML_MAPPING_START_EVENT) {
                if (is_scalar(c) && is_null(c))
                        return fail_at(c, &c->ev.start_mark, "%s: missing value", what);
                return fail_at(c, &c->ev.start_mark, "%s: expected a mapping, got %s", what,
                               describe(c));
        }
        for (;;) {
                size_t i;

                if ((r = next(c)) < 0)
                        return r;
                if (c->ev.type == YAML_MAPPING_END_EVENT)
                        return 0;
                if (!is_scalar(c))
                        return fail_at(c, &c->ev.start_mark, "%s: a key must be a string, got "
                                       "%s", what, describe(c));
                for (i = 0; i < n_keys; i++)
                        if (!strcmp(scalar(c), keys[i].name))
                                break;
                if (i == n_keys)
                        return fail_at(c, &c->ev.start_mark, "%s: unknown key %s", what,
                                       quote(c, scalar(c), c->ev.data.scalar.length));
                if (seen & (1u << i))
                        return fail_at(c, &c->ev.start_mark, "%s: duplicate key %s", what,
                                       keys[i].name);
                seen |= 1u << i;
                if ((r = next(c)) < 0)
                        return r;
                if ((r = keys[i].parse(c, cfg)) < 0)
                        return r;
        }
}

static int parse_stream(struct pctx *c, struct bridge_config *cfg)
{
        int r;

        if ((r = next(c)) < 0)          /* stream start */
                return r;
        if ((r = next(c)) < 0)
                return r;
        if (c->ev.type == YAML_STREAM_END_EVENT)
                return 0;               /* an empty file: every default */
        if ((r = next(c)) < 0)          /* after the document start: the root */
                return r;
        if (!(is_scalar(c) && is_null(c))) {
                r = parse_mapping(c, cfg, "configuration", root_keys,
                                  sizeof(root_keys) / sizeof(root_keys[0]));
                if (r < 0)
                        return r;
        }
        if ((r = next(c)) < 0)          /* document end */
                return r;
        if ((r = next(c)) < 0)
                return r;
        if (c->ev.type != YAML_STREAM_END_EVENT)
                return fail_at(c, &c->ev.start_mark, "only one YAML document is allowed");
        return 0;
}

void bridge_config_defaults(struct bridge_config *ret)
{
        memset(ret, 0, sizeof(*ret));
        snprintf(ret->prefix, sizeof(ret->prefix), "sharedlink");
        snprintf(ret->host, sizeof(ret->host), "localhost");
        ret->port = BRIDGE_PORT_DEFAULT;
        ret->keepalive_s = BRIDGE_KEEPALIVE_DEFAULT;
        ret->reconnect_min_ms = BRIDGE_RECONNECT_MIN_DEFAULT;
        ret->reconnect_max_ms = BRIDGE_RECONNECT_MAX_DEFAULT;
        ret->max_inflight = BRIDGE_INFLIGHT_DEFAULT;
        ret->publish.count = 1;
        snprintf(ret->publish.glob[0], sizeof(ret->publish.glob[0]), "*");
        ret->qos = 0;
        ret->retain = true;
        ret->meta = BRIDGE_META_JSON;
        ret->events = true;
        ret->events_qos = 1;
        ret->events_window = BRIDGE_WINDOW_DEFAULT;
        ret->cursor_sync_ms = BRIDGE_CURSOR_SYNC_DEFAULT;
        ret->drain_ms = BRIDGE_DRAIN_DEFAULT;
        ret->set_qos = 1;
}

int bridge_config_parse(const char *name, const char *text, size_t len, struct bridge_config *ret,
                        char *err, size_t err_size)
{
        struct pctx c = { .name = name, .text = text, .len = len, .err = err,
                          .err_size = err_size };
        struct bridge_config *cfg;
        int r;

        if (err_size)
                err[0] = '\0';
        if (memchr(text, '\0', len)) {
                yaml_mark_t m = offset_mark(&c, (size_t)((const char *)memchr(text, '\0', len) -
                                                         text));

                return fail_at(&c, &m, "NUL byte in the file");
        }
        cfg = malloc(sizeof(*cfg));
        if (!cfg) {
                fail_at(&c, NULL, "out of memory");
                return -ENOMEM;
        }
        bridge_config_defaults(cfg);
        if (!yaml_parser_initialize(&c.parser)) {
                free(cfg);
                fail_at(&c, NULL, "out of memory");
                return -ENOMEM;
        }
        yaml_parser_set_input_string(&c.parser, (const unsigned char *)text, len);
        r = parse_stream(&c, cfg);
        if (c.have_ev)
                yaml_event_delete(&c.ev);
        yaml_parser_delete(&c.parser);
        if (r == 0)
                *ret = *cfg;
        free(cfg);
        return r;
}

static int read_file(const char *path, size_t max, char **ret_text, size_t *ret_len)
{
        struct stat st;
        char *buf;
        ssize_t n = 0;
        size_t len = 0;
        int fd = open(path, O_RDONLY | O_CLOEXEC), r = 0;

        if (fd < 0)
                return -errno;
        if (fstat(fd, &st) < 0 || !S_ISREG(st.st_mode)) {
                r = fstat(fd, &st) < 0 ? -errno : S_ISDIR(st.st_mode) ? -EISDIR : -EINVAL;
                close(fd);
                return r;
        }
        buf = malloc(max + 1);
        if (!buf) {
                close(fd);
                return -ENOMEM;
        }
        while (len < max + 1 && (n = read(fd, buf + len, max + 1 - len)) > 0)
                len += (size_t)n;
        if (n < 0)
                r = -errno;
        close(fd);
        if (r == 0 && len > max)
                r = -EFBIG;
        if (r < 0) {
                free(buf);
                return r;
        }
        buf[len] = '\0';
        *ret_text = buf;
        *ret_len = len;
        return 0;
}

/* The first line of password_file, without its newline. */
static int load_password(struct bridge_config *cfg, const char *path, char *err, size_t err_size)
{
        char *text;
        size_t len;
        int r = read_file(cfg->password_file, PASSWORD_FILE_MAX, &text, &len);

        if (r < 0) {
                snprintf(err, err_size, "%s: password_file %s: %s", path, cfg->password_file,
                         strerror(-r));
                return r;
        }
        len = strcspn(text, "\r\n");
        if (len == 0 || len >= sizeof(cfg->password)) {
                snprintf(err, err_size, "%s: password_file %s: %s", path, cfg->password_file,
                         len ? "password too long" : "empty first line");
                free(text);
                return -EINVAL;
        }
        memcpy(cfg->password, text, len);
        cfg->password[len] = '\0';
        explicit_bzero(text, len);
        free(text);
        return 0;
}

int bridge_config_load(const char *path, struct bridge_config *ret, char *err, size_t err_size)
{
        char *text;
        size_t len;
        int r = read_file(path, BRIDGE_FILE_MAX, &text, &len);

        if (r < 0) {
                snprintf(err, err_size, "%s: %s", path,
                         r == -EFBIG ? "file too large" : strerror(-r));
                return r;
        }
        r = bridge_config_parse(path, text, len, ret, err, err_size);
        free(text);
        if (r == 0 && ret->password_file[0])
                r = load_password(ret, path, err, err_size);
        return r;
}

bool bridge_globs_match(const struct bridge_globs *g, const char *name)
{
        for (unsigned i = 0; i < g->count; i++)
                if (fnmatch(g->glob[i], name, 0) == 0)
                        return true;
        return false;
}
