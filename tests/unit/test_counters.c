/*
 * cli/counters: slctl knows every counter of the shared layout, with its scope, through the public
 * library (sl_counter_name, sl_counter_scope: one list, shm/layout.h), and stats' selection
 * (the counters in scope, non-zero first, in the library's order) picks and orders right.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "cli/counters.h"
#include "shm/layout.h"

/* Every counter the layout names is known to slctl, with a scope, and nothing else is. */
static void test_every_layout_counter_has_a_scope(void **state)
{
        (void)state;
        assert_int_equal(counters_known(), SHM_COUNTER_COUNT);
        for (unsigned i = 0; i < SHM_COUNTER_COUNT; i++) {
                const char *name = shm_layout_counter_name(i);
                unsigned found = 0;

                assert_non_null(name);
                for (unsigned k = 0; k < counters_known(); k++)
                        found += strcmp(counters_known_name(k), name) == 0;
                if (found != 1)
                        fail_msg("counter %s: known %u times to slctl", name, found);
                assert_true(counters_scope(name) != 0);
                assert_true((counters_scope(name) & ~COUNTERS_ALL) == 0);
        }
        assert_null(counters_known_name(counters_known()));
}

static void test_scopes(void **state)
{
        (void)state;
        assert_int_equal(counters_scope("frames_in"), COUNTERS_LINKS);
        assert_int_equal(counters_scope("bad_address"), COUNTERS_SHAREDLINK);
        assert_int_equal(counters_scope("noncompliant_status"), COUNTERS_CIRCE);
        assert_int_equal(counters_scope("out_accepted"), COUNTERS_DAEMON);
        /* A newer library's counter is shown everywhere rather than hidden. */
        assert_int_equal(counters_scope("from_the_future"), COUNTERS_ALL);
        assert_int_equal(counters_scope(NULL), COUNTERS_ALL);
        assert_int_equal(counters_protocol_scope("sharedlink"), COUNTERS_SHAREDLINK);
        assert_int_equal(counters_protocol_scope("circe"), COUNTERS_CIRCE);
        assert_int_equal(counters_protocol_scope(""), COUNTERS_ALL);
        assert_int_equal(counters_protocol_scope("mqtt"), COUNTERS_ALL);
}

static void test_select(void **state)
{
        static const struct sl_counter in[] = {
                { "frames_in", 0 }, { "bad_address", 3 }, { "unknown_op", 5 },
                { "frames_out", 7 }, { "out_busy", 1 }, { "resync", 0 }, { "new_one", 0 },
        };
        const struct sl_counter *out[8];
        unsigned n = sizeof(in) / sizeof(in[0]);

        (void)state;
        /* SharedLink: the CIRCE and daemon ones go; non-zero first, each in order. */
        assert_int_equal(counters_select(in, n, COUNTERS_SHAREDLINK, out), 5);
        assert_string_equal(out[0]->name, "bad_address");
        assert_string_equal(out[1]->name, "frames_out");
        assert_string_equal(out[2]->name, "frames_in");
        assert_string_equal(out[3]->name, "resync");
        assert_string_equal(out[4]->name, "new_one");
        assert_ptr_equal(out[0], &in[1]);
        /* The daemon: its own and the unknown one. */
        assert_int_equal(counters_select(in, n, COUNTERS_DAEMON, out), 2);
        assert_string_equal(out[0]->name, "out_busy");
        assert_string_equal(out[1]->name, "new_one");
        /* --all: everything, non-zero first. */
        assert_int_equal(counters_select(in, n, COUNTERS_ALL, out), n);
        assert_string_equal(out[0]->name, "bad_address");
        assert_string_equal(out[3]->name, "out_busy");
        assert_string_equal(out[4]->name, "frames_in");
        assert_int_equal(counters_select(in, 0, COUNTERS_ALL, out), 0);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_every_layout_counter_has_a_scope),
                cmocka_unit_test(test_scopes),
                cmocka_unit_test(test_select),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
