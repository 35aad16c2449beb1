/*
 * Codec benchmark: decode and encode throughput of the wire codecs, one core.
 *
 * Each row of `cases` is a codec case: a workload builder (the traffic, as the codec's own
 * messages, and the same traffic as wire bytes), a decode function (decodes the wire bytes once,
 * returns the frames decoded) and an encode function (encodes the messages once, returns the
 * bytes written). To benchmark another codec (CIRCE), write those three functions and add rows.
 *
 * Every figure is the median of BENCH_RUNS runs; one run repeats the operation for at least
 * BENCH_RUN_NS. Decoding is fed in BENCH_READ_CHUNK pieces, the size of one read() from a tty.
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

#include "proto/sharedlink.h"

#define BENCH_RUNS              7
#define BENCH_RUN_NS            30000000ull     /* 30 ms per run */
#define BENCH_WIRE_TARGET       (1u << 20)      /* about 1 MiB of traffic per case */
#define BENCH_READ_CHUNK        4096
#define NS_PER_S                1000000000.0

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
};

struct codec_case {
        const char *codec;
        const char *name;
        unsigned variant;                                       /* passed to build */
        /* Fills every member of @w (wire bytes included, sized for encode's output). */
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

static uint32_t rng_state = 2463534242u;

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
        struct sl_list list;    /* SLB_LIST */
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
                m->list = (struct sl_list){
                        .dst = 'A', .src = 'B', .values = values + nv, .changed = changed + nv,
                        .count = count, .max_frame = SL_FRAME_DEFAULT, .crlf = m->crlf,
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
                unsigned flags = m->crlf ? SL_ENCODE_CRLF : 0;
                size_t cursor = 0;
                int r = 0;

                switch (m->kind) {
                case SLB_LIST:
                        while ((r = sl_encode_list(&m->list, &cursor, out + len, cap - len)) > 0)
                                len += (size_t)r;
                        break;
                case SLB_QUERY_MSG:
                        r = sl_encode_query(out + len, cap - len, 'A', 'B', m->name, flags);
                        len += r > 0 ? (size_t)r : 0;
                        break;
                case SLB_ANSWER_MSG:
                        r = sl_encode_answer(out + len, cap - len, 'B', 'A', m->name, m->value,
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
        static struct sl_decoder d;
        const uint8_t *p = (const uint8_t *)w->wire;
        size_t left = w->wire_len, frames = 0, fields = 0;

        sl_decoder_init(&d, SL_FRAME_DEFAULT);
        while (left > 0) {
                size_t chunk = left < BENCH_READ_CHUNK ? left : BENCH_READ_CHUNK;

                left -= chunk;
                while (chunk > 0) {
                        struct sl_decode_result r;
                        size_t used = sl_decoder_feed(&d, p, chunk, &r);

                        p += used;
                        chunk -= used;
                        if (r.kind == SL_RESULT_FRAME) {
                                frames++;
                                fields += r.frame->nfields;
                        }
                }
        }
        bench_sink += fields;
        return frames;
}

/* ---------------------------------------------------------------------------------------------
 * The table */

static const struct codec_case cases[] = {
        { "sharedlink", "data, 4 doubles", SLB_DATA4, slb_build, slb_decode, slb_encode },
        { "sharedlink", "data, 40 doubles", SLB_DATA40, slb_build, slb_decode, slb_encode },
        { "sharedlink", "compressed, 40 positions", SLB_COMPRESSED, slb_build, slb_decode,
          slb_encode },
        { "sharedlink", "queries and answers", SLB_QUERY, slb_build, slb_decode, slb_encode },
        { "sharedlink", "mix + CR LF + noise", SLB_MIX, slb_build, slb_decode, slb_encode },
};

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

int main(int argc, char **argv)
{
        size_t ncases = sizeof(cases) / sizeof(cases[0]);
        const char *only = argc > 1 ? argv[1] : NULL;

        printf("codec benchmark: one core, median of %d runs of >= %llu ms, reads of %d bytes\n",
               BENCH_RUNS, (unsigned long long)(BENCH_RUN_NS / 1000000), BENCH_READ_CHUNK);
        printf("%-11s %-26s %7s %7s %12s %9s %12s %9s\n", "codec", "case", "frames", "B/frame",
               "decode MB/s", "ns/frame", "encode MB/s", "ns/frame");
        for (size_t i = 0; i < ncases; i++) {
                const struct codec_case *c = &cases[i];
                struct workload w = { 0 };
                size_t cap, frames;
                char *out;
                double dec_s, enc_s;

                if (only && !strstr(c->name, only) && !strstr(c->codec, only))
                        continue;

                c->build(&w, c->variant);
                cap = w.wire_cap;
                out = xcalloc(cap, 1);
                frames = c->decode(&w);
                if (frames != w.frames || w.frames == 0) {
                        fprintf(stderr, "bench_codec: %s: decoded %zu frames of %zu\n", c->name,
                                frames, w.frames);
                        return 1;
                }
                dec_s = time_op(c, &w, true, out, cap);
                enc_s = time_op(c, &w, false, out, cap);
                printf("%-11s %-26s %7zu %7.1f %12.0f %9.1f %12.0f %9.1f\n", c->codec, c->name,
                       w.frames, (double)w.wire_len / (double)w.frames,
                       (double)w.wire_len / dec_s / 1e6, dec_s * NS_PER_S / (double)w.frames,
                       (double)w.wire_len / enc_s / 1e6, enc_s * NS_PER_S / (double)w.frames);
                free(out);
                for (size_t k = 0; k < WORKLOAD_OWNED_MAX; k++)
                        free(w.owned[k]);
        }
        return 0;
}
