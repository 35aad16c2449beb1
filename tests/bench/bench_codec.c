/*
 * Codec benchmark: decode and encode throughput of the wire codecs (SharedLink and CIRCE), one
 * core, in MB/s of wire bytes and ns per frame.
 *
 * Each row of `cases` is a codec case: a workload builder (the traffic, as the codec's own
 * messages, and the same traffic as wire bytes), a decode function (decodes the wire bytes once,
 * returns the frames decoded) and an encode function (encodes the messages once, returns the
 * bytes written; NULL for a decode-only row). To benchmark another codec, write those three
 * functions and add rows.
 *
 * Every figure is the median of BENCH_RUNS runs; one run repeats the operation for at least
 * BENCH_RUN_NS. Decoding is fed in BENCH_READ_CHUNK pieces, the size of one read() from a tty,
 * unless the case asks for smaller reads (at line rate, one read() often returns only a few
 * dozen bytes). Every workload is about BENCH_WIRE_TARGET bytes of traffic, so that the
 * codecs are compared on the same amount of memory. After the table, one line per codec gives
 * its decode throughput on the mixes as a multiple of what a 921600-baud 8N1 line can carry.
 * Built optimised without sanitizers by `make bench`. Usage: bench_codec [SUBSTRING] runs only the
 * cases whose codec or name contains SUBSTRING.
 *
 * Times are CPU time of this thread (CLOCK_THREAD_CPUTIME_ID), so that other work on a shared
 * machine does not count; a busy sibling hyperthread still slows it down.
 */
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "proto/circe.h"
#include "proto/sharedlink.h"

#define BENCH_RUNS              7
#define BENCH_RUN_NS            30000000ull     /* 30 ms per run */
#define BENCH_WIRE_TARGET       (1u << 20)      /* about 1 MiB of traffic per case */
#define BENCH_READ_CHUNK        4096
#define NS_PER_S                1000000000.0
#define BENCH_SEED              2463534242u     /* xorshift state; build starts at SEED + variant */

/* The fastest line sharedlinkd drives: 921600 baud, 8N1 = 10 bits on the wire per byte. CIRCE
 * itself is specified at 115200 baud, so for it this bar is 8 times higher than needed. */
#define LINE_BAUD               921600
#define LINE_BITS_PER_BYTE      10

#define WORKLOAD_OWNED_MAX      4

/* Traffic of one case: the codec's messages (opaque here) and the same traffic on the wire. */
struct workload {
        char *wire;
        size_t wire_len;
        size_t wire_cap;
        size_t frames;          /* frames in wire */
        void *msgs;             /* codec-specific */
        size_t nmsgs;
        void *owned[WORKLOAD_OWNED_MAX];        /* freed by the driver */
        size_t read_size;       /* bytes per decoder feed; set by the driver, not by build */
};

struct codec_case {
        const char *codec;
        const char *name;
        unsigned variant;                       /* passed to build */
        size_t read_size;                       /* bytes per read; 0 means BENCH_READ_CHUNK */
        bool line_rate;                         /* a mix: compared with the line rate */
        /* Fills every member of @w but read_size; wire is sized for encode's output. */
        void (*build)(struct workload *w, unsigned variant);
        size_t (*decode)(const struct workload *w);             /* returns frames decoded */
        size_t (*encode)(const struct workload *w, char *out, size_t cap);  /* returns bytes */
};

static volatile size_t bench_sink;     /* keeps results alive */

static void *xcalloc(size_t n, size_t size)
{
        void *p = calloc(n, size);

        if (!p) {
                fprintf(stderr, "bench_codec: out of memory\n");
                exit(1);
        }
        return p;
}

static uint64_t now_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
        return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

static uint32_t rng_state = BENCH_SEED;

static uint32_t rng(void)
{
        rng_state ^= rng_state << 13;
        rng_state ^= rng_state >> 17;
        rng_state ^= rng_state << 5;
        return rng_state;
}

/* ---------------------------------------------------------------------------------------------
 * SharedLink cases */

enum sl_variant {
        SLB_DATA4,              /* N0 + 4 doubles (a GPS fix) */
        SLB_DATA40,             /* N0 + 40 doubles */
        SLB_COMPRESSED,         /* 40 positions, about 1 in 5 changed, the rest empty D */
        SLB_QUERY,              /* queries and answers */
        SLB_MIX,                /* 4-40 doubles, compressed, queries/answers, CR LF, some noise */
};

enum slb_kind { SLB_LIST, SLB_QUERY_MSG, SLB_ANSWER_MSG, SLB_NOISE };

struct slb_msg {
        enum slb_kind kind;
        struct slp_list list;   /* SLB_LIST */
        const char *name;       /* SLB_QUERY_MSG, SLB_ANSWER_MSG */
        const char *value;      /* SLB_ANSWER_MSG */
        bool crlf;
};

#define SLB_POOL        4096
#define SLB_MSGS_MAX    40000
#define SLB_VALUES_MAX  (SLB_MSGS_MAX * 40)

static char slb_pool[SLB_POOL][24];
static const char *slb_names[] = {
        "AutoGpsLat", "AutoGpsLon", "AutoGpsHead", "AutoGpsVel", "CmdThrottle", "CmdSteer",
        "veh_gear", "sys_thd",
};
static const char slb_noise[] = "\x00\xff garbage ";

static size_t slb_encode(const struct workload *w, char *out, size_t cap);

static void slb_make_pool(void)
{
        for (size_t i = 0; i < SLB_POOL; i++)
                snprintf(slb_pool[i], sizeof(slb_pool[i]), "%.8f",
                         ((double)(int32_t)rng() / 2147483648.0) * 180.0);
}

static void slb_build(struct workload *w, unsigned variant)
{
        struct slb_msg *msgs = xcalloc(SLB_MSGS_MAX, sizeof(*msgs));
        const char **values = xcalloc(SLB_VALUES_MAX, sizeof(*values));
        bool *changed = xcalloc(SLB_VALUES_MAX, sizeof(*changed));
        size_t nv = 0, n = 0, est = 0;

        slb_make_pool();
        while (est < BENCH_WIRE_TARGET && n < SLB_MSGS_MAX) {
                struct slb_msg *m = &msgs[n++];
                unsigned pick = variant == SLB_MIX ? rng() % 10 : 0;
                size_t count;

                m->crlf = variant != SLB_QUERY || n % 2;
                if (variant == SLB_QUERY || (variant == SLB_MIX && pick == 8)) {
                        m->kind = n % 2 ? SLB_QUERY_MSG : SLB_ANSWER_MSG;
                        m->name = slb_names[rng() % (sizeof(slb_names) / sizeof(slb_names[0]))];
                        m->value = slb_pool[rng() % SLB_POOL];
                        est += 40;
                        continue;
                }
                if (variant == SLB_MIX && pick == 9) {
                        m->kind = SLB_NOISE;
                        est += sizeof(slb_noise) - 1;
                        continue;
                }
                count = variant == SLB_DATA4 ? 4 : variant == SLB_MIX ? 4 + rng() % 37 : 40;
                m->kind = SLB_LIST;
                m->list = (struct slp_list){
                        .dst = 'A', .src = 'B', .values = values + nv, .changed = changed + nv,
                        .count = count, .max_frame = SLP_FRAME_DEFAULT, .crlf = m->crlf,
                        .compress = variant == SLB_COMPRESSED || (variant == SLB_MIX && pick < 3),
                };
                for (size_t i = 0; i < count; i++) {
                        values[nv + i] = slb_pool[rng() % SLB_POOL];
                        changed[nv + i] = rng() % 5 == 0;
                        est += m->list.compress && !changed[nv + i] ? 2 : 2 + strlen(values[nv + i]);
                }
                nv += count;
                est += 20;
        }
        w->msgs = msgs;
        w->nmsgs = n;
        w->owned[0] = msgs;
        w->owned[1] = values;
        w->owned[2] = changed;
        w->wire_cap = 4 * BENCH_WIRE_TARGET;
        w->wire = xcalloc(w->wire_cap, 1);
        w->owned[3] = w->wire;
        w->wire_len = slb_encode(w, w->wire, w->wire_cap);
        /* Counted independently of the decoder: noise never holds a '['. */
        for (size_t i = 0; i < w->wire_len; i++)
                w->frames += w->wire[i] == '[';
}

static size_t slb_encode(const struct workload *w, char *out, size_t cap)
{
        const struct slb_msg *msgs = w->msgs;
        size_t len = 0;

        for (size_t i = 0; i < w->nmsgs; i++) {
                const struct slb_msg *m = &msgs[i];
                unsigned flags = m->crlf ? SLP_ENCODE_CRLF : 0;
                size_t cursor = 0;
                int r = 0;

                switch (m->kind) {
                case SLB_LIST:
                        while ((r = slp_encode_list(&m->list, &cursor, out + len, cap - len)) > 0)
                                len += (size_t)r;
                        break;
                case SLB_QUERY_MSG:
                        r = slp_encode_query(out + len, cap - len, 'A', 'B', m->name, flags);
                        len += r > 0 ? (size_t)r : 0;
                        break;
                case SLB_ANSWER_MSG:
                        r = slp_encode_answer(out + len, cap - len, 'B', 'A', m->name, m->value,
                                              flags);
                        len += r > 0 ? (size_t)r : 0;
                        break;
                case SLB_NOISE:
                        if (cap - len < sizeof(slb_noise) - 1) {
                                r = -1;
                                break;
                        }
                        memcpy(out + len, slb_noise, sizeof(slb_noise) - 1);
                        len += sizeof(slb_noise) - 1;
                        break;
                }
                if (r < 0) {
                        fprintf(stderr, "bench_codec: encode failed (%d)\n", r);
                        exit(1);
                }
        }
        return len;
}

static size_t slb_decode(const struct workload *w)
{
        static struct slp_decoder d;
        const uint8_t *p = (const uint8_t *)w->wire;
        size_t left = w->wire_len, frames = 0, fields = 0;

        slp_decoder_init(&d, SLP_FRAME_DEFAULT);
        while (left > 0) {
                size_t chunk = left < w->read_size ? left : w->read_size;

                left -= chunk;
                while (chunk > 0) {
                        struct slp_decode_result r;
                        size_t used = slp_decoder_feed(&d, p, chunk, &r);

                        p += used;
                        chunk -= used;
                        if (r.kind == SLP_RESULT_FRAME) {
                                frames++;
                                fields += r.frame->nfields;
                        }
                }
        }
        bench_sink += fields;
        return frames;
}

/* ---------------------------------------------------------------------------------------------
 * CIRCE cases
 *
 * The traffic a controller sees: Notify Status, Notify Action and Keep Alive from the mediator,
 * plus the controller's own Visualize; every packet with a checksum (what we send). The mix, by
 * packet count, is what a mediator with a dozen devices sends: 60% Notify Status, 25% Notify
 * Action, 5% Keep Alive, 10% Visualize.
 */

enum cb_variant {
        CB_MIX,
        CB_STATUS,
        CB_ACTION,
        CB_KEEPALIVE,
        CB_VISUALIZE,
};

#define CB_MIX_STATUS_PCT       60
#define CB_MIX_ACTION_PCT       25
#define CB_MIX_KEEPALIVE_PCT    5               /* the rest (10%) is Visualize */
#define CB_PACKET_MIN           16              /* below every packet built here (Keep Alive: 23 bytes) */
#define CB_MSGS_MAX             (BENCH_WIRE_TARGET / CB_PACKET_MIN + 1)
#define CB_SENSOR_TIME_MAX      1000000u        /* 025 and 031 are 0-999999 ms */
#define CB_COMPETITOR_MAX       1000u           /* 028 and 029 are 0-999 */
#define CB_FAULTS_MAX           10u
#define CB_REFUSALS_MAX         3u
#define CB_KEYS                 16              /* bits in 024 */

static const uint32_t cb_devices[] = {
        0xE1E1E1, 0xE2E2E2, 0xAAAAAA, 0xD15D15, 0x123456, 0xABCDEF, 0x0A0B0C, 0x424242,
};

/* The operation of the next packet of a workload. */
static enum circe_op cb_pick(enum cb_variant variant)
{
        unsigned pct;

        switch (variant) {
        case CB_STATUS:
                return CIRCE_OP_NOTIFY_STATUS;
        case CB_ACTION:
                return CIRCE_OP_NOTIFY_ACTION;
        case CB_KEEPALIVE:
                return CIRCE_OP_KEEP_ALIVE;
        case CB_VISUALIZE:
                return CIRCE_OP_VISUALIZE;
        case CB_MIX:
                break;
        }
        pct = rng() % 100;
        if (pct < CB_MIX_STATUS_PCT)
                return CIRCE_OP_NOTIFY_STATUS;
        if (pct < CB_MIX_STATUS_PCT + CB_MIX_ACTION_PCT)
                return CIRCE_OP_NOTIFY_ACTION;
        if (pct < CB_MIX_STATUS_PCT + CB_MIX_ACTION_PCT + CB_MIX_KEEPALIVE_PCT)
                return CIRCE_OP_KEEP_ALIVE;
        return CIRCE_OP_VISUALIZE;
}

static void cb_make_msg(enum cb_variant variant, struct circe_msg *m)
{
        uint32_t r = rng();
        uint32_t dev = cb_devices[r % (sizeof(cb_devices) / sizeof(cb_devices[0]))];

        memset(m, 0, sizeof(*m));
        m->op = cb_pick(variant);
        switch (m->op) {
        case CIRCE_OP_NOTIFY_STATUS:
                m->u.notify_status = (struct circe_notify_status){
                        .origin = dev, .membership = true, .capabilities = CIRCE_CAP_TIME_SENSOR,
                        .roles = CIRCE_ROLE_FINISH_TIMER, .signal = (uint8_t)(r >> 8),
                        .has_battery = true, .battery = (uint8_t)(r >> 16),
                        .has_aligned = true, .aligned = r & 1,
                        .has_clock_sync = (r & 6) == 0, .clock_sync = CIRCE_CLOCK_SYNC_SUCCEEDED,
                };
                break;
        case CIRCE_OP_NOTIFY_ACTION:
                m->u.notify_action.origin = dev;
                if (r & 1) {
                        m->u.notify_action.has_sensor_time = true;
                        m->u.notify_action.sensor_time_ms = (r >> 4) % CB_SENSOR_TIME_MAX;
                } else {
                        m->u.notify_action.has_keys = true;
                        m->u.notify_action.keys = (uint16_t)(1u << ((r >> 4) % CB_KEYS));
                }
                break;
        case CIRCE_OP_KEEP_ALIVE:
                m->u.keep_alive.version = (struct circe_version){ 0, 2, 3 };
                break;
        default:        /* CIRCE_OP_VISUALIZE, the only other one cb_pick() returns */
                m->u.visualize = (struct circe_visualize){
                        .dest_count = 2, .dests = { 0xD15D15, 0xD25D25 },
                        .has_current = true, .current = (uint16_t)(r % CB_COMPETITOR_MAX),
                        .has_next = true, .next = (uint16_t)((r + 1) % CB_COMPETITOR_MAX),
                        .has_primary = true, .primary_ms = (r >> 8) % CB_SENSOR_TIME_MAX,
                        .has_faults = true, .faults = (uint8_t)(r % CB_FAULTS_MAX),
                        .has_refusals = true, .refusals = (uint8_t)(r % CB_REFUSALS_MAX),
                };
                break;
        }
}

static size_t cb_encode(const struct workload *w, char *out, size_t cap)
{
        const struct circe_msg *msgs = w->msgs;
        size_t len = 0;

        for (size_t i = 0; i < w->nmsgs; i++) {
                int r = circe_encode(&msgs[i], 1, out + len, cap - len);

                if (r < 0) {
                        fprintf(stderr, "bench_codec: circe encode failed (%d)\n", r);
                        exit(1);
                }
                len += (size_t)r;
        }
        return len;
}

static void cb_build(struct workload *w, unsigned variant)
{
        struct circe_msg *msgs = xcalloc(CB_MSGS_MAX, sizeof(*msgs));
        char scratch[CIRCE_PACKET_MAX];
        size_t n = 0, est = 0;

        while (est < BENCH_WIRE_TARGET && n < CB_MSGS_MAX) {
                int r;

                cb_make_msg((enum cb_variant)variant, &msgs[n]);
                r = circe_encode(&msgs[n], 1, scratch, sizeof(scratch));
                if (r < 0) {
                        fprintf(stderr, "bench_codec: circe encode failed (%d)\n", r);
                        exit(1);
                }
                est += (size_t)r;
                n++;
        }
        w->msgs = msgs;
        w->nmsgs = n;
        w->owned[0] = msgs;
        w->wire_cap = 2 * BENCH_WIRE_TARGET;
        w->wire = xcalloc(w->wire_cap, 1);
        w->owned[1] = w->wire;
        w->wire_len = cb_encode(w, w->wire, w->wire_cap);
        /* Counted independently of the decoder: values never hold an STX. */
        for (size_t i = 0; i < w->wire_len; i++)
                w->frames += w->wire[i] == CIRCE_STX;
}

static size_t cb_decode(const struct workload *w)
{
        static struct circe_decoder d;
        const uint8_t *p = (const uint8_t *)w->wire;
        size_t left = w->wire_len, frames = 0, ops = 0;

        circe_decoder_init(&d);
        while (left > 0) {
                size_t chunk = left < w->read_size ? left : w->read_size;

                left -= chunk;
                while (chunk > 0) {
                        struct circe_result r;
                        size_t used = circe_decoder_feed(&d, p, chunk, &r);

                        p += used;
                        chunk -= used;
                        if (r.kind == CIRCE_RESULT_MESSAGE) {
                                frames++;
                                ops += (size_t)r.msg.op;
                        }
                }
        }
        bench_sink += ops;
        return frames;
}

/* Baseline for cb_decode(): only find where each packet starts and ends (memchr for STX, ETX). */
static size_t cb_scan(const struct workload *w)
{
        const char *p = w->wire, *end = w->wire + w->wire_len;
        size_t frames = 0, bytes = 0;

        while (p < end) {
                const char *s = memchr(p, CIRCE_STX, (size_t)(end - p));
                const char *e;

                if (!s)
                        break;
                e = memchr(s, CIRCE_ETX, (size_t)(end - s));
                if (!e)
                        break;
                frames++;
                bytes += (size_t)(e - s);
                p = e + 1;
        }
        bench_sink += bytes;
        return frames;
}

/* ---------------------------------------------------------------------------------------------
 * The table */

#define READS_SMALL     64      /* bytes per read of the "64-byte reads" rows */

static const struct codec_case cases[] = {
        { "sharedlink", "data, 4 doubles", SLB_DATA4, 0, false, slb_build, slb_decode,
          slb_encode },
        { "sharedlink", "data, 40 doubles", SLB_DATA40, 0, false, slb_build, slb_decode,
          slb_encode },
        { "sharedlink", "compressed, 40 positions", SLB_COMPRESSED, 0, false, slb_build,
          slb_decode, slb_encode },
        { "sharedlink", "queries and answers", SLB_QUERY, 0, false, slb_build, slb_decode,
          slb_encode },
        { "sharedlink", "mix + CR LF + noise", SLB_MIX, 0, true, slb_build, slb_decode,
          slb_encode },
        { "sharedlink", "mix, 64-byte reads", SLB_MIX, READS_SMALL, true, slb_build, slb_decode,
          slb_encode },
        { "circe", "notify status", CB_STATUS, 0, false, cb_build, cb_decode, cb_encode },
        { "circe", "notify action", CB_ACTION, 0, false, cb_build, cb_decode, cb_encode },
        { "circe", "keep alive", CB_KEEPALIVE, 0, false, cb_build, cb_decode, cb_encode },
        { "circe", "visualize", CB_VISUALIZE, 0, false, cb_build, cb_decode, cb_encode },
        { "circe", "mix 60/25/5/10 %", CB_MIX, 0, true, cb_build, cb_decode, cb_encode },
        { "circe", "mix, 64-byte reads", CB_MIX, READS_SMALL, true, cb_build, cb_decode,
          cb_encode },
        /* The mix's decode time minus this row's is what parsing adds to finding the packets. */
        { "circe", "mix, framing scan only", CB_MIX, 0, false, cb_build, cb_scan, NULL },
};

#define CASES_COUNT     (sizeof(cases) / sizeof(cases[0]))

/* ---------------------------------------------------------------------------------------------
 * Driver */

static int cmp_double(const void *a, const void *b)
{
        double x = *(const double *)a, y = *(const double *)b;

        return (x > y) - (x < y);
}

/* Median over BENCH_RUNS runs of the seconds one call takes. */
static double time_op(const struct codec_case *c, const struct workload *w, bool decode,
                      char *out, size_t cap)
{
        double samples[BENCH_RUNS];

        for (int run = 0; run < BENCH_RUNS; run++) {
                uint64_t t0 = now_ns(), t1;
                size_t reps = 0;

                do {
                        bench_sink += decode ? c->decode(w) : c->encode(w, out, cap);
                        reps++;
                        t1 = now_ns();
                } while (t1 - t0 < BENCH_RUN_NS);
                samples[run] = (double)(t1 - t0) / NS_PER_S / (double)reps;
        }
        qsort(samples, BENCH_RUNS, sizeof(samples[0]), cmp_double);
        return samples[BENCH_RUNS / 2];
}

/* Builds, checks and times one case, prints its row; returns decode MB/s, or -1 on failure. */
static double run_case(size_t index)
{
        const struct codec_case *c = &cases[index];
        struct workload w = { 0 };
        size_t frames;
        char *out;
        double dec_s, dec_mbs = -1, enc_s;

        /* Rows of one variant (a mix and its 64-byte reads) see the same traffic, whatever else
         * runs. */
        rng_state = BENCH_SEED + c->variant;
        c->build(&w, c->variant);
        w.read_size = c->read_size ? c->read_size : BENCH_READ_CHUNK;
        out = xcalloc(w.wire_cap, 1);
        frames = c->decode(&w);
        if (frames != w.frames || w.frames == 0) {
                fprintf(stderr, "bench_codec: %s %s: decoded %zu frames of %zu\n", c->codec,
                        c->name, frames, w.frames);
                goto out;
        }
        if (c->encode && (c->encode(&w, out, w.wire_cap) != w.wire_len ||
                          memcmp(out, w.wire, w.wire_len) != 0)) {
                fprintf(stderr, "bench_codec: %s %s: encode differs from the workload\n",
                        c->codec, c->name);
                goto out;
        }
        dec_s = time_op(c, &w, true, out, w.wire_cap);
        dec_mbs = (double)w.wire_len / dec_s / 1e6;
        printf("%-11s %-26s %7zu %7.1f %12.0f %9.1f", c->codec, c->name, w.frames,
               (double)w.wire_len / (double)w.frames, dec_mbs,
               dec_s * NS_PER_S / (double)w.frames);
        if (c->encode) {
                enc_s = time_op(c, &w, false, out, w.wire_cap);
                printf(" %12.0f %9.1f\n", (double)w.wire_len / enc_s / 1e6,
                       enc_s * NS_PER_S / (double)w.frames);
        } else {
                printf(" %12s %9s\n", "-", "-");
        }
out:
        free(out);
        for (size_t k = 0; k < WORKLOAD_OWNED_MAX; k++)
                free(w.owned[k]);
        return dec_mbs;
}

/* One line per codec: decode MB/s of each mix that ran, as a multiple of the line rate. */
static void print_line_rate(const double dec_mbs[CASES_COUNT])
{
        double line_mbs = (double)LINE_BAUD / LINE_BITS_PER_BYTE / 1e6;

        for (size_t i = 0; i < CASES_COUNT; i++) {
                bool seen = false, any = false;

                for (size_t j = 0; j < i && !seen; j++)
                        seen = strcmp(cases[j].codec, cases[i].codec) == 0;
                if (seen)
                        continue;
                for (size_t j = i; j < CASES_COUNT; j++) {
                        if (strcmp(cases[j].codec, cases[i].codec) != 0 || !cases[j].line_rate ||
                            dec_mbs[j] <= 0)
                                continue;
                        if (!any)
                                printf("%-11s decode / %d-baud line rate (%.3f MB/s):",
                                       cases[i].codec, LINE_BAUD, line_mbs);
                        printf("%s %.0fx (%s)", any ? "," : "", dec_mbs[j] / line_mbs,
                               cases[j].name);
                        any = true;
                }
                if (any)
                        printf("\n");
        }
}

static bool case_selected(size_t index, const char *only)
{
        return !only || strstr(cases[index].name, only) || strstr(cases[index].codec, only);
}

int main(int argc, char **argv)
{
        const char *only = argc > 1 ? argv[1] : NULL;
        double dec_mbs[CASES_COUNT] = { 0 };   /* 0: the case did not run */
        size_t selected = 0;

        for (size_t i = 0; i < CASES_COUNT; i++)
                selected += case_selected(i, only);
        if (selected == 0) {
                fprintf(stderr, "bench_codec: no case matches '%s'\n", only);
                return 1;
        }
        printf("codec benchmark: one core, median of %d runs of >= %llu ms, about %u KiB of "
               "traffic per case, reads of %d bytes unless the case says otherwise\n",
               BENCH_RUNS, (unsigned long long)(BENCH_RUN_NS / 1000000), BENCH_WIRE_TARGET / 1024,
               BENCH_READ_CHUNK);
        printf("%-11s %-26s %7s %7s %12s %9s %12s %9s\n", "codec", "case", "frames", "B/frame",
               "decode MB/s", "ns/frame", "encode MB/s", "ns/frame");
        for (size_t i = 0; i < CASES_COUNT; i++) {
                if (!case_selected(i, only))
                        continue;
                dec_mbs[i] = run_case(i);
                if (dec_mbs[i] < 0)
                        return 1;
        }
        print_line_rate(dec_mbs);
        /* For tests/bench/summary.sh: the slowest decode of each codec. */
        for (size_t i = 0; i < CASES_COUNT; i++) {
                double slowest = 0;
                bool seen = false;

                for (size_t j = 0; j < i && !seen; j++)
                        seen = strcmp(cases[j].codec, cases[i].codec) == 0;
                for (size_t j = i; j < CASES_COUNT && !seen; j++)
                        if (strcmp(cases[j].codec, cases[i].codec) == 0 && dec_mbs[j] > 0 &&
                            (slowest == 0 || dec_mbs[j] < slowest))
                                slowest = dec_mbs[j];
                if (!seen && slowest > 0)
                        printf("FIGURE|codec_%s|%s decode, slowest case|%.0f|MB/s|-\n",
                               cases[i].codec, cases[i].codec, slowest);
        }
        return 0;
}
