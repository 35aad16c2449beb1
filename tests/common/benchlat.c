/*
 * Interleaved latency probes for the benchmarks (see benchlat.h).
 */
#include "common/benchlat.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>

#define NS_PER_US       1000.0
#define NS_PER_S        1000000000ull
#define PERCENT         100

static int cmp_u64(const void *a, const void *b)
{
        uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;

        return (x > y) - (x < y);
}

/* The q-th percentile of the n sorted values, in us (0 for none). */
static double percentile_us(const uint64_t *v, size_t n, size_t q)
{
        return n ? (double)v[n * q / PERCENT] / NS_PER_US : 0;
}

int benchlat_run(struct benchlat *l)
{
        uint64_t *lat[BENCHLAT_PROBES_MAX] = { NULL };
        size_t n[BENCHLAT_PROBES_MAX] = { 0 };
        int r = 0;

        if (l->probes <= 0 || l->probes > BENCHLAT_PROBES_MAX)
                return -EINVAL;
        for (int p = 0; p < l->probes; p++)
                if (!(lat[p] = calloc(l->samples ? l->samples : 1, sizeof(uint64_t))))
                        r = -ENOMEM;
        for (size_t i = 0; r == 0 && i < l->samples + l->warmup; i++)
                for (int p = 0; p < l->probes; p++) {
                        uint64_t ns = l->sample(l->arg, p, l->first_value + (long)i);

                        usleep(l->gap_us);
                        if (i < l->warmup)
                                continue;
                        if (ns == 0)
                                l->lost[p]++;
                        else
                                lat[p][n[p]++] = ns;
                }
        if (r == 0) {
                printf("latency, %zu samples each, interleaved (us):\n", l->samples);
                printf("  %-7s %9s %9s %6s\n", "probe", "median", "p99", "lost");
        }
        for (int p = 0; r == 0 && p < l->probes; p++) {
                qsort(lat[p], n[p], sizeof(uint64_t), cmp_u64);
                l->median_us[p] = percentile_us(lat[p], n[p], PERCENT / 2);
                l->p99_us[p] = percentile_us(lat[p], n[p], PERCENT - 1);
                printf("  %-7s %9.1f %9.1f %6zu\n", l->names[p], l->median_us[p], l->p99_us[p],
                       l->lost[p]);
        }
        for (int p = 0; p < l->probes; p++)
                free(lat[p]);
        return r;
}

int benchlat_cpu_ns(pid_t pid, uint64_t *ret)
{
        struct timespec ts;
        clockid_t c;
        int r = clock_getcpuclockid(pid, &c);

        if (r != 0)
                return -r;
        if (clock_gettime(c, &ts) < 0)
                return -errno;
        *ret = (uint64_t)ts.tv_sec * NS_PER_S + (uint64_t)ts.tv_nsec;
        return 0;
}

double benchlat_cpu_per_sample(const struct benchlat *l, int p, pid_t pid, long *value,
                               double *ret_median_us)
{
        uint64_t c0 = 0, c1 = 0, *lat = calloc(l->samples ? l->samples : 1, sizeof(*lat));
        double cpu = -1;

        if (!lat || !l->sample(l->arg, p, ++*value))
                goto out;
        benchlat_cpu_ns(pid, &c0);
        for (size_t i = 0; i < l->samples; i++) {
                lat[i] = l->sample(l->arg, p, ++*value);
                if (!lat[i])
                        goto out;
                usleep(l->gap_us);
        }
        benchlat_cpu_ns(pid, &c1);
        qsort(lat, l->samples, sizeof(uint64_t), cmp_u64);
        *ret_median_us = percentile_us(lat, l->samples, PERCENT / 2);
        cpu = l->samples ? (double)(c1 - c0) / NS_PER_US / (double)l->samples : 0;
out:
        free(lat);
        return cpu;
}

static int cmp_double(const void *a, const void *b)
{
        double x = *(const double *)a, y = *(const double *)b;

        return (x > y) - (x < y);
}

int benchlat_wake_compare(const struct benchlat *l, int p, benchlat_restart_fn restart,
                          long *value, const char *key, const char *what)
{
        double cpu[2][BENCHLAT_WAKE_ROUNDS], med[2][BENCHLAT_WAKE_ROUNDS];
        static const char *const mode[2] = { "full read (forced)", "changed only" };

        printf("wake-ups, one variable changing (%zu each, one frame each), %d rounds "
               "alternating:\n", l->samples, BENCHLAT_WAKE_ROUNDS);
        for (int r = 0; r < BENCHLAT_WAKE_ROUNDS; r++)
                for (int m = 0; m < 2; m++) {
                        pid_t pid = restart(l->arg, m == 0);

                        cpu[m][r] = pid > 0 ? benchlat_cpu_per_sample(l, p, pid, value,
                                                                      &med[m][r]) : -1;
                        if (cpu[m][r] < 0) {
                                fprintf(stderr, "benchlat: %s, %s: no restart, or a sample "
                                        "never came\n", what, mode[m]);
                                return -1;
                        }
                        printf("  round %d  %-19s bridge CPU %6.1f us per wake-up, latency "
                               "median %6.1f us\n", r + 1, mode[m], cpu[m][r], med[m][r]);
                }
        for (int m = 0; m < 2; m++)
                qsort(cpu[m], BENCHLAT_WAKE_ROUNDS, sizeof(double), cmp_double);
        printf("  median of the rounds: full read %.1f us, changed only %.1f us per wake-up: "
               "%.1f us saved (%.2fx)\n", cpu[0][BENCHLAT_WAKE_ROUNDS / 2],
               cpu[1][BENCHLAT_WAKE_ROUNDS / 2],
               cpu[0][BENCHLAT_WAKE_ROUNDS / 2] - cpu[1][BENCHLAT_WAKE_ROUNDS / 2],
               cpu[1][BENCHLAT_WAKE_ROUNDS / 2] > 0 ?
               cpu[0][BENCHLAT_WAKE_ROUNDS / 2] / cpu[1][BENCHLAT_WAKE_ROUNDS / 2] : 0.0);
        printf("FIGURE|%s_wake_full|%s: bridge CPU per wake-up, one variable changing, full "
               "read (forced)|%.1f|us|-\n", key, what, cpu[0][BENCHLAT_WAKE_ROUNDS / 2]);
        printf("FIGURE|%s_wake_changed|%s: bridge CPU per wake-up, one variable changing, "
               "changed only|%.1f|us|-\n", key, what, cpu[1][BENCHLAT_WAKE_ROUNDS / 2]);
        return 0;
}
