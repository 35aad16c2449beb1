/*
 * Interleaved latency probes for the benchmarks: each round takes one sample of every probe in
 * turn (so a busy spell of the machine touches all of them alike), gap_us apart, the first
 * `warmup` rounds thrown away; then one table of median, p99 and lost samples in microseconds.
 * Used by bench_mqtt and bench_ros2.
 */
#pragma once

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

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

/* CPU time of every thread of process pid so far, in ns. 0 or -errno. */
int benchlat_cpu_ns(pid_t pid, uint64_t *ret);

/*
 * The CPU process pid spends per sample of probe p of l: l->samples samples, values *value + 1
 * on (left at the last), each after the previous one arrived and l->gap_us apart, after one not
 * counted (it waits for whatever was starting). Returns microseconds of pid's CPU per sample with
 * the samples' median latency in *ret_median_us, or -1 when a sample never came (-ENOMEM: -1 as
 * well).
 */
double benchlat_cpu_per_sample(const struct benchlat *l, int p, pid_t pid, long *value,
                               double *ret_median_us);

/* Restarts the process under test, reading every variable at each wake-up when full_read
 * (SHAREDLINK_CHANGES=all); returns its pid, or -1. */
typedef pid_t (*benchlat_restart_fn)(void *arg, bool full_read);

#define BENCHLAT_WAKE_ROUNDS    3       /* alternating rounds of the wake comparison */

/*
 * A bridge's CPU per wake-up, full read (forced) against changed only, side by side in one run:
 * BENCHLAT_WAKE_ROUNDS rounds, each restarting it both ways in turn (restart with l->arg) and
 * taking benchlat_cpu_per_sample of probe p (values from *value on). Prints each round, the
 * medians, and the FIGURE lines <key>_wake_full and <key>_wake_changed (label: what). 0, or -1
 * when a restart failed or a sample never came.
 */
int benchlat_wake_compare(const struct benchlat *l, int p, benchlat_restart_fn restart,
                          long *value, const char *key, const char *what);
