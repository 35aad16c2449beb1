/*
 * CIRCE codec tests (PROTOCOLS.md section 2): table-driven packet vectors, parameter limits,
 * framing on a byte stream split every way, encoder output and refusals, round trips.
 *
 * Expected checksums are never taken from the codec: the vectors either carry a hand-worked
 * value (sum written out in a comment) or ask wire.h's builder to append one.
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

#include "common/wire.h"
#include "proto/circe.h"

#define STX "\x02"
#define ETX "\x03"
#define T "\t"
#define PKT_MAX (2 * CIRCE_PACKET_MAX)
#define STREAM_MAX (64 * 1024)
#define RESULTS_MAX 512

/* ---- Building packets ------------------------------------------------------------------------ */

enum cs_mode {
        CS_NONE,        /* no checksum: the body ends with TAB */
        CS_LITERAL,     /* the body already ends with its (hand-worked) checksum */
        CS_UPPER,       /* append the right checksum, uppercase */
        CS_LOWER,       /* append the right checksum, lowercase */
        CS_WRONG,       /* append the right checksum + 1 */
};

/* STX body [CC] ETX into out (room for body_len + 4 bytes); returns the length. The checksum
 * comes from wire.h, written from PROTOCOLS.md independently of the codec. */
static size_t build(const char *body, size_t body_len, enum cs_mode cs, uint8_t *out)
{
        static const enum wire_cs mode[] = {
                [CS_NONE] = WIRE_CS_NONE, [CS_LITERAL] = WIRE_CS_NONE, [CS_UPPER] = WIRE_CS_UPPER,
                [CS_LOWER] = WIRE_CS_LOWER, [CS_WRONG] = WIRE_CS_WRONG,
        };

        return wire_circe_packet(out, body_len + 4, body, body_len, mode[cs]);
}

/* ---- Packet vectors -------------------------------------------------------------------------- */

struct vec {
        const char *name;
        const char *body;               /* between STX and ETX (checksum excluded unless LITERAL) */
        size_t body_len;                /* 0: strlen(body) */
        enum cs_mode cs;
        enum circe_result_kind kind;
        enum circe_reason reason;
        unsigned param;
        unsigned skipped, repeated;
        bool canonical;                 /* the encoder writes exactly this body */
        struct circe_msg msg;
};

#define OK(n, b, ...) { .name = n, .body = b, .kind = CIRCE_RESULT_MESSAGE, __VA_ARGS__ }
#define BAD(n, b, r, ...) { .name = n, .body = b, .kind = CIRCE_RESULT_REJECTED, .reason = r, \
                            __VA_ARGS__ }

#define NS_HEAD "52" T "015:E1E1E1" T "016:1" T "019:32" T "020:4" T "021:150" T

static const struct vec vecs[] = {
        /* The spec's example: 0x02 + '0' 0x30 + '1' 0x31 + TAB 0x09 = 0x6C. */
        OK("login spec example", "01" T "6C", .cs = CS_LITERAL, .canonical = true,
           .msg = { .op = CIRCE_OP_LOGIN }),
        OK("login", "01" T, .canonical = true, .msg = { .op = CIRCE_OP_LOGIN }),
        OK("logout", "02" T, .canonical = true, .msg = { .op = CIRCE_OP_LOGOUT }),
        /* 2+48+51+9 = 110; "014:" 207; "123456" 309; TAB 9: 635 = 2*256 + 0x7B. */
        OK("alert, hand-worked checksum", "03" T "014:123456" T "7B", .cs = CS_LITERAL,
           .canonical = true, .msg = { .op = CIRCE_OP_ALERT, .u.alert.dest = 0x123456 }),
        OK("alert, lowercase hand-worked checksum", "03" T "014:123456" T "7b", .cs = CS_LITERAL,
           .msg = { .op = CIRCE_OP_ALERT, .u.alert.dest = 0x123456 }),
        OK("alert", "03" T "014:123456" T, .canonical = true,
           .msg = { .op = CIRCE_OP_ALERT, .u.alert.dest = 0x123456 }),
        OK("alert to an unconfigured device", "03" T "014:000000" T, .canonical = true,
           .msg = { .op = CIRCE_OP_ALERT, .u.alert.dest = 0 }),
        OK("network setup", "04" T "014:ABCDEF" T "017:1" T "020:127" T, .canonical = true,
           .msg = { .op = CIRCE_OP_NETWORK_SETUP,
                    .u.network_setup = { .dest = 0xABCDEF, .set_membership = true,
                                         .roles = 127 } }),
        OK("network setup, other order", "04" T "020:0" T "017:0" T "014:ABCDEF" T,
           .msg = { .op = CIRCE_OP_NETWORK_SETUP,
                    .u.network_setup = { .dest = 0xABCDEF, .set_membership = false,
                                         .roles = 0 } }),
        OK("device setup, reference order", "05" T "014:000000" T "026:E1E1E1" T "019:32" T,
           .canonical = true,
           .msg = { .op = CIRCE_OP_DEVICE_SETUP,
                    .u.device_setup = { .has_dest = true, .dest = 0, .assign = 0xE1E1E1,
                                        .has_capabilities = true, .capabilities = 32 } }),
        OK("device setup, 026 only", "05" T "026:E1E1E1" T, .canonical = true,
           .msg = { .op = CIRCE_OP_DEVICE_SETUP, .u.device_setup = { .assign = 0xE1E1E1 } }),
        OK("sync clocks", "06" T, .canonical = true, .msg = { .op = CIRCE_OP_SYNC_CLOCKS }),
        OK("visualize, every field in spec order",
           "07" T "034:0" T "028:12" T "029:13" T "030:1" T "031:65432" T "038:999999" T
           "032:5" T "033:99" T "035:3" T "014:D15D15" T "014:000001" T,
           .canonical = true,
           .msg = { .op = CIRCE_OP_VISUALIZE,
                    .u.visualize = { .dest_count = 2, .dests = { 0xD15D15, 0x000001 },
                                     .has_eliminated = true, .eliminated = false,
                                     .has_current = true, .current = 12,
                                     .has_next = true, .next = 13, .start_timer = true,
                                     .has_primary = true, .primary_ms = 65432,
                                     .has_secondary = true, .secondary_ms = 999999,
                                     .has_faults = true, .faults = 5,
                                     .has_refusals = true, .refusals = 99,
                                     .has_placement = true, .placement = 3 } }),
        OK("visualize, start timer only", "07" T "030:1" T "014:D15D15" T, .canonical = true,
           .msg = { .op = CIRCE_OP_VISUALIZE,
                    .u.visualize = { .dest_count = 1, .dests = { 0xD15D15 },
                                     .start_timer = true } }),
        OK("visualize, destinations first", "07" T "014:D15D15" T "034:1" T,
           .msg = { .op = CIRCE_OP_VISUALIZE,
                    .u.visualize = { .dest_count = 1, .dests = { 0xD15D15 },
                                     .has_eliminated = true, .eliminated = true } }),
        OK("visualize, several 014 (duplicates kept)",
           "07" T "028:7" T "014:111111" T "014:222222" T "014:333333" T "014:111111" T,
           .canonical = true,
           .msg = { .op = CIRCE_OP_VISUALIZE,
                    .u.visualize = { .dest_count = 4,
                                     .dests = { 0x111111, 0x222222, 0x333333, 0x111111 },
                                     .has_current = true, .current = 7 } }),
        /* 2+53+49+9; "010:" 193 "0.2.3" 245 TAB 9; "012:" 195 "0" 48 TAB 9 = 828 = 3*256 + 0x3C */
        OK("keep alive, hand-worked checksum", "51" T "010:0.2.3" T "012:0" T "3C",
           .cs = CS_LITERAL, .canonical = true,
           .msg = { .op = CIRCE_OP_KEEP_ALIVE,
                    .u.keep_alive = { .version = { 0, 2, 3 }, .status = 0 } }),
        OK("keep alive, unconfigured mediator (012 erratum)", "51" T "010:1.20.300" T "012:1" T,
           .canonical = true,
           .msg = { .op = CIRCE_OP_KEEP_ALIVE,
                    .u.keep_alive = { .version = { 1, 20, 300 },
                                      .status = CIRCE_MEDIATOR_UNCONFIGURED } }),
        OK("notify status, mandatory only", NS_HEAD, .canonical = true,
           .msg = { .op = CIRCE_OP_NOTIFY_STATUS,
                    .u.notify_status = { .origin = 0xE1E1E1, .membership = true,
                                         .capabilities = 32, .roles = 4, .signal = 150 } }),
        OK("notify status, every field (037 erratum)",
           "52" T "015:AAAAAA" T "016:0" T "019:31" T "020:1" T "021:0" T "022:255" T "023:1" T
           "027:2" T "037:1" T,
           .canonical = true,
           .msg = { .op = CIRCE_OP_NOTIFY_STATUS,
                    .u.notify_status = { .origin = 0xAAAAAA, .membership = false,
                                         .capabilities = 31, .roles = 1, .signal = 0,
                                         .has_battery = true, .battery = 255,
                                         .has_aligned = true, .aligned = true,
                                         .has_clock_sync = true, .clock_sync = 2,
                                         .has_version_mismatch = true,
                                         .version_mismatch = true } }),
        OK("notify action, origin only", "53" T "015:AAAAAA" T, .canonical = true,
           .msg = { .op = CIRCE_OP_NOTIFY_ACTION, .u.notify_action = { .origin = 0xAAAAAA } }),
        OK("notify action, keys and sensor time", "53" T "015:E1E1E1" T "024:32768" T "025:5000" T,
           .canonical = true,
           .msg = { .op = CIRCE_OP_NOTIFY_ACTION,
                    .u.notify_action = { .origin = 0xE1E1E1, .has_keys = true,
                                         .keys = CIRCE_KEY_READY, .has_sensor_time = true,
                                         .sensor_time_ms = 5000 } }),
        OK("log", "54" T "036:00FF7A" T, .canonical = true,
           .msg = { .op = CIRCE_OP_LOG, .u.log = { .len = 3, .data = { 0x00, 0xFF, 0x7A } } }),

        /* Leading zeros are accepted within the maximum length; the encoder drops them. */
        OK("leading zeros", "53" T "015:000ABC" T "024:00001" T "025:000000" T,
           .msg = { .op = CIRCE_OP_NOTIFY_ACTION,
                    .u.notify_action = { .origin = 0xABC, .has_keys = true, .keys = 1,
                                         .has_sensor_time = true, .sensor_time_ms = 0 } }),
        OK("competitor 0999: max length 4, range 0-999", "07" T "028:0999" T "014:D15D15" T,
           .msg = { .op = CIRCE_OP_VISUALIZE,
                    .u.visualize = { .dest_count = 1, .dests = { 0xD15D15 },
                                     .has_current = true, .current = 999 } }),

        /* Field practice: not-allowed parameters are skipped, their values unchecked. */
        OK("login with a parameter", "01" T "014:123456" T, .skipped = 1,
           .msg = { .op = CIRCE_OP_LOGIN }),
        OK("unknown parameter id, any value", "03" T "014:123456" T "999:any value: at all" T,
           .skipped = 1, .msg = { .op = CIRCE_OP_ALERT, .u.alert.dest = 0x123456 }),
        OK("not-allowed parameter with a bad value", "03" T "015:zz" T "014:123456" T,
           .skipped = 1, .msg = { .op = CIRCE_OP_ALERT, .u.alert.dest = 0x123456 }),
        OK("not-allowed parameter with an empty value", "03" T "000:" T "014:123456" T,
           .skipped = 1, .msg = { .op = CIRCE_OP_ALERT, .u.alert.dest = 0x123456 }),
        OK("signal in notify action", "53" T "015:AAAAAA" T "021:999" T "012:x" T, .skipped = 2,
           .msg = { .op = CIRCE_OP_NOTIFY_ACTION, .u.notify_action = { .origin = 0xAAAAAA } }),
        OK("non-ASCII in a skipped value", "53" T "015:AAAAAA" T "100:\xff\x80\x01" T,
           .skipped = 1,
           .msg = { .op = CIRCE_OP_NOTIFY_ACTION, .u.notify_action = { .origin = 0xAAAAAA } }),

        /* Field practice: a repeat keeps the first occurrence; later ones are not checked. */
        OK("repeated 014 in alert", "03" T "014:123456" T "014:654321" T, .repeated = 1,
           .msg = { .op = CIRCE_OP_ALERT, .u.alert.dest = 0x123456 }),
        OK("repeat with a bad value", "03" T "014:123456" T "014:zz" T, .repeated = 1,
           .msg = { .op = CIRCE_OP_ALERT, .u.alert.dest = 0x123456 }),
        OK("repeated keys", "53" T "015:AAAAAA" T "024:1" T "024:2" T "015:BBBBBB" T,
           .repeated = 2,
           .msg = { .op = CIRCE_OP_NOTIFY_ACTION,
                    .u.notify_action = { .origin = 0xAAAAAA, .has_keys = true, .keys = 1 } }),
        OK("repeated display field in visualize", "07" T "028:5" T "028:6" T "014:111111" T,
           .repeated = 1,
           .msg = { .op = CIRCE_OP_VISUALIZE,
                    .u.visualize = { .dest_count = 1, .dests = { 0x111111 },
                                     .has_current = true, .current = 5 } }),

        /* Errata. */
        BAD("013 instead of 012 in keep alive", "51" T "010:0.2.3" T "013:0" T,
            CIRCE_REASON_MISSING_PARAM, .param = 12, .skipped = 1),
        BAD("016 instead of 026 in device setup", "05" T "016:E1E1E1" T,
            CIRCE_REASON_MISSING_PARAM, .param = 26, .skipped = 1),

        /* Checksum. */
        BAD("wrong checksum", "01" T "6D", CIRCE_REASON_BAD_CHECKSUM, .cs = CS_LITERAL),
        BAD("checksum not hex", "01" T "6G", CIRCE_REASON_CHECKSUM_SYNTAX, .cs = CS_LITERAL),
        BAD("checksum one digit", "01" T "6", CIRCE_REASON_CHECKSUM_SYNTAX, .cs = CS_LITERAL),
        BAD("checksum three digits", "01" T "6C7", CIRCE_REASON_CHECKSUM_SYNTAX,
            .cs = CS_LITERAL),
        BAD("checksum after a space", "01" T " 6C", CIRCE_REASON_CHECKSUM_SYNTAX,
            .cs = CS_LITERAL),
        BAD("empty packet", "", CIRCE_REASON_CHECKSUM_SYNTAX, .cs = CS_LITERAL),
        BAD("op without TAB", "01", CIRCE_REASON_CHECKSUM_SYNTAX, .cs = CS_LITERAL),
        /* STX 0x02 + TAB 0x09 = 0x0B: a good checksum over a missing header. */
        BAD("checksum right after STX", T "0B", CIRCE_REASON_BAD_HEADER, .cs = CS_LITERAL),

        /* Header and operation. */
        BAD("one-digit op", "1" T, CIRCE_REASON_BAD_HEADER),
        BAD("three-digit op", "001" T, CIRCE_REASON_BAD_HEADER),
        BAD("letter in op", "a1" T, CIRCE_REASON_BAD_HEADER),
        BAD("TAB only", T, CIRCE_REASON_BAD_HEADER),
        BAD("no TAB after op", "03014:123456" T, CIRCE_REASON_BAD_HEADER),
        BAD("op 00", "00" T, CIRCE_REASON_UNKNOWN_OP),
        BAD("op 08", "08" T, CIRCE_REASON_UNKNOWN_OP),
        BAD("op 50", "50" T, CIRCE_REASON_UNKNOWN_OP),
        BAD("op 55", "55" T, CIRCE_REASON_UNKNOWN_OP),
        BAD("op 99", "99" T "014:123456" T, CIRCE_REASON_UNKNOWN_OP),

        /* Parameter syntax, checked for every parameter before any value. */
        BAD("two-digit id", "03" T "14:123456" T, CIRCE_REASON_BAD_PARAM_SYNTAX),
        BAD("= instead of :", "03" T "014=123456" T, CIRCE_REASON_BAD_PARAM_SYNTAX),
        BAD("letter in id", "03" T "0a4:123456" T, CIRCE_REASON_BAD_PARAM_SYNTAX),
        BAD("empty field", "03" T "014:123456" T T, CIRCE_REASON_BAD_PARAM_SYNTAX),
        BAD("id only", "03" T "014" T, CIRCE_REASON_BAD_PARAM_SYNTAX),
        BAD("NUL in a value", "03" T "014:12\0" "3456" T, CIRCE_REASON_BAD_PARAM_SYNTAX,
            .body_len = 15),
        BAD("syntax error after a value error", "03" T "014:zzzzzz" T "x" T,
            CIRCE_REASON_BAD_PARAM_SYNTAX),
        BAD("syntax error in a not-allowed parameter", "01" T "999" T,
            CIRCE_REASON_BAD_PARAM_SYNTAX),
        BAD("syntax error in a repeat", "03" T "014:123456" T "014" T,
            CIRCE_REASON_BAD_PARAM_SYNTAX),

        /* Values: the first bad one in wire order is reported. */
        BAD("first bad value wins", "52" T "015:E1E1E1" T "016:2" T "019:200" T "020:4" T
            "021:150" T, CIRCE_REASON_VALUE_RANGE, .param = 16),
        BAD("bad second destination", "07" T "030:1" T "014:111111" T "014:11111g" T,
            CIRCE_REASON_VALUE_TYPE, .param = 14),
        BAD("value error before missing parameter", "04" T "014:FFFFFF" T,
            CIRCE_REASON_VALUE_RANGE, .param = 14),

        /* Mandatory parameters (the lowest missing id is reported). */
        BAD("alert without 014", "03" T, CIRCE_REASON_MISSING_PARAM, .param = 14),
        BAD("network setup without 020", "04" T "014:123456" T "017:1" T,
            CIRCE_REASON_MISSING_PARAM, .param = 20),
        BAD("network setup without 014", "04" T "017:1" T "020:1" T,
            CIRCE_REASON_MISSING_PARAM, .param = 14),
        BAD("network setup without 017", "04" T "014:123456" T "020:1" T,
            CIRCE_REASON_MISSING_PARAM, .param = 17),
        BAD("device setup without 026", "05" T "014:123456" T "019:1" T,
            CIRCE_REASON_MISSING_PARAM, .param = 26),
        BAD("visualize without display field", "07" T "014:123456" T,
            CIRCE_REASON_MISSING_PARAM, .param = 0),
        BAD("visualize without 014", "07" T "030:1" T, CIRCE_REASON_MISSING_PARAM, .param = 14),
        BAD("keep alive without 010", "51" T "012:0" T, CIRCE_REASON_MISSING_PARAM, .param = 10),
        BAD("notify status without 021", "52" T "015:E1E1E1" T "016:1" T "019:32" T "020:4" T,
            CIRCE_REASON_MISSING_PARAM, .param = 21),
        BAD("notify status without 016", "52" T "015:E1E1E1" T "019:32" T "020:4" T "021:1" T,
            CIRCE_REASON_MISSING_PARAM, .param = 16),
        BAD("notify status without 019", "52" T "015:E1E1E1" T "016:1" T "020:4" T "021:1" T,
            CIRCE_REASON_MISSING_PARAM, .param = 19),
        BAD("empty notify status", "52" T, CIRCE_REASON_MISSING_PARAM, .param = 15),
        BAD("notify action without 015", "53" T "024:1" T, CIRCE_REASON_MISSING_PARAM,
            .param = 15),
        BAD("log without 036", "54" T, CIRCE_REASON_MISSING_PARAM, .param = 36),
};

#define VEC_COUNT (sizeof(vecs) / sizeof(vecs[0]))

static size_t vec_build(const struct vec *v, enum cs_mode cs, uint8_t *out)
{
        return build(v->body, v->body_len ? v->body_len : strlen(v->body), cs, out);
}

/* One result against a vector's expectations. */
static void check_result(const struct vec *v, const struct circe_result *r)
{
        if (r->kind != v->kind || r->reason != v->reason || r->param != v->param)
                fail_msg("%s: got kind %d reason \"%s\" param %u, want kind %d \"%s\" param %u",
                         v->name, r->kind, circe_reason_str(r->reason), r->param, v->kind,
                         circe_reason_str(v->reason), v->param);
        if (v->kind != CIRCE_RESULT_MESSAGE)
                return;
        if (r->skipped != v->skipped || r->repeated != v->repeated)
                fail_msg("%s: skipped %u repeated %u, want %u %u", v->name, r->skipped,
                         r->repeated, v->skipped, v->repeated);
        if (!circe_msg_equal(&r->msg, &v->msg))
                fail_msg("%s: decoded message differs", v->name);
}

static void check_vec_as(const struct vec *v, enum cs_mode cs)
{
        uint8_t pkt[PKT_MAX];
        size_t len = vec_build(v, cs, pkt);
        struct circe_result r;
        struct circe_decoder d;

        /* Whole packet, standalone parser. */
        circe_decode(pkt, len, &r);
        check_result(v, &r);
        assert_ptr_equal(r.packet, pkt);
        assert_int_equal(r.packet_len, len);
        if (r.kind == CIRCE_RESULT_MESSAGE)
                assert_int_equal(r.has_checksum, cs != CS_NONE);

        /* Through the framer, split at every byte boundary. */
        for (size_t cut = 0; cut <= len; cut++) {
                size_t n;

                circe_decoder_init(&d);
                n = circe_decoder_feed(&d, pkt, cut, &r);
                assert_int_equal(n, cut);
                if (cut < len) {
                        assert_int_equal(r.kind, CIRCE_RESULT_NONE);
                        n = circe_decoder_feed(&d, pkt + cut, len - cut, &r);
                        assert_int_equal(n, len - cut);
                }
                check_result(v, &r);
                assert_int_equal(r.packet_len, len);
                assert_memory_equal(r.packet, pkt, len);
                assert_int_equal(d.stats.bytes, len);
                assert_int_equal(d.stats.noise + d.stats.stray_etx + d.stats.discarded, 0);
                if (v->kind == CIRCE_RESULT_MESSAGE)
                        assert_int_equal(d.stats.messages, 1);
                else
                        assert_int_equal(d.stats.rejected[v->reason], 1);
        }

        /* Byte by byte: nothing until the last byte. */
        circe_decoder_init(&d);
        for (size_t i = 0; i < len; i++) {
                assert_int_equal(circe_decoder_feed(&d, pkt + i, 1, &r), 1);
                if (i + 1 < len)
                        assert_int_equal(r.kind, CIRCE_RESULT_NONE);
        }
        check_result(v, &r);
}

static void test_vectors(void **state)
{
        (void)state;
        for (size_t i = 0; i < VEC_COUNT; i++) {
                const struct vec *v = &vecs[i];

                check_vec_as(v, v->cs);
                if (v->cs != CS_NONE)
                        continue;
                if (v->kind == CIRCE_RESULT_MESSAGE) {
                        /* Every valid packet without checksum also passes with one, upper or
                         * lower case, and fails with a wrong one. */
                        struct vec w = *v;
                        check_vec_as(&w, CS_UPPER);
                        check_vec_as(&w, CS_LOWER);
                        w.kind = CIRCE_RESULT_REJECTED;
                        w.reason = CIRCE_REASON_BAD_CHECKSUM;
                        w.param = 0;
                        check_vec_as(&w, CS_WRONG);
                } else if (v->reason > CIRCE_REASON_BAD_CHECKSUM) {
                        /* Later checks fail the same way behind a good checksum. */
                        check_vec_as(v, CS_UPPER);
                }
        }
}

/* A checksum is present iff the byte before ETX is not TAB. */
static void test_checksum_presence_rule(void **state)
{
        uint8_t pkt[PKT_MAX];
        struct circe_result r;
        size_t len;

        (void)state;
        len = build("01" T, 3, CS_NONE, pkt);
        circe_decode(pkt, len, &r);
        assert_int_equal(r.kind, CIRCE_RESULT_MESSAGE);
        assert_false(r.has_checksum);

        /* The 6C of the spec example: sum of STX '0' '1' TAB, computed here. */
        assert_int_equal(wire_circe_sum((const uint8_t *)STX "01" T, 4), 0x6C);
        len = build("01" T "6C", 5, CS_LITERAL, pkt);
        circe_decode(pkt, len, &r);
        assert_int_equal(r.kind, CIRCE_RESULT_MESSAGE);
        assert_true(r.has_checksum);

        /* Every wrong checksum value is caught. */
        for (unsigned s = 0; s < 256; s++) {
                char body[8];
                snprintf(body, sizeof(body), "01" T "%02X", s);
                len = build(body, 5, CS_LITERAL, pkt);
                circe_decode(pkt, len, &r);
                if (s == 0x6C)
                        assert_int_equal(r.kind, CIRCE_RESULT_MESSAGE);
                else
                        assert_int_equal(r.reason, CIRCE_REASON_BAD_CHECKSUM);
        }
}

/* ---- Parameter limits ------------------------------------------------------------------------ */

struct limit {
        unsigned id;
        const char *value;
        enum circe_reason reason;       /* NONE: accepted */
        long want;                      /* the decoded value when accepted */
};

/* A packet of an operation that allows id, with '@' where the value goes. */
static const char *host_template(unsigned id)
{
        switch (id) {
        case 10: return "51" T "010:@" T "012:0" T;
        case 12: return "51" T "010:0.2.3" T "012:@" T;
        case 14: return "03" T "014:@" T;
        case 15: return "53" T "015:@" T;
        case 16: return "52" T "015:E1E1E1" T "016:@" T "019:32" T "020:4" T "021:150" T;
        case 17: return "04" T "014:123456" T "017:@" T "020:3" T;
        case 19: return "52" T "015:E1E1E1" T "016:1" T "019:@" T "020:4" T "021:150" T;
        case 20: return "52" T "015:E1E1E1" T "016:1" T "019:32" T "020:@" T "021:150" T;
        case 21: return "52" T "015:E1E1E1" T "016:1" T "019:32" T "020:4" T "021:@" T;
        case 22: return NS_HEAD "022:@" T;
        case 23: return NS_HEAD "023:@" T;
        case 24: return "53" T "015:AAAAAA" T "024:@" T;
        case 25: return "53" T "015:AAAAAA" T "025:@" T;
        case 26: return "05" T "026:@" T;
        case 27: return NS_HEAD "027:@" T;
        case 28: return "07" T "028:@" T "014:D15D15" T;
        case 29: return "07" T "029:@" T "014:D15D15" T;
        case 30: return "07" T "030:@" T "014:D15D15" T;
        case 31: return "07" T "031:@" T "014:D15D15" T;
        case 32: return "07" T "032:@" T "014:D15D15" T;
        case 33: return "07" T "033:@" T "014:D15D15" T;
        case 34: return "07" T "034:@" T "014:D15D15" T;
        case 35: return "07" T "035:@" T "014:D15D15" T;
        case 36: return "54" T "036:@" T;
        case 37: return NS_HEAD "037:@" T;
        case 38: return "07" T "038:@" T "014:D15D15" T;
        default: return NULL;
        }
}

static void build_limit_body(const struct limit *l, char *out, size_t size)
{
        const char *tpl = host_template(l->id);
        size_t n = 0;

        assert_non_null(tpl);
        for (const char *p = tpl; *p; p++) {
                const char *s = *p == '@' ? l->value : (char[2]){ *p, 0 };
                size_t k = strlen(s);
                assert_true(n + k < size);
                memcpy(out + n, s, k);
                n += k;
        }
        out[n] = '\0';
}

/* The decoded value of parameter id, read from the typed struct; -1 when absent. */
static long field_of(const struct circe_msg *m, unsigned id)
{
        const struct circe_visualize *v = &m->u.visualize;
        const struct circe_notify_status *s = &m->u.notify_status;
        const struct circe_notify_action *a = &m->u.notify_action;

        switch (id) {
        case 10: return m->u.keep_alive.version.major * 1000000L +
                        m->u.keep_alive.version.minor * 1000L + m->u.keep_alive.version.patch;
        case 12: return m->u.keep_alive.status;
        case 14: return m->u.alert.dest;
        case 15: return a->origin;
        case 16: return s->membership;
        case 17: return m->u.network_setup.set_membership;
        case 19: return s->capabilities;
        case 20: return s->roles;
        case 21: return s->signal;
        case 22: return s->has_battery ? s->battery : -1;
        case 23: return s->has_aligned ? s->aligned : -1;
        case 24: return a->has_keys ? a->keys : -1;
        case 25: return a->has_sensor_time ? (long)a->sensor_time_ms : -1;
        case 26: return m->u.device_setup.assign;
        case 27: return s->has_clock_sync ? s->clock_sync : -1;
        case 28: return v->has_current ? v->current : -1;
        case 29: return v->has_next ? v->next : -1;
        case 30: return v->start_timer ? 1 : -1;
        case 31: return v->has_primary ? (long)v->primary_ms : -1;
        case 32: return v->has_faults ? v->faults : -1;
        case 33: return v->has_refusals ? v->refusals : -1;
        case 34: return v->has_eliminated ? v->eliminated : -1;
        case 35: return v->has_placement ? v->placement : -1;
        case 36: return m->u.log.len ? m->u.log.data[m->u.log.len - 1] : -1;
        case 37: return s->has_version_mismatch ? s->version_mismatch : -1;
        case 38: return v->has_secondary ? (long)v->secondary_ms : -1;
        default: return -2;
        }
}

#define L_OK(i, v, w) { i, v, CIRCE_REASON_NONE, w }
#define L_LEN(i, v) { i, v, CIRCE_REASON_VALUE_LENGTH, 0 }
#define L_TYPE(i, v) { i, v, CIRCE_REASON_VALUE_TYPE, 0 }
#define L_RANGE(i, v) { i, v, CIRCE_REASON_VALUE_RANGE, 0 }

/* Just inside and just outside every limit of PROTOCOLS.md 2.3. */
static const struct limit limits[] = {
        L_OK(10, "0.2.3", 2003), L_OK(10, "999.999.999", 999999999), L_OK(10, "0.0.0", 0),
        L_OK(10, "001.02.3", 1002003), L_LEN(10, ""), L_LEN(10, "0001.002.003"),
        L_TYPE(10, "1000.1.1"), L_TYPE(10, "1.2"), L_TYPE(10, "1.2.3.4"), L_TYPE(10, "1..3"),
        L_TYPE(10, ".1.2"), L_TYPE(10, "1.2."), L_TYPE(10, "a.b.c"), L_TYPE(10, "1.2.3 "),
        L_TYPE(10, "1,2,3"), L_TYPE(10, "+1.2.3"),
        L_OK(12, "0", 0), L_OK(12, "999", 999), L_OK(12, "012", 12), L_LEN(12, "1000"),
        L_LEN(12, ""), L_TYPE(12, "-1"), L_TYPE(12, " 1"), L_TYPE(12, "1a"), L_TYPE(12, "+1"),
        L_OK(14, "000000", 0), L_OK(14, "FFFFFE", 0xFFFFFE), L_OK(14, "0A1B2C", 0x0A1B2C),
        L_RANGE(14, "FFFFFF"), L_TYPE(14, "fffffe"), L_TYPE(14, "12345G"), L_TYPE(14, " 12345"),
        L_LEN(14, "12345"), L_LEN(14, "1234567"), L_LEN(14, ""),
        L_OK(15, "ABCDEF", 0xABCDEF), L_RANGE(15, "FFFFFF"), L_TYPE(15, "abcdef"),
        L_LEN(15, "ABCDE"),
        L_OK(16, "0", 0), L_OK(16, "1", 1), L_RANGE(16, "2"), L_LEN(16, "01"), L_LEN(16, ""),
        L_TYPE(16, "a"),
        L_OK(17, "0", 0), L_OK(17, "1", 1), L_RANGE(17, "2"), L_LEN(17, "10"),
        L_OK(19, "0", 0), L_OK(19, "127", 127), L_RANGE(19, "128"), L_LEN(19, "0127"),
        L_OK(20, "127", 127), L_RANGE(20, "128"), L_LEN(20, "1000"), L_TYPE(20, "1-2"),
        L_OK(21, "255", 255), L_OK(21, "000", 0), L_RANGE(21, "256"), L_LEN(21, "0255"),
        L_OK(22, "255", 255), L_OK(22, "0", 0), L_RANGE(22, "256"), L_LEN(22, ""),
        L_OK(23, "1", 1), L_OK(23, "0", 0), L_RANGE(23, "2"), L_TYPE(23, "T"),
        L_OK(24, "65535", 65535), L_OK(24, "0", 0), L_RANGE(24, "65536"),
        L_LEN(24, "100000"), L_TYPE(24, "0x100"),
        L_OK(25, "999999", 999999), L_OK(25, "000000", 0), L_LEN(25, "1000000"),
        L_TYPE(25, "1.5"),
        L_OK(26, "E1E1E1", 0xE1E1E1), L_OK(26, "000000", 0), L_RANGE(26, "FFFFFF"),
        L_TYPE(26, "e1e1e1"), L_LEN(26, "E1E1E1E"),
        L_OK(27, "1", 1), L_OK(27, "2", 2), L_RANGE(27, "0"), L_RANGE(27, "3"), L_LEN(27, "01"),
        L_OK(28, "999", 999), L_OK(28, "0999", 999), L_OK(28, "0", 0), L_RANGE(28, "1000"),
        L_LEN(28, "00000"), L_TYPE(28, "-1"),
        L_OK(29, "999", 999), L_OK(29, "0000", 0), L_RANGE(29, "1000"), L_RANGE(29, "9999"),
        L_LEN(29, "01000"),
        L_OK(30, "1", 1), L_RANGE(30, "0"), L_RANGE(30, "2"), L_LEN(30, "01"), L_LEN(30, ""),
        L_OK(31, "999999", 999999), L_OK(31, "0", 0), L_LEN(31, "1000000"), L_TYPE(31, "9e5"),
        L_OK(32, "99", 99), L_OK(32, "0", 0), L_LEN(32, "100"), L_TYPE(32, " 9"),
        L_OK(33, "99", 99), L_LEN(33, "100"), L_LEN(33, ""),
        L_OK(34, "0", 0), L_OK(34, "1", 1), L_RANGE(34, "2"), L_LEN(34, "00"),
        L_OK(35, "999", 999), L_OK(35, "0", 0), L_LEN(35, "1000"), L_TYPE(35, "x"),
        L_OK(36, "00", 0), L_OK(36, "0123456789ABCDEF", 0xEF), L_LEN(36, ""),
        L_TYPE(36, "0"), L_TYPE(36, "ABC"), L_TYPE(36, "0g"), L_TYPE(36, "ab"),
        L_TYPE(36, "A B "),
        L_OK(37, "1", 1), L_OK(37, "0", 0), L_RANGE(37, "2"), L_LEN(37, ""),
        L_OK(38, "999999", 999999), L_OK(38, "0", 0), L_LEN(38, "1000000"), L_TYPE(38, "-1"),
};

static void test_parameter_limits(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(limits) / sizeof(limits[0]); i++) {
                const struct limit *l = &limits[i];
                char body[256];
                uint8_t pkt[PKT_MAX];
                struct circe_result r;
                size_t len;

                build_limit_body(l, body, sizeof(body));
                for (int cs = 0; cs < 2; cs++) {
                        len = build(body, strlen(body), cs ? CS_UPPER : CS_NONE, pkt);
                        circe_decode(pkt, len, &r);
                        if (l->reason == CIRCE_REASON_NONE) {
                                if (r.kind != CIRCE_RESULT_MESSAGE)
                                        fail_msg("%03u:\"%s\" rejected: %s (param %u)", l->id,
                                                 l->value, circe_reason_str(r.reason), r.param);
                                if (field_of(&r.msg, l->id) != l->want)
                                        fail_msg("%03u:\"%s\" decoded as %ld, want %ld", l->id,
                                                 l->value, field_of(&r.msg, l->id), l->want);
                        } else if (r.reason != l->reason || r.param != l->id) {
                                fail_msg("%03u:\"%s\": got \"%s\" param %u, want \"%s\"", l->id,
                                         l->value, circe_reason_str(r.reason), r.param,
                                         circe_reason_str(l->reason));
                        }
                }
        }
}

/* Log data decodes to bytes: every byte value, and the largest payload. */
static void test_log_data(void **state)
{
        char body[PKT_MAX];
        uint8_t pkt[PKT_MAX];
        struct circe_result r;
        size_t n = 0, len;

        (void)state;
        n += (size_t)snprintf(body, sizeof(body), "54" T "036:");
        for (unsigned b = 0; b < 256; b++)
                n += (size_t)snprintf(body + n, sizeof(body) - n, "%02X", b);
        body[n++] = '\t';
        len = build(body, n, CS_UPPER, pkt);
        circe_decode(pkt, len, &r);
        assert_int_equal(r.kind, CIRCE_RESULT_MESSAGE);
        assert_int_equal(r.msg.u.log.len, 256);
        for (unsigned b = 0; b < 256; b++)
                assert_int_equal(r.msg.u.log.data[b], b);
}

/* ---- Framing on a byte stream ---------------------------------------------------------------- */

struct expect {
        enum circe_result_kind kind;
        enum circe_reason reason;
        enum circe_op op;
};

/* Feeds stream with cuts at the given offsets (sorted, may be empty), collects the results. */
static size_t feed_all(struct circe_decoder *d, const uint8_t *s, size_t len, const size_t *cuts,
                       size_t ncuts, struct expect *out, size_t max)
{
        size_t nres = 0, start = 0;

        for (size_t c = 0; c <= ncuts; c++) {
                size_t stop = c < ncuts ? cuts[c] : len;
                while (start < stop) {
                        struct circe_result r;
                        size_t n = circe_decoder_feed(d, s + start, stop - start, &r);

                        assert_true(n >= 1 && n <= stop - start);
                        assert_true(n == stop - start || r.kind != CIRCE_RESULT_NONE);
                        start += n;
                        if (r.kind == CIRCE_RESULT_NONE)
                                continue;
                        assert_true(nres < max);
                        out[nres].kind = r.kind;
                        out[nres].reason = r.reason;
                        out[nres].op = r.msg.op;
                        nres++;
                }
        }
        return nres;
}

static void assert_results(const struct expect *got, size_t ngot, const struct expect *want,
                           size_t nwant)
{
        assert_int_equal(ngot, nwant);
        for (size_t i = 0; i < nwant; i++) {
                if (got[i].kind != want[i].kind || got[i].reason != want[i].reason ||
                    got[i].op != want[i].op)
                        fail_msg("result %zu: kind %d reason \"%s\" op %d, want %d \"%s\" %d", i,
                                 got[i].kind, circe_reason_str(got[i].reason), got[i].op,
                                 want[i].kind, circe_reason_str(want[i].reason), want[i].op);
        }
}

#define MSG(o) { CIRCE_RESULT_MESSAGE, CIRCE_REASON_NONE, o }
#define REJ(r) { CIRCE_RESULT_REJECTED, r, CIRCE_OP_NONE }

static void check_stream(const char *stream, size_t len, const struct expect *want, size_t nwant,
                         struct circe_decoder_stats *ret_stats)
{
        const uint8_t *s = (const uint8_t *)stream;
        struct expect got[RESULTS_MAX];
        struct circe_decoder d;
        size_t n;

        circe_decoder_init(&d);
        n = feed_all(&d, s, len, NULL, 0, got, RESULTS_MAX);
        assert_results(got, n, want, nwant);
        *ret_stats = d.stats;
        assert_int_equal(d.stats.bytes, len);

        /* Split at every boundary: same results, same counters. */
        for (size_t cut = 0; cut <= len; cut++) {
                circe_decoder_init(&d);
                n = feed_all(&d, s, len, &cut, 1, got, RESULTS_MAX);
                assert_results(got, n, want, nwant);
                assert_memory_equal(&d.stats, ret_stats, sizeof(d.stats));
        }
}

static void test_noise_and_stray_etx(void **state)
{
        static const char s[] =
                "xyz\r\n"                                       /* noise before: 5 */
                STX "01" T ETX
                "\n\r" ETX ETX                                  /* noise 2, stray ETX 2 */
                STX "03" T "014:123456" T ETX
                "\xff\x00 "                                     /* noise 3 (one NUL) */
                STX "02" T ETX
                ETX;                                            /* stray ETX 1 */
        const struct expect want[] = { MSG(CIRCE_OP_LOGIN), MSG(CIRCE_OP_ALERT),
                                       MSG(CIRCE_OP_LOGOUT) };
        struct circe_decoder_stats st;

        (void)state;
        check_stream(s, sizeof(s) - 1, want, 3, &st);
        assert_int_equal(st.noise, 10);
        assert_int_equal(st.stray_etx, 3);
        assert_int_equal(st.messages, 3);
        assert_int_equal(st.discarded, 0);
}

static void test_stx_restart(void **state)
{
        static const char s[] =
                STX "03" T "014:12"                             /* abandoned by the next STX */
                STX "01" T ETX
                STX STX STX "02" T ETX                          /* two empty partials abandoned */
                STX "53" T "015:AAAAAA" T ETX;
        const struct expect want[] = { REJ(CIRCE_REASON_ABANDONED), MSG(CIRCE_OP_LOGIN),
                                       REJ(CIRCE_REASON_ABANDONED),
                                       REJ(CIRCE_REASON_ABANDONED), MSG(CIRCE_OP_LOGOUT),
                                       MSG(CIRCE_OP_NOTIFY_ACTION) };
        struct circe_decoder_stats st;
        struct circe_decoder d;
        struct circe_result r;

        (void)state;
        check_stream(s, sizeof(s) - 1, want, 6, &st);
        assert_int_equal(st.rejected[CIRCE_REASON_ABANDONED], 3);
        assert_int_equal(st.messages, 3);

        /* The abandoned result shows the partial packet. */
        circe_decoder_init(&d);
        assert_int_equal(circe_decoder_feed(&d, (const uint8_t *)s, sizeof(s) - 1, &r), 11);
        assert_int_equal(r.reason, CIRCE_REASON_ABANDONED);
        assert_int_equal(r.packet_len, 10);
        assert_memory_equal(r.packet, STX "03" T "014:12", 10);
}

/* Garbage inside a packet spoils that packet only. */
static void test_noise_inside(void **state)
{
        static const char s[] =
                STX "03" T "014:12\xff\xfe" "3456" T ETX
                STX "03" T "0\r\n14:123456" T ETX
                STX "03" T "014:123456" T "7B" ETX;
        const struct expect want[] = { REJ(CIRCE_REASON_VALUE_LENGTH),
                                       REJ(CIRCE_REASON_BAD_PARAM_SYNTAX), MSG(CIRCE_OP_ALERT) };
        struct circe_decoder_stats st;

        (void)state;
        check_stream(s, sizeof(s) - 1, want, 3, &st);
        assert_int_equal(st.noise, 0);
}

/* A Log body of n data bytes (2n hex digits), without checksum. */
static size_t log_body(char *body, size_t n)
{
        size_t k = (size_t)sprintf(body, "54" T "036:");

        for (size_t i = 0; i < n; i++)
                k += (size_t)sprintf(body + k, "%02X", (unsigned)((i * 7) & 0xFF));
        body[k++] = '\t';
        return k;
}

static void test_packet_bound(void **state)
{
        static char body[PKT_MAX];
        static uint8_t s[4 * PKT_MAX];
        struct expect got[8];
        struct circe_decoder d;
        struct circe_result r;
        size_t len, n;

        (void)state;
        /* Exactly CIRCE_PACKET_MAX bytes, with and without checksum: accepted. */
        len = build(body, log_body(body, CIRCE_LOG_MAX), CS_NONE, s);
        assert_int_equal(len, CIRCE_PACKET_MAX);
        circe_decoder_init(&d);
        assert_int_equal(circe_decoder_feed(&d, s, len, &r), len);
        assert_int_equal(r.kind, CIRCE_RESULT_MESSAGE);
        assert_int_equal(r.msg.u.log.len, CIRCE_LOG_MAX);
        len = build(body, log_body(body, CIRCE_LOG_MAX - 1), CS_UPPER, s);
        assert_int_equal(len, CIRCE_PACKET_MAX);
        assert_int_equal(circe_decoder_feed(&d, s, len, &r), len);
        assert_int_equal(r.kind, CIRCE_RESULT_MESSAGE);
        assert_true(r.has_checksum);

        /* One byte more: overlong at byte 1025, the rest up to the next STX discarded,
         * then the decoder recovers. */
        len = build(body, log_body(body, CIRCE_LOG_MAX), CS_NONE, s);
        memmove(s + 2, s + 1, len - 1);        /* doubles the first op digit: "554" */
        len++;
        assert_int_equal(len, CIRCE_PACKET_MAX + 1);
        memcpy(s + len, STX "01" T ETX, 5);
        circe_decoder_init(&d);
        n = circe_decoder_feed(&d, s, len + 5, &r);
        assert_int_equal(n, CIRCE_PACKET_MAX);  /* the byte that cannot fit */
        assert_int_equal(r.kind, CIRCE_RESULT_REJECTED);
        assert_int_equal(r.reason, CIRCE_REASON_OVERLONG);
        assert_int_equal(r.packet_len, CIRCE_PACKET_MAX - 1);
        n += circe_decoder_feed(&d, s + n, len + 5 - n, &r);
        assert_int_equal(n, len + 5);
        assert_int_equal(r.kind, CIRCE_RESULT_MESSAGE);
        assert_int_equal(r.msg.op, CIRCE_OP_LOGIN);
        assert_int_equal(d.stats.discarded, 2);         /* the 1024th body byte and the ETX */
        assert_int_equal(d.stats.rejected[CIRCE_REASON_OVERLONG], 1);
        assert_int_equal(d.stats.stray_etx, 0);
        {
                /* The same whatever the reads: split everywhere, counters included. */
                const struct expect want2[] = { REJ(CIRCE_REASON_OVERLONG), MSG(CIRCE_OP_LOGIN) };
                struct circe_decoder_stats st;
                check_stream((const char *)s, len + 5, want2, 2, &st);
                assert_int_equal(st.discarded, 2);
        }
        {
                /* Exactly at the bound, preceded and followed by other packets, split
                 * everywhere. */
                size_t k = build("02" T, 3, CS_NONE, s);
                k += build(body, log_body(body, CIRCE_LOG_MAX), CS_NONE, s + k);
                k += build("06" T, 3, CS_UPPER, s + k);
                const struct expect want3[] = { MSG(CIRCE_OP_LOGOUT), MSG(CIRCE_OP_LOG),
                                                MSG(CIRCE_OP_SYNC_CLOCKS) };
                struct circe_decoder_stats st;
                check_stream((const char *)s, k, want3, 3, &st);
                assert_int_equal(st.rejected[CIRCE_REASON_OVERLONG], 0);
        }

        /* A long run of garbage after STX: one overlong result, not one per byte. */
        memset(s, 'A', sizeof(s));
        s[0] = 0x02;
        memcpy(s + 3000, STX "02" T ETX, 5);
        circe_decoder_init(&d);
        const struct expect want[] = { REJ(CIRCE_REASON_OVERLONG), MSG(CIRCE_OP_LOGOUT) };
        n = feed_all(&d, s, 3005, NULL, 0, got, 8);
        assert_results(got, n, want, 2);
        assert_int_equal(d.stats.discarded, 3000 - (CIRCE_PACKET_MAX - 1));

        /* Standalone parser: longer than the bound is OVERLONG whatever the content. */
        len = build(body, log_body(body, CIRCE_LOG_MAX), CS_UPPER, s);
        assert_int_equal(len, CIRCE_PACKET_MAX + 2);
        circe_decode(s, len, &r);
        assert_int_equal(r.reason, CIRCE_REASON_OVERLONG);
}

/* The most destinations a packet holds, and one more. */
static void test_visualize_dest_bound(void **state)
{
        static char body[2 * PKT_MAX];
        static uint8_t pkt[2 * PKT_MAX];
        struct circe_result r;
        size_t k, len;

        (void)state;
        k = (size_t)sprintf(body, "07" T "030:1" T);
        for (unsigned i = 0; i < CIRCE_VISUALIZE_DEST_MAX; i++)
                k += (size_t)sprintf(body + k, "014:%06X" T, i + 1);
        len = build(body, k, CS_NONE, pkt);
        assert_true(len <= CIRCE_PACKET_MAX);
        circe_decode(pkt, len, &r);
        assert_int_equal(r.kind, CIRCE_RESULT_MESSAGE);
        assert_int_equal(r.msg.u.visualize.dest_count, CIRCE_VISUALIZE_DEST_MAX);
        assert_int_equal(r.msg.u.visualize.dests[CIRCE_VISUALIZE_DEST_MAX - 1],
                         CIRCE_VISUALIZE_DEST_MAX);

        k += (size_t)sprintf(body + k, "014:%06X" T, 0xABCDEFu);
        len = build(body, k, CS_NONE, pkt);
        assert_true(len > CIRCE_PACKET_MAX);
        circe_decode(pkt, len, &r);
        assert_int_equal(r.reason, CIRCE_REASON_OVERLONG);
}

static void test_decode_framing(void **state)
{
        static const struct {
                const char *bytes;
                size_t len;
        } bad[] = {
                { "", 0 },
                { STX, 1 },
                { ETX, 1 },
                { "01" T ETX, 4 },              /* no STX */
                { STX "01" T, 4 },              /* no ETX */
                { STX "01" T ETX ETX, 6 },      /* ETX inside */
                { STX "01" STX T ETX, 6 },      /* STX inside */
                { ETX "01" T STX, 5 },
        };
        struct circe_result r;

        (void)state;
        for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
                circe_decode((const uint8_t *)bad[i].bytes, bad[i].len, &r);
                assert_int_equal(r.kind, CIRCE_RESULT_REJECTED);
                assert_int_equal(r.reason, CIRCE_REASON_BAD_FRAMING);
                assert_int_equal(r.msg.op, CIRCE_OP_NONE);
        }
}

/* Every valid vector back to back, with noise between, cut everywhere and byte by byte. */
static void test_stream_of_vectors(void **state)
{
        static uint8_t s[STREAM_MAX];
        static struct expect want[RESULTS_MAX], got[RESULTS_MAX];
        struct circe_decoder d;
        size_t len = 0, nwant = 0, n;

        (void)state;
        for (size_t i = 0; i < VEC_COUNT; i++) {
                if (vecs[i].kind != CIRCE_RESULT_MESSAGE)
                        continue;
                for (int cs = 0; cs < 2; cs++) {
                        len += vec_build(&vecs[i], vecs[i].cs == CS_LITERAL ? CS_LITERAL
                                                   : cs ? CS_UPPER : CS_NONE, s + len);
                        s[len++] = (uint8_t)(i % 3 == 0 ? '\n' : i % 3 == 1 ? 0x03 : 0xAA);
                        want[nwant].kind = CIRCE_RESULT_MESSAGE;
                        want[nwant].reason = CIRCE_REASON_NONE;
                        want[nwant].op = vecs[i].msg.op;
                        nwant++;
                }
        }
        assert_true(len < STREAM_MAX);

        for (size_t cut = 0; cut <= len; cut++) {
                circe_decoder_init(&d);
                n = feed_all(&d, s, len, &cut, 1, got, RESULTS_MAX);
                assert_results(got, n, want, nwant);
        }
        {
                static size_t cuts[STREAM_MAX];
                for (size_t i = 0; i < len; i++)
                        cuts[i] = i + 1;
                circe_decoder_init(&d);
                n = feed_all(&d, s, len, cuts, len, got, RESULTS_MAX);
                assert_results(got, n, want, nwant);
                assert_int_equal(d.stats.messages, nwant);
        }
}

static void test_feed_empty(void **state)
{
        struct circe_decoder d;
        struct circe_result r;

        (void)state;
        circe_decoder_init(&d);
        r.kind = CIRCE_RESULT_MESSAGE;
        assert_int_equal(circe_decoder_feed(&d, (const uint8_t *)"", 0, &r), 0);
        assert_int_equal(r.kind, CIRCE_RESULT_NONE);
        assert_int_equal(d.stats.bytes, 0);
}

/* ---- Encoder --------------------------------------------------------------------------------- */

/* Canonical vectors encode to exactly their bytes, with and without checksum. */
static void test_encode_canonical(void **state)
{
        (void)state;
        for (size_t i = 0; i < VEC_COUNT; i++) {
                const struct vec *v = &vecs[i];
                uint8_t want[PKT_MAX];
                char got[PKT_MAX];
                size_t len;
                int n;

                if (!v->canonical)
                        continue;
                if (v->cs == CS_LITERAL) {
                        len = vec_build(v, CS_LITERAL, want);
                        n = circe_encode(&v->msg, 1, got, sizeof(got));
                } else {
                        len = vec_build(v, CS_NONE, want);
                        n = circe_encode(&v->msg, 0, got, sizeof(got));
                        if (n != (int)len || memcmp(got, want, len) != 0)
                                fail_msg("%s: encoding without checksum differs", v->name);
                        len = vec_build(v, CS_UPPER, want);
                        n = circe_encode(&v->msg, 1, got, sizeof(got));
                }
                if (n != (int)len || memcmp(got, want, len) != 0)
                        fail_msg("%s: encoding differs (%d bytes, want %zu)", v->name, n, len);
        }
}

/* Every decoded message re-encodes and decodes to the same message, both ways. */
static void test_round_trip(void **state)
{
        (void)state;
        for (size_t i = 0; i < VEC_COUNT; i++) {
                const struct vec *v = &vecs[i];

                if (v->kind != CIRCE_RESULT_MESSAGE)
                        continue;
                for (int cs = 0; cs < 2; cs++) {
                        char buf[PKT_MAX];
                        struct circe_result r;
                        int n = circe_encode(&v->msg, cs, buf, sizeof(buf));

                        if (n < 0)
                                fail_msg("%s: encode failed: %d", v->name, n);
                        circe_decode((const uint8_t *)buf, (size_t)n, &r);
                        assert_int_equal(r.kind, CIRCE_RESULT_MESSAGE);
                        assert_int_equal(r.skipped + r.repeated, 0);
                        assert_int_equal(r.has_checksum, cs);
                        if (!circe_msg_equal(&r.msg, &v->msg))
                                fail_msg("%s: round trip differs", v->name);
                }
        }
}

static void test_encode_limits(void **state)
{
        static char body[PKT_MAX];
        static struct circe_msg m;
        char buf[PKT_MAX];
        int n;

        (void)state;
        /* The largest Log: fits without checksum, one byte too long with. */
        memset(&m, 0, sizeof(m));
        m.op = CIRCE_OP_LOG;
        m.u.log.len = CIRCE_LOG_MAX;
        for (size_t i = 0; i < CIRCE_LOG_MAX; i++)
                m.u.log.data[i] = (uint8_t)((i * 7) & 0xFF);
        n = circe_encode(&m, 0, buf, sizeof(buf));
        assert_int_equal(n, CIRCE_PACKET_MAX);
        uint8_t want[PKT_MAX];
        size_t len = build(body, log_body(body, CIRCE_LOG_MAX), CS_NONE, want);
        assert_int_equal(len, (size_t)n);
        assert_memory_equal(buf, want, len);
        assert_int_equal(circe_encode(&m, 1, buf, sizeof(buf)), -EMSGSIZE);
        m.u.log.len = CIRCE_LOG_MAX - 1;
        assert_int_equal(circe_encode(&m, 1, buf, sizeof(buf)), CIRCE_PACKET_MAX);

        /* Visualize with every field and the most destinations: too long. */
        memset(&m, 0, sizeof(m));
        m.op = CIRCE_OP_VISUALIZE;
        m.u.visualize.dest_count = CIRCE_VISUALIZE_DEST_MAX;
        m.u.visualize.start_timer = true;
        assert_true(circe_encode(&m, 0, buf, sizeof(buf)) > 0);
        m.u.visualize.has_primary = true;
        assert_int_equal(circe_encode(&m, 0, buf, sizeof(buf)), -EMSGSIZE);

        /* The caller's buffer: exact size works (no NUL written), one less is refused. */
        memset(&m, 0, sizeof(m));
        m.op = CIRCE_OP_ALERT;
        m.u.alert.dest = 0x123456;
        n = circe_encode(&m, 1, buf, sizeof(buf));
        assert_int_equal(n, 18);
        char *exact = malloc((size_t)n);
        assert_non_null(exact);
        assert_int_equal(circe_encode(&m, 1, exact, (size_t)n), n);
        assert_memory_equal(exact, STX "03" T "014:123456" T "7B" ETX, (size_t)n);
        assert_int_equal(circe_encode(&m, 1, exact, (size_t)n - 1), -ENOBUFS);
        assert_int_equal(circe_encode(&m, 1, NULL, 0), -ENOBUFS);
        free(exact);
}

/* A message that is valid except for one field, changed by the table entry. */
struct refusal {
        const char *name;
        struct circe_msg msg;
};

#define VIS(...) { .op = CIRCE_OP_VISUALIZE, .u.visualize = { .dest_count = 1, __VA_ARGS__ } }
#define NSTAT(...) { .op = CIRCE_OP_NOTIFY_STATUS, .u.notify_status = { __VA_ARGS__ } }

static const struct refusal refusals[] = {
        { "op none", { .op = CIRCE_OP_NONE } },
        { "op 08", { .op = (enum circe_op)8 } },
        { "op 55", { .op = (enum circe_op)55 } },
        { "op 100", { .op = (enum circe_op)100 } },
        { "alert to FFFFFF", { .op = CIRCE_OP_ALERT, .u.alert.dest = 0xFFFFFF } },
        { "alert to a 25-bit address", { .op = CIRCE_OP_ALERT, .u.alert.dest = 0x1000000 } },
        { "network setup roles 128", { .op = CIRCE_OP_NETWORK_SETUP,
                                       .u.network_setup = { .roles = 128 } } },
        { "network setup to FFFFFF", { .op = CIRCE_OP_NETWORK_SETUP,
                                       .u.network_setup = { .dest = 0xFFFFFF } } },
        { "device setup caps 128", { .op = CIRCE_OP_DEVICE_SETUP,
                                     .u.device_setup = { .has_capabilities = true,
                                                         .capabilities = 128 } } },
        { "device setup assign FFFFFF", { .op = CIRCE_OP_DEVICE_SETUP,
                                          .u.device_setup = { .assign = 0xFFFFFF } } },
        { "device setup dest FFFFFF", { .op = CIRCE_OP_DEVICE_SETUP,
                                        .u.device_setup = { .has_dest = true,
                                                            .dest = 0xFFFFFF } } },
        { "visualize without display field", VIS(.dests = { 1 }) },
        { "visualize without destination",
          { .op = CIRCE_OP_VISUALIZE, .u.visualize = { .start_timer = true } } },
        { "visualize with too many destinations",
          { .op = CIRCE_OP_VISUALIZE,
            .u.visualize = { .dest_count = CIRCE_VISUALIZE_DEST_MAX + 1,
                             .start_timer = true } } },
        { "visualize destination FFFFFF", VIS(.dests = { 0xFFFFFF }, .start_timer = true) },
        { "visualize current 1000", VIS(.has_current = true, .current = 1000) },
        { "visualize next 1000", VIS(.has_next = true, .next = 1000) },
        { "visualize primary 1000000", VIS(.has_primary = true, .primary_ms = 1000000) },
        { "visualize secondary 1000000", VIS(.has_secondary = true, .secondary_ms = 1000000) },
        { "visualize faults 100", VIS(.has_faults = true, .faults = 100) },
        { "visualize refusals 100", VIS(.has_refusals = true, .refusals = 100) },
        { "visualize placement 1000", VIS(.has_placement = true, .placement = 1000) },
        { "keep alive major 1000", { .op = CIRCE_OP_KEEP_ALIVE,
                                     .u.keep_alive = { .version = { 1000, 0, 0 } } } },
        { "keep alive minor 1000", { .op = CIRCE_OP_KEEP_ALIVE,
                                     .u.keep_alive = { .version = { 0, 1000, 0 } } } },
        { "keep alive patch 1000", { .op = CIRCE_OP_KEEP_ALIVE,
                                     .u.keep_alive = { .version = { 0, 0, 1000 } } } },
        { "keep alive status 1000", { .op = CIRCE_OP_KEEP_ALIVE,
                                      .u.keep_alive = { .status = 1000 } } },
        { "notify status origin FFFFFF", NSTAT(.origin = 0xFFFFFF) },
        { "notify status caps 128", NSTAT(.capabilities = 128) },
        { "notify status roles 128", NSTAT(.roles = 128) },
        { "notify status clock sync 0", NSTAT(.has_clock_sync = true, .clock_sync = 0) },
        { "notify status clock sync 3", NSTAT(.has_clock_sync = true, .clock_sync = 3) },
        { "notify action origin FFFFFF", { .op = CIRCE_OP_NOTIFY_ACTION,
                                           .u.notify_action = { .origin = 0xFFFFFF } } },
        { "notify action sensor time 1000000",
          { .op = CIRCE_OP_NOTIFY_ACTION,
            .u.notify_action = { .has_sensor_time = true, .sensor_time_ms = 1000000 } } },
        { "log of 0 bytes", { .op = CIRCE_OP_LOG, .u.log = { .len = 0 } } },
        { "log of CIRCE_LOG_MAX + 1 bytes", { .op = CIRCE_OP_LOG,
                                              .u.log = { .len = CIRCE_LOG_MAX + 1 } } },
};

static void test_encode_refusals(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(refusals) / sizeof(refusals[0]); i++) {
                char buf[PKT_MAX];
                for (int cs = 0; cs < 2; cs++) {
                        int n = circe_encode(&refusals[i].msg, cs, buf, sizeof(buf));
                        if (n != -EINVAL)
                                fail_msg("%s: encode returned %d, want -EINVAL",
                                         refusals[i].name, n);
                }
        }
        /* The fields ignored while absent do not make a message invalid. */
        struct circe_msg m = VIS(.dests = { 5 }, .start_timer = true, .current = 5000,
                                 .faults = 200, .placement = 9999, .primary_ms = 1u << 30);
        char buf[PKT_MAX];
        assert_true(circe_encode(&m, 1, buf, sizeof(buf)) > 0);
}

/* ---- Helpers --------------------------------------------------------------------------------- */

static void test_msg_equal(void **state)
{
        struct circe_msg a = { .op = CIRCE_OP_NOTIFY_ACTION,
                               .u.notify_action = { .origin = 1, .has_keys = true, .keys = 2 } };
        struct circe_msg b = a;

        (void)state;
        assert_true(circe_msg_equal(&a, &b));
        b.u.notify_action.keys = 3;
        assert_false(circe_msg_equal(&a, &b));
        b = a;
        b.u.notify_action.has_keys = false;
        assert_false(circe_msg_equal(&a, &b));
        b.u.notify_action.keys = 0;
        a.u.notify_action.has_keys = false;
        assert_true(circe_msg_equal(&a, &b));           /* absent values are not compared */
        b.op = CIRCE_OP_NOTIFY_STATUS;
        assert_false(circe_msg_equal(&a, &b));

        /* Each canonical vector differs from every other one. */
        for (size_t i = 0; i < VEC_COUNT; i++)
                for (size_t j = 0; j < VEC_COUNT; j++) {
                        if (!vecs[i].canonical || !vecs[j].canonical)
                                continue;
                        bool same = strcmp(vecs[i].body, vecs[j].body) == 0 ||
                                    (vecs[i].msg.op == CIRCE_OP_LOGIN &&
                                     vecs[j].msg.op == CIRCE_OP_LOGIN) ||
                                    (vecs[i].msg.op == CIRCE_OP_ALERT &&
                                     vecs[j].msg.op == CIRCE_OP_ALERT &&
                                     vecs[i].msg.u.alert.dest == vecs[j].msg.u.alert.dest);
                        if (circe_msg_equal(&vecs[i].msg, &vecs[j].msg) != same)
                                fail_msg("equal(%s, %s) != %d", vecs[i].name, vecs[j].name,
                                         same);
                }
}

static void test_capabilities_compliant(void **state)
{
        static const struct {
                unsigned caps;
                bool ok;
        } cases[] = {
                { 0, false }, { 1, true }, { 2, true }, { 4, true }, { 8, true }, { 16, true },
                { 31, true }, { 32, true }, { 33, false }, { 48, false }, { 64, true },
                { 65, false }, { 96, false }, { 127, false }, { 128, false }, { 160, false },
                { 3, true }, { 12, true },
        };

        (void)state;
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++)
                if (circe_capabilities_compliant(cases[i].caps) != cases[i].ok)
                        fail_msg("capabilities %u: want %d", cases[i].caps, cases[i].ok);
        assert_int_equal(CIRCE_CAP_TIME_SENSOR, 32);
        assert_int_equal(CIRCE_CAP_DISPLAY, 64);
        assert_int_equal(CIRCE_ROLE_INTERMEDIATE_TIMER_3, 32);
        assert_int_equal(CIRCE_KEY_0, 2048);
        assert_int_equal(CIRCE_KEY_READY, 32768);
}

static void test_address_and_version(void **state)
{
        static const struct {
                const char *s;
                int r;
                uint32_t addr;
        } addrs[] = {
                { "E1E1E1", 0, 0xE1E1E1 },
                { "000000", 0, 0 },
                { "FFFFFE", 0, 0xFFFFFE },
                { "FFFFFF", -ERANGE, 0 },       /* reserved: its own error */
                { "e1e1e1", -EINVAL, 0 },
                { "E1E1E", -EINVAL, 0 },
                { "E1E1E1E", -EINVAL, 0 },
                { "G1E1E1", -EINVAL, 0 },
                { "", -EINVAL, 0 },
        };
        static const struct {
                const char *s;
                unsigned parts;
                int r;
                unsigned major, minor, patch;
        } versions[] = {
                { "0.2.3", 3, 0, 0, 2, 3 },
                { "999.999.999", 3, 0, 999, 999, 999 },
                { "0.2", 2, 0, 0, 2, 0 },
                { "10.20", 2, 0, 10, 20, 0 },
                { "7", 1, 0, 7, 0, 0 },
                { "0.2", 3, -EINVAL, 0, 0, 0 },
                { "0.2.3", 2, -EINVAL, 0, 0, 0 },
                { "1.2.3x", 3, -EINVAL, 0, 0, 0 },
                { "1000.2.3", 3, -EINVAL, 0, 0, 0 },
                { "v0.2.3", 3, -EINVAL, 0, 0, 0 },
                { "0..2", 2, -EINVAL, 0, 0, 0 },
                { "0.2.", 2, -EINVAL, 0, 0, 0 },
                { ".2", 2, -EINVAL, 0, 0, 0 },
                { "", 2, -EINVAL, 0, 0, 0 },
                { "0.2.3", 0, -EINVAL, 0, 0, 0 },
                { "0.2.3", 4, -EINVAL, 0, 0, 0 },
        };
        char s[CIRCE_ADDRESS_LEN + 1];
        uint32_t a;
        struct circe_version v;

        (void)state;
        circe_address_format(0x0A1B2C, s);
        assert_string_equal(s, "0A1B2C");
        circe_address_format(0, s);
        assert_string_equal(s, "000000");
        for (size_t i = 0; i < sizeof(addrs) / sizeof(addrs[0]); i++) {
                a = 42;
                assert_int_equal(circe_address_parse(addrs[i].s, strlen(addrs[i].s), &a),
                                 addrs[i].r);
                assert_int_equal(a, addrs[i].r == 0 ? addrs[i].addr : 42);  /* untouched */
        }
        /* The length decides: a NUL inside it is not a hex digit. */
        assert_int_equal(circe_address_parse("E1E\0E1", 6, &a), -EINVAL);

        for (size_t i = 0; i < sizeof(versions) / sizeof(versions[0]); i++) {
                v = (struct circe_version){ 1, 1, 1 };
                assert_int_equal(circe_version_parse(versions[i].s, strlen(versions[i].s),
                                                     versions[i].parts, &v), versions[i].r);
                if (versions[i].r < 0) {
                        assert_int_equal(v.major + v.minor + v.patch, 3);       /* untouched */
                        continue;
                }
                assert_int_equal(v.major, versions[i].major);
                assert_int_equal(v.minor, versions[i].minor);
                assert_int_equal(v.patch, versions[i].patch);
        }
}

static void test_strings(void **state)
{
        (void)state;
        for (int i = 0; i < CIRCE_REASON_COUNT; i++) {
                const char *s = circe_reason_str((enum circe_reason)i);
                assert_non_null(s);
                for (int j = 0; j < i; j++)
                        assert_string_not_equal(s, circe_reason_str((enum circe_reason)j));
        }
        assert_string_equal(circe_reason_str(CIRCE_REASON_BAD_CHECKSUM), "bad checksum");
        assert_string_equal(circe_reason_str(CIRCE_REASON_COUNT), "unknown reason");
        assert_string_equal(circe_op_str(CIRCE_OP_NOTIFY_STATUS), "Notify Status");
        assert_string_equal(circe_op_str(CIRCE_OP_SYNC_CLOCKS), "Synchronize Clocks");
        assert_null(circe_op_str((enum circe_op)8));
        assert_null(circe_op_str(CIRCE_OP_NONE));
        assert_true(circe_op_from_controller(CIRCE_OP_VISUALIZE));
        assert_false(circe_op_from_controller(CIRCE_OP_KEEP_ALIVE));
        assert_false(circe_op_from_controller((enum circe_op)99));
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_vectors),
                cmocka_unit_test(test_checksum_presence_rule),
                cmocka_unit_test(test_parameter_limits),
                cmocka_unit_test(test_log_data),
                cmocka_unit_test(test_noise_and_stray_etx),
                cmocka_unit_test(test_stx_restart),
                cmocka_unit_test(test_noise_inside),
                cmocka_unit_test(test_packet_bound),
                cmocka_unit_test(test_visualize_dest_bound),
                cmocka_unit_test(test_decode_framing),
                cmocka_unit_test(test_stream_of_vectors),
                cmocka_unit_test(test_feed_empty),
                cmocka_unit_test(test_encode_canonical),
                cmocka_unit_test(test_round_trip),
                cmocka_unit_test(test_encode_limits),
                cmocka_unit_test(test_encode_refusals),
                cmocka_unit_test(test_msg_equal),
                cmocka_unit_test(test_capabilities_compliant),
                cmocka_unit_test(test_address_and_version),
                cmocka_unit_test(test_strings),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
