/*
 * link.c's helpers: the command-word routing (link_protocol_for_command), and the wait queue
 * both engines use (link_waitq_*), on real control requests: a control socket on a real event
 * loop, its clients in this process, the queue driven by hand with the time the test chooses.
 * The wait=MS word itself is the vocabulary's (test_request_proto.c).
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "common/ctlserver.h"
#include "common/harness.h"
#include "daemon/control.h"
#include "daemon/evloop.h"
#include "daemon/link.h"
#include "svc/log.h"

#define T0              1000u           /* the queue's clock starts here (ms) */
#define GUARD_MS        5000            /* a wait longer than this has failed */
#define CLIENTS         (LINK_WAITQ_MAX + 3)
#define NAME_MAX_LEN    16

static void test_command_words(void **state)
{
        enum config_protocol p = CONFIG_PROTOCOL_CIRCE;

        (void)state;
        assert_int_equal(link_protocol_for_command("query", &p), 0);
        assert_int_equal(p, CONFIG_PROTOCOL_SHAREDLINK);
        assert_true(link_ops_has_word(link_ops_for(p), "query"));
        assert_int_equal(link_protocol_for_command("command", &p), 0);
        assert_int_equal(p, CONFIG_PROTOCOL_SHAREDLINK);
        assert_true(link_ops_has_word(link_ops_for(p), "command"));
        assert_false(link_ops_has_word(link_ops_for(p), "circe"));
        assert_int_equal(link_protocol_for_command("circe", &p), 0);
        assert_int_equal(p, CONFIG_PROTOCOL_CIRCE);
        assert_true(link_ops_has_word(link_ops_for(p), "circe"));
        assert_false(link_ops_has_word(link_ops_for(p), "query"));
        assert_int_equal(link_protocol_for_command("ping", &p), -ENOENT);
        assert_int_equal(link_protocol_for_command("", &p), -ENOENT);
        assert_int_equal(p, CONFIG_PROTOCOL_CIRCE);
}

/* ---- the wait queue ---------------------------------------------------------------------- */

struct fx {
        struct ctlserver srv;
        unsigned calls;
        struct link_waitq q;
        bool ready;
        char log[512];                  /* "run:c0 expire:c1/50 ..." in call order */
        int fds[CLIENTS];
};

static void fx_log(struct fx *f, const char *what, const char *name, unsigned wait_ms)
{
        size_t n = strlen(f->log);

        if (wait_ms)
                snprintf(f->log + n, sizeof(f->log) - n, "%s:%s/%u ", what, name, wait_ms);
        else
                snprintf(f->log + n, sizeof(f->log) - n, "%s:%s ", what, name);
}

static bool w_ready(void *engine)
{
        return ((struct fx *)engine)->ready;
}

static void w_run(void *engine, struct control_request *req, const void *data)
{
        fx_log(engine, "run", data, 0);
        control_reply_ok(req, "%s", (const char *)data);
}

static void w_expire(void *engine, struct control_request *req, const void *data,
                     unsigned wait_ms)
{
        fx_log(engine, "expire", data, wait_ms);
        control_reply_error(req, ETIMEDOUT, "%s waited %u ms", (const char *)data, wait_ms);
}

static const struct link_waitq_ops wait_ops = {
        .ready = w_ready, .run = w_run, .expire = w_expire,
};

/* "w NAME WAIT_MS": queued with NAME as its data, or EBUSY. */
static void on_request(struct control_request *req, int argc, char **argv, void *arg)
{
        struct fx *f = arg;
        char name[NAME_MAX_LEN] = "";
        unsigned wait_ms = 0;
        int r;

        f->calls++;
        assert_int_equal(argc, 3);
        snprintf(name, sizeof(name), "%s", argv[1]);
        wait_ms = (unsigned)strtoul(argv[2], NULL, 10);
        assert_true(wait_ms >= 1 && wait_ms <= CTLP_WAIT_MAX_MS);
        r = link_waitq_add(&f->q, req, T0, wait_ms, name, sizeof(name));
        if (r < 0)
                control_reply_error(req, r, "queue full");
}

static int wq_setup(void **state)
{
        struct fx *f = calloc(1, sizeof(*f));

        if (!f || ctlserver_init(&f->srv, "lnk", on_request, f) < 0)
                return -1;
        for (unsigned i = 0; i < CLIENTS; i++)
                f->fds[i] = -1;
        *state = f;
        return 0;
}

static int wq_teardown(void **state)
{
        struct fx *f = *state;

        for (unsigned i = 0; i < CLIENTS; i++)
                if (f->fds[i] >= 0)
                        close(f->fds[i]);
        ctlserver_free(&f->srv);
        free(f);
        return 0;
}

/* Runs the loop until cond(f, i) holds, under the guard. */
static void pump_until(struct fx *f, bool (*cond)(struct fx *f, unsigned i), unsigned i)
{
        f->srv.timed_out = false;
        assert_int_equal(evloop_timer_arm(&f->srv.guard, GUARD_MS, 0), 0);
        while (!cond(f, i)) {
                assert_int_equal(evloop_run_once(f->srv.loop), 0);
                assert_false(f->srv.timed_out);
        }
        evloop_timer_cancel(&f->srv.guard);
}

static bool calls_reached(struct fx *f, unsigned n)
{
        return f->calls >= n;
}

static bool request_gone(struct fx *f, unsigned i)
{
        return !control_request_alive(f->q.q[i].req);
}

/* Client i sends "w c<i> <wait_ms>"; returns once the handler has seen it (so the queue order
 * is the order of the calls). */
static void client_send(struct fx *f, unsigned i, unsigned wait_ms)
{
        char line[64];
        int n = snprintf(line, sizeof(line), "w c%u %u\n", i, wait_ms);

        f->fds[i] = harness_connect_unix(f->srv.path);
        assert_true(f->fds[i] >= 0);
        assert_int_equal(harness_write_all(f->fds[i], line, (size_t)n, GUARD_MS), 0);
        pump_until(f, calls_reached, f->calls + 1);
}

static void expect_reply(struct fx *f, unsigned i, const char *want)
{
        char buf[256];

        assert_true(harness_read_until(f->fds[i], buf, sizeof(buf), '\n', GUARD_MS) > 0);
        assert_string_equal(buf, want);
}

/* Bounded, in order, each request answered once: expired at its own deadline or when its client
 * left, run once ready, cancelled at the end. */
static void test_waitq(void **state)
{
        struct fx *f = *state;
        char want[512];
        size_t n = 0;

        for (unsigned i = 0; i < LINK_WAITQ_MAX; i++)
                client_send(f, i, i == 1 ? 50 : 100);
        client_send(f, LINK_WAITQ_MAX, 100);
        expect_reply(f, LINK_WAITQ_MAX, "ERR 16 queue full\n");
        assert_int_equal(f->q.n, LINK_WAITQ_MAX);
        assert_int_equal(link_waitq_deadline(&f->q), T0 + 50);

        /* Not ready: only what is due expires. */
        link_waitq_run(&f->q, T0 + 49, &wait_ops, f);
        assert_string_equal(f->log, "");
        link_waitq_run(&f->q, T0 + 50, &wait_ops, f);
        assert_string_equal(f->log, "expire:c1/50 ");
        expect_reply(f, 1, "ERR 110 c1 waited 50 ms\n");
        assert_int_equal(link_waitq_deadline(&f->q), T0 + 100);

        /* A client that leaves is ended at the next run, before its deadline. */
        close(f->fds[3]);
        f->fds[3] = -1;
        pump_until(f, request_gone, 2);         /* c3 is third in the queue now */
        link_waitq_run(&f->q, T0 + 60, &wait_ops, f);
        assert_string_equal(f->log, "expire:c1/50 expire:c3/100 ");

        /* Ready: every other one runs, in the order it came. */
        f->ready = true;
        link_waitq_run(&f->q, T0 + 70, &wait_ops, f);
        n = (size_t)snprintf(want, sizeof(want), "expire:c1/50 expire:c3/100 ");
        for (unsigned i = 0; i < LINK_WAITQ_MAX; i++)
                if (i != 1 && i != 3)
                        n += (size_t)snprintf(want + n, sizeof(want) - n, "run:c%u ", i);
        assert_string_equal(f->log, want);
        expect_reply(f, 0, "OK c0\n");
        expect_reply(f, LINK_WAITQ_MAX - 1, "OK c15\n");
        assert_int_equal(f->q.n, 0);
        assert_int_equal(link_waitq_deadline(&f->q), UINT64_MAX);

        /* Cancel: what waits is ended with the error given. */
        client_send(f, LINK_WAITQ_MAX + 1, 1000);
        client_send(f, LINK_WAITQ_MAX + 2, 1000);
        link_waitq_cancel(&f->q, ECANCELED, "link stopped");
        expect_reply(f, LINK_WAITQ_MAX + 1, "ERR 125 link stopped\n");
        expect_reply(f, LINK_WAITQ_MAX + 2, "ERR 125 link stopped\n");
        assert_int_equal(f->q.n, 0);
        assert_int_equal(link_waitq_add(&f->q, NULL, T0, 1, want, LINK_WAITQ_DATA_MAX + 1),
                         -EINVAL);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_command_words),
                cmocka_unit_test_setup_teardown(test_waitq, wq_setup, wq_teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
