/*
 * libFuzzer target for the CIRCE codec (src/proto/circe.c).
 *
 * The input is used twice:
 *  1. as a byte stream, fed to one decoder all at once and to another in chunks whose sizes come
 *     from the input; both must give the same results and counters (the framer cannot depend on
 *     how reads split the stream), every call must make progress within bounds, and every
 *     decoded message must re-encode (with and without checksum) to bytes that decode to an
 *     identical message and re-encode to the same bytes;
 *  2. as the fields of a message handed to the encoder: whatever it accepts must decode back to
 *     the same message, so the encoder never emits what the decoder rejects.
 * Any broken invariant is a __builtin_trap().
 */
#include <errno.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "proto/circe.h"

#define CHECK(cond)                                                                            \
        do {                                                                                   \
                if (!(cond))                                                                   \
                        __builtin_trap();                                                      \
        } while (0)

#define CHUNK_SPREAD 61                 /* chunk sizes 1..61 */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* ---- Streaming ------------------------------------------------------------------------------- */

struct stream {
        struct circe_decoder dec;
        const uint8_t *data;
        size_t size, pos, chunk_end;
        bool chunked;
        unsigned results;
};

/* Next chunk length at pos, derived from the input so the fuzzer controls the splits. */
static size_t chunk_len(const struct stream *s)
{
        size_t n = 1 + (size_t)(s->data[s->pos] * 7u + s->pos) % CHUNK_SPREAD;
        size_t left = s->size - s->pos;

        return n < left ? n : left;
}

static void stream_init(struct stream *s, const uint8_t *data, size_t size, bool chunked)
{
        circe_decoder_init(&s->dec);
        s->data = data;
        s->size = size;
        s->pos = 0;
        s->chunk_end = 0;
        s->chunked = chunked;
        s->results = 0;
}

/* The next result, or false when the input is used up. */
static bool stream_next(struct stream *s, struct circe_result *r)
{
        while (s->pos < s->size) {
                size_t avail, n;

                if (s->pos == s->chunk_end)
                        s->chunk_end = s->pos + (s->chunked ? chunk_len(s) : s->size - s->pos);
                avail = s->chunk_end - s->pos;
                n = circe_decoder_feed(&s->dec, s->data + s->pos, avail, r);
                CHECK(n >= 1 && n <= avail);
                CHECK(n == avail || r->kind != CIRCE_RESULT_NONE);
                s->pos += n;
                if (r->kind != CIRCE_RESULT_NONE) {
                        s->results++;
                        return true;
                }
        }
        return false;
}

static bool results_equal(const struct circe_result *a, const struct circe_result *b)
{
        if (a->kind != b->kind || a->reason != b->reason || a->param != b->param ||
            a->packet_len != b->packet_len || memcmp(a->packet, b->packet, a->packet_len) != 0)
                return false;
        if (a->kind != CIRCE_RESULT_MESSAGE)
                return true;
        return a->skipped == b->skipped && a->repeated == b->repeated &&
               a->has_checksum == b->has_checksum && circe_msg_equal(&a->msg, &b->msg);
}

/* Encodes m, decodes it back (standalone and through a framer), re-encodes: all identical. */
static int check_encoding(const struct circe_msg *m, int with_checksum, char *out)
{
        static struct circe_decoder dec;
        static struct circe_result r;
        static char again[CIRCE_PACKET_MAX];
        int n = circe_encode(m, with_checksum, out, CIRCE_PACKET_MAX);

        CHECK(n != -ENOBUFS);           /* CIRCE_PACKET_MAX bytes are always enough */
        if (n < 0)
                return n;
        CHECK(n >= 5 && n <= CIRCE_PACKET_MAX);
        CHECK((uint8_t)out[0] == CIRCE_STX && (uint8_t)out[n - 1] == CIRCE_ETX);

        circe_decode((const uint8_t *)out, (size_t)n, &r);
        CHECK(r.kind == CIRCE_RESULT_MESSAGE);
        CHECK(r.skipped == 0 && r.repeated == 0);
        CHECK(r.has_checksum == (with_checksum != 0));
        CHECK(circe_msg_equal(&r.msg, m));
        CHECK(circe_encode(&r.msg, with_checksum, again, sizeof(again)) == n);
        CHECK(memcmp(again, out, (size_t)n) == 0);

        circe_decoder_init(&dec);
        CHECK(circe_decoder_feed(&dec, (const uint8_t *)out, (size_t)n, &r) == (size_t)n);
        CHECK(r.kind == CIRCE_RESULT_MESSAGE && circe_msg_equal(&r.msg, m));

        /* The exact size is enough, one byte less is refused. */
        CHECK(circe_encode(m, with_checksum, again, (size_t)n) == n);
        CHECK(circe_encode(m, with_checksum, again, (size_t)n - 1) == -ENOBUFS);
        return n;
}

static void check_result(const struct circe_result *r)
{
        static char plain[CIRCE_PACKET_MAX], summed[CIRCE_PACKET_MAX];
        int n0, n1;

        CHECK(r->packet_len <= CIRCE_PACKET_MAX);
        if (r->kind == CIRCE_RESULT_REJECTED) {
                CHECK(r->reason > CIRCE_REASON_NONE && r->reason < CIRCE_REASON_COUNT);
                CHECK(r->reason != CIRCE_REASON_BAD_FRAMING);   /* the framer cuts right */
                CHECK(r->msg.op == CIRCE_OP_NONE);
                CHECK(r->param < 1000);
                CHECK(circe_reason_str(r->reason) != NULL);
                return;
        }
        CHECK(r->kind == CIRCE_RESULT_MESSAGE);
        CHECK(r->reason == CIRCE_REASON_NONE);
        CHECK(circe_op_str(r->msg.op) != NULL);
        CHECK(r->packet[0] == CIRCE_STX && r->packet[r->packet_len - 1] == CIRCE_ETX);

        /* Canonical form: never longer than what came in (no skipped parameters, no leading
         * zeros, no checksum). */
        n0 = check_encoding(&r->msg, 0, plain);
        CHECK(n0 > 0);
        CHECK((size_t)n0 <= r->packet_len - (r->has_checksum ? 2 : 0));
        n1 = check_encoding(&r->msg, 1, summed);
        if (n1 == -EMSGSIZE)
                CHECK(n0 + 2 > CIRCE_PACKET_MAX);
        else
                CHECK(n1 == n0 + 2 && memcmp(plain + 1, summed + 1, (size_t)n0 - 2) == 0);
}

static void fuzz_stream(const uint8_t *data, size_t size)
{
        static struct stream whole, chunks;
        static struct circe_result a, b;
        uint64_t results = 0;

        stream_init(&whole, data, size, false);
        stream_init(&chunks, data, size, true);
        for (;;) {
                bool got_a = stream_next(&whole, &a);
                bool got_b = stream_next(&chunks, &b);

                CHECK(got_a == got_b);
                if (!got_a)
                        break;
                CHECK(results_equal(&a, &b));
                check_result(&a);
                results++;
        }
        CHECK(memcmp(&whole.dec.stats, &chunks.dec.stats, sizeof(whole.dec.stats)) == 0);
        CHECK(whole.dec.stats.bytes == size);

        uint64_t counted = whole.dec.stats.messages;
        for (int i = 0; i < CIRCE_REASON_COUNT; i++)
                counted += whole.dec.stats.rejected[i];
        CHECK(counted == results);
}

/* The input as one packet: the standalone parser agrees with the framer on a lone packet. */
static void fuzz_one_packet(const uint8_t *data, size_t size)
{
        static struct circe_result direct, framed;
        static struct circe_decoder dec;
        bool lone = size >= 2 && size <= CIRCE_PACKET_MAX && data[0] == CIRCE_STX &&
                    data[size - 1] == CIRCE_ETX && !memchr(data + 1, CIRCE_STX, size - 2) &&
                    !memchr(data + 1, CIRCE_ETX, size - 2);

        circe_decode(data, size, &direct);
        CHECK(direct.packet == data && direct.packet_len == size);
        if (!lone) {
                CHECK(direct.kind == CIRCE_RESULT_REJECTED);
                CHECK(direct.reason == CIRCE_REASON_BAD_FRAMING ||
                      direct.reason == CIRCE_REASON_OVERLONG);
                return;
        }
        circe_decoder_init(&dec);
        CHECK(circe_decoder_feed(&dec, data, size, &framed) == size);
        CHECK(results_equal(&direct, &framed));
}

/* ---- Encoder fed with arbitrary field values -------------------------------------------------- */

struct reader {
        const uint8_t *p;
        size_t left;
};

static uint32_t get(struct reader *rd, unsigned bytes)
{
        uint32_t v = 0;

        while (bytes--) {
                v <<= 8;
                if (rd->left) {
                        v |= *rd->p++;
                        rd->left--;
                }
        }
        return v;
}

/* Mostly valid addresses, sometimes FFFFFF or wider than 24 bits. */
static uint32_t get_addr(struct reader *rd)
{
        uint8_t sel = (uint8_t)get(rd, 1);

        if (sel < 8)
                return CIRCE_ADDRESS_RESERVED;
        if (sel < 12)
                return get(rd, 4);
        return get(rd, 3);
}

static bool get_bool(struct reader *rd)
{
        return get(rd, 1) & 1;
}

static void fill_visualize(struct reader *rd, struct circe_visualize *v)
{
        uint32_t flags = get(rd, 2);

        v->dest_count = (uint16_t)(get(rd, 1) % (CIRCE_VISUALIZE_DEST_MAX + 2));
        for (size_t i = 0; i < v->dest_count && i < CIRCE_VISUALIZE_DEST_MAX; i++)
                v->dests[i] = get_addr(rd);
        v->has_eliminated = flags & 1;
        v->eliminated = flags & 2;
        v->has_current = flags & 4;
        v->current = (uint16_t)(get(rd, 2) % 1100);
        v->has_next = flags & 8;
        v->next = (uint16_t)(get(rd, 2) % 1100);
        v->start_timer = flags & 16;
        v->has_primary = flags & 32;
        v->primary_ms = get(rd, 3) % 1100000;
        v->has_secondary = flags & 64;
        v->secondary_ms = get(rd, 3) % 1100000;
        v->has_faults = flags & 128;
        v->faults = (uint8_t)get(rd, 1);
        v->has_refusals = flags & 256;
        v->refusals = (uint8_t)get(rd, 1);
        v->has_placement = flags & 512;
        v->placement = (uint16_t)(get(rd, 2) % 1100);
}

static void fill_msg(struct reader *rd, struct circe_msg *m)
{
        static const uint8_t codes[] = { 1, 2, 3, 4, 5, 6, 7, 51, 52, 53, 54, 0, 8, 99 };
        uint32_t flags;

        memset(m, 0, sizeof(*m));
        m->op = (enum circe_op)codes[get(rd, 1) % sizeof(codes)];
        switch (m->op) {
        case CIRCE_OP_ALERT:
                m->u.alert.dest = get_addr(rd);
                break;
        case CIRCE_OP_NETWORK_SETUP:
                m->u.network_setup.dest = get_addr(rd);
                m->u.network_setup.set_membership = get_bool(rd);
                m->u.network_setup.roles = (uint8_t)get(rd, 1);
                break;
        case CIRCE_OP_DEVICE_SETUP:
                flags = get(rd, 1);
                m->u.device_setup.has_dest = flags & 1;
                m->u.device_setup.dest = get_addr(rd);
                m->u.device_setup.assign = get_addr(rd);
                m->u.device_setup.has_capabilities = flags & 2;
                m->u.device_setup.capabilities = (uint8_t)get(rd, 1);
                break;
        case CIRCE_OP_VISUALIZE:
                fill_visualize(rd, &m->u.visualize);
                break;
        case CIRCE_OP_KEEP_ALIVE:
                m->u.keep_alive.version.major = (uint16_t)(get(rd, 2) % 1100);
                m->u.keep_alive.version.minor = (uint16_t)(get(rd, 2) % 1100);
                m->u.keep_alive.version.patch = (uint16_t)(get(rd, 2) % 1100);
                m->u.keep_alive.status = (uint16_t)(get(rd, 2) % 1100);
                break;
        case CIRCE_OP_NOTIFY_STATUS: {
                struct circe_notify_status *s = &m->u.notify_status;
                flags = get(rd, 1);
                s->origin = get_addr(rd);
                s->membership = flags & 1;
                s->capabilities = (uint8_t)get(rd, 1);
                s->roles = (uint8_t)get(rd, 1);
                s->signal = (uint8_t)get(rd, 1);
                s->has_battery = flags & 2;
                s->battery = (uint8_t)get(rd, 1);
                s->has_aligned = flags & 4;
                s->aligned = flags & 8;
                s->has_clock_sync = flags & 16;
                s->clock_sync = (uint8_t)(get(rd, 1) % 4);
                s->has_version_mismatch = flags & 32;
                s->version_mismatch = flags & 64;
                break;
        }
        case CIRCE_OP_NOTIFY_ACTION:
                flags = get(rd, 1);
                m->u.notify_action.origin = get_addr(rd);
                m->u.notify_action.has_keys = flags & 1;
                m->u.notify_action.keys = (uint16_t)get(rd, 2);
                m->u.notify_action.has_sensor_time = flags & 2;
                m->u.notify_action.sensor_time_ms = get(rd, 3) % 1100000;
                break;
        case CIRCE_OP_LOG:
                m->u.log.len = (uint16_t)(get(rd, 2) % (CIRCE_LOG_MAX + 2));
                for (size_t i = 0; i < m->u.log.len && i < CIRCE_LOG_MAX; i++)
                        m->u.log.data[i] = (uint8_t)get(rd, 1);
                break;
        default:
                break;
        }
}

static void fuzz_encoder(const uint8_t *data, size_t size)
{
        static struct circe_msg m;
        static char plain[CIRCE_PACKET_MAX], summed[CIRCE_PACKET_MAX];
        struct reader rd = { data, size };
        int n0, n1;

        fill_msg(&rd, &m);
        n0 = check_encoding(&m, 0, plain);
        n1 = check_encoding(&m, 1, summed);
        CHECK(n0 == -EINVAL || n0 == -EMSGSIZE || n0 > 0);
        if (n0 == -EINVAL)
                CHECK(n1 == -EINVAL);
        else if (n0 == -EMSGSIZE)
                CHECK(n1 == -EMSGSIZE);
        else
                CHECK(n1 == n0 + 2 || (n1 == -EMSGSIZE && n0 + 2 > CIRCE_PACKET_MAX));
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        fuzz_stream(data, size);
        fuzz_one_packet(data, size);
        fuzz_encoder(data, size);
        return 0;
}
