/*
 * Interleaved latency probes for the benchmarks: each round takes one sample of every probe in
 * turn (so a busy spell of the machine touches all of them alike), gap_us apart, the first
 * `warmup` rounds thrown away; then one table of median, p99 and lost samples in microseconds.
 * Used by bench_mqtt and bench_ros2.
 */
#pragma once

#include <stddef.h>
#include <stdint.h>

#define BENCHLAT_PROBES_MAX     8

/* One sample of probe p carrying value v: its latency in ns, 0 when it never arrived. */
typedef uint64_t (*benchlat_sample_fn)(void *arg, int p, long v);

struct benchlat {
        int probes;                     /* how many (<= BENCHLAT_PROBES_MAX) */
        const char *const *names;       /* their names, for the table */
        size_t samples;                 /* kept per probe */
        size_t warmup;                  /* rounds thrown away first */
        unsigned gap_us;                /* pause after each sample */
        long first_value;               /* v of the first round; each round adds 1 */
        benchlat_sample_fn sample;
        void *arg;
        double median_us[BENCHLAT_PROBES_MAX], p99_us[BENCHLAT_PROBES_MAX];  /* results */
        size_t lost[BENCHLAT_PROBES_MAX];
};

/* Runs the rounds and prints "latency, N samples each, interleaved (us):" and the table; fills
 * the results. 0, or -ENOMEM / -EINVAL. */
int benchlat_run(struct benchlat *l);
