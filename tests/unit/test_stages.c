/*
 * stages: durations per stage from rows of stamps, percentiles over the ring, dropped passes,
 * saturation, the ring overwriting its oldest passes.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include <cmocka.h>

#include "daemon/stages.h"

#define BASE_NS         1000000000ull   /* any start: stamps are CLOCK_MONOTONIC readings */

/* The struct is large (a ring per stage): one static instance for the whole binary. */
static struct stages st;

/* Records a pass of three stages lasting a, b and c ns. */
static void pass3(uint64_t a, uint64_t b, uint64_t c)
{
        uint64_t t[4] = { BASE_NS, BASE_NS + a, BASE_NS + a + b, BASE_NS + a + b + c };

        stages_record(&st, t);
}

static void test_empty_and_range(void **state)
{
        struct stages_summary sum;

        (void)state;
        stages_init(&st, 3);
        assert_int_equal(stages_summary(&st, 0, &sum), -ENODATA);
        assert_int_equal(stages_summary(&st, 3, &sum), -EINVAL);
        /* Clamped: 0 stages is one, too many is STAGES_MAX. */
        stages_init(&st, 0);
        assert_int_equal(stages_summary(&st, 1, &sum), -EINVAL);
        stages_init(&st, STAGES_MAX + 5);
        assert_int_equal(stages_summary(&st, STAGES_MAX, &sum), -EINVAL);
        assert_int_equal(stages_summary(&st, STAGES_MAX - 1, &sum), -ENODATA);
}

static void test_percentiles(void **state)
{
        struct stages_summary sum;

        (void)state;
        stages_init(&st, 3);
        /* Stage 0 takes 1..100 us in a shuffled order, stage 1 always 7 ns, stage 2 i * 2. */
        for (unsigned i = 0; i < 100; i++) {
                unsigned v = (i * 37u) % 100u + 1u;

                pass3(v * 1000ull, 7, v * 2ull);
        }
        assert_int_equal(stages_summary(&st, 0, &sum), 0);
        assert_int_equal(sum.samples, 100);
        assert_int_equal(sum.p50_ns, 51000);
        assert_int_equal(sum.p99_ns, 100000);
        assert_int_equal(sum.max_ns, 100000);
        assert_int_equal(stages_summary(&st, 1, &sum), 0);
        assert_int_equal(sum.p50_ns, 7);
        assert_int_equal(sum.max_ns, 7);
        assert_int_equal(stages_summary(&st, 2, &sum), 0);
        assert_int_equal(sum.p50_ns, 102);
        assert_int_equal(sum.max_ns, 200);
        assert_int_equal(st.passes, 100);
        assert_int_equal(st.dropped, 0);
}

static void test_dropped_and_saturated(void **state)
{
        uint64_t zero[4] = { 0, BASE_NS, BASE_NS + 1, BASE_NS + 2 };
        uint64_t back[4] = { BASE_NS, BASE_NS + 10, BASE_NS + 5, BASE_NS + 20 };
        struct stages_summary sum;

        (void)state;
        stages_init(&st, 3);
        stages_record(&st, zero);
        stages_record(&st, back);
        assert_int_equal(st.dropped, 2);
        assert_int_equal(stages_summary(&st, 0, &sum), -ENODATA);
        /* Longer than 32 bits of ns (4.3 s): kept as the largest figure, not wrapped. */
        pass3(10ull * BASE_NS, 1, 1);
        assert_int_equal(stages_summary(&st, 0, &sum), 0);
        assert_int_equal(sum.max_ns, UINT32_MAX);
        assert_int_equal(st.passes, 1);
}

static void test_ring_keeps_the_latest(void **state)
{
        struct stages_summary sum;

        (void)state;
        stages_init(&st, 1);
        /* A burst of slow passes, then a ring's worth of fast ones: the slow ones are gone. */
        for (unsigned i = 0; i < 10; i++) {
                uint64_t t[2] = { BASE_NS, BASE_NS + 5000000 };

                stages_record(&st, t);
        }
        for (unsigned i = 0; i < STAGES_RING; i++) {
                uint64_t t[2] = { BASE_NS, BASE_NS + 100 + i % 10 };

                stages_record(&st, t);
        }
        assert_int_equal(stages_summary(&st, 0, &sum), 0);
        assert_int_equal(sum.samples, STAGES_RING);
        assert_int_equal(sum.max_ns, 109);
        assert_int_equal(st.passes, STAGES_RING + 10);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_empty_and_range),
                cmocka_unit_test(test_percentiles),
                cmocka_unit_test(test_dropped_and_saturated),
                cmocka_unit_test(test_ring_keeps_the_latest),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
