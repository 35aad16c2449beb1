/*
 * channel: a reconnecting transport on real ptys and loopback UDP.
 *
 * Unplugging is played by the test closing its side of a pty pair (the channel's tty hangs up)
 * and pointing the device symlink at a name that does not exist; plugging back in is a new pty
 * pair behind the same symlink. (The symlink never points at a freed /dev/pts/N, which another
 * process might get next.) Backoff is checked as the sequence of scheduled delays reported by
 * the down callback, never as wall time; every loop run has a guard timer.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmocka.h>

#include "common/harness.h"
#include "daemon/channel.h"
#include "svc/evloop.h"

#define WAIT_MS         5000
#define GUARD_MS        15000
#define DOWNS_MAX       16
#define IN_MAX          (64 * 1024)

struct link {
        struct evloop *loop;
        struct channel *ch;
        struct evloop_timer guard;
        char dir[64];
        char dev[TRANSPORT_PATH_MAX];   /* the symlink the channel opens */
        char absent[TRANSPORT_PATH_MAX];

        int ups, downs;
        unsigned retry[DOWNS_MAX];
        char reason[DOWNS_MAX][CHANNEL_REASON_MAX];
        char in[IN_MAX];
        size_t in_len, datagrams;
        size_t dgram_len[DOWNS_MAX];

        /* When to stop the loop, and what to do in callbacks. */
        size_t want_in;
        size_t want_datagrams;
        int want_downs;
        bool exit_on_up;
        void (*down_hook)(struct link *l);
        bool free_in_input, free_in_down;
};

/* ---------------------------------------------------------------------------------------------
 * Fixture */

static void on_guard(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        (void)loop;
        (void)timer;
        (void)arg;
        fail_msg("guard timer fired: the awaited channel event never came");
}

static int setup(void **state)
{
        struct link *l = calloc(1, sizeof(*l));

        if (!l)
                return -1;
        snprintf(l->dir, sizeof(l->dir), "/tmp/slchannel.XXXXXX");
        if (!mkdtemp(l->dir) || evloop_new(&l->loop) < 0)
                return -1;
        snprintf(l->dev, sizeof(l->dev), "%s/ttyLINK", l->dir);
        snprintf(l->absent, sizeof(l->absent), "%s/unplugged", l->dir);
        evloop_timer_init(&l->guard, l->loop, on_guard, NULL);
        if (evloop_timer_arm(&l->guard, GUARD_MS, 0) < 0)
                return -1;
        *state = l;
        return 0;
}

static int teardown(void **state)
{
        struct link *l = *state;
        char cmd[HARNESS_PATH_MAX + 32];

        channel_free(l->ch);
        evloop_timer_cancel(&l->guard);
        evloop_free(l->loop);
        snprintf(cmd, sizeof(cmd), "rm -rf '%s'", l->dir);
        free(l);
        return system(cmd) == 0 ? 0 : -1;
}

/* Points the device symlink at target, atomically (as udev would replace a by-id link). */
static void repoint(struct link *l, const char *target)
{
        char tmp[TRANSPORT_PATH_MAX + 8];

        snprintf(tmp, sizeof(tmp), "%s.new", l->dev);
        unlink(tmp);
        assert_int_equal(symlink(target, tmp), 0);
        assert_int_equal(rename(tmp, l->dev), 0);
}

/* ---------------------------------------------------------------------------------------------
 * Callbacks */

static void on_up(struct channel *ch, void *arg)
{
        struct link *l = arg;

        assert_ptr_equal(ch, l->ch);
        assert_int_equal(channel_state(ch), CHANNEL_STATE_UP);
        l->ups++;
        if (l->exit_on_up)
                evloop_exit(l->loop, 0);
}

static void on_down(struct channel *ch, const char *reason, unsigned retry_ms, void *arg)
{
        struct link *l = arg;

        assert_int_equal(channel_state(ch), CHANNEL_STATE_BACKOFF);
        assert_int_equal(channel_retry_ms(ch), retry_ms);
        assert_true(l->downs < DOWNS_MAX);
        l->retry[l->downs] = retry_ms;
        snprintf(l->reason[l->downs], CHANNEL_REASON_MAX, "%s", reason);
        l->downs++;
        if (l->down_hook)
                l->down_hook(l);
        if (l->free_in_down) {
                l->ch = channel_free(ch);
                evloop_exit(l->loop, 0);
                return;
        }
        if (l->want_downs && l->downs >= l->want_downs)
                evloop_exit(l->loop, 0);
}

static void on_input(struct channel *ch, const uint8_t *data, size_t len, void *arg)
{
        struct link *l = arg;

        assert_true(l->in_len + len <= IN_MAX);
        memcpy(l->in + l->in_len, data, len);
        l->in_len += len;
        if (l->datagrams < DOWNS_MAX)
                l->dgram_len[l->datagrams] = len;
        l->datagrams++;
        if (l->free_in_input) {
                l->ch = channel_free(ch);
                evloop_exit(l->loop, 0);
                return;
        }
        if ((l->want_in && l->in_len >= l->want_in) ||
            (l->want_datagrams && l->datagrams >= l->want_datagrams))
                evloop_exit(l->loop, 0);
}

static const struct channel_ops link_ops = { on_up, on_down, on_input };

static void run(struct link *l)
{
        assert_int_equal(evloop_run(l->loop), 0);
}

static void new_serial(struct link *l, const struct channel_options *opts, const char *dev2)
{
        struct transport_params p;

        transport_params_init(&p, TRANSPORT_SERIAL);
        assert_int_equal(transport_params_add_device(&p, l->dev), 0);
        if (dev2)
                assert_int_equal(transport_params_add_device(&p, dev2), 0);
        assert_int_equal(channel_new(l->loop, &p, opts, &link_ops, l, &l->ch), 0);
        assert_int_equal(channel_state(l->ch), CHANNEL_STATE_STOPPED);
}

struct pty_pair {
        int master, slave;
        char path[HARNESS_PATH_MAX];
};

static void plug(struct link *l, struct pty_pair *pp)
{
        assert_int_equal(harness_openpty(&pp->master, &pp->slave, pp->path), 0);
        repoint(l, pp->path);
}

/* The device goes away: the link names nothing, the pty pair is closed (hang-up). */
static void unplug(struct link *l, struct pty_pair *pp)
{
        repoint(l, l->absent);
        close(pp->master);
        close(pp->slave);
        pp->master = pp->slave = -1;
}

static void expect_input(struct link *l, const char *text)
{
        size_t len = strlen(text);

        l->in_len = 0;
        l->want_in = len;
        run(l);
        l->want_in = 0;
        assert_int_equal(l->in_len, len);
        assert_memory_equal(l->in, text, len);
}

/* ---------------------------------------------------------------------------------------------
 * Tests */

static struct pty_pair replug_pair;

static void replug_on_second_down(struct link *l)
{
        if (l->downs == 2)
                plug(l, &replug_pair);
}

static void test_unplug_backoff_reopen(void **state)
{
        struct link *l = *state;
        struct channel_stats st;
        struct pty_pair pp;
        char buf[64];

        plug(l, &pp);
        new_serial(l, NULL, NULL);
        assert_int_equal(channel_start(l->ch), 0);
        assert_int_equal(channel_start(l->ch), -EALREADY);
        assert_int_equal(channel_state(l->ch), CHANNEL_STATE_UP);
        assert_string_equal(channel_device(l->ch), l->dev);
        assert_non_null(channel_transport(l->ch));
        assert_int_equal(l->ups, 0);                    /* start reports by its return */

        assert_int_equal(harness_write_all(pp.master, "hello", 5, WAIT_MS), 0);
        expect_input(l, "hello");
        assert_int_equal(channel_send(l->ch, "world\n", 6), 0);
        assert_int_equal(harness_read_until(pp.master, buf, sizeof(buf), '\n', WAIT_MS), 6);

        /* Unplug: hang-up, then the device is missing, then it comes back. */
        unplug(l, &pp);
        l->down_hook = replug_on_second_down;
        l->exit_on_up = true;
        run(l);
        assert_int_equal(l->downs, 2);
        assert_int_equal(l->ups, 1);
        assert_string_equal(l->reason[0], "hang-up");
        assert_int_equal(l->retry[0], CHANNEL_BACKOFF_MIN_MS);
        assert_non_null(strstr(l->reason[1], l->dev));
        assert_non_null(strstr(l->reason[1], strerror(ENOENT)));
        assert_int_equal(l->retry[1], 2 * CHANNEL_BACKOFF_MIN_MS);
        assert_int_equal(channel_state(l->ch), CHANNEL_STATE_UP);
        assert_int_equal(channel_retry_ms(l->ch), 0);
        channel_get_stats(l->ch, &st);
        assert_int_equal(st.opens, 2);
        assert_int_equal(st.reopens, 1);
        assert_int_equal(st.open_failures, 1);
        assert_int_equal(st.downs, 1);
        assert_int_equal(st.bytes_in, 5);
        assert_int_equal(st.bytes_out, 6);

        /* Carries on with the new device. */
        assert_int_equal(harness_write_all(replug_pair.master, "again", 5, WAIT_MS), 0);
        expect_input(l, "again");

        /* Unplugged again at once: a flapping device keeps doubling (it was up for far less
         * than CHANNEL_BACKOFF_MAX_MS). */
        l->down_hook = NULL;
        l->exit_on_up = false;
        l->want_downs = 3;
        unplug(l, &replug_pair);
        run(l);
        assert_string_equal(l->reason[2], "hang-up");
        assert_int_equal(l->retry[2], 4 * CHANNEL_BACKOFF_MIN_MS);
}

static void test_missing_devices_doubling(void **state)
{
        struct link *l = *state;
        const struct channel_options opts = { .backoff_min_ms = 10, .backoff_max_ms = 80 };
        static const unsigned expect[] = { 20, 40, 80, 80, 80 };
        char other[TRANSPORT_PATH_MAX];
        struct channel_stats st;

        snprintf(other, sizeof(other), "%s/ttyOTHER", l->dir);
        new_serial(l, &opts, other);
        assert_int_equal(channel_start(l->ch), -ENOENT);
        assert_int_equal(channel_state(l->ch), CHANNEL_STATE_BACKOFF);
        assert_int_equal(channel_retry_ms(l->ch), 10);
        assert_non_null(strstr(channel_reason(l->ch), l->dev));
        assert_string_equal(channel_device(l->ch), other);      /* tried next */
        assert_int_equal(channel_send(l->ch, "x", 1), -ENOTCONN);

        l->want_downs = 5;
        run(l);
        for (int i = 0; i < 5; i++) {
                assert_int_equal(l->retry[i], expect[i]);
                /* Devices tried in turn: other, dev, other, ... */
                assert_non_null(strstr(l->reason[i], i % 2 == 0 ? other : l->dev));
        }
        channel_get_stats(l->ch, &st);
        assert_int_equal(st.open_failures, 6);
        assert_int_equal(st.opens, 0);
        assert_int_equal(st.tx_dropped, 1);
        channel_stop(l->ch);
        assert_int_equal(channel_state(l->ch), CHANNEL_STATE_STOPPED);
        assert_int_equal(channel_retry_ms(l->ch), 0);
}

/* The real constants: the first delays are 100 then 200 ms. */
static void test_missing_device_default_delays(void **state)
{
        struct link *l = *state;

        new_serial(l, NULL, NULL);
        assert_int_equal(channel_start(l->ch), -ENOENT);
        assert_int_equal(channel_retry_ms(l->ch), CHANNEL_BACKOFF_MIN_MS);
        l->want_downs = 1;
        run(l);
        assert_int_equal(l->retry[0], 2 * CHANNEL_BACKOFF_MIN_MS);
}

static struct pty_pair stable_pair;

static void plug_on_first_down(struct link *l)
{
        if (l->downs == 1)
                plug(l, &stable_pair);
}

static void on_wait_done(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        (void)timer;
        (void)arg;
        evloop_exit(loop, 0);
}

/* A link that stayed up for backoff_max starts over at backoff_min. */
static void test_backoff_resets_when_stable(void **state)
{
        struct link *l = *state;
        const struct channel_options opts = { .backoff_min_ms = 10, .backoff_max_ms = 80 };
        struct evloop_timer wait;

        new_serial(l, &opts, NULL);
        assert_int_equal(channel_start(l->ch), -ENOENT);        /* next delays: 10, 20, 40 */
        l->down_hook = plug_on_first_down;
        l->exit_on_up = true;
        run(l);
        assert_int_equal(l->retry[0], 20);
        assert_int_equal(l->ups, 1);

        /* Up for longer than backoff_max (an event: a loop timer, not a sleep). */
        evloop_timer_init(&wait, l->loop, on_wait_done, NULL);
        assert_int_equal(evloop_timer_arm(&wait, 2 * opts.backoff_max_ms, 0), 0);
        run(l);

        l->down_hook = NULL;
        l->exit_on_up = false;
        l->want_downs = 2;
        unplug(l, &stable_pair);
        run(l);
        assert_string_equal(l->reason[1], "hang-up");
        assert_int_equal(l->retry[1], opts.backoff_min_ms);
}

/* Output: partial writes and EAGAIN queue the rest, a full queue refuses whole frames, POLLOUT
 * is asked for only while something is queued. */
struct drain {
        int fd;
        char buf[IN_MAX];
        size_t len, want;
};

static void on_master_readable(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct drain *d = arg;
        ssize_t n;

        (void)revents;
        while ((n = read(fd, d->buf + d->len, sizeof(d->buf) - d->len)) > 0)
                d->len += (size_t)n;
        if (d->len >= d->want)
                evloop_exit(loop, 0);
}

static void test_output_queue(void **state)
{
        struct link *l = *state;
        const struct channel_options opts = { .outq_bytes = 1024 };
        static struct drain d;
        struct evloop_stats before, after;
        struct evloop_timer wait;
        struct channel_stats st;
        struct pty_pair pp;
        char frame[16], *expect;
        unsigned accepted = 0;
        int r;

        plug(l, &pp);
        new_serial(l, &opts, NULL);
        assert_int_equal(channel_start(l->ch), 0);
        /* Nobody reads the master: the pty fills, then the queue, then frames are refused. */
        for (;;) {
                snprintf(frame, sizeof(frame), "F%05u\n", accepted % 100000);
                r = channel_send(l->ch, frame, 7);
                if (r == -ENOBUFS)
                        break;
                assert_int_equal(r, 0);
                accepted++;
                assert_true(accepted < 100000);
        }
        assert_true(channel_queued(l->ch) > 1024 - 7);
        assert_true(accepted * 7 > 1024);               /* the kernel took its share */
        assert_int_equal(channel_send(l->ch, "", 0), 0);
        {
                char big[1025] = { 0 };

                assert_int_equal(channel_send(l->ch, big, sizeof(big)), -EMSGSIZE);
        }
        channel_get_stats(l->ch, &st);
        assert_int_equal(st.tx_dropped, 2);

        /* Drain the master through the loop: everything accepted arrives, in order, whole. */
        memset(&d, 0, sizeof(d));
        d.fd = pp.master;
        d.want = accepted * 7;
        assert_true(d.want <= sizeof(d.buf));
        assert_int_equal(evloop_add_fd(l->loop, pp.master, POLLIN, on_master_readable, &d), 0);
        run(l);
        assert_int_equal(d.len, d.want);
        expect = malloc(d.want + 1);
        assert_non_null(expect);
        for (unsigned i = 0; i < accepted; i++)
                snprintf(expect + 7 * i, 8, "F%05u\n", i % 100000);
        assert_memory_equal(d.buf, expect, d.want);
        free(expect);
        assert_int_equal(channel_queued(l->ch), 0);
        channel_get_stats(l->ch, &st);
        assert_int_equal(st.bytes_out, d.want);

        /* Queue empty: no POLLOUT, so an idle wait is exactly one wakeup (the timer). */
        evloop_get_stats(l->loop, &before);
        evloop_timer_init(&wait, l->loop, on_wait_done, NULL);
        assert_int_equal(evloop_timer_arm(&wait, 30, 0), 0);
        run(l);
        evloop_get_stats(l->loop, &after);
        assert_int_equal(after.wakeups - before.wakeups, 1);
        assert_int_equal(after.fd_events - before.fd_events, 0);
        assert_int_equal(evloop_del_fd(l->loop, pp.master), 0);
        close(pp.master);
        close(pp.slave);
}

/* A write that fails for good is reported by the loop, not from inside channel_send(). */
static void test_write_error_goes_down_from_loop(void **state)
{
        struct link *l = *state;
        struct pty_pair pp;
        int r;

        plug(l, &pp);
        new_serial(l, NULL, NULL);
        assert_int_equal(channel_start(l->ch), 0);
        unplug(l, &pp);
        r = channel_send(l->ch, "x", 1);
        assert_true(r < 0 && r != -EAGAIN);
        assert_int_equal(l->downs, 0);
        assert_int_equal(channel_state(l->ch), CHANNEL_STATE_UP);
        assert_int_equal(channel_send(l->ch, "y", 1), -ENOTCONN);
        l->want_downs = 1;
        run(l);
        assert_non_null(strstr(l->reason[0], "write: "));
}

static void test_fail_moves_to_next_device(void **state)
{
        struct link *l = *state;
        const struct channel_options opts = { .backoff_min_ms = 10, .backoff_max_ms = 80 };
        char other[TRANSPORT_PATH_MAX];
        struct channel_stats st;
        struct pty_pair pp;

        snprintf(other, sizeof(other), "%s/ttyOTHER", l->dir);
        plug(l, &pp);
        new_serial(l, &opts, other);
        assert_int_equal(channel_start(l->ch), 0);
        channel_fail(l->ch, "no login reply");
        assert_int_equal(channel_state(l->ch), CHANNEL_STATE_BACKOFF);
        assert_string_equal(channel_reason(l->ch), "no login reply");
        assert_string_equal(channel_device(l->ch), other);
        assert_int_equal(l->downs, 0);                  /* no callback from inside the call */
        channel_fail(l->ch, "ignored while down");
        assert_string_equal(channel_reason(l->ch), "no login reply");
        channel_get_stats(l->ch, &st);
        assert_int_equal(st.downs, 1);

        /* other is missing, then the first device opens again. */
        l->exit_on_up = true;
        run(l);
        assert_int_equal(l->downs, 1);
        assert_non_null(strstr(l->reason[0], other));
        assert_string_equal(channel_device(l->ch), l->dev);
        close(pp.master);
        close(pp.slave);
}

static void test_free_from_callbacks(void **state)
{
        struct link *l = *state;
        struct pty_pair pp;

        plug(l, &pp);
        new_serial(l, NULL, NULL);
        assert_int_equal(channel_start(l->ch), 0);
        l->free_in_input = true;
        assert_int_equal(harness_write_all(pp.master, "bye", 3, WAIT_MS), 0);
        run(l);
        assert_null(l->ch);

        /* Again from the down callback. */
        l->free_in_input = false;
        l->free_in_down = true;
        new_serial(l, NULL, NULL);
        assert_int_equal(channel_start(l->ch), 0);
        unplug(l, &pp);
        run(l);
        assert_null(l->ch);
        assert_int_equal(l->downs, 1);
}

static void test_pty_kind_survives_peers(void **state)
{
        struct link *l = *state;
        struct transport_params p;
        struct evloop_timer wait;
        struct channel_stats st;
        char buf[32];

        transport_params_init(&p, TRANSPORT_PTY);
        assert_int_equal(transport_params_add_device(&p, l->dev), 0);
        assert_int_equal(channel_new(l->loop, &p, NULL, &link_ops, l, &l->ch), 0);
        assert_int_equal(channel_start(l->ch), 0);
        assert_non_null(transport_pty_slave(channel_transport(l->ch)));
        for (int round = 0; round < 3; round++) {
                int peer = open(l->dev, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);

                assert_true(peer >= 0);
                assert_int_equal(harness_write_all(peer, "ping", 4, WAIT_MS), 0);
                expect_input(l, "ping");
                assert_int_equal(channel_send(l->ch, "pong\n", 5), 0);
                assert_int_equal(harness_read_until(peer, buf, sizeof(buf), '\n', WAIT_MS), 5);
                close(peer);
                /* No peer: the link stays up through a loop round. */
                evloop_timer_init(&wait, l->loop, on_wait_done, NULL);
                assert_int_equal(evloop_timer_arm(&wait, 20, 0), 0);
                run(l);
                assert_int_equal(channel_state(l->ch), CHANNEL_STATE_UP);
        }
        channel_get_stats(l->ch, &st);
        assert_int_equal(st.downs, 0);
        assert_int_equal(l->downs, 0);
        channel_stop(l->ch);
        assert_int_equal(access(l->dev, F_OK), -1);     /* symlink removed */
}

static unsigned free_udp_port(void)
{
        struct sockaddr_in sa = { .sin_family = AF_INET };
        socklen_t len = sizeof(sa);
        unsigned port;
        int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);

        assert_true(fd >= 0);
        sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        assert_int_equal(bind(fd, (struct sockaddr *)&sa, sizeof(sa)), 0);
        assert_int_equal(getsockname(fd, (struct sockaddr *)&sa, &len), 0);
        port = ntohs(sa.sin_port);
        close(fd);
        return port;
}

static void test_udp_datagrams(void **state)
{
        struct link *l = *state;
        struct link *peer = calloc(1, sizeof(*peer));
        struct transport_params pa, pb;
        struct channel_stats st;
        char addr[TRANSPORT_ADDR_MAX];
        static const char *const frames[] = { "[:BA|N0|D1|C00]", "[:BA|N0|D22|C00]", "[x]" };
        static char big[TRANSPORT_DATAGRAM_MAX + 1];

        assert_non_null(peer);
        peer->loop = l->loop;
        snprintf(addr, sizeof(addr), "127.0.0.1:%u", free_udp_port());
        transport_params_init(&pb, TRANSPORT_UDP);
        assert_int_equal(transport_params_set_udp(&pb, addr, NULL), 0);
        assert_int_equal(channel_new(l->loop, &pb, NULL, &link_ops, l, &l->ch), 0);
        assert_int_equal(channel_start(l->ch), 0);
        transport_params_init(&pa, TRANSPORT_UDP);
        assert_int_equal(transport_params_set_udp(&pa, NULL, addr), 0);
        assert_int_equal(channel_new(l->loop, &pa, NULL, &link_ops, peer, &peer->ch), 0);
        assert_int_equal(channel_start(peer->ch), 0);

        assert_int_equal(channel_send(l->ch, "x", 1), -EDESTADDRREQ);  /* nobody spoke yet */
        assert_int_equal(channel_state(l->ch), CHANNEL_STATE_UP);
        for (size_t i = 0; i < 3; i++)
                assert_int_equal(channel_send(peer->ch, frames[i], strlen(frames[i])), 0);
        assert_int_equal(channel_send(peer->ch, big, sizeof(big)), -EMSGSIZE);
        l->want_datagrams = 3;
        run(l);
        assert_int_equal(l->datagrams, 3);
        for (size_t i = 0, off = 0; i < 3; i++) {
                assert_int_equal(l->dgram_len[i], strlen(frames[i]));
                assert_memory_equal(l->in + off, frames[i], strlen(frames[i]));
                off += strlen(frames[i]);
        }

        /* The listener answers whoever spoke last. */
        assert_int_equal(channel_send(l->ch, "[:AB|G0|C00]", 12), 0);
        peer->want_datagrams = 1;
        run(peer);
        assert_int_equal(peer->in_len, 12);
        channel_get_stats(peer->ch, &st);
        assert_int_equal(st.datagrams_out, 3);
        assert_int_equal(st.datagrams_in, 1);
        assert_int_equal(st.tx_dropped, 1);
        channel_get_stats(l->ch, &st);
        assert_int_equal(st.datagrams_in, 3);
        assert_int_equal(st.io_errors, 1);              /* the -EDESTADDRREQ */
        channel_free(peer->ch);
        free(peer);
}

/*
 * Issue 13.8: a host sends before the vehicle's socket exists. On loopback the ICMP port
 * unreachable comes back within the first send, so the next send reports ECONNREFUSED and the
 * kernel drops that datagram: the channel sends it again and counts a refusal, not an io_error.
 * A refusal picked up by a read (POLLERR) is counted the same way.
 */
static void test_udp_peer_not_listening_yet(void **state)
{
        struct link *l = *state;
        struct link *peer = calloc(1, sizeof(*peer));
        struct transport_params pa, pb;
        struct channel_stats st;
        char addr[TRANSPORT_ADDR_MAX];

        assert_non_null(peer);
        peer->loop = l->loop;
        snprintf(addr, sizeof(addr), "127.0.0.1:%u", free_udp_port());
        transport_params_init(&pa, TRANSPORT_UDP);
        assert_int_equal(transport_params_set_udp(&pa, NULL, addr), 0);
        assert_int_equal(channel_new(l->loop, &pa, NULL, &link_ops, l, &l->ch), 0);
        assert_int_equal(channel_start(l->ch), 0);

        /* Nobody listens: the datagram goes, the ICMP answer waits on the socket. */
        assert_int_equal(channel_send(l->ch, "[:BA|P0|C78]", 12), 0);
        /* The peer starts; the next datagram must reach it, without an error anywhere. */
        transport_params_init(&pb, TRANSPORT_UDP);
        assert_int_equal(transport_params_set_udp(&pb, addr, NULL), 0);
        assert_int_equal(channel_new(l->loop, &pb, NULL, &link_ops, peer, &peer->ch), 0);
        assert_int_equal(channel_start(peer->ch), 0);
        assert_int_equal(channel_send(l->ch, "[:BA|G0|C6F]", 12), 0);
        peer->want_datagrams = 1;
        run(peer);
        assert_int_equal(peer->in_len, 12);
        assert_memory_equal(peer->in, "[:BA|G0|C6F]", 12);
        channel_get_stats(l->ch, &st);
        assert_int_equal(st.refused, 1);
        assert_int_equal(st.io_errors, 0);
        assert_int_equal(st.tx_dropped, 0);
        assert_int_equal(st.datagrams_out, 2);
        assert_int_equal(channel_state(l->ch), CHANNEL_STATE_UP);

        /* The peer goes away: the refusal of the next datagram is read by the loop (POLLERR). */
        peer->ch = channel_free(peer->ch);
        assert_int_equal(channel_send(l->ch, "[:BA|P0|C78]", 12), 0);
        while (channel_get_stats(l->ch, &st), st.refused < 2)
                assert_true(evloop_run_once(l->loop) >= 0);
        assert_int_equal(st.io_errors, 0);
        assert_int_equal(channel_state(l->ch), CHANNEL_STATE_UP);
        free(peer);
}

static void test_new_rejects_bad_input(void **state)
{
        struct link *l = *state;
        struct transport_params p;
        struct channel *ch = NULL;
        struct channel_options o = { .backoff_min_ms = 500, .backoff_max_ms = 100 };

        transport_params_init(&p, TRANSPORT_SERIAL);
        assert_int_equal(channel_new(l->loop, &p, NULL, NULL, NULL, &ch), -EINVAL);
        assert_int_equal(transport_params_add_device(&p, l->dev), 0);
        assert_int_equal(channel_new(l->loop, &p, &o, NULL, NULL, &ch), -EINVAL);
        o = (struct channel_options){ .outq_bytes = CHANNEL_OUTQ_MAX + 1 };
        assert_int_equal(channel_new(l->loop, &p, &o, NULL, NULL, &ch), -EINVAL);
        assert_int_equal(channel_new(NULL, &p, NULL, NULL, NULL, &ch), -EINVAL);
        assert_null(ch);
        assert_null(channel_free(NULL));
        /* No ops at all is allowed. */
        assert_int_equal(channel_new(l->loop, &p, NULL, NULL, NULL, &ch), 0);
        assert_int_equal(channel_send(ch, "x", 1), -ENOTCONN);
        channel_free(ch);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_unplug_backoff_reopen, setup, teardown),
                cmocka_unit_test_setup_teardown(test_missing_devices_doubling, setup, teardown),
                cmocka_unit_test_setup_teardown(test_missing_device_default_delays, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_backoff_resets_when_stable, setup, teardown),
                cmocka_unit_test_setup_teardown(test_output_queue, setup, teardown),
                cmocka_unit_test_setup_teardown(test_write_error_goes_down_from_loop, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_fail_moves_to_next_device, setup, teardown),
                cmocka_unit_test_setup_teardown(test_free_from_callbacks, setup, teardown),
                cmocka_unit_test_setup_teardown(test_pty_kind_survives_peers, setup, teardown),
                cmocka_unit_test_setup_teardown(test_udp_datagrams, setup, teardown),
                cmocka_unit_test_setup_teardown(test_udp_peer_not_listening_yet, setup, teardown),
                cmocka_unit_test_setup_teardown(test_new_rejects_bad_input, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
