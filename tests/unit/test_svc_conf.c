/*
 * svc/conf: the reader's errors with line and column, and a mapping read through a key table
 * (types, ranges, unknown and duplicate keys, nested mappings and their checks, handlers,
 * defaults kept, file order).
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "svc/conf.h"

#define NAME            "t.yaml"
#define INPUT_MAX       4096u
#define NAME_SIZE       8

enum color { COLOR_RED, COLOR_BLUE };

struct settings {
        char name[NAME_SIZE];
        char dir[32];
        uint32_t count;
        int level;
        bool on;
        int color;
        uint32_t lo, hi;                /* inner: lo <= hi */
        unsigned handled;               /* custom: the length of its list */
};

static int check_inner(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                       void *obj)
{
        const struct settings *s = obj;

        if (s->lo > s->hi)
                return conf_fail(c, n, "%s: lo (%u) is more than hi (%u)", k->name, s->lo, s->hi);
        return 0;
}

static int parse_list(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                      void *obj)
{
        int r = conf_need_kind(c, k->name, n, CONF_NODE_SEQUENCE);

        if (r == 0)
                ((struct settings *)obj)->handled = n->count;
        return r;
}

static int check_name(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                      void *obj)
{
        if (strchr(((struct settings *)obj)->name, '/'))
                return conf_fail(c, n, "%s: no '/' here", k->name);
        return 0;
}

static const struct conf_enum_name color_names[] = { { "red", COLOR_RED }, { "blue", COLOR_BLUE } };
static const struct conf_enum colors = { color_names, 2 };

static const struct conf_key inner_keys[] = {
        CONF_KEY_UINT("lo", struct settings, lo, 0, 100),
        CONF_KEY_UINT("hi", struct settings, hi, 0, 100),
};

static const struct conf_key keys[] = {
        { .name = "name", .type = CONF_STRING, CONF_FIELD(struct settings, name),
          .check = check_name },
        CONF_KEY_PATH("dir", struct settings, dir),
        CONF_KEY_UINT("count", struct settings, count, 1, 10),
        CONF_KEY_INT("level", struct settings, level, 0, 3),
        CONF_KEY_BOOL("on", struct settings, on),
        CONF_KEY_ENUM("color", struct settings, color, &colors),
        CONF_KEY_MAPPING("inner", inner_keys, check_inner),
        CONF_KEY_CUSTOM("list", parse_list),
};

static const struct settings defaults = { "dflt", "/d", 5, 1, false, COLOR_RED, 0, 100, 0 };

/* Reads TEXT into *S (from the defaults); the error message in ERR. */
static int read_text(const char *text, size_t len, struct settings *s, char *err, size_t size)
{
        struct conf c;
        uint32_t root = CONF_NONE;
        int r;

        *s = defaults;
        r = conf_init(&c, NAME, text, len, INPUT_MAX);
        if (r == 0)
                r = conf_tree_build(&c, &root);
        if (r == 0 && root != CONF_NONE)
                r = conf_table_read(&c, conf_child(&c, root), "settings", "at top level", keys,
                                    sizeof(keys) / sizeof(keys[0]), s);
        snprintf(err, size, "%s", r < 0 ? c.err.message : "");
        conf_free(&c);
        return r;
}

static void fails(const char *text, int want_r, const char *want)
{
        struct settings s;
        char err[CONF_ERROR_MAX];
        int r = read_text(text, strlen(text), &s, err, sizeof(err));

        if (r != want_r || strcmp(err, want) != 0)
                fail_msg("%s\n  got %d: %s\n  want %d: %s", text, r, err, want_r, want);
}

static void test_values_and_defaults(void **state)
{
        static const char text[] = "name: abc\ndir: /x/y\ncount: 10\nlevel: 3\non: true\n"
                                   "color: blue\ninner: {lo: 7}\nlist: [a, b, c]\n";
        struct settings s;
        char err[CONF_ERROR_MAX];

        (void)state;
        assert_int_equal(read_text(text, strlen(text), &s, err, sizeof(err)), 0);
        assert_string_equal(s.name, "abc");
        assert_string_equal(s.dir, "/x/y");
        assert_int_equal(s.count, 10);
        assert_int_equal(s.level, 3);
        assert_true(s.on);
        assert_int_equal(s.color, COLOR_BLUE);
        assert_int_equal(s.lo, 7);
        assert_int_equal(s.hi, 100);            /* absent: the default stays */
        assert_int_equal(s.handled, 3);

        /* An empty file is no root at all; the caller keeps its defaults. */
        assert_int_equal(read_text("", 0, &s, err, sizeof(err)), 0);
        assert_string_equal(s.name, defaults.name);
        assert_int_equal(s.count, defaults.count);
        assert_int_equal(s.hi, defaults.hi);
        /* A UTF-8 BOM does not count as a column. */
        fails("\xEF\xBB\xBF" "count: 0\n", -EINVAL, NAME ":1:8: count 0 out of range (1..10)");
}

/* A table read that fails, and its message. */
struct bad {
        const char *text, *want;
};

static const struct bad table_errors[] = {
        { "bogus: 1\n", NAME ":1:1: unknown key \"bogus\" at top level" },
        { "on: true\ncount: 2\non: false\n", NAME ":3:1: duplicate key \"on\" (first at 1:1)" },
        { "inner: {lo: 1, x: 2}\n", NAME ":1:16: unknown key \"x\" in inner" },
        { "inner: {lo: 1, lo: 2}\n", NAME ":1:16: duplicate key \"lo\" (first at 1:9)" },
        { "<<: {count: 2}\n", NAME ":1:1: merge keys (\"<<\") are not supported" },
        { "[1]\n", NAME ":1:1: settings: expected a mapping, got a list" },
        { "inner: 5\n", NAME ":1:8: inner: expected a mapping, got \"5\"" },
        { "inner:\n", NAME ":1:7: inner: missing value" },
        /* Ranges, at both ends and beyond 32 bits. */
        { "count: 0\n", NAME ":1:8: count 0 out of range (1..10)" },
        { "count: 11\n", NAME ":1:8: count 11 out of range (1..10)" },
        { "count: -1\n", NAME ":1:8: count -1 out of range (1..10)" },
        { "count: 99999999999999999999999999999\n",
          NAME ":1:8: count 999999999999999999999999... out of range (1..10)" },
        { "level: 4\n", NAME ":1:8: level 4 out of range (0..3)" },
        { "count: 010\n", NAME ":1:8: count: leading zeros are not allowed in \"010\"" },
        { "count: \"3\"\n", NAME ":1:8: count: expected an integer, got a quoted string" },
        { "count: 3x\n", NAME ":1:8: count: expected an integer, got \"3x\"" },
        { "count: ~\n", NAME ":1:8: count: missing value" },
        /* Other types. */
        { "on: yes\n", NAME ":1:5: on: expected true or false, got \"yes\"" },
        { "color: green\n", NAME ":1:8: color: expected red or blue, got \"green\"" },
        { "name: abcdefgh\n", NAME ":1:7: name: \"abcdefgh\" too long (8 bytes, at most 7)" },
        { "name: \"a\\tb\"\n", NAME ":1:7: name: control character in \"a\\x09b\"" },
        { "name: [a]\n", NAME ":1:7: name: expected a string, got a list" },
        { "dir: rel\n", NAME ":1:6: dir: \"rel\" is not an absolute path" },
        { "list: x\n", NAME ":1:7: list: expected a list, got \"x\"" },
        /* Checks: of a key after its value, of a mapping after its keys, at its node. */
        { "name: a/b\n", NAME ":1:7: name: no '/' here" },
        { "inner:\n  lo: 9\n  hi: 8\n", NAME ":2:3: inner: lo (9) is more than hi (8)" },
        /* File order: the first bad key in the file is the one reported. */
        { "on: 1\ncount: 0\n", NAME ":1:5: on: expected true or false, got \"1\"" },
        { "count: 0\non: 1\n", NAME ":1:8: count 0 out of range (1..10)" },
};

static void fails_all(const struct bad *b, size_t n)
{
        for (size_t i = 0; i < n; i++)
                fails(b[i].text, -EINVAL, b[i].want);
}

static void test_table_errors(void **state)
{
        (void)state;
        fails_all(table_errors, sizeof(table_errors) / sizeof(table_errors[0]));
}

static const struct bad yaml_errors[] = {
        { "count: &a 1\n", NAME ":1:8: anchors and aliases are not supported" },
        { "count: !!int 1\n", NAME ":1:8: tags are not supported" },
        { "a: &x 1\nb: *x\n", NAME ":1:4: anchors and aliases are not supported" },
        { "on: true\n---\non: false\n", NAME ":2:1: only one YAML document is allowed" },
        { "list: [a\n",
          NAME ":2:1: did not find expected ',' or ']' (while parsing a flow sequence)" },
        { "on: true\n  count: 1\n", NAME ":2:8: mapping values are not allowed in this context" },
        { "name: \"\xff\"\n", NAME ":1:8: invalid leading UTF-8 octet (0xFF)" },
        { "list: [[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]\n",
          NAME ":1:22: nested deeper than 16 levels" },
};

static void test_yaml_errors(void **state)
{
        static const char nul[] = "count: 1\n\0";
        struct settings s;
        char err[CONF_ERROR_MAX];
        char big[INPUT_MAX + 2];

        (void)state;
        fails_all(yaml_errors, sizeof(yaml_errors) / sizeof(yaml_errors[0]));
        assert_int_equal(read_text(nul, sizeof(nul) - 1, &s, err, sizeof(err)), -EINVAL);
        assert_string_equal(err, NAME ":2:1: control characters are not allowed (0x00)");
        /* The input bound; no input at all. */
        memset(big, ' ', sizeof(big));
        assert_int_equal(read_text(big, INPUT_MAX + 1, &s, err, sizeof(err)), -EFBIG);
        assert_string_equal(err, NAME ": too large (4097 bytes, at most 4096)");
        assert_int_equal(read_text(NULL, 1, &s, err, sizeof(err)), -EINVAL);
        assert_string_equal(err, NAME ": no input");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_values_and_defaults),
                cmocka_unit_test(test_table_errors),
                cmocka_unit_test(test_yaml_errors),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
