/*
 * CIRCE codec throughput: decode (framer + parser) and encode on the traffic a controller sees,
 * per packet kind and as a mix, median of 7 runs.  A framing-only scan (find STX, find ETX) over
 * the same bytes is the baseline the decode cost is compared with.
 *
 * Mix (by packet count, what a mediator with a dozen devices sends plus the controller's own
 * traffic): 60% Notify Status, 25% Notify Action, 5% Keep Alive, 10% Visualize; all with checksum.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "proto/circe.h"

#define BENCH_PACKETS 1000              /* packets per workload */
#define BENCH_RUNS 7
#define BENCH_MIN_NS 40000000ull        /* each run repeats its workload for at least 40 ms */
#define BENCH_READ_SIZE 64              /* bytes per feed call, like a serial read */
#define STREAM_MAX (BENCH_PACKETS * CIRCE_PACKET_MAX)

enum kind { K_MIX, K_STATUS, K_ACTION, K_KEEPALIVE, K_VISUALIZE, K_COUNT };

static const char *const kind_names[K_COUNT] = {
        "mix", "notify status", "notify action", "keep alive", "visualize",
};

struct workload {
        struct circe_msg *msgs;
        size_t count;
        uint8_t *stream;
        size_t len;
};

static volatile uint64_t sink;          /* keeps the work from being optimised away */

static uint64_t now_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

static uint32_t rng_next(uint32_t *s)
{
        *s ^= *s << 13;
        *s ^= *s >> 17;
        *s ^= *s << 5;
        return *s;
}

static void make_msg(enum kind k, uint32_t *rng, struct circe_msg *m)
{
        static const uint32_t devices[] = { 0xE1E1E1, 0xE2E2E2, 0xAAAAAA, 0xD15D15, 0x123456,
                                            0xABCDEF, 0x0A0B0C, 0x424242 };
        uint32_t r = rng_next(rng);
        uint32_t dev = devices[r % (sizeof(devices) / sizeof(devices[0]))];

        memset(m, 0, sizeof(*m));
        if (k == K_MIX) {
                unsigned pick = rng_next(rng) % 100;
                k = pick < 60 ? K_STATUS : pick < 85 ? K_ACTION : pick < 90 ? K_KEEPALIVE
                                                                          : K_VISUALIZE;
        }
        switch (k) {
        case K_STATUS:
                m->op = CIRCE_OP_NOTIFY_STATUS;
                m->u.notify_status = (struct circe_notify_status){
                        .origin = dev, .membership = true, .capabilities = CIRCE_CAP_TIME_SENSOR,
                        .roles = CIRCE_ROLE_FINISH_TIMER, .signal = (uint8_t)(r >> 8),
                        .has_battery = true, .battery = (uint8_t)(r >> 16),
                        .has_aligned = true, .aligned = r & 1,
                        .has_clock_sync = (r & 6) == 0, .clock_sync = 2 };
                break;
        case K_ACTION:
                m->op = CIRCE_OP_NOTIFY_ACTION;
                m->u.notify_action.origin = dev;
                if (r & 1) {
                        m->u.notify_action.has_sensor_time = true;
                        m->u.notify_action.sensor_time_ms = (r >> 4) % 1000000;
                } else {
                        m->u.notify_action.has_keys = true;
                        m->u.notify_action.keys = (uint16_t)(1u << ((r >> 4) % 16));
                }
                break;
        case K_KEEPALIVE:
                m->op = CIRCE_OP_KEEP_ALIVE;
                m->u.keep_alive.version = (struct circe_version){ 0, 2, 3 };
                break;
        case K_VISUALIZE:
                m->op = CIRCE_OP_VISUALIZE;
                m->u.visualize = (struct circe_visualize){
                        .dest_count = 2, .dests = { 0xD15D15, 0xD25D25 },
                        .has_current = true, .current = (uint16_t)(r % 1000),
                        .has_next = true, .next = (uint16_t)((r + 1) % 1000),
                        .has_primary = true, .primary_ms = (r >> 8) % 1000000,
                        .has_faults = true, .faults = (uint8_t)(r % 10),
                        .has_refusals = true, .refusals = (uint8_t)(r % 3) };
                break;
        default:
                break;
        }
}

static int workload_init(struct workload *w, enum kind k)
{
        uint32_t rng = 0x2545F491u + (uint32_t)k;

        w->count = BENCH_PACKETS;
        w->msgs = calloc(w->count, sizeof(*w->msgs));
        w->stream = malloc(STREAM_MAX);
        if (!w->msgs || !w->stream)
                return -1;
        w->len = 0;
        for (size_t i = 0; i < w->count; i++) {
                int n;

                make_msg(k, &rng, &w->msgs[i]);
                n = circe_encode(&w->msgs[i], 1, (char *)w->stream + w->len, STREAM_MAX - w->len);
                if (n < 0)
                        return -1;
                w->len += (size_t)n;
        }
        return 0;
}

/* One pass of each measured operation; returns a value that depends on the work done. */
static uint64_t pass_decode(const struct workload *w, size_t read_size)
{
        static struct circe_decoder d;
        static struct circe_result r;
        uint64_t acc = 0;

        circe_decoder_init(&d);
        for (size_t pos = 0; pos < w->len;) {
                size_t chunk = w->len - pos < read_size ? w->len - pos : read_size;
                size_t end = pos + chunk;
                while (pos < end) {
                        pos += circe_decoder_feed(&d, w->stream + pos, end - pos, &r);
                        if (r.kind == CIRCE_RESULT_MESSAGE)
                                acc += (uint64_t)r.msg.op;
                }
        }
        if (d.stats.messages != w->count) {
                fprintf(stderr, "bench: decoded %llu of %zu packets\n",
                        (unsigned long long)d.stats.messages, w->count);
                exit(1);
        }
        return acc;
}

static uint64_t pass_encode(const struct workload *w, size_t read_size)
{
        static char buf[CIRCE_PACKET_MAX];
        uint64_t acc = 0;

        (void)read_size;
        for (size_t i = 0; i < w->count; i++)
                acc += (uint64_t)circe_encode(&w->msgs[i], 1, buf, sizeof(buf)) + (uint8_t)buf[1];
        return acc;
}

/* Baseline: only find where each packet starts and ends. */
static uint64_t pass_scan(const struct workload *w, size_t read_size)
{
        const uint8_t *p = w->stream, *end = w->stream + w->len;
        uint64_t acc = 0;

        (void)read_size;
        while (p < end) {
                const uint8_t *s = memchr(p, CIRCE_STX, (size_t)(end - p));
                const uint8_t *e;
                if (!s)
                        break;
                e = memchr(s, CIRCE_ETX, (size_t)(end - s));
                if (!e)
                        break;
                acc += (uint64_t)(e - s);
                p = e + 1;
        }
        return acc;
}

static int cmp_double(const void *a, const void *b)
{
        double x = *(const double *)a, y = *(const double *)b;

        return (x > y) - (x < y);
}

struct timing {
        double median, min, max;        /* nanoseconds per pass over the workload */
};

/* BENCH_RUNS runs of one pass type; the spread (max / min) shows how noisy the machine was. */
static struct timing measure(uint64_t (*pass)(const struct workload *, size_t),
                             const struct workload *w, size_t read_size)
{
        double per_pass[BENCH_RUNS];
        struct timing t;

        sink += pass(w, read_size);     /* warm up */
        for (int run = 0; run < BENCH_RUNS; run++) {
                uint64_t start = now_ns(), elapsed;
                unsigned passes = 0;
                do {
                        sink += pass(w, read_size);
                        passes++;
                        elapsed = now_ns() - start;
                } while (elapsed < BENCH_MIN_NS);
                per_pass[run] = (double)elapsed / passes;
        }
        qsort(per_pass, BENCH_RUNS, sizeof(per_pass[0]), cmp_double);
        t.median = per_pass[BENCH_RUNS / 2];
        t.min = per_pass[0];
        t.max = per_pass[BENCH_RUNS - 1];
        return t;
}

static void print_row(const char *workload, const char *what, const struct workload *w,
                      struct timing t)
{
        double n = (double)w->count;

        printf("%-14s %-10s %6.1f %9.1f %9.1f %9.1f %7.2f\n", workload, what,
               (double)w->len / n, (double)w->len / 1e6 / (t.median / 1e9), t.median / n,
               t.min / n, t.max / t.min);
}

int main(void)
{
        static struct workload w[K_COUNT];

        printf("CIRCE codec: %d packets per workload, checksum on, %d runs of >= %llu ms\n",
               BENCH_PACKETS, BENCH_RUNS, BENCH_MIN_NS / 1000000ull);
        printf("%-14s %-10s %6s %9s %9s %9s %7s\n", "workload", "operation", "B/pkt",
               "MB/s med", "ns/pkt", "ns/pkt", "spread");
        printf("%-14s %-10s %6s %9s %9s %9s %7s\n", "", "", "", "", "median", "best",
               "max/min");
        for (int k = 0; k < K_COUNT; k++) {
                struct timing dec, dec64, enc, scan;

                if (workload_init(&w[k], (enum kind)k) < 0) {
                        fprintf(stderr, "bench: cannot build workload %s\n", kind_names[k]);
                        return 1;
                }
                dec = measure(pass_decode, &w[k], w[k].len);
                dec64 = measure(pass_decode, &w[k], BENCH_READ_SIZE);
                enc = measure(pass_encode, &w[k], 0);
                scan = measure(pass_scan, &w[k], 0);
                print_row(kind_names[k], "decode", &w[k], dec);
                print_row(kind_names[k], "decode/64", &w[k], dec64);
                print_row(kind_names[k], "encode", &w[k], enc);
                print_row(kind_names[k], "scan", &w[k], scan);
                printf("%-14s %-10s decode / scan = %.1f (median), %.1f (best)\n", "", "ratio",
                       dec.median / scan.median, dec.min / scan.min);
                free(w[k].msgs);
                free(w[k].stream);
        }
        printf("decode: framer + parser, whole buffer per feed loop; decode/64: %d-byte reads; "
               "scan: memchr for STX and ETX only (baseline)\n", BENCH_READ_SIZE);
        return 0;
}
