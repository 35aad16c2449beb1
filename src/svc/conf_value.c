/*
 * The toolkit's scalar readers and key tables (conf.h): each conf_get_*() takes one node and the
 * key it belongs to, and either stores the value or reports why not; conf_table_read() reads a
 * mapping through a table of keys with those readers.
 */
#include "svc/conf.h"
#include "svc/io.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define ENUM_EXPECTED_MAX       128     /* "a, b or c" in a message */

int conf_need_scalar(struct conf *c, const char *key, const struct conf_node *n,
                     const char *expected)
{
        if (n->kind != CONF_NODE_SCALAR)
                return conf_fail(c, n, "%s: expected %s, got %s", key, expected,
                                 conf_describe(c, n));
        if (conf_is_null(n))
                return conf_fail(c, n, "%s: missing value", key);
        return 0;
}

int conf_get_string(struct conf *c, const char *key, const struct conf_node *n, char *out,
                    size_t size)
{
        int r = conf_need_scalar(c, key, n, "a string");

        if (r < 0)
                return r;
        if (n->len == 0)
                return conf_fail(c, n, "%s: empty string", key);
        for (size_t i = 0; i < n->len; i++) {
                unsigned char ch = (unsigned char)n->text[i];

                if (ch < 0x20 || ch == 0x7f)
                        return conf_fail(c, n, "%s: control character in %s", key,
                                         conf_quote_node(c, n));
        }
        if (n->len >= size)
                return conf_fail(c, n, "%s: %s too long (%zu bytes, at most %zu)", key,
                                 conf_quote_node(c, n), n->len, size - 1);
        memcpy(out, n->text, n->len + 1);
        return 0;
}

/* Plain decimal integer in [min, max]. */
int conf_get_uint(struct conf *c, const char *key, const struct conf_node *n, uint32_t min,
                  uint32_t max, uint32_t *ret)
{
        const char *s;
        bool negative;
        uint64_t v = 0;
        bool overflow = false;
        size_t i;
        int r = conf_need_scalar(c, key, n, "an integer");

        if (r < 0)
                return r;
        if (!n->plain)
                return conf_fail(c, n, "%s: expected an integer, got a quoted string", key);
        s = n->text;
        negative = s[0] == '-';
        i = (s[0] == '-' || s[0] == '+') ? 1 : 0;
        if (i >= n->len)
                return conf_fail(c, n, "%s: expected an integer, got %s", key,
                                 conf_quote_node(c, n));
        for (size_t j = i; j < n->len; j++) {
                if (s[j] < '0' || s[j] > '9')
                        return conf_fail(c, n, "%s: expected an integer, got %s", key,
                                         conf_quote_node(c, n));
                if (v > UINT32_MAX)
                        overflow = true;
                else
                        v = v * 10 + (uint64_t)(s[j] - '0');
        }
        if (s[i] == '0' && n->len - i > 1)
                return conf_fail(c, n, "%s: leading zeros are not allowed in %s", key,
                                 conf_quote_node(c, n));
        if (overflow || (negative && v) || v < min || v > max)
                return conf_fail(c, n, "%s %s out of range (%u..%u)", key,
                                 conf_number_text(c, n->text, n->len), min, max);
        *ret = (uint32_t)v;
        return 0;
}

int conf_get_bool(struct conf *c, const char *key, const struct conf_node *n, bool *ret)
{
        static const char *const truths[] = { "true", "True", "TRUE" };
        static const char *const lies[] = { "false", "False", "FALSE" };
        int r = conf_need_scalar(c, key, n, "true or false");

        if (r < 0)
                return r;
        if (!n->plain)
                return conf_fail(c, n, "%s: expected true or false, got a quoted string", key);
        for (size_t i = 0; i < sizeof(truths) / sizeof(truths[0]); i++) {
                if (conf_scalar_is(n, truths[i])) {
                        *ret = true;
                        return 0;
                }
                if (conf_scalar_is(n, lies[i])) {
                        *ret = false;
                        return 0;
                }
        }
        return conf_fail(c, n, "%s: expected true or false, got %s", key, conf_quote_node(c, n));
}

int conf_get_enum(struct conf *c, const char *key, const struct conf_node *n,
                  const struct conf_enum *e, int *ret)
{
        char expected[ENUM_EXPECTED_MAX];
        size_t o = 0;
        int r = conf_need_scalar(c, key, n, "a name");

        if (r < 0)
                return r;
        for (size_t i = 0; i < e->count; i++) {
                if (conf_scalar_is(n, e->names[i].name)) {
                        *ret = e->names[i].value;
                        return 0;
                }
        }
        for (size_t i = 0; i < e->count && o < sizeof(expected); i++)
                o += (size_t)snprintf(expected + o, sizeof(expected) - o, "%s%s",
                                      i == 0 ? "" : (i + 1 == e->count ? " or " : ", "),
                                      e->names[i].name);
        return conf_fail(c, n, "%s: expected %s, got %s", key, expected, conf_quote_node(c, n));
}

const char *conf_enum_name(const struct conf_enum *e, int value)
{
        for (size_t i = 0; i < e->count; i++)
                if (e->names[i].value == value)
                        return e->names[i].name;
        return "?";
}

int conf_get_path(struct conf *c, const char *key, const struct conf_node *n, char *out,
                  size_t size)
{
        int r = conf_get_string(c, key, n, out, size);

        if (r < 0)
                return r;
        if (out[0] != '/')
                return conf_fail(c, n, "%s: %s is not an absolute path", key,
                                 conf_quote_node(c, n));
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Key tables */

static int key_read(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                    void *obj)
{
        char *field = (char *)obj + k->offset;
        char in[CONF_QUOTE_BUF];
        uint32_t v;
        int e, r;

        switch (k->type) {
        case CONF_STRING:
                return conf_get_string(c, k->name, n, field, k->size);
        case CONF_PATH:
                return conf_get_path(c, k->name, n, field, k->size);
        case CONF_UINT:
                return conf_get_uint(c, k->name, n, k->min, k->max, (uint32_t *)(void *)field);
        case CONF_INT:
                r = conf_get_uint(c, k->name, n, k->min, k->max > INT_MAX ? INT_MAX : k->max,
                                  &v);
                if (r == 0)
                        *(int *)(void *)field = (int)v;
                return r;
        case CONF_BOOL:
                return conf_get_bool(c, k->name, n, (bool *)(void *)field);
        case CONF_ENUM:
                r = conf_get_enum(c, k->name, n, k->names, &e);
                if (r == 0)
                        *(int *)(void *)field = e;
                return r;
        case CONF_MAPPING:
                snprintf(in, sizeof(in), "in %s", k->name);
                return conf_table_read(c, n, k->name, in, k->keys, k->n_keys, obj);
        case CONF_CUSTOM:
                return k->parse(c, k, n, obj);
        }
        return -EINVAL;
}

int conf_table_read(struct conf *c, const struct conf_node *map, const char *what,
                    const char *in, const struct conf_key *keys, size_t n_keys, void *obj)
{
        const struct conf_node *knodes[CONF_TABLE_MAX], *vals[CONF_TABLE_MAX];
        int r;

        if (n_keys > CONF_TABLE_MAX)
                return conf_fail(c, map, "%s: more than %u keys in one table", what,
                                 CONF_TABLE_MAX);
        r = conf_need_kind(c, what, map, CONF_NODE_MAPPING);
        if (r < 0)
                return r;
        r = conf_map_read(c, map, in, keys, n_keys, sizeof(keys[0]), knodes, vals);
        if (r < 0)
                return r;
        /* In file order, so that the first error in the file is the one reported. */
        for (const struct conf_node *kn = conf_child(c, map->first); kn;
             kn = conf_next(c, conf_next(c, kn))) {
                size_t i = 0;

                while (knodes[i] != kn)
                        i++;            /* conf_map_read() filed every key */
                r = key_read(c, &keys[i], vals[i], obj);
                if (r == 0 && keys[i].check)
                        r = keys[i].check(c, &keys[i], vals[i], obj);
                if (r < 0)
                        return r;
        }
        return 0;
}

int conf_read_text(const char *name, const char *text, size_t len, size_t input_max,
                   const struct conf_key *keys, size_t n_keys, void *obj, char *err,
                   size_t err_size)
{
        struct conf *c = malloc(sizeof(*c));
        const struct conf_node *root;
        uint32_t root_index = CONF_NONE;
        int r;

        if (err_size)
                err[0] = '\0';
        if (!c) {
                snprintf(err, err_size, "%s: out of memory", name);
                return -ENOMEM;
        }
        r = conf_init(c, name, text, len, input_max);
        if (r == 0)
                r = conf_tree_build(c, &root_index);
        root = r == 0 ? conf_child(c, root_index) : NULL;
        if (root && !conf_is_null(root))
                r = conf_table_read(c, root, "configuration", "at top level", keys, n_keys, obj);
        if (r < 0)
                snprintf(err, err_size, "%s", c->err.message);
        conf_free(c);
        free(c);
        return r;
}

int conf_read_file(const char *path, size_t input_max, const struct conf_key *keys,
                   size_t n_keys, void *obj, char *err, size_t err_size)
{
        char *text;
        size_t len;
        int r = io_read_file(path, input_max, &text, &len);

        if (r < 0) {
                snprintf(err, err_size, "%s: %s", path,
                         r == -EFBIG ? "file too large" : strerror(-r));
                return r;
        }
        r = conf_read_text(path, text, len, input_max, keys, n_keys, obj, err, err_size);
        free(text);
        return r;
}
