/*
 * sharedlink-agility timing (src/agility/agility_timing.c): the run time between two passages
 * and its precision, table-driven: synchronised gates that agree with the received times (high),
 * the 4 s agreement bound on both sides, unsynchronised gates, a missing sensor time, a pass key
 * (manual: low even with a sensor time), the 999999 -> 0 wrap, and a clock that restarted.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "agility/agility_timing.h"

#define HIGH AGILITY_PRECISION_HIGH
#define LOW AGILITY_PRECISION_LOW

struct timing_case {
        const char *what;
        struct agility_passage from, to;
        uint32_t ms;
        enum agility_precision precision;
};

/* Passages: received time, sensor time, has sensor, synced, manual. */
#define P(recv, sensor, has, sync, man) \
        { .received_ms = (recv), .sensor_ms = (sensor), .has_sensor = (has), .synced = (sync), \
          .manual = (man) }
#define GATE(recv, sensor) P(recv, sensor, true, true, false)

static const struct timing_case cases[] = {
        /* The specification's example session: start 5000, finish 32000. */
        { "spec example", GATE(100000, 5000), GATE(127020, 32000), 27000, HIGH },
        { "received exactly", GATE(0, 5000), GATE(27000, 32000), 27000, HIGH },
        { "agrees by 3999 ms", GATE(0, 5000), GATE(30999, 32000), 27000, HIGH },
        { "disagrees by 4000 ms", GATE(0, 5000), GATE(31000, 32000), 31000, LOW },
        { "sensor longer by 3999", GATE(0, 5000), GATE(23001, 32000), 27000, HIGH },
        { "sensor longer by 4000", GATE(0, 5000), GATE(23000, 32000), 23000, LOW },
        { "wrap keeps high", GATE(0, 999000), GATE(27010, 26000), 27000, HIGH },
        { "wrap at the very end", GATE(0, 999999), GATE(1, 0), 1, HIGH },
        { "restarted clock", GATE(0, 500000), GATE(27000, 3000), 27000, LOW },
        { "start not synced", P(0, 5000, true, false, false), GATE(27020, 32000), 27020, LOW },
        { "finish not synced", GATE(0, 5000), P(27020, 32000, true, false, false), 27020, LOW },
        { "no sensor time", P(0, 0, false, true, false), GATE(27020, 32000), 27020, LOW },
        { "pass key (manual)", GATE(0, 5000), P(27020, 32000, true, true, true), 27000, LOW },
        { "received backwards", GATE(5000, 5000), P(1000, 0, false, false, false), 0, LOW },
        { "zero", GATE(7, 42), GATE(7, 42), 0, HIGH },
};

static void test_elapsed(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                struct agility_elapsed e;

                memset(&e, 0xa5, sizeof(e));
                agility_timing_elapsed(&cases[i].from, &cases[i].to, &e);
                print_message("%s\n", cases[i].what);
                assert_int_equal(e.ms, cases[i].ms);
                assert_int_equal(e.precision, cases[i].precision);
        }
}

static void test_clamp_and_names(void **state)
{
        struct agility_passage a = P(0, 0, false, false, false);
        struct agility_passage b = P(UINT64_MAX, 0, false, false, false);
        struct agility_elapsed e;

        (void)state;
        agility_timing_elapsed(&a, &b, &e);
        assert_int_equal(e.ms, UINT32_MAX);
        assert_string_equal(agility_timing_precision_name(HIGH), "high");
        assert_string_equal(agility_timing_precision_name(LOW), "low");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_elapsed),
                cmocka_unit_test(test_clamp_and_names),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
