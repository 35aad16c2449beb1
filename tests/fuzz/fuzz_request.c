/*
 * libFuzzer target for the control-command vocabulary (src/proto/request.c).
 *
 * The input is used two ways:
 *  1. as a request line the daemon receives: split the daemon's way and decoded. Whatever
 *     decodes must encode, into a line the strict grammar passes (what a client sends), that
 *     decodes again and encodes to the same line: decode -> encode -> decode -> encode is stable.
 *     Whatever is refused has a reason.
 *  2. as a request the library builds: the first byte picks the kind, the rest drives the
 *     setters with numbers in and out of range and words from the input. Whatever the encoder
 *     takes must decode and encode to the same line: encode -> decode -> encode is equal.
 * Any broken invariant is a __builtin_trap().
 */
#include <errno.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "fuzz_input.h"
#include "proto/request.h"

#define WORD_MAX        80      /* longest word the setters get from the input */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Decodes line (a strict one, as encoded) and encodes it again: must give the same line. */
static void check_round_trip(const char *line, size_t len)
{
        static char buf[CTLP_LINE_MAX], again[CTLP_LINE_MAX];
        char *argv[CTLP_WORDS_MAX + 1], err[REQP_ERR_MAX];
        struct reqp_request r;
        int argc = 0, n;

        CHECK(len == strlen(line) && len < CTLP_LINE_MAX);
        CHECK(ctlp_request_check(line, len, NULL) == CTLP_REASON_NONE);
        memcpy(buf, line, len + 1u);
        CHECK(ctlp_request_split(buf, len, argv, &argc) == CTLP_REASON_NONE);
        CHECK(reqp_decode(argc, argv, &r, err, sizeof(err)) == 0);
        n = reqp_encode(&r, again, sizeof(again), err, sizeof(err));
        CHECK(n >= 0 && (size_t)n == len && strcmp(again, line) == 0);
}

/* ---- 1. lines the daemon receives ---------------------------------------------------------- */

static void fuzz_line(const uint8_t *data, size_t size)
{
        static char line[CTLP_LINE_MAX + 1], out[CTLP_LINE_MAX];
        char *argv[CTLP_WORDS_MAX + 1], err[REQP_ERR_MAX];
        size_t n = size < CTLP_LINE_MAX - 1u ? size : CTLP_LINE_MAX - 1u;
        struct reqp_request r;
        int argc = 0, len, rc;

        memcpy(line, data, n);
        line[n] = '\0';
        if (ctlp_request_split(line, n, argv, &argc) != CTLP_REASON_NONE)
                return;
        err[0] = '\0';
        rc = reqp_decode(argc, argv, &r, err, sizeof(err));
        if (rc < 0) {
                CHECK(rc == -EINVAL && err[0] != '\0');
                return;
        }
        CHECK((unsigned)r.kind < REQP_KIND_COUNT);
        len = reqp_encode(&r, out, sizeof(out), err, sizeof(err));
        CHECK(len > 0);
        check_round_trip(out, (size_t)len);
}

/* ---- 2. requests the library builds -------------------------------------------------------- */

/*
 * A word of the input. Raw bytes alone would seldom make a request the encoder takes, so most of
 * the time the word is shaped: an address (six hex digits, now and then lower case), a node
 * letter, a name of letters and digits, a text of such words; else up to WORD_MAX raw bytes.
 */
static const char *take_word(struct input *in, char *buf)
{
        static const char alnum[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";
        uint8_t shape = take(in);
        size_t n = take(in) % (WORD_MAX + 1u), i;

        switch (shape % 5u) {
        case 0:
                snprintf(buf, WORD_MAX + 1u, shape & 0x80u ? "%06x" : "%06X",
                         (unsigned)take(in) << 16 | (unsigned)take(in) << 8 | take(in));
                return buf;
        case 1:
                buf[0] = (char)('A' + take(in) % 17u);          /* 'Q' now and then */
                buf[1] = '\0';
                return buf;
        case 2:
        case 3:
                for (i = 0; i < n && i < WORD_MAX; i++) {
                        uint8_t b = take(in);

                        /* Text gets a space now and then (a double or trailing one too). */
                        buf[i] = shape % 5u == 3u && b % 7u == 0 ? ' ' :
                                 alnum[b % (sizeof(alnum) - 1u)];
                }
                buf[i] = '\0';
                return buf;
        default:
                for (i = 0; i < n && in->n > 0; i++) {
                        buf[i] = (char)take(in);
                        if (buf[i] == '\0')
                                break;
                }
                buf[i] = '\0';
                return buf;
        }
}

/* A number around the interesting ranges: small, near a limit, negative, huge. */
static long take_number(struct input *in)
{
        static const long edges[] = { 0, 1, 2, 99, 100, 127, 128, 255, 999, 1000, 65535, 65536,
                                      999999, 1000000, 60000, 60001, -1, 0x7fffffffL };
        uint8_t sel = take(in);

        if (sel < 128)
                return edges[sel % (sizeof(edges) / sizeof(edges[0]))];
        return (long)((uint32_t)take(in) << 16 | (uint32_t)take(in) << 8 | take(in));
}

/* The keys the library sets, by kind, in the library's order. */
static const char *const keys[REQP_KIND_COUNT][10] = {
        [REQP_QUERY] = { "peer", "variable name", "timeout" },
        [REQP_COMMAND] = { "module", "command text" },
        [REQP_PEER_PING] = { "peer", "timeout" },
        [REQP_CIRCE_ALERT] = { "address" },
        [REQP_CIRCE_NETWORK_SETUP] = { "address", "membership", "roles" },
        [REQP_CIRCE_DEVICE_SETUP] = { "address to assign", "destination", "capabilities" },
        [REQP_CIRCE_VISUALIZE] = { "destination", "current", "next", "start-timer", "primary",
                                   "secondary", "faults", "refusals", "eliminated",
                                   "placement" },
        [REQP_CIRCE_EMULATE_ACTION] = { "device", "keys", "sensor-time" },
};

static void fuzz_build(const uint8_t *data, size_t size)
{
        static char out[CTLP_LINE_MAX];
        struct input in = { data, size };
        char word[WORD_MAX + 1], err[REQP_ERR_MAX];
        enum reqp_kind kind = (enum reqp_kind)(take(&in) % REQP_KIND_COUNT);
        struct reqp_request r;
        int len;

        reqp_init(&r, kind);
        if (reqp_has_link(kind))
                reqp_set_link(&r, take_word(&in, word), err, sizeof(err));
        /* Each key zero or more times, a number or a word as the input says. */
        while (in.n > 0) {
                uint8_t op = take(&in);
                const char *key = keys[kind][op % 10u];

                if (!key)
                        key = "nothing";
                if (op & 0x80u)
                        reqp_set_number(&r, key, take_number(&in), err, sizeof(err));
                else
                        reqp_set_text(&r, key, take_word(&in, word), err, sizeof(err));
                if ((op & 0x60u) == 0x60u)
                        r.wait_ms = take(&in) * 300u;   /* 0..76500: past the limit too */
        }
        len = reqp_encode(&r, out, sizeof(out), err, sizeof(err));
        if (len < 0) {
                CHECK(len == -EINVAL || len == -EMSGSIZE);
                return;
        }
        CHECK(reqp_verb(kind)[0] != '?');
        check_round_trip(out, (size_t)len);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        fuzz_line(data, size);
        fuzz_build(data, size);
        return 0;
}
