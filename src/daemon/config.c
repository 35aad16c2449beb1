/*
 * sharedlinkd configuration parser (the only user of libyaml in the project).
 *
 * Two stages. First libyaml's event API builds a small tree of our own (struct ynode) with the
 * position of every node; the event API lets us refuse anchors, aliases and tags, which the
 * document API would resolve silently (an alias bomb must not reach the schema walker). Then the
 * schema walker reads that tree into struct config, checking every key, type and range, and
 * reports the first problem as "FILE:LINE:COL: text".
 *
 * Decisions (documented for users in conf/sharedlinkd.yaml):
 * - Numbers and booleans must be plain (unquoted) scalars; strings may be plain or quoted.
 *   Integers are decimal digits only; leading zeros are refused (YAML 1.1 reads them as octal).
 * - Booleans are true/false (also True/TRUE/False/FALSE, the YAML 1.2 core schema); yes/no/on/off
 *   are refused, not guessed.
 * - A plain empty value, "~" or "null" is a missing value, never a default.
 * - Anchors, aliases, merge keys ("<<") and tags are refused; so is a second document.
 * - Strings may not contain control characters (double-quoted escapes could produce them).
 */
#include "daemon/config.h"
#include "proto/sharedlink.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <yaml.h>

#define YNONE                   UINT32_MAX
#define QUOTE_MAX               40u     /* bytes of user text echoed in a message */
#define QUOTE_BUF               (QUOTE_MAX * 4u + 8u)
#define QUOTE_SLOTS             2u
#define NUMBER_ECHO_MAX         24u     /* digits of an out-of-range number echoed */
#define SOCKET_SUFFIX           ".sock"

/* ---------------------------------------------------------------------------------------------
 * Node tree built from libyaml events */

enum ynode_kind {
        YNODE_SCALAR,
        YNODE_SEQUENCE,
        YNODE_MAPPING,
};

struct ynode {
        enum ynode_kind kind;
        bool plain;                     /* scalar written as a plain (unquoted, non-block) scalar */
        unsigned line, column;          /* 1-based */
        char *text;                     /* scalar bytes + NUL (may contain NULs from escapes) */
        size_t len;
        uint32_t first, last, next;     /* children; a mapping's are key, value, key, value... */
        uint32_t count;
};

struct seen_var {
        const char *name;
        const struct ynode *node;
};

struct ctx {
        const char *filename;
        const char *text;
        size_t text_len;
        struct config_error *err;
        struct ynode *nodes;
        uint32_t n_nodes, cap_nodes;
        struct config *cfg;
        struct seen_var vars[CONFIG_VARS_MAX];
        const struct ynode *link_name_nodes[CONFIG_LINKS_MAX];
        const struct ynode *device_nodes[CONFIG_LINKS_MAX][CONFIG_DEVICES_MAX];
        const struct ynode *runtime_dir_node;
        char quote[QUOTE_SLOTS][QUOTE_BUF];
        unsigned quote_next;
};

/* ---------------------------------------------------------------------------------------------
 * Errors */

static void error_vset(struct ctx *c, unsigned line, unsigned column, const char *fmt, va_list ap)
        __attribute__((format(printf, 4, 0)));

static void error_vset(struct ctx *c, unsigned line, unsigned column, const char *fmt, va_list ap)
{
        size_t n;
        int k;

        if (c->err->message[0])
                return;         /* the first error wins */
        c->err->line = line;
        c->err->column = column;
        if (line)
                k = snprintf(c->err->message, sizeof(c->err->message), "%s:%u:%u: ", c->filename,
                             line, column);
        else
                k = snprintf(c->err->message, sizeof(c->err->message), "%s: ", c->filename);
        n = k < 0 ? 0 : (size_t)k;
        if (n < sizeof(c->err->message))
                vsnprintf(c->err->message + n, sizeof(c->err->message) - n, fmt, ap);
}

static int fail_at(struct ctx *c, unsigned line, unsigned column, const char *fmt, ...)
        __attribute__((format(printf, 4, 5)));

static int fail_at(struct ctx *c, unsigned line, unsigned column, const char *fmt, ...)
{
        va_list ap;

        va_start(ap, fmt);
        error_vset(c, line, column, fmt, ap);
        va_end(ap);
        return -EINVAL;
}

static int fail(struct ctx *c, const struct ynode *n, const char *fmt, ...)
        __attribute__((format(printf, 3, 4)));

static int fail(struct ctx *c, const struct ynode *n, const char *fmt, ...)
{
        va_list ap;

        va_start(ap, fmt);
        error_vset(c, n->line, n->column, fmt, ap);
        va_end(ap);
        return -EINVAL;
}

static int fail_nomem(struct ctx *c)
{
        fail_at(c, 0, 0, "out of memory");
        return -ENOMEM;
}

/* User text for a message: quoted, at most QUOTE_MAX bytes, all but printable ASCII escaped. */
static const char *quote(struct ctx *c, const char *s, size_t len)
{
        char *out = c->quote[c->quote_next++ % QUOTE_SLOTS];
        size_t o = 0;

        out[o++] = '"';
        for (size_t i = 0; i < len && i < QUOTE_MAX; i++) {
                unsigned char ch = (unsigned char)s[i];

                if (ch == '"' || ch == '\\') {
                        out[o++] = '\\';
                        out[o++] = (char)ch;
                } else if (ch < 0x20 || ch >= 0x7f) {
                        o += (size_t)snprintf(out + o, QUOTE_BUF - o, "\\x%02X", ch);
                } else {
                        out[o++] = (char)ch;
                }
        }
        out[o++] = '"';
        if (len > QUOTE_MAX) {
                memcpy(out + o, "...", 3);
                o += 3;
        }
        out[o] = '\0';
        return out;
}

/* A number as written (only signs and digits get here), unquoted, cut at NUMBER_ECHO_MAX. */
static const char *number_text(struct ctx *c, const char *s, size_t len)
{
        char *out = c->quote[c->quote_next++ % QUOTE_SLOTS];

        snprintf(out, QUOTE_BUF, "%.*s%s", (int)(len > NUMBER_ECHO_MAX ? NUMBER_ECHO_MAX : len), s,
                 len > NUMBER_ECHO_MAX ? "..." : "");
        return out;
}

static const char *quote_node(struct ctx *c, const struct ynode *n)
{
        return quote(c, n->text, n->len);
}

/* What a node is, for "expected X, got Y": a list, a mapping, or the scalar's text. */
static const char *describe(struct ctx *c, const struct ynode *n)
{
        switch (n->kind) {
        case YNODE_SEQUENCE:
                return "a list";
        case YNODE_MAPPING:
                return "a mapping";
        case YNODE_SCALAR:
                break;
        }
        return quote_node(c, n);
}

/* ---------------------------------------------------------------------------------------------
 * Stage 1: events -> tree */

static struct ynode *node_at(struct ctx *c, uint32_t i)
{
        return &c->nodes[i];
}

static int node_add(struct ctx *c, enum ynode_kind kind, const yaml_mark_t *mark, uint32_t parent,
                    uint32_t *ret_index)
{
        struct ynode *n;

        if (c->n_nodes >= CONFIG_NODES_MAX)
                return fail_at(c, (unsigned)mark->line + 1, (unsigned)mark->column + 1,
                               "too many YAML nodes (at most %u)", CONFIG_NODES_MAX);
        if (c->n_nodes == c->cap_nodes) {
                uint32_t cap = c->cap_nodes ? c->cap_nodes * 2 : 256;
                struct ynode *nn = realloc(c->nodes, (size_t)cap * sizeof(*nn));

                if (!nn)
                        return fail_nomem(c);
                c->nodes = nn;
                c->cap_nodes = cap;
        }
        n = &c->nodes[c->n_nodes];
        memset(n, 0, sizeof(*n));
        n->kind = kind;
        n->line = (unsigned)mark->line + 1;
        n->column = (unsigned)mark->column + 1;
        n->first = n->last = n->next = YNONE;
        if (parent != YNONE) {
                struct ynode *p = node_at(c, parent);

                if (p->last == YNONE)
                        p->first = c->n_nodes;
                else
                        node_at(c, p->last)->next = c->n_nodes;
                p->last = c->n_nodes;
                p->count++;
        }
        *ret_index = c->n_nodes++;
        return 0;
}

static void nodes_free(struct ctx *c)
{
        for (uint32_t i = 0; i < c->n_nodes; i++)
                free(c->nodes[i].text);
        free(c->nodes);
        c->nodes = NULL;
        c->n_nodes = c->cap_nodes = 0;
}

/* Reader errors carry a byte offset, not a mark: count lines and UTF-8 characters up to it. */
static void offset_position(const struct ctx *c, size_t offset, unsigned *ret_line,
                            unsigned *ret_column)
{
        unsigned line = 1, column = 1;

        for (size_t i = 0; i < offset && i < c->text_len; i++) {
                unsigned char ch = (unsigned char)c->text[i];
                bool crlf = ch == '\r' && i + 1 < c->text_len && c->text[i + 1] == '\n';

                if (ch == '\n' || (ch == '\r' && !crlf)) {
                        line++;
                        column = 1;
                } else if ((ch & 0xC0) != 0x80 && ch != '\r') {
                        column++;
                }
        }
        *ret_line = line;
        *ret_column = column;
}

static int yaml_failure(struct ctx *c, const yaml_parser_t *p)
{
        const char *problem = p->problem ? p->problem : "syntax error";
        unsigned line, column;

        switch (p->error) {
        case YAML_MEMORY_ERROR:
                return fail_nomem(c);
        case YAML_READER_ERROR:
                offset_position(c, p->problem_offset, &line, &column);
                if (p->problem_value >= 0)
                        return fail_at(c, line, column, "%s (0x%02X)", problem,
                                       (unsigned)p->problem_value);
                return fail_at(c, line, column, "%s", problem);
        default:
                line = (unsigned)p->problem_mark.line + 1;
                column = (unsigned)p->problem_mark.column + 1;
                if (p->context)
                        return fail_at(c, line, column, "%s (%s)", problem, p->context);
                return fail_at(c, line, column, "%s", problem);
        }
}

static int event_node(struct ctx *c, const yaml_event_t *ev, uint32_t parent, uint32_t *ret_index)
{
        const yaml_mark_t *m = &ev->start_mark;
        const yaml_char_t *anchor = NULL, *tag = NULL;
        enum ynode_kind kind;
        int r;

        switch (ev->type) {
        case YAML_SCALAR_EVENT:
                kind = YNODE_SCALAR;
                anchor = ev->data.scalar.anchor;
                tag = ev->data.scalar.tag;
                break;
        case YAML_SEQUENCE_START_EVENT:
                kind = YNODE_SEQUENCE;
                anchor = ev->data.sequence_start.anchor;
                tag = ev->data.sequence_start.tag;
                break;
        default:
                kind = YNODE_MAPPING;
                anchor = ev->data.mapping_start.anchor;
                tag = ev->data.mapping_start.tag;
                break;
        }
        if (anchor)
                return fail_at(c, (unsigned)m->line + 1, (unsigned)m->column + 1,
                               "anchors and aliases are not supported");
        if (tag)
                return fail_at(c, (unsigned)m->line + 1, (unsigned)m->column + 1,
                               "tags are not supported");
        r = node_add(c, kind, m, parent, ret_index);
        if (r < 0)
                return r;
        if (kind == YNODE_SCALAR) {
                struct ynode *n = node_at(c, *ret_index);

                n->len = ev->data.scalar.length;
                n->plain = ev->data.scalar.style == YAML_PLAIN_SCALAR_STYLE;
                n->text = malloc(n->len + 1);
                if (!n->text)
                        return fail_nomem(c);
                memcpy(n->text, ev->data.scalar.value, n->len);
                n->text[n->len] = '\0';
        }
        return 0;
}

/* One event into the tree; *done is set at the end of the stream. */
static int tree_event(struct ctx *c, const yaml_event_t *ev, uint32_t *stack, unsigned *depth,
                      uint32_t *root, bool *seen_document, bool *done)
{
        const yaml_mark_t *m = &ev->start_mark;
        uint32_t parent = *depth ? stack[*depth - 1] : YNONE;
        uint32_t index = YNONE;
        int r;

        switch (ev->type) {
        case YAML_STREAM_END_EVENT:
                *done = true;
                return 0;
        case YAML_DOCUMENT_START_EVENT:
                if (*seen_document)
                        return fail_at(c, (unsigned)m->line + 1, (unsigned)m->column + 1,
                                       "only one YAML document is allowed");
                *seen_document = true;
                return 0;
        case YAML_ALIAS_EVENT:
                return fail_at(c, (unsigned)m->line + 1, (unsigned)m->column + 1,
                               "anchors and aliases are not supported");
        case YAML_SCALAR_EVENT:
        case YAML_SEQUENCE_START_EVENT:
        case YAML_MAPPING_START_EVENT:
                r = event_node(c, ev, parent, &index);
                if (r < 0)
                        return r;
                if (parent == YNONE)
                        *root = index;
                if (ev->type == YAML_SCALAR_EVENT)
                        return 0;
                if (*depth >= CONFIG_DEPTH_MAX)
                        return fail_at(c, (unsigned)m->line + 1, (unsigned)m->column + 1,
                                       "nested deeper than %u levels", CONFIG_DEPTH_MAX);
                stack[(*depth)++] = index;
                return 0;
        case YAML_SEQUENCE_END_EVENT:
        case YAML_MAPPING_END_EVENT:
                if (*depth)
                        (*depth)--;
                return 0;
        default:
                return 0;
        }
}

static int tree_build(struct ctx *c, uint32_t *ret_root)
{
        yaml_parser_t parser;
        uint32_t stack[CONFIG_DEPTH_MAX];
        unsigned depth = 0;
        uint32_t root = YNONE;
        bool seen_document = false, done = false;
        int r = 0;

        if (!yaml_parser_initialize(&parser))
                return fail_nomem(c);
        yaml_parser_set_input_string(&parser, (const unsigned char *)c->text, c->text_len);
        /* Forced, so a UTF-16 file is an encoding error instead of being accepted by its BOM. */
        yaml_parser_set_encoding(&parser, YAML_UTF8_ENCODING);
        while (!done && r == 0) {
                yaml_event_t ev;

                if (!yaml_parser_parse(&parser, &ev)) {
                        r = yaml_failure(c, &parser);
                        break;
                }
                r = tree_event(c, &ev, stack, &depth, &root, &seen_document, &done);
                yaml_event_delete(&ev);
        }
        yaml_parser_delete(&parser);
        if (r < 0)
                return r;
        *ret_root = root;
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Scalars */

static const struct ynode *child(const struct ctx *c, uint32_t i)
{
        return i == YNONE ? NULL : &c->nodes[i];
}

static const struct ynode *next(const struct ctx *c, const struct ynode *n)
{
        return child(c, n->next);
}

/* Exact match: a scalar may hold NULs (from escapes), so strcmp() alone would be fooled. */
static bool scalar_is(const struct ynode *n, const char *s)
{
        return n->kind == YNODE_SCALAR && n->len == strlen(s) && memcmp(n->text, s, n->len) == 0;
}

static bool is_null(const struct ynode *n)
{
        static const char *const nulls[] = { "", "~", "null", "Null", "NULL" };

        if (n->kind != YNODE_SCALAR || !n->plain)
                return false;
        for (size_t i = 0; i < sizeof(nulls) / sizeof(nulls[0]); i++)
                if (scalar_is(n, nulls[i]))
                        return true;
        return false;
}

/* A scalar holding a value of some kind: not a list or mapping, not null. */
static int need_scalar(struct ctx *c, const char *key, const struct ynode *n, const char *expected)
{
        if (n->kind != YNODE_SCALAR)
                return fail(c, n, "%s: expected %s, got %s", key, expected, describe(c, n));
        if (is_null(n))
                return fail(c, n, "%s: missing value", key);
        return 0;
}

static int get_string(struct ctx *c, const char *key, const struct ynode *n, char *out,
                      size_t size)
{
        int r = need_scalar(c, key, n, "a string");

        if (r < 0)
                return r;
        if (n->len == 0)
                return fail(c, n, "%s: empty string", key);
        for (size_t i = 0; i < n->len; i++) {
                unsigned char ch = (unsigned char)n->text[i];

                if (ch < 0x20 || ch == 0x7f)
                        return fail(c, n, "%s: control character in %s", key, quote_node(c, n));
        }
        if (n->len >= size)
                return fail(c, n, "%s: %s too long (%zu bytes, at most %zu)", key,
                            quote_node(c, n), n->len, size - 1);
        memcpy(out, n->text, n->len + 1);
        return 0;
}

/* Plain decimal integer in [min, max]. */
static int get_uint(struct ctx *c, const char *key, const struct ynode *n, uint32_t min,
                    uint32_t max, uint32_t *ret)
{
        const char *s;
        bool negative;
        uint64_t v = 0;
        bool overflow = false;
        size_t i;
        int r = need_scalar(c, key, n, "an integer");

        if (r < 0)
                return r;
        if (!n->plain)
                return fail(c, n, "%s: expected an integer, got a quoted string", key);
        s = n->text;
        negative = s[0] == '-';
        i = (s[0] == '-' || s[0] == '+') ? 1 : 0;
        if (i >= n->len)
                return fail(c, n, "%s: expected an integer, got %s", key, quote_node(c, n));
        for (size_t j = i; j < n->len; j++) {
                if (s[j] < '0' || s[j] > '9')
                        return fail(c, n, "%s: expected an integer, got %s", key,
                                    quote_node(c, n));
                if (v > UINT32_MAX)
                        overflow = true;
                else
                        v = v * 10 + (uint64_t)(s[j] - '0');
        }
        if (s[i] == '0' && n->len - i > 1)
                return fail(c, n, "%s: leading zeros are not allowed in %s", key,
                            quote_node(c, n));
        if (overflow || (negative && v) || v < min || v > max)
                return fail(c, n, "%s %s out of range (%u..%u)", key,
                            number_text(c, n->text, n->len), min, max);
        *ret = (uint32_t)v;
        return 0;
}

static int get_bool(struct ctx *c, const char *key, const struct ynode *n, bool *ret)
{
        static const char *const truths[] = { "true", "True", "TRUE" };
        static const char *const lies[] = { "false", "False", "FALSE" };
        int r = need_scalar(c, key, n, "true or false");

        if (r < 0)
                return r;
        if (!n->plain)
                return fail(c, n, "%s: expected true or false, got a quoted string", key);
        for (size_t i = 0; i < 3; i++) {
                if (scalar_is(n, truths[i])) {
                        *ret = true;
                        return 0;
                }
                if (scalar_is(n, lies[i])) {
                        *ret = false;
                        return 0;
                }
        }
        return fail(c, n, "%s: expected true or false, got %s", key, quote_node(c, n));
}

struct enum_name {
        const char *name;
        int value;
};

#define ENUM_COUNT(t) (sizeof(t) / sizeof((t)[0]))

static const struct enum_name protocol_names[] = {
        { "sharedlink", CONFIG_PROTOCOL_SHAREDLINK },
        { "circe", CONFIG_PROTOCOL_CIRCE },
};
static const struct enum_name transport_names[] = {
        { "serial", CONFIG_TRANSPORT_SERIAL },
        { "udp", CONFIG_TRANSPORT_UDP },
        { "pty", CONFIG_TRANSPORT_PTY },
};
static const struct enum_name role_names[] = {
        { "controller", CONFIG_ROLE_CONTROLLER },
        { "mediator", CONFIG_ROLE_MEDIATOR },
};
static const struct enum_name parity_names[] = {
        { "none", CONFIG_PARITY_NONE },
        { "even", CONFIG_PARITY_EVEN },
        { "odd", CONFIG_PARITY_ODD },
};
static const struct enum_name flow_names[] = {
        { "none", CONFIG_FLOW_NONE },
        { "rtscts", CONFIG_FLOW_RTSCTS },
        { "xonxoff", CONFIG_FLOW_XONXOFF },
};
static const struct enum_name dialect_names[] = {
        { "bulletin", CONFIG_DIALECT_BULLETIN },
        { "pronto4", CONFIG_DIALECT_PRONTO4 },
};
static const struct enum_name var_type_names[] = {
        { "string", CONFIG_VAR_STRING },
        { "long", CONFIG_VAR_LONG },
        { "double", CONFIG_VAR_DOUBLE },
};

static int get_enum(struct ctx *c, const char *key, const struct ynode *n,
                    const struct enum_name *names, size_t count, int *ret)
{
        char expected[128];
        size_t o = 0;
        int r = need_scalar(c, key, n, "a name");

        if (r < 0)
                return r;
        for (size_t i = 0; i < count; i++) {
                if (scalar_is(n, names[i].name)) {
                        *ret = names[i].value;
                        return 0;
                }
        }
        for (size_t i = 0; i < count && o < sizeof(expected); i++)
                o += (size_t)snprintf(expected + o, sizeof(expected) - o, "%s%s",
                                      i == 0 ? "" : (i + 1 == count ? " or " : ", "),
                                      names[i].name);
        return fail(c, n, "%s: expected %s, got %s", key, expected, quote_node(c, n));
}

static const char *enum_lookup(const struct enum_name *names, size_t count, int value)
{
        for (size_t i = 0; i < count; i++)
                if (names[i].value == value)
                        return names[i].name;
        return "?";
}

static bool is_name_char(char ch, bool dot)
{
        return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') ||
               ch == '_' || ch == '-' || (dot && ch == '.');
}

/*
 * Instance and link names: letters, digits, '_' and '-', not starting with '-' (they appear on
 * slctl's command line, in shm names and in socket and variable names; no '.', so the prefix
 * "<link>." of one CIRCE link can never be the start of another's).
 */
static int get_ident(struct ctx *c, const char *key, const struct ynode *n, char *out, size_t size)
{
        int r = get_string(c, key, n, out, size);

        if (r < 0)
                return r;
        if (out[0] == '-')
                return fail(c, n, "%s %s must not start with '-'", key, quote_node(c, n));
        for (size_t i = 0; out[i]; i++)
                if (!is_name_char(out[i], false))
                        return fail(c, n, "%s %s: invalid character '%c' (allowed: letters, "
                                    "digits, _ -)", key, quote_node(c, n), out[i]);
        return 0;
}

/* Group names as useradd takes them: [A-Za-z_][A-Za-z0-9_.-]*, optionally ending in '$'. */
static int get_group(struct ctx *c, const struct ynode *n, char *out, size_t size)
{
        int r = get_string(c, "group", n, out, size);
        size_t len;

        if (r < 0)
                return r;
        len = strlen(out);
        for (size_t i = 0; i < len; i++) {
                char ch = out[i];
                bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || ch == '_' ||
                          (i > 0 && ((ch >= '0' && ch <= '9') || ch == '.' || ch == '-')) ||
                          (i > 0 && i + 1 == len && ch == '$');

                if (!ok)
                        return fail(c, n, "group %s is not a valid group name", quote_node(c, n));
        }
        return 0;
}

static int get_path(struct ctx *c, const char *key, const struct ynode *n, char *out, size_t size)
{
        int r = get_string(c, key, n, out, size);

        if (r < 0)
                return r;
        if (out[0] != '/')
                return fail(c, n, "%s: %s is not an absolute path", key, quote_node(c, n));
        return 0;
}

static int get_sl_address(struct ctx *c, const char *key, const struct ynode *n, char *ret)
{
        int r = need_scalar(c, key, n, "a node address");

        if (r < 0)
                return r;
        if (n->len != 1 || n->text[0] < 'A' || n->text[0] > 'P')
                return fail(c, n, "%s %s is not a SharedLink node address (A..P)", key,
                            quote_node(c, n));
        *ret = n->text[0];
        return 0;
}

static int get_circe_address(struct ctx *c, const char *key, const struct ynode *n,
                             uint32_t *ret)
{
        int r = need_scalar(c, key, n, "a CIRCE address");

        if (r < 0)
                return r;
        r = circe_address_parse(n->text, n->len, ret);
        if (r == -ERANGE)
                return fail(c, n, "%s FFFFFF is reserved", key);
        if (r < 0)
                return fail(c, n, "%s %s: expected six uppercase hex digits", key,
                            quote_node(c, n));
        return 0;
}

/* CIRCE version: PARTS dot-separated numbers of 1..3 digits ("0.2" or "0.2.3"). */
static int get_circe_version(struct ctx *c, const char *key, const struct ynode *n,
                             unsigned parts, struct config_circe_version *ret)
{
        struct circe_version v;
        const char *example = parts == 2 ? "MAJOR.MINOR (e.g. \"0.2\")"
                                         : "MAJOR.MINOR.PATCH (e.g. \"0.2.3\")";
        int r = need_scalar(c, key, n, "a version");

        if (r < 0)
                return r;
        if (circe_version_parse(n->text, n->len, parts, &v) < 0)
                return fail(c, n, "%s: expected %s, got %s", key, example, quote_node(c, n));
        memcpy(ret->text, n->text, n->len + 1);         /* <= CIRCE_VERSION_LEN_MAX: checked */
        ret->major = v.major;
        ret->minor = v.minor;
        ret->patch = v.patch;
        return 0;
}

/* "IPV4:PORT", "[IPV6]:PORT" or "localhost:PORT"; no name lookups in a pure parser. */
static int get_endpoint(struct ctx *c, const char *key, const struct ynode *n, uint32_t port_min,
                        struct config_endpoint *ret)
{
        char text[CONFIG_ENDPOINT_MAX], host[CONFIG_ENDPOINT_MAX];
        const char *port_text, *end;
        struct config_endpoint ep;
        struct sockaddr_in *in4 = (struct sockaddr_in *)&ep.addr;
        struct sockaddr_in6 *in6 = (struct sockaddr_in6 *)&ep.addr;
        bool v6 = false;
        uint32_t port = 0;
        int r = get_string(c, key, n, text, sizeof(text));

        if (r < 0)
                return r;
        if (text[0] == '[') {
                end = strchr(text, ']');
                if (!end || end[1] != ':')
                        goto bad;
                v6 = true;
                memcpy(host, text + 1, (size_t)(end - text - 1));
                host[end - text - 1] = '\0';
                port_text = end + 2;
        } else {
                end = strchr(text, ':');
                if (!end || strchr(end + 1, ':'))
                        goto bad;
                memcpy(host, text, (size_t)(end - text));
                host[end - text] = '\0';
                port_text = end + 1;
        }
        if (!port_text[0])
                goto bad;
        for (const char *p = port_text; *p; p++) {
                if (*p < '0' || *p > '9')
                        goto bad;
                if (port <= UINT16_MAX)         /* stays above the range once it is */
                        port = port * 10 + (uint32_t)(*p - '0');
        }
        if (port < port_min || port > UINT16_MAX)
                return fail(c, n, "%s: port %s out of range (%u..%u)", key,
                            number_text(c, port_text, strlen(port_text)), port_min, UINT16_MAX);

        memset(&ep, 0, sizeof(ep));
        memcpy(ep.text, text, sizeof(ep.text));
        if (v6) {
                if (inet_pton(AF_INET6, host, &in6->sin6_addr) != 1)
                        goto bad;
                in6->sin6_family = AF_INET6;
                in6->sin6_port = htons((uint16_t)port);
                ep.addr_len = sizeof(*in6);
        } else {
                if (strcmp(host, "localhost") == 0)
                        strcpy(host, "127.0.0.1");
                if (inet_pton(AF_INET, host, &in4->sin_addr) != 1)
                        goto bad;
                in4->sin_family = AF_INET;
                in4->sin_port = htons((uint16_t)port);
                ep.addr_len = sizeof(*in4);
        }
        *ret = ep;
        return 0;
bad:
        return fail(c, n, "%s: bad address %s (expected IPV4:PORT, [IPV6]:PORT or localhost:PORT)",
                    key, quote_node(c, n));
}

/* ---------------------------------------------------------------------------------------------
 * Mappings */

/*
 * Checks a mapping's keys against KNOWN (all scalars, no merge key, no unknown key, no duplicate)
 * and files each value under its key's index in vals[] (NULL when absent); keys[] likewise.
 */
static int map_read(struct ctx *c, const struct ynode *map, const char *what,
                    const char *const *known, size_t n_known, const struct ynode **keys,
                    const struct ynode **vals)
{
        for (size_t i = 0; i < n_known; i++)
                keys[i] = vals[i] = NULL;
        for (const struct ynode *k = child(c, map->first); k; k = next(c, next(c, k))) {
                const struct ynode *v = next(c, k);
                size_t i;

                if (k->kind != YNODE_SCALAR)
                        return fail(c, k, "a key must be a string, not %s", describe(c, k));
                if (k->plain && scalar_is(k, "<<"))
                        return fail(c, k, "merge keys (\"<<\") are not supported");
                for (i = 0; i < n_known; i++)
                        if (scalar_is(k, known[i]))
                                break;
                if (i == n_known)
                        return fail(c, k, "unknown key %s %s", quote_node(c, k), what);
                if (keys[i])
                        return fail(c, k, "duplicate key %s (first at %u:%u)", quote_node(c, k),
                                    keys[i]->line, keys[i]->column);
                keys[i] = k;
                vals[i] = v;    /* libyaml always pairs a key with a value, possibly empty */
        }
        return 0;
}

/* A list or a mapping (KIND), where a null value is reported as missing. */
static int need_kind(struct ctx *c, const char *what, const struct ynode *n, enum ynode_kind kind)
{
        if (n->kind == kind)
                return 0;
        if (is_null(n))
                return fail(c, n, "%s: missing value", what);
        return fail(c, n, "%s: expected %s, got %s", what,
                    kind == YNODE_SEQUENCE ? "a list" : "a mapping", describe(c, n));
}

/* ---------------------------------------------------------------------------------------------
 * Variables */

static int var_name_check(struct ctx *c, const struct ynode *n, const char *name)
{
        for (size_t i = 0; name[i]; i++)
                if (!is_name_char(name[i], true))
                        return fail(c, n, "variable name %s: invalid character %s (allowed: "
                                    "letters, digits, _ . -)", quote_node(c, n),
                                    quote(c, name + i, 1));
        return 0;
}

/* Names are unique per instance. Quadratic, but bounded by CONFIG_VARS_MAX. */
static int var_register(struct ctx *c, const struct ynode *n, const char *name)
{
        for (unsigned i = 0; i < c->cfg->n_vars; i++)
                if (strcmp(c->vars[i].name, name) == 0)
                        return fail(c, n, "duplicate variable name %s (first at %u:%u)",
                                    quote_node(c, n), c->vars[i].node->line,
                                    c->vars[i].node->column);
        if (c->cfg->n_vars >= CONFIG_VARS_MAX)
                return fail(c, n, "too many variables (at most %u per instance)", CONFIG_VARS_MAX);
        c->vars[c->cfg->n_vars].name = name;
        c->vars[c->cfg->n_vars].node = n;
        c->cfg->n_vars++;
        return 0;
}

enum { VK_NAME, VK_TYPE, VK_COUNT };
static const char *const var_keys[VK_COUNT] = { [VK_NAME] = "name", [VK_TYPE] = "type" };

static int parse_var(struct ctx *c, const struct ynode *n, struct config_var *ret)
{
        const struct ynode *keys[VK_COUNT], *vals[VK_COUNT];
        const struct ynode *name_node = n;
        int type = CONFIG_VAR_STRING;
        int r;

        if (n->kind == YNODE_MAPPING) {
                r = map_read(c, n, "in variable", var_keys, VK_COUNT, keys, vals);
                if (r < 0)
                        return r;
                if (!vals[VK_NAME])
                        return fail(c, n, "missing key \"name\" in variable");
                name_node = vals[VK_NAME];
                if (vals[VK_TYPE]) {
                        r = get_enum(c, "type", vals[VK_TYPE], var_type_names,
                                     ENUM_COUNT(var_type_names), &type);
                        if (r < 0)
                                return r;
                }
        } else if (n->kind != YNODE_SCALAR) {
                return fail(c, n, "variable: expected a name or {name, type}, got a list");
        }
        r = get_string(c, "variable name", name_node, ret->name, sizeof(ret->name));
        if (r < 0)
                return r;
        r = var_name_check(c, name_node, ret->name);
        if (r < 0)
                return r;
        ret->type = (enum config_var_type)type;
        return var_register(c, name_node, ret->name);
}

static int parse_var_list(struct ctx *c, const char *key, const struct ynode *n,
                          struct config_var **ret_vars, unsigned *ret_count)
{
        struct config_var *vars;
        unsigned i = 0;
        int r = need_kind(c, key, n, YNODE_SEQUENCE);

        if (r < 0)
                return r;
        if (n->count > CONFIG_LIST_MAX)
                return fail(c, n, "%s: too many variables (%u, at most %u per list)", key,
                            n->count, CONFIG_LIST_MAX);
        if (n->count == 0)
                return 0;
        vars = calloc(n->count, sizeof(*vars));
        if (!vars)
                return fail_nomem(c);
        /* Owned by the config from here on, so config_free() releases it on any later error. */
        *ret_vars = vars;
        for (const struct ynode *item = child(c, n->first); item; item = next(c, item)) {
                r = parse_var(c, item, &vars[i]);
                if (r < 0)
                        return r;
                *ret_count = ++i;
        }
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * SharedLink peers */

enum {
        PK_ADDRESS, PK_PERIOD_MS, PK_REFRESH_MS, PK_COMPRESSION, PK_ON_CHANGE, PK_MIN_INTERVAL_MS,
        PK_STALE_MS, PK_MAX_FRAME, PK_OUTBOUND, PK_INBOUND, PK_DIALECT, PK_DECLARE, PK_LEARN_MAX,
        PK_COUNT
};
static const char *const peer_keys[PK_COUNT] = {
        [PK_ADDRESS] = "address", [PK_PERIOD_MS] = "period_ms", [PK_REFRESH_MS] = "refresh_ms",
        [PK_COMPRESSION] = "compression", [PK_ON_CHANGE] = "on_change",
        [PK_MIN_INTERVAL_MS] = "min_interval_ms", [PK_STALE_MS] = "stale_ms",
        [PK_MAX_FRAME] = "max_frame", [PK_OUTBOUND] = "outbound", [PK_INBOUND] = "inbound",
        [PK_DIALECT] = "dialect", [PK_DECLARE] = "declare", [PK_LEARN_MAX] = "learn_max",
};

/* ---------------------------------------------------------------------------------------------
 * SharedLink peers: the Pronto4 dialect (docs/pronto4.md) */

/*
 * The longest text a value of each type takes on the wire, for the one-frame check. A long is
 * checked against its type before it is sent; a double goes out in its shortest round-trip form
 * (what sl_write_double() with decimals < 0 writes, and what the link re-formats to).
 */
static size_t var_text_max(enum config_var_type type)
{
        switch (type) {
        case CONFIG_VAR_LONG:
                return SLP_LONG_TEXT_MAX;
        case CONFIG_VAR_DOUBLE:
                return SLP_DOUBLE_TEXT_MAX;
        case CONFIG_VAR_STRING:
                break;
        }
        return SLP_VALUE_MAX;
}

/* An outbound or inbound list, or the word "learn" (the list comes from the peer). */
static int parse_peer_list(struct ctx *c, const char *key, const struct ynode *n,
                           struct config_var **ret_vars, unsigned *ret_count, bool *ret_learn)
{
        if (n->kind == YNODE_SCALAR && scalar_is(n, "learn")) {
                *ret_learn = true;
                return 0;
        }
        return parse_var_list(c, key, n, ret_vars, ret_count);
}

/* Bytes of the fields "|T<t>|Q<name>" of a declaration of @vars. */
static size_t declaration_fields_len(const struct config_var *vars, unsigned n)
{
        size_t len = 0;

        for (unsigned i = 0; i < n; i++)
                len += 2 + 1 + 2 + strlen(vars[i].name);
        return len;
}

/*
 * The Pronto4 clients want every data frame as one full-length N0 list (a partial one kills the
 * ROS 2 bridge's receiver) and the answers to N? and L? (our typed declarations) as one frame
 * each: the worst case of each must fit max_frame, or the link could never talk to them.
 */
static int check_pronto4_frames(struct ctx *c, const struct config_peer *p, bool crlf,
                                const struct ynode *out_node, const struct ynode *in_node)
{
        size_t data = 0, len;

        for (unsigned i = 0; i < p->n_outbound; i++)
                data += 2 + var_text_max(p->outbound[i].type);
        len = slp_list_frame_len(data, crlf);
        if (p->n_outbound > 0 && len > p->max_frame)
                return fail(c, out_node, "outbound: %u variables take up to %zu bytes as one "
                            "frame, more than max_frame %u (a pronto4 peer gets every data "
                            "frame as one full N0 list)", p->n_outbound, len, p->max_frame);
        len = slp_list_frame_len(declaration_fields_len(p->outbound, p->n_outbound), crlf);
        if (p->n_outbound > 0 && len > p->max_frame)
                return fail(c, out_node, "outbound: its declaration N0|T|Q... takes %zu bytes, "
                            "more than max_frame %u (a pronto4 peer wants it in one frame)", len,
                            p->max_frame);
        len = slp_list_frame_len(declaration_fields_len(p->inbound, p->n_inbound), crlf);
        if (p->n_inbound > 0 && len > p->max_frame)
                return fail(c, in_node, "inbound: its declaration L0|T|Q... takes %zu bytes, "
                            "more than max_frame %u (a pronto4 peer wants it in one frame)", len,
                            p->max_frame);
        return 0;
}

/* The keys that only a pronto4 peer may have: refused, by name, on a bulletin peer. */
static int check_bulletin_peer(struct ctx *c, const struct ynode *const *keys,
                               const struct ynode *const *vals, const struct config_peer *p)
{
        static const unsigned only_pronto4[] = { PK_DECLARE, PK_LEARN_MAX };

        for (size_t i = 0; i < ENUM_COUNT(only_pronto4); i++)
                if (keys[only_pronto4[i]])
                        return fail(c, keys[only_pronto4[i]], "key %s needs dialect: pronto4",
                                    quote_node(c, keys[only_pronto4[i]]));
        if (p->outbound_learn)
                return fail(c, vals[PK_OUTBOUND], "outbound: learn needs dialect: pronto4 (a "
                            "bulletin peer never declares its lists)");
        if (p->inbound_learn)
                return fail(c, vals[PK_INBOUND], "inbound: learn needs dialect: pronto4 (a "
                            "bulletin peer never declares its lists)");
        return 0;
}

/*
 * dialect, declare, learn_max, after the lists. Decision: a pronto4 peer with configured lists
 * and nothing learned is the host side and declares by default; a peer that learns is the
 * vehicle side, which answers declarations and never sends its own.
 */
static int parse_peer_dialect(struct ctx *c, const struct ynode *const *keys,
                              const struct ynode *const *vals, struct config_peer *p, bool crlf)
{
        bool learned = p->outbound_learn || p->inbound_learn;
        bool listed = p->n_outbound + p->n_inbound > 0;
        int e, r;

        p->dialect = CONFIG_DIALECT_BULLETIN;
        if (vals[PK_DIALECT]) {
                r = get_enum(c, "dialect", vals[PK_DIALECT], dialect_names,
                             ENUM_COUNT(dialect_names), &e);
                if (r < 0)
                        return r;
                p->dialect = (enum config_dialect)e;
        }
        if (p->dialect == CONFIG_DIALECT_BULLETIN)
                return check_bulletin_peer(c, keys, vals, p);

        p->declare = listed && !learned;
        if (vals[PK_DECLARE] && (r = get_bool(c, "declare", vals[PK_DECLARE], &p->declare)) < 0)
                return r;
        if (p->declare && learned)
                return fail(c, vals[PK_DECLARE], "declare: true with a learned list (the side "
                            "that learns answers declarations, it does not send them)");
        if (p->declare && !listed)
                return fail(c, vals[PK_DECLARE], "declare: true, but the peer has no outbound "
                            "or inbound variables to declare");
        p->learn_max = learned ? CONFIG_LEARN_MAX_DEFAULT : 0;
        if (vals[PK_LEARN_MAX]) {
                if (!learned)
                        return fail(c, keys[PK_LEARN_MAX], "learn_max needs outbound: learn or "
                                    "inbound: learn");
                r = get_uint(c, "learn_max", vals[PK_LEARN_MAX], CONFIG_LEARN_MAX_MIN,
                             CONFIG_LEARN_MAX_MAX, &p->learn_max);
                if (r < 0)
                        return r;
        }
        return check_pronto4_frames(c, p, crlf, vals[PK_OUTBOUND], vals[PK_INBOUND]);
}


static int parse_peer(struct ctx *c, const struct ynode *n, char own_address, bool crlf,
                      struct config_peer *p, const struct ynode **ret_address_node)
{
        const struct ynode *keys[PK_COUNT], *vals[PK_COUNT];
        int r = need_kind(c, "peer", n, YNODE_MAPPING);

        if (r < 0)
                return r;
        r = map_read(c, n, "in peer", peer_keys, PK_COUNT, keys, vals);
        if (r < 0)
                return r;
        p->period_ms = CONFIG_PERIOD_MS_DEFAULT;
        p->refresh_ms = CONFIG_REFRESH_MS_DEFAULT;
        p->min_interval_ms = CONFIG_MIN_INTERVAL_MS_DEFAULT;
        p->max_frame = CONFIG_MAX_FRAME_DEFAULT;
        p->compression = true;
        p->on_change = false;

        if (!vals[PK_ADDRESS])
                return fail(c, n, "missing key \"address\" in peer");
        r = get_sl_address(c, "address", vals[PK_ADDRESS], &p->address);
        if (r < 0)
                return r;
        *ret_address_node = vals[PK_ADDRESS];
        if (p->address == own_address)
                return fail(c, vals[PK_ADDRESS], "peer address %c is the link's own address",
                            p->address);
        if (vals[PK_PERIOD_MS] && (r = get_uint(c, "period_ms", vals[PK_PERIOD_MS], 0,
                                                CONFIG_PERIOD_MS_MAX, &p->period_ms)) < 0)
                return r;
        if (vals[PK_REFRESH_MS] && (r = get_uint(c, "refresh_ms", vals[PK_REFRESH_MS],
                                                 CONFIG_REFRESH_MS_MIN, CONFIG_REFRESH_MS_MAX,
                                                 &p->refresh_ms)) < 0)
                return r;
        if (vals[PK_COMPRESSION] &&
            (r = get_bool(c, "compression", vals[PK_COMPRESSION], &p->compression)) < 0)
                return r;
        if (vals[PK_ON_CHANGE] && (r = get_bool(c, "on_change", vals[PK_ON_CHANGE],
                                                &p->on_change)) < 0)
                return r;
        if (vals[PK_MIN_INTERVAL_MS] &&
            (r = get_uint(c, "min_interval_ms", vals[PK_MIN_INTERVAL_MS], 0,
                          CONFIG_MIN_INTERVAL_MS_MAX, &p->min_interval_ms)) < 0)
                return r;
        p->stale_ms = CONFIG_STALE_REFRESHES * p->refresh_ms;
        if (vals[PK_STALE_MS] && (r = get_uint(c, "stale_ms", vals[PK_STALE_MS], 0,
                                               CONFIG_STALE_MS_MAX, &p->stale_ms)) < 0)
                return r;
        if (vals[PK_MAX_FRAME] && (r = get_uint(c, "max_frame", vals[PK_MAX_FRAME],
                                                CONFIG_MAX_FRAME_MIN, CONFIG_MAX_FRAME_MAX,
                                                &p->max_frame)) < 0)
                return r;
        if (vals[PK_OUTBOUND] && (r = parse_peer_list(c, "outbound", vals[PK_OUTBOUND],
                                                      &p->outbound, &p->n_outbound,
                                                      &p->outbound_learn)) < 0)
                return r;
        if (vals[PK_INBOUND] && (r = parse_peer_list(c, "inbound", vals[PK_INBOUND],
                                                     &p->inbound, &p->n_inbound,
                                                     &p->inbound_learn)) < 0)
                return r;
        return parse_peer_dialect(c, keys, vals, p, crlf);
}

static int parse_peers(struct ctx *c, const struct ynode *n, bool crlf,
                       struct config_sharedlink *sl)
{
        const struct ynode *address_nodes[CONFIG_PEERS_MAX];
        int r = need_kind(c, "peers", n, YNODE_SEQUENCE);

        if (r < 0)
                return r;
        if (n->count == 0)
                return fail(c, n, "peers: at least one peer is needed");
        for (const struct ynode *item = child(c, n->first); item; item = next(c, item)) {
                struct config_peer *p;

                if (sl->n_peers >= CONFIG_PEERS_MAX)
                        return fail(c, item, "too many peers (at most %u)", CONFIG_PEERS_MAX);
                /* Counted before parsing: config_free() then sees its variable lists. */
                p = &sl->peers[sl->n_peers++];
                r = parse_peer(c, item, sl->address, crlf, p, &address_nodes[sl->n_peers - 1]);
                if (r < 0)
                        return r;
                for (unsigned i = 0; i + 1 < sl->n_peers; i++)
                        if (sl->peers[i].address == p->address)
                                return fail(c, address_nodes[sl->n_peers - 1],
                                            "duplicate peer address %c (first at %u:%u)",
                                            p->address, address_nodes[i]->line,
                                            address_nodes[i]->column);
        }
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * CIRCE emulated devices */

enum { EK_ADDRESS, EK_CAPABILITIES, EK_SIGNAL, EK_BATTERY, EK_ROLES, EK_MEMBERSHIP, EK_COUNT };
static const char *const emulate_keys[EK_COUNT] = {
        [EK_ADDRESS] = "address", [EK_CAPABILITIES] = "capabilities", [EK_SIGNAL] = "signal",
        [EK_BATTERY] = "battery", [EK_ROLES] = "roles", [EK_MEMBERSHIP] = "membership",
};

static int parse_emulated(struct ctx *c, const struct ynode *n, struct config_emulated_device *d,
                          const struct ynode **ret_address_node)
{
        const struct ynode *keys[EK_COUNT], *vals[EK_COUNT];
        uint32_t v;
        int r = need_kind(c, "emulated device", n, YNODE_MAPPING);

        if (r < 0)
                return r;
        r = map_read(c, n, "in emulated device", emulate_keys, EK_COUNT, keys, vals);
        if (r < 0)
                return r;
        if (!vals[EK_ADDRESS])
                return fail(c, n, "missing key \"address\" in emulated device");
        r = get_circe_address(c, "address", vals[EK_ADDRESS], &d->address);
        if (r < 0)
                return r;
        *ret_address_node = vals[EK_ADDRESS];
        if (!vals[EK_CAPABILITIES])
                return fail(c, n, "missing key \"capabilities\" in emulated device");
        r = get_uint(c, "capabilities", vals[EK_CAPABILITIES], CONFIG_CIRCE_CAPABILITIES_MIN,
                     CIRCE_CAPABILITIES_MAX, &v);
        if (r < 0)
                return r;
        d->capabilities = (uint8_t)v;
        v = CONFIG_CIRCE_SIGNAL_DEFAULT;
        if (vals[EK_SIGNAL] &&
            (r = get_uint(c, "signal", vals[EK_SIGNAL], 0, CIRCE_LEVEL_MAX, &v)) < 0)
                return r;
        d->signal = (uint8_t)v;
        if (vals[EK_BATTERY]) {
                r = get_uint(c, "battery", vals[EK_BATTERY], 0, CIRCE_LEVEL_MAX, &v);
                if (r < 0)
                        return r;
                d->battery = (uint8_t)v;
                d->has_battery = true;
        }
        v = 0;
        if (vals[EK_ROLES] &&
            (r = get_uint(c, "roles", vals[EK_ROLES], 0, CIRCE_ROLES_MAX, &v)) < 0)
                return r;
        d->roles = (uint8_t)v;
        if (vals[EK_MEMBERSHIP] &&
            (r = get_bool(c, "membership", vals[EK_MEMBERSHIP], &d->membership)) < 0)
                return r;
        return 0;
}

static int parse_emulate(struct ctx *c, const struct ynode *n, struct config_circe *ci)
{
        const struct ynode *address_nodes[CONFIG_EMULATE_MAX];
        int r = need_kind(c, "emulate", n, YNODE_SEQUENCE);

        if (r < 0)
                return r;
        for (const struct ynode *item = child(c, n->first); item; item = next(c, item)) {
                struct config_emulated_device *d;

                if (ci->n_emulate >= CONFIG_EMULATE_MAX)
                        return fail(c, item, "too many emulated devices (at most %u)",
                                    CONFIG_EMULATE_MAX);
                d = &ci->emulate[ci->n_emulate];
                r = parse_emulated(c, item, d, &address_nodes[ci->n_emulate]);
                if (r < 0)
                        return r;
                for (unsigned i = 0; i < ci->n_emulate; i++)
                        if (ci->emulate[i].address == d->address)
                                return fail(c, address_nodes[ci->n_emulate],
                                            "duplicate emulated device %06X (first at %u:%u)",
                                            d->address, address_nodes[i]->line,
                                            address_nodes[i]->column);
                ci->n_emulate++;
        }
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Links */

enum {
        LK_NAME, LK_PROTOCOL, LK_TRANSPORT, LK_ROLE, LK_DEVICE, LK_DEVICES, LK_BAUD, LK_PARITY,
        LK_DATA_BITS, LK_STOP_BITS, LK_FLOW_CONTROL, LK_LOCAL, LK_REMOTE, LK_ADDRESS, LK_PEERS,
        LK_CHECKSUM, LK_EXPECT_VERSION, LK_LOGIN_TIMEOUT_MS, LK_IDLE_TIMEOUT_MS, LK_VERSION,
        LK_STATUS, LK_KEEPALIVE_MS, LK_EMULATE, LK_CRLF, LK_COUNT
};

/* Where a link key applies: protocol/role bits and transport bits. */
enum {
        SCOPE_SL = 1 << 0,
        SCOPE_CONTROLLER = 1 << 1,
        SCOPE_MEDIATOR = 1 << 2,
        SCOPE_CIRCE = SCOPE_CONTROLLER | SCOPE_MEDIATOR,
        SCOPE_ANY_PROTOCOL = SCOPE_SL | SCOPE_CIRCE,
        SCOPE_SERIAL = 1 << 3,
        SCOPE_UDP = 1 << 4,
        SCOPE_PTY = 1 << 5,
        SCOPE_TTY = SCOPE_SERIAL | SCOPE_PTY,
        SCOPE_ANY_TRANSPORT = SCOPE_TTY | SCOPE_UDP,
        SCOPE_ANY = SCOPE_ANY_PROTOCOL | SCOPE_ANY_TRANSPORT,
};

static const struct link_key {
        const char *name;
        unsigned scope;
} link_keys[LK_COUNT] = {
        [LK_NAME] = { "name", SCOPE_ANY },
        [LK_PROTOCOL] = { "protocol", SCOPE_ANY },
        [LK_TRANSPORT] = { "transport", SCOPE_ANY },
        [LK_ROLE] = { "role", SCOPE_CIRCE | SCOPE_ANY_TRANSPORT },
        [LK_DEVICE] = { "device", SCOPE_ANY_PROTOCOL | SCOPE_TTY },
        [LK_DEVICES] = { "devices", SCOPE_ANY_PROTOCOL | SCOPE_SERIAL },
        [LK_BAUD] = { "baud", SCOPE_ANY_PROTOCOL | SCOPE_TTY },
        [LK_PARITY] = { "parity", SCOPE_ANY_PROTOCOL | SCOPE_TTY },
        [LK_DATA_BITS] = { "data_bits", SCOPE_ANY_PROTOCOL | SCOPE_TTY },
        [LK_STOP_BITS] = { "stop_bits", SCOPE_ANY_PROTOCOL | SCOPE_TTY },
        [LK_FLOW_CONTROL] = { "flow_control", SCOPE_ANY_PROTOCOL | SCOPE_TTY },
        [LK_LOCAL] = { "local", SCOPE_ANY_PROTOCOL | SCOPE_UDP },
        [LK_REMOTE] = { "remote", SCOPE_ANY_PROTOCOL | SCOPE_UDP },
        [LK_ADDRESS] = { "address", SCOPE_SL | SCOPE_MEDIATOR | SCOPE_ANY_TRANSPORT },
        [LK_PEERS] = { "peers", SCOPE_SL | SCOPE_ANY_TRANSPORT },
        [LK_CHECKSUM] = { "checksum", SCOPE_CIRCE | SCOPE_ANY_TRANSPORT },
        [LK_EXPECT_VERSION] = { "expect_version", SCOPE_CONTROLLER | SCOPE_ANY_TRANSPORT },
        [LK_LOGIN_TIMEOUT_MS] = { "login_timeout_ms", SCOPE_CONTROLLER | SCOPE_ANY_TRANSPORT },
        [LK_IDLE_TIMEOUT_MS] = { "idle_timeout_ms", SCOPE_CONTROLLER | SCOPE_ANY_TRANSPORT },
        [LK_VERSION] = { "version", SCOPE_MEDIATOR | SCOPE_ANY_TRANSPORT },
        [LK_STATUS] = { "status", SCOPE_MEDIATOR | SCOPE_ANY_TRANSPORT },
        [LK_KEEPALIVE_MS] = { "keepalive_ms", SCOPE_MEDIATOR | SCOPE_ANY_TRANSPORT },
        [LK_EMULATE] = { "emulate", SCOPE_MEDIATOR | SCOPE_ANY_TRANSPORT },
        [LK_CRLF] = { "crlf", SCOPE_SL | SCOPE_UDP },
};

static unsigned link_scope(const struct config_link *l)
{
        unsigned s;

        if (l->protocol == CONFIG_PROTOCOL_SHAREDLINK)
                s = SCOPE_SL;
        else
                s = l->circe.role == CONFIG_ROLE_CONTROLLER ? SCOPE_CONTROLLER : SCOPE_MEDIATOR;
        switch (l->transport) {
        case CONFIG_TRANSPORT_SERIAL:
                return s | SCOPE_SERIAL;
        case CONFIG_TRANSPORT_UDP:
                return s | SCOPE_UDP;
        case CONFIG_TRANSPORT_PTY:
                return s | SCOPE_PTY;
        }
        return s;
}

/* Every key present must apply to this protocol, role and transport; checked in file order. */
static int link_check_scope(struct ctx *c, const struct ynode *map, const struct config_link *l)
{
        unsigned scope = link_scope(l);

        for (const struct ynode *k = child(c, map->first); k; k = next(c, next(c, k))) {
                const struct link_key *lk = &link_keys[0];

                /* map_read() has accepted every key, so each is in the table. */
                while (!scalar_is(k, lk->name))
                        lk++;
                if ((lk->scope & scope & SCOPE_ANY_PROTOCOL) == 0) {
                        if (l->protocol == CONFIG_PROTOCOL_CIRCE && (lk->scope & SCOPE_CIRCE))
                                return fail(c, k, "key %s is not valid for role %s",
                                            quote_node(c, k), config_role_name(l->circe.role));
                        return fail(c, k, "key %s is not valid for protocol %s", quote_node(c, k),
                                    config_protocol_name(l->protocol));
                }
                if ((lk->scope & scope & SCOPE_ANY_TRANSPORT) == 0)
                        return fail(c, k, "key %s is not valid for transport %s",
                                    quote_node(c, k), config_transport_name(l->transport));
        }
        return 0;
}

static int parse_devices(struct ctx *c, const struct ynode *const *keys,
                         const struct ynode *const *vals, const struct ynode *map,
                         struct config_link *l, unsigned link_index)
{
        const struct ynode **nodes = c->device_nodes[link_index];
        int r;

        if (vals[LK_DEVICE] && vals[LK_DEVICES])
                return fail(c, keys[LK_DEVICES], "keys \"device\" and \"devices\" are exclusive");
        if (vals[LK_DEVICE]) {
                nodes[0] = vals[LK_DEVICE];
                l->n_devices = 1;
                return get_path(c, "device", vals[LK_DEVICE], l->devices[0],
                                sizeof(l->devices[0]));
        }
        if (!vals[LK_DEVICES])
                return fail(c, map, l->transport == CONFIG_TRANSPORT_PTY
                                ? "missing key \"device\" in link"
                                : "missing key \"device\" (or \"devices\") in link");
        r = need_kind(c, "devices", vals[LK_DEVICES], YNODE_SEQUENCE);
        if (r < 0)
                return r;
        if (vals[LK_DEVICES]->count == 0)
                return fail(c, vals[LK_DEVICES], "devices: at least one device is needed");
        for (const struct ynode *item = child(c, vals[LK_DEVICES]->first); item;
             item = next(c, item)) {
                if (l->n_devices >= CONFIG_DEVICES_MAX)
                        return fail(c, item, "too many devices (at most %u)", CONFIG_DEVICES_MAX);
                nodes[l->n_devices] = item;
                r = get_path(c, "devices", item, l->devices[l->n_devices],
                             sizeof(l->devices[0]));
                if (r < 0)
                        return r;
                l->n_devices++;
        }
        return 0;
}

static int parse_serial(struct ctx *c, const struct ynode *const *vals, struct config_serial *s)
{
        uint32_t v;
        int e, r;

        if (vals[LK_BAUD] && (r = get_uint(c, "baud", vals[LK_BAUD], CONFIG_BAUD_MIN,
                                           CONFIG_BAUD_MAX, &s->baud)) < 0)
                return r;
        if (vals[LK_PARITY]) {
                r = get_enum(c, "parity", vals[LK_PARITY], parity_names,
                             ENUM_COUNT(parity_names), &e);
                if (r < 0)
                        return r;
                s->parity = (enum config_parity)e;
        }
        if (vals[LK_DATA_BITS]) {
                r = get_uint(c, "data_bits", vals[LK_DATA_BITS], 7, 8, &v);
                if (r < 0)
                        return r;
                s->data_bits = (uint8_t)v;
        }
        if (vals[LK_STOP_BITS]) {
                r = get_uint(c, "stop_bits", vals[LK_STOP_BITS], 1, 2, &v);
                if (r < 0)
                        return r;
                s->stop_bits = (uint8_t)v;
        }
        if (vals[LK_FLOW_CONTROL]) {
                r = get_enum(c, "flow_control", vals[LK_FLOW_CONTROL], flow_names,
                             ENUM_COUNT(flow_names), &e);
                if (r < 0)
                        return r;
                s->flow_control = (enum config_flow)e;
        }
        return 0;
}

/*
 * crlf (udp only) defaults to on when a peer is pronto4: the public C++ adapter aborts on a
 * datagram without "]\r\n". A byte stream always ends frames with CR LF, so the one-frame checks
 * of pronto4 peers count it on every transport, and on udp unless crlf: false says otherwise.
 */
static int parse_link_sharedlink(struct ctx *c, const struct ynode *const *vals,
                                 const struct ynode *map, enum config_transport transport,
                                 struct config_sharedlink *sl)
{
        bool crlf_set = false;
        int r;

        if (!vals[LK_ADDRESS])
                return fail(c, map, "missing key \"address\" in link");
        r = get_sl_address(c, "address", vals[LK_ADDRESS], &sl->address);
        if (r < 0)
                return r;
        if (vals[LK_CRLF]) {
                r = get_bool(c, "crlf", vals[LK_CRLF], &sl->crlf);
                if (r < 0)
                        return r;
                crlf_set = true;
        }
        if (!vals[LK_PEERS])
                return fail(c, map, "missing key \"peers\" in link");
        r = parse_peers(c, vals[LK_PEERS], transport != CONFIG_TRANSPORT_UDP || !crlf_set ||
                        sl->crlf, sl);
        if (r < 0 || crlf_set || transport != CONFIG_TRANSPORT_UDP)
                return r;
        for (unsigned i = 0; i < sl->n_peers; i++)
                sl->crlf |= sl->peers[i].dialect == CONFIG_DIALECT_PRONTO4;
        return 0;
}

static int parse_link_circe(struct ctx *c, const struct ynode *const *vals,
                            struct config_circe *ci)
{
        uint32_t v;
        int r;

        ci->checksum = true;
        ci->login_timeout_ms = CONFIG_LOGIN_TIMEOUT_MS_DEFAULT;
        ci->idle_timeout_ms = CONFIG_IDLE_TIMEOUT_MS_DEFAULT;
        ci->keepalive_ms = CONFIG_KEEPALIVE_MS_DEFAULT;
        ci->expect_version = (struct config_circe_version){ "0.2", 0, 2, 0 };
        ci->version = (struct config_circe_version){ "0.2.3", 0, 2, 3 };
        if (vals[LK_CHECKSUM] && (r = get_bool(c, "checksum", vals[LK_CHECKSUM],
                                               &ci->checksum)) < 0)
                return r;
        if (vals[LK_EXPECT_VERSION] &&
            (r = get_circe_version(c, "expect_version", vals[LK_EXPECT_VERSION], 2,
                                   &ci->expect_version)) < 0)
                return r;
        if (vals[LK_LOGIN_TIMEOUT_MS] &&
            (r = get_uint(c, "login_timeout_ms", vals[LK_LOGIN_TIMEOUT_MS], CONFIG_TIMEOUT_MS_MIN,
                          CONFIG_TIMEOUT_MS_MAX, &ci->login_timeout_ms)) < 0)
                return r;
        if (vals[LK_IDLE_TIMEOUT_MS] &&
            (r = get_uint(c, "idle_timeout_ms", vals[LK_IDLE_TIMEOUT_MS], CONFIG_TIMEOUT_MS_MIN,
                          CONFIG_TIMEOUT_MS_MAX, &ci->idle_timeout_ms)) < 0)
                return r;
        if (vals[LK_VERSION] && (r = get_circe_version(c, "version", vals[LK_VERSION], 3,
                                                       &ci->version)) < 0)
                return r;
        if (vals[LK_STATUS]) {
                r = get_uint(c, "status", vals[LK_STATUS], 0, CIRCE_STATUS_MAX, &v);
                if (r < 0)
                        return r;
                ci->status = (uint16_t)v;
        }
        if (vals[LK_ADDRESS]) {
                r = get_circe_address(c, "address", vals[LK_ADDRESS], &ci->address);
                if (r < 0)
                        return r;
                ci->has_address = true;
        }
        if (vals[LK_KEEPALIVE_MS] &&
            (r = get_uint(c, "keepalive_ms", vals[LK_KEEPALIVE_MS], CONFIG_KEEPALIVE_MS_MIN,
                          CONFIG_KEEPALIVE_MS_MAX, &ci->keepalive_ms)) < 0)
                return r;
        if (vals[LK_EMULATE] && (r = parse_emulate(c, vals[LK_EMULATE], ci)) < 0)
                return r;
        return 0;
}

static int parse_link_name(struct ctx *c, const struct ynode *map,
                           const struct ynode *const *vals, unsigned index)
{
        struct config_link *l = &c->cfg->links[index];
        int r;

        if (!vals[LK_NAME])
                return fail(c, map, "missing key \"name\" in link");
        r = get_ident(c, "link name", vals[LK_NAME], l->name, sizeof(l->name));
        if (r < 0)
                return r;
        c->link_name_nodes[index] = vals[LK_NAME];
        for (unsigned i = 0; i < index; i++)
                if (strcmp(c->cfg->links[i].name, l->name) == 0)
                        return fail(c, vals[LK_NAME], "duplicate link name %s (first at %u:%u)",
                                    quote_node(c, vals[LK_NAME]), c->link_name_nodes[i]->line,
                                    c->link_name_nodes[i]->column);
        return 0;
}

static int get_required_enum(struct ctx *c, const struct ynode *map, const char *key,
                             const struct ynode *n, const struct enum_name *names, size_t count,
                             int *ret)
{
        if (!n)
                return fail(c, map, "missing key \"%s\" in link", key);
        return get_enum(c, key, n, names, count, ret);
}

/* Protocol, transport and role: what every other key of the link is checked against. */
static int parse_link_kind(struct ctx *c, const struct ynode *map,
                           const struct ynode *const *vals, struct config_link *l)
{
        int e, r;

        r = get_required_enum(c, map, "protocol", vals[LK_PROTOCOL], protocol_names,
                              ENUM_COUNT(protocol_names), &e);
        if (r < 0)
                return r;
        l->protocol = (enum config_protocol)e;
        r = get_required_enum(c, map, "transport", vals[LK_TRANSPORT], transport_names,
                              ENUM_COUNT(transport_names), &e);
        if (r < 0)
                return r;
        l->transport = (enum config_transport)e;
        l->circe.role = CONFIG_ROLE_NONE;
        if (l->protocol == CONFIG_PROTOCOL_CIRCE) {
                r = get_required_enum(c, map, "role", vals[LK_ROLE], role_names,
                                      ENUM_COUNT(role_names), &e);
                if (r < 0)
                        return r;
                l->circe.role = (enum config_role)e;
        }
        return link_check_scope(c, map, l);
}

static int parse_link_transport(struct ctx *c, const struct ynode *map,
                                const struct ynode *const *keys, const struct ynode *const *vals,
                                unsigned index)
{
        struct config_link *l = &c->cfg->links[index];
        int r;

        l->serial = (struct config_serial){ CONFIG_BAUD_DEFAULT, CONFIG_PARITY_NONE, 8, 1,
                                            CONFIG_FLOW_NONE };
        if (l->transport != CONFIG_TRANSPORT_UDP) {
                r = parse_devices(c, keys, vals, map, l, index);
                if (r < 0)
                        return r;
                return parse_serial(c, vals, &l->serial);
        }
        if (!vals[LK_LOCAL])
                return fail(c, map, "missing key \"local\" in link");
        r = get_endpoint(c, "local", vals[LK_LOCAL], 0, &l->local);
        if (r < 0)
                return r;
        if (vals[LK_REMOTE]) {
                r = get_endpoint(c, "remote", vals[LK_REMOTE], 1, &l->remote);
                if (r < 0)
                        return r;
                l->has_remote = true;
        }
        return 0;
}

static int parse_link(struct ctx *c, const struct ynode *map, unsigned index)
{
        const char *key_names[LK_COUNT];
        const struct ynode *keys[LK_COUNT], *vals[LK_COUNT];
        struct config_link *l = &c->cfg->links[index];
        int r;

        r = need_kind(c, "link", map, YNODE_MAPPING);
        if (r < 0)
                return r;
        for (size_t i = 0; i < LK_COUNT; i++)
                key_names[i] = link_keys[i].name;
        r = map_read(c, map, "in link", key_names, LK_COUNT, keys, vals);
        if (r < 0)
                return r;
        r = parse_link_name(c, map, vals, index);
        if (r < 0)
                return r;
        r = parse_link_kind(c, map, vals, l);
        if (r < 0)
                return r;
        r = parse_link_transport(c, map, keys, vals, index);
        if (r < 0)
                return r;
        if (l->protocol == CONFIG_PROTOCOL_SHAREDLINK)
                return parse_link_sharedlink(c, vals, map, l->transport, &l->sl);
        return parse_link_circe(c, vals, &l->circe);
}

static int parse_links(struct ctx *c, const struct ynode *n)
{
        unsigned i = 0;
        int r = need_kind(c, "links", n, YNODE_SEQUENCE);

        if (r < 0)
                return r;
        if (n->count == 0)
                return fail(c, n, "links: at least one link is needed");
        for (const struct ynode *item = child(c, n->first); item; item = next(c, item), i++) {
                if (i >= CONFIG_LINKS_MAX)
                        return fail(c, item, "too many links (at most %u)", CONFIG_LINKS_MAX);
                c->cfg->n_links = i + 1;        /* config_free() then sees this link's lists */
                r = parse_link(c, item, i);
                if (r < 0)
                        return r;
        }
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Whole-instance checks */

/*
 * A serial path is opened by one link only, a pty path created by one link only; one pty link and
 * one serial link on the same path is the back-to-back setup of the demo.
 */
static int check_devices(struct ctx *c)
{
        const struct config *cfg = c->cfg;

        for (unsigned a = 0; a < cfg->n_links; a++) {
                for (unsigned i = 0; i < cfg->links[a].n_devices; i++) {
                        for (unsigned b = 0; b <= a; b++) {
                                const struct config_link *la = &cfg->links[a], *lb = &cfg->links[b];
                                unsigned end = b == a ? i : lb->n_devices;

                                if (la->transport != lb->transport)
                                        continue;
                                for (unsigned j = 0; j < end; j++)
                                        if (strcmp(la->devices[i], lb->devices[j]) == 0)
                                                return fail(c, c->device_nodes[a][i],
                                                            "device %s is already used by link "
                                                            "\"%s\" (%u:%u)",
                                                            quote_node(c, c->device_nodes[a][i]),
                                                            lb->name,
                                                            c->device_nodes[b][j]->line,
                                                            c->device_nodes[b][j]->column);
                        }
                }
        }
        return 0;
}

/* CIRCE links publish "<link>.…" names (DESIGN.md §2.8): no configured variable may start so. */
static int check_reserved_names(struct ctx *c)
{
        const struct config *cfg = c->cfg;

        for (unsigned v = 0; v < cfg->n_vars; v++) {
                for (unsigned i = 0; i < cfg->n_links; i++) {
                        const struct config_link *l = &cfg->links[i];
                        size_t len = strlen(l->name);

                        if (l->protocol == CONFIG_PROTOCOL_CIRCE &&
                            strncmp(c->vars[v].name, l->name, len) == 0 &&
                            c->vars[v].name[len] == '.')
                                return fail(c, c->vars[v].node, "variable name %s is in the "
                                            "namespace of circe link \"%s\"",
                                            quote_node(c, c->vars[v].node), l->name);
                }
        }
        return 0;
}

/* The control socket "<runtime_dir>/<instance>.sock" must fit in sun_path. */
static int check_socket_path(struct ctx *c)
{
        size_t len = strlen(c->cfg->runtime_dir) + 1 + strlen(c->cfg->instance) +
                     strlen(SOCKET_SUFFIX);

        if (len < CONFIG_SOCKET_PATH_MAX)
                return 0;
        if (c->runtime_dir_node)
                return fail(c, c->runtime_dir_node, "runtime_dir %s too long: the control socket "
                            "path would be %zu bytes (at most %u)",
                            quote_node(c, c->runtime_dir_node), len, CONFIG_SOCKET_PATH_MAX - 1);
        return 0;       /* default runtime_dir + instance of <= 32 bytes always fits */
}

/* ---------------------------------------------------------------------------------------------
 * Top level */

enum { TK_INSTANCE, TK_RUNTIME_DIR, TK_GROUP, TK_LINKS, TK_COUNT };
static const char *const top_keys[TK_COUNT] = {
        [TK_INSTANCE] = "instance", [TK_RUNTIME_DIR] = "runtime_dir", [TK_GROUP] = "group",
        [TK_LINKS] = "links",
};

static int parse_root(struct ctx *c, uint32_t root_index)
{
        const struct ynode *keys[TK_COUNT], *vals[TK_COUNT];
        const struct ynode *root = child(c, root_index);
        struct config *cfg = c->cfg;
        int r;

        if (!root || is_null(root))
                return fail_at(c, 1, 1, "empty configuration");
        if (root->kind != YNODE_MAPPING)
                return fail(c, root, "the configuration must be a mapping, not %s",
                            describe(c, root));
        r = map_read(c, root, "at top level", top_keys, TK_COUNT, keys, vals);
        if (r < 0)
                return r;

        strcpy(cfg->instance, CONFIG_INSTANCE_DEFAULT);
        strcpy(cfg->runtime_dir, CONFIG_RUNTIME_DIR_DEFAULT);
        if (vals[TK_INSTANCE] && (r = get_ident(c, "instance", vals[TK_INSTANCE], cfg->instance,
                                                sizeof(cfg->instance))) < 0)
                return r;
        if (vals[TK_RUNTIME_DIR]) {
                r = get_path(c, "runtime_dir", vals[TK_RUNTIME_DIR], cfg->runtime_dir,
                             sizeof(cfg->runtime_dir));
                if (r < 0)
                        return r;
                c->runtime_dir_node = vals[TK_RUNTIME_DIR];
                cfg->runtime_dir_set = true;
        }
        if (vals[TK_GROUP] && (r = get_group(c, vals[TK_GROUP], cfg->group,
                                             sizeof(cfg->group))) < 0)
                return r;
        if (!vals[TK_LINKS])
                return fail(c, root, "missing key \"links\"");
        r = parse_links(c, vals[TK_LINKS]);
        if (r < 0)
                return r;
        r = check_devices(c);
        if (r < 0)
                return r;
        r = check_reserved_names(c);
        if (r < 0)
                return r;
        return check_socket_path(c);
}

/* ---------------------------------------------------------------------------------------------
 * API */

int config_parse(const char *text, size_t len, const char *filename, struct config **ret_config,
                 struct config_error *ret_error)
{
        static const char bom[] = "\xEF\xBB\xBF";
        struct config_error err = { 0 };
        struct ctx *c;
        uint32_t root = YNONE;
        int r;

        if (!filename)
                filename = "<config>";
        if (!text && len == 0)
                text = "";      /* libyaml asserts on a NULL input, even an empty one */
        /* The context holds a few tens of kilobytes of bookkeeping: heap, not stack. */
        c = calloc(1, sizeof(*c));
        if (!c) {
                snprintf(err.message, sizeof(err.message), "%s: out of memory", filename);
                r = -ENOMEM;
                goto out;
        }
        c->filename = filename;
        c->err = &err;
        if (!text) {
                r = fail_at(c, 0, 0, "no input");
                goto out;
        }
        if (len > CONFIG_INPUT_MAX) {
                fail_at(c, 0, 0, "too large (%zu bytes, at most %u)", len, CONFIG_INPUT_MAX);
                r = -EFBIG;
                goto out;
        }
        /*
         * With the encoding forced to UTF-8 libyaml would count a BOM as a column of the first
         * line; dropping it here keeps positions what an editor shows.
         */
        if (len >= sizeof(bom) - 1 && memcmp(text, bom, sizeof(bom) - 1) == 0) {
                text += sizeof(bom) - 1;
                len -= sizeof(bom) - 1;
        }
        c->text = text;
        c->text_len = len;
        c->cfg = calloc(1, sizeof(*c->cfg));
        if (!c->cfg) {
                r = fail_nomem(c);
                goto out;
        }
        r = tree_build(c, &root);
        if (r == 0)
                r = parse_root(c, root);
        if (r == 0) {
                *ret_config = c->cfg;
                c->cfg = NULL;
        }
out:
        if (c) {
                config_free(c->cfg);
                nodes_free(c);
                free(c);
        }
        if (r < 0 && ret_error)
                *ret_error = err;
        return r;
}

int config_load_file(const char *path, struct config **ret_config, struct config_error *ret_error)
{
        char *buf;
        size_t n = 0;
        int fd, r;

        buf = malloc(CONFIG_INPUT_MAX + 1);
        if (!buf) {
                r = -ENOMEM;
                goto io_error;
        }
        fd = open(path, O_RDONLY | O_CLOEXEC | O_NOCTTY);
        if (fd < 0) {
                r = -errno;
                goto io_error;
        }
        /* One byte more than allowed, so an oversized file is told apart from a full one. */
        while (n < CONFIG_INPUT_MAX + 1) {
                ssize_t k = read(fd, buf + n, CONFIG_INPUT_MAX + 1 - n);

                if (k < 0 && errno == EINTR)
                        continue;
                if (k < 0) {
                        r = -errno;
                        close(fd);
                        goto io_error;
                }
                if (k == 0)
                        break;
                n += (size_t)k;
        }
        close(fd);
        r = config_parse(buf, n, path, ret_config, ret_error);
        free(buf);
        return r;

io_error:
        free(buf);
        if (ret_error) {
                memset(ret_error, 0, sizeof(*ret_error));
                snprintf(ret_error->message, sizeof(ret_error->message), "%s: %s", path,
                         strerror(-r));
        }
        return r;
}

struct config *config_free(struct config *config)
{
        if (!config)
                return NULL;
        for (unsigned i = 0; i < config->n_links; i++) {
                struct config_sharedlink *sl = &config->links[i].sl;

                for (unsigned j = 0; j < sl->n_peers; j++) {
                        free(sl->peers[j].outbound);
                        free(sl->peers[j].inbound);
                }
        }
        free(config);
        return NULL;
}

static bool vars_equal(const struct config_var *a, unsigned na, const struct config_var *b,
                       unsigned nb)
{
        if (na != nb)
                return false;
        for (unsigned i = 0; i < na; i++)
                if (a[i].type != b[i].type || strcmp(a[i].name, b[i].name) != 0)
                        return false;
        return true;
}

static bool peer_equal(const struct config_peer *a, const struct config_peer *b)
{
        return a->address == b->address && a->period_ms == b->period_ms &&
               a->refresh_ms == b->refresh_ms && a->min_interval_ms == b->min_interval_ms &&
               a->stale_ms == b->stale_ms && a->max_frame == b->max_frame &&
               a->compression == b->compression && a->on_change == b->on_change &&
               vars_equal(a->outbound, a->n_outbound, b->outbound, b->n_outbound) &&
               vars_equal(a->inbound, a->n_inbound, b->inbound, b->n_inbound) &&
               a->dialect == b->dialect && a->declare == b->declare &&
               a->outbound_learn == b->outbound_learn && a->inbound_learn == b->inbound_learn &&
               a->learn_max == b->learn_max;
}

static bool version_equal(const struct config_circe_version *a,
                          const struct config_circe_version *b)
{
        return strcmp(a->text, b->text) == 0;   /* the numbers follow from the text */
}

static bool emulated_equal(const struct config_emulated_device *a,
                           const struct config_emulated_device *b)
{
        return a->address == b->address && a->capabilities == b->capabilities &&
               a->roles == b->roles && a->signal == b->signal &&
               a->has_battery == b->has_battery && (!a->has_battery || a->battery == b->battery) &&
               a->membership == b->membership;
}

static bool circe_equal(const struct config_circe *a, const struct config_circe *b)
{
        if (a->role != b->role || a->checksum != b->checksum ||
            !version_equal(&a->expect_version, &b->expect_version) ||
            a->login_timeout_ms != b->login_timeout_ms ||
            a->idle_timeout_ms != b->idle_timeout_ms || !version_equal(&a->version, &b->version) ||
            a->status != b->status || a->has_address != b->has_address ||
            (a->has_address && a->address != b->address) || a->keepalive_ms != b->keepalive_ms ||
            a->n_emulate != b->n_emulate)
                return false;
        for (unsigned i = 0; i < a->n_emulate; i++)
                if (!emulated_equal(&a->emulate[i], &b->emulate[i]))
                        return false;
        return true;
}

static bool sharedlink_equal(const struct config_sharedlink *a, const struct config_sharedlink *b)
{
        if (a->address != b->address || a->n_peers != b->n_peers || a->crlf != b->crlf)
                return false;
        for (unsigned i = 0; i < a->n_peers; i++)
                if (!peer_equal(&a->peers[i], &b->peers[i]))
                        return false;
        return true;
}

bool config_link_equal(const struct config_link *a, const struct config_link *b)
{
        if (strcmp(a->name, b->name) != 0 || a->protocol != b->protocol ||
            a->transport != b->transport || a->n_devices != b->n_devices)
                return false;
        for (unsigned i = 0; i < a->n_devices; i++)
                if (strcmp(a->devices[i], b->devices[i]) != 0)
                        return false;
        if (a->serial.baud != b->serial.baud || a->serial.parity != b->serial.parity ||
            a->serial.data_bits != b->serial.data_bits ||
            a->serial.stop_bits != b->serial.stop_bits ||
            a->serial.flow_control != b->serial.flow_control)
                return false;
        /* The text is the address as written; equal text means an equal address. */
        if (strcmp(a->local.text, b->local.text) != 0 || a->has_remote != b->has_remote ||
            strcmp(a->remote.text, b->remote.text) != 0)
                return false;
        if (a->protocol == CONFIG_PROTOCOL_SHAREDLINK)
                return sharedlink_equal(&a->sl, &b->sl);
        return circe_equal(&a->circe, &b->circe);
}

const struct config_link *config_link_find(const struct config *config, const char *name)
{
        for (unsigned i = 0; i < config->n_links; i++)
                if (strcmp(config->links[i].name, name) == 0)
                        return &config->links[i];
        return NULL;
}

const char *config_protocol_name(enum config_protocol protocol)
{
        return enum_lookup(protocol_names, ENUM_COUNT(protocol_names), (int)protocol);
}

const char *config_transport_name(enum config_transport transport)
{
        return enum_lookup(transport_names, ENUM_COUNT(transport_names), (int)transport);
}

const char *config_role_name(enum config_role role)
{
        if (role == CONFIG_ROLE_NONE)
                return "none";
        return enum_lookup(role_names, ENUM_COUNT(role_names), (int)role);
}

const char *config_var_type_name(enum config_var_type type)
{
        return enum_lookup(var_type_names, ENUM_COUNT(var_type_names), (int)type);
}

const char *config_dialect_name(enum config_dialect dialect)
{
        return enum_lookup(dialect_names, ENUM_COUNT(dialect_names), (int)dialect);
}
