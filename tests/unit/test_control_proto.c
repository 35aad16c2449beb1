/*
 * Control-socket line protocol tests (src/proto/control.h): table-driven requests for both
 * grammars (the strict one a client sends, the liberal one the daemon splits), the word builder
 * at every limit, reply lines formatted (cut, sanitised, every errno) and parsed (every kind of
 * bad one), and format -> parse round trips.
 */
#include <errno.h>
#include <limits.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "proto/control.h"

#define ARR(a) (sizeof(a) / sizeof((a)[0]))
#define NO_POS ((size_t)-1)
#define JOINED_MAX (2 * CTLP_LINE_MAX)

/* n words "w" separated by sep (one or more spaces), into buf; returns its length. */
static size_t words_line(char *buf, size_t size, unsigned n, const char *sep)
{
        size_t len = 0;

        buf[0] = '\0';
        for (unsigned i = 0; i < n; i++)
                len += (size_t)snprintf(buf + len, size - len, "%sw", i ? sep : "");
        return len;
}

/* ---- strict requests (what a client sends) -------------------------------------------------- */

static void test_request_check(void **state)
{
        static const struct {
                const char *line;
                size_t len;                     /* 0: strlen(line) */
                enum ctlp_reason reason;
                size_t pos;                     /* NO_POS: not looked at */
        } cases[] = {
                { "ping", 0, CTLP_REASON_NONE, NO_POS },
                { "query vehicle A AutoGpsLat 250", 0, CTLP_REASON_NONE, NO_POS },
                { "circe agility visualize D15D15,E1E1E1 current=1", 0, CTLP_REASON_NONE, NO_POS },
                { "~!\"#$%&'()*+,-./:;<=>?@[\\]^_`{|}", 0, CTLP_REASON_NONE, NO_POS },
                { "", 0, CTLP_REASON_EMPTY, NO_POS },
                { " ping", 0, CTLP_REASON_BAD_SPACE, 0 },
                { "ping ", 0, CTLP_REASON_BAD_SPACE, 4 },
                { "query  vehicle", 0, CTLP_REASON_BAD_SPACE, 6 },
                { " ", 0, CTLP_REASON_BAD_SPACE, 0 },
                { "query\tvehicle", 0, CTLP_REASON_BAD_BYTE, 5 },
                { "ping\n", 0, CTLP_REASON_BAD_BYTE, 4 },
                { "ping\r", 0, CTLP_REASON_BAD_BYTE, 4 },
                { "caf\xc3\xa9", 0, CTLP_REASON_BAD_BYTE, 3 },
                { "del\x7f", 0, CTLP_REASON_BAD_BYTE, 3 },
                { "ping\0rm", 7, CTLP_REASON_BAD_BYTE, 4 },     /* a NUL is not an end */
        };
        char line[CTLP_LINE_MAX + 1];
        size_t len;

        (void)state;
        for (size_t i = 0; i < ARR(cases); i++) {
                size_t pos = NO_POS;
                size_t n = cases[i].len ? cases[i].len : strlen(cases[i].line);

                if (ctlp_request_check(cases[i].line, n, &pos) != cases[i].reason)
                        fail_msg("case %zu \"%s\": reason %d, expected %d", i, cases[i].line,
                                 ctlp_request_check(cases[i].line, n, NULL), cases[i].reason);
                if (cases[i].pos != NO_POS)
                        assert_int_equal(pos, cases[i].pos);
        }

        /* Length: the line and its '\n' fit CTLP_LINE_MAX, one byte more does not. */
        memset(line, 'x', sizeof(line));
        assert_int_equal(ctlp_request_check(line, CTLP_LINE_MAX - 1, NULL), CTLP_REASON_NONE);
        assert_int_equal(ctlp_request_check(line, CTLP_LINE_MAX, NULL), CTLP_REASON_TOO_LONG);

        /* Words: CTLP_WORDS_MAX pass, one more does not. */
        len = words_line(line, sizeof(line), CTLP_WORDS_MAX, " ");
        assert_int_equal(ctlp_request_check(line, len, NULL), CTLP_REASON_NONE);
        len = words_line(line, sizeof(line), CTLP_WORDS_MAX + 1, " ");
        assert_int_equal(ctlp_request_check(line, len, NULL), CTLP_REASON_TOO_MANY_WORDS);
}

/* ---- liberal requests (what the daemon takes) ----------------------------------------------- */

/* Joins argv with '|' for comparing. */
static void join(char *out, size_t size, int argc, char *const *argv)
{
        size_t len = 0;

        out[0] = '\0';
        for (int i = 0; i < argc; i++)
                len += (size_t)snprintf(out + len, size - len, "%s%s", i ? "|" : "", argv[i]);
}

static void test_request_split(void **state)
{
        static const struct {
                const char *line;
                size_t len;                     /* 0: strlen(line) */
                enum ctlp_reason reason;
                const char *words;              /* joined with '|' */
        } cases[] = {
                { "ping", 0, CTLP_REASON_NONE, "ping" },
                { "query vehicle B x", 0, CTLP_REASON_NONE, "query|vehicle|B|x" },
                { "  query   vehicle  ", 0, CTLP_REASON_NONE, "query|vehicle" },
                { "a b", 0, CTLP_REASON_NONE, "a|b" },
                { "", 0, CTLP_REASON_EMPTY, NULL },
                { "   ", 0, CTLP_REASON_EMPTY, NULL },
                { "tab\there", 0, CTLP_REASON_BAD_BYTE, NULL },
                { "del\x7f", 0, CTLP_REASON_BAD_BYTE, NULL },
                { "caf\xc3\xa9", 0, CTLP_REASON_BAD_BYTE, NULL },
                { "cr\r", 0, CTLP_REASON_BAD_BYTE, NULL },
                { "ping\x01", 0, CTLP_REASON_BAD_BYTE, NULL },
                { "ping\0rm", 7, CTLP_REASON_BAD_BYTE, NULL },  /* not "ping" */
        };
        char line[CTLP_LINE_MAX + 1], joined[JOINED_MAX];
        char *argv[CTLP_WORDS_MAX + 1];
        size_t len;
        int argc;

        (void)state;
        for (size_t i = 0; i < ARR(cases); i++) {
                size_t n = cases[i].len ? cases[i].len : strlen(cases[i].line);
                enum ctlp_reason r;

                memcpy(line, cases[i].line, n);
                line[n] = '\0';
                argc = -1;
                r = ctlp_request_split(line, n, argv, &argc);
                if (r != cases[i].reason)
                        fail_msg("case %zu \"%s\": reason %d, expected %d", i, cases[i].line, r,
                                 cases[i].reason);
                if (r != CTLP_REASON_NONE) {
                        assert_int_equal(argc, -1);             /* untouched */
                        continue;
                }
                assert_null(argv[argc]);
                join(joined, sizeof(joined), argc, argv);
                assert_string_equal(joined, cases[i].words);
        }

        /* CTLP_WORDS_MAX words, even with runs of spaces between them; one more is refused. */
        len = words_line(line, sizeof(line), CTLP_WORDS_MAX, "   ");
        assert_int_equal(ctlp_request_split(line, len, argv, &argc), CTLP_REASON_NONE);
        assert_int_equal(argc, CTLP_WORDS_MAX);
        assert_null(argv[CTLP_WORDS_MAX]);
        len = words_line(line, sizeof(line), CTLP_WORDS_MAX + 1, " ");
        assert_int_equal(ctlp_request_split(line, len, argv, &argc), CTLP_REASON_TOO_MANY_WORDS);

        /* Length: CTLP_LINE_MAX - 1 bytes split, CTLP_LINE_MAX are refused. */
        memset(line, 'x', CTLP_LINE_MAX);
        line[CTLP_LINE_MAX - 1] = '\0';
        assert_int_equal(ctlp_request_split(line, CTLP_LINE_MAX - 1, argv, &argc),
                         CTLP_REASON_NONE);
        assert_int_equal(argc, 1);
        assert_int_equal(strlen(argv[0]), CTLP_LINE_MAX - 1);
        memset(line, 'x', CTLP_LINE_MAX);
        line[CTLP_LINE_MAX] = '\0';
        assert_int_equal(ctlp_request_split(line, CTLP_LINE_MAX, argv, &argc),
                         CTLP_REASON_TOO_LONG);
}

/* ---- building requests ---------------------------------------------------------------------- */

static void test_builder(void **state)
{
        static const struct {
                const char *word;
                size_t len;                     /* 0: strlen(word) */
                enum ctlp_reason reason;
        } bad[] = {
                { "", 0, CTLP_REASON_EMPTY },
                { "two words", 0, CTLP_REASON_BAD_BYTE },
                { "tab\t", 0, CTLP_REASON_BAD_BYTE },
                { "nl\n", 0, CTLP_REASON_BAD_BYTE },
                { "caf\xc3\xa9", 0, CTLP_REASON_BAD_BYTE },
                { "nul\0x", 5, CTLP_REASON_BAD_BYTE },
        };
        struct ctlp_builder b;
        char word[CTLP_LINE_MAX + 1];

        (void)state;
        ctlp_builder_init(&b);
        assert_string_equal(b.line, "");
        assert_int_equal(ctlp_builder_add(&b, "circe", 5), CTLP_REASON_NONE);
        assert_int_equal(ctlp_builder_add(&b, "agility", 7), CTLP_REASON_NONE);
        assert_int_equal(ctlp_builder_add(&b, "alertXX", 5), CTLP_REASON_NONE);  /* len counts */
        assert_string_equal(b.line, "circe agility alert");
        assert_int_equal(b.len, strlen(b.line));
        assert_int_equal(b.words, 3);
        /* What the builder makes, the strict check passes. */
        assert_int_equal(ctlp_request_check(b.line, b.len, NULL), CTLP_REASON_NONE);

        for (size_t i = 0; i < ARR(bad); i++) {
                size_t n = bad[i].len ? bad[i].len : strlen(bad[i].word);

                assert_int_equal(ctlp_builder_add(&b, bad[i].word, n), bad[i].reason);
                assert_string_equal(b.line, "circe agility alert");     /* unchanged */
                assert_int_equal(b.words, 3);
        }

        /* Length: a word that fills the line to CTLP_LINE_MAX - 1 passes, one byte more not. */
        memset(word, 'x', sizeof(word));
        ctlp_builder_init(&b);
        assert_int_equal(ctlp_builder_add(&b, "a", 1), CTLP_REASON_NONE);
        assert_int_equal(ctlp_builder_add(&b, word, CTLP_LINE_MAX - 2), CTLP_REASON_TOO_LONG);
        assert_int_equal(ctlp_builder_add(&b, word, CTLP_LINE_MAX - 3), CTLP_REASON_NONE);
        assert_int_equal(b.len, CTLP_LINE_MAX - 1);
        assert_int_equal(ctlp_request_check(b.line, b.len, NULL), CTLP_REASON_NONE);
        ctlp_builder_init(&b);
        assert_int_equal(ctlp_builder_add(&b, word, CTLP_LINE_MAX), CTLP_REASON_TOO_LONG);
        assert_int_equal(b.len, 0);

        /* Words: CTLP_WORDS_MAX, then no more. */
        ctlp_builder_init(&b);
        for (unsigned i = 0; i < CTLP_WORDS_MAX; i++)
                assert_int_equal(ctlp_builder_add(&b, "w", 1), CTLP_REASON_NONE);
        assert_int_equal(ctlp_builder_add(&b, "w", 1), CTLP_REASON_TOO_MANY_WORDS);
        assert_int_equal(b.words, CTLP_WORDS_MAX);
        assert_int_equal(ctlp_request_check(b.line, b.len, NULL), CTLP_REASON_NONE);
}

/* ---- formatting replies --------------------------------------------------------------------- */

static void test_reply_format(void **state)
{
        static const struct {
                enum ctlp_reply_kind kind;
                int err;
                const char *text;               /* NULL: no text */
                const char *line;
        } cases[] = {
                { CTLP_REPLY_OK, 0, NULL, "OK\n" },
                { CTLP_REPLY_OK, 0, "", "OK \n" },
                { CTLP_REPLY_OK, 0, "1234 5678", "OK 1234 5678\n" },
                { CTLP_REPLY_DATA, 0, "E1E1E1 succeeded", "DATA E1E1E1 succeeded\n" },
                { CTLP_REPLY_DATA, 0, NULL, "DATA\n" },
                { CTLP_REPLY_ERR, 110, "no answer", "ERR 110 no answer\n" },
                { CTLP_REPLY_ERR, -2, "no such link", "ERR 2 no such link\n" },
                { CTLP_REPLY_ERR, -4095, NULL, "ERR 4095\n" },
                { CTLP_REPLY_ERR, 7, "", "ERR 7 \n" },
                { CTLP_REPLY_ERR, INT_MIN, NULL, "ERR 2147483648\n" },
                { CTLP_REPLY_ERR, INT_MAX, NULL, "ERR 2147483647\n" },
                /* One reply line stays one line: control bytes become spaces. */
                { CTLP_REPLY_OK, 0, "two\nlines\r\t\x1b[2J\x7f", "OK two lines   [2J \n" },
                { CTLP_REPLY_ERR, 22, "bad\nname", "ERR 22 bad name\n" },
        };
        char buf[CTLP_REPLY_LINE_MAX + 1], text[CTLP_REPLY_LINE_MAX + 8];
        size_t len;

        (void)state;
        for (size_t i = 0; i < ARR(cases); i++) {
                memset(buf, '#', sizeof(buf));
                len = ctlp_reply_format(buf, sizeof(buf), cases[i].kind, cases[i].err,
                                        cases[i].text);
                assert_string_equal(buf, cases[i].line);
                assert_int_equal(len, strlen(cases[i].line));
        }

        /* Cut: the line with its '\n' takes at most size - 1 bytes, whatever the text. */
        memset(text, 'y', sizeof(text) - 1);
        text[sizeof(text) - 1] = '\0';
        len = ctlp_reply_format(buf, sizeof(buf), CTLP_REPLY_OK, 0, text);
        assert_int_equal(len, sizeof(buf) - 1);
        assert_int_equal(buf[len - 1], '\n');
        assert_int_equal(buf[len], '\0');
        assert_int_equal(strspn(buf + 3, "y"), len - 4);
        {
                char small[CTLP_REPLY_HEAD_MAX];

                len = ctlp_reply_format(small, sizeof(small), CTLP_REPLY_ERR, INT_MIN, text);
                assert_string_equal(small, "ERR 2147483648\n");
                assert_int_equal(len, sizeof(small) - 1);
                len = ctlp_reply_format(small, sizeof(small), CTLP_REPLY_OK, 0, text);
                assert_int_equal(len, sizeof(small) - 1);
                assert_string_equal(small, "OK yyyyyyyyyyy\n");
                /* Too small for the head: nothing written. */
                memset(small, '#', sizeof(small));
                assert_int_equal(ctlp_reply_format(small, sizeof(small) - 1, CTLP_REPLY_OK, 0,
                                                   NULL), 0);
                assert_int_equal(small[0], '#');
                assert_int_equal(ctlp_reply_format(NULL, sizeof(small), CTLP_REPLY_OK, 0, NULL),
                                 0);
        }
}

/* ---- parsing replies ------------------------------------------------------------------------ */

static void test_reply_parse(void **state)
{
        static const struct {
                const char *line;
                size_t len;                     /* 0: strlen(line) */
                int kind;                       /* or -EPROTO */
                const char *text;
                int err;
        } cases[] = {
                { "OK", 0, CTLP_REPLY_OK, "", 0 },
                { "OK ", 0, CTLP_REPLY_OK, "", 0 },
                { "OK 40.12345678", 0, CTLP_REPLY_OK, "40.12345678", 0 },
                { "OK 1234 5678", 0, CTLP_REPLY_OK, "1234 5678", 0 },
                { "OK  two spaces", 0, CTLP_REPLY_OK, " two spaces", 0 },
                { "DATA E1E1E1 succeeded", 0, CTLP_REPLY_DATA, "E1E1E1 succeeded", 0 },
                { "DATA", 0, CTLP_REPLY_DATA, "", 0 },
                { "ERR 2 no such link: nope", 0, CTLP_REPLY_ERR, "no such link: nope", 2 },
                { "ERR 110", 0, CTLP_REPLY_ERR, "", 110 },
                { "ERR 4095 x", 0, CTLP_REPLY_ERR, "x", 4095 },
                { "ERR 107 tab\tinside", 0, CTLP_REPLY_ERR, "tab\tinside", 107 },
                { "ERR 0 zero", 0, -EPROTO, NULL, 0 },
                { "ERR 4096 big", 0, -EPROTO, NULL, 0 },
                { "ERR 99999999999999999999 huge", 0, -EPROTO, NULL, 0 },
                { "ERR 012 leading zero", 0, -EPROTO, NULL, 0 },
                { "ERR -2 negative", 0, -EPROTO, NULL, 0 },
                { "ERR +2 plus", 0, -EPROTO, NULL, 0 },
                { "ERR  2 two spaces", 0, -EPROTO, NULL, 0 },
                { "ERR 12x", 0, -EPROTO, NULL, 0 },
                { "ERR\t12", 0, -EPROTO, NULL, 0 },
                { "ERR", 0, -EPROTO, NULL, 0 },
                { "ERR ", 0, -EPROTO, NULL, 0 },
                { "ERR x", 0, -EPROTO, NULL, 0 },
                { "OKAY", 0, -EPROTO, NULL, 0 },
                { "ok", 0, -EPROTO, NULL, 0 },
                { "err 2 x", 0, -EPROTO, NULL, 0 },
                { "DATAx", 0, -EPROTO, NULL, 0 },
                { "DATA\tx", 0, -EPROTO, NULL, 0 },
                { " OK", 0, -EPROTO, NULL, 0 },
                { "", 0, -EPROTO, NULL, 0 },
                { "HELLO", 0, -EPROTO, NULL, 0 },
                { "OK \x1b[2J", 0, -EPROTO, NULL, 0 },
                { "OK cr\r", 0, -EPROTO, NULL, 0 },
                { "DATA \x7f", 0, -EPROTO, NULL, 0 },
                { "OK a\0b", 6, -EPROTO, NULL, 0 },             /* an embedded NUL */
                { "ERR 2\0 x", 8, -EPROTO, NULL, 0 },
        };
        char line[CTLP_REPLY_LINE_MAX + 2];

        (void)state;
        for (size_t i = 0; i < ARR(cases); i++) {
                const char *text = NULL;
                int err = -1;
                size_t n = cases[i].len ? cases[i].len : strlen(cases[i].line);
                int kind = ctlp_reply_parse(cases[i].line, n, &text, &err);

                if (kind != cases[i].kind)
                        fail_msg("case %zu \"%s\": %d, expected %d", i, cases[i].line, kind,
                                 cases[i].kind);
                if (kind < 0) {
                        assert_null(text);                      /* untouched */
                        assert_int_equal(err, -1);
                        continue;
                }
                assert_string_equal(text, cases[i].text);
                assert_int_equal(err, kind == CTLP_REPLY_ERR ? cases[i].err : -1);
        }

        /* Length: CTLP_REPLY_LINE_MAX bytes are a line, one more is not. */
        {
                const char *text;
                int err;

                memset(line, 'z', sizeof(line));
                memcpy(line, "OK ", 3);
                line[CTLP_REPLY_LINE_MAX] = '\0';
                assert_int_equal(ctlp_reply_parse(line, CTLP_REPLY_LINE_MAX, &text, &err),
                                 CTLP_REPLY_OK);
                assert_int_equal(strlen(text), CTLP_REPLY_LINE_MAX - 3);
                line[CTLP_REPLY_LINE_MAX] = 'z';
                line[CTLP_REPLY_LINE_MAX + 1] = '\0';
                assert_int_equal(ctlp_reply_parse(line, CTLP_REPLY_LINE_MAX + 1, &text, &err),
                                 -EPROTO);
        }
}

/* Whatever the daemon formats, the client parses back to the same kind, errno and text. */
static void test_reply_round_trip(void **state)
{
        static const struct {
                enum ctlp_reply_kind kind;
                int err;
                const char *text;
                const char *back;               /* the text the client reads */
        } cases[] = {
                { CTLP_REPLY_OK, 0, NULL, "" },
                { CTLP_REPLY_OK, 0, "value 1.5", "value 1.5" },
                { CTLP_REPLY_DATA, 0, "loop wakeups=3", "loop wakeups=3" },
                { CTLP_REPLY_ERR, -110, "no answer from peer B", "no answer from peer B" },
                { CTLP_REPLY_ERR, 1, NULL, "" },
                { CTLP_REPLY_ERR, CTLP_ERRNO_MAX, "x", "x" },
                { CTLP_REPLY_ERR, 13, "tab\there\nnl", "tab here nl" },
        };
        char buf[CTLP_REPLY_LINE_MAX + 1];

        (void)state;
        for (size_t i = 0; i < ARR(cases); i++) {
                const char *text;
                int err = -1;
                size_t len = ctlp_reply_format(buf, sizeof(buf), cases[i].kind, cases[i].err,
                                               cases[i].text);

                assert_true(len > 0 && buf[len - 1] == '\n');
                buf[--len] = '\0';
                assert_int_equal(ctlp_reply_parse(buf, len, &text, &err), (int)cases[i].kind);
                assert_string_equal(text, cases[i].back);
                if (cases[i].kind == CTLP_REPLY_ERR)
                        assert_int_equal(err, cases[i].err < 0 ? -cases[i].err : cases[i].err);
        }
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_request_check),
                cmocka_unit_test(test_request_split),
                cmocka_unit_test(test_builder),
                cmocka_unit_test(test_reply_format),
                cmocka_unit_test(test_reply_parse),
                cmocka_unit_test(test_reply_round_trip),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
