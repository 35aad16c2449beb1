/*
 * Control socket server (control.c) in-process: a real Unix socket on a real event loop, clients
 * on the other end in the same process, the loop pumped by hand until the expected reply. The
 * request handler is the test: it answers at once, later (from a timer), or never, so that the
 * life of a request (pipelining, orphans, a server freed first) can be checked under ASan.
 * Peer credentials other than our own are covered by tests/integration/test_daemon.c (as nobody).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "common/ctlserver.h"
#include "common/harness.h"
#include "daemon/control.h"
#include "svc/evloop.h"
#include "svc/log.h"

#define T_GUARD_MS      5000    /* a test that waits longer has failed */
#define HELD_MAX        8
#define BUF_MAX         8192
#define BIG_LINE        4000    /* one DATA line of the slow-reader test */
#define BIG_LINES       400     /* 1.6 MB: more than any socket buffer plus CONTROL_REPLY_MAX */
#define FILLERS_MAX     4096    /* fds the out-of-fds test may hold */
#define PAUSES          3       /* accept pauses the out-of-fds test sits through */
#define T_IDLE_MS       20      /* idle timeout of the idle test */

enum mode {
        MODE_ECHO,              /* OK <argc> <argv...> at once */
        MODE_HOLD,              /* keep the request; the test answers it */
        MODE_FLOOD,             /* BIG_LINES DATA lines, then OK */
        MODE_STREAM,            /* like MODE_HOLD, and answered as soon as its client goes */
};

struct fixture {
        struct ctlserver srv;
        enum mode mode;
        struct control_request *held[HELD_MAX];
        unsigned n_held;
        unsigned calls;
        unsigned gone;                  /* gone callbacks seen (MODE_STREAM registers one) */
};

/* The client of a held request left: answer it at once, as a recorder does. */
static void on_gone(struct control_request *req, void *arg)
{
        struct fixture *f = arg;

        f->gone++;
        for (unsigned i = 0; i < f->n_held; i++) {
                if (f->held[i] == req) {
                        assert_false(control_request_alive(req));
                        control_reply_ok(req, "nobody reads this");
                        f->held[i] = NULL;
                        return;
                }
        }
        fail_msg("gone callback for a request the test does not hold");
}

static void on_request(struct control_request *req, int argc, char **argv, void *arg)
{
        struct fixture *f = arg;
        char text[2 * CTLP_LINE_MAX] = "";

        f->calls++;
        switch (f->mode) {
        case MODE_ECHO:
                for (int i = 0; i < argc; i++) {
                        strcat(text, " ");
                        strcat(text, argv[i]);
                }
                control_reply_ok(req, "%d%s", argc, text);
                break;
        case MODE_HOLD:
        case MODE_STREAM:
                assert_true(f->n_held < HELD_MAX);
                f->held[f->n_held++] = req;
                if (f->mode == MODE_STREAM)
                        control_request_on_gone(req, on_gone, f);
                break;
        case MODE_FLOOD: {
                static char big[BIG_LINE + 1];

                memset(big, 'x', BIG_LINE);
                for (int i = 0; i < BIG_LINES; i++)
                        control_reply_data(req, "%s", big);
                control_reply_ok(req, NULL);
                break;
        }
        }
}

static int setup(void **state)
{
        struct fixture *f = calloc(1, sizeof(*f));

        if (!f || ctlserver_init(&f->srv, "ctl", on_request, f) < 0)
                return -1;
        *state = f;
        return 0;
}

static int teardown(void **state)
{
        struct fixture *f = *state;

        ctlserver_free(&f->srv);
        free(f);
        return 0;
}

/* Runs the loop until done(f, arg) holds; fails after T_GUARD_MS. */
static void pump_until(struct fixture *f, int (*done)(struct fixture *f, void *arg), void *arg)
{
        f->srv.timed_out = 0;
        evloop_timer_arm(&f->srv.guard, T_GUARD_MS, 0);
        while (!done(f, arg)) {
                assert_int_equal(evloop_run_once(f->srv.loop), 0);
                if (f->srv.timed_out)
                        fail_msg("timed out waiting on the control server");
        }
        evloop_timer_cancel(&f->srv.guard);
}

/* One round of the loop, which has something to do (data sent to it): never blocks long. */
static void pump_once(struct fixture *f)
{
        f->srv.timed_out = 0;
        evloop_timer_arm(&f->srv.guard, T_GUARD_MS, 0);
        assert_int_equal(evloop_run_once(f->srv.loop), 0);
        assert_false(f->srv.timed_out);
        evloop_timer_cancel(&f->srv.guard);
}

static int client_connect(struct fixture *f)
{
        int fd = harness_connect_unix(f->srv.path);

        assert_true(fd >= 0);
        fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
        return fd;
}

static void client_send(int fd, const char *text)
{
        assert_int_equal(send(fd, text, strlen(text), MSG_NOSIGNAL), (ssize_t)strlen(text));
}

/* Reads what has arrived on fd into r (appending); 1 at EOF/reset. */
struct rx {
        int fd;
        char buf[BUF_MAX];
        size_t len;
        int eof;
        size_t lines_wanted;
        size_t total;           /* bytes seen, also those not kept */
};

static void rx_drain(struct rx *r)
{
        for (;;) {
                char tmp[4096];
                ssize_t n = recv(r->fd, tmp, sizeof(tmp), MSG_DONTWAIT);

                if (n > 0) {
                        size_t take = (size_t)n < sizeof(r->buf) - 1 - r->len ?
                                      (size_t)n : sizeof(r->buf) - 1 - r->len;

                        memcpy(r->buf + r->len, tmp, take);
                        r->len += take;
                        r->buf[r->len] = '\0';
                        r->total += (size_t)n;
                        continue;
                }
                if (n == 0 || (errno != EAGAIN && errno != EINTR))
                        r->eof = 1;
                return;
        }
}

static size_t count_lines(const char *s)
{
        size_t n = 0;

        for (; *s; s++)
                n += *s == '\n';
        return n;
}

static int rx_has_lines(struct fixture *f, void *arg)
{
        struct rx *r = arg;

        (void)f;
        rx_drain(r);
        return count_lines(r->buf) >= r->lines_wanted || r->eof;
}

static int rx_at_eof(struct fixture *f, void *arg)
{
        struct rx *r = arg;

        (void)f;
        rx_drain(r);
        return r->eof;
}

/* Sends text and waits for `lines` reply lines on fd. */
static void exchange(struct fixture *f, struct rx *r, const char *text, size_t lines)
{
        if (text)
                client_send(r->fd, text);
        r->lines_wanted = count_lines(r->buf) + lines;
        pump_until(f, rx_has_lines, r);
        assert_true(count_lines(r->buf) >= r->lines_wanted);
}

static int held_n(struct fixture *f, void *arg)
{
        return f->n_held >= (unsigned)(uintptr_t)arg;
}

static int orphaned_n(struct fixture *f, void *arg)
{
        struct control_stats st;

        control_get_stats(f->srv.ctl, &st);
        return st.orphaned >= (uint64_t)(uintptr_t)arg;
}

static int slow_n(struct fixture *f, void *arg)
{
        struct control_stats st;

        control_get_stats(f->srv.ctl, &st);
        return st.slow_readers >= (uint64_t)(uintptr_t)arg;
}

static int clients_n(struct fixture *f, void *arg)
{
        struct control_stats st;

        control_get_stats(f->srv.ctl, &st);
        return st.clients == (unsigned)(uintptr_t)arg;
}

/* ---------------------------------------------------------------------------------------------
 * Tests */

static void test_socket_mode(void **state)
{
        struct fixture *f = *state;
        struct stat st;

        assert_int_equal(lstat(f->srv.path, &st), 0);
        assert_true(S_ISSOCK(st.st_mode));
        assert_int_equal(st.st_mode & 07777, 0660);
}

struct line_case {
        const char *request;
        const char *reply;
};

/* Word splitting and line checks, all answered in order on one connection. */
static const struct line_case line_cases[] = {
        { "ping\n", "OK 1 ping\n" },
        { "a b  c\n", "OK 3 a b c\n" },                 /* runs of spaces separate words */
        { "  lead trail  \n", "OK 2 lead trail\n" },
        { "crlf\r\n", "OK 1 crlf\n" },
        { "\n", "ERR 22 empty request\n" },
        { "tab\there\n", "ERR 22 request contains a byte outside printable ASCII\n" },
        { "del\x7f\n", "ERR 22 request contains a byte outside printable ASCII\n" },
        { "w w w w w w w w w w w w w w w w w w w w w w w w w w w w w w w w\n",
          "OK 32 w w w w w w w w w w w w w w w w w w w w w w w w w w w w w w w w\n" },
        { "w w w w w w w w w w w w w w w w w w w w w w w w w w w w w w w w w\n",
          "ERR 7 too many words in the request\n" },
};

static void test_lines(void **state)
{
        struct fixture *f = *state;
        struct rx r = { .fd = client_connect(f) };

        for (size_t i = 0; i < sizeof(line_cases) / sizeof(line_cases[0]); i++) {
                r.len = 0;
                r.buf[0] = '\0';
                exchange(f, &r, line_cases[i].request, 1);
                assert_string_equal(r.buf, line_cases[i].reply);
        }
        /* A NUL inside the line (not expressible in the table): refused, not cut short. */
        r.len = 0;
        r.buf[0] = '\0';
        assert_int_equal(send(r.fd, "ping\0rm -x\n", 12, MSG_NOSIGNAL), 12);
        exchange(f, &r, NULL, 1);
        assert_string_equal(r.buf, "ERR 22 request contains a byte outside printable ASCII\n");
        close(r.fd);
}

/* A request split over several writes is one request. */
static void test_partial_writes(void **state)
{
        struct fixture *f = *state;
        struct rx r = { .fd = client_connect(f) };

        client_send(r.fd, "pi");
        pump_once(f);
        assert_int_equal(f->calls, 0);
        client_send(r.fd, "ng ag");
        pump_once(f);
        assert_int_equal(f->calls, 0);
        exchange(f, &r, "ain\n", 1);
        assert_string_equal(r.buf, "OK 2 ping again\n");
        close(r.fd);
}

/* An answer given later (from anywhere on the loop) comes with its DATA lines; the requests
 * queued behind it wait, then are answered in order. */
static void test_async_in_order(void **state)
{
        struct fixture *f = *state;
        struct rx r = { .fd = client_connect(f) };

        f->mode = MODE_HOLD;
        client_send(r.fd, "first\nsecond\nthird\n");
        pump_until(f, held_n, (void *)1);
        /* Only the first one reached the handler (all three arrived in one read). */
        assert_int_equal(f->calls, 1);
        assert_true(control_request_alive(f->held[0]));
        control_reply_data(f->held[0], "line %d", 1);
        control_reply_data(f->held[0], "two\nlines");   /* a newline cannot break the framing */
        control_reply_ok(f->held[0], "done");
        pump_until(f, held_n, (void *)2);
        control_reply_error(f->held[1], -ETIMEDOUT, "no answer from peer %c", 'B');
        pump_until(f, held_n, (void *)3);
        control_reply_ok(f->held[2], NULL);
        exchange(f, &r, NULL, 5);
        assert_string_equal(r.buf, "DATA line 1\nDATA two lines\nOK done\n"
                                   "ERR 110 no answer from peer B\nOK\n");
        close(r.fd);
}

/* The client leaves while its request is pending: the request stays valid, its answer goes
 * nowhere and is counted. */
static void test_orphan(void **state)
{
        struct fixture *f = *state;
        struct control_stats st;
        int fd = client_connect(f);

        f->mode = MODE_HOLD;
        client_send(fd, "slow\n");
        pump_until(f, held_n, (void *)1);
        close(fd);
        pump_until(f, orphaned_n, (void *)1);
        assert_false(control_request_alive(f->held[0]));
        control_reply_data(f->held[0], "nobody reads this");
        control_reply_ok(f->held[0], "late");
        control_get_stats(f->srv.ctl, &st);
        assert_int_equal(st.orphan_answers, 1);
        assert_int_equal(st.clients, 0);
}

/* A client that sends and closes at once: its request is still carried out (handed to the
 * handler), then orphaned. */
static void test_send_and_close(void **state)
{
        struct fixture *f = *state;
        struct control_stats st;
        int fd = client_connect(f);

        f->mode = MODE_HOLD;
        client_send(fd, "fire and forget\n");
        close(fd);
        pump_until(f, orphaned_n, (void *)1);
        assert_int_equal(f->n_held, 1);
        assert_false(control_request_alive(f->held[0]));
        control_reply_ok(f->held[0], NULL);
        control_get_stats(f->srv.ctl, &st);
        assert_int_equal(st.orphan_answers, 1);
        assert_int_equal(st.requests, 1);
}

/* The server goes first: a request an engine still holds stays valid until answered. */
static void test_server_freed_first(void **state)
{
        struct fixture *f = *state;
        int fd1 = client_connect(f), fd2 = client_connect(f);

        f->mode = MODE_HOLD;
        client_send(fd1, "one\n");
        client_send(fd2, "two\n");
        pump_until(f, held_n, (void *)2);
        close(fd1);
        pump_until(f, orphaned_n, (void *)1);           /* one orphan, one still attached */
        f->srv.ctl = control_free(f->srv.ctl);
        assert_int_equal(access(f->srv.path, F_OK), -1);    /* socket removed */
        assert_false(control_request_alive(f->held[0]));
        assert_false(control_request_alive(f->held[1]));
        control_reply_ok(f->held[0], NULL);
        control_reply_error(f->held[1], ECANCELED, "engine destroyed");
        close(fd2);
}

/* A client that shuts its sending side still gets every answer, a last line without '\n'
 * included; then the server closes. */
static void test_half_close(void **state)
{
        struct fixture *f = *state;
        struct rx r = { .fd = client_connect(f) };

        f->mode = MODE_HOLD;
        client_send(r.fd, "held\nlast");
        assert_int_equal(shutdown(r.fd, SHUT_WR), 0);
        pump_until(f, held_n, (void *)1);
        assert_true(control_request_alive(f->held[0]));
        f->mode = MODE_ECHO;
        control_reply_ok(f->held[0], "answered");
        pump_until(f, rx_at_eof, &r);
        assert_string_equal(r.buf, "OK answered\nOK 1 last\n");
        close(r.fd);
        pump_until(f, clients_n, (void *)0);
}

/* A client asks for a stream (a recorder), shuts its sending side and later closes (socat when
 * its input ends): while half-closed it still gets what the stream sends; once closed it is
 * dropped at once and the stream is told (gone callback), with no other traffic. After its EOF
 * the server asks nothing of the fd, which must still be polled for the hangup. */
static void test_half_close_then_close(void **state)
{
        struct fixture *f = *state;
        struct control_stats st;
        struct rx r = { .fd = client_connect(f) };

        f->mode = MODE_STREAM;
        client_send(r.fd, "record link\n");
        assert_int_equal(shutdown(r.fd, SHUT_WR), 0);
        pump_until(f, held_n, (void *)1);
        control_reply_data(f->held[0], "chunk");
        exchange(f, &r, NULL, 1);
        assert_string_equal(r.buf, "DATA chunk\n");
        assert_int_equal(f->gone, 0);
        assert_true(control_request_alive(f->held[0]));

        close(r.fd);
        pump_until(f, clients_n, (void *)0);
        assert_int_equal(f->gone, 1);
        assert_null(f->held[0]);                        /* answered from the callback */
        control_get_stats(f->srv.ctl, &st);
        assert_int_equal(st.orphaned, 1);
        assert_int_equal(st.orphan_answers, 1);
}

static int gone_n(struct fixture *f, void *arg)
{
        return f->gone >= (unsigned)(uintptr_t)arg;
}

/* The same with the server freed while the stream runs: the callback comes from control_free()
 * and may answer there. */
static void test_gone_on_free(void **state)
{
        struct fixture *f = *state;
        int fd = client_connect(f);

        f->mode = MODE_STREAM;
        client_send(fd, "record link\n");
        pump_until(f, held_n, (void *)1);
        f->srv.ctl = control_free(f->srv.ctl);
        assert_true(gone_n(f, (void *)1));
        assert_null(f->held[0]);
        close(fd);
}

static int idle_closed_n(struct fixture *f, void *arg)
{
        struct control_stats st;

        control_get_stats(f->srv.ctl, &st);
        return st.idle_closed >= (uint64_t)(uintptr_t)arg;
}

/* Connections with no request pending are closed after the idle timeout (told why), a partial
 * line notwithstanding; one whose request is pending is not, and its clock starts at the
 * answer. No timing is assumed: a client accepted earlier has the earlier deadline, so when a
 * later one is closed, the earlier one's deadline has passed too. */
static void test_idle_timeout(void **state)
{
        struct fixture *f = *state;
        struct rx a, b, c;
        struct control_stats st;
        char want[BUF_MAX];

        snprintf(want, sizeof(want), "ERR 110 no request for %u ms: closing the connection\n",
                 T_IDLE_MS);
        control_set_idle_timeout(f->srv.ctl, T_IDLE_MS);
        f->mode = MODE_HOLD;
        memset(&a, 0, sizeof(a));
        memset(&b, 0, sizeof(b));
        memset(&c, 0, sizeof(c));
        /* a's request is there before its accept: it is read (io before timers) in the round
         * after the accept, whatever the timeout, so its clock never runs out first. */
        a.fd = client_connect(f);
        client_send(a.fd, "hold\n");
        pump_until(f, held_n, (void *)1);
        b.fd = client_connect(f);
        pump_until(f, clients_n, (void *)2);
        c.fd = client_connect(f);
        client_send(c.fd, "partial line, never end");
        pump_until(f, clients_n, (void *)3);

        pump_until(f, rx_at_eof, &b);
        assert_string_equal(b.buf, want);
        pump_until(f, rx_at_eof, &c);
        assert_string_equal(c.buf, want);
        control_get_stats(f->srv.ctl, &st);
        assert_int_equal(st.idle_closed, 2);
        assert_int_equal(st.clients, 1);
        assert_true(control_request_alive(f->held[0]));

        /* Answered: idle from now on. */
        control_reply_ok(f->held[0], "held");
        pump_until(f, rx_at_eof, &a);
        assert_memory_equal(a.buf, "OK held\n", 8);
        assert_string_equal(a.buf + 8, want);
        pump_until(f, idle_closed_n, (void *)3);
        pump_until(f, clients_n, (void *)0);
        close(a.fd);
        close(b.fd);
        close(c.fd);
}

/* CTLP_LINE_MAX bytes with the '\n' is a line; one more byte is answered ERR 90 and the
 * connection is closed, also when the long line waited behind a pending request. */
static void test_overlong(void **state)
{
        struct fixture *f = *state;
        static char line[CTLP_LINE_MAX + 2];
        struct control_stats st;
        struct rx r = { .fd = client_connect(f) }, r2;
        unsigned calls;

        memset(line, 'a', CTLP_LINE_MAX - 1);
        line[CTLP_LINE_MAX - 1] = '\n';
        line[CTLP_LINE_MAX] = '\0';
        exchange(f, &r, line, 1);
        assert_memory_equal(r.buf, "OK 1 aaa", 8);
        r.len = 0;
        r.buf[0] = '\0';
        line[CTLP_LINE_MAX - 1] = 'a';
        line[CTLP_LINE_MAX] = '\n';
        client_send(r.fd, line);
        pump_until(f, rx_at_eof, &r);
        assert_string_equal(r.buf, "ERR 90 request line too long\n");
        close(r.fd);

        /* Behind a pending request: noticed once that one is answered. */
        memset(&r2, 0, sizeof(r2));
        r2.fd = client_connect(f);
        f->mode = MODE_HOLD;
        client_send(r2.fd, "wait\n");
        pump_until(f, held_n, (void *)1);
        calls = f->calls;
        client_send(r2.fd, line);
        pump_once(f);                                   /* reads (some of) it, answers nothing */
        assert_int_equal(f->calls, calls);
        control_reply_ok(f->held[0], NULL);
        pump_until(f, rx_at_eof, &r2);
        assert_string_equal(r2.buf, "OK\nERR 90 request line too long\n");
        close(r2.fd);
        control_get_stats(f->srv.ctl, &st);
        assert_int_equal(st.overlong, 2);
}

/* A client that fills its input buffer behind a pending request and hangs up: POLLHUP keeps
 * coming while the full buffer cannot be read, so the client must be dropped (request
 * orphaned), not polled again and again until the request is answered. */
static void test_hangup_full_buffer(void **state)
{
        struct fixture *f = *state;
        static char line[CTLP_LINE_MAX + 2];
        struct control_stats st;
        int fd = client_connect(f);

        f->mode = MODE_HOLD;
        client_send(fd, "wait\n");
        pump_until(f, held_n, (void *)1);
        memset(line, 'a', CTLP_LINE_MAX + 1);
        client_send(fd, line);
        close(fd);
        pump_until(f, orphaned_n, (void *)1);
        assert_false(control_request_alive(f->held[0]));
        control_reply_ok(f->held[0], NULL);
        control_get_stats(f->srv.ctl, &st);
        assert_int_equal(st.clients, 0);
        assert_int_equal(st.orphan_answers, 1);
}

/* A client that does not read its replies is disconnected once CONTROL_REPLY_MAX is queued;
 * the server never blocks on it. */
static void test_slow_reader(void **state)
{
        struct fixture *f = *state;
        struct control_stats st;
        struct rx r = { .fd = client_connect(f) };

        f->mode = MODE_FLOOD;
        client_send(r.fd, "flood\n");
        pump_until(f, slow_n, (void *)1);
        control_get_stats(f->srv.ctl, &st);
        assert_int_equal(st.slow_readers, 1);
        assert_int_equal(st.clients, 0);
        pump_until(f, rx_at_eof, &r);
        assert_true(r.total < (size_t)BIG_LINES * BIG_LINE);
        close(r.fd);
}

/* CONTROL_CLIENTS_MAX at once; the next one gets a line and is closed. */
static void test_clients_max(void **state)
{
        struct fixture *f = *state;
        int fds[CONTROL_CLIENTS_MAX];
        struct control_stats st;
        struct rx r;

        /* One by one: connect() would block on a full backlog in this single thread. */
        for (int i = 0; i < CONTROL_CLIENTS_MAX; i++) {
                fds[i] = client_connect(f);
                pump_until(f, clients_n, (void *)(uintptr_t)(i + 1));
        }
        memset(&r, 0, sizeof(r));
        r.fd = client_connect(f);
        pump_until(f, rx_at_eof, &r);
        assert_string_equal(r.buf, "ERR 87 too many control connections\n");
        close(r.fd);
        control_get_stats(f->srv.ctl, &st);
        assert_int_equal(st.refused_full, 1);
        assert_int_equal(st.accepted, CONTROL_CLIENTS_MAX);
        for (int i = 0; i < CONTROL_CLIENTS_MAX; i++)
                close(fds[i]);
        pump_until(f, clients_n, (void *)0);
}

/* The path is taken: by a regular file (left alone), by a stale socket (replaced), by a live
 * listener (refused). control_free never removes a node that is not its own. */
static void test_path_taken(void **state)
{
        struct fixture *f = *state;
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        struct control *c2 = NULL;
        char path[HARNESS_PATH_MAX + 32];
        struct stat st;
        int fd;

        snprintf(path, sizeof(path), "%s/other.sock", f->srv.h.dir);
        strcpy(sa.sun_path, path);

        assert_int_equal(harness_write_file(&f->srv.h, "other.sock", "not a socket\n", NULL), 0);
        assert_int_equal(control_new(f->srv.loop, path, 0, 0, on_request, f, &c2), -EADDRINUSE);
        assert_int_equal(lstat(path, &st), 0);
        assert_true(S_ISREG(st.st_mode));
        unlink(path);

        fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        assert_int_equal(bind(fd, (struct sockaddr *)&sa, sizeof(sa)), 0);
        close(fd);                                      /* stale */
        assert_int_equal(control_new(f->srv.loop, path, 0, 0, on_request, f, &c2), 0);
        assert_non_null(c2);

        /* c2 lives: a third server on the same path is refused. */
        {
                struct control *c3 = NULL;

                assert_int_equal(control_new(f->srv.loop, path, 0, 0, on_request, f, &c3),
                                 -EADDRINUSE);
                assert_null(c3);
        }
        /* Someone replaced c2's node: freeing c2 leaves the newcomer's alone. */
        unlink(path);
        fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        assert_int_equal(bind(fd, (struct sockaddr *)&sa, sizeof(sa)), 0);
        c2 = control_free(c2);
        assert_int_equal(lstat(path, &st), 0);
        close(fd);
        assert_null(control_free(NULL));
}

static int timer_fires_n(struct fixture *f, void *arg)
{
        struct evloop_stats st;

        evloop_get_stats(f->srv.loop, &st);
        return st.timer_fires >= *(uint64_t *)arg;
}

/* Out of fds, accept() fails while the connection stays pending: the server must pause instead
 * of spinning on a readable socket, and take the client once an fd is free again. */
static void test_accept_out_of_fds(void **state)
{
        struct fixture *f = *state;
        static int fillers[FILLERS_MAX];
        struct evloop_stats before, after;
        struct rlimit old, lim;
        struct rx r;
        uint64_t want;
        int n = 0, low = dup(0);                        /* the lowest free fd */

        assert_true(low >= 0);
        close(low);
        assert_int_equal(getrlimit(RLIMIT_NOFILE, &old), 0);
        lim = old;
        lim.rlim_cur = (rlim_t)low + 16;                /* a little room above what is open */
        assert_int_equal(setrlimit(RLIMIT_NOFILE, &lim), 0);
        while (n < FILLERS_MAX && (fillers[n] = dup(0)) >= 0)
                n++;
        assert_int_equal(errno, EMFILE);
        close(fillers[--n]);                            /* one fd left: the client's */

        memset(&r, 0, sizeof(r));
        r.fd = client_connect(f);
        evloop_get_stats(f->srv.loop, &before);
        want = before.timer_fires + PAUSES;
        pump_until(f, timer_fires_n, &want);            /* PAUSES pauses of 100 ms */
        evloop_get_stats(f->srv.loop, &after);
        /* One failed accept per pause, not thousands. */
        assert_true(after.fd_events - before.fd_events <= PAUSES + 1);

        close(fillers[--n]);                            /* an fd for the server */
        pump_until(f, clients_n, (void *)1);
        exchange(f, &r, "ping\n", 1);
        assert_string_equal(r.buf, "OK 1 ping\n");
        close(r.fd);
        while (n > 0)
                close(fillers[--n]);
        assert_int_equal(setrlimit(RLIMIT_NOFILE, &old), 0);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_socket_mode, setup, teardown),
                cmocka_unit_test_setup_teardown(test_lines, setup, teardown),
                cmocka_unit_test_setup_teardown(test_partial_writes, setup, teardown),
                cmocka_unit_test_setup_teardown(test_async_in_order, setup, teardown),
                cmocka_unit_test_setup_teardown(test_orphan, setup, teardown),
                cmocka_unit_test_setup_teardown(test_send_and_close, setup, teardown),
                cmocka_unit_test_setup_teardown(test_server_freed_first, setup, teardown),
                cmocka_unit_test_setup_teardown(test_half_close, setup, teardown),
                cmocka_unit_test_setup_teardown(test_half_close_then_close, setup, teardown),
                cmocka_unit_test_setup_teardown(test_gone_on_free, setup, teardown),
                cmocka_unit_test_setup_teardown(test_idle_timeout, setup, teardown),
                cmocka_unit_test_setup_teardown(test_overlong, setup, teardown),
                cmocka_unit_test_setup_teardown(test_hangup_full_buffer, setup, teardown),
                cmocka_unit_test_setup_teardown(test_slow_reader, setup, teardown),
                cmocka_unit_test_setup_teardown(test_clients_max, setup, teardown),
                cmocka_unit_test_setup_teardown(test_path_taken, setup, teardown),
                cmocka_unit_test_setup_teardown(test_accept_out_of_fds, setup, teardown),
        };

        signal(SIGPIPE, SIG_IGN);
        return cmocka_run_group_tests(tests, NULL, NULL);
}
