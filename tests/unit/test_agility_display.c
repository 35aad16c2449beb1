/*
 * sharedlink-agility display model (src/agility/agility_display.c): an unknown display gets
 * every field, a known one only what changed; a running timer goes as Start Timer alone and a
 * stopped time as Primary Timer Value alone (the precedence rule); a display that joins mid-run
 * gets no running time; hidden values and clamps.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "agility/agility_display.h"

/* Fields set in v, as a string "E C N S P 2 F R L" for eliminated, current, next, start timer,
 * primary, secondary, faults, refusals, placement, in wire order. */
static const char *fields(const struct sl_circe_visualize *v, char *buf)
{
        const int set[] = { v->has_eliminated, v->has_current, v->has_next, v->start_timer,
                            v->has_primary, v->has_secondary, v->has_faults, v->has_refusals,
                            v->has_placement };
        const char names[] = "ECNSP2FRL";
        size_t o = 0;

        for (size_t i = 0; i < sizeof(set) / sizeof(set[0]); i++)
                if (set[i])
                        buf[o++] = names[i];
        buf[o] = '\0';
        return buf;
}

static void test_unknown_gets_everything(void **state)
{
        struct agility_display shown, want, after;
        struct sl_circe_visualize v;
        char f[16];

        (void)state;
        agility_display_unknown(&shown);
        agility_display_blank(&want);
        want.current = 12;
        want.next = 13;
        want.primary_ms = 0;
        want.faults = 0;
        want.refusals = 0;
        assert_int_equal(agility_display_diff(&shown, &want, &v, &after), 8);
        assert_string_equal(fields(&v, f), "ECNP2FRL");
        assert_int_equal(v.size, sizeof(v));
        assert_int_equal(v.current, 12);
        assert_int_equal(v.next, 13);
        assert_int_equal(v.primary_ms, 0);
        assert_int_equal(v.secondary_ms, AGILITY_HIDDEN_TIME);
        assert_int_equal(v.placement, AGILITY_HIDDEN_NUMBER);
        assert_true(after.known);
        /* Shown as wanted: nothing more to send. */
        assert_int_equal(agility_display_diff(&after, &want, &v, &after), 0);
        assert_string_equal(fields(&v, f), "");
}

static void test_only_changes(void **state)
{
        struct agility_display shown, want;
        struct sl_circe_visualize v;
        char f[16];

        (void)state;
        agility_display_blank(&shown);
        shown.faults = 0;
        shown.refusals = 0;
        want = shown;
        want.faults = 5;
        assert_int_equal(agility_display_diff(&shown, &want, &v, &shown), 1);
        assert_string_equal(fields(&v, f), "F");
        assert_int_equal(v.faults, 5);
        want.eliminated = true;
        want.placement = 3;
        assert_int_equal(agility_display_diff(&shown, &want, &v, &shown), 2);
        assert_string_equal(fields(&v, f), "EL");
}

/* Start Timer and a Primary Timer Value never travel together: 031 would stop 030's timer. */
static void test_timer_precedence(void **state)
{
        struct agility_display shown, want;
        struct sl_circe_visualize v;
        char f[16];

        (void)state;
        agility_display_blank(&shown);
        shown.primary_ms = 0;
        want = shown;
        want.timer = AGILITY_TIMER_RUNNING;
        want.run = 1;
        want.primary_ms = 27000;        /* ignored while running */
        assert_int_equal(agility_display_diff(&shown, &want, &v, &shown), 1);
        assert_string_equal(fields(&v, f), "S");
        assert_int_equal(v.start_timer, 1);
        /* Still the same run: nothing. */
        assert_int_equal(agility_display_diff(&shown, &want, &v, &shown), 0);
        /* A new run (reset and started again between two calls): started again. */
        want.run = 2;
        assert_int_equal(agility_display_diff(&shown, &want, &v, &shown), 1);
        assert_string_equal(fields(&v, f), "S");
        /* The finish stops it at the time. */
        want.timer = AGILITY_TIMER_VALUE;
        want.primary_ms = 27000;
        assert_int_equal(agility_display_diff(&shown, &want, &v, &shown), 1);
        assert_string_equal(fields(&v, f), "P");
        assert_int_equal(v.primary_ms, 27000);
}

/* A display that comes online mid-run gets the time hidden, not a timer from zero, and is not
 * started later for the same run. */
static void test_unknown_mid_run(void **state)
{
        struct agility_display shown, want;
        struct sl_circe_visualize v;

        (void)state;
        agility_display_unknown(&shown);
        agility_display_blank(&want);
        want.timer = AGILITY_TIMER_RUNNING;
        want.run = 4;
        agility_display_diff(&shown, &want, &v, &shown);
        assert_false(v.start_timer);
        assert_true(v.has_primary);
        assert_int_equal(v.primary_ms, AGILITY_HIDDEN_TIME);
        assert_int_equal(agility_display_diff(&shown, &want, &v, &shown), 0);
        want.run = 5;
        assert_int_equal(agility_display_diff(&shown, &want, &v, &shown), 1);
        assert_true(v.start_timer);
}

static void test_clamps(void **state)
{
        struct agility_display shown, want;
        struct sl_circe_visualize v;

        (void)state;
        agility_display_unknown(&shown);
        agility_display_blank(&want);
        want.primary_ms = 1234567;
        want.secondary_ms = AGILITY_HIDDEN_TIME;
        want.faults = 150;
        want.refusals = AGILITY_HIDDEN_COUNT;
        want.current = 1000;
        want.placement = 1000;
        agility_display_diff(&shown, &want, &v, &shown);
        assert_int_equal(v.primary_ms, AGILITY_DISPLAY_TIME_MAX);
        assert_int_equal(v.secondary_ms, AGILITY_HIDDEN_TIME);
        assert_int_equal(v.faults, AGILITY_HIDDEN_COUNT - 1);
        assert_int_equal(v.refusals, AGILITY_HIDDEN_COUNT);
        assert_int_equal(v.current, AGILITY_HIDDEN_NUMBER);
        assert_int_equal(v.placement, AGILITY_HIDDEN_NUMBER);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_unknown_gets_everything),
                cmocka_unit_test(test_only_changes),
                cmocka_unit_test(test_timer_precedence),
                cmocka_unit_test(test_unknown_mid_run),
                cmocka_unit_test(test_clamps),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
