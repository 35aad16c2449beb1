/*
 * The CIRCE bad-input script (see circe_garbage.h).
 */
#include "common/circe_garbage.h"

#include <stdlib.h>
#include <string.h>

#include "common/circe_sessions.h"
#include "common/wire.h"

#define OVERLONG_LEN    (CIRCE_PACKET_MAX + 10)

enum step_kind {
        STEP_RAW,               /* text as it is, len bytes */
        STEP_PACKET,            /* a packet with its checksum */
        STEP_BAD_CS,            /* the same with its checksum's last digit changed */
        STEP_LOWER_CS,          /* with a lowercase checksum */
        STEP_NO_CS,             /* without a checksum */
        STEP_OVERLONG,          /* STX and OVERLONG_LEN - 1 bytes of 'x', no ETX */
};

struct step {
        enum step_kind kind;
        const char *text;
        size_t len;             /* STEP_RAW only */
};

#define RAW(s)          { STEP_RAW, s, sizeof(s) - 1 }
#define PKT(s)          { STEP_PACKET, s, 0 }

static const struct step steps[CIRCE_GARBAGE_STEPS] = {
        /* noise between packets: 7 bytes, plus a stray ETX */
        RAW("garbage\x03"),
        PKT("53\t015:A00001\t025:1\t"),
        { STEP_BAD_CS, "53\t015:B00001\t025:1\t", 0 },
        PKT("53\t015:A00002\t025:2\t"),
        /* checksum accepted in lower case; no checksum at all is fine too */
        { STEP_LOWER_CS, "53\t015:A0000A\t025:3\t", 0 },
        { STEP_NO_CS, "53\t015:A0000B\t025:4\t", 0 },
        /* unknown operation */
        PKT("99\t015:B00002\t"),
        /* bad values: signal over 255, a lowercase address, an empty value */
        PKT("52\t015:B00003\t016:0\t019:32\t020:0\t021:256\t"),
        PKT("53\t015:b00004\t025:1\t"),
        PKT("53\t015:\t025:1\t"),
        /* a mandatory parameter missing (Notify Status without 021) */
        PKT("52\t015:B00005\t016:0\t019:32\t020:0\t"),
        /* a repeated parameter keeps its first occurrence */
        PKT("53\t015:A00003\t025:7\t025:8\t"),
        /* a parameter not allowed for the operation is skipped, unchecked */
        PKT("53\t015:A00004\t025:9\t031:xyz\t"),
        /* a second STX abandons the partial packet */
        RAW("\x02" "53\t015:B00006"),
        PKT("53\t015:A00005\t025:10\t"),
        /* an overlong packet is abandoned, the next one still lands */
        { STEP_OVERLONG, NULL, 0 },
        PKT("53\t015:A00006\t025:11\t"),
        /* non-compliant statuses: ignored and counted */
        PKT("52\t015:C00001\t016:0\t019:0\t020:0\t021:1\t"),
        PKT("52\t015:C00002\t016:0\t019:33\t020:0\t021:1\t"),
        PKT("52\t015:C00003\t016:0\t019:65\t020:0\t021:1\t"),
        PKT("52\t015:000000\t016:0\t019:32\t020:0\t021:1\t"),
        /* an operation of the controller's own, from the mediator */
        PKT(CIRCE_S_NET_ALERT_E1E1E1),
        PKT("52\t015:A00007\t016:0\t019:96\t020:0\t021:1\t"),       /* 96 = 64|32: no */
        PKT("52\t015:A00008\t016:0\t019:31\t020:0\t021:1\t"),
};

const struct circe_garbage_count circe_garbage_counts[CIRCE_GARBAGE_COUNTERS] = {
        /* "garbage" + stray ETX; the overlong packet's bytes after STX fill the
         * CIRCE_PACKET_MAX - 2 bytes of room, the rest is noise up to the next STX. */
        { "noise_bytes", 8 + (OVERLONG_LEN - 1) - (CIRCE_PACKET_MAX - 2) },
        { "bad_checksum", 1 },
        { "unknown_op", 2 },
        { "bad_value", 3 },
        { "missing_param", 1 },
        { "repeated_param", 1 },
        { "skipped_param", 1 },
        { "resync", 1 },
        { "overlong", 1 },
        { "noncompliant_status", 5 },
        /* KA + A00001..6 + A0000A + A0000B + 5 non-compliant (A00007 among them) + 03 + A00008 */
        { "frames_in", 1 + 6 + 2 + 5 + 1 + 1 },
};

size_t circe_garbage_bytes(unsigned i, uint8_t *out, size_t size)
{
        const struct step *s;
        size_t n;

        if (i >= CIRCE_GARBAGE_STEPS || size < CIRCE_GARBAGE_STEP_MAX)
                abort();        /* a bug in the test, not an input */
        s = &steps[i];
        switch (s->kind) {
        case STEP_RAW:
                memcpy(out, s->text, s->len);
                return s->len;
        case STEP_BAD_CS:
                n = wire_circe_str(out, size, s->text, WIRE_CS_UPPER);
                out[n - 2] = out[n - 2] == '0' ? '1' : '0';
                return n;
        case STEP_LOWER_CS:
                return wire_circe_str(out, size, s->text, WIRE_CS_LOWER);
        case STEP_NO_CS:
                return wire_circe_str(out, size, s->text, WIRE_CS_NONE);
        case STEP_OVERLONG:
                memset(out, 'x', OVERLONG_LEN);
                out[0] = WIRE_CIRCE_STX;
                return OVERLONG_LEN;
        case STEP_PACKET:
        default:
                return wire_circe_str(out, size, s->text, WIRE_CS_UPPER);
        }
}
