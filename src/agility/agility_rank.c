/*
 * sharedlink-agility: run results, penalties and placements (agility_rank.h).
 */
#include <stdlib.h>

#include "agility/agility_rank.h"

/* Completion groups, best first (agility_rank.h, rule 1). */
enum group {
        GROUP_CLEAN_FINISH,
        GROUP_FINISHED_ELIMINATED,
        GROUP_ELIMINATED,
        GROUP_NO_RUN,
};

static enum group group_of(const struct agility_result *r)
{
        if (r->finished)
                return r->eliminated ? GROUP_FINISHED_ELIMINATED : GROUP_CLEAN_FINISH;
        return r->eliminated ? GROUP_ELIMINATED : GROUP_NO_RUN;
}

static int cmp_u32(uint32_t a, uint32_t b)
{
        return (a > b) - (a < b);
}

static unsigned course_faults(const struct agility_result *r)
{
        return (unsigned)r->faults + r->refusals;
}

uint32_t agility_rank_penalty_ms(const struct agility_result *r, uint32_t sct_ms)
{
        uint64_t p = (uint64_t)course_faults(r) * AGILITY_MS_PER_PENALTY;

        if (r->finished && sct_ms > 0 && r->finish_ms > sct_ms)
                p += r->finish_ms - sct_ms;
        return p > UINT32_MAX ? UINT32_MAX : (uint32_t)p;
}

/* Rules 1-4: everything but the competitor number. */
static int compare_run(const struct agility_result *a, const struct agility_result *b)
{
        int c = cmp_u32(group_of(a), group_of(b));

        if (c == 0)
                c = cmp_u32(a->penalty_ms, b->penalty_ms);
        if (c == 0)
                c = cmp_u32(course_faults(a), course_faults(b));
        if (c == 0)
                c = cmp_u32(a->finished ? a->finish_ms : 0, b->finished ? b->finish_ms : 0);
        return c;
}

int agility_rank_compare(const struct agility_result *a, const struct agility_result *b)
{
        int c = compare_run(a, b);

        return c != 0 ? c : cmp_u32(a->competitor, b->competitor);
}

bool agility_rank_tied(const struct agility_result *a, const struct agility_result *b)
{
        return group_of(a) == GROUP_CLEAN_FINISH && compare_run(a, b) == 0;
}

static int compare_ptr(const void *x, const void *y)
{
        const struct agility_result *const *a = x;
        const struct agility_result *const *b = y;

        return agility_rank_compare(*a, *b);
}

void agility_rank_place(struct agility_result *results, size_t n, uint32_t sct_ms,
                        const struct agility_result **order)
{
        uint16_t placement = 0;

        for (size_t i = 0; i < n; i++) {
                results[i].penalty_ms = agility_rank_penalty_ms(&results[i], sct_ms);
                order[i] = &results[i];
        }
        if (n > 1)
                qsort(order, n, sizeof(*order), compare_ptr);
        for (size_t i = 0; i < n; i++) {
                /* order[] points into results[]: index back into the writable array
                 * rather than cast the const away. */
                struct agility_result *r = &results[order[i] - results];

                if (group_of(r) != GROUP_CLEAN_FINISH) {
                        r->placement = 0;
                        continue;
                }
                if (i == 0 || !agility_rank_tied(order[i - 1], r))
                        placement++;
                r->placement = placement;
        }
}
