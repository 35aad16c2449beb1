/*
 * Interleaved latency probes for the benchmarks (see benchlat.h).
 */
#include "common/benchlat.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#define NS_PER_US       1000.0
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
