/*
 * sharedlink-agility: run results, penalties and placements (docs/agility.md "Results").
 *
 * Penalty = faults + refusals (each counts as seconds) + the time over the standard course
 * time, in milliseconds. The ranking, as the reference controller sorts it:
 *   1. finished and not eliminated, then finished and eliminated, then eliminated without a
 *      finish, then no run yet;
 *   2. lower penalty;
 *   3. on equal penalty, fewer course faults (faults + refusals), i.e. more of the penalty is
 *      time over the standard course time;
 *   4. lower finish time;
 *   5. lower competitor number.
 * Only finished, not eliminated runs are placed. Runs equal in 1-4 share a placement and the
 * next run takes the next number (1, 2, 2, 3). The reference also asks for equal fault and
 * refusal counts each; a fault and a refusal weigh the same, so here only their sum must match.
 *
 * Pure code: no syscalls, no allocation, no logging.
 */
#ifndef SHAREDLINK_AGILITY_RANK_H
#define SHAREDLINK_AGILITY_RANK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "agility/agility_timing.h"

#define AGILITY_INTERMEDIATES_MAX 3     /* intermediate timers of a class, 0..3 */
#define AGILITY_MS_PER_PENALTY 1000u    /* a fault or refusal point costs one second */

struct agility_result {
        uint16_t competitor;            /* 1..999 */
        bool completed;                 /* a run was stored for this competitor */
        bool finished;                  /* it passed the finish */
        bool eliminated;
        uint8_t faults;                 /* 0..95 in steps of 5 */
        uint8_t refusals;               /* 0..15 in steps of 5 */
        uint8_t intermediates;          /* intermediate times taken, 0..3, in gate order */
        uint32_t intermediate_ms[AGILITY_INTERMEDIATES_MAX];
        enum agility_precision intermediate_precision[AGILITY_INTERMEDIATES_MAX];
        uint32_t finish_ms;             /* when finished */
        enum agility_precision finish_precision;
        uint32_t penalty_ms;            /* set by agility_rank_place */
        uint16_t placement;             /* set by agility_rank_place; 0: not placed */
};

/* The penalty of r in ms, with a standard course time of sct_ms (0: none). */
uint32_t agility_rank_penalty_ms(const struct agility_result *r, uint32_t sct_ms);

/* Ranking order of two results whose penalty_ms is set: < 0 when a ranks first, > 0 when b
 * does; 0 only for the same competitor number. */
int agility_rank_compare(const struct agility_result *a, const struct agility_result *b);

/* True when a and b share a placement: both placed and equal in everything but the number. */
bool agility_rank_tied(const struct agility_result *a, const struct agility_result *b);

/*
 * Sets penalty_ms and placement of the n results (standard course time sct_ms, 0: none) and
 * leaves them in ranking order in order (room for n pointers).
 */
void agility_rank_place(struct agility_result *results, size_t n, uint32_t sct_ms,
                        const struct agility_result **order);

#endif
