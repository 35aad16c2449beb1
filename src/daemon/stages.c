/*
 * Stage timing (see stages.h).
 */
#include "daemon/stages.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#define STAGES_PERCENT          100u
#define STAGES_P50              50u
#define STAGES_P99              99u

void stages_init(struct stages *s, unsigned n)
{
        s->n = n < 1 ? 1 : n > STAGES_MAX ? STAGES_MAX : n;
        s->passes = 0;
        s->dropped = 0;
}

void stages_record(struct stages *s, const uint64_t *stamps)
{
        size_t at = (size_t)(s->passes % STAGES_RING);

        for (unsigned k = 0; k < s->n; k++) {
                if (stamps[k] == 0 || stamps[k + 1] < stamps[k]) {
                        s->dropped++;
                        return;
                }
        }
        for (unsigned k = 0; k < s->n; k++) {
                uint64_t d = stamps[k + 1] - stamps[k];

                s->ns[k][at] = d > UINT32_MAX ? UINT32_MAX : (uint32_t)d;
        }
        s->passes++;
}

static int stages_cmp(const void *a, const void *b)
{
        uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;

        return (x > y) - (x < y);
}

int stages_summary(const struct stages *s, unsigned k, struct stages_summary *ret_summary)
{
        size_t n = s->passes < STAGES_RING ? (size_t)s->passes : STAGES_RING;
        uint32_t *v;

        if (k >= s->n)
                return -EINVAL;
        if (n == 0)
                return -ENODATA;
        /* Sorted in a copy: the ring keeps its order for the passes still to come. */
        v = malloc(n * sizeof(*v));
        if (!v)
                return -ENOMEM;
        memcpy(v, s->ns[k], n * sizeof(*v));
        qsort(v, n, sizeof(*v), stages_cmp);
        ret_summary->samples = n;
        ret_summary->p50_ns = v[n * STAGES_P50 / STAGES_PERCENT];
        ret_summary->p99_ns = v[n * STAGES_P99 / STAGES_PERCENT];
        ret_summary->max_ns = v[n - 1];
        free(v);
        return 0;
}
