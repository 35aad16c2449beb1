/*
 * agilityd_worker: jobs run off the loop, one at a time in submission order, and their results
 * come back on the loop in posting order with the job's kind and tag; a job that posts more than
 * the result ring holds waits for the loop and loses nothing; a full queue refuses and counts; a
 * stop never waits for a running job (it returns while the job is still blocked), drops and
 * counts what was queued, and the abandoned job's later post is refused; an idle worker stops
 * with nothing left. The jobs are the test's own (no daemon): a script in the job's link name.
 */
#include <errno.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <cmocka.h>

#include "agility/agilityd_worker.h"
#include "svc/evloop.h"

#define GUARD_MS        20000   /* a loop that never gets its results fails here, not hangs */
#define BLOCK_MAX_S     20      /* a blocking job ends by itself after this: a hang guard */
#define GOT_MAX         (AGILITYD_WORKER_RESULTS_MAX * 4)
#define MANY            (AGILITYD_WORKER_RESULTS_MAX * 3)       /* more than the ring holds */

struct fx {
        struct evloop *loop;
        struct evloop_timer guard;
        bool timed_out;
        struct agilityd_worker *w;
        struct agilityd_result got[GOT_MAX];
        unsigned n_got, want;
        pthread_mutex_t m;              /* the blocking job's record, below */
        pthread_cond_t cv;
        bool in_job;                    /* a blocking job started */
        bool release;                   /* it may end */
        bool job_ended;
        int last_post;                  /* what its post returned */
};

static struct fx *fx_of(void **state)
{
        return *state;
}

/* "block": waits for release, posts once (what that returns is recorded), ends. "devices:N":
 * N device results, then the end with err = -tag. */
static void exec_fake(const struct agilityd_job *job, struct agilityd_worker_post *post,
                      struct agilityd_result *ret_done, void *arg)
{
        struct fx *f = arg;
        struct agilityd_result res = { .kind = AGILITYD_RESULT_DEVICE };

        if (strcmp(job->link, "block") == 0) {
                struct timespec until;
                int r;

                clock_gettime(CLOCK_REALTIME, &until);
                until.tv_sec += BLOCK_MAX_S;
                pthread_mutex_lock(&f->m);
                f->in_job = true;
                pthread_cond_broadcast(&f->cv);
                while (!f->release &&
                       pthread_cond_timedwait(&f->cv, &f->m, &until) != ETIMEDOUT)
                        ;
                pthread_mutex_unlock(&f->m);
                r = agilityd_worker_post(post, &res);
                pthread_mutex_lock(&f->m);
                f->last_post = r;
                f->job_ended = true;
                pthread_cond_broadcast(&f->cv);
                pthread_mutex_unlock(&f->m);
                return;
        }
        unsigned n = (unsigned)atoi(job->link + strlen("devices:"));

        for (unsigned i = 0; i < n; i++) {
                struct agilityd_result d = { .kind = AGILITYD_RESULT_DEVICE,
                                             .succeeded = i % 2u == 0 };

                snprintf(d.addr, sizeof(d.addr), "%06X", i & 0xFFFFFFu);
                if (agilityd_worker_post(post, &d) < 0)
                        return;
        }
        ret_done->err = -(int)job->tag;
}

static void on_result(const struct agilityd_result *res, void *arg)
{
        struct fx *f = arg;

        if (f->n_got < GOT_MAX)
                f->got[f->n_got] = *res;
        f->n_got++;
        if (f->n_got >= f->want)
                evloop_exit(f->loop, 0);
}

static void on_guard(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        struct fx *f = arg;

        (void)t;
        f->timed_out = true;
        evloop_exit(loop, 0);
}

static int setup(void **state)
{
        struct fx *f = calloc(1, sizeof(*f));

        if (!f || evloop_new(&f->loop) < 0)
                return -1;
        evloop_timer_init(&f->guard, f->loop, on_guard, f);
        pthread_mutex_init(&f->m, NULL);
        pthread_cond_init(&f->cv, NULL);
        if (agilityd_worker_start(f->loop, exec_fake, f, on_result, f, &f->w) < 0)
                return -1;
        *state = f;
        return 0;
}

static int teardown(void **state)
{
        struct fx *f = *state;

        agilityd_worker_stop(f->w, NULL);
        /* An abandoned blocking job still uses f: let it end first. */
        pthread_mutex_lock(&f->m);
        f->release = true;
        pthread_cond_broadcast(&f->cv);
        while (f->in_job && !f->job_ended)
                pthread_cond_wait(&f->cv, &f->m);
        pthread_mutex_unlock(&f->m);
        evloop_timer_cancel(&f->guard);
        evloop_free(f->loop);
        pthread_cond_destroy(&f->cv);
        pthread_mutex_destroy(&f->m);
        free(f);
        return 0;
}

static void submit(struct fx *f, enum agilityd_job_kind kind, uint64_t tag, const char *script)
{
        struct agilityd_job job = { .kind = kind, .tag = tag };

        snprintf(job.link, sizeof(job.link), "%s", script);
        assert_int_equal(agilityd_worker_submit(f->w, &job), 0);
}

/* Runs the loop until want results in all came. */
static void pump(struct fx *f, unsigned want)
{
        f->want = want;
        assert_int_equal(evloop_timer_arm(&f->guard, GUARD_MS, 0), 0);
        if (f->n_got < want)
                evloop_run(f->loop);
        evloop_timer_cancel(&f->guard);
        if (f->timed_out)
                fail_msg("%u of %u results came", f->n_got, want);
}

static void wait_in_job(struct fx *f)
{
        pthread_mutex_lock(&f->m);
        while (!f->in_job)
                pthread_cond_wait(&f->cv, &f->m);
        pthread_mutex_unlock(&f->m);
}

static void test_results_in_order(void **state)
{
        struct fx *f = fx_of(state);
        static const struct {
                enum agilityd_result_kind kind;
                enum agilityd_job_kind job;
                uint64_t tag;
                const char *addr;
                int err;
        } want[] = {
                { AGILITYD_RESULT_DEVICE, AGILITYD_JOB_SYNC_CLOCKS, 1, "000000", 0 },
                { AGILITYD_RESULT_DEVICE, AGILITYD_JOB_SYNC_CLOCKS, 1, "000001", 0 },
                { AGILITYD_RESULT_DONE, AGILITYD_JOB_SYNC_CLOCKS, 1, "", -1 },
                { AGILITYD_RESULT_DONE, AGILITYD_JOB_VISUALIZE, 2, "", -2 },
                { AGILITYD_RESULT_DEVICE, AGILITYD_JOB_SYNC_CLOCKS, 3, "000000", 0 },
                { AGILITYD_RESULT_DONE, AGILITYD_JOB_SYNC_CLOCKS, 3, "", -3 },
        };

        submit(f, AGILITYD_JOB_SYNC_CLOCKS, 1, "devices:2");
        submit(f, AGILITYD_JOB_VISUALIZE, 2, "devices:0");
        submit(f, AGILITYD_JOB_SYNC_CLOCKS, 3, "devices:1");
        pump(f, sizeof(want) / sizeof(want[0]));
        assert_int_equal(f->n_got, sizeof(want) / sizeof(want[0]));
        for (size_t i = 0; i < sizeof(want) / sizeof(want[0]); i++) {
                const struct agilityd_result *g = &f->got[i];

                assert_int_equal(g->kind, want[i].kind);
                assert_int_equal(g->job, want[i].job);
                assert_int_equal(g->tag, want[i].tag);
                assert_string_equal(g->addr, want[i].addr);
                if (g->kind == AGILITYD_RESULT_DONE)
                        assert_int_equal(g->err, want[i].err);
                else
                        assert_int_equal(g->succeeded, strcmp(g->addr, "000000") == 0);
        }
}

/* One job posts three times what the ring holds while the loop is not running: it waits for
 * room, and every result arrives, in order. */
static void test_full_ring_waits(void **state)
{
        struct fx *f = fx_of(state);
        char script[32];

        snprintf(script, sizeof(script), "devices:%u", MANY);
        submit(f, AGILITYD_JOB_SYNC_CLOCKS, 7, script);
        pump(f, MANY + 1);
        for (unsigned i = 0; i < MANY; i++) {
                char addr[SL_CIRCE_ADDRESS_SIZE];

                snprintf(addr, sizeof(addr), "%06X", i & 0xFFFFFFu);
                assert_int_equal(f->got[i].kind, AGILITYD_RESULT_DEVICE);
                assert_string_equal(f->got[i].addr, addr);
        }
        assert_int_equal(f->got[MANY].kind, AGILITYD_RESULT_DONE);
        assert_int_equal(f->got[MANY].err, -7);
}

/* A blocked job and a full queue: the next submit is refused and counted. The stop returns with
 * the job still blocked (it would not return before the job ends if it waited), reports it
 * abandoned and the queued ones dropped; the job's post afterwards is refused. */
static void test_full_queue_and_stop(void **state)
{
        struct fx *f = fx_of(state);
        struct agilityd_job job = { .kind = AGILITYD_JOB_VISUALIZE };
        struct agilityd_worker_stats st;
        bool ended;

        submit(f, AGILITYD_JOB_SYNC_CLOCKS, 1, "block");
        wait_in_job(f);
        for (unsigned i = 1; i < AGILITYD_WORKER_JOBS_MAX; i++)
                submit(f, AGILITYD_JOB_VISUALIZE, i, "devices:0");
        assert_int_equal(agilityd_worker_submit(f->w, &job), -ENOSPC);

        f->w = agilityd_worker_stop(f->w, &st);
        pthread_mutex_lock(&f->m);
        ended = f->job_ended;
        pthread_mutex_unlock(&f->m);
        assert_false(ended);
        assert_true(st.abandoned);
        assert_int_equal(st.abandoned_kind, AGILITYD_JOB_SYNC_CLOCKS);
        assert_int_equal(st.dropped, AGILITYD_WORKER_JOBS_MAX - 1);
        assert_int_equal(st.refused, 1);
        assert_int_equal(st.done, 0);

        pthread_mutex_lock(&f->m);
        f->release = true;
        pthread_cond_broadcast(&f->cv);
        while (!f->job_ended)
                pthread_cond_wait(&f->cv, &f->m);
        pthread_mutex_unlock(&f->m);
        assert_int_equal(f->last_post, -ECANCELED);
        assert_int_equal(f->n_got, 0);          /* nothing reached the loop */
}

/* An idle worker stops with nothing abandoned or dropped. */
static void test_stop_idle(void **state)
{
        struct fx *f = fx_of(state);
        struct agilityd_worker_stats st;

        submit(f, AGILITYD_JOB_VISUALIZE, 4, "devices:0");
        pump(f, 1);
        f->w = agilityd_worker_stop(f->w, &st);
        assert_false(st.abandoned);
        assert_int_equal(st.dropped, 0);
        assert_int_equal(st.refused, 0);
        assert_int_equal(st.done, 1);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_results_in_order, setup, teardown),
                cmocka_unit_test_setup_teardown(test_full_ring_waits, setup, teardown),
                cmocka_unit_test_setup_teardown(test_full_queue_and_stop, setup, teardown),
                cmocka_unit_test_setup_teardown(test_stop_idle, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
