/*
 * Recording format tests (src/proto/recording.h): every byte value escaped and read back, the
 * escape of each byte class, chunk lines formatted and parsed, every broken-line form with its
 * message (table-driven), the rules between lines (header, times, continued pieces, "# dropped")
 * and whole texts split into lines, with the number of the broken line.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "proto/control.h"
#include "proto/recording.h"

#define ARR(a) (sizeof(a) / sizeof((a)[0]))
#define BYTE_VALUES 256

/* A chunk line fits one DATA reply line of the control socket ("DATA " + line). */
_Static_assert(REC_LINE_MAX + 5 <= CTLP_REPLY_LINE_MAX, "a line must fit a DATA line");

struct collected {
        size_t chunks;
        size_t bytes;
        uint8_t last[REC_CHUNK_MAX];
        size_t last_len;
        enum rec_dir last_dir;
        uint64_t last_t;
};

static int collect(void *arg, const struct rec_reader *r)
{
        struct collected *c = arg;

        c->chunks++;
        c->bytes += r->len;
        memcpy(c->last, r->chunk, r->len);
        c->last_len = r->len;
        c->last_dir = r->dir;
        c->last_t = r->last_t_us;
        return 0;
}

/* ---- escaping ------------------------------------------------------------------------------- */

static void test_escape_classes(void **state)
{
        static const struct {
                uint8_t byte;
                const char *text;
        } cases[] = {
                { 'A', "A" }, { '!', "!" }, { '~', "~" }, { '#', "#" }, { '<', "<" },
                { ' ', "\\s" }, { '\\', "\\\\" }, { '\r', "\\r" }, { '\n', "\\n" },
                { '\t', "\\t" }, { 0x00, "\\x00" }, { 0x02, "\\x02" }, { 0x7f, "\\x7f" },
                { 0xab, "\\xab" }, { 0xff, "\\xff" },
        };
        char out[REC_ESCAPE_MAX + 1];

        (void)state;
        for (size_t i = 0; i < ARR(cases); i++) {
                size_t n = rec_escape(out, &cases[i].byte, 1);

                assert_string_equal(out, cases[i].text);
                assert_int_equal(n, strlen(cases[i].text));
        }
}

/* All 256 byte values in one chunk (more than one piece), and each alone: out and back. */
static void test_round_trip_all_bytes(void **state)
{
        uint8_t all[BYTE_VALUES * 5];
        char line[REC_LINE_MAX + 1];
        struct rec_line l;
        const char *why = NULL;
        size_t used;

        (void)state;
        for (size_t i = 0; i < sizeof(all); i++)
                all[i] = (uint8_t)(i * 7);      /* every value, five times, in a mixed order */
        for (unsigned b = 0; b < BYTE_VALUES; b++) {
                uint8_t one = (uint8_t)b;

                rec_format_chunk(line, 1234567, REC_DIR_IN, false, &one, 1, &used);
                assert_int_equal(used, 1);
                assert_int_equal(rec_parse_line(line, strlen(line), &l, &why), 0);
                assert_false(l.comment);
                assert_int_equal(l.len, 1);
                assert_int_equal(l.data[0], b);
                assert_int_equal(l.t_us, 1234567);
                assert_int_equal(l.dir, REC_DIR_IN);
                assert_null(strchr(line, '\n'));
        }
        /* Pieces of REC_PIECE_MAX through a reader give the chunk back whole. */
        {
                struct rec_reader *r = calloc(1, sizeof(*r));
                size_t off = 0;
                int k = 0;

                assert_non_null(r);
                rec_reader_init(r);
                assert_int_equal(rec_reader_line(r, REC_HEADER, strlen(REC_HEADER)), 0);
                while (off < sizeof(all)) {
                        size_t len = rec_format_chunk(line, 5000000, REC_DIR_OUT,
                                                      sizeof(all) - off > REC_PIECE_MAX,
                                                      all + off, sizeof(all) - off, &used);

                        assert_true(len <= REC_LINE_MAX);
                        off += used;
                        k = rec_reader_line(r, line, len);
                        assert_int_equal(k, off < sizeof(all) ? 0 : 1);
                }
                assert_int_equal(k, 1);
                assert_int_equal(r->len, sizeof(all));
                assert_memory_equal(r->chunk, all, sizeof(all));
                assert_int_equal(r->dir, REC_DIR_OUT);
                assert_int_equal(r->last_t_us, 5000000);
                assert_int_equal(rec_reader_end(r), 0);
                free(r);
        }
}

/* The longest line: a full piece of bytes that each take four characters. */
static void test_longest_line(void **state)
{
        uint8_t data[REC_PIECE_MAX + 10];
        char line[REC_LINE_MAX + 1];
        size_t used, len;
        struct rec_line l;
        const char *why;

        (void)state;
        memset(data, 0xff, sizeof(data));
        len = rec_format_chunk(line, 9999999999999999ull, REC_DIR_IN, true, data, sizeof(data),
                               &used);
        assert_int_equal(used, REC_PIECE_MAX);
        assert_int_equal(len, REC_LINE_MAX);
        assert_int_equal(rec_parse_line(line, len, &l, &why), 0);
        assert_true(l.more);
        assert_int_equal(l.len, REC_PIECE_MAX);
        assert_int_equal(l.t_us, 9999999999999999ull);
}

/* ---- lines ---------------------------------------------------------------------------------- */

static void test_parse_good_lines(void **state)
{
        static const struct {
                const char *line;
                bool comment;
                uint64_t t_us;
                enum rec_dir dir;
                bool more;
                const char *bytes;
                size_t len;
        } cases[] = {
                { "0.000000 < A", false, 0, REC_DIR_IN, false, "A", 1 },
                { "0.012345 > [:AB|N0|D1|C3f]\\r\\n", false, 12345, REC_DIR_OUT, false,
                  "[:AB|N0|D1|C3f]\r\n", 17 },
                { "12.000001 <+ \\s\\\\\\t", false, 12000001, REC_DIR_IN, true, " \\\t", 3 },
                { "9999999999.999999 > \\x00\\xff", false, 9999999999999999ull, REC_DIR_OUT,
                  false, "\0\xff", 2 },
                { "0.000001 < \\x41", false, 1, REC_DIR_IN, false, "A", 1 },  /* liberal */
                { "#", true, 0, REC_DIR_IN, false, "", 0 },
                { "# link: vehicle", true, 0, REC_DIR_IN, false, "", 0 },
                { "#\tstart 2026-12-02T08:00:00Z ~", true, 0, REC_DIR_IN, false, "", 0 },
        };

        (void)state;
        for (size_t i = 0; i < ARR(cases); i++) {
                struct rec_line l;
                const char *why = NULL;

                if (rec_parse_line(cases[i].line, strlen(cases[i].line), &l, &why) != 0)
                        fail_msg("case %zu \"%s\": %s", i, cases[i].line, why);
                assert_int_equal(l.comment, cases[i].comment);
                if (l.comment)
                        continue;
                assert_int_equal(l.t_us, cases[i].t_us);
                assert_int_equal(l.dir, cases[i].dir);
                assert_int_equal(l.more, cases[i].more);
                assert_int_equal(l.len, cases[i].len);
                assert_memory_equal(l.data, cases[i].bytes, cases[i].len);
        }
}

static void test_parse_broken_lines(void **state)
{
        static const struct {
                const char *line;
                size_t len;                     /* 0: strlen(line) */
                const char *why;
        } cases[] = {
                { "", 0, "empty line" },
                { "x.000000 < A", 0, "time: SECONDS.MICROS expected" },
                { "< A", 0, "time: SECONDS.MICROS expected" },
                { "00.000000 < A", 0, "time: leading zero" },
                { "12345678901.000000 < A", 0, "time: too many digits before the point" },
                { "1 < A", 0, "time: '.' and 6 digits of microseconds expected" },
                { "1.00000 < A", 0, "time: 6 digits of microseconds expected" },
                { "1.0000000 < A", 0, "missing direction" },
                { "1.000000", 0, "missing direction" },
                { "1.000000 ", 0, "missing direction" },
                { "1.000000 = A", 0, "unknown direction (< or > expected)" },
                { "1.000000 << A", 0, "unknown direction (< or > expected)" },
                { "1.000000 <+- A", 0, "unknown direction (< or > expected)" },
                { "1.000000 <", 0, "missing bytes" },
                { "1.000000 < ", 0, "missing bytes" },
                { "1.000000 <  A", 0, "a space in the bytes (write it \\s)" },
                { "1.000000 < A ", 0, "a space in the bytes (write it \\s)" },
                { "1.000000 < A\tB", 0,
                  "a control or non-ASCII byte in the line (write it \\xHH)" },
                { "1.000000 < A\r", 0,
                  "a control or non-ASCII byte in the line (write it \\xHH)" },
                { "1.000000 < caf\xc3\xa9", 0,
                  "a control or non-ASCII byte in the line (write it \\xHH)" },
                { "1.000000 < A\\", 0, "backslash at the end of the line" },
                { "1.000000 < \\q", 0, "bad escape (\\s \\\\ \\r \\n \\t \\xHH)" },
                { "1.000000 < \\0", 0, "bad escape (\\s \\\\ \\r \\n \\t \\xHH)" },
                { "1.000000 < \\x4", 0, "\\x needs two lower-case hex digits" },
                { "1.000000 < \\x4G", 0, "\\x needs two lower-case hex digits" },
                { "1.000000 < \\xAB", 0, "\\x needs two lower-case hex digits" },
                { "1.000000 < A\0B", 14, "NUL byte in the line" },
                { "# a\0b", 5, "NUL byte in the line" },
                { "# bell\a", 0, "a control or non-ASCII byte in a comment" },
        };

        (void)state;
        for (size_t i = 0; i < ARR(cases); i++) {
                size_t n = cases[i].len ? cases[i].len : strlen(cases[i].line);
                struct rec_line l;
                const char *why = NULL;

                if (rec_parse_line(cases[i].line, n, &l, &why) != -EINVAL)
                        fail_msg("case %zu \"%s\": accepted", i, cases[i].line);
                if (strcmp(why, cases[i].why) != 0)
                        fail_msg("case %zu \"%s\": \"%s\", expected \"%s\"", i, cases[i].line,
                                 why, cases[i].why);
        }
}

/* Over-long lines: more than a piece of bytes, more than REC_LINE_MAX characters. */
static void test_parse_too_long(void **state)
{
        char *line = malloc(REC_LINE_MAX + 16);
        struct rec_line l;
        const char *why = NULL;
        size_t n;

        (void)state;
        assert_non_null(line);
        n = (size_t)snprintf(line, REC_LINE_MAX + 16, "1.000000 < ");
        memset(line + n, 'A', REC_PIECE_MAX + 1);
        n += REC_PIECE_MAX + 1;
        assert_int_equal(rec_parse_line(line, n, &l, &why), -EINVAL);
        assert_string_equal(why, "more than 1000 bytes on one line");
        memset(line, '#', REC_LINE_MAX + 1);
        assert_int_equal(rec_parse_line(line, REC_LINE_MAX + 1, &l, &why), -EINVAL);
        assert_string_equal(why, "line too long");
        assert_int_equal(rec_parse_line(line, REC_LINE_MAX, &l, &why), 0);
        free(line);
}

/* ---- whole recordings ----------------------------------------------------------------------- */

static void test_text_good(void **state)
{
        static const char text[] =
                REC_HEADER "\n"
                "# link: vehicle\n"
                "0.000100 < [:BA|N0|D1\n"
                "0.000100 > x\n"
                "# dropped 3 chunks\n"
                "0.500000 <+ ab\n"
                "0.500000 < cd\n"
                "# dropped 4 chunks\n"
                "1.000000 < \\r\\n\n";
        struct rec_reader *r = calloc(1, sizeof(*r));
        struct collected c = { 0 };

        (void)state;
        assert_non_null(r);
        rec_reader_init(r);
        assert_int_equal(rec_parse_text(r, text, strlen(text), collect, &c), 0);
        assert_int_equal(c.chunks, 4);
        assert_int_equal(c.bytes, 10 + 1 + 4 + 2);
        assert_int_equal(c.last_len, 2);
        assert_memory_equal(c.last, "\r\n", 2);
        assert_int_equal(c.last_t, 1000000);
        assert_int_equal(r->dropped, 7);
        assert_int_equal(r->line_no, 9);
        free(r);
}

/* "# transport: X" before the first chunk names the recorded transport; later ones, or one too
 * long to keep, do not; only "udp" makes the chunks datagrams. */
static void test_text_transport(void **state)
{
        static const struct {
                const char *text, *transport;
                bool datagram;
        } cases[] = {
                { REC_HEADER "\n# link: p4\n# transport: udp\n0.000001 < A\n", "udp", true },
                { REC_HEADER "\n# transport: serial\n0.000001 < A\n", "serial", false },
                { REC_HEADER "\n# transport: pty\n# transport: udp\n", "pty", false },
                { REC_HEADER "\n0.000001 < A\n# transport: udp\n", "", false },
                { REC_HEADER "\n# transport:udp\n", "", false },
                { REC_HEADER "\n# transport: udpudpudpudpudpudpudpudpudpudpudp\n", "", false },
                { REC_HEADER "\n# transport: udp6\n", "udp6", false },
        };
        struct rec_reader *r = calloc(1, sizeof(*r));

        (void)state;
        assert_non_null(r);
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                rec_reader_init(r);
                assert_int_equal(rec_parse_text(r, cases[i].text, strlen(cases[i].text), NULL,
                                                NULL), 0);
                assert_string_equal(r->transport, cases[i].transport);
                assert_int_equal(rec_reader_datagram(r), cases[i].datagram);
        }
        /* A reader used again forgets the last recording's transport. */
        rec_reader_init(r);
        assert_string_equal(r->transport, "");
        free(r);
}

static void test_text_broken(void **state)
{
        static const struct {
                const char *text;
                unsigned line;
                const char *why;
        } cases[] = {
                { "", 0, "empty file: no \"" REC_HEADER "\" line" },
                { "# sharedlink recording 2\n", 1,
                  "not a recording: the first line must be \"" REC_HEADER "\"" },
                { "0.000000 < A\n", 1,
                  "not a recording: the first line must be \"" REC_HEADER "\"" },
                { REC_HEADER "\n0.000000 < A", 2,
                  "the last line has no newline (file cut short?)" },
                { REC_HEADER "\n0.000002 < A\n0.000001 < B\n", 3, "time goes backwards" },
                { REC_HEADER "\n0.000002 < A\n0.000002 > B\n0.000001 > C\n", 4,
                  "time goes backwards" },
                { REC_HEADER "\n0.000001 <+ A\n0.000001 > B\n", 3,
                  "a continued chunk must go on with the same time and direction" },
                { REC_HEADER "\n0.000001 <+ A\n0.000002 < B\n", 3,
                  "a continued chunk must go on with the same time and direction" },
                { REC_HEADER "\n0.000001 <+ A\n# x\n0.000001 < B\n", 3,
                  "a comment inside a chunk continued with '+'" },
                { REC_HEADER "\n0.000001 <+ A\n", 2,
                  "the recording ends inside a chunk continued with '+'" },
                { REC_HEADER "\n# ok\n\n", 3, "empty line" },
                { REC_HEADER "\n0.000001 ? A\n", 2, "unknown direction (< or > expected)" },
                { REC_HEADER "\n0.000001 < \\z\n", 2,
                  "bad escape (\\s \\\\ \\r \\n \\t \\xHH)" },
                { REC_HEADER "\n1.0 < A\n", 2, "time: 6 digits of microseconds expected" },
        };

        (void)state;
        for (size_t i = 0; i < ARR(cases); i++) {
                struct rec_reader *r = calloc(1, sizeof(*r));

                assert_non_null(r);
                rec_reader_init(r);
                if (rec_parse_text(r, cases[i].text, strlen(cases[i].text), NULL, NULL) !=
                    -EINVAL)
                        fail_msg("case %zu: accepted", i);
                if (r->line_no != cases[i].line || strcmp(r->why, cases[i].why) != 0)
                        fail_msg("case %zu: line %u \"%s\", expected line %u \"%s\"", i,
                                 r->line_no, r->why, cases[i].line, cases[i].why);
                free(r);
        }
}

/* A chunk cut into pieces may not pass REC_CHUNK_MAX; a line may not pass REC_LINE_MAX. */
static void test_text_limits(void **state)
{
        size_t pieces = REC_CHUNK_MAX / REC_PIECE_MAX + 1, size = (pieces + 2) * REC_LINE_MAX;
        char *text = malloc(size);
        struct rec_reader *r = calloc(1, sizeof(*r));
        uint8_t data[REC_PIECE_MAX];
        size_t len, used;

        (void)state;
        assert_non_null(text);
        assert_non_null(r);
        memset(data, 'z', sizeof(data));
        len = (size_t)snprintf(text, size, "%s\n", REC_HEADER);
        for (size_t i = 0; i < pieces; i++) {
                len += rec_format_chunk(text + len, 7, REC_DIR_IN, i + 1 < pieces, data,
                                        sizeof(data), &used);
                text[len++] = '\n';
        }
        rec_reader_init(r);
        assert_int_equal(rec_parse_text(r, text, len, NULL, NULL), -EINVAL);
        assert_string_equal(r->why, "chunk longer than 8192 bytes");
        assert_int_equal(r->line_no, 1 + pieces);

        len = (size_t)snprintf(text, size, "%s\n#", REC_HEADER);
        memset(text + len, 'y', REC_LINE_MAX);
        len += REC_LINE_MAX;
        text[len++] = '\n';
        rec_reader_init(r);
        assert_int_equal(rec_parse_text(r, text, len, NULL, NULL), -EINVAL);
        assert_string_equal(r->why, "line too long");
        assert_int_equal(r->line_no, 2);
        free(r);
        free(text);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_escape_classes),
                cmocka_unit_test(test_round_trip_all_bytes),
                cmocka_unit_test(test_longest_line),
                cmocka_unit_test(test_parse_good_lines),
                cmocka_unit_test(test_parse_broken_lines),
                cmocka_unit_test(test_parse_too_long),
                cmocka_unit_test(test_text_good),
                cmocka_unit_test(test_text_transport),
                cmocka_unit_test(test_text_broken),
                cmocka_unit_test(test_text_limits),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
