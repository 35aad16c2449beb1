/*
 * svc/json: the one escaping rule (json.h) byte by byte, through both sinks (a FILE and a
 * buffer), and the buffer writer's overflow.
 */
#define _GNU_SOURCE     /* open_memstream */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "svc/json.h"

#define OUT_MAX         512

struct escape_case {
        const char *in;
        size_t len;                     /* 0: strlen(in) */
        const char *out;
};

static const struct escape_case cases[] = {
        { "plain text 0-9 ~", 0, "\"plain text 0-9 ~\"" },
        { "", 0, "\"\"" },
        { "q\"b\\s/", 0, "\"q\\\"b\\\\s/\"" },
        { "a\nb\rc\td", 0, "\"a\\nb\\rc\\td\"" },
        /* other control characters and DEL */
        { "\x01\x08\x0c\x1f\x7f", 0, "\"\\u0001\\u0008\\u000c\\u001f\\u007f\"" },
        { "a\0b", 3, "\"a\\u0000b\"" },
        /* well-formed UTF-8 passes: 2, 3 and 4 bytes, the edges of each range */
        { "caf\xc3\xa9", 0, "\"caf\xc3\xa9\"" },
        { "\xc2\x80\xdf\xbf", 0, "\"\xc2\x80\xdf\xbf\"" },
        { "\xe2\x82\xac \xe0\xa0\x80 \xef\xbf\xbf \xed\x9f\xbf", 0,
          "\"\xe2\x82\xac \xe0\xa0\x80 \xef\xbf\xbf \xed\x9f\xbf\"" },
        { "\xf0\x9f\x98\x80 \xf4\x8f\xbf\xbf", 0, "\"\xf0\x9f\x98\x80 \xf4\x8f\xbf\xbf\"" },
        /* bytes that are not UTF-8, one escape each */
        { "\x80", 0, "\"\\u0080\"" },
        { "\xff\xfe", 0, "\"\\u00ff\\u00fe\"" },
        { "\xc3", 0, "\"\\u00c3\"" },                          /* cut at the end */
        { "\xc3(", 0, "\"\\u00c3(\"" },                        /* no continuation */
        { "\xe2\x82", 0, "\"\\u00e2\\u0082\"" },              /* cut 3-byte form */
        { "\xc0\x80", 0, "\"\\u00c0\\u0080\"" },              /* overlong NUL */
        { "\xc1\xbf", 0, "\"\\u00c1\\u00bf\"" },              /* overlong */
        { "\xe0\x80\xaf", 0, "\"\\u00e0\\u0080\\u00af\"" },   /* overlong '/' */
        { "\xed\xa0\x80", 0, "\"\\u00ed\\u00a0\\u0080\"" },   /* surrogate U+D800 */
        { "\xf0\x8f\xbf\xbf", 0, "\"\\u00f0\\u008f\\u00bf\\u00bf\"" },    /* overlong */
        { "\xf4\x90\x80\x80", 0, "\"\\u00f4\\u0090\\u0080\\u0080\"" },    /* > U+10FFFF */
        { "\xf5\x80\x80\x80", 0, "\"\\u00f5\\u0080\\u0080\\u0080\"" },
        /* a bad byte between good characters leaves them as they are */
        { "\xc3\xa9\xff\xc3\xa9", 0, "\"\xc3\xa9\\u00ff\xc3\xa9\"" },
        { "\xe2\x82\xc3\xa9", 0, "\"\\u00e2\\u0082\xc3\xa9\"" },
};

static void put(void *arg, const char *s, size_t n)
{
        char *out = arg;
        size_t len = strlen(out);

        assert_true(len + n < OUT_MAX);
        memcpy(out + len, s, n);
        out[len + n] = '\0';
}

static void test_escape_table(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                const struct escape_case *c = &cases[i];
                char out[OUT_MAX] = "";

                json_quote(put, out, c->in, c->len ? c->len : strlen(c->in));
                if (strcmp(out, c->out) != 0)
                        fail_msg("case %zu: got %s, want %s", i, out, c->out);
        }
}

/* The FILE sink and the buffer sink write the same bytes as json_quote(). */
static void test_sinks_agree(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                const struct escape_case *c = &cases[i];
                char buf[OUT_MAX], want[OUT_MAX];
                struct json_buf j;
                char *text = NULL;
                size_t size = 0;
                FILE *f;

                if (c->len)
                        continue;       /* NUL-terminated APIs only */
                f = open_memstream(&text, &size);
                assert_non_null(f);
                json_member_string(f, 1, "k", c->in);
                fclose(f);
                snprintf(want, sizeof(want), "\"k\":%s", c->out);
                assert_string_equal(text, want);
                free(text);

                json_buf_begin(&j, buf, sizeof(buf));
                json_buf_str(&j, "k", c->in);
                assert_true(json_buf_end(&j) > 0);
                snprintf(want, sizeof(want), "{\"k\":%s}", c->out);
                assert_string_equal(buf, want);
        }
}

static void test_buf_members_and_overflow(void **state)
{
        static const char want[] = "{\"n\":18446744073709551615,\"t\":true,\"f\":false,"
                                   "\"o\":{\"a\":\"x\"}}";
        char buf[sizeof(want)];
        struct json_buf j;

        (void)state;
        json_buf_begin(&j, buf, sizeof(buf));
        json_buf_u64(&j, "n", UINT64_MAX);
        json_buf_bool(&j, "t", true);
        json_buf_bool(&j, "f", false);
        json_buf_key(&j, "o");
        json_buf_raw(&j, "{", 1);
        json_buf_quoted(&j, "a", 1);
        json_buf_raw(&j, ":", 1);
        json_buf_quoted(&j, "x", 1);
        json_buf_raw(&j, "}", 1);
        assert_int_equal(json_buf_end(&j), (int)strlen(want));
        assert_string_equal(buf, want);

        /* One byte less: the end reports it, and what was written is still a C string. */
        json_buf_begin(&j, buf, sizeof(want) - 1);
        json_buf_u64(&j, "n", UINT64_MAX);
        json_buf_bool(&j, "t", true);
        json_buf_bool(&j, "f", false);
        json_buf_key(&j, "o");
        json_buf_raw(&j, "{\"a\":\"x\"}", strlen("{\"a\":\"x\"}"));
        assert_int_equal(json_buf_end(&j), -ENOBUFS);
        assert_true(strlen(buf) < sizeof(want) - 1);
}

static void test_file_members(void **state)
{
        char *text = NULL;
        size_t size = 0;
        FILE *f = open_memstream(&text, &size);

        (void)state;
        assert_non_null(f);
        fputc('{', f);
        json_member_u64(f, 1, "n", 7);
        json_member_bool(f, 0, "b", 1);
        json_key(f, 0, "s");
        json_string(f, "\xff");
        fputc('}', f);
        fclose(f);
        assert_string_equal(text, "{\"n\":7,\"b\":true,\"s\":\"\\u00ff\"}");
        free(text);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_escape_table),
                cmocka_unit_test(test_sinks_agree),
                cmocka_unit_test(test_buf_members_and_overflow),
                cmocka_unit_test(test_file_members),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
