/*
 * svc/waker: a change the daemon's side commits (real tables, the real library) reaches the
 * loop as one callback; a burst may coalesce, nothing is missed; stop joins the thread and takes
 * the fd off the loop.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <cmocka.h>

#include <sharedlink.h>

#include "common/shmtest.h"
#include "shm/table.h"
#include "svc/evloop.h"
#include "svc/waker.h"

#define GUARD_MS        20000   /* a test that never sees its change fails here, not hangs */
#define QUIET_MS        100     /* how long test_stop listens for a call that must not come */

static const struct shm_var vars[] = {
        { "AutoGpsLat", SHM_DIR_IN, SHM_TYPE_DOUBLE, 0, "A", 0 },
};

struct fixture {
        struct shmtest_table tb;
        struct sl_client *c;
        struct evloop *loop;
        struct evloop_timer guard;
        unsigned calls;
        int timed_out;
};

static void on_change(void *arg)
{
        struct fixture *f = arg;

        f->calls++;
        evloop_exit(f->loop, 0);
}

static void on_guard(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        struct fixture *f = arg;

        (void)t;
        f->timed_out = 1;
        evloop_exit(loop, 0);
}

static int setup(void **state)
{
        struct fixture *f = calloc(1, sizeof(*f));

        if (!f)
                return -1;
        *state = f;
        shmtest_table_init(&f->tb, "waker");
        shmtest_table_config(&f->tb, vars, 1, 0);
        if (shmtest_table_create(&f->tb) < 0 || sl_open(f->tb.instance, &f->c) < 0 ||
            evloop_new(&f->loop) < 0)
                return -1;
        evloop_timer_init(&f->guard, f->loop, on_guard, f);
        return 0;
}

static int teardown(void **state)
{
        struct fixture *f = *state;

        evloop_timer_cancel(&f->guard);
        f->loop = evloop_free(f->loop);
        sl_close(f->c);
        shmtest_table_destroy(&f->tb);
        free(f);
        return 0;
}

/* Commits value on the daemon's side, then runs the loop until the waker calls back. */
static void commit_and_wait(struct fixture *f, const char *value)
{
        unsigned before = f->calls;

        assert_int_equal(shm_table_set_str(f->tb.t, 0, value), 0);
        shm_table_commit(f->tb.t);
        evloop_timer_arm(&f->guard, GUARD_MS, 0);
        while (f->calls == before && !f->timed_out)
                assert_true(evloop_run(f->loop) >= 0);
        evloop_timer_cancel(&f->guard);
        assert_false(f->timed_out);
}

static void test_change_reaches_loop(void **state)
{
        struct fixture *f = *state;
        struct waker *w = NULL;
        char value[SL_VALUE_SIZE];

        assert_int_equal(waker_start(f->loop, f->c, on_change, f, &w), 0);
        assert_non_null(w);
        commit_and_wait(f, "40.5");
        assert_true(sl_read(f->c, sl_find(f->c, "AutoGpsLat"), value, sizeof(value), NULL) >= 0);
        assert_string_equal(value, "40.5");
        commit_and_wait(f, "41.5");             /* and the next one: the thread goes on */
        assert_true(f->calls >= 2);
        assert_null(waker_stop(w));
}

static void test_stop(void **state)
{
        struct fixture *f = *state;
        struct waker *w = NULL;

        assert_null(waker_stop(NULL));
        assert_int_equal(waker_start(f->loop, f->c, on_change, f, &w), 0);
        assert_null(waker_stop(w));             /* joins within a slice, fd off the loop */
        assert_int_equal(shm_table_set_str(f->tb.t, 0, "1"), 0);
        shm_table_commit(f->tb.t);
        /* Nothing may call back after the stop: run the loop until a timer ends it. */
        evloop_timer_arm(&f->guard, QUIET_MS, 0);
        assert_true(evloop_run(f->loop) >= 0);
        assert_true(f->timed_out);
        assert_int_equal(f->calls, 0);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_change_reaches_loop, setup, teardown),
                cmocka_unit_test_setup_teardown(test_stop, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
