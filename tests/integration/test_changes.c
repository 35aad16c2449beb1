/*
 * sl_changed against the real sharedlinkd (build/asan) and its real tables: one SharedLink link
 * on a pty whose master the test holds, playing the peers of tests/common/benchlink.h (1,000
 * inbound variables v0..v999 in four lists).
 *
 *  - a round of frames comes back as the ids of the variables it set, each read with its value;
 *  - a wake-up loop that reads only what it is told follows a variable frame by frame: after
 *    each frame's wake-up it is told that variable alone and reads the frame's value, never
 *    "read everything" after the first call (the peers never go stale: stale_ms 0);
 *  - more changes than the daemon's record holds: an overrun, then ids as before;
 *  - a daemon restart: ids resolved anew, then the same ids for the same names.
 */
#define _GNU_SOURCE
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <sharedlink.h>

#include "common/benchlink.h"
#include "common/harness.h"
#include "common/wire.h"

#define T_START_MS      15000   /* READY=1 (ASan build) */
#define T_WAIT_MS       15000   /* one awaited change (a hang guard, not a timing assertion) */
#define T_STOP_MS       15000
#define CONFIG_MAX      (64 * 1024)
#define PATH_BUF        512
#define IDS_MAX         2048
#define STEPS           200     /* frames followed one by one */
#define OVERRUN_ROUNDS  8       /* rounds of 1,000 changes: more than the record holds */

struct fx {
        struct harness h;
        struct sl_client *cl;
        int master, slave;
        char config[PATH_BUF];
        uint64_t cursor;
        uint32_t wait;                  /* sl_wait's cursor */
        int ids[IDS_MAX];
        uint32_t flags;
};

/* Adds stale_ms: 0 to every peer of the configuration text (size bytes): a silent peer's
 * variables then never turn stale, so the only changes are the test's. False if it does not fit. */
static bool never_stale(char *text, size_t size)
{
        static const char key[] = "        period_ms: 0\n", add[] = "        stale_ms: 0\n";
        char *copy = strdup(text), *p, *at;
        size_t n = 0;

        if (!copy)
                return false;
        for (p = copy; (at = strstr(p, key)); p = at + strlen(key))
                n += (size_t)snprintf(text + n, n < size ? size - n : 0, "%.*s%s",
                                      (int)(at + strlen(key) - p), p, add);
        n += (size_t)snprintf(text + n, n < size ? size - n : 0, "%s", p);
        free(copy);
        return n < size;
}

static int setup(void **state)
{
        struct fx *f = calloc(1, sizeof(*f));
        char text[CONFIG_MAX], slave[PATH_BUF], dev[PATH_BUF];
        int st = 0;

        *state = f;
        if (!f || harness_init(&f->h, "chg") < 0 ||
            harness_openpty(&f->master, &f->slave, slave) < 0)
                return -1;
        snprintf(dev, sizeof(dev), "%s/dev0", f->h.dir);
        if (symlink(slave, dev) < 0 ||
            benchlink_config(text, sizeof(text), f->h.instance, dev, "long", NULL) == 0 ||
            !never_stale(text, sizeof(text)) ||
            harness_write_file(&f->h, "daemon.yaml", text, f->config) < 0)
                return -1;
        f->h.capture_log = 1;
        if (harness_start_daemon(&f->h, f->config, T_START_MS, &st, NULL) != 0)
                return -1;
        return sl_open(f->h.instance, &f->cl) == 0 ? 0 : -1;
}

static int teardown(void **state)
{
        struct fx *f = *state;

        sl_close(f->cl);
        harness_close_fd(&f->master);
        harness_close_fd(&f->slave);
        if (f->h.dir[0])
                harness_cleanup(&f->h);
        free(f);
        return 0;
}

/* Drops what the daemon sent the peers (it must never find the pty full). */
static void drain(struct fx *f)
{
        char buf[4096];
        struct pollfd p = { .fd = f->master, .events = POLLIN };

        while (poll(&p, 1, 0) > 0 && (p.revents & POLLIN) && read(f->master, buf, sizeof(buf)) > 0)
                ;
}

static void send_frame(struct fx *f, const char *frame, size_t n)
{
        drain(f);
        assert_int_equal(harness_write_all(f->master, frame, n, T_WAIT_MS), 0);
}

/* v0 (the first of peer B's list) = value. */
static void send_v0(struct fx *f, long value)
{
        char body[64], frame[128];

        snprintf(body, sizeof(body), "N0|D%ld", value);
        send_frame(f, frame, wire_slp_frame(frame, sizeof(frame), BENCHLINK_DST, 'B', body, true));
}

/* Every frame of round `round`: each of the 1,000 variables = round. */
static void send_round(struct fx *f, unsigned long long round)
{
        char frame[BENCHLINK_FRAME_MAX];

        for (int i = 0; i < BENCHLINK_FRAMES; i++)
                send_frame(f, frame, benchlink_round_frame(frame, i, round));
}

static int changed(struct fx *f)
{
        int n = sl_changed(f->cl, &f->cursor, f->ids, IDS_MAX, &f->flags);

        assert_true(n >= 0);
        return n;
}

/* A first call: everything once; then nothing pending. */
static void start(struct fx *f)
{
        assert_int_equal(changed(f), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_START);
        sl_wait(f->cl, &f->wait, 0);
}

static long read_long(struct fx *f, int id)
{
        long v = -1;

        assert_int_equal(sl_read_long(f->cl, id, &v, NULL), 0);
        return v;
}

/* Waits for a change (bounded), then takes what changed into f->ids; the count. */
static int wait_changed(struct fx *f)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)T_WAIT_MS * 1000000u;

        for (;;) {
                int n = changed(f);

                if (n > 0 || f->flags)
                        return n;
                assert_true(harness_now_ns() < deadline);
                sl_wait(f->cl, &f->wait, 100);
        }
}

/* A round's values come back as the ids of all 1,000 variables, each read with the round's
 * value (other ids, e.g. of a peer's variables turning stale, would read another). */
static void test_round_names_its_variables(void **state)
{
        struct fx *f = *state;
        static bool seen[BENCHLINK_VARS];
        int count = sl_count(f->cl), got = 0;
        const unsigned long long round = 4242;

        assert_int_equal(count, BENCHLINK_VARS);
        start(f);
        send_round(f, round);
        while (got < BENCHLINK_VARS) {
                int n = wait_changed(f);

                assert_int_equal(f->flags & SL_CHANGED_ALL, 0);
                for (int i = 0; i < n; i++) {
                        assert_true(f->ids[i] >= 0 && f->ids[i] < count);
                        assert_int_equal(read_long(f, f->ids[i]), (long)round);
                        got += !seen[f->ids[i]];
                        seen[f->ids[i]] = true;
                }
        }
}

/*
 * The answer after the wake-up a frame v0 = value caused, the way a bridge takes it (wake, ask
 * what changed, read only that): v0 alone (nothing else changes: the peers never go stale here),
 * never "read everything", and read as the frame's value, not an older one.
 */
static void expect_v0(struct fx *f, int v0, long value)
{
        int n = wait_changed(f);

        assert_int_equal(f->flags, 0);
        for (int i = 0; i < n; i++)
                assert_int_equal(f->ids[i], v0);
        assert_int_equal(read_long(f, v0), value);
}

/* Frame by frame: each value is read right after the wake-up it caused. */
static void test_follow_reads_never_older(void **state)
{
        struct fx *f = *state;
        int v0 = sl_find(f->cl, "v0");

        assert_true(v0 >= 0);
        start(f);
        for (long k = 1; k <= STEPS; k++) {
                send_v0(f, k);
                expect_v0(f, v0, k);
        }
}

/* More changes than the record holds between two calls: everything once, then ids again. */
static void test_overrun(void **state)
{
        struct fx *f = *state;
        int v0 = sl_find(f->cl, "v0"), v999 = sl_find(f->cl, "v999");

        start(f);
        for (unsigned long long r = 1; r <= OVERRUN_ROUNDS; r++)
                send_round(f, r);
        while (read_long(f, v999) != OVERRUN_ROUNDS)
                assert_true(sl_wait(f->cl, &f->wait, T_WAIT_MS) == 1);
        assert_int_equal(changed(f), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_OVERRUN);
        send_v0(f, 77);
        expect_v0(f, v0, 77);
}

/* A daemon restart: ids resolved anew (everything once), then the same id for the same name. */
static void test_daemon_restart(void **state)
{
        struct fx *f = *state;
        int v0 = sl_find(f->cl, "v0"), st = 0;

        start(f);
        assert_true(harness_stop_daemon(&f->h, SIGTERM, T_STOP_MS) >= 0);
        assert_int_equal(harness_start_daemon(&f->h, f->config, T_START_MS, &st, NULL), 0);
        assert_int_equal(wait_changed(f), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_REMAPPED);
        assert_int_equal(sl_find(f->cl, "v0"), v0);
        send_v0(f, 6);
        expect_v0(f, v0, 6);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_round_names_its_variables, setup, teardown),
                cmocka_unit_test_setup_teardown(test_follow_reads_never_older, setup, teardown),
                cmocka_unit_test_setup_teardown(test_overrun, setup, teardown),
                cmocka_unit_test_setup_teardown(test_daemon_restart, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
