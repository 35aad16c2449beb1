/*
 * notify: a test NOTIFY_SOCKET (a path socket and an abstract one) receives READY=1, STATUS=,
 * WATCHDOG=1, RELOADING=1 + MONOTONIC_USEC=, STOPPING=1; the watchdog period is read from the
 * environment; no socket means no-op. Runs against whichever backend the build selected, and
 * also exercises the built-in datagram sender directly.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <inttypes.h>
#include <poll.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include <cmocka.h>

#include "svc/notify.h"

#define WAIT_MS 5000
#define FILL_MAX        100000  /* datagrams: far more than any receive queue holds */
#define STALL_GUARD_S   60      /* a test that hangs this long is killed, not waited for */

struct sock {
        int fd;
        char dir[64];
        char name[sizeof(((struct sockaddr_un *)NULL)->sun_path) + 1];   /* as in NOTIFY_SOCKET */
};

/* Binds a datagram socket: a path in a temp dir, or an abstract name ("@..."). */
static void sock_open(struct sock *s, bool abstract)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        socklen_t len;

        s->fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        assert_true(s->fd >= 0);
        s->dir[0] = '\0';
        if (abstract) {
                snprintf(s->name, sizeof(s->name), "@sharedlink-test-notify-%ld", (long)getpid());
                memcpy(sa.sun_path, s->name, strlen(s->name));
                sa.sun_path[0] = '\0';
                len = (socklen_t)(offsetof(struct sockaddr_un, sun_path) + strlen(s->name));
        } else {
                snprintf(s->dir, sizeof(s->dir), "/tmp/slnotify.XXXXXX");
                assert_non_null(mkdtemp(s->dir));
                snprintf(s->name, sizeof(s->name), "%s/notify", s->dir);
                strcpy(sa.sun_path, s->name);
                len = sizeof(sa);
        }
        assert_int_equal(bind(s->fd, (struct sockaddr *)&sa, len), 0);
}

static void sock_close(struct sock *s)
{
        close(s->fd);
        if (s->dir[0]) {
                unlink(s->name);
                rmdir(s->dir);
        }
}

/* Receives one datagram as a string. */
static const char *sock_recv(struct sock *s)
{
        static char buf[1024];
        struct pollfd p = { .fd = s->fd, .events = POLLIN };
        ssize_t n;

        assert_int_equal(poll(&p, 1, WAIT_MS), 1);
        n = recv(s->fd, buf, sizeof(buf) - 1, 0);
        assert_true(n >= 0);
        buf[n] = '\0';
        return buf;
}

static bool sock_empty(struct sock *s)
{
        struct pollfd p = { .fd = s->fd, .events = POLLIN };

        return poll(&p, 1, 0) == 0;
}

static uint64_t mono_usec(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static void sequence(bool abstract)
{
        struct notify *n;
        struct sock s;
        const char *msg;
        uint64_t before, stamp;

        sock_open(&s, abstract);
        setenv("NOTIFY_SOCKET", s.name, 1);
        assert_int_equal(notify_new(&n), 0);
        assert_true(notify_enabled(n));

        assert_int_equal(notify_ready(n), 1);
        assert_string_equal(sock_recv(&s), "READY=1");
        assert_int_equal(notify_status(n, "links up %d/%d", 1, 2), 1);
        assert_string_equal(sock_recv(&s), "STATUS=links up 1/2");
        /* A newline cannot smuggle in another assignment. */
        assert_int_equal(notify_status(n, "%s", "evil\nREADY=1"), 1);
        assert_string_equal(sock_recv(&s), "STATUS=evil READY=1");
        assert_int_equal(notify_watchdog(n), 1);
        assert_string_equal(sock_recv(&s), "WATCHDOG=1");

        before = mono_usec();
        assert_int_equal(notify_reloading(n), 1);
        msg = sock_recv(&s);
        assert_int_equal(sscanf(msg, "RELOADING=1\nMONOTONIC_USEC=%" SCNu64, &stamp), 1);
        assert_true(stamp >= before && stamp <= mono_usec());

        assert_int_equal(notify_stopping(n), 1);
        assert_string_equal(sock_recv(&s), "STOPPING=1");
        assert_true(sock_empty(&s));
        notify_free(n);
        unsetenv("NOTIFY_SOCKET");
        sock_close(&s);
}

static void test_path_socket(void **state)
{
        (void)state;
        sequence(false);
}

static void test_abstract_socket(void **state)
{
        (void)state;
        sequence(true);
}

static void test_no_socket_is_noop(void **state)
{
        struct notify *n;

        (void)state;
        unsetenv("NOTIFY_SOCKET");
        setenv("WATCHDOG_USEC", "2000000", 1);
        assert_int_equal(notify_new(&n), 0);
        assert_false(notify_enabled(n));
        assert_int_equal(notify_ready(n), 0);
        assert_int_equal(notify_status(n, "x"), 0);
        assert_int_equal(notify_watchdog(n), 0);
        assert_int_equal(notify_reloading(n), 0);
        assert_int_equal(notify_stopping(n), 0);
        assert_int_equal(notify_watchdog_usec(n), 0);
        notify_free(n);
        unsetenv("WATCHDOG_USEC");
        assert_null(notify_free(NULL));
        assert_false(notify_enabled(NULL));
}

static void test_watchdog_env(void **state)
{
        struct sock s;
        char pid[32];
        static const struct {
                const char *usec, *pid;         /* pid "self" = ours */
                uint64_t expect_usec, expect_ms;
        } table[] = {
                { "3000000", "self", 3000000, 1500 },
                { "3000000", NULL, 3000000, 1500 },
                { "3000000", "1", 0, 0 },       /* meant for another process */
                { NULL, NULL, 0, 0 },
                { "500", "self", 500, 1 },      /* never 0 ms while enabled */
        };

        (void)state;
        sock_open(&s, false);
        setenv("NOTIFY_SOCKET", s.name, 1);
        snprintf(pid, sizeof(pid), "%ld", (long)getpid());
        for (size_t i = 0; i < sizeof(table) / sizeof(table[0]); i++) {
                struct notify *n;

                if (table[i].usec)
                        setenv("WATCHDOG_USEC", table[i].usec, 1);
                else
                        unsetenv("WATCHDOG_USEC");
                if (table[i].pid)
                        setenv("WATCHDOG_PID", strcmp(table[i].pid, "self") ? table[i].pid : pid,
                               1);
                else
                        unsetenv("WATCHDOG_PID");
                assert_int_equal(notify_new(&n), 0);
                assert_int_equal(notify_watchdog_usec(n), table[i].expect_usec);
                assert_int_equal(notify_watchdog_interval_ms(n), table[i].expect_ms);
                notify_free(n);
        }
        unsetenv("WATCHDOG_USEC");
        unsetenv("WATCHDOG_PID");
        unsetenv("NOTIFY_SOCKET");
        sock_close(&s);
}

/* The built-in sender, whatever backend notify_send() uses in this build. */
static void test_datagram_sender(void **state)
{
        struct sock s;
        char longname[200];

        (void)state;
        sock_open(&s, false);
        assert_int_equal(notify_send_datagram(s.name, "READY=1\nSTATUS=ok", 0), 1);
        assert_string_equal(sock_recv(&s), "READY=1\nSTATUS=ok");
        sock_close(&s);
        sock_open(&s, true);
        assert_int_equal(notify_send_datagram(s.name, "STOPPING=1", NOTIFY_ONCE_WAIT_MS), 1);
        assert_string_equal(sock_recv(&s), "STOPPING=1");
        sock_close(&s);

        assert_int_equal(notify_send_datagram("relative/path", "x", 0), -EAFNOSUPPORT);
        assert_int_equal(notify_send_datagram("", "x", 0), -EINVAL);
        memset(longname, 'a', sizeof(longname) - 1);
        longname[0] = '/';
        longname[sizeof(longname) - 1] = '\0';
        assert_int_equal(notify_send_datagram(longname, "x", 0), -EINVAL);
        /* Nobody listening. */
        assert_int_equal(notify_send_datagram("/nonexistent/notify.sock", "x", 0), -ENOENT);
}

/* A manager that does not read: its queue fills, and no message makes the caller wait without
 * bound (sd_notify() would: the daemon's loop, watchdog included, stalled behind it). The
 * periodic ones do not wait at all, READY=1 at most NOTIFY_ONCE_WAIT_MS; all are counted. */
static void test_full_queue_never_stalls(void **state)
{
        struct notify *n;
        struct sock s;
        int filled = 0;

        (void)state;
        /* A hang is the failure this test looks for: end it rather than the whole run. */
        alarm(STALL_GUARD_S);
        sock_open(&s, false);
        while (notify_send_datagram(s.name, "X", 0) == 1 && filled < FILL_MAX)
                filled++;
        assert_true(filled > 0 && filled < FILL_MAX);   /* the queue is full now */
        setenv("NOTIFY_SOCKET", s.name, 1);
        assert_int_equal(notify_new(&n), 0);
        assert_int_equal(notify_status(n, "links up %d/%d", 0, 1), -EAGAIN);
        assert_int_equal(notify_watchdog(n), -EAGAIN);
        assert_int_equal(notify_ready(n), -EAGAIN);
        assert_int_equal(notify_failed(n), 3);
        /* Room again: the next message goes. */
        assert_string_equal(sock_recv(&s), "X");
        assert_int_equal(notify_watchdog(n), 1);
        assert_int_equal(notify_failed(n), 3);
        alarm(0);
        notify_free(n);
        unsetenv("NOTIFY_SOCKET");
        sock_close(&s);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_path_socket),
                cmocka_unit_test(test_abstract_socket),
                cmocka_unit_test(test_no_socket_is_noop),
                cmocka_unit_test(test_watchdog_env),
                cmocka_unit_test(test_datagram_sender),
                cmocka_unit_test(test_full_queue_never_stalls),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
