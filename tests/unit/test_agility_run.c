/*
 * sharedlink-agility run engine (src/agility/agility_run.c) on a fake clock: every state
 * against every input (a table), every key, the specification's example session, the 999999
 * wrap, a combined start/finish gate with its minimum delay, passages out of order and twice,
 * keys from a device that is no keypad, unsynchronised gates (low precision), clock sync
 * failure and age, the maximum course time, competitor entry, resuming a class, the display it
 * asks for, and shared placements.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "agility/agility_run.h"
#include "proto/circe.h"

#define START 0xE1E1E1u
#define FINISH 0xF1F1F1u
#define I1 0x111111u
#define I2 0x222222u
#define I3 0x333333u
#define REMOTE 0xAAAAAAu
#define STRANGER 0x999999u
#define SCT 40000u
#define MAXT 60000u
#define T0 1000000u                     /* the fake clock's start, ms */
#define NCOMP 4

struct fixture {
        struct agility_run run;
        struct agility_class cls;
        struct agility_competitor comp[NCOMP];
        struct agility_result res[NCOMP];
        struct agility_actions acts;
        uint64_t now;
};

static struct agility_class default_class(void)
{
        return (struct agility_class){
                .standard_course_time_ms = SCT,
                .max_course_time_ms = MAXT,
                .intermediates = 3,
                .start = START,
                .finish = FINISH,
                .intermediate = { I1, I2, I3 },
                .keypads = { REMOTE },
                .keypad_count = 1,
        };
}

static struct fixture *fixture_new(const struct agility_class *cls)
{
        struct fixture *f = calloc(1, sizeof(*f));
        const uint16_t numbers[NCOMP] = { 3, 1, 2, 4 };         /* file order, not sorted */

        assert_non_null(f);
        f->cls = cls ? *cls : default_class();
        for (int i = 0; i < NCOMP; i++)
                f->comp[i].number = numbers[i];
        assert_int_equal(agility_run_init(&f->run, &f->cls, f->comp, NCOMP, f->res, 0), 0);
        f->now = T0;
        return f;
}

static int setup(void **state)
{
        *state = fixture_new(NULL);
        return 0;
}

static int teardown(void **state)
{
        free(*state);
        return 0;
}

/* ---- Driving the engine ------------------------------------------------------------------ */

static bool has_action(const struct fixture *f, enum agility_action_kind kind)
{
        for (unsigned i = 0; i < f->acts.count; i++)
                if (f->acts.a[i].kind == kind)
                        return true;
        return false;
}

static bool has_notice(const struct fixture *f, enum agility_notice n, uint32_t device)
{
        for (unsigned i = 0; i < f->acts.count; i++)
                if (f->acts.a[i].kind == AGILITY_ACT_NOTICE && f->acts.a[i].notice == n &&
                    f->acts.a[i].device == device)
                        return true;
        return false;
}

/* A key pressed and released on device (two actions). */
static void key(struct fixture *f, uint32_t dev, uint16_t k)
{
        agility_run_action(&f->run, f->now, dev, true, k, false, 0, &f->acts);
        struct agility_actions press = f->acts;

        agility_run_action(&f->run, f->now, dev, true, 0, false, 0, &f->acts);
        f->acts = press;                /* the release never acts: keep the press's actions */
}

/* A time sensor passage: sensor time s, received at now + latency. */
static void gate(struct fixture *f, uint32_t dev, uint32_t s)
{
        agility_run_action(&f->run, f->now, dev, false, 0, true, s, &f->acts);
}

static void sync_all(struct fixture *f)
{
        const uint32_t gates[] = { START, FINISH, I1, I2, I3 };

        for (size_t i = 0; i < 5; i++)
                agility_run_sync_device(&f->run, f->now, gates[i], true, &f->acts);
        agility_run_sync_done(&f->run, f->now, &f->acts);
}

static enum agility_state st(const struct fixture *f)
{
        return f->run.state;
}

/* Inputs of the transition table. */
enum input {
        IN_READY, IN_START, IN_I1, IN_I2, IN_I3, IN_FINISH, IN_RESET, IN_SYNC_OK, IN_SYNC_FAIL,
        IN_ABORT, IN_COUNT
};

static void apply(struct fixture *f, enum input in)
{
        switch (in) {
        case IN_READY: key(f, REMOTE, CIRCE_KEY_READY); break;
        case IN_START: gate(f, START, (uint32_t)(f->now % 1000000)); break;
        case IN_I1: gate(f, I1, (uint32_t)(f->now % 1000000)); break;
        case IN_I2: gate(f, I2, (uint32_t)(f->now % 1000000)); break;
        case IN_I3: gate(f, I3, (uint32_t)(f->now % 1000000)); break;
        case IN_FINISH: gate(f, FINISH, (uint32_t)(f->now % 1000000)); break;
        case IN_RESET: key(f, REMOTE, CIRCE_KEY_RESET_RUN); break;
        case IN_SYNC_OK: sync_all(f); break;
        case IN_SYNC_FAIL: agility_run_sync_done(&f->run, f->now, &f->acts); break;
        case IN_ABORT: agility_run_abort(&f->run, f->now, &f->acts); break;
        case IN_COUNT: break;
        }
        f->now += 5000;
}

/* Drives a fresh engine into state s along the legal path. */
static void reach(struct fixture *f, enum agility_state s)
{
        static const enum input path[] = { IN_READY, IN_SYNC_OK, IN_START, IN_I1, IN_I2,
                                           IN_I3, IN_FINISH, IN_READY };

        if (s == AGILITY_OFFLINE)
                return;
        agility_run_start_class(&f->run, f->now, &f->acts);
        for (size_t i = 0; st(f) != s && i < sizeof(path) / sizeof(path[0]); i++)
                apply(f, path[i]);
        assert_int_equal(st(f), s);
}

#define OFF AGILITY_OFFLINE
#define SET AGILITY_SETUP_COMPLETED
#define WAI AGILITY_WAITING_FOR_SYNC
#define RDY AGILITY_READY_TO_START
#define STA AGILITY_START_PASSED
#define IP1 AGILITY_INTERMEDIATE1_PASSED
#define IP2 AGILITY_INTERMEDIATE2_PASSED
#define IP3 AGILITY_INTERMEDIATE3_PASSED
#define FIN AGILITY_FINISH_PASSED
#define CMP AGILITY_RUN_COMPLETED

/* [from][input] -> to. Columns: Ready, start, int 1, 2, 3, finish, reset run, sync ok,
 * sync failed, abort. */
static const enum agility_state transitions[AGILITY_STATE_COUNT][IN_COUNT] = {
        [OFF] = { OFF, OFF, OFF, OFF, OFF, OFF, OFF, OFF, OFF, OFF },
        [SET] = { WAI, SET, SET, SET, SET, SET, SET, SET, SET, OFF },
        [WAI] = { WAI, WAI, WAI, WAI, WAI, WAI, WAI, RDY, SET, OFF },
        [RDY] = { WAI, STA, RDY, RDY, RDY, RDY, RDY, RDY, RDY, OFF },
        [STA] = { STA, STA, IP1, STA, STA, FIN, RDY, STA, STA, OFF },
        [IP1] = { IP1, IP1, IP1, IP2, IP1, FIN, RDY, IP1, IP1, OFF },
        [IP2] = { IP2, IP2, IP2, IP2, IP3, FIN, RDY, IP2, IP2, OFF },
        [IP3] = { IP3, IP3, IP3, IP3, IP3, FIN, RDY, IP3, IP3, OFF },
        [FIN] = { CMP, FIN, FIN, FIN, FIN, FIN, RDY, FIN, FIN, OFF },
        [CMP] = { WAI, CMP, CMP, CMP, CMP, CMP, CMP, CMP, CMP, OFF },
};

static void test_transitions(void **state)
{
        (void)state;
        for (int s = 0; s < AGILITY_STATE_COUNT; s++) {
                for (int in = 0; in < IN_COUNT; in++) {
                        struct fixture *f = fixture_new(NULL);

                        reach(f, (enum agility_state)s);
                        apply(f, (enum input)in);
                        print_message("%s + input %d\n", agility_run_state_name(s), in);
                        assert_int_equal(st(f), transitions[s][in]);
                        /* A passage the state refuses is said so. */
                        if (in >= IN_START && in <= IN_FINISH && st(f) == (enum agility_state)s)
                                assert_true(f->acts.count > 0 &&
                                            f->acts.a[0].kind == AGILITY_ACT_NOTICE &&
                                            f->acts.a[0].notice == AGILITY_NOTICE_OUT_OF_ORDER);
                        free(f);
                }
        }
}

/* The specification's example: Ready, start at sensor time 5000, finish at 32000: 27.000 s. */
static void test_spec_example(void **state)
{
        struct fixture *f = *state;
        struct agility_run_view v;

        agility_run_start_class(&f->run, f->now, &f->acts);
        assert_int_equal(st(f), SET);
        assert_int_equal(f->run.current, 1);            /* the lowest number starts */
        assert_int_equal(agility_run_next(&f->run), 2);
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(st(f), WAI);
        assert_true(has_action(f, AGILITY_ACT_SYNC_CLOCKS));
        sync_all(f);
        assert_int_equal(st(f), RDY);
        gate(f, START, 5000);
        assert_int_equal(st(f), STA);
        f->now += 27015;                /* the finish arrives 27.015 s later */
        gate(f, FINISH, 32000);
        assert_int_equal(st(f), FIN);
        agility_run_view(&f->run, f->now, &v);
        assert_int_equal(v.elapsed_ms, 27000);
        assert_int_equal(v.precision, AGILITY_PRECISION_HIGH);
        assert_true(v.finished);
        assert_false(v.eliminated);
        /* Ready completes the run: stored before the state and display move on. */
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(st(f), CMP);
        assert_true(f->acts.count >= 3);
        assert_int_equal(f->acts.a[0].kind, AGILITY_ACT_STORE_RESULT);
        assert_int_equal(f->acts.a[1].kind, AGILITY_ACT_STATE);
        assert_int_equal(f->acts.a[f->acts.count - 1].kind, AGILITY_ACT_DISPLAY);
        struct agility_result *r = &f->res[f->acts.a[0].index];

        assert_int_equal(r->competitor, 1);
        assert_true(r->completed && r->finished && !r->eliminated);
        assert_int_equal(r->finish_ms, 27000);
        assert_int_equal(r->finish_precision, AGILITY_PRECISION_HIGH);
        assert_int_equal(r->placement, 1);
        assert_int_equal(r->penalty_ms, 0);
        /* Ready again: the next competitor, and a new sync. */
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(st(f), WAI);
        assert_int_equal(f->run.current, 2);
        assert_int_equal(agility_run_next(&f->run), 3);
}

/* A run across the sensor clock's wrap keeps high precision. */
static void test_wrap(void **state)
{
        struct fixture *f = *state;
        struct agility_run_view v;

        reach(f, RDY);
        gate(f, START, 990000);
        f->now += 27000;
        gate(f, FINISH, 17000);
        agility_run_view(&f->run, f->now, &v);
        assert_int_equal(v.elapsed_ms, 27000);
        assert_int_equal(v.precision, AGILITY_PRECISION_HIGH);
}

/* Intermediates: strictly in order, each timed from the start. */
static void test_intermediates(void **state)
{
        struct fixture *f = *state;
        struct agility_run_view v;

        reach(f, RDY);
        gate(f, START, 1000);
        f->now += 5000;
        gate(f, I2, 6000);              /* out of order: ignored */
        assert_true(has_notice(f, AGILITY_NOTICE_OUT_OF_ORDER, I2));
        gate(f, I1, 6000);
        f->now += 5000;
        gate(f, I1, 11000);             /* the same gate twice */
        assert_true(has_notice(f, AGILITY_NOTICE_OUT_OF_ORDER, I1));
        gate(f, I2, 11000);
        agility_run_view(&f->run, f->now, &v);
        assert_int_equal(st(f), IP2);
        assert_int_equal(v.intermediates, 2);
        assert_int_equal(v.intermediate_ms[0], 5000);
        assert_int_equal(v.intermediate_ms[1], 10000);
        /* Finish without the third: allowed from any intermediate. */
        f->now += 5000;
        gate(f, FINISH, 16000);
        assert_int_equal(st(f), FIN);
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(f->res[1].intermediates, 2);
        assert_int_equal(f->res[1].intermediate_ms[1], 10000);
}

/* A class with fewer intermediates ignores the others' gates (not part of the class). */
static void test_fewer_intermediates(void **state)
{
        struct agility_class cls = default_class();
        struct fixture *f;

        (void)state;
        cls.intermediates = 1;
        f = fixture_new(&cls);
        reach(f, RDY);
        gate(f, START, 0);
        gate(f, I1, 100);
        assert_int_equal(st(f), IP1);
        gate(f, I2, 200);
        assert_int_equal(st(f), IP1);
        assert_true(has_notice(f, AGILITY_NOTICE_UNKNOWN_DEVICE, I2));
        free(f);
}

/* The start and the finish gate each triggering twice. */
static void test_gate_twice(void **state)
{
        struct fixture *f = *state;
        struct agility_run_view v;

        reach(f, RDY);
        gate(f, START, 5000);
        f->now += 300;
        gate(f, START, 5300);
        assert_int_equal(st(f), STA);
        assert_true(has_notice(f, AGILITY_NOTICE_OUT_OF_ORDER, START));
        assert_int_equal(f->run.start.sensor_ms, 5000);         /* the first start counts */
        f->now += 26700;
        gate(f, FINISH, 32000);
        f->now += 200;
        gate(f, FINISH, 32200);
        assert_true(has_notice(f, AGILITY_NOTICE_OUT_OF_ORDER, FINISH));
        agility_run_view(&f->run, f->now, &v);
        assert_int_equal(v.elapsed_ms, 27000);
}

/* One gate for start and finish: a second passage within the minimum delay is the dog still
 * going through it, not the finish. */
static void test_combined_gate(void **state)
{
        struct agility_class cls = default_class();
        struct agility_run_view v;
        struct fixture *f;

        (void)state;
        cls.combined = true;
        cls.finish = 0;
        cls.intermediates = 0;
        cls.min_delay_ms = AGILITY_MIN_DELAY_DEFAULT_MS;
        f = fixture_new(&cls);
        agility_run_start_class(&f->run, f->now, &f->acts);
        key(f, REMOTE, CIRCE_KEY_READY);
        agility_run_sync_device(&f->run, f->now, START, true, &f->acts);
        assert_int_equal(st(f), RDY);                   /* the only gate */
        gate(f, START, 10000);
        assert_int_equal(st(f), STA);
        f->now += 2999;
        gate(f, START, 12999);
        assert_int_equal(st(f), STA);
        assert_true(has_notice(f, AGILITY_NOTICE_TOO_SOON, START));
        f->now += 1;
        gate(f, START, 13000);
        assert_int_equal(st(f), FIN);
        agility_run_view(&f->run, f->now, &v);
        assert_int_equal(v.elapsed_ms, 3000);
        assert_int_equal(v.precision, AGILITY_PRECISION_HIGH);
        free(f);
}

/* Unsynchronised gates: the received times decide, low precision. */
static void test_low_precision(void **state)
{
        struct fixture *f = *state;
        struct agility_run_view v;

        reach(f, RDY);
        /* The finish gate restarted since the sync (027:1). */
        agility_run_sync_lost(&f->run, f->now, FINISH, &f->acts);
        gate(f, START, 5000);
        f->now += 27040;
        gate(f, FINISH, 32000);
        agility_run_view(&f->run, f->now, &v);
        assert_int_equal(v.elapsed_ms, 27040);
        assert_int_equal(v.precision, AGILITY_PRECISION_LOW);
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(f->res[1].finish_precision, AGILITY_PRECISION_LOW);
        /* The next run: the finish gate asks for a sync while it is under way and then
         * succeeds: synchronised again, high precision. */
        key(f, REMOTE, CIRCE_KEY_READY);
        agility_run_sync_lost(&f->run, f->now, FINISH, &f->acts);
        sync_all(f);
        gate(f, START, 5000);
        f->now += 27040;
        gate(f, FINISH, 32000);
        agility_run_view(&f->run, f->now, &v);
        assert_int_equal(v.elapsed_ms, 27000);
        assert_int_equal(v.precision, AGILITY_PRECISION_HIGH);
}

/* A sensor time that disagrees with the received times by 4 s or more is not used. */
static void test_disagreeing_sensor(void **state)
{
        struct fixture *f = *state;
        struct agility_run_view v;

        reach(f, RDY);
        gate(f, START, 5000);
        f->now += 27000;
        gate(f, FINISH, 36000);         /* says 31 s */
        agility_run_view(&f->run, f->now, &v);
        assert_int_equal(v.elapsed_ms, 27000);
        assert_int_equal(v.precision, AGILITY_PRECISION_LOW);
}

/* A remote configured as the start and finish gate: its pass keys time the run (low
 * precision: a hand pressed them); a remote that is not a gate gets a notice. */
static void test_pass_keys(void **state)
{
        struct agility_class cls = default_class();
        struct agility_run_view v;
        struct fixture *f;

        (void)state;
        cls.start = REMOTE;
        cls.intermediates = 1;
        cls.intermediate[0] = 0xBBBBBBu;
        f = fixture_new(&cls);
        agility_run_start_class(&f->run, f->now, &f->acts);
        key(f, REMOTE, CIRCE_KEY_READY);
        agility_run_sync_device(&f->run, f->now, REMOTE, true, &f->acts);
        agility_run_sync_device(&f->run, f->now, FINISH, true, &f->acts);
        agility_run_sync_device(&f->run, f->now, 0xBBBBBBu, true, &f->acts);
        assert_int_equal(st(f), RDY);
        /* Pass finish from the start remote: not its gate. */
        key(f, REMOTE, CIRCE_KEY_PASS_FINISH);
        assert_true(has_notice(f, AGILITY_NOTICE_NOT_GATE, REMOTE));
        agility_run_action(&f->run, f->now, REMOTE, true, CIRCE_KEY_PASS_START, true, 1000,
                           &f->acts);
        agility_run_action(&f->run, f->now, REMOTE, true, 0, false, 0, &f->acts);
        assert_int_equal(st(f), STA);
        f->now += 4000;
        /* The intermediate remote is not a keypad, but its key 2 is its passage. */
        agility_run_action(&f->run, f->now, 0xBBBBBBu, true, CIRCE_KEY_2, true, 5000,
                           &f->acts);
        assert_int_equal(st(f), IP1);
        /* Its Ready is refused: not a keypad. */
        agility_run_action(&f->run, f->now, 0xBBBBBBu, true, CIRCE_KEY_READY, false, 0,
                           &f->acts);
        assert_true(has_notice(f, AGILITY_NOTICE_NOT_KEYPAD, 0xBBBBBBu));
        f->now += 4000;
        gate(f, FINISH, 9000);
        agility_run_view(&f->run, f->now, &v);
        assert_int_equal(v.elapsed_ms, 8000);
        assert_int_equal(v.precision, AGILITY_PRECISION_LOW);
        assert_int_equal(v.intermediate_ms[0], 4000);
        free(f);
}

/* Keys from a device that is no keypad: the gate's Ready does nothing; a stranger's action
 * is refused whole. */
static void test_not_keypad(void **state)
{
        struct fixture *f = *state;

        agility_run_start_class(&f->run, f->now, &f->acts);
        key(f, START, CIRCE_KEY_READY);
        assert_int_equal(st(f), SET);
        assert_true(has_notice(f, AGILITY_NOTICE_NOT_KEYPAD, START));
        key(f, STRANGER, CIRCE_KEY_READY);
        assert_int_equal(st(f), SET);
        assert_true(has_notice(f, AGILITY_NOTICE_UNKNOWN_DEVICE, STRANGER));
        gate(f, STRANGER, 5000);
        assert_true(has_notice(f, AGILITY_NOTICE_UNKNOWN_DEVICE, STRANGER));
        /* A gate action without a sensor time. */
        reach(f, RDY);
        agility_run_action(&f->run, f->now, START, false, 0, false, 0, &f->acts);
        assert_true(has_notice(f, AGILITY_NOTICE_NO_TIME, START));
        assert_int_equal(st(f), RDY);
        /* A keypad action without keys: nothing. */
        agility_run_action(&f->run, f->now, REMOTE, false, 0, true, 5, &f->acts);
        assert_int_equal(st(f), RDY);
}

/* Every scoring key: faults and refusals in steps of 5 with their limits, the elimination
 * toggle, three refusals, reset. */
struct key_case {
        uint16_t key;
        uint8_t faults, refusals;
        bool manual;
        uint8_t want_faults, want_refusals;
        bool want_eliminated;
};

static const struct key_case key_cases[] = {
        { CIRCE_KEY_9, 0, 0, false, 5, 0, false },
        { CIRCE_KEY_9, 90, 0, false, 95, 0, false },
        { CIRCE_KEY_9, 95, 0, false, 95, 0, false },            /* at most 95 */
        { CIRCE_KEY_8, 10, 0, false, 5, 0, false },
        { CIRCE_KEY_8, 0, 0, false, 0, 0, false },              /* not below 0 */
        { CIRCE_KEY_6, 0, 0, false, 0, 5, false },
        { CIRCE_KEY_6, 0, 10, false, 0, 15, true },             /* the third eliminates */
        { CIRCE_KEY_6, 0, 15, false, 0, 15, true },
        { CIRCE_KEY_5, 0, 15, false, 0, 10, false },            /* and taking it back too */
        { CIRCE_KEY_5, 0, 0, false, 0, 0, false },
        { CIRCE_KEY_3, 0, 0, false, 0, 0, true },               /* toggle on */
        { CIRCE_KEY_3, 5, 5, true, 5, 5, false },               /* and off */
        { CIRCE_KEY_RESET_RUN, 30, 10, true, 0, 0, false },
        { CIRCE_KEY_1, 5, 5, false, 5, 5, false },              /* keys without a command */
        { CIRCE_KEY_4, 5, 5, false, 5, 5, false },
        { CIRCE_KEY_7, 5, 5, false, 5, 5, false },
        { CIRCE_KEY_0, 5, 5, false, 5, 5, false },
        { CIRCE_KEY_2, 5, 5, false, 5, 5, false },              /* a remote: not a gate */
};

static void test_keys(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(key_cases) / sizeof(key_cases[0]); i++) {
                const struct key_case *c = &key_cases[i];
                struct fixture *f = fixture_new(NULL);
                struct agility_run_view v;

                print_message("key case %zu\n", i);
                reach(f, STA);
                f->run.faults = c->faults;
                f->run.refusals = c->refusals;
                f->run.manual_eliminated = c->manual;
                key(f, REMOTE, c->key);
                agility_run_view(&f->run, f->now, &v);
                assert_int_equal(v.faults, c->want_faults);
                assert_int_equal(v.refusals, c->want_refusals);
                assert_int_equal(v.eliminated, c->want_eliminated);
                free(f);
        }
}

/* Scoring keys do nothing before the run is ready. */
static void test_keys_outside_run(void **state)
{
        struct fixture *f = *state;

        agility_run_start_class(&f->run, f->now, &f->acts);
        key(f, REMOTE, CIRCE_KEY_9);
        key(f, REMOTE, CIRCE_KEY_6);
        key(f, REMOTE, CIRCE_KEY_3);
        assert_int_equal(f->run.faults, 0);
        assert_int_equal(f->run.refusals, 0);
        assert_false(f->run.manual_eliminated);
        /* In ReadyToStart they count (a fault before the start line). */
        reach(f, RDY);
        key(f, REMOTE, CIRCE_KEY_9);
        assert_int_equal(f->run.faults, 5);
}

/* An eliminated run completes on Ready before the finish; a clean one does not. */
static void test_eliminated_completes(void **state)
{
        struct fixture *f = *state;

        reach(f, STA);
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(st(f), STA);
        key(f, REMOTE, CIRCE_KEY_6);
        key(f, REMOTE, CIRCE_KEY_6);
        key(f, REMOTE, CIRCE_KEY_6);
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(st(f), CMP);
        assert_true(f->res[1].eliminated);
        assert_false(f->res[1].finished);
        assert_int_equal(f->res[1].refusals, 15);
        assert_int_equal(f->res[1].placement, 0);
}

/* The maximum course time eliminates on the clock, but a finish measured within it wins. */
static void test_max_course_time(void **state)
{
        struct fixture *f = *state;
        struct agility_run_view v;

        reach(f, RDY);
        uint64_t t = f->now;

        gate(f, START, 0);
        assert_int_equal(agility_run_next_deadline(&f->run), t + MAXT + 1);
        f->now = t + MAXT;
        agility_run_tick(&f->run, f->now, &f->acts);
        assert_false(f->run.time_eliminated);
        f->now = t + MAXT + 1;
        agility_run_tick(&f->run, f->now, &f->acts);
        assert_true(has_notice(f, AGILITY_NOTICE_MAX_COURSE_TIME, 0));
        assert_true(has_action(f, AGILITY_ACT_DISPLAY));
        agility_run_view(&f->run, f->now, &v);
        assert_true(v.eliminated);
        assert_int_equal(agility_run_next_deadline(&f->run), UINT64_MAX);
        /* The finish passage was on its way: its sensor says 59.990 s. */
        f->now += 50;
        gate(f, FINISH, 59990);
        agility_run_view(&f->run, f->now, &v);
        assert_int_equal(v.elapsed_ms, 59990);
        assert_false(v.eliminated);
        /* Reset, and a finish that is over. */
        key(f, REMOTE, CIRCE_KEY_RESET_RUN);
        t = f->now;
        gate(f, START, 100000);
        f->now = t + MAXT + 500;
        gate(f, FINISH, 100000 + MAXT + 500);
        agility_run_view(&f->run, f->now, &v);
        assert_true(v.eliminated);
}

/* Clock synchronisation: a gate that does not answer sends the class back to setup (the
 * reference goes offline); Ready tries again with the same competitor. */
static void test_sync_failure(void **state)
{
        struct fixture *f = *state;

        agility_run_start_class(&f->run, f->now, &f->acts);
        key(f, REMOTE, CIRCE_KEY_READY);
        agility_run_sync_device(&f->run, f->now, START, true, &f->acts);
        agility_run_sync_device(&f->run, f->now, REMOTE, true, &f->acts);   /* not a gate */
        agility_run_sync_device(&f->run, f->now, FINISH, false, &f->acts);
        assert_int_equal(st(f), WAI);
        agility_run_sync_done(&f->run, f->now, &f->acts);
        assert_int_equal(st(f), SET);
        assert_true(has_notice(f, AGILITY_NOTICE_SYNC_FAILED, FINISH));
        assert_int_equal(f->run.current, 1);
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(st(f), WAI);
        assert_int_equal(f->run.current, 1);
        /* A late result after the sync ended changes nothing. */
        sync_all(f);
        assert_int_equal(st(f), RDY);
        agility_run_sync_device(&f->run, f->now, FINISH, false, &f->acts);
        assert_int_equal(st(f), RDY);
}

/* A sync grows old while the class waits: recommended after 10 min, required after 15. */
static void test_sync_age(void **state)
{
        struct fixture *f = *state;
        uint64_t t;

        reach(f, RDY);
        t = f->now - 5000;              /* apply() moved the clock on after the sync */
        assert_int_equal(agility_run_next_deadline(&f->run), t + AGILITY_SYNC_RECOMMEND_MS);
        agility_run_tick(&f->run, t + AGILITY_SYNC_RECOMMEND_MS - 1, &f->acts);
        assert_int_equal(f->acts.count, 0);
        agility_run_tick(&f->run, t + AGILITY_SYNC_RECOMMEND_MS, &f->acts);
        assert_true(has_notice(f, AGILITY_NOTICE_SYNC_RECOMMENDED, 0));
        agility_run_tick(&f->run, t + AGILITY_SYNC_RECOMMEND_MS + 1, &f->acts);
        assert_int_equal(f->acts.count, 0);     /* said once */
        assert_int_equal(agility_run_next_deadline(&f->run), t + AGILITY_SYNC_REQUIRE_MS);
        /* At the limit the class is back in setup before the start is looked at. */
        f->now = t + AGILITY_SYNC_REQUIRE_MS;
        gate(f, START, 5000);
        assert_int_equal(st(f), SET);
        assert_true(has_notice(f, AGILITY_NOTICE_SYNC_REQUIRED, 0));
        assert_int_equal(agility_run_next_deadline(&f->run), UINT64_MAX);
}

/* A reset into ReadyToStart long after the sync: the old sync is caught at once, not at the
 * next call (found by fuzz_agility_run: the deadline was already past). */
static void test_sync_age_on_reset(void **state)
{
        struct agility_class cls = default_class();
        struct fixture *f;

        (void)state;
        cls.max_course_time_ms = 0;
        f = fixture_new(&cls);
        reach(f, STA);
        f->now += AGILITY_SYNC_REQUIRE_MS;
        key(f, REMOTE, CIRCE_KEY_RESET_RUN);
        assert_int_equal(st(f), SET);
        assert_true(has_notice(f, AGILITY_NOTICE_SYNC_REQUIRED, 0));
        assert_true(agility_run_next_deadline(&f->run) > f->now);
        free(f);
}

/* Ready in ReadyToStart resyncs on demand. */
static void test_resync_on_ready(void **state)
{
        struct fixture *f = *state;

        reach(f, RDY);
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(st(f), WAI);
        assert_true(has_action(f, AGILITY_ACT_SYNC_CLOCKS));
}

/* Entering the current and the next competitor on the remote. */
static void test_entry(void **state)
{
        struct fixture *f = *state;
        const uint16_t cur = CIRCE_KEY_ENTER_CURRENT, next = CIRCE_KEY_ENTER_NEXT;
        struct agility_display d;

        agility_run_start_class(&f->run, f->now, &f->acts);
        agility_run_action(&f->run, f->now, REMOTE, true, cur, false, 0, &f->acts);
        agility_run_action(&f->run, f->now, REMOTE, true, cur | CIRCE_KEY_4, false, 0,
                           &f->acts);
        /* The number shows while it is typed. */
        agility_run_display(&f->run, &d);
        assert_int_equal(d.current, 4);
        assert_true(has_action(f, AGILITY_ACT_DISPLAY));
        agility_run_action(&f->run, f->now, REMOTE, true, 0, false, 0, &f->acts);
        assert_int_equal(f->run.current, 4);
        /* The next after 4 wraps to the first open one. */
        assert_int_equal(agility_run_next(&f->run), 1);
        /* 3 while "next" is held is a digit, not the elimination toggle. */
        agility_run_action(&f->run, f->now, REMOTE, true, next | CIRCE_KEY_3, false, 0,
                           &f->acts);
        agility_run_action(&f->run, f->now, REMOTE, true, next, false, 0, &f->acts);
        agility_run_action(&f->run, f->now, REMOTE, true, 0, false, 0, &f->acts);
        assert_int_equal(agility_run_next(&f->run), 3);
        /* An unknown number: refused, said so. */
        agility_run_action(&f->run, f->now, REMOTE, true, cur | CIRCE_KEY_9, false, 0,
                           &f->acts);
        agility_run_action(&f->run, f->now, REMOTE, true, 0, false, 0, &f->acts);
        assert_true(has_notice(f, AGILITY_NOTICE_UNKNOWN_COMPETITOR, 0));
        assert_int_equal(f->run.current, 4);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.current, 4);
        /* Choosing the typed next as current clears the typed next. */
        agility_run_action(&f->run, f->now, REMOTE, true, cur | CIRCE_KEY_3, false, 0,
                           &f->acts);
        agility_run_action(&f->run, f->now, REMOTE, true, 0, false, 0, &f->acts);
        assert_int_equal(f->run.current, 3);
        assert_int_equal(f->run.next_typed, 0);
        assert_int_equal(agility_run_next(&f->run), 4);
        /* The run goes to the typed competitor: Ready, run, Ready, Ready -> 4. */
        reach(f, CMP);
        assert_int_equal(f->res[0].competitor, 3);
        assert_true(f->res[0].completed);
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(f->run.current, 4);
}

/* A class resumed after a restart: the run after the last completed one starts, and the
 * previous placement is shown. */
static void test_resume(void **state)
{
        struct fixture *f = *state;
        struct agility_display d;

        (void)state;
        f->res[2] = (struct agility_result){ .completed = true, .finished = true,
                                             .finish_ms = 30000 };     /* number 2 */
        assert_int_equal(agility_run_init(&f->run, &f->cls, f->comp, NCOMP, f->res, 2), 0);
        assert_int_equal(f->res[2].competitor, 2);
        assert_int_equal(f->res[2].placement, 1);
        agility_run_start_class(&f->run, f->now, &f->acts);
        assert_int_equal(f->run.current, 3);
        assert_int_equal(agility_run_next(&f->run), 4);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.placement, 1);
        assert_int_equal(d.current, 3);
        assert_int_equal(d.next, 4);
        /* Number 2 chosen again: its earlier run is shown until something changes. */
        reach(f, RDY);
        agility_run_action(&f->run, f->now, REMOTE, true, CIRCE_KEY_ENTER_CURRENT | CIRCE_KEY_2,
                           false, 0, &f->acts);
        agility_run_action(&f->run, f->now, REMOTE, true, 0, false, 0, &f->acts);
        assert_int_equal(f->run.current, 2);
        assert_true(f->run.showing_existing);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.primary_ms, 30000);
        assert_int_equal(d.faults, 0);
        key(f, REMOTE, CIRCE_KEY_9);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.primary_ms, 0);
        assert_int_equal(d.faults, 5);
}

/* After the last competitor, Ready ends the class. */
static void test_class_completed(void **state)
{
        struct fixture *f = *state;

        for (int i = 0; i < NCOMP - 1; i++)
                f->res[i].completed = true;
        assert_int_equal(agility_run_init(&f->run, &f->cls, f->comp, NCOMP, f->res, 0), 0);
        reach(f, CMP);
        assert_int_equal(f->res[3].competitor, 4);
        assert_true(f->res[3].completed);
        assert_int_equal(agility_run_next(&f->run), 0);
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(st(f), OFF);
        assert_true(has_notice(f, AGILITY_NOTICE_CLASS_COMPLETED, 0));
}

/* What the displays are asked to show along a run, and that an unchanged display is not
 * updated. */
static void test_display_flow(void **state)
{
        struct fixture *f = *state;
        struct agility_display d;

        agility_run_display(&f->run, &d);
        assert_int_equal(d.current, AGILITY_HIDDEN_NUMBER);
        assert_int_equal(d.faults, AGILITY_HIDDEN_COUNT);
        agility_run_start_class(&f->run, f->now, &f->acts);
        assert_true(has_action(f, AGILITY_ACT_DISPLAY));
        agility_run_display(&f->run, &d);
        assert_int_equal(d.current, 1);
        assert_int_equal(d.next, 2);
        assert_int_equal(d.primary_ms, AGILITY_HIDDEN_TIME);
        assert_int_equal(d.placement, AGILITY_HIDDEN_NUMBER);
        agility_run_tick(&f->run, f->now, &f->acts);
        assert_false(has_action(f, AGILITY_ACT_DISPLAY));
        reach(f, RDY);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.timer, AGILITY_TIMER_VALUE);
        assert_int_equal(d.primary_ms, 0);
        assert_int_equal(d.faults, 0);
        assert_int_equal(d.refusals, 0);
        assert_int_equal(d.secondary_ms, AGILITY_HIDDEN_TIME);
        gate(f, START, 1000);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.timer, AGILITY_TIMER_RUNNING);
        uint32_t run_id = d.run;

        f->now += 4000;
        gate(f, I1, 5000);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.secondary_ms, 4000);
        assert_int_equal(d.run, run_id);
        f->now += 4000;
        gate(f, FINISH, 9000);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.timer, AGILITY_TIMER_VALUE);
        assert_int_equal(d.primary_ms, 8000);
        assert_int_equal(d.secondary_ms, 4000);
        key(f, REMOTE, CIRCE_KEY_READY);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.placement, 1);
        assert_int_equal(d.primary_ms, 8000);
        /* The next run: cleared while syncing, zero when ready, a new timer. */
        key(f, REMOTE, CIRCE_KEY_READY);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.current, 2);
        assert_int_equal(d.primary_ms, AGILITY_HIDDEN_TIME);
        assert_int_equal(d.faults, AGILITY_HIDDEN_COUNT);
        assert_int_equal(d.placement, 1);
        sync_all(f);
        gate(f, START, 1000);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.timer, AGILITY_TIMER_RUNNING);
        assert_true(d.run != run_id);
        /* Offline: everything hidden. */
        agility_run_abort(&f->run, f->now, &f->acts);
        agility_run_display(&f->run, &d);
        assert_int_equal(d.current, AGILITY_HIDDEN_NUMBER);
        assert_int_equal(d.placement, AGILITY_HIDDEN_NUMBER);
}

/* Two clean runs with the same time share first place; a slower one is second (1, 1, 2). */
static void test_shared_placement(void **state)
{
        struct fixture *f = *state;
        const uint32_t times[] = { 30000, 30000, 31000 };

        agility_run_start_class(&f->run, f->now, &f->acts);
        for (int i = 0; i < 3; i++) {
                key(f, REMOTE, CIRCE_KEY_READY);
                if (i > 0)
                        key(f, REMOTE, CIRCE_KEY_READY);
                sync_all(f);
                gate(f, START, 0);
                f->now += times[i];
                gate(f, FINISH, times[i]);
        }
        key(f, REMOTE, CIRCE_KEY_READY);
        assert_int_equal(f->res[1].placement, 1);       /* number 1 */
        assert_int_equal(f->res[2].placement, 1);       /* number 2 */
        assert_int_equal(f->res[0].placement, 2);       /* number 3 */
        assert_int_equal(f->res[3].placement, 0);       /* number 4: no run */
        assert_int_equal(f->run.order[0]->competitor, 1);
        assert_int_equal(f->run.order[2]->competitor, 3);
}

/* The scoreboard's running clock: from the start as received. */
static void test_view_running(void **state)
{
        struct fixture *f = *state;
        struct agility_run_view v;

        reach(f, RDY);
        gate(f, START, 1000);
        agility_run_view(&f->run, f->now + 12345, &v);
        assert_true(v.started);
        assert_false(v.finished);
        assert_int_equal(v.elapsed_ms, 12345);
        assert_int_equal(v.precision, AGILITY_PRECISION_LOW);
        assert_int_equal(v.current, 1);
        assert_int_equal(v.next, 2);
        assert_string_equal(agility_run_state_name(v.state), "StartPassed");
        assert_string_equal(agility_run_state_name(AGILITY_STATE_COUNT), "?");
        assert_string_equal(agility_run_notice_name(AGILITY_NOTICE_TOO_SOON), "too-soon");
        assert_string_equal(agility_run_notice_name(AGILITY_NOTICE_COUNT), "?");
}

/* A class that breaks the rules is refused. */
static void test_init_rejects(void **state)
{
        struct fixture *f = *state;
        struct agility_competitor dup[2] = { { .number = 5 }, { .number = 5 } };
        struct agility_competitor zero[1] = { { .number = 0 } };
        struct agility_class c;

        c = default_class();
        c.intermediates = 4;
        assert_int_equal(agility_run_init(&f->run, &c, f->comp, NCOMP, f->res, 0), -EINVAL);
        c = default_class();
        c.finish = START;                       /* one gate, two roles */
        assert_int_equal(agility_run_init(&f->run, &c, f->comp, NCOMP, f->res, 0), -EINVAL);
        c = default_class();
        c.intermediate[2] = 0;                  /* missing */
        assert_int_equal(agility_run_init(&f->run, &c, f->comp, NCOMP, f->res, 0), -EINVAL);
        c = default_class();
        c.start = CIRCE_ADDRESS_RESERVED;
        assert_int_equal(agility_run_init(&f->run, &c, f->comp, NCOMP, f->res, 0), -EINVAL);
        c = default_class();
        c.keypads[0] = 0;
        assert_int_equal(agility_run_init(&f->run, &c, f->comp, NCOMP, f->res, 0), -EINVAL);
        c = default_class();
        c.keypad_count = AGILITY_KEYPADS_MAX + 1;
        assert_int_equal(agility_run_init(&f->run, &c, f->comp, NCOMP, f->res, 0), -EINVAL);
        c = default_class();
        c.max_course_time_ms = SCT - 1;
        assert_int_equal(agility_run_init(&f->run, &c, f->comp, NCOMP, f->res, 0), -EINVAL);
        c = default_class();
        assert_int_equal(agility_run_init(&f->run, &c, f->comp, 0, f->res, 0), -EINVAL);
        assert_int_equal(agility_run_init(&f->run, &c, dup, 2, f->res, 0), -EINVAL);
        assert_int_equal(agility_run_init(&f->run, &c, zero, 1, f->res, 0), -EINVAL);
        /* A combined gate needs no finish; an unknown last competitor is forgotten. */
        c.combined = true;
        c.finish = 0;
        assert_int_equal(agility_run_init(&f->run, &c, f->comp, NCOMP, f->res, 77), 0);
        assert_int_equal(f->run.last_completed, 0);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_transitions),
#define T(name) cmocka_unit_test_setup_teardown(name, setup, teardown)
                T(test_spec_example),
                T(test_wrap),
                T(test_intermediates),
                T(test_fewer_intermediates),
                T(test_gate_twice),
                T(test_combined_gate),
                T(test_low_precision),
                T(test_disagreeing_sensor),
                T(test_pass_keys),
                T(test_not_keypad),
                T(test_keys),
                T(test_keys_outside_run),
                T(test_eliminated_completes),
                T(test_max_course_time),
                T(test_sync_failure),
                T(test_sync_age),
                T(test_sync_age_on_reset),
                T(test_resync_on_ready),
                T(test_entry),
                T(test_resume),
                T(test_class_completed),
                T(test_display_flow),
                T(test_shared_placement),
                T(test_view_running),
                T(test_init_rejects),
#undef T
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
