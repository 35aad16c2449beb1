/*
 * evloop: fds, timer order / re-arm / cancel, removal during dispatch, signals through
 * signalfd, exit, limits, and the wakeup counters (counts, never durations).
 *
 * Every test that runs the loop arms a guard timer first; if the event under test never comes,
 * the guard fails the test instead of hanging it.
 */
#define _GNU_SOURCE     /* pipe2 */
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "svc/evloop.h"

#define GUARD_MS        10000
#define EVENTS_MAX      64

/* What the callbacks saw, in order. */
struct trace {
        struct evloop *loop;
        int events[EVENTS_MAX];
        size_t n;
};

static void trace_add(struct trace *t, int v)
{
        assert_true(t->n < EVENTS_MAX);
        t->events[t->n++] = v;
}

static void on_guard(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        (void)loop;
        (void)timer;
        (void)arg;
        fail_msg("guard timer fired: the awaited event never came");
}

static void arm_guard(struct evloop *loop, struct evloop_timer *guard)
{
        evloop_timer_init(guard, loop, on_guard, NULL);
        assert_int_equal(evloop_timer_arm(guard, GUARD_MS, 0), 0);
}

static void make_pipe(int p[2])
{
        assert_int_equal(pipe2(p, O_CLOEXEC | O_NONBLOCK), 0);
}

/* ---------------------------------------------------------------------------------------------
 * fds */

struct fdctx {
        int calls;
        unsigned last_revents;
        int fd_seen;
};

static void on_fd(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct fdctx *c = arg;
        char buf[64];

        (void)loop;
        c->calls++;
        c->last_revents = revents;
        c->fd_seen = fd;
        if (revents & POLLIN)
                while (read(fd, buf, sizeof(buf)) > 0)
                        ;
}

static void on_timer_exit(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        (void)timer;
        (void)arg;
        evloop_exit(loop, 0);
}

static void test_fd_basic(void **state)
{
        struct evloop *loop;
        struct evloop_timer guard, kick;
        struct fdctx rd = { 0 }, wr = { 0 };
        int p[2];

        (void)state;
        assert_int_equal(evloop_new(&loop), 0);
        arm_guard(loop, &guard);
        make_pipe(p);

        assert_int_equal(evloop_add_fd(loop, p[0], POLLIN, on_fd, &rd), 0);
        assert_int_equal(evloop_add_fd(loop, p[0], POLLIN, on_fd, &rd), -EEXIST);
        assert_int_equal(evloop_add_fd(loop, -1, POLLIN, on_fd, &rd), -EINVAL);
        assert_int_equal(evloop_add_fd(loop, p[1], POLLIN | 0x4000, on_fd, &wr), -EINVAL);
        assert_int_equal(evloop_add_fd(loop, p[1], POLLOUT, NULL, &wr), -EINVAL);
        assert_int_equal(evloop_mod_fd(loop, 999, POLLIN), -ENOENT);
        assert_int_equal(evloop_del_fd(loop, 999), -ENOENT);

        /* Readable after a write. */
        assert_int_equal(write(p[1], "x", 1), 1);
        assert_int_equal(evloop_run_once(loop), 0);
        assert_int_equal(rd.calls, 1);
        assert_int_equal(rd.fd_seen, p[0]);
        assert_true(rd.last_revents & POLLIN);

        /* POLLOUT on the write end. */
        assert_int_equal(evloop_add_fd(loop, p[1], POLLOUT, on_fd, &wr), 0);
        assert_int_equal(evloop_run_once(loop), 0);
        assert_int_equal(wr.calls, 1);
        assert_int_equal(wr.last_revents, POLLOUT);
        assert_int_equal(rd.calls, 1);

        /* Events 0: not polled at all, though readable; a due timer ends the round. */
        assert_int_equal(evloop_mod_fd(loop, p[1], 0), 0);
        assert_int_equal(evloop_mod_fd(loop, p[0], 0), 0);
        assert_int_equal(write(p[1], "y", 1), 1);
        evloop_timer_init(&kick, loop, on_timer_exit, NULL);
        assert_int_equal(evloop_timer_arm(&kick, 0, 0), 0);
        assert_int_equal(evloop_run(loop), 0);
        assert_int_equal(rd.calls, 1);
        assert_int_equal(wr.calls, 1);

        /* Enabled again: the pending byte is seen. */
        assert_int_equal(evloop_mod_fd(loop, p[0], POLLIN), 0);
        assert_int_equal(evloop_run_once(loop), 0);
        assert_int_equal(rd.calls, 2);

        /* Removed: never called again. */
        assert_int_equal(evloop_del_fd(loop, p[0]), 0);
        assert_int_equal(evloop_del_fd(loop, p[0]), -ENOENT);
        assert_int_equal(write(p[1], "z", 1), 1);
        assert_int_equal(evloop_timer_arm(&kick, 0, 0), 0);
        assert_int_equal(evloop_run(loop), 0);
        assert_int_equal(rd.calls, 2);

        evloop_timer_cancel(&guard);
        evloop_free(loop);
        close(p[0]);
        close(p[1]);
}

/* EVLOOP_HANGUP alone: a socket whose peer only shut its sending side (readable for ever, at
 * EOF) is not reported, so nothing spins; the peer's full close is, as POLLHUP. Events 0 would
 * never report it. */
static void test_fd_hangup_only(void **state)
{
        struct evloop *loop;
        struct evloop_timer guard, kick;
        struct fdctx rd = { 0 };
        int sp[2];

        (void)state;
        assert_int_equal(evloop_new(&loop), 0);
        arm_guard(loop, &guard);
        evloop_timer_init(&kick, loop, on_timer_exit, NULL);
        assert_int_equal(socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0, sp),
                         0);
        assert_int_equal(evloop_add_fd(loop, sp[0], EVLOOP_HANGUP, on_fd, &rd), 0);

        /* Half-closed: POLLIN|POLLRDHUP for ever, none of which was asked for. */
        assert_int_equal(shutdown(sp[1], SHUT_WR), 0);
        assert_int_equal(evloop_timer_arm(&kick, 0, 0), 0);
        assert_int_equal(evloop_run(loop), 0);
        assert_int_equal(rd.calls, 0);

        /* Gone altogether: reported without waiting for a timer. */
        close(sp[1]);
        assert_int_equal(evloop_run_once(loop), 0);
        assert_int_equal(rd.calls, 1);
        assert_true(rd.last_revents & POLLHUP);
        assert_false(rd.last_revents & POLLIN);

        evloop_timer_cancel(&guard);
        evloop_free(loop);
        close(sp[0]);
}

/* A POLLNVAL fd (closed behind the loop's back) is reported once and then dropped. */
static void test_fd_nval_dropped(void **state)
{
        struct evloop *loop;
        struct evloop_timer guard;
        struct evloop_stats st;
        struct fdctx c = { 0 };
        int p[2];

        (void)state;
        assert_int_equal(evloop_new(&loop), 0);
        arm_guard(loop, &guard);
        make_pipe(p);
        assert_int_equal(evloop_add_fd(loop, p[0], POLLIN, on_fd, &c), 0);
        close(p[0]);
        assert_int_equal(evloop_run_once(loop), 0);
        assert_int_equal(c.calls, 1);
        assert_true(c.last_revents & POLLNVAL);
        evloop_get_stats(loop, &st);
        assert_int_equal(st.nval_drops, 1);
        assert_int_equal(evloop_del_fd(loop, p[0]), -ENOENT);
        evloop_free(loop);
        close(p[1]);
}

/* ---------------------------------------------------------------------------------------------
 * Removal during dispatch */

struct removal {
        struct evloop *loop;
        int a[2], b[2], c[2];
        int calls_a, calls_b, calls_c;
        int reused_fd;
};

static void on_c(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct removal *r = arg;
        char buf[8];

        (void)loop;
        (void)revents;
        r->calls_c++;
        while (read(fd, buf, sizeof(buf)) > 0)
                ;
}

static void on_b(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct removal *r = arg;

        (void)loop;
        (void)fd;
        (void)revents;
        r->calls_b++;
}

/* A's callback removes itself and B (ready in the same round), closes B and puts a new pipe
 * under B's fd number: the newcomer must not inherit B's revents in this round. */
static void on_a(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct removal *r = arg;
        int fresh[2];

        (void)revents;
        r->calls_a++;
        assert_int_equal(evloop_del_fd(loop, fd), 0);
        assert_int_equal(evloop_del_fd(loop, r->b[0]), 0);
        make_pipe(fresh);
        r->reused_fd = r->b[0];
        assert_int_equal(dup3(fresh[0], r->reused_fd, O_CLOEXEC), r->reused_fd);
        close(fresh[0]);
        r->c[0] = r->reused_fd;
        r->c[1] = fresh[1];
        assert_int_equal(evloop_add_fd(loop, r->reused_fd, POLLIN, on_c, r), 0);
}

static void test_fd_removal_during_dispatch(void **state)
{
        struct removal r = { 0 };
        struct evloop_timer guard;

        (void)state;
        assert_int_equal(evloop_new(&r.loop), 0);
        arm_guard(r.loop, &guard);
        make_pipe(r.a);
        make_pipe(r.b);
        assert_int_equal(evloop_add_fd(r.loop, r.a[0], POLLIN, on_a, &r), 0);
        assert_int_equal(evloop_add_fd(r.loop, r.b[0], POLLIN, on_b, &r), 0);
        assert_int_equal(write(r.a[1], "a", 1), 1);
        assert_int_equal(write(r.b[1], "b", 1), 1);

        assert_int_equal(evloop_run_once(r.loop), 0);
        assert_int_equal(r.calls_a, 1);
        assert_int_equal(r.calls_b, 0);
        assert_int_equal(r.calls_c, 0);         /* added this round: not dispatched */

        /* Next round: A is gone (still readable), C gets its own data. */
        assert_int_equal(write(r.c[1], "c", 1), 1);
        assert_int_equal(evloop_run_once(r.loop), 0);
        assert_int_equal(r.calls_a, 1);
        assert_int_equal(r.calls_b, 0);
        assert_int_equal(r.calls_c, 1);

        evloop_timer_cancel(&guard);
        evloop_free(r.loop);
        close(r.a[0]);
        close(r.a[1]);
        close(r.b[1]);
        close(r.c[0]);
        close(r.c[1]);
}

/* Dropping POLLOUT from an fd ready in the same round suppresses that event. */
struct modctx {
        int w1, w2;
        int calls1, calls2;
};

static void on_w1(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct modctx *m = arg;

        (void)fd;
        (void)revents;
        m->calls1++;
        assert_int_equal(evloop_mod_fd(loop, m->w2, POLLIN), 0);
}

static void on_w2(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct modctx *m = arg;

        (void)loop;
        (void)fd;
        (void)revents;
        m->calls2++;
}

static void test_fd_mod_during_dispatch(void **state)
{
        struct evloop *loop;
        struct evloop_timer guard;
        struct modctx m = { 0 };
        int p1[2], p2[2];

        (void)state;
        assert_int_equal(evloop_new(&loop), 0);
        arm_guard(loop, &guard);
        make_pipe(p1);
        make_pipe(p2);
        m.w1 = p1[1];
        m.w2 = p2[1];
        assert_int_equal(evloop_add_fd(loop, m.w1, POLLOUT, on_w1, &m), 0);
        assert_int_equal(evloop_add_fd(loop, m.w2, POLLOUT, on_w2, &m), 0);
        assert_int_equal(evloop_run_once(loop), 0);
        assert_int_equal(m.calls1, 1);
        assert_int_equal(m.calls2, 0);
        evloop_timer_cancel(&guard);
        evloop_free(loop);
        close(p1[0]);
        close(p1[1]);
        close(p2[0]);
        close(p2[1]);
}

/* ---------------------------------------------------------------------------------------------
 * Timers */

struct tnode {
        struct evloop_timer t;
        struct trace *trace;
        int id;
        int fires;
        int fires_max;                  /* periodic: cancel itself after this many */
        struct tnode *victim;           /* cancelled by this timer's callback */
        bool exit_after;
};

static void on_tnode(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        struct tnode *n = arg;

        assert_ptr_equal(timer, &n->t);
        n->fires++;
        trace_add(n->trace, n->id);
        if (n->victim)
                evloop_timer_cancel(&n->victim->t);
        if (n->fires_max && n->fires >= n->fires_max)
                evloop_timer_cancel(timer);
        if (n->exit_after)
                evloop_exit(loop, n->id);
}

static void test_timer_order(void **state)
{
        static const struct {
                int id;
                unsigned delay_ms;
        } arm[] = {
                { 30, 30 }, { 10, 10 }, { 20, 20 }, { 11, 10 }, { 0, 0 }, { 31, 30 },
        };
        static const int expect[] = { 0, 10, 11, 20, 30, 31 };
        struct evloop *loop;
        struct evloop_timer guard;
        struct tnode n[6];
        struct trace tr = { 0 };

        (void)state;
        assert_int_equal(evloop_new(&loop), 0);
        arm_guard(loop, &guard);
        for (size_t i = 0; i < 6; i++) {
                n[i] = (struct tnode){ .trace = &tr, .id = arm[i].id };
                evloop_timer_init(&n[i].t, loop, on_tnode, &n[i]);
                assert_false(evloop_timer_armed(&n[i].t));
                assert_int_equal(evloop_timer_arm(&n[i].t, arm[i].delay_ms, 0), 0);
                assert_true(evloop_timer_armed(&n[i].t));
        }
        n[5].exit_after = true;
        assert_int_equal(evloop_run(loop), 31);
        assert_int_equal(tr.n, 6);
        assert_memory_equal(tr.events, expect, sizeof(expect));
        for (size_t i = 0; i < 6; i++)
                assert_false(evloop_timer_armed(&n[i].t));
        evloop_timer_cancel(&guard);
        evloop_free(loop);
}

static void test_timer_rearm_cancel_periodic(void **state)
{
        struct evloop *loop;
        struct evloop_timer guard;
        struct tnode moved, plain, gone, tick, last;
        struct trace tr = { 0 };

        (void)state;
        assert_int_equal(evloop_new(&loop), 0);
        arm_guard(loop, &guard);
        moved = (struct tnode){ .trace = &tr, .id = 1 };
        plain = (struct tnode){ .trace = &tr, .id = 2 };
        gone = (struct tnode){ .trace = &tr, .id = 3 };
        tick = (struct tnode){ .trace = &tr, .id = 4, .fires_max = 3 };
        last = (struct tnode){ .trace = &tr, .id = 5, .exit_after = true };
        evloop_timer_init(&moved.t, loop, on_tnode, &moved);
        evloop_timer_init(&plain.t, loop, on_tnode, &plain);
        evloop_timer_init(&gone.t, loop, on_tnode, &gone);
        evloop_timer_init(&tick.t, loop, on_tnode, &tick);
        evloop_timer_init(&last.t, loop, on_tnode, &last);

        assert_int_equal(evloop_timer_arm(&moved.t, 5, 0), 0);
        assert_int_equal(evloop_timer_arm(&plain.t, 20, 0), 0);
        assert_int_equal(evloop_timer_arm(&gone.t, 10, 0), 0);
        assert_int_equal(evloop_timer_arm(&moved.t, 40, 0), 0);  /* re-arm: now after plain */
        evloop_timer_cancel(&gone.t);
        evloop_timer_cancel(&gone.t);                           /* twice is fine */
        evloop_timer_cancel(NULL);
        assert_int_equal(evloop_timer_arm(&tick.t, 1, 15), 0);  /* 1, 16, 31 ms, then cancels */
        assert_int_equal(evloop_timer_arm(&last.t, 80, 0), 0);

        assert_int_equal(evloop_run(loop), 5);
        assert_int_equal(gone.fires, 0);
        assert_int_equal(tick.fires, 3);
        assert_int_equal(moved.fires, 1);
        assert_int_equal(plain.fires, 1);
        /* One-shots in deadline order: plain@20, moved@40 (re-armed from 5), last@80; the
         * periodic tick fires at 1, 16, 31 and stops itself, well before last. */
        {
                static const int expect[] = { 2, 1, 5 };
                int one_shots[6], n = 0, ticks_before_last = 0;

                assert_int_equal(tr.n, 6);
                for (size_t i = 0; i < tr.n; i++) {
                        if (tr.events[i] == 4)
                                ticks_before_last++;
                        else
                                one_shots[n++] = tr.events[i];
                }
                assert_int_equal(n, 3);
                assert_memory_equal(one_shots, expect, sizeof(expect));
                assert_int_equal(tr.events[0], 4);
                assert_int_equal(ticks_before_last, 3);
        }
        evloop_timer_cancel(&guard);
        evloop_free(loop);
}

/* Two timers due in the same round (delay 0): the first cancels the second, which must not
 * fire although it was due when the round began. */
static void test_timer_cancel_later_in_round(void **state)
{
        struct evloop *loop;
        struct evloop_timer guard;
        struct tnode a, b;
        struct trace tr = { 0 };

        (void)state;
        assert_int_equal(evloop_new(&loop), 0);
        arm_guard(loop, &guard);
        a = (struct tnode){ .trace = &tr, .id = 1, .victim = &b };
        b = (struct tnode){ .trace = &tr, .id = 2 };
        evloop_timer_init(&a.t, loop, on_tnode, &a);
        evloop_timer_init(&b.t, loop, on_tnode, &b);
        assert_int_equal(evloop_timer_arm(&a.t, 0, 0), 0);
        assert_int_equal(evloop_timer_arm(&b.t, 0, 0), 0);
        assert_int_equal(evloop_run_once(loop), 0);
        assert_int_equal(a.fires, 1);
        assert_int_equal(b.fires, 0);
        assert_false(evloop_timer_armed(&b.t));
        evloop_timer_cancel(&guard);
        evloop_free(loop);
}

/* A timer whose callback frees the memory it lives in (ASan catches any later touch). */
struct selffree {
        struct evloop_timer t;
        int *fired;
};

static void on_selffree(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        struct selffree *s = arg;

        (void)loop;
        evloop_timer_cancel(timer);             /* periodic: must stop before the free */
        (*s->fired)++;
        free(s);
}

/* Re-arming itself with delay 0 fires once per round, not in a loop. */
static void on_rearm_zero(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        int *fires = arg;

        (void)loop;
        (*fires)++;
        assert_int_equal(evloop_timer_arm(timer, 0, 0), 0);
}

static void test_timer_self_free_and_rearm_zero(void **state)
{
        struct evloop *loop;
        struct evloop_timer guard, zero;
        struct selffree *s = calloc(1, sizeof(*s));
        int fired = 0, zero_fires = 0;

        (void)state;
        assert_non_null(s);
        assert_int_equal(evloop_new(&loop), 0);
        arm_guard(loop, &guard);
        s->fired = &fired;
        evloop_timer_init(&s->t, loop, on_selffree, s);
        assert_int_equal(evloop_timer_arm(&s->t, 0, 1), 0);
        evloop_timer_init(&zero, loop, on_rearm_zero, &zero_fires);
        assert_int_equal(evloop_timer_arm(&zero, 0, 0), 0);

        assert_int_equal(evloop_run_once(loop), 0);
        assert_int_equal(fired, 1);
        assert_int_equal(zero_fires, 1);
        assert_int_equal(evloop_next_timeout_ms(loop), 0);      /* zero is due again */
        assert_int_equal(evloop_run_once(loop), 0);
        assert_int_equal(fired, 1);
        assert_int_equal(zero_fires, 2);
        evloop_timer_cancel(&zero);
        evloop_timer_cancel(&guard);
        evloop_free(loop);
}

static void test_timer_limits(void **state)
{
        struct evloop *loop;
        struct evloop_timer *t = calloc(EVLOOP_TIMERS_MAX + 1, sizeof(*t));
        struct evloop_timer unset = { .heap_index = EVLOOP_TIMER_IDLE };

        (void)state;
        assert_non_null(t);
        assert_int_equal(evloop_new(&loop), 0);
        assert_int_equal(evloop_timer_arm(&unset, 1, 0), -EINVAL);
        for (size_t i = 0; i <= EVLOOP_TIMERS_MAX; i++) {
                evloop_timer_init(&t[i], loop, on_guard, NULL);
                assert_int_equal(evloop_timer_arm(&t[i], 3600 * 1000 + i, 0),
                                 i < EVLOOP_TIMERS_MAX ? 0 : -ENOSPC);
        }
        assert_false(evloop_timer_armed(&t[EVLOOP_TIMERS_MAX]));
        assert_int_equal(evloop_timer_arm(&t[0], UINT64_MAX, 0), -EINVAL);
        /* Cancel from the middle keeps the heap consistent: the earliest is still first. */
        for (size_t i = 1; i < EVLOOP_TIMERS_MAX; i += 2)
                evloop_timer_cancel(&t[i]);
        assert_true(evloop_next_timeout_ms(loop) > 3599 * 1000);
        evloop_free(loop);                      /* disarms what is left */
        for (size_t i = 0; i <= EVLOOP_TIMERS_MAX; i++)
                assert_false(evloop_timer_armed(&t[i]));
        free(t);
}

static void test_fd_limit(void **state)
{
        struct evloop *loop;
        struct fdctx c = { 0 };

        (void)state;
        assert_int_equal(evloop_new(&loop), 0);
        /* Registration does not touch the fds: numbers far above any open one. */
        for (int i = 0; i <= EVLOOP_FDS_MAX; i++)
                assert_int_equal(evloop_add_fd(loop, 100000 + i, POLLIN, on_fd, &c),
                                 i < EVLOOP_FDS_MAX ? 0 : -ENOSPC);
        assert_int_equal(evloop_del_fd(loop, 100000), 0);
        assert_int_equal(evloop_add_fd(loop, 100000, POLLIN, on_fd, &c), -ENOSPC);
        evloop_free(loop);
}

/* ---------------------------------------------------------------------------------------------
 * Wakeups: counts, not durations. */

static void test_no_idle_wakeups(void **state)
{
        struct evloop *loop;
        struct evloop_timer far, guard;
        struct tnode tick;
        struct trace tr = { 0 };
        struct evloop_stats st;
        struct fdctx c = { 0 };
        int p[2];

        (void)state;
        assert_int_equal(evloop_new(&loop), 0);
        assert_int_equal(evloop_next_timeout_ms(loop), -1);     /* nothing armed: forever */
        make_pipe(p);
        assert_int_equal(evloop_add_fd(loop, p[0], POLLIN, on_fd, &c), 0);   /* never written */
        assert_int_equal(evloop_next_timeout_ms(loop), -1);

        evloop_timer_init(&far, loop, on_guard, NULL);
        assert_int_equal(evloop_timer_arm(&far, 3600 * 1000, 0), 0);
        assert_true(evloop_next_timeout_ms(loop) > 3599 * 1000);
        arm_guard(loop, &guard);

        tick = (struct tnode){ .trace = &tr, .id = 9, .fires_max = 5 };
        evloop_timer_init(&tick.t, loop, on_tnode, &tick);
        assert_int_equal(evloop_timer_arm(&tick.t, 10, 10), 0);
        while (tick.fires < 5)
                assert_int_equal(evloop_run_once(loop), 0);

        evloop_get_stats(loop, &st);
        /* One wakeup per timer expiry and none besides: poll slept until each deadline. */
        assert_int_equal(st.timer_fires, 5);
        assert_int_equal(st.wakeups, 5);
        assert_int_equal(st.idle_wakeups, 0);
        assert_int_equal(st.fd_events, 0);
        assert_int_equal(c.calls, 0);

        evloop_timer_cancel(&far);
        evloop_timer_cancel(&guard);
        assert_int_equal(evloop_next_timeout_ms(loop), -1);
        evloop_free(loop);
        close(p[0]);
        close(p[1]);
}

/* ---------------------------------------------------------------------------------------------
 * Signals, exit */

struct sigctx {
        int seen[4];
        int n;
        int children_reaped;
};

static void on_signal(struct evloop *loop, int signo, void *arg)
{
        struct sigctx *s = arg;

        (void)loop;
        if (s->n < 4)
                s->seen[s->n] = signo;
        s->n++;
        if (signo == SIGCHLD)
                while (waitpid(-1, NULL, WNOHANG) > 0)
                        s->children_reaped++;
        if (signo == SIGTERM)
                evloop_exit(loop, 42);
}

static bool signal_blocked(int signo)
{
        sigset_t cur;

        pthread_sigmask(SIG_BLOCK, NULL, &cur);
        return sigismember(&cur, signo) == 1;
}

static void test_signals(void **state)
{
        struct evloop *loop;
        struct evloop_timer guard;
        struct sigctx s = { 0 };
        pid_t pid;

        (void)state;
        assert_false(signal_blocked(SIGHUP));
        assert_int_equal(evloop_new(&loop), 0);
        arm_guard(loop, &guard);
        assert_int_equal(evloop_add_signal(loop, SIGHUP, on_signal, &s), 0);
        assert_int_equal(evloop_add_signal(loop, SIGHUP, on_signal, &s), -EEXIST);
        assert_int_equal(evloop_add_signal(loop, SIGKILL, on_signal, &s), -EINVAL);
        assert_int_equal(evloop_add_signal(loop, 0, on_signal, &s), -EINVAL);
        assert_int_equal(evloop_add_signal(loop, SIGTERM, on_signal, &s), 0);
        assert_int_equal(evloop_add_signal(loop, SIGINT, on_signal, &s), 0);
        assert_int_equal(evloop_add_signal(loop, SIGCHLD, on_signal, &s), 0);
        assert_true(signal_blocked(SIGHUP));

        assert_int_equal(raise(SIGHUP), 0);     /* blocked: waits in the signalfd */
        assert_int_equal(evloop_run_once(loop), 0);
        assert_int_equal(s.n, 1);
        assert_int_equal(s.seen[0], SIGHUP);

        pid = fork();
        assert_true(pid >= 0);
        if (pid == 0)
                _exit(0);
        while (s.children_reaped == 0)
                assert_int_equal(evloop_run_once(loop), 0);
        assert_int_equal(s.seen[1], SIGCHLD);

        assert_int_equal(raise(SIGINT), 0);
        assert_int_equal(raise(SIGTERM), 0);
        assert_int_equal(evloop_run(loop), 42);
        assert_int_equal(s.n, 4);
        assert_false(evloop_exiting(loop));

        evloop_timer_cancel(&guard);
        evloop_free(loop);
        /* Released: the mask is as before. */
        assert_false(signal_blocked(SIGHUP));
        assert_false(signal_blocked(SIGTERM));
        assert_false(signal_blocked(SIGCHLD));
}

static volatile sig_atomic_t usr2_handled;

static void count_usr2(int signo)
{
        (void)signo;
        usr2_handled++;
}

/* Removing a signal with a delivery pending discards it: the old handler never sees it. */
static void test_signal_del_discards_pending(void **state)
{
        struct sigaction sa = { .sa_handler = count_usr2 }, old;
        struct evloop *loop;
        struct sigctx s = { 0 };

        (void)state;
        sigemptyset(&sa.sa_mask);
        assert_int_equal(sigaction(SIGUSR2, &sa, &old), 0);
        assert_int_equal(evloop_new(&loop), 0);
        assert_int_equal(evloop_add_signal(loop, SIGUSR2, on_signal, &s), 0);
        assert_int_equal(raise(SIGUSR2), 0);
        assert_int_equal(evloop_del_signal(loop, SIGUSR2), 0);
        assert_int_equal(evloop_del_signal(loop, SIGUSR2), -ENOENT);
        assert_false(signal_blocked(SIGUSR2));
        assert_int_equal(usr2_handled, 0);
        assert_int_equal(s.n, 0);
        /* And the handler works again afterwards. */
        assert_int_equal(raise(SIGUSR2), 0);
        assert_int_equal(usr2_handled, 1);
        evloop_free(loop);
        sigaction(SIGUSR2, &old, NULL);
}

/* evloop_exit() before evloop_run() returns at once; run/run_once refuse to nest. */
static struct evloop *nested_loop;
static int nested_result;

static void on_nested(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        (void)timer;
        (void)arg;
        nested_result = evloop_run_once(nested_loop);
        evloop_exit(loop, nested_result == -EBUSY && evloop_run(loop) == -EBUSY ? 3 : 4);
}

static void test_exit_and_nesting(void **state)
{
        struct evloop *loop;
        struct evloop_timer t;
        struct evloop_stats st;

        (void)state;
        assert_int_equal(evloop_new(&loop), 0);
        evloop_exit(loop, 9);
        assert_true(evloop_exiting(loop));
        assert_int_equal(evloop_run(loop), 9);
        evloop_get_stats(loop, &st);
        assert_int_equal(st.wakeups, 0);

        nested_loop = loop;
        evloop_timer_init(&t, loop, on_nested, NULL);
        assert_int_equal(evloop_timer_arm(&t, 0, 0), 0);
        assert_int_equal(evloop_run(loop), 3);
        assert_int_equal(nested_result, -EBUSY);
        evloop_free(loop);
        assert_null(evloop_free(NULL));
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_fd_basic),
                cmocka_unit_test(test_fd_hangup_only),
                cmocka_unit_test(test_fd_nval_dropped),
                cmocka_unit_test(test_fd_removal_during_dispatch),
                cmocka_unit_test(test_fd_mod_during_dispatch),
                cmocka_unit_test(test_fd_limit),
                cmocka_unit_test(test_timer_order),
                cmocka_unit_test(test_timer_rearm_cancel_periodic),
                cmocka_unit_test(test_timer_cancel_later_in_round),
                cmocka_unit_test(test_timer_self_free_and_rearm_zero),
                cmocka_unit_test(test_timer_limits),
                cmocka_unit_test(test_no_idle_wakeups),
                cmocka_unit_test(test_signals),
                cmocka_unit_test(test_signal_del_discards_pending),
                cmocka_unit_test(test_exit_and_nesting),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
