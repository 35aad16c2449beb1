/*
 * The toolkit's YAML reader (conf.h): the only user of libyaml in the project.
 *
 * libyaml's event API builds a small tree of our own (struct conf_node) with the position of
 * every node; the event API lets us refuse anchors, aliases and tags, which the document API
 * would resolve silently (an alias bomb must not reach the schema walker). Merge keys are refused
 * where mappings are read (conf_map_read()). Errors are "FILE:LINE:COL: text", the first one wins.
 */
#include "svc/conf.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <yaml.h>

#define NUMBER_ECHO_MAX         24u     /* digits of an out-of-range number echoed */
#define NODES_INITIAL           256u

/* ---------------------------------------------------------------------------------------------
 * The input */

int conf_init(struct conf *c, const char *filename, const char *text, size_t len,
              size_t input_max)
{
        static const char bom[] = "\xEF\xBB\xBF";

        memset(c, 0, sizeof(*c));
        c->filename = filename ? filename : "<config>";
        if (!text && len == 0)
                text = "";      /* libyaml asserts on a NULL input, even an empty one */
        if (!text)
                return conf_fail_at(c, 0, 0, "no input");
        if (len > input_max) {
                conf_fail_at(c, 0, 0, "too large (%zu bytes, at most %zu)", len, input_max);
                return -EFBIG;
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
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Errors */

static void error_vset(struct conf *c, unsigned line, unsigned column, const char *fmt, va_list ap)
        __attribute__((format(printf, 4, 0)));

static void error_vset(struct conf *c, unsigned line, unsigned column, const char *fmt, va_list ap)
{
        size_t n;
        int k;

        if (c->err.message[0])
                return;         /* the first error wins */
        c->err.line = line;
        c->err.column = column;
        if (line)
                k = snprintf(c->err.message, sizeof(c->err.message), "%s:%u:%u: ", c->filename,
                             line, column);
        else
                k = snprintf(c->err.message, sizeof(c->err.message), "%s: ", c->filename);
        n = k < 0 ? 0 : (size_t)k;
        if (n < sizeof(c->err.message))
                vsnprintf(c->err.message + n, sizeof(c->err.message) - n, fmt, ap);
}

int conf_fail_at(struct conf *c, unsigned line, unsigned column, const char *fmt, ...)
{
        va_list ap;

        va_start(ap, fmt);
        error_vset(c, line, column, fmt, ap);
        va_end(ap);
        return -EINVAL;
}

int conf_fail(struct conf *c, const struct conf_node *n, const char *fmt, ...)
{
        va_list ap;

        va_start(ap, fmt);
        error_vset(c, n->line, n->column, fmt, ap);
        va_end(ap);
        return -EINVAL;
}

int conf_fail_nomem(struct conf *c)
{
        conf_fail_at(c, 0, 0, "out of memory");
        return -ENOMEM;
}

/* User text for a message: quoted, at most CONF_QUOTE_MAX bytes, all but printable ASCII
 * escaped. */
const char *conf_quote(struct conf *c, const char *s, size_t len)
{
        char *out = c->quote[c->quote_next++ % CONF_QUOTE_SLOTS];
        size_t o = 0;

        out[o++] = '"';
        for (size_t i = 0; i < len && i < CONF_QUOTE_MAX; i++) {
                unsigned char ch = (unsigned char)s[i];

                if (ch == '"' || ch == '\\') {
                        out[o++] = '\\';
                        out[o++] = (char)ch;
                } else if (ch < 0x20 || ch >= 0x7f) {
                        o += (size_t)snprintf(out + o, CONF_QUOTE_BUF - o, "\\x%02X", ch);
                } else {
                        out[o++] = (char)ch;
                }
        }
        out[o++] = '"';
        if (len > CONF_QUOTE_MAX) {
                memcpy(out + o, "...", 3);
                o += 3;
        }
        out[o] = '\0';
        return out;
}

/* A number as written (only signs and digits get here), unquoted, cut at NUMBER_ECHO_MAX. */
const char *conf_number_text(struct conf *c, const char *s, size_t len)
{
        char *out = c->quote[c->quote_next++ % CONF_QUOTE_SLOTS];

        snprintf(out, CONF_QUOTE_BUF, "%.*s%s",
                 (int)(len > NUMBER_ECHO_MAX ? NUMBER_ECHO_MAX : len), s,
                 len > NUMBER_ECHO_MAX ? "..." : "");
        return out;
}

const char *conf_quote_node(struct conf *c, const struct conf_node *n)
{
        return conf_quote(c, n->text, n->len);
}

/* What a node is, for "expected X, got Y": a list, a mapping, or the scalar's text. */
const char *conf_describe(struct conf *c, const struct conf_node *n)
{
        switch (n->kind) {
        case CONF_NODE_SEQUENCE:
                return "a list";
        case CONF_NODE_MAPPING:
                return "a mapping";
        case CONF_NODE_SCALAR:
                break;
        }
        return conf_quote_node(c, n);
}

/* ---------------------------------------------------------------------------------------------
 * Events -> tree */

static struct conf_node *node_at(struct conf *c, uint32_t i)
{
        return &c->nodes[i];
}

static int node_add(struct conf *c, enum conf_node_kind kind, const yaml_mark_t *mark,
                    uint32_t parent, uint32_t *ret_index)
{
        struct conf_node *n;

        if (c->n_nodes >= CONF_NODES_MAX)
                return conf_fail_at(c, (unsigned)mark->line + 1, (unsigned)mark->column + 1,
                                    "too many YAML nodes (at most %u)", CONF_NODES_MAX);
        if (c->n_nodes == c->cap_nodes) {
                uint32_t cap = c->cap_nodes ? c->cap_nodes * 2 : NODES_INITIAL;
                struct conf_node *nn = realloc(c->nodes, (size_t)cap * sizeof(*nn));

                if (!nn)
                        return conf_fail_nomem(c);
                c->nodes = nn;
                c->cap_nodes = cap;
        }
        n = &c->nodes[c->n_nodes];
        memset(n, 0, sizeof(*n));
        n->kind = kind;
        n->line = (unsigned)mark->line + 1;
        n->column = (unsigned)mark->column + 1;
        n->first = n->last = n->next = CONF_NONE;
        if (parent != CONF_NONE) {
                struct conf_node *p = node_at(c, parent);

                if (p->last == CONF_NONE)
                        p->first = c->n_nodes;
                else
                        node_at(c, p->last)->next = c->n_nodes;
                p->last = c->n_nodes;
                p->count++;
        }
        *ret_index = c->n_nodes++;
        return 0;
}

void conf_free(struct conf *c)
{
        for (uint32_t i = 0; i < c->n_nodes; i++)
                free(c->nodes[i].text);
        free(c->nodes);
        c->nodes = NULL;
        c->n_nodes = c->cap_nodes = 0;
}

/* Reader errors carry a byte offset, not a mark: count lines and UTF-8 characters up to it. */
static void offset_position(const struct conf *c, size_t offset, unsigned *ret_line,
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

static int yaml_failure(struct conf *c, const yaml_parser_t *p)
{
        const char *problem = p->problem ? p->problem : "syntax error";
        unsigned line, column;

        switch (p->error) {
        case YAML_MEMORY_ERROR:
                return conf_fail_nomem(c);
        case YAML_READER_ERROR:
                offset_position(c, p->problem_offset, &line, &column);
                if (p->problem_value >= 0)
                        return conf_fail_at(c, line, column, "%s (0x%02X)", problem,
                                            (unsigned)p->problem_value);
                return conf_fail_at(c, line, column, "%s", problem);
        default:
                line = (unsigned)p->problem_mark.line + 1;
                column = (unsigned)p->problem_mark.column + 1;
                if (p->context)
                        return conf_fail_at(c, line, column, "%s (%s)", problem, p->context);
                return conf_fail_at(c, line, column, "%s", problem);
        }
}

static int event_node(struct conf *c, const yaml_event_t *ev, uint32_t parent, uint32_t *ret_index)
{
        const yaml_mark_t *m = &ev->start_mark;
        const yaml_char_t *anchor = NULL, *tag = NULL;
        enum conf_node_kind kind;
        int r;

        switch (ev->type) {
        case YAML_SCALAR_EVENT:
                kind = CONF_NODE_SCALAR;
                anchor = ev->data.scalar.anchor;
                tag = ev->data.scalar.tag;
                break;
        case YAML_SEQUENCE_START_EVENT:
                kind = CONF_NODE_SEQUENCE;
                anchor = ev->data.sequence_start.anchor;
                tag = ev->data.sequence_start.tag;
                break;
        default:
                kind = CONF_NODE_MAPPING;
                anchor = ev->data.mapping_start.anchor;
                tag = ev->data.mapping_start.tag;
                break;
        }
        if (anchor)
                return conf_fail_at(c, (unsigned)m->line + 1, (unsigned)m->column + 1,
                                    "anchors and aliases are not supported");
        if (tag)
                return conf_fail_at(c, (unsigned)m->line + 1, (unsigned)m->column + 1,
                                    "tags are not supported");
        r = node_add(c, kind, m, parent, ret_index);
        if (r < 0)
                return r;
        if (kind == CONF_NODE_SCALAR) {
                struct conf_node *n = node_at(c, *ret_index);

                n->len = ev->data.scalar.length;
                n->plain = ev->data.scalar.style == YAML_PLAIN_SCALAR_STYLE;
                n->text = malloc(n->len + 1);
                if (!n->text)
                        return conf_fail_nomem(c);
                memcpy(n->text, ev->data.scalar.value, n->len);
                n->text[n->len] = '\0';
        }
        return 0;
}

/* One event into the tree; *done is set at the end of the stream. */
static int tree_event(struct conf *c, const yaml_event_t *ev, uint32_t *stack, unsigned *depth,
                      uint32_t *root, bool *seen_document, bool *done)
{
        const yaml_mark_t *m = &ev->start_mark;
        uint32_t parent = *depth ? stack[*depth - 1] : CONF_NONE;
        uint32_t index = CONF_NONE;
        int r;

        switch (ev->type) {
        case YAML_STREAM_END_EVENT:
                *done = true;
                return 0;
        case YAML_DOCUMENT_START_EVENT:
                if (*seen_document)
                        return conf_fail_at(c, (unsigned)m->line + 1, (unsigned)m->column + 1,
                                            "only one YAML document is allowed");
                *seen_document = true;
                return 0;
        case YAML_ALIAS_EVENT:
                return conf_fail_at(c, (unsigned)m->line + 1, (unsigned)m->column + 1,
                                    "anchors and aliases are not supported");
        case YAML_SCALAR_EVENT:
        case YAML_SEQUENCE_START_EVENT:
        case YAML_MAPPING_START_EVENT:
                r = event_node(c, ev, parent, &index);
                if (r < 0)
                        return r;
                if (parent == CONF_NONE)
                        *root = index;
                if (ev->type == YAML_SCALAR_EVENT)
                        return 0;
                if (*depth >= CONF_DEPTH_MAX)
                        return conf_fail_at(c, (unsigned)m->line + 1, (unsigned)m->column + 1,
                                            "nested deeper than %u levels", CONF_DEPTH_MAX);
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

int conf_tree_build(struct conf *c, uint32_t *ret_root)
{
        yaml_parser_t parser;
        uint32_t stack[CONF_DEPTH_MAX];
        unsigned depth = 0;
        uint32_t root = CONF_NONE;
        bool seen_document = false, done = false;
        int r = 0;

        if (!yaml_parser_initialize(&parser))
                return conf_fail_nomem(c);
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
 * Walking the tree */

const struct conf_node *conf_child(const struct conf *c, uint32_t i)
{
        return i == CONF_NONE ? NULL : &c->nodes[i];
}

const struct conf_node *conf_next(const struct conf *c, const struct conf_node *n)
{
        return conf_child(c, n->next);
}

/* Exact match: a scalar may hold NULs (from escapes), so strcmp() alone would be fooled. */
bool conf_scalar_is(const struct conf_node *n, const char *s)
{
        return n->kind == CONF_NODE_SCALAR && n->len == strlen(s) &&
               memcmp(n->text, s, n->len) == 0;
}

bool conf_is_null(const struct conf_node *n)
{
        static const char *const nulls[] = { "", "~", "null", "Null", "NULL" };

        if (n->kind != CONF_NODE_SCALAR || !n->plain)
                return false;
        for (size_t i = 0; i < sizeof(nulls) / sizeof(nulls[0]); i++)
                if (conf_scalar_is(n, nulls[i]))
                        return true;
        return false;
}

/* ---------------------------------------------------------------------------------------------
 * Mappings */

/*
 * Checks a mapping's keys against KNOWN (all scalars, no merge key, no unknown key, no duplicate)
 * and files each value under its key's index in vals[] (NULL when absent); keys[] likewise.
 */
int conf_map_read(struct conf *c, const struct conf_node *map, const char *what, const void *known,
                  size_t n_known, size_t stride, const struct conf_node **keys,
                  const struct conf_node **vals)
{
        for (size_t i = 0; i < n_known; i++)
                keys[i] = vals[i] = NULL;
        for (const struct conf_node *k = conf_child(c, map->first); k;
             k = conf_next(c, conf_next(c, k))) {
                const struct conf_node *v = conf_next(c, k);
                size_t i;

                if (k->kind != CONF_NODE_SCALAR)
                        return conf_fail(c, k, "a key must be a string, not %s",
                                         conf_describe(c, k));
                if (k->plain && conf_scalar_is(k, "<<"))
                        return conf_fail(c, k, "merge keys (\"<<\") are not supported");
                for (i = 0; i < n_known; i++)
                        if (conf_scalar_is(k, *(const char *const *)(const void *)
                                           ((const char *)known + i * stride)))
                                break;
                if (i == n_known)
                        return conf_fail(c, k, "unknown key %s %s", conf_quote_node(c, k), what);
                if (keys[i])
                        return conf_fail(c, k, "duplicate key %s (first at %u:%u)",
                                         conf_quote_node(c, k), keys[i]->line, keys[i]->column);
                keys[i] = k;
                vals[i] = v;    /* libyaml always pairs a key with a value, possibly empty */
        }
        return 0;
}

/* A list or a mapping (KIND), where a null value is reported as missing. */
int conf_need_kind(struct conf *c, const char *what, const struct conf_node *n,
                   enum conf_node_kind kind)
{
        if (n->kind == kind)
                return 0;
        if (conf_is_null(n))
                return conf_fail(c, n, "%s: missing value", what);
        return conf_fail(c, n, "%s: expected %s, got %s", what,
                         kind == CONF_NODE_SEQUENCE ? "a list" : "a mapping", conf_describe(c, n));
}
