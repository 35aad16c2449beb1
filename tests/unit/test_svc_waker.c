/*
 * svc/waker: a change the daemon's side commits (real tables, the real library) reaches the
 * loop as one callback; a burst may coalesce, nothing is missed; stop joins the thread and takes
 * the fd off the loop. waker_start_with: on_thread runs on the waker's own thread with the loop
 * not running at all, and the loop hears of the change only when it asks; a spin budget above
 * SL_WAIT_SPIN_MAX_US is refused, one within it still delivers.
 */
#include <errno.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdbool.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <cmocka.h>

#include <sharedlink.h>

#include "common/harness.h"
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
        pthread_mutex_t m;              /* on_thread's record, below */
        pthread_cond_t cv;
        unsigned thread_calls;
        bool other_thread;              /* every on_thread call ran off the test's thread */
        bool ring;                      /* what on_thread returns */
        char seen[SL_VALUE_SIZE];       /* the value on_thread read */
        pthread_t main_thread;
};

static void on_change(void *arg)
{
        struct fixture *f = arg;

        f->calls++;
        evloop_exit(f->loop, 0);
}

static bool on_thread(void *arg)
{
        struct fixture *f = arg;
        char value[SL_VALUE_SIZE] = "";

        sl_read(f->c, sl_find(f->c, "AutoGpsLat"), value, sizeof(value), NULL);
        pthread_mutex_lock(&f->m);
        f->thread_calls++;
        if (pthread_equal(pthread_self(), f->main_thread))
                f->other_thread = false;
        memcpy(f->seen, value, sizeof(f->seen));
        pthread_cond_broadcast(&f->cv);
        pthread_mutex_unlock(&f->m);
        return f->ring;
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
        pthread_mutex_init(&f->m, NULL);
        pthread_cond_init(&f->cv, NULL);
        f->main_thread = pthread_self();
        f->other_thread = true;
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
        pthread_cond_destroy(&f->cv);
        pthread_mutex_destroy(&f->m);
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

/* Commits value, then waits (the loop not running) until on_thread has seen it. */
static void commit_and_wait_thread(struct fixture *f, const char *value)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)GUARD_MS * 1000000u;

        assert_int_equal(shm_table_set_str(f->tb.t, 0, value), 0);
        shm_table_commit(f->tb.t);
        pthread_mutex_lock(&f->m);
        while (strcmp(f->seen, value) != 0 && harness_now_ns() < deadline) {
                struct timespec until;

                clock_gettime(CLOCK_REALTIME, &until);
                until.tv_sec += 1;
                pthread_cond_timedwait(&f->cv, &f->m, &until);
        }
        assert_string_equal(f->seen, value);
        pthread_mutex_unlock(&f->m);
}

static void test_on_thread(void **state)
{
        struct fixture *f = *state;
        const struct waker_opts opts = { .on_thread = on_thread };
        struct waker *w = NULL;

        assert_int_equal(waker_start_with(f->loop, f->c, on_change, f, &opts, &w), 0);
        /* Not asked to ring: the thread did it all, the loop never ran and has nothing. */
        commit_and_wait_thread(f, "40.5");
        commit_and_wait_thread(f, "41.5");
        assert_true(f->other_thread);
        evloop_timer_arm(&f->guard, QUIET_MS, 0);
        assert_true(evloop_run(f->loop) >= 0);
        assert_true(f->timed_out);
        assert_int_equal(f->calls, 0);
        /* Asked to ring: the loop is called back as with waker_start. */
        f->timed_out = 0;
        pthread_mutex_lock(&f->m);
        f->ring = true;
        pthread_mutex_unlock(&f->m);
        commit_and_wait(f, "42.5");
        assert_true(f->calls >= 1);
        assert_true(f->other_thread);
        assert_null(waker_stop(w));
}

static void test_spin(void **state)
{
        struct fixture *f = *state;
        struct waker_opts opts = { .spin_us = SL_WAIT_SPIN_MAX_US + 1 };
        struct waker *w = NULL;

        assert_int_equal(waker_start_with(f->loop, f->c, on_change, f, &opts, &w), -EINVAL);
        assert_null(w);
        opts.spin_us = SL_WAIT_SPIN_MAX_US;
        assert_int_equal(waker_start_with(f->loop, f->c, on_change, f, &opts, &w), 0);
        commit_and_wait(f, "43.5");
        assert_null(waker_stop(w));
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_change_reaches_loop, setup, teardown),
                cmocka_unit_test_setup_teardown(test_stop, setup, teardown),
                cmocka_unit_test_setup_teardown(test_on_thread, setup, teardown),
                cmocka_unit_test_setup_teardown(test_spin, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
