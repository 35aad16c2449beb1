/*
 * Unit tests of the SharedLink codec (src/proto/sharedlink.c) against PROTOCOLS.md section 1.
 *
 * The decoder vectors are literal wire bytes whose checksums were computed outside this code base
 * (the spec's worked examples among them). Every vector is decoded whole, split in two at every
 * byte boundary, and byte by byte; all three must give the same results. A result is written as
 * text: a frame as "AB|N0@0|D1" (dst src, then the fields; N/L show "@index", unknown types a
 * leading '*', and " {u=1}" / " {e=2}" count unknown and empty fields), a rejection as
 * "!reason/bytes". Results are separated by " ; ".
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <errno.h>
#include <limits.h>
#include <sys/mman.h>
#include <unistd.h>
#include <cmocka.h>

#include "common/wire.h"
#include "proto/sharedlink.h"
#include "shm/layout.h"

#define OUT_MAX         16384
#define PIECES_MAX      4

static struct slp_decoder dec;

/* ---------------------------------------------------------------------------------------------
 * Result transcript */

struct out {
        char s[OUT_MAX];
        size_t n;
};

static void out_add(struct out *o, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static void out_add(struct out *o, const char *fmt, ...)
{
        va_list ap;
        int r;

        va_start(ap, fmt);
        r = vsnprintf(o->s + o->n, sizeof(o->s) - o->n, fmt, ap);
        va_end(ap);
        assert_true(r >= 0 && (size_t)r < sizeof(o->s) - o->n);
        o->n += (size_t)r;
}

static const char *reason_tag(enum slp_decode_reason r)
{
        static const char *const tags[SLP_REASON_COUNT] = {
                [SLP_REASON_NONE] = "none",
                [SLP_REASON_NOISE] = "noise",
                [SLP_REASON_RESYNC] = "resync",
                [SLP_REASON_OVERLONG] = "overlong",
                [SLP_REASON_TRUNCATED] = "truncated",
                [SLP_REASON_NO_CHECKSUM] = "nocsum",
                [SLP_REASON_BAD_CHECKSUM_SYNTAX] = "csumsyntax",
                [SLP_REASON_BAD_CHECKSUM] = "badcsum",
                [SLP_REASON_BAD_HEADER] = "header",
                [SLP_REASON_BAD_ADDRESS] = "address",
                [SLP_REASON_BAD_FIELD] = "field",
                [SLP_REASON_NO_FIELDS] = "nofields",
                [SLP_REASON_UNKNOWN_FIELD] = "unknown",
                [SLP_REASON_EMPTY_FIELD] = "empty",
        };

        assert_true(r >= 0 && r < SLP_REASON_COUNT);
        return tags[r];
}

/* Checks what every decoded frame must satisfy, then writes it to the transcript. */
static void describe_frame(struct out *o, const struct slp_decode_result *r)
{
        const struct slp_frame *f = r->frame;
        size_t unknown = 0;

        assert_non_null(f);
        assert_true(f->dst >= 'A' && f->dst <= 'P' && f->src >= 'A' && f->src <= 'P');
        assert_int_equal(f->dst_index, f->dst - 'A');
        assert_int_equal(f->src_index, f->src - 'A');
        assert_int_equal(r->bytes, f->raw_len);
        assert_true(f->raw_len <= dec.max_frame);
        assert_int_equal(f->raw[0], '[');
        assert_int_equal(f->raw[f->raw_len - 1], ']');
        assert_true(f->nfields > 0);
        out_add(o, "%c%c", f->dst, f->src);
        for (size_t i = 0; i < f->nfields; i++) {
                const struct slp_field *fl = &f->fields[i];

                /* Values point into the decoder's copy of the frame. */
                assert_true(fl->value > f->raw && fl->value + fl->len < f->raw + f->raw_len);
                if (fl->type == SLP_FIELD_UNKNOWN) {
                        unknown++;
                        out_add(o, "|*");
                } else {
                        assert_int_equal(fl->type, fl->letter);
                        out_add(o, "|");
                }
                out_add(o, "%c%.*s", fl->letter, (int)fl->len, fl->value);
                if (fl->type == SLP_FIELD_N || fl->type == SLP_FIELD_L) {
                        if (fl->index == SLP_INDEX_QUERY)
                                out_add(o, "@?");
                        else
                                out_add(o, "@%lu", (unsigned long)fl->index);
                }
        }
        assert_int_equal(unknown, f->unknown_fields);
        if (f->unknown_fields)
                out_add(o, " {u=%zu}", f->unknown_fields);
        if (f->empty_fields)
                out_add(o, " {e=%zu}", f->empty_fields);
}

static void describe(struct out *o, const struct slp_decode_result *r)
{
        if (o->n > 0)
                out_add(o, " ; ");
        if (r->kind == SLP_RESULT_FRAME) {
                describe_frame(o, r);
        } else {
                assert_int_equal(r->kind, SLP_RESULT_REJECT);
                assert_null(r->frame);
                assert_true(r->reason != SLP_REASON_NONE);
                assert_true(r->bytes > 0);
                out_add(o, "!%s/%zu", reason_tag(r->reason), r->bytes);
        }
}

/* Feeds one chunk, describing every result; the decoder must always make progress. */
static void feed_chunk(const uint8_t *p, size_t n, struct out *o)
{
        while (n > 0) {
                struct slp_decode_result r;
                size_t used = slp_decoder_feed(&dec, p, n, &r);

                assert_true(used >= 1 && used <= n);
                if (r.kind == SLP_RESULT_NONE)
                        assert_int_equal(used, n);
                else
                        describe(o, &r);
                p += used;
                n -= used;
        }
}

enum chunking { CHUNK_WHOLE, CHUNK_SPLIT, CHUNK_BYTES };

/* Feeds one piece (a datagram, or the whole stream) and ends it. */
static void feed_piece(const uint8_t *p, size_t len, enum chunking how, size_t split, struct out *o)
{
        struct slp_decode_result r;
        size_t off = 0;

        while (off < len) {
                size_t chunk = len - off;

                if (how == CHUNK_BYTES)
                        chunk = 1;
                else if (how == CHUNK_SPLIT && off < split && split < len)
                        chunk = split - off;
                feed_chunk(p + off, chunk, o);
                off += chunk;
        }
        if (slp_decoder_end(&dec, &r))
                describe(o, &r);
        /* After end() the decoder is idle: a second end() has nothing to say. */
        assert_false(slp_decoder_end(&dec, &r));
}

/* ---------------------------------------------------------------------------------------------
 * Decoder vectors */

struct vector {
        const char *name;
        const char *in[PIECES_MAX];     /* one stream, or several datagrams; each is ended */
        size_t len;                     /* length of in[0] when it holds a NUL byte; else 0 */
        size_t max_frame;               /* 0: SLP_FRAME_DEFAULT */
        const char *expect;
};

#define SPEC_DATA "[:AB|N0|D40.12345678|D-113.12345678|D85.6|D22.1|CD4]"
#define SPEC_DATA_OUT "AB|N0@0|D40.12345678|D-113.12345678|D85.6|D22.1"
#define PING "[:AB|P0|C78]"
#define X32 "[:AB|D01234567890123456789x|CCE]"      /* exactly 32 bytes */
#define X33 "[:AB|D01234567890123456789xy|C47]"     /* 33 bytes */

#define P4_PING_BA "[:BA|P0|C78]"
#define P4_ACK "[:AB|N0|Rvideo_mux1|D0|Rveh_start|D0|Rveh_enable|D0|Rveh_motion|D0|Rjoy_steer|D0" \
        "|Rveh_steer|D0|Rveh_brake|D100|Rveh_throttle|D0|Rveh_shift|D0|Rveh_clutch|D0|C92]"
#define P4_DECL_N "[:BA|N0|T0|Qvideo_mux1|T0|Qveh_start|T0|Qveh_enable|T0|Qveh_motion" \
        "|T2|Qjoy_steer|T0|Qveh_steer|T0|Qveh_brake|T0|Qveh_throttle|T0|Qveh_shift" \
        "|T0|Qveh_clutch|CC9]"
#define P4_DECL_L_FIELDS "L0|T2|QAutoGpsHead|T2|QAutoGpsLat|T2|QAutoGpsLon|T2|QAutoGpsVel" \
        "|T0|QAutoGpsReferences|T0|QAutoGpsQuality|T2|QAutoGpsStamp|T0|Qpause|T0|Qkey_on" \
        "|T0|Qeng_enb|T0|Qpe7|T0|Qbbrake|T0|Qfbrake|T2|Qsteerang|T0|Qthrottle|Qsvp_enb_eng" \
        "|T0|Qserialpck|T0|Qveh_gear|T0|Qveh_state|T0|Qveh_estop|T0|Qveh_obstacle|T2|Qvehicle_bat" \
        "|T4|Qrun_composite|T4|QVehicleName|T0|QHealth_total|T0|Qrpm|T0|Qfuel|T2|Qsys_thd"
#define P4_DECL_L "[:BA|" P4_DECL_L_FIELDS "|C52]"
#define P4_DECL_L_OUT "BA|L0@0" \
        "|T2|QAutoGpsHead|T2|QAutoGpsLat|T2|QAutoGpsLon|T2|QAutoGpsVel" \
        "|T0|QAutoGpsReferences|T0|QAutoGpsQuality|T2|QAutoGpsStamp|T0|Qpause|T0|Qkey_on" \
        "|T0|Qeng_enb|T0|Qpe7|T0|Qbbrake|T0|Qfbrake|T2|Qsteerang|T0|Qthrottle|Qsvp_enb_eng" \
        "|T0|Qserialpck|T0|Qveh_gear|T0|Qveh_state|T0|Qveh_estop|T0|Qveh_obstacle|T2|Qvehicle_bat" \
        "|T4|Qrun_composite|T4|QVehicleName|T0|QHealth_total|T0|Qrpm|T0|Qfuel|T2|Qsys_thd"

static const struct vector vectors[] = {
        /* PROTOCOLS.md 1.3 worked examples, and the captured ping */
        { "spec data", { SPEC_DATA }, 0, 0, SPEC_DATA_OUT },
        { "spec query", { "[:AB|QAutoGpsLat|C2D]" }, 0, 0, "AB|QAutoGpsLat" },
        { "spec answer", { "[:BA|RAutoGpsLat|D40.12345678|C24]" }, 0, 0,
          "BA|RAutoGpsLat|D40.12345678" },
        { "spec compressed", { "[:AB|N0|D|D|D85.7|D|C48]" }, 0, 0, "AB|N0@0|D|D|D85.7|D" },
        { "captured ping", { PING }, 0, 0, "AB|P0" },
        /* line ends and checksum spellings */
        { "CR LF then LF CR", { SPEC_DATA "\r\n" PING "\n\r" PING "\n\n\r\r" }, 0, 0,
          SPEC_DATA_OUT " ; AB|P0 ; AB|P0" },
        { "lowercase checksum", { "[:AB|QAutoGpsLat|C2d]" }, 0, 0, "AB|QAutoGpsLat" },
        { "one-digit checksum", { "[:AB|Dde|C5]" }, 0, 0, "AB|Dde" },
        { "zero-padded low checksum", { "[:AB|Dde|C05]" }, 0, 0, "AB|Dde" },
        { "one lowercase digit", { "[:AP|N12|D3.5|Cd]" }, 0, 0, "AP|N12@12|D3.5" },
        { "addresses P and A", { "[:PA|P0|C86]" }, 0, 0, "PA|P0" },
        { "other addresses", { "[:CD|N0|D1|C6B]" }, 0, 0, "CD|N0@0|D1" },
        /* checksum failures */
        { "bad checksum", { "[:AB|N0|D40.12345678|D-113.12345678|D85.6|D22.1|CD5]" }, 0, 0,
          "!badcsum/52" },
        { "one-digit checksum off by one", { "[:AB|Dde|C6]" }, 0, 0, "!badcsum/12" },
        { "missing checksum", { "[:AB|N0|D1]" }, 0, 0, "!nocsum/11" },
        { "empty last field", { "[:AB|N0|D1|]" }, 0, 0, "!nocsum/12" },
        { "lowercase checksum letter", { "[:AB|P0|c78]" }, 0, 0, "!nocsum/12" },
        { "empty frame", { "[]" }, 0, 0, "!nocsum/2" },
        { "no bar at all", { "[:AB]" }, 0, 0, "!nocsum/5" },
        { "checksum without digits", { "[:AB|N0|D1|C]" }, 0, 0, "!csumsyntax/13" },
        { "checksum with three digits", { "[:AB|N0|D1|C067]" }, 0, 0, "!csumsyntax/16" },
        { "checksum not hex", { "[:AB|N0|D1|CXY]" }, 0, 0, "!csumsyntax/15" },
        /* header */
        { "missing colon", { "[AB|P0|C3E]" }, 0, 0, "!header/11" },
        { "three address letters", { "[:ABX|P0|CD0]" }, 0, 0, "!header/13" },
        { "lowercase address", { "[:aB|P0|C98]" }, 0, 0, "!address/12" },
        { "address beyond P", { "[:AQ|P0|C87]" }, 0, 0, "!address/12" },
        { "one address letter", { "[:A|P0|C36]" }, 0, 0, "!address/11" },
        /* fields */
        { "field without type letter", { "[:AB|0|C28]" }, 0, 0, "!field/11" },
        { "lowercase type letter", { "[:AB|dx|CD4]" }, 0, 0, "!field/12" },
        { "control byte in value", { "[:AB|D\x01|C3D]" }, 0, 0, "!field/12" },
        { "tab in value", { "[:AB|D\t|C45]" }, 0, 0, "!field/12" },
        { "DEL in value", { "[:AB|P0|D\x7f|CB7]" }, 0, 0, "!field/15" },
        { "high byte in value", { "[:AB|D\xff|C3B]" }, 0, 0, "!field/12" },
        { "N not a number", { "[:AB|Nx|D1|CAF]" }, 0, 0, "!field/15" },
        { "N empty", { "[:AB|N|C46]" }, 0, 0, "!field/11" },
        { "checksum field before the end", { "[:AB|C00|D1|C8C]" }, 0, 0, "!field/16" },
        { "only a checksum", { "[:AB|C7C]" }, 0, 0, "!nofields/9" },
        { "only an empty field", { "[:AB||CF8]" }, 0, 0, "!nofields/10" },
        { "unknown field type", { "[:AB|MUI|P0|CDF]" }, 0, 0, "AB|*MUI|P0 {u=1}" },
        { "empty field", { "[:AB|N0||D1|CE3]" }, 0, 0, "AB|N0@0|D1 {e=1}" },
        { "empty fields twice", { "[:AB|N0||D1||C5F]" }, 0, 0, "AB|N0@0|D1 {e=2}" },
        { "empty field in an answer", { "[:BA|RAutoGpsLat||D40.12345678|CA0]" }, 0, 0,
          "BA|RAutoGpsLat|D40.12345678 {e=1}" },
        { "several N fields", { "[:AB|N0|D1|N5|D2|C58]" }, 0, 0, "AB|N0@0|D1|N5@5|D2" },
        { "D without N", { "[:AB|D1|D2|C5F]" }, 0, 0, "AB|D1|D2" },
        { "empty D", { "[:AB|N0|D|C36]" }, 0, 0, "AB|N0@0|D" },
        { "huge N saturates", { "[:AB|N99999999999|D1|CAA]" }, 0, 0,
          "AB|N99999999999@4294967294|D1" },
        { "N at UINT32_MAX saturates", { "[:AB|N4294967295|C5F]" }, 0, 0,
          "AB|N4294967295@4294967294" },
        /* Pronto4 dialect (PROTOCOLS.md 1.6) */
        { "N? asks for the N list", { "[:BA|N?|C85]" }, 0, 0, "BA|N?@?" },
        { "L? asks for the L list", { "[:BA|L?|C83]" }, 0, 0, "BA|L?@?" },
        { "L list declaration", { "[:AB|L0|T2|QAutoGpsLat|T2|QAutoGpsLon|CE2]" }, 0, 0,
          "AB|L0@0|T2|QAutoGpsLat|T2|QAutoGpsLon" },
        { "self-describing frame",
          { "[:BA|N0|T4|QVehicleName|DVEH_1|T2|QAutoGpsLat|D0|C5E]" }, 0, 0,
          "BA|N0@0|T4|QVehicleName|DVEH_1|T2|QAutoGpsLat|D0" },
        { "pong", { "[:BA|G0|C6F]" }, 0, 0, "BA|G0" },
        { "module command", { "[:BA|ELink|D0, outbound, on|CA0]" }, 0, 0,
          "BA|ELink|D0, outbound, on" },
        /* Pronto4 field traffic (docs/pronto4.md), byte for byte from the public clients */
        { "vehicle acknowledges a declaration", { P4_ACK }, 0, 0,
          "AB|N0@0|Rvideo_mux1|D0|Rveh_start|D0|Rveh_enable|D0|Rveh_motion|D0|Rjoy_steer|D0"
          "|Rveh_steer|D0|Rveh_brake|D100|Rveh_throttle|D0|Rveh_shift|D0|Rveh_clutch|D0" },
        { "host N0 declaration", { P4_DECL_N }, 0, 0,
          "BA|N0@0|T0|Qvideo_mux1|T0|Qveh_start|T0|Qveh_enable|T0|Qveh_motion|T2|Qjoy_steer"
          "|T0|Qveh_steer|T0|Qveh_brake|T0|Qveh_throttle|T0|Qveh_shift|T0|Qveh_clutch" },
        { "host L0 declaration, one entry untyped", { P4_DECL_L }, 0, 0, P4_DECL_L_OUT },
        { "Q inside a declaration, no T",
          { "[:BA|N0|T0|Qthrottle|Qsvp_enb_eng|T0|Qserialpck|C97]" }, 0, 0,
          "BA|N0@0|T0|Qthrottle|Qsvp_enb_eng|T0|Qserialpck" },
        { "data with an empty field and empty D", { "[:AB|N0||D0|D|D|C62]" }, 0, 0,
          "AB|N0@0|D0|D|D {e=1}" },
        { "uppercase unpadded checksum, a letter", { "[:AB|N0|D0|Dxl|CA]" }, 0, 0,
          "AB|N0@0|D0|Dxl" },
        { "uppercase unpadded checksum, a digit", { "[:BA|EServoPod|D0,TELEOP START|C2]" }, 0,
          0, "BA|EServoPod|D0,TELEOP START" },
        { "padded module command", { "[:BA|EServoPod|D0,TELEOP START|C02]" }, 0, 0,
          "BA|EServoPod|D0,TELEOP START" },
        { "datagrams ending LF CR and CR LF", { P4_PING_BA "\n\r", P4_PING_BA "\r\n" }, 0, 0,
          "BA|P0 ; BA|P0" },
        { "connect sequence",
          { "[:BA|ELink|D0, SetIP, 192.168.200.10:4220, 4000|CE2]\r\n",
            "[:BA|ELink|D0, outbound, on|CA0]\r\n", "[:BA|ELink|D0, inbound, on|C1F]\r\n" },
          0, 0, "BA|ELink|D0, SetIP, 192.168.200.10:4220, 4000 ; BA|ELink|D0, outbound, on ; "
          "BA|ELink|D0, inbound, on" },
        { "MUI MUO MW ML are unknown types to the codec",
          { "[:BA|MUI|CE3]", "[:BA|MUO|CE9]", "[:BA|MW|C9C]", "[:BA|ML|C91]" }, 0, 0,
          "BA|*MUI {u=1} ; BA|*MUO {u=1} ; BA|*MW {u=1} ; BA|*ML {u=1}" },
        { "physics command", { "[:BA|EPhysics|D0,Stop|CE2]" }, 0, 0, "BA|EPhysics|D0,Stop" },
        { "self-describing frame from the host",
          { "[:BA|N0|T4|QVehicleName|DVEH_1|T4|QAutoGpsLat|D0|C60]" }, 0, 0,
          "BA|N0@0|T4|QVehicleName|DVEH_1|T4|QAutoGpsLat|D0" },
        /* garbage before, between and inside frames */
        { "garbage before", { "xyz" PING }, 0, 0, "!noise/3 ; AB|P0" },
        { "garbage between", { PING "\r\nab\r\n" PING }, 0, 0, "AB|P0 ; !noise/2 ; AB|P0" },
        { "spaces are noise", { PING " \t" PING }, 0, 0, "AB|P0 ; !noise/2 ; AB|P0" },
        { "stray closing brackets", { "]]" PING "]" }, 0, 0, "!noise/2 ; AB|P0 ; !noise/1" },
        { "NUL and high bytes between", { PING "\0\xff\x80" PING }, 15 + 12, 0,
          "AB|P0 ; !noise/3 ; AB|P0" },
        { "bracket inside a frame resyncs", { "[:AB|N0|D1" PING }, 0, 0, "!resync/10 ; AB|P0" },
        { "two brackets", { "[[" PING }, 0, 0, "!resync/1 ; !resync/1 ; AB|P0" },
        { "bad frame between good ones", { PING "[:AB|P0|C79]" PING }, 0, 0,
          "AB|P0 ; !badcsum/12 ; AB|P0" },
        { "trailing partial frame", { PING "[:AB|N0" }, 0, 0, "AB|P0 ; !truncated/7" },
        { "trailing noise", { PING "zz" }, 0, 0, "AB|P0 ; !noise/2" },
        { "lone bracket at the end", { "[" }, 0, 0, "!truncated/1" },
        { "only CR LF", { "\r\n\n\r" }, 0, 0, "" },
        /* maximum lengths (max_frame 32) */
        { "exactly max_frame", { X32 }, 0, 32, "AB|D01234567890123456789x" },
        { "max_frame + 1 then resync", { X33 PING }, 0, 32, "!overlong/32 ; !noise/1 ; AB|P0" },
        { "overlong tail with CR LF", { X33 "\r\n" PING }, 0, 32,
          "!overlong/32 ; !noise/1 ; AB|P0" },
        { "bracket where only ']' fits", { "[:AB|D01234567890123456789abcde" PING }, 0, 32,
          "!resync/31 ; AB|P0" },
        { "overlong right before a bracket", { "[:AB|D01234567890123456789abcdef" PING }, 0, 32,
          "!overlong/32 ; AB|P0" },
        { "bracket inside an overlong-sized frame", { "[:AB|D01234567890123456789xy[P0|C78]" PING },
          0, 32, "!resync/28 ; !badcsum/8 ; AB|P0" },
        { "value longer than SLP_VALUE_MAX is decoded",
          { "[:AB|D0123456789012345678901234567890123456789012345678901234567890123456789|C97]" },
          0, 0, "AB|D0123456789012345678901234567890123456789012345678901234567890123456789" },
        /* datagrams: every piece is ended, so nothing joins across datagrams */
        { "datagram with two frames", { SPEC_DATA PING }, 0, 0, SPEC_DATA_OUT " ; AB|P0" },
        { "datagram cut in two", { "[:AB|P0", "|C78]", PING }, 0, 0,
          "!truncated/7 ; !noise/5 ; AB|P0" },
        { "datagram with a trailing partial frame", { PING "[:AB|N0|D", PING }, 0, 0,
          "AB|P0 ; !truncated/9 ; AB|P0" },
        { "datagram without CR LF after datagram with", { PING "\r\n", PING }, 0, 0,
          "AB|P0 ; AB|P0" },
};

static void run_vector(const struct vector *v, enum chunking how, size_t split, struct out *o)
{
        o->n = 0;
        o->s[0] = '\0';
        assert_int_equal(slp_decoder_init(&dec, v->max_frame), 0);
        for (size_t i = 0; i < PIECES_MAX && v->in[i]; i++) {
                size_t len = (i == 0 && v->len) ? v->len : strlen(v->in[i]);

                feed_piece((const uint8_t *)v->in[i], len, how, split, o);
        }
}

static void check_vector(const struct vector *v, enum chunking how, size_t split)
{
        static struct out o;

        run_vector(v, how, split, &o);
        if (strcmp(o.s, v->expect) != 0) {
                print_error("vector \"%s\" (%s, split %zu)\n  got:  %s\n  want: %s\n", v->name,
                            how == CHUNK_WHOLE ? "whole" : how == CHUNK_SPLIT ? "split" : "bytes",
                            split, o.s, v->expect);
                fail();
        }
}

static void test_decode_vectors(void **state)
{
        (void)state;
        assert_true(sizeof(vectors) / sizeof(vectors[0]) >= 30);
        for (size_t i = 0; i < sizeof(vectors) / sizeof(vectors[0]); i++) {
                const struct vector *v = &vectors[i];
                size_t longest = 0;

                for (size_t k = 0; k < PIECES_MAX && v->in[k]; k++) {
                        size_t len = (k == 0 && v->len) ? v->len : strlen(v->in[k]);
                        if (len > longest)
                                longest = len;
                }
                check_vector(v, CHUNK_WHOLE, 0);
                check_vector(v, CHUNK_BYTES, 0);
                for (size_t split = 1; split < longest; split++)
                        check_vector(v, CHUNK_SPLIT, split);
        }
}

/* The field values are where the frame said, and raw is the frame as received. */
static void test_frame_layout(void **state)
{
        static const char wire[] = "\r\n" SPEC_DATA "\r\n";
        struct slp_decode_result r;
        size_t used;

        (void)state;
        assert_int_equal(slp_decoder_init(&dec, 0), 0);
        used = slp_decoder_feed(&dec, (const uint8_t *)wire, strlen(wire), &r);
        assert_int_equal(used, 2 + strlen(SPEC_DATA));
        assert_int_equal(r.kind, SLP_RESULT_FRAME);
        assert_int_equal(r.frame->raw_len, strlen(SPEC_DATA));
        assert_memory_equal(r.frame->raw, SPEC_DATA, strlen(SPEC_DATA));
        assert_int_equal(r.frame->nfields, 5);
        assert_int_equal(r.frame->fields[0].type, SLP_FIELD_N);
        assert_int_equal(r.frame->fields[0].index, 0);
        assert_int_equal(r.frame->fields[2].len, strlen("-113.12345678"));
        assert_memory_equal(r.frame->fields[2].value, "-113.12345678", r.frame->fields[2].len);
        assert_int_equal(r.frame->dst_index, 0);
        assert_int_equal(r.frame->src_index, 1);
        /* The trailing CR LF is whitespace: consumed, nothing reported. */
        used = slp_decoder_feed(&dec, (const uint8_t *)wire + used, 2, &r);
        assert_int_equal(used, 2);
        assert_int_equal(r.kind, SLP_RESULT_NONE);
        assert_false(slp_decoder_end(&dec, &r));
}

static void test_decoder_init_limits(void **state)
{
        (void)state;
        assert_int_equal(slp_decoder_init(&dec, 0), 0);
        assert_int_equal(dec.max_frame, SLP_FRAME_DEFAULT);
        assert_int_equal(slp_decoder_init(&dec, SLP_FRAME_MAX), 0);
        assert_int_equal(slp_decoder_init(&dec, SLP_FRAME_MIN), 0);
        assert_int_equal(slp_decoder_init(&dec, SLP_FRAME_MIN - 1), -EINVAL);
        assert_int_equal(slp_decoder_init(&dec, SLP_FRAME_MAX + 1), -EINVAL);
}

/* Noise runs are reported once per SLP_NOISE_RUN_MAX bytes, not once per byte; CR LF are free. */
static void test_noise_runs(void **state)
{
        static uint8_t buf[2 * SLP_NOISE_RUN_MAX + 600];
        static struct out o;
        size_t n = 0;

        (void)state;
        for (size_t i = 0; i < 2 * SLP_NOISE_RUN_MAX + 400; i++)
                buf[n++] = (uint8_t)('a' + i % 26);
        for (size_t i = 0; i < 100; i++) {
                buf[n++] = '\r';
                buf[n++] = '\n';
        }
        o.n = 0;
        assert_int_equal(slp_decoder_init(&dec, 0), 0);
        feed_chunk(buf, n, &o);
        assert_string_equal(o.s, "!noise/1024 ; !noise/1024");
        feed_piece(buf, 0, CHUNK_WHOLE, 0, &o);
        assert_string_equal(o.s, "!noise/1024 ; !noise/1024 ; !noise/400");
}

/* Builds "[:AB|D<x...>|Chh]" of exactly @len bytes, its checksum by wire.h (not the codec). */
static size_t make_frame(char *buf, size_t len)
{
        size_t n = 0;

        assert_true(len >= 12);
        n += (size_t)sprintf(buf, "[:AB|D");
        for (; n < len - 5; n++)
                buf[n] = (char)('0' + n % 10);
        n = wire_slp_close(buf, len + 1, n);
        assert_int_equal(n, len);
        return n;
}

/* At the default and the largest max_frame: max_frame accepted, max_frame + 1 rejected, resync. */
static void test_max_frame_edges(void **state)
{
        static const size_t limits[] = { SLP_FRAME_DEFAULT, SLP_FRAME_MAX, 100 };
        static char buf[2 * SLP_FRAME_MAX + 64];

        (void)state;
        for (size_t k = 0; k < sizeof(limits) / sizeof(limits[0]); k++) {
                size_t max = limits[k], n;
                static struct out o;
                char want[128];

                assert_int_equal(slp_decoder_init(&dec, max), 0);
                o.n = 0;
                n = make_frame(buf, max);
                n += make_frame(buf + n, max + 1);
                memcpy(buf + n, PING, strlen(PING));
                n += strlen(PING);
                feed_piece((const uint8_t *)buf, n, CHUNK_WHOLE, 0, &o);
                snprintf(want, sizeof(want), "!overlong/%zu ; !noise/1 ; AB|P0", max);
                assert_int_equal(strncmp(o.s, "AB|D", 4), 0);
                assert_non_null(strstr(o.s, want));
                assert_int_equal(strlen(strstr(o.s, want)), strlen(want));
        }
}

/* A byte outside 0x20-0x7E at any offset (so at every place in an 8-byte word) is found, and a
 * '|' at any offset splits the fields there; both with the right checksum. */
static void test_every_offset(void **state)
{
        static const unsigned char bad[] = { 0x00, 0x01, 0x1f, 0x7f, 0x80, 0xfe, 0xff };
        char buf[128];

        (void)state;
        for (size_t len = 1; len <= 40; len++) {
                for (size_t at = 0; at < len; at++) {
                        struct slp_decode_result r;
                        size_t n;

                        for (size_t k = 0; k < sizeof(bad); k++) {
                                n = (size_t)sprintf(buf, "[:AB|D");
                                for (size_t i = 0; i < len; i++)
                                        buf[n++] = i == at ? (char)bad[k] : (char)('a' + i % 26);
                                n = wire_slp_close(buf, sizeof(buf), n);
                                assert_int_equal(slp_decoder_init(&dec, 0), 0);
                                assert_int_equal(
                                        slp_decoder_feed(&dec, (const uint8_t *)buf, n, &r), n);
                                assert_int_equal(r.kind, SLP_RESULT_REJECT);
                                assert_int_equal(r.reason, SLP_REASON_BAD_FIELD);
                        }
                        /* "D<at letters>|D<the rest>" */
                        n = (size_t)sprintf(buf, "[:AB|D");
                        for (size_t i = 0; i < len; i++)
                                buf[n++] = i == at ? '|' : (char)('a' + i % 26);
                        if (at + 1 < len)
                                buf[n - len + at + 1] = 'D';
                        n = wire_slp_close(buf, sizeof(buf), n);
                        assert_int_equal(slp_decoder_init(&dec, 0), 0);
                        assert_int_equal(slp_decoder_feed(&dec, (const uint8_t *)buf, n, &r), n);
                        assert_int_equal(r.kind, SLP_RESULT_FRAME);
                        assert_int_equal(r.frame->nfields, at + 1 < len ? 2 : 1);
                        assert_int_equal(r.frame->empty_fields, at + 1 < len ? 0 : 1);
                        assert_int_equal(r.frame->fields[0].len, at);
                        if (at + 1 < len)
                                assert_int_equal(r.frame->fields[1].len, len - at - 2);
                }
        }
}

static void test_reason_strings(void **state)
{
        (void)state;
        for (int i = 0; i < SLP_REASON_COUNT; i++) {
                const char *s = slp_decode_reason_str((enum slp_decode_reason)i);

                assert_non_null(s);
                assert_true(strlen(s) > 0);
                assert_string_not_equal(s, "unknown reason");
                for (int j = 0; j < i; j++)
                        assert_string_not_equal(
                                s, slp_decode_reason_str((enum slp_decode_reason)j));
        }
        assert_string_equal(slp_decode_reason_str(SLP_REASON_BAD_CHECKSUM), "bad checksum");
        assert_string_equal(slp_decode_reason_str(SLP_REASON_COUNT), "unknown reason");
        assert_int_equal(slp_field_type_of('D'), SLP_FIELD_D);
        assert_int_equal(slp_field_type_of('M'), SLP_FIELD_UNKNOWN);
        assert_int_equal(slp_field_type_of('d'), SLP_FIELD_UNKNOWN);
}

/* ---------------------------------------------------------------------------------------------
 * Encoder */

#define F(l, v) { .letter = (l), .value = (v), .len = sizeof(v) - 1 }
#define FIELDS_MAX 8

struct enc_vector {
        const char *name;
        char dst, src;
        struct slp_field fields[FIELDS_MAX];
        size_t nfields;
        unsigned flags;
        const char *expect;     /* wire bytes, or NULL when an error is expected */
        int error;
};

static const struct enc_vector enc_vectors[] = {
        { "spec data", 'A', 'B',
          { F('N', "0"), F('D', "40.12345678"), F('D', "-113.12345678"), F('D', "85.6"),
            F('D', "22.1") }, 5, 0, SPEC_DATA, 0 },
        { "spec data CR LF", 'A', 'B',
          { F('N', "0"), F('D', "40.12345678"), F('D', "-113.12345678"), F('D', "85.6"),
            F('D', "22.1") }, 5, SLP_ENCODE_CRLF, SPEC_DATA "\r\n", 0 },
        { "spec compressed", 'A', 'B', { F('N', "0"), F('D', ""), F('D', ""), F('D', "85.7"),
          F('D', "") }, 5, 0, "[:AB|N0|D|D|D85.7|D|C48]", 0 },
        { "ping", 'A', 'B', { F('P', "0") }, 1, 0, PING, 0 },
        { "low checksum is zero padded", 'A', 'B', { F('D', "de") }, 1, 0, "[:AB|Dde|C05]", 0 },
        { "other addresses", 'A', 'P', { F('N', "12"), F('D', "3.5") }, 2, 0,
          "[:AP|N12|D3.5|C0D]", 0 },
        { "N?", 'B', 'A', { F('N', "?") }, 1, 0, "[:BA|N?|C85]", 0 },
        { "unknown letter is allowed", 'A', 'B', { F('M', "UI"), F('P', "0") }, 2, 0,
          "[:AB|MUI|P0|CDF]", 0 },
        { "value of exactly 63 bytes", 'A', 'B',
          { F('D', "012345678901234567890123456789012345678901234567890123456789012") }, 1, 0,
          "[:AB|D012345678901234567890123456789012345678901234567890123456789012|C1D]", 0 },
        /* refusals */
        { "bar in value", 'A', 'B', { F('D', "a|b") }, 1, 0, NULL, -EINVAL },
        { "open bracket in value", 'A', 'B', { F('D', "a[b") }, 1, 0, NULL, -EINVAL },
        { "close bracket in value", 'A', 'B', { F('D', "a]b") }, 1, 0, NULL, -EINVAL },
        { "control byte in value", 'A', 'B', { F('D', "a\x1f") }, 1, 0, NULL, -EINVAL },
        { "CR in value", 'A', 'B', { F('D', "a\r") }, 1, 0, NULL, -EINVAL },
        { "DEL in value", 'A', 'B', { F('D', "\x7f") }, 1, 0, NULL, -EINVAL },
        { "high byte in value", 'A', 'B', { F('D', "\x80") }, 1, 0, NULL, -EINVAL },
        { "value of 64 bytes", 'A', 'B',
          { F('D', "0123456789012345678901234567890123456789012345678901234567890123") }, 1, 0,
          NULL, -EMSGSIZE },
        { "destination beyond P", 'Q', 'B', { F('P', "0") }, 1, 0, NULL, -EINVAL },
        { "lowercase source", 'A', 'b', { F('P', "0") }, 1, 0, NULL, -EINVAL },
        { "checksum letter as a field", 'A', 'B', { F('C', "00") }, 1, 0, NULL, -EINVAL },
        { "digit as a type", 'A', 'B', { F('1', "0") }, 1, 0, NULL, -EINVAL },
        { "lowercase type", 'A', 'B', { F('d', "0") }, 1, 0, NULL, -EINVAL },
        { "N not a number", 'A', 'B', { F('N', "x"), F('D', "1") }, 2, 0, NULL, -EINVAL },
        { "N empty", 'A', 'B', { F('N', ""), F('D', "1") }, 2, 0, NULL, -EINVAL },
        { "L not a number", 'A', 'B', { F('L', "-1") }, 1, 0, NULL, -EINVAL },
        { "no fields", 'A', 'B', { F('P', "0") }, 0, 0, NULL, -EINVAL },
};

/* Decodes one encoded frame and checks it carries exactly the fields that were encoded. */
static void check_decodes_to(const char *wire, size_t len, char dst, char src,
                             const struct slp_field *fields, size_t nfields)
{
        struct slp_decode_result r;
        size_t used;

        assert_int_equal(slp_decoder_init(&dec, SLP_FRAME_MAX), 0);
        used = slp_decoder_feed(&dec, (const uint8_t *)wire, len, &r);
        assert_int_equal(r.kind, SLP_RESULT_FRAME);
        /* Whatever follows the ']' is the optional CR LF. */
        assert_true(len - used == 0 || (len - used == 2 && memcmp(wire + used, "\r\n", 2) == 0));
        assert_int_equal(r.frame->dst, dst);
        assert_int_equal(r.frame->src, src);
        assert_int_equal(r.frame->nfields, nfields);
        for (size_t i = 0; i < nfields; i++) {
                assert_int_equal(r.frame->fields[i].letter, fields[i].letter);
                assert_int_equal(r.frame->fields[i].len, fields[i].len);
                assert_memory_equal(r.frame->fields[i].value, fields[i].value, fields[i].len);
        }
}

static void test_encode_vectors(void **state)
{
        char buf[SLP_FRAME_MAX];

        (void)state;
        for (size_t i = 0; i < sizeof(enc_vectors) / sizeof(enc_vectors[0]); i++) {
                const struct enc_vector *v = &enc_vectors[i];
                int r = slp_frame_encode(buf, sizeof(buf), v->dst, v->src, v->fields, v->nfields,
                                         v->flags);

                if (!v->expect) {
                        if (r != v->error)
                                print_error("encode \"%s\": got %d want %d\n", v->name, r, v->error);
                        assert_int_equal(r, v->error);
                        continue;
                }
                if (r != (int)strlen(v->expect) || memcmp(buf, v->expect, (size_t)r) != 0)
                        print_error("encode \"%s\": got %.*s want %s\n", v->name, r > 0 ? r : 0,
                                    buf, v->expect);
                assert_int_equal(r, strlen(v->expect));
                assert_memory_equal(buf, v->expect, (size_t)r);
                check_decodes_to(buf, (size_t)r, v->dst, v->src, v->fields, v->nfields);
        }
}

/* A buffer one byte short is refused, the exact size works. */
static void test_encode_buffer_size(void **state)
{
        const struct slp_field f[] = { F('P', "0") };
        char buf[32];

        (void)state;
        assert_int_equal(slp_frame_encode(buf, strlen(PING) - 1, 'A', 'B', f, 1, 0), -ENOSPC);
        assert_int_equal(slp_frame_encode(buf, strlen(PING), 'A', 'B', f, 1, 0), strlen(PING));
        assert_int_equal(slp_frame_encode(buf, strlen(PING) + 1, 'A', 'B', f, 1, SLP_ENCODE_CRLF),
                         -ENOSPC);
        assert_int_equal(slp_frame_encode(buf, strlen(PING) + 2, 'A', 'B', f, 1, SLP_ENCODE_CRLF),
                         strlen(PING) + 2);
        assert_int_equal(slp_frame_encode(buf, 0, 'A', 'B', f, 1, 0), -ENOSPC);
}

static void test_encode_helpers(void **state)
{
        char buf[128];
        int r;

        (void)state;
        r = slp_encode_query(buf, sizeof(buf), 'A', 'B', "AutoGpsLat", 0);
        assert_int_equal(r, strlen("[:AB|QAutoGpsLat|C2D]"));
        assert_memory_equal(buf, "[:AB|QAutoGpsLat|C2D]", (size_t)r);
        r = slp_encode_answer(buf, sizeof(buf), 'B', 'A', "AutoGpsLat", "40.12345678",
                              SLP_ENCODE_CRLF);
        assert_int_equal(r, strlen("[:BA|RAutoGpsLat|D40.12345678|C24]\r\n"));
        assert_memory_equal(buf, "[:BA|RAutoGpsLat|D40.12345678|C24]\r\n", (size_t)r);
        /* Decision: a query for an unknown name is answered with an empty value. */
        r = slp_encode_answer(buf, sizeof(buf), 'B', 'A', "Nope", "", 0);
        assert_true(r > 0);
        check_decodes_to(buf, (size_t)r, 'B', 'A',
                         (const struct slp_field[]){ F('R', "Nope"), F('D', "") }, 2);
        assert_int_equal(slp_encode_query(buf, sizeof(buf), 'A', 'B', "a|b", 0), -EINVAL);
        assert_int_equal(slp_encode_answer(buf, sizeof(buf), 'A', 'B', "x", "1]", 0), -EINVAL);
        assert_int_equal(slp_encode_answer(buf, sizeof(buf), 'A', 'B', "x",
                         "0123456789012345678901234567890123456789012345678901234567890123", 0),
                         -EMSGSIZE);
        assert_int_equal(slp_encode_query(buf, 10, 'A', 'B', "AutoGpsLat", 0), -ENOSPC);
}

/* ---------------------------------------------------------------------------------------------
 * List encoder */

#define LIST_MAX 300

struct list_case {
        const char *name;
        size_t count;
        size_t max_frame;
        bool compress, full, crlf;
        unsigned changed_every;         /* position i changed when i % changed_every == 0; 0: NULL */
};

static const struct list_case list_cases[] = {
        { "4 doubles, one frame", 4, 0, false, false, false, 0 },
        { "40 doubles, 96-byte frames", 40, 96, false, false, false, 0 },
        { "40 doubles, 96-byte frames, CR LF", 40, 96, false, false, true, 0 },
        { "40 doubles, compressed", 40, 96, true, false, false, 3 },
        { "40 doubles, compressed, full refresh", 40, 96, true, true, true, 3 },
        { "40 doubles, nothing changed", 40, 96, true, false, false, 1000 },
        { "changed ignored without compression", 40, 96, false, false, false, 2 },
        { "300 values, N offsets over 100", 300, SLP_FRAME_MIN + 60, false, false, true, 0 },
        { "300 values, default max_frame", 300, 0, true, false, true, 5 },
        { "300 values, largest max_frame", 300, SLP_FRAME_MAX, false, false, false, 0 },
};

static char list_storage[LIST_MAX][SLP_VALUE_MAX + 1];
static const char *list_values[LIST_MAX];
static bool list_changed[LIST_MAX];

/* Deterministic values of varied length, some empty, one of the maximum length. */
static void make_values(size_t count)
{
        uint32_t x = 12345;

        for (size_t i = 0; i < count; i++) {
                x = x * 1103515245u + 12345u;
                if (i % 17 == 5)
                        list_storage[i][0] = '\0';
                else if (i % 23 == 7) {
                        memset(list_storage[i], 'v', SLP_VALUE_MAX);
                        list_storage[i][SLP_VALUE_MAX] = '\0';
                } else {
                        snprintf(list_storage[i], sizeof(list_storage[i]), "%.*f", (int)(x % 9),
                                 (double)(int32_t)x / 1000.0);
                }
                list_values[i] = list_storage[i];
        }
}

static void check_list_case(const struct list_case *c)
{
        struct slp_list l = {
                .dst = 'A', .src = 'B', .values = list_values, .count = c->count,
                .max_frame = c->max_frame, .compress = c->compress, .full = c->full, .crlf = c->crlf,
                .changed = c->changed_every ? list_changed : NULL,
        };
        size_t max = c->max_frame ? c->max_frame : SLP_FRAME_DEFAULT;
        size_t cursor = 0, frames = 0;
        char buf[SLP_FRAME_MAX];
        int r;

        make_values(c->count);
        for (size_t i = 0; i < c->count; i++)
                list_changed[i] = c->changed_every && i % c->changed_every == 0;
        while ((r = slp_encode_list(&l, &cursor, buf, sizeof(buf))) > 0) {
                size_t start, n = (size_t)r, body = c->crlf ? n - 2 : n;
                struct slp_decode_result res;
                const struct slp_frame *f;

                assert_true(++frames <= c->count);
                assert_true(n <= max);
                if (c->crlf)
                        assert_memory_equal(buf + n - 2, "\r\n", 2);
                assert_int_equal(buf[body - 1], ']');
                assert_int_equal(slp_decoder_init(&dec, SLP_FRAME_MAX), 0);
                assert_int_equal(slp_decoder_feed(&dec, (const uint8_t *)buf, body, &res), body);
                assert_int_equal(res.kind, SLP_RESULT_FRAME);
                f = res.frame;
                assert_int_equal(f->dst, 'A');
                assert_int_equal(f->src, 'B');
                assert_int_equal(f->fields[0].type, SLP_FIELD_N);
                start = f->fields[0].index;
                assert_true(cursor > start);
                assert_int_equal(f->nfields, 1 + cursor - start);
                for (size_t i = start; i < cursor; i++) {
                        const struct slp_field *fl = &f->fields[1 + i - start];
                        bool sent = !c->compress || c->full || list_changed[i];
                        const char *want = sent ? list_values[i] : "";

                        assert_int_equal(fl->type, SLP_FIELD_D);
                        assert_int_equal(fl->len, strlen(want));
                        assert_memory_equal(fl->value, want, fl->len);
                }
                /* Greedy: the next position would not have fitted in this frame. */
                if (cursor < c->count) {
                        bool sent = !c->compress || c->full || list_changed[cursor];
                        size_t next = sent ? strlen(list_values[cursor]) : 0;

                        assert_true(n + 2 + next > max);
                }
        }
        assert_int_equal(r, 0);
        assert_int_equal(cursor, c->count);
        assert_true(frames >= 1);
        /* Called again at the end: nothing more. */
        assert_int_equal(slp_encode_list(&l, &cursor, buf, sizeof(buf)), 0);
}

static void test_list_split(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(list_cases) / sizeof(list_cases[0]); i++) {
                print_message("list case: %s\n", list_cases[i].name);
                check_list_case(&list_cases[i]);
        }
}

/* The spec's own frames come out of the list encoder byte for byte. */
static void test_list_spec_frames(void **state)
{
        static const char *const v[] = { "40.12345678", "-113.12345678", "85.6", "22.1" };
        static const char *const v2[] = { "40.12345678", "-113.12345678", "85.7", "22.1" };
        static const bool changed[] = { false, false, true, false };
        struct slp_list l = { .dst = 'A', .src = 'B', .values = v, .count = 4 };
        char buf[256];
        size_t cursor = 0;
        int r;

        (void)state;
        r = slp_encode_list(&l, &cursor, buf, sizeof(buf));
        assert_int_equal(r, strlen(SPEC_DATA));
        assert_memory_equal(buf, SPEC_DATA, (size_t)r);
        assert_int_equal(cursor, 4);

        l.values = v2;
        l.changed = changed;
        l.compress = true;
        cursor = 0;
        r = slp_encode_list(&l, &cursor, buf, sizeof(buf));
        assert_int_equal(r, strlen("[:AB|N0|D|D|D85.7|D|C48]"));
        assert_memory_equal(buf, "[:AB|N0|D|D|D85.7|D|C48]", (size_t)r);

        /* Full refresh sends everything even with compression on. */
        l.full = true;
        cursor = 0;
        r = slp_encode_list(&l, &cursor, buf, sizeof(buf));
        assert_int_equal(r, strlen("[:AB|N0|D40.12345678|D-113.12345678|D85.7|D22.1|CD5]"));
        assert_memory_equal(buf, "[:AB|N0|D40.12345678|D-113.12345678|D85.7|D22.1|CD5]", (size_t)r);
}

static void test_list_errors(void **state)
{
        static const char long_value[] =
                "012345678901234567890123456789012345678901234567890123456789012";
        static const char *const fits[] = { "1", "2" };
        static const char *const too_big[] = { "1", long_value };
        static const char *const bad[] = { "1", "2|3" };
        static const char *const too_long[] = {
                "0123456789012345678901234567890123456789012345678901234567890123"
        };
        struct slp_list l = { .dst = 'A', .src = 'B', .values = too_big, .count = 2,
                             .max_frame = SLP_FRAME_MIN };
        char buf[SLP_FRAME_MAX];
        size_t cursor = 0;
        int r;

        (void)state;
        /* Position 0 fits, position 1 can never fit in 32 bytes: one frame, then an error. */
        r = slp_encode_list(&l, &cursor, buf, sizeof(buf));
        assert_true(r > 0 && r <= SLP_FRAME_MIN);
        assert_int_equal(cursor, 1);
        assert_int_equal(slp_encode_list(&l, &cursor, buf, sizeof(buf)), -EMSGSIZE);
        assert_int_equal(cursor, 1);
        assert_int_equal(slp_encode_list(&l, &cursor, buf, sizeof(buf)), -EMSGSIZE);

        /* The caller's buffer, not max_frame, is what is too small. */
        l.values = fits;
        l.max_frame = 0;
        cursor = 0;
        assert_int_equal(slp_encode_list(&l, &cursor, buf, 12), -ENOSPC);
        assert_int_equal(slp_encode_list(&l, &cursor, buf, 4), -ENOSPC);
        assert_int_equal(cursor, 0);

        /* A bad value ends the frame before it; the next call names it. */
        l.values = bad;
        assert_int_equal(slp_encode_list(&l, &cursor, buf, sizeof(buf)), strlen("[:AB|N0|D1|C67]"));
        assert_memory_equal(buf, "[:AB|N0|D1|C67]", strlen("[:AB|N0|D1|C67]"));
        assert_int_equal(cursor, 1);
        assert_int_equal(slp_encode_list(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        assert_int_equal(cursor, 1);
        /* ... but an unchanged bad value is not sent, so it does not matter. */
        cursor = 0;
        l.compress = true;
        l.changed = (const bool[]){ true, false };
        assert_true(slp_encode_list(&l, &cursor, buf, sizeof(buf)) > 0);
        assert_int_equal(cursor, 2);

        l = (struct slp_list){ .dst = 'A', .src = 'B', .values = too_long, .count = 1 };
        cursor = 0;
        assert_int_equal(slp_encode_list(&l, &cursor, buf, sizeof(buf)), -EMSGSIZE);
        l.values = fits;
        l.dst = 'Z';
        assert_int_equal(slp_encode_list(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        l.dst = 'A';
        l.max_frame = SLP_FRAME_MAX + 1;
        assert_int_equal(slp_encode_list(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        l.max_frame = 0;
        l.count = 0;
        assert_int_equal(slp_encode_list(&l, &cursor, buf, sizeof(buf)), 0);
}

/* Encode -> decode of every decoder vector's frames gives the same frames back. */
static void test_roundtrip_vectors(void **state)
{
        static struct slp_field copy[SLP_FIELDS_MAX];
        static char values[SLP_FRAME_MAX];
        char buf[SLP_FRAME_MAX + 8];
        size_t checked = 0;

        (void)state;
        for (size_t i = 0; i < sizeof(vectors) / sizeof(vectors[0]); i++) {
                const char *in = vectors[i].in[0];
                size_t len = vectors[i].len ? vectors[i].len : strlen(in);
                struct slp_decode_result r;

                assert_int_equal(slp_decoder_init(&dec, vectors[i].max_frame), 0);
                while (len > 0) {
                        size_t used = slp_decoder_feed(&dec, (const uint8_t *)in, len, &r);
                        const struct slp_frame *f = r.frame;
                        char dst, src;
                        size_t nf;
                        bool long_value = false;
                        int n;

                        in += used;
                        len -= used;
                        if (r.kind != SLP_RESULT_FRAME)
                                continue;
                        /* Copy out: the decoder is reused below. */
                        dst = f->dst;
                        src = f->src;
                        nf = f->nfields;
                        memcpy(values, f->raw, f->raw_len);
                        for (size_t k = 0; k < nf; k++) {
                                copy[k] = f->fields[k];
                                copy[k].value = values + (f->fields[k].value - f->raw);
                                long_value |= copy[k].len > SLP_VALUE_MAX;
                        }
                        n = slp_frame_encode(buf, sizeof(buf), dst, src, copy, nf, 0);
                        if (long_value) {
                                /* We decode long values but never emit them. */
                                assert_int_equal(n, -EMSGSIZE);
                                continue;
                        }
                        assert_true(n > 0);
                        check_decodes_to(buf, (size_t)n, dst, src, copy, nf);
                        checked++;
                        /* check_decodes_to() reset the shared decoder: stop this vector. */
                        break;
                }
        }
        assert_true(checked >= 30);
}

/* ---------------------------------------------------------------------------------------------
 * Pronto4 dialect helpers and encoders (docs/pronto4.md) */

static void test_type_parse(void **state)
{
        enum slp_type t = SLP_TYPE_STRING;

        (void)state;
        assert_int_equal(slp_type_parse("0", 1, &t), 0);
        assert_int_equal(t, SLP_TYPE_LONG);
        assert_int_equal(slp_type_parse("2", 1, &t), 0);
        assert_int_equal(t, SLP_TYPE_DOUBLE);
        assert_int_equal(slp_type_parse("4", 1, &t), 0);
        assert_int_equal(t, SLP_TYPE_STRING);
        /* Anything else is an error and leaves the output alone. */
        static const char *const bad[] = { "1", "3", "5", "9", "x", "00", "02", " 0", "", "?" };
        for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
                t = SLP_TYPE_LONG;
                assert_int_equal(slp_type_parse(bad[i], strlen(bad[i]), &t), -EINVAL);
                assert_int_equal(t, SLP_TYPE_LONG);
        }
        assert_int_equal(slp_type_digit(SLP_TYPE_LONG), '0');
        assert_int_equal(slp_type_digit(SLP_TYPE_DOUBLE), '2');
        assert_int_equal(slp_type_digit(SLP_TYPE_STRING), '4');
        assert_int_equal(slp_type_digit((enum slp_type)1), 0);
        assert_int_equal(slp_type_digit((enum slp_type)3), 0);
        assert_int_equal(slp_type_digit((enum slp_type)5), 0);
        assert_int_equal(slp_type_digit((enum slp_type)-1), 0);
}

struct value_case {
        enum slp_type type;
        const char *value;
        int expect;
};

#define V64 "0123456789012345678901234567890123456789012345678901234567890123"

static const struct value_case value_cases[] = {
        /* long */
        { SLP_TYPE_LONG, "0", 0 },
        { SLP_TYPE_LONG, "-0", 0 },
        { SLP_TYPE_LONG, "+17", 0 },
        { SLP_TYPE_LONG, "007", 0 },
        { SLP_TYPE_LONG, "100", 0 },
        { SLP_TYPE_LONG, "9223372036854775807", 0 },
        { SLP_TYPE_LONG, "-9223372036854775808", 0 },
        { SLP_TYPE_LONG, "00000000000000000000009223372036854775807", 0 },
        { SLP_TYPE_LONG, "999999999999999999", 0 },          /* 18 digits: never added up */
        { SLP_TYPE_LONG, "-000000000000000000009223372036854775809", -EINVAL },
        { SLP_TYPE_LONG, "9223372036854775808", -EINVAL },
        { SLP_TYPE_LONG, "-9223372036854775809", -EINVAL },
        { SLP_TYPE_LONG, "18446744073709551616", -EINVAL },
        { SLP_TYPE_LONG, "99999999999999999999999", -EINVAL },
        { SLP_TYPE_LONG, "", -EINVAL },
        { SLP_TYPE_LONG, "-", -EINVAL },
        { SLP_TYPE_LONG, "+", -EINVAL },
        { SLP_TYPE_LONG, "+-1", -EINVAL },
        { SLP_TYPE_LONG, "1.0", -EINVAL },
        { SLP_TYPE_LONG, "1e3", -EINVAL },
        { SLP_TYPE_LONG, " 1", -EINVAL },
        { SLP_TYPE_LONG, "1 ", -EINVAL },
        { SLP_TYPE_LONG, "0x10", -EINVAL },
        { SLP_TYPE_LONG, "12a", -EINVAL },
        { SLP_TYPE_LONG, "1|2", -EINVAL },
        { SLP_TYPE_LONG, V64, -EMSGSIZE },
        /* double */
        { SLP_TYPE_DOUBLE, "0", 0 },
        { SLP_TYPE_DOUBLE, "-113.12345678", 0 },
        { SLP_TYPE_DOUBLE, "+40.5", 0 },
        { SLP_TYPE_DOUBLE, ".5", 0 },
        { SLP_TYPE_DOUBLE, "5.", 0 },
        { SLP_TYPE_DOUBLE, "-.5e-3", 0 },
        { SLP_TYPE_DOUBLE, "1E10", 0 },
        { SLP_TYPE_DOUBLE, "1e+10", 0 },
        { SLP_TYPE_DOUBLE, "100", 0 },
        { SLP_TYPE_DOUBLE, "1e-400", 0 },               /* underflows to 0: finite */
        { SLP_TYPE_DOUBLE, "0e999999999999999999999", 0 },
        { SLP_TYPE_DOUBLE, "0.000e400", 0 },
        { SLP_TYPE_DOUBLE, "1.7976931348623157e308", 0 },
        { SLP_TYPE_DOUBLE, "-1.7976931348623157e+308", 0 },
        { SLP_TYPE_DOUBLE, "17976931348623157e292", 0 },
        { SLP_TYPE_DOUBLE, "0.017976931348623157e310", 0 },
        { SLP_TYPE_DOUBLE, "1.79769313486231569e308", 0 },
        { SLP_TYPE_DOUBLE, "9.9e307", 0 },
        /* the significant digits found past leading zeros, in the fraction, and over the point */
        { SLP_TYPE_DOUBLE, "00.000017976931348623157e313", 0 },
        { SLP_TYPE_DOUBLE, "00.000017976931348623158e313", -EINVAL },
        { SLP_TYPE_DOUBLE, "179769313486231570.0e291", 0 },
        { SLP_TYPE_DOUBLE, "179769313486231570.1e291", -EINVAL },
        { SLP_TYPE_DOUBLE, "0000000000000000000000000000002e308", -EINVAL },
        { SLP_TYPE_DOUBLE, "0000000000000000000000000000001e308", 0 },
        { SLP_TYPE_DOUBLE, "1.79769313486231571e308", -EINVAL },
        { SLP_TYPE_DOUBLE, "1.8e308", -EINVAL },
        { SLP_TYPE_DOUBLE, "1e309", -EINVAL },
        { SLP_TYPE_DOUBLE, "0.1e310", -EINVAL },
        { SLP_TYPE_DOUBLE, "1e99999999999999999999", -EINVAL },
        { SLP_TYPE_DOUBLE, "", -EINVAL },
        { SLP_TYPE_DOUBLE, ".", -EINVAL },
        { SLP_TYPE_DOUBLE, "-", -EINVAL },
        { SLP_TYPE_DOUBLE, "-.", -EINVAL },
        { SLP_TYPE_DOUBLE, "e5", -EINVAL },
        { SLP_TYPE_DOUBLE, "1e", -EINVAL },
        { SLP_TYPE_DOUBLE, "1e+", -EINVAL },
        { SLP_TYPE_DOUBLE, "1.2.3", -EINVAL },
        { SLP_TYPE_DOUBLE, "1,5", -EINVAL },           /* no locale: ',' is never a point */
        { SLP_TYPE_DOUBLE, "0x1p3", -EINVAL },
        { SLP_TYPE_DOUBLE, "inf", -EINVAL },
        { SLP_TYPE_DOUBLE, "-infinity", -EINVAL },
        { SLP_TYPE_DOUBLE, "nan", -EINVAL },
        { SLP_TYPE_DOUBLE, "NAN(1)", -EINVAL },
        { SLP_TYPE_DOUBLE, " 1.5", -EINVAL },
        { SLP_TYPE_DOUBLE, "1.5 ", -EINVAL },
        { SLP_TYPE_DOUBLE, "1.5x", -EINVAL },
        { SLP_TYPE_DOUBLE, "1e5.0", -EINVAL },
        { SLP_TYPE_DOUBLE, "++1", -EINVAL },
        { SLP_TYPE_DOUBLE, V64, -EMSGSIZE },
        /* string */
        { SLP_TYPE_STRING, "", 0 },
        { SLP_TYPE_STRING, "VEH_1", 0 },
        { SLP_TYPE_STRING, "0, TELEOP START ~!@#$%^&*(){}", 0 },
        { SLP_TYPE_STRING, "a|b", -EINVAL },
        { SLP_TYPE_STRING, "a[", -EINVAL },
        { SLP_TYPE_STRING, "]", -EINVAL },
        { SLP_TYPE_STRING, "tab\there", -EINVAL },
        { SLP_TYPE_STRING, "\x7f", -EINVAL },
        { SLP_TYPE_STRING, "\xc3\xa9", -EINVAL },
        { SLP_TYPE_STRING, V64, -EMSGSIZE },
        /* not a type */
        { (enum slp_type)1, "0", -EINVAL },
        { (enum slp_type)3, "0", -EINVAL },
};

/* Node addresses: exactly the sixteen letters A..P, one character, whatever the byte. */
static void test_address_valid(void **state)
{
        unsigned valid = 0;

        (void)state;
        for (int b = CHAR_MIN; b <= CHAR_MAX; b++) {
                char c = (char)b;
                bool want = c >= 'A' && c <= 'P';

                if (slp_address_valid(c) != want)
                        print_error("address byte 0x%02x: got %d\n", (unsigned char)c, !want);
                assert_int_equal(slp_address_valid(c), want);
                /* The index and the text of an address follow the same rule. */
                if (want) {
                        assert_int_equal(slp_address_index(c), (unsigned)(c - 'A'));
                        assert_non_null(slp_address_text(c));
                        assert_int_equal(slp_address_text(c)[0], c);
                        assert_int_equal(slp_address_text(c)[1], '\0');
                } else {
                        assert_null(slp_address_text(c));
                }
                valid += want;
        }
        assert_int_equal(valid, SLP_ADDR_COUNT);
        assert_true(slp_address_text_valid("A", 1));
        assert_true(slp_address_text_valid("P", 1));
        assert_false(slp_address_text_valid("Q", 1));
        assert_false(slp_address_text_valid("@", 1));
        assert_false(slp_address_text_valid("a", 1));
        assert_false(slp_address_text_valid("AB", 2));
        assert_false(slp_address_text_valid("", 0));
        /* The length is the caller's: "A" with its NUL is two bytes, not an address. */
        assert_false(slp_address_text_valid("A", 2));
        assert_true(slp_address_text_valid("AB", 1));
}

/*
 * Issue 18.5: one rule for the bytes of a value and one for the bytes of a name, whoever asks:
 * the codec (slp_value_check, slp_name_check), the table and the library (shm_layout_*). A name
 * is letters, digits, _ . - (sharedlinkd.yaml(5)); the table used to take any value byte but
 * space, so "a:b" was a variable name for it and for nothing else.
 */
static void test_one_rule(void **state)
{
        unsigned names = 0, values = 0;

        (void)state;
        for (int b = 1; b <= UCHAR_MAX; b++) {
                char one[2] = { (char)b, '\0' };
                bool name = slp_name_byte((char)b), value = slp_value_byte((unsigned char)b);

                assert_int_equal(shm_layout_name_check(one) == 0, name);
                assert_int_equal(slp_name_check(one, 1) == 0, name);
                assert_int_equal(shm_layout_value_char(b) != 0, value);
                assert_int_equal(shm_layout_value_check(one, 1) == 0, value);
                assert_int_equal(slp_value_check(SLP_TYPE_STRING, one, 1) == 0, value);
                /* Every name byte is a value byte: a name can travel in a Q, R or E field. */
                assert_true(!name || value);
                names += name;
                values += value;
        }
        assert_int_equal(names, 26 + 26 + 10 + 3);
        assert_int_equal(values, SLP_VALUE_BYTE_MAX - SLP_VALUE_BYTE_MIN + 1 - 3);
        assert_int_equal(shm_layout_name_check("a:b"), -EINVAL);
        assert_int_equal(shm_layout_name_check("veh.A.joy_steer-2"), 0);
}

static void test_value_check(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(value_cases) / sizeof(value_cases[0]); i++) {
                const struct value_case *c = &value_cases[i];
                int r = slp_value_check(c->type, c->value, strlen(c->value));

                if (r != c->expect)
                        print_error("value check T%d \"%s\": got %d want %d\n", (int)c->type,
                                    c->value, r, c->expect);
                assert_int_equal(r, c->expect);
        }
        /* The length is the caller's, not strlen(): a NUL inside is a bad byte. */
        assert_int_equal(slp_value_check(SLP_TYPE_LONG, "12", 1), 0);
        assert_int_equal(slp_value_check(SLP_TYPE_STRING, "a\0b", 3), -EINVAL);
        assert_int_equal(slp_value_check(SLP_TYPE_DOUBLE, "1e5\0", 4), -EINVAL);
        assert_int_equal(slp_value_check(SLP_TYPE_STRING, V64, SLP_VALUE_MAX), 0);
}

/*
 * sl_write checks the caller's own string, whose last byte may be the last of a page: the value
 * checks (eight and sixteen bytes at a time, their last load overlapping) never read past len.
 * Every length up to SLP_VALUE_MAX at the end of a page followed by one that faults, each valid
 * and then with one bad byte at every position; the same values as long and double.
 */
static void test_value_check_page_end(void **state)
{
        long page = sysconf(_SC_PAGESIZE);
        char *base = mmap(NULL, 2u * (size_t)page, PROT_READ | PROT_WRITE,
                          MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);

        (void)state;
        assert_true(base != MAP_FAILED);
        assert_int_equal(mprotect(base + page, (size_t)page, PROT_NONE), 0);
        for (size_t len = 0; len <= SLP_VALUE_MAX; len++) {
                char *v = base + page - len;

                memset(v, '7', len);
                assert_int_equal(shm_layout_value_check(v, len), 0);
                assert_int_equal(slp_value_check(SLP_TYPE_DOUBLE, v, len), len ? 0 : -EINVAL);
                assert_int_equal(slp_value_type_check(SLP_TYPE_DOUBLE, v, len),
                                 len ? 0 : -EINVAL);
                if (len > 0 && len <= 18)
                        assert_int_equal(slp_value_type_check(SLP_TYPE_LONG, v, len), 0);
                for (size_t bad = 0; bad < len; bad++) {
                        v[bad] = '|';
                        assert_int_equal(shm_layout_value_check(v, len), -EINVAL);
                        v[bad] = 'x';
                        assert_int_equal(slp_value_type_check(SLP_TYPE_DOUBLE, v, len), -EINVAL);
                        assert_int_equal(slp_value_type_check(SLP_TYPE_LONG, v, len), -EINVAL);
                        v[bad] = '7';
                }
        }
        munmap(base, 2u * (size_t)page);
}

static void test_name_check(void **state)
{
        static const char *const good[] = { "a", "AutoGpsLat", "veh_start", "b.Cmd-1", "7" };
        static const char *const bad[] = { "", "a b", "a|b", "a]", "ä", "a\tb", "a,b", "Link:" };

        (void)state;
        for (size_t i = 0; i < sizeof(good) / sizeof(good[0]); i++)
                assert_int_equal(slp_name_check(good[i], strlen(good[i])), 0);
        for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++)
                assert_int_equal(slp_name_check(bad[i], strlen(bad[i])), -EINVAL);
        assert_int_equal(slp_name_check(V64, SLP_VALUE_MAX), 0);
        assert_int_equal(slp_name_check(V64, SLP_VALUE_MAX + 1), -EMSGSIZE);
}

/* The host list of the public clients: the vehicle's N0 declaration and its acknowledgement. */
static const char *const p4_names[] = {
        "video_mux1", "veh_start", "veh_enable", "veh_motion", "joy_steer",
        "veh_steer", "veh_brake", "veh_throttle", "veh_shift", "veh_clutch",
};
static const enum slp_type p4_types[] = {
        SLP_TYPE_LONG, SLP_TYPE_LONG, SLP_TYPE_LONG, SLP_TYPE_LONG, SLP_TYPE_DOUBLE,
        SLP_TYPE_LONG, SLP_TYPE_LONG, SLP_TYPE_LONG, SLP_TYPE_LONG, SLP_TYPE_LONG,
};
static const char *const p4_values[] = { "0", "0", "0", "0", "0", "0", "100", "0", "0", "0" };
#define P4_COUNT (sizeof(p4_names) / sizeof(p4_names[0]))

/* Decodes buf (one frame, optional CR LF) into the shared decoder and returns the frame. */
static const struct slp_frame *decode_one(const char *buf, size_t len)
{
        struct slp_decode_result r;
        size_t used;

        assert_int_equal(slp_decoder_init(&dec, SLP_FRAME_MAX), 0);
        used = slp_decoder_feed(&dec, (const uint8_t *)buf, len, &r);
        assert_int_equal(r.kind, SLP_RESULT_FRAME);
        assert_true(len - used == 0 || (len - used == 2 && memcmp(buf + used, "\r\n", 2) == 0));
        return r.frame;
}

static bool field_is(const struct slp_field *f, char letter, const char *value)
{
        return f->letter == letter && f->len == strlen(value) &&
               memcmp(f->value, value, f->len) == 0;
}

/*
 * Encodes a named list frame by frame and checks, through the decoder, that every position
 * comes out once, in order, with its T/Q or R/D pair, each frame starting at its own offset and
 * no longer than max_frame. Returns the number of frames.
 */
static size_t check_named_roundtrip(const struct slp_named_list *l, bool declaration)
{
        size_t max = l->max_frame ? l->max_frame : SLP_FRAME_DEFAULT, cursor = 0, frames = 0;
        char buf[SLP_FRAME_MAX];
        int r;

        while ((r = declaration ? slp_encode_declaration(l, &cursor, buf, sizeof(buf))
                                : slp_encode_acknowledgement(l, &cursor, buf, sizeof(buf))) > 0) {
                const struct slp_frame *f = decode_one(buf, (size_t)r);
                size_t start;

                assert_true((size_t)r <= max);
                assert_true(++frames <= l->count);
                assert_int_equal(f->dst, l->dst);
                assert_int_equal(f->src, l->src);
                assert_int_equal(f->fields[0].letter, l->head);
                start = f->fields[0].index;
                assert_true(cursor > start);
                assert_int_equal(f->nfields, 1 + 2 * (cursor - start));
                for (size_t i = start; i < cursor; i++) {
                        const struct slp_field *a = &f->fields[1 + 2 * (i - start)];
                        char digit[2] = { slp_type_digit(declaration ? l->types[i] : 0), 0 };

                        if (declaration) {
                                assert_true(field_is(&a[0], 'T', digit));
                                assert_true(field_is(&a[1], 'Q', l->names[i]));
                        } else {
                                assert_true(field_is(&a[0], 'R', l->names[i]));
                                assert_true(field_is(&a[1], 'D', l->values[i]));
                        }
                }
        }
        assert_int_equal(r, 0);
        assert_int_equal(cursor, l->count);
        return frames;
}

static void test_declaration_encode(void **state)
{
        struct slp_named_list l = {
                .dst = 'A', .src = 'B', .head = 'N', .names = p4_names, .types = p4_types,
                .count = P4_COUNT,
        };
        char buf[SLP_FRAME_MAX];
        size_t cursor = 0;
        int r;

        (void)state;
        /* The host's N0 declaration of the public clients, byte for byte (sent by B to A). */
        l.dst = 'B';
        l.src = 'A';
        r = slp_encode_declaration(&l, &cursor, buf, sizeof(buf));
        assert_int_equal(r, strlen(P4_DECL_N));
        assert_memory_equal(buf, P4_DECL_N, (size_t)r);
        assert_int_equal(cursor, P4_COUNT);
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), 0);
        assert_int_equal(check_named_roundtrip(&l, true), 1);

        /* L form, CR LF, every type. */
        l = (struct slp_named_list){
                .dst = 'A', .src = 'B', .head = 'L', .crlf = true,
                .names = (const char *const[]){ "a", "b", "c" },
                .types = (const enum slp_type[]){ SLP_TYPE_LONG, SLP_TYPE_DOUBLE,
                                                  SLP_TYPE_STRING },
                .count = 3,
        };
        cursor = 0;
        r = slp_encode_declaration(&l, &cursor, buf, sizeof(buf));
        assert_int_equal(r, strlen("[:AB|L0|T0|Qa|T2|Qb|T4|Qc|C07]\r\n"));
        assert_memory_equal(buf, "[:AB|L0|T0|Qa|T2|Qb|T4|Qc|C07]\r\n", (size_t)r);

        /* Split over frames of 64 bytes: "L<k>" offsets, every entry exactly once. */
        l = (struct slp_named_list){ .dst = 'B', .src = 'A', .head = 'L', .names = p4_names,
                                     .types = p4_types, .count = P4_COUNT, .max_frame = 64 };
        assert_true(check_named_roundtrip(&l, true) >= 3);
        /* ... unless one frame is demanded: too long for 64 bytes, fine in 1024. */
        l.one_frame = true;
        cursor = 0;
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EMSGSIZE);
        assert_int_equal(cursor, 0);
        l.max_frame = 0;
        assert_int_equal(check_named_roundtrip(&l, true), 1);
        /* The caller's buffer is the limit: -ENOSPC, not -EMSGSIZE. */
        cursor = 0;
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, 100), -ENOSPC);
        /* one_frame never starts in the middle. */
        cursor = 3;
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EINVAL);
}

static void test_declaration_errors(void **state)
{
        static const char *const names[] = { "ok", "bad name", "" };
        static const enum slp_type types[] = { SLP_TYPE_LONG, SLP_TYPE_LONG, SLP_TYPE_LONG };
        static const enum slp_type bad_types[] = { SLP_TYPE_LONG, (enum slp_type)3 };
        struct slp_named_list l = { .dst = 'A', .src = 'B', .head = 'N', .names = names,
                                    .types = types, .count = 2 };
        char buf[SLP_FRAME_MAX];
        size_t cursor = 0;

        (void)state;
        /* A bad name ends the frame before it; the next call names it. */
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)),
                         strlen("[:AB|N0|T0|Qok|C1D]"));
        assert_memory_equal(buf, "[:AB|N0|T0|Qok|C1D]", strlen("[:AB|N0|T0|Qok|C1D]"));
        assert_int_equal(cursor, 1);
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        assert_int_equal(cursor, 1);
        /* With one_frame the whole list fails. */
        l.one_frame = true;
        cursor = 0;
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        l.one_frame = false;
        /* Empty name, unknown type, no types, bad head, bad address, NULL name. */
        l.names = (const char *const[]){ "" };
        l.count = 1;
        cursor = 0;
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        l.names = (const char *const[]){ "a", "b" };
        l.types = bad_types;
        l.count = 2;
        cursor = 1;
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        l.types = NULL;
        cursor = 0;
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        l.types = types;
        l.head = 'D';
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        l.head = 'N';
        l.src = 'Q';
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        l.src = 'B';
        l.names = (const char *const[]){ NULL, "b" };
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        l.names = (const char *const[]){ V64, "b" };
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EMSGSIZE);
        /* An entry that can never fit max_frame alone. */
        l.names = (const char *const[]){ "a01234567890123456789" };
        l.count = 1;
        l.max_frame = SLP_FRAME_MIN;
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), -EMSGSIZE);
        /* An empty list: nothing to send. */
        l.count = 0;
        l.max_frame = 0;
        assert_int_equal(slp_encode_declaration(&l, &cursor, buf, sizeof(buf)), 0);
}

static void test_acknowledgement_encode(void **state)
{
        struct slp_named_list l = {
                .dst = 'A', .src = 'B', .head = 'N', .names = p4_names, .values = p4_values,
                .count = P4_COUNT, .one_frame = true,
        };
        char buf[SLP_FRAME_MAX];
        size_t cursor = 0;
        int r;

        (void)state;
        /* The vehicle's answer to the declaration above, byte for byte (the C92 frame). */
        r = slp_encode_acknowledgement(&l, &cursor, buf, sizeof(buf));
        assert_int_equal(r, strlen(P4_ACK));
        assert_memory_equal(buf, P4_ACK, (size_t)r);
        assert_int_equal(check_named_roundtrip(&l, false), 1);
        /* Split, with CR LF. */
        l.one_frame = false;
        l.crlf = true;
        l.max_frame = 48;
        assert_true(check_named_roundtrip(&l, false) >= 4);
        /* Empty values are fine (nothing known yet); bad ones are not. */
        l = (struct slp_named_list){ .dst = 'A', .src = 'B', .head = 'N',
                                     .names = (const char *const[]){ "ok", "x" },
                                     .values = (const char *const[]){ "1", "" }, .count = 2 };
        cursor = 0;
        r = slp_encode_acknowledgement(&l, &cursor, buf, sizeof(buf));
        assert_int_equal(r, strlen("[:AB|N0|Rok|D1|Rx|D|C15]"));
        assert_memory_equal(buf, "[:AB|N0|Rok|D1|Rx|D|C15]", (size_t)r);
        assert_int_equal(check_named_roundtrip(&l, false), 1);
        l.values = (const char *const[]){ "1", "a]" };
        cursor = 0;
        assert_int_equal(slp_encode_acknowledgement(&l, &cursor, buf, sizeof(buf)),
                         strlen("[:AB|N0|Rok|D1|C0F]"));
        assert_memory_equal(buf, "[:AB|N0|Rok|D1|C0F]", strlen("[:AB|N0|Rok|D1|C0F]"));
        assert_int_equal(slp_encode_acknowledgement(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        l.values = (const char *const[]){ "1", V64 };
        assert_int_equal(slp_encode_acknowledgement(&l, &cursor, buf, sizeof(buf)), -EMSGSIZE);
        l.values = (const char *const[]){ "1", NULL };
        assert_int_equal(slp_encode_acknowledgement(&l, &cursor, buf, sizeof(buf)), -EINVAL);
        l.values = NULL;
        cursor = 0;
        assert_int_equal(slp_encode_acknowledgement(&l, &cursor, buf, sizeof(buf)), -EINVAL);
}

static void test_list_query_encode(void **state)
{
        char buf[64];
        int r;

        (void)state;
        r = slp_encode_list_query(buf, sizeof(buf), 'A', 'B', 'N', 0);
        assert_int_equal(r, strlen("[:AB|N?|C85]"));
        assert_memory_equal(buf, "[:AB|N?|C85]", (size_t)r);
        r = slp_encode_list_query(buf, sizeof(buf), 'B', 'A', 'L', SLP_ENCODE_CRLF);
        assert_int_equal(r, strlen("[:BA|L?|C83]\r\n"));
        assert_memory_equal(buf, "[:BA|L?|C83]\r\n", (size_t)r);
        assert_int_equal(decode_one(buf, (size_t)r)->fields[0].index, SLP_INDEX_QUERY);
        assert_int_equal(slp_encode_list_query(buf, sizeof(buf), 'A', 'B', 'Q', 0), -EINVAL);
        assert_int_equal(slp_encode_list_query(buf, sizeof(buf), 'A', 'b', 'N', 0), -EINVAL);
        assert_int_equal(slp_encode_list_query(buf, 11, 'A', 'B', 'N', 0), -ENOSPC);
}

static void test_command_encode(void **state)
{
        static const char *const cmds[][3] = {
                { "Link", "0, SetIP, 192.168.200.10:4220, 4000",
                  "[:BA|ELink|D0, SetIP, 192.168.200.10:4220, 4000|CE2]" },
                { "Link", "0, outbound, on", "[:BA|ELink|D0, outbound, on|CA0]" },
                { "Link", "0, inbound, on", "[:BA|ELink|D0, inbound, on|C1F]" },
                /* Sum 0x02: we pad it, where some senders write "C2". */
                { "ServoPod", "0,TELEOP START", "[:BA|EServoPod|D0,TELEOP START|C02]" },
                { "Physics", "0,Stop", "[:BA|EPhysics|D0,Stop|CE2]" },
        };
        char buf[128];
        int r;

        (void)state;
        for (size_t i = 0; i < sizeof(cmds) / sizeof(cmds[0]); i++) {
                const struct slp_frame *f;

                r = slp_encode_command(buf, sizeof(buf), 'B', 'A', cmds[i][0], cmds[i][1], 0);
                assert_int_equal(r, strlen(cmds[i][2]));
                assert_memory_equal(buf, cmds[i][2], (size_t)r);
                f = decode_one(buf, (size_t)r);
                assert_int_equal(f->nfields, 2);
                assert_true(field_is(&f->fields[0], 'E', cmds[i][0]));
                assert_int_equal(f->fields[0].type, SLP_FIELD_E);
                assert_true(field_is(&f->fields[1], 'D', cmds[i][1]));
        }
        r = slp_encode_command(buf, sizeof(buf), 'A', 'B', "Link", "", SLP_ENCODE_CRLF);
        assert_int_equal(r, strlen("[:AB|ELink|D|C8B]\r\n"));
        assert_memory_equal(buf, "[:AB|ELink|D|C8B]\r\n", (size_t)r);
        /* Bad module, bad text, too long, too small a buffer. */
        assert_int_equal(slp_encode_command(buf, sizeof(buf), 'A', 'B', "", "x", 0), -EINVAL);
        assert_int_equal(slp_encode_command(buf, sizeof(buf), 'A', 'B', "Servo Pod", "x", 0),
                         -EINVAL);
        assert_int_equal(slp_encode_command(buf, sizeof(buf), 'A', 'B', "a|D1", "x", 0), -EINVAL);
        assert_int_equal(slp_encode_command(buf, sizeof(buf), 'A', 'B', V64, "x", 0), -EMSGSIZE);
        assert_int_equal(slp_encode_command(buf, sizeof(buf), 'A', 'B', "Link", "0|x", 0),
                         -EINVAL);
        assert_int_equal(slp_encode_command(buf, sizeof(buf), 'A', 'B', "Link", "[", 0), -EINVAL);
        assert_int_equal(slp_encode_command(buf, sizeof(buf), 'A', 'B', "Link", V64, 0),
                         -EMSGSIZE);
        assert_int_equal(slp_encode_command(buf, sizeof(buf), 'A', 'B', "Link", "\n", 0), -EINVAL);
        assert_int_equal(slp_encode_command(buf, 10, 'A', 'B', "Link", "0", 0), -ENOSPC);
        /* The bare module requests go out bare (docs/pronto4.md §9's own frames), without text,
         * and read back as such; a name that only starts like one is a command. */
        {
                static const char *const bare[][2] = {
                        { "MUI", "[:BA|MUI|CE3]" }, { "MUO", "[:BA|MUO|CE9]" },
                        { "MW", "[:BA|MW|C9C]" }, { "ML", "[:BA|ML|C91]" },
                };

                for (size_t i = 0; i < sizeof(bare) / sizeof(bare[0]); i++) {
                        const struct slp_frame *f;

                        r = slp_encode_command(buf, sizeof(buf), 'B', 'A', bare[i][0], NULL, 0);
                        assert_int_equal(r, strlen(bare[i][1]));
                        assert_memory_equal(buf, bare[i][1], (size_t)r);
                        assert_int_equal(slp_encode_command(buf, sizeof(buf), 'B', 'A',
                                                            bare[i][0], "", 0), r);
                        f = decode_one(buf, (size_t)r);
                        assert_int_equal(slp_p4_kind_of(f), SLP_P4_MU);
                        assert_int_equal(slp_encode_command(buf, sizeof(buf), 'B', 'A',
                                                            bare[i][0], "x", 0), -EINVAL);
                }
                assert_true(slp_p4_bare_request("MUI", 3));
                assert_false(slp_p4_bare_request("MUIX", 4));
                assert_false(slp_p4_bare_request("MU", 2));
                r = slp_encode_command(buf, sizeof(buf), 'B', 'A', "MUIX", "", 0);
                assert_int_equal(r, strlen("[:BA|EMUIX|D|C00]"));
                assert_memory_equal(buf, "[:BA|EMUIX|D|", 13);
        }
        assert_int_equal(slp_encode_command(buf, sizeof(buf), 'A', 'R', "Link", "0", 0), -EINVAL);
}

static void test_list_whole(void **state)
{
        static const char *const v[] = { "1", "2.5", "hello" };
        static const char *const spec[] = { "40.12345678", "-113.12345678", "85.7", "22.1" };
        struct slp_list l = { .dst = 'A', .src = 'B', .values = v, .count = 3 };
        char buf[SLP_FRAME_MAX];
        int r;

        (void)state;
        r = slp_encode_list_whole(&l, buf, sizeof(buf));
        assert_int_equal(r, strlen("[:AB|N0|D1|D2.5|Dhello|C90]"));
        assert_memory_equal(buf, "[:AB|N0|D1|D2.5|Dhello|C90]", (size_t)r);
        /* Compressed, still the whole length (empty D for unchanged positions). */
        l = (struct slp_list){ .dst = 'A', .src = 'B', .values = spec, .count = 4,
                               .compress = true,
                               .changed = (const bool[]){ false, false, true, false } };
        r = slp_encode_list_whole(&l, buf, sizeof(buf));
        assert_int_equal(r, strlen("[:AB|N0|D|D|D85.7|D|C48]"));
        assert_memory_equal(buf, "[:AB|N0|D|D|D85.7|D|C48]", (size_t)r);
        /* Exactly max_frame fits; one byte less does not, and nothing is split. */
        l.crlf = true;
        l.max_frame = (size_t)r + 2;
        assert_int_equal(slp_encode_list_whole(&l, buf, sizeof(buf)), r + 2);
        assert_memory_equal(buf + r, "\r\n", 2);
        l.max_frame = (size_t)r + 1;
        assert_int_equal(slp_encode_list_whole(&l, buf, sizeof(buf)), -EMSGSIZE);
        /* The full refresh of a long list that slp_encode_list() would split. */
        make_values(100);
        l = (struct slp_list){ .dst = 'A', .src = 'B', .values = list_values, .count = 100 };
        assert_int_equal(slp_encode_list_whole(&l, buf, sizeof(buf)), -EMSGSIZE);
        l.count = 10;
        r = slp_encode_list_whole(&l, buf, sizeof(buf));
        assert_true(r > 0);
        assert_int_equal(decode_one(buf, (size_t)r)->nfields, 11);
        /* What a configuration check computes from the lengths alone. */
        size_t fields = 0, names = 0;
        for (size_t i = 0; i < 10; i++)
                fields += 2 + strlen(list_values[i]);
        assert_int_equal(slp_list_frame_len(fields, false), r);
        assert_int_equal(slp_list_frame_len(fields, true), r + 2);
        for (size_t i = 0; i < P4_COUNT; i++)
                names += 2 + 1 + 2 + strlen(p4_names[i]);
        assert_int_equal(slp_list_frame_len(names, false), strlen(P4_DECL_N));
        assert_int_equal(slp_list_frame_len(0, false), strlen("[:AB|N0|C00]"));
        assert_int_equal(slp_encode_list_whole(&l, buf, (size_t)r - 1), -ENOSPC);
        /* Bad values and addresses; an empty list sends nothing. */
        l = (struct slp_list){ .dst = 'A', .src = 'B', .values = (const char *const[]){ "1", "|" },
                               .count = 2 };
        assert_int_equal(slp_encode_list_whole(&l, buf, sizeof(buf)), -EINVAL);
        l.values = (const char *const[]){ "1", V64 };
        assert_int_equal(slp_encode_list_whole(&l, buf, sizeof(buf)), -EMSGSIZE);
        l.values = v;
        l.dst = '@';
        assert_int_equal(slp_encode_list_whole(&l, buf, sizeof(buf)), -EINVAL);
        l.dst = 'A';
        l.count = 0;
        assert_int_equal(slp_encode_list_whole(&l, buf, sizeof(buf)), 0);
}

/* The dialect's reading of decoded frames: what each is, and its entries. */

static const struct kind_case {
        const char *wire;
        enum slp_p4_kind kind;
} kind_cases[] = {
        { P4_DECL_N, SLP_P4_DECLARATION },
        { P4_DECL_L, SLP_P4_DECLARATION },
        { "[:BA|L1|T0|Qz|CBC]", SLP_P4_DECLARATION },
        { P4_ACK, SLP_P4_ACKNOWLEDGEMENT },
        { "[:AB|N0|T4|QVehicleName|DVEH_1|T2|QAutoGpsLat|D0|C5E]", SLP_P4_SELF_DESCRIBING },
        { "[:AB|N0||D0|D|D|C62]", SLP_P4_DATA },
        { "[:BA|N5|D1|D2|C5E]", SLP_P4_DATA },
        { "[:BA|N?|C85]", SLP_P4_LIST_QUERY },
        { "[:BA|L?|C83]", SLP_P4_LIST_QUERY },
        { "[:AB|P0|C78]", SLP_P4_PING },
        { "[:BA|G0|C6F]", SLP_P4_PONG },
        { "[:BA|EServoPod|D0,TELEOP START|C2]", SLP_P4_COMMAND },
        { "[:BA|MUI|CE3]", SLP_P4_MU },
        { "[:BA|MUO|CE9]", SLP_P4_MU },
        { "[:BA|MW|C9C]", SLP_P4_MU },
        { "[:BA|ML|C91]", SLP_P4_MU },
        { "[:BA|MX|C9D]", SLP_P4_OTHER },
        { "[:BA|MUI|D1|CD4]", SLP_P4_OTHER },
        { "[:AB|RAutoGpsLat|D1|C1F]", SLP_P4_OTHER },          /* a bulletin answer */
        { "[:AB|QAutoGpsLat|C2D]", SLP_P4_OTHER },              /* a bulletin query */
        { "[:AB|D1|D2|C5F]", SLP_P4_OTHER },
        { "[:BA|L0|D1|C65]", SLP_P4_OTHER },
};

static void test_p4_kind(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(kind_cases) / sizeof(kind_cases[0]); i++) {
                const struct slp_frame *f = decode_one(kind_cases[i].wire,
                                                       strlen(kind_cases[i].wire));
                enum slp_p4_kind k = slp_p4_kind_of(f);

                if (k != kind_cases[i].kind)
                        print_error("%s: kind %d, want %d\n", kind_cases[i].wire, (int)k,
                                    (int)kind_cases[i].kind);
                assert_int_equal(k, kind_cases[i].kind);
        }
}

/* Entries of a frame as text: "name:type" ("name:2?" untyped), "=value" when it has one,
 * "!" for a bad entry; separated by spaces. */
static void entries_text(const char *wire, char *out, size_t size)
{
        const struct slp_frame *f = decode_one(wire, strlen(wire));
        struct slp_entry e;
        size_t pos = 1, n = 0, last = 0;
        int r;

        out[0] = '\0';
        while ((r = slp_entry_next(f, &pos, &e)) != 0) {
                int w;

                assert_true(pos > last && pos <= f->nfields);  /* always moves on */
                last = pos;
                if (r < 0) {
                        assert_int_equal(r, -EINVAL);
                        w = snprintf(out + n, size - n, "%s!", n ? " " : "");
                } else {
                        w = snprintf(out + n, size - n, "%s%c%.*s:%d%s", n ? " " : "", e.letter,
                                     (int)e.name_len, e.name, (int)e.type, e.typed ? "" : "?");
                        if (w > 0 && e.has_value)
                                w += snprintf(out + n + (size_t)w, size - n - (size_t)w, "=%.*s",
                                              (int)e.value_len, e.value);
                }
                assert_true(w > 0 && (size_t)w < size - n);
                n += (size_t)w;
        }
        assert_int_equal(pos, f->nfields);
}

static void test_p4_entries(void **state)
{
        static const char *const cases[][2] = {
                { "[:BA|N0|T0|Qthrottle|Qsvp_enb_eng|T0|Qserialpck|C97]",
                  "Qthrottle:0 Qsvp_enb_eng:2? Qserialpck:0" },
                { "[:AB|N0|T4|QVehicleName|DVEH_1|T2|QAutoGpsLat|D0|C5E]",
                  "QVehicleName:4=VEH_1 QAutoGpsLat:2=0" },
                { "[:AB|N0|Rok|D1|Rx|D|C15]", "Rok:2?=1 Rx:2?=" },
                { "[:BA|N0|Rsvp_enb_eng|CCA]", "Rsvp_enb_eng:2?" },
                /* bad entries: the T 3 takes its name with it; a T without a name; a bad name;
                 * a stray D; a T at the end */
                { "[:BA|N0|T3|Qa|T0|Qb|CD6]", "! Qb:0" },
                { "[:BA|N0|T0|T2|Qb|CA7]", "! Qb:2" },
                { "[:BA|N0|T0|Qa b|T2|Qc|C58]", "! Qc:2" },
                { "[:BA|N0|Dx|T0|Qa|CDC]", "! Qa:0" },
                { "[:BA|N0|T0|Qa|T4|CA8]", "Qa:0 !" },
                { "[:BA|N?|C85]", "" },
        };
        char out[1024];

        (void)state;
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                entries_text(cases[i][0], out, sizeof(out));
                if (strcmp(out, cases[i][1]) != 0)
                        print_error("%s\n  got:  %s\n  want: %s\n", cases[i][0], out, cases[i][1]);
                assert_string_equal(out, cases[i][1]);
        }
        /* The field lists: 10 typed entries, and 31 with one untyped (a double). */
        entries_text(P4_DECL_N, out, sizeof(out));
        assert_string_equal(out, "Qvideo_mux1:0 Qveh_start:0 Qveh_enable:0 Qveh_motion:0 "
                            "Qjoy_steer:2 Qveh_steer:0 Qveh_brake:0 Qveh_throttle:0 Qveh_shift:0 "
                            "Qveh_clutch:0");
        entries_text(P4_DECL_L, out, sizeof(out));
        assert_non_null(strstr(out, " Qthrottle:0 Qsvp_enb_eng:2? Qserialpck:0 "));
        assert_null(strchr(out, '!'));
        entries_text(P4_ACK, out, sizeof(out));
        assert_string_equal(out, "Rvideo_mux1:2?=0 Rveh_start:2?=0 Rveh_enable:2?=0 "
                            "Rveh_motion:2?=0 Rjoy_steer:2?=0 Rveh_steer:2?=0 Rveh_brake:2?=100 "
                            "Rveh_throttle:2?=0 Rveh_shift:2?=0 Rveh_clutch:2?=0");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_decode_vectors),
                cmocka_unit_test(test_frame_layout),
                cmocka_unit_test(test_decoder_init_limits),
                cmocka_unit_test(test_noise_runs),
                cmocka_unit_test(test_max_frame_edges),
                cmocka_unit_test(test_every_offset),
                cmocka_unit_test(test_reason_strings),
                cmocka_unit_test(test_encode_vectors),
                cmocka_unit_test(test_encode_buffer_size),
                cmocka_unit_test(test_encode_helpers),
                cmocka_unit_test(test_list_spec_frames),
                cmocka_unit_test(test_list_split),
                cmocka_unit_test(test_list_errors),
                cmocka_unit_test(test_roundtrip_vectors),
                cmocka_unit_test(test_type_parse),
                cmocka_unit_test(test_address_valid),
                cmocka_unit_test(test_one_rule),
                cmocka_unit_test(test_value_check),
                cmocka_unit_test(test_value_check_page_end),
                cmocka_unit_test(test_name_check),
                cmocka_unit_test(test_declaration_encode),
                cmocka_unit_test(test_declaration_errors),
                cmocka_unit_test(test_acknowledgement_encode),
                cmocka_unit_test(test_list_query_encode),
                cmocka_unit_test(test_command_encode),
                cmocka_unit_test(test_list_whole),
                cmocka_unit_test(test_p4_kind),
                cmocka_unit_test(test_p4_entries),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
