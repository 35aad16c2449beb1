/*
 * tests/common/wire: the tests' own frame and packet builders against the worked examples of
 * PROTOCOLS.md (§1.3 and §2.1). Every codec test trusts these builders instead of the codec's
 * encoder, so they are checked against the document, not against the code they test.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "common/wire.h"

#define BUF_MAX 256
#define T "\t"

/* PROTOCOLS.md §1.3's worked examples, and the captured ping of the same section. */
static void test_slp_vectors(void **state)
{
        static const char *const vec[][2] = {
                { ":AB|N0|D40.12345678|D-113.12345678|D85.6|D22.1",
                  "[:AB|N0|D40.12345678|D-113.12345678|D85.6|D22.1|CD4]" },
                { ":AB|QAutoGpsLat", "[:AB|QAutoGpsLat|C2D]" },
                { ":BA|RAutoGpsLat|D40.12345678", "[:BA|RAutoGpsLat|D40.12345678|C24]" },
                { ":AB|N0|D|D|D85.7|D", "[:AB|N0|D|D|D85.7|D|C48]" },
                { ":AB|P0", "[:AB|P0|C78]" },
        };
        char buf[BUF_MAX];

        (void)state;
        for (size_t i = 0; i < sizeof(vec) / sizeof(vec[0]); i++) {
                assert_int_equal(wire_slp_raw(buf, sizeof(buf), vec[i][0], false),
                                 strlen(vec[i][1]));
                assert_string_equal(buf, vec[i][1]);
        }
}

/* The three ways to build one frame agree, with and without CR LF. */
static void test_slp_frame_close_sum(void **state)
{
        char a[BUF_MAX], b[BUF_MAX], c[BUF_MAX];
        size_t n;

        (void)state;
        assert_int_equal(wire_slp_frame(a, sizeof(a), 'A', 'B', "P0", true), 14);
        assert_string_equal(a, "[:AB|P0|C78]\r\n");
        assert_int_equal(wire_slp_raw(b, sizeof(b), ":AB|P0", true), 14);
        assert_string_equal(b, a);
        n = (size_t)snprintf(c, sizeof(c), "[:AB|P0");
        assert_int_equal(wire_slp_close(c, sizeof(c), n), 12);
        assert_string_equal(c, "[:AB|P0|C78]");
        /* ':' 'A' 'B' '|' 'P' '0' '|' 'C' = 0x178 */
        assert_int_equal(wire_slp_sum(":AB|P0|C", 8), 0x78);
        /* a sum below 0x10 is zero padded */
        assert_int_equal(wire_slp_raw(a, sizeof(a), ":AB|Dde", false), 13);
        assert_string_equal(a, "[:AB|Dde|C05]");
}

/* §2.1's Login example, the same with a lowercase and a wrong checksum, and without one. */
static void test_circe_login(void **state)
{
        uint8_t pkt[BUF_MAX];
        size_t n;

        (void)state;
        /* STX '0' '1' TAB = 0x02 + 0x30 + 0x31 + 0x09 = 0x6C */
        assert_int_equal(wire_circe_sum((const uint8_t *)"\x02" "01" T, 4), 0x6C);
        n = wire_circe_str(pkt, sizeof(pkt), "01" T, WIRE_CS_UPPER);
        assert_int_equal(n, 7);
        assert_memory_equal(pkt, "\x02" "01" T "6C\x03", n);
        n = wire_circe_str(pkt, sizeof(pkt), "01" T, WIRE_CS_LOWER);
        assert_memory_equal(pkt, "\x02" "01" T "6c\x03", n);
        n = wire_circe_str(pkt, sizeof(pkt), "01" T, WIRE_CS_WRONG);
        assert_memory_equal(pkt, "\x02" "01" T "6D\x03", n);
        n = wire_circe_str(pkt, sizeof(pkt), "01" T, WIRE_CS_NONE);
        assert_int_equal(n, 5);
        assert_memory_equal(pkt, "\x02" "01" T "\x03", n);
}

/* A hand-worked Alert, a body with a NUL byte (the length, not strlen), '|' for TAB, and the
 * rendering for failure messages. */
static void test_circe_bodies(void **state)
{
        uint8_t pkt[BUF_MAX], text[BUF_MAX];
        char shown[BUF_MAX];
        size_t n, m;

        (void)state;
        /* 0x02 + "03\t014:123456\t" = 0x37B */
        n = wire_circe_str(pkt, sizeof(pkt), "03" T "014:123456" T, WIRE_CS_UPPER);
        assert_memory_equal(pkt, "\x02" "03" T "014:123456" T "7B\x03", n);
        m = wire_circe_text(text, sizeof(text), "03|014:123456|", WIRE_CS_UPPER);
        assert_int_equal(m, n);
        assert_memory_equal(text, pkt, n);
        n = wire_circe_packet(pkt, sizeof(pkt), "01" T "\0", 4, WIRE_CS_NONE);
        assert_int_equal(n, 6);
        assert_memory_equal(pkt, "\x02" "01" T "\0\x03", n);
        wire_circe_show(text, m, shown, sizeof(shown));
        assert_string_equal(shown, "<STX>03<TAB>014:123456<TAB>7B<ETX>");
        /* truncated at a whole token, always terminated */
        wire_circe_show(text, m, shown, 9);
        assert_string_equal(shown, "<STX>03");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_slp_vectors),
                cmocka_unit_test(test_slp_frame_close_sum),
                cmocka_unit_test(test_circe_login),
                cmocka_unit_test(test_circe_bodies),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
