/*
 * svc/backoff: 100 ms doubling to 5 s, the first failure told once, a success starting over.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "svc/backoff.h"

static void test_doubling_to_the_cap(void **state)
{
        static const unsigned delays[] = { 100, 200, 400, 800, 1600, 3200, 5000, 5000 };
        struct backoff b;
        uint64_t now = 1000;

        (void)state;
        backoff_reset(&b);
        assert_true(backoff_due(&b, 0));
        for (unsigned i = 0; i < sizeof(delays) / sizeof(delays[0]); i++) {
                assert_int_equal(backoff_failed(&b, now), i == 0);
                assert_int_equal(backoff_due_ms(&b), now + delays[i]);
                assert_false(backoff_due(&b, now + delays[i] - 1));
                assert_true(backoff_due(&b, now + delays[i]));
                now += delays[i];
        }
}

/* A success starts over: the next outage is retried after 100 ms and told again. */
static void test_success_starts_over(void **state)
{
        struct backoff b;

        (void)state;
        backoff_reset(&b);
        for (int i = 0; i < 10; i++)
                backoff_failed(&b, 0);
        backoff_reset(&b);
        assert_true(backoff_due(&b, 0));
        assert_true(backoff_failed(&b, 500));
        assert_int_equal(backoff_due_ms(&b), 500 + BACKOFF_MIN_MS);
        assert_false(backoff_failed(&b, 600));
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_doubling_to_the_cap),
                cmocka_unit_test(test_success_starts_over),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
