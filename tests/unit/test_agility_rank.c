/*
 * sharedlink-agility ranking (src/agility/agility_rank.c): penalties with and without a
 * standard course time, the order of completion groups, the tie-breaks (course faults, time,
 * number), shared placements (1, 2, 2, 3), and that only clean finishes are placed.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "agility/agility_rank.h"

#define SCT 40000u

static struct agility_result run(uint16_t number, uint32_t finish_ms, uint8_t faults,
                                 uint8_t refusals, bool elim)
{
        return (struct agility_result){ .competitor = number, .completed = true,
                                        .finished = finish_ms > 0, .finish_ms = finish_ms,
                                        .faults = faults, .refusals = refusals,
                                        .eliminated = elim };
}

static void test_penalty(void **state)
{
        struct agility_result r = run(1, 42500, 5, 10, false);

        (void)state;
        assert_int_equal(agility_rank_penalty_ms(&r, SCT), 15000 + 2500);
        assert_int_equal(agility_rank_penalty_ms(&r, 0), 15000);
        r.finish_ms = SCT;
        assert_int_equal(agility_rank_penalty_ms(&r, SCT), 15000);
        r = run(2, 0, 5, 0, true);      /* no finish: no time over */
        assert_int_equal(agility_rank_penalty_ms(&r, SCT), 5000);
}

/* Placements of a class with a tie for second: 1, 2, 2, 3, then the unplaced. */
static void test_ties(void **state)
{
        struct agility_result r[] = {
                run(7, 35000, 5, 0, false),     /* 5 s penalty, 35 s: 2nd (tie) */
                run(3, 30000, 0, 0, false),     /* clean: 1st */
                run(9, 35000, 0, 5, false),     /* fault vs refusal, same time: tie with 7 */
                run(4, 36000, 5, 0, false),     /* 5 s penalty, slower: 3rd */
                run(5, 0, 0, 15, true),         /* eliminated, no finish */
                { .competitor = 6 },            /* no run yet */
                run(8, 31000, 0, 0, true),      /* finished but eliminated */
        };
        const struct agility_result *order[7];
        const uint16_t want_order[] = { 3, 7, 9, 4, 8, 5, 6 };
        const uint16_t want_place[] = { 1, 2, 2, 3, 0, 0, 0 };

        (void)state;
        agility_rank_place(r, 7, SCT, order);
        for (size_t i = 0; i < 7; i++) {
                assert_int_equal(order[i]->competitor, want_order[i]);
                assert_int_equal(order[i]->placement, want_place[i]);
        }
        assert_true(agility_rank_tied(&r[0], &r[2]));
        assert_false(agility_rank_tied(&r[0], &r[3]));
        assert_false(agility_rank_tied(&r[4], &r[4]));  /* never placed, never tied */
}

/* At equal penalty, the run with fewer course faults (more time over) ranks first. */
static void test_course_faults_break_tie(void **state)
{
        struct agility_result r[] = {
                run(1, 40000, 5, 0, false),     /* 5 s of faults, 40 s */
                run(2, 45000, 0, 0, false),     /* 5 s over the SCT, no faults */
        };
        const struct agility_result *order[2];

        (void)state;
        agility_rank_place(r, 2, SCT, order);
        assert_int_equal(r[0].penalty_ms, r[1].penalty_ms);
        assert_int_equal(order[0]->competitor, 2);
        assert_int_equal(r[1].placement, 1);
        assert_int_equal(r[0].placement, 2);
}

/* Equal in everything: shared placement, the lower number listed first. */
static void test_number_last(void **state)
{
        struct agility_result r[] = { run(12, 30000, 0, 0, false), run(11, 30000, 0, 0, false),
                                      run(13, 30001, 0, 0, false) };
        const struct agility_result *order[3];

        (void)state;
        agility_rank_place(r, 3, 0, order);
        assert_int_equal(order[0]->competitor, 11);
        assert_int_equal(order[1]->competitor, 12);
        assert_int_equal(order[2]->competitor, 13);
        assert_int_equal(r[0].placement, 1);
        assert_int_equal(r[1].placement, 1);
        assert_int_equal(r[2].placement, 2);
        assert_true(agility_rank_compare(&r[1], &r[0]) < 0);
        assert_true(agility_rank_compare(&r[0], &r[1]) > 0);
        assert_int_equal(agility_rank_compare(&r[0], &r[0]), 0);
}

static void test_groups(void **state)
{
        struct agility_result r[] = {
                { .competitor = 1 },                    /* no run */
                run(2, 0, 0, 0, true),                  /* eliminated */
                run(3, 90000, 95, 10, true),            /* finished, eliminated */
                run(4, 99000, 95, 10, false),           /* finished, dreadful, but clean */
        };
        const struct agility_result *order[4];

        (void)state;
        agility_rank_place(r, 4, SCT, order);
        for (size_t i = 0; i < 4; i++)
                assert_int_equal(order[i]->competitor, 4 - i);
        assert_int_equal(r[3].placement, 1);
        assert_int_equal(r[2].placement, 0);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_penalty),
                cmocka_unit_test(test_ties),
                cmocka_unit_test(test_course_faults_break_tie),
                cmocka_unit_test(test_number_last),
                cmocka_unit_test(test_groups),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
