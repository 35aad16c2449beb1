/*
 * libFuzzer target for the daemon's handling of control connections (src/daemon/control.c): the
 * real server on a real Unix socket and event loop, real clients connected to it in the same
 * process, and a request handler played by the target. The input is a program of operations:
 *
 *   op 0    a client sends raw bytes (any, partial lines, NULs, overlong lines)
 *   op 1    a client sends request lines built from a small vocabulary and the input's words
 *   op 2    a client shuts its sending side (shutdown(SHUT_WR), as socat at the end of input)
 *   op 3    a client closes
 *   op 4    a closed client connects again
 *   op 5    a client reads what has arrived
 *   op 6    the handler answers a held request: DATA (it stays pending), OK, ERR, a burst of
 *           long DATA lines, and asks whether it is alive and how much is queued
 *   op 7    the loop runs until nothing is left to do
 *   op 8    every connection without a request pending is idle for too long (timeout 0)
 *   op 9    the server is freed with whatever it holds and made again on the same path
 *
 * The handler answers at once (OK with the words echoed, or ERR), or holds the request for op 6:
 * "hold" holds it, "stream" holds it and asks to be told when its client goes (then answers at
 * once, as a recorder does), "data N" answers N DATA lines and OK, "flood N" N long ones.
 *
 * Invariants (a broken one is a __builtin_trap()):
 *   - the handler gets 1..CTLP_WORDS_MAX non-empty words of printable ASCII;
 *   - every line a client reads parses as DATA, OK or ERR (proto/control.h), within
 *     CTLP_REPLY_LINE_MAX; a client never gets more final lines than lines it sent, plus one
 *     (the refusal of a line over CTLP_LINE_MAX, or the idle notice);
 *   - a gone callback comes only for a request that asked, once, after its client left;
 *   - the loop comes to rest within a bound of rounds after every operation (no spinning);
 *   - at the end, once every client has closed and the loop has run, the server counts no
 *     client (a closed peer is noticed, whatever it asked: issue 19.1 is caught here), and
 *     every request the handler got is answered exactly once (ASan checks the rest).
 */
#include <errno.h>
#include <fcntl.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include "daemon/control.h"
#include "fuzz/fuzz_input.h"
#include "proto/control.h"
#include "svc/evloop.h"
#include "svc/log.h"

#define CLIENTS         6               /* client connections at once */
#define HELD_MAX        64              /* requests held by the handler at once */
#define STEPS_MAX       512             /* operations per input */
#define RAW_MAX         255             /* bytes per raw send */
#define WORDS_OP_MAX    8               /* words per built line */
#define LINES_OP_MAX    4               /* lines per op 1 */
#define DATA_LINES_MAX  16              /* "data N" */
#define FLOOD_LINES_MAX 80              /* "flood N", op 6 bursts: 320 KB, past any buffer */
#define FLOOD_LINE      4000            /* bytes of one long DATA line */
#define TEXT_MAX        96              /* text of an answer taken from the input */
#define PUMP_ROUNDS_MAX 1024            /* rounds the loop may need to come to rest */
#define IDLE_FAR_MS     (3600u * 1000u) /* the idle timeout between op 8s: never in a run */
#define READ_CHUNK      8192

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

struct client {
        int fd;                         /* -1: closed */
        bool shut;                      /* shutdown(SHUT_WR) done */
        bool eof;                       /* the server closed its end */
        unsigned lines_sent;            /* '\n's sent, plus one for a last line at SHUT_WR */
        bool partial;                   /* bytes sent since the last '\n' */
        unsigned finals;                /* OK/ERR lines read */
        size_t len;
        char line[CTLP_REPLY_LINE_MAX + 2];
};

struct held {
        struct control_request *req;
        bool wants_gone;
};

struct bench {
        struct evloop *loop;
        struct control *ctl;
        struct evloop_timer tick;       /* delay 0 before each round: poll never blocks */
        struct client cl[CLIENTS];
        struct held held[HELD_MAX];
        unsigned n_held;
        uint64_t handed, answered;      /* requests the handler got / answered */
        struct input in;
};

static char sock_dir[] = "/tmp/fuzz_control_conn.XXXXXX";
static char sock_path[sizeof(((struct sockaddr_un *)NULL)->sun_path)];
static char flood_line[FLOOD_LINE + 1];

/* ---- the handler ---------------------------------------------------------------------------- */

static void held_drop(struct bench *b, unsigned i)
{
        b->held[i] = b->held[--b->n_held];
        b->answered++;
}

static void on_gone(struct control_request *req, void *arg)
{
        struct bench *b = arg;

        CHECK(!control_request_alive(req));
        for (unsigned i = 0; i < b->n_held; i++) {
                if (b->held[i].req != req)
                        continue;
                CHECK(b->held[i].wants_gone);
                control_reply_ok(req, "gone");
                held_drop(b, i);
                return;
        }
        CHECK(false);                   /* not one of ours, or told twice */
}

static unsigned word_number(const char *w, unsigned max)
{
        unsigned long n = strtoul(w, NULL, 10);

        return n > max ? max : (unsigned)n;
}

static void on_request(struct control_request *req, int argc, char **argv, void *arg)
{
        struct bench *b = arg;
        char text[CTLP_LINE_MAX + 8] = "";
        size_t len = 0;

        b->handed++;
        CHECK(argc >= 1 && argc <= CTLP_WORDS_MAX && argv[argc] == NULL);
        for (int i = 0; i < argc; i++) {
                size_t n = strlen(argv[i]);

                CHECK(n > 0);
                for (size_t k = 0; k < n; k++)
                        CHECK(ctlp_is_word_byte((unsigned char)argv[i][k]));
                CHECK(len + n + 1 < sizeof(text));
                len += (size_t)snprintf(text + len, sizeof(text) - len, " %s", argv[i]);
        }
        if (!strcmp(argv[0], "hold") || !strcmp(argv[0], "stream")) {
                if (b->n_held == HELD_MAX) {
                        control_reply_error(req, EBUSY, "the fuzzer holds enough");
                        b->answered++;
                        return;
                }
                b->held[b->n_held].req = req;
                b->held[b->n_held].wants_gone = argv[0][0] == 's';
                if (argv[0][0] == 's')
                        control_request_on_gone(req, on_gone, b);
                b->n_held++;
                return;
        }
        if (!strcmp(argv[0], "data") || !strcmp(argv[0], "flood")) {
                bool flood = argv[0][0] == 'f';
                unsigned n = argc > 1 ? word_number(argv[1], flood ? FLOOD_LINES_MAX :
                                                                     DATA_LINES_MAX) : 1;

                for (unsigned i = 0; i < n; i++) {
                        if (flood)
                                control_reply_data(req, "%s", flood_line);
                        else
                                control_reply_data(req, "%u%s", i, text);
                }
                control_reply_ok(req, NULL);
        } else if (argc % 2) {
                control_reply_ok(req, "%d%s", argc, text);
        } else {
                control_reply_error(req, -EINVAL, "even%s", text);
        }
        b->answered++;
}

/* ---- the loop ------------------------------------------------------------------------------- */

static void on_tick(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        (void)loop;
        (void)t;
        (void)arg;
}

/* Runs rounds until one does nothing but the tick; a loop that never rests is a spin. */
static void pump(struct bench *b)
{
        for (unsigned round = 0; round < PUMP_ROUNDS_MAX; round++) {
                struct evloop_stats before, after;

                evloop_get_stats(b->loop, &before);
                evloop_timer_arm(&b->tick, 0, 0);
                CHECK(evloop_run_once(b->loop) == 0);
                evloop_get_stats(b->loop, &after);
                if (after.fd_events == before.fd_events &&
                    after.timer_fires == before.timer_fires + 1)
                        return;
        }
        CHECK(false);
}

/* ---- clients -------------------------------------------------------------------------------- */

static void client_connect(struct client *c)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };

        memset(c, 0, sizeof(*c));
        c->fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
        CHECK(c->fd >= 0);
        memcpy(sa.sun_path, sock_path, sizeof(sa.sun_path));
        if (connect(c->fd, (struct sockaddr *)&sa, sizeof(sa)) < 0) {
                close(c->fd);
                c->fd = -1;
        }
}

static void client_close(struct client *c)
{
        if (c->fd >= 0)
                close(c->fd);
        c->fd = -1;
}

static void client_send(struct client *c, const char *buf, size_t len)
{
        ssize_t n;

        if (c->fd < 0 || c->shut || len == 0)
                return;
        n = send(c->fd, buf, len, MSG_DONTWAIT | MSG_NOSIGNAL);
        if (n <= 0)
                return;                 /* full, or the server closed its end */
        for (ssize_t i = 0; i < n; i++) {
                if (buf[i] == '\n') {
                        c->lines_sent++;
                        c->partial = false;
                } else {
                        c->partial = true;
                }
        }
}

static void client_shut(struct client *c)
{
        if (c->fd < 0 || c->shut)
                return;
        shutdown(c->fd, SHUT_WR);
        c->shut = true;
        /* The server takes a last line without '\n' before EOF. */
        if (c->partial)
                c->lines_sent++;
        c->partial = false;
}

/* One complete reply line (without its '\n'). */
static void client_line(struct client *c)
{
        const char *text;
        int err = 0, kind;

        c->line[c->len] = '\0';
        kind = ctlp_reply_parse(c->line, c->len, &text, &err);
        CHECK(kind == CTLP_REPLY_DATA || kind == CTLP_REPLY_OK || kind == CTLP_REPLY_ERR);
        if (kind != CTLP_REPLY_DATA)
                c->finals++;
        CHECK(c->finals <= c->lines_sent + 1);
        c->len = 0;
}

static void client_read(struct client *c)
{
        char buf[READ_CHUNK];

        while (c->fd >= 0 && !c->eof) {
                ssize_t n = recv(c->fd, buf, sizeof(buf), MSG_DONTWAIT);

                if (n <= 0) {
                        if (n == 0 || (errno != EAGAIN && errno != EINTR))
                                c->eof = true;
                        return;
                }
                for (ssize_t i = 0; i < n; i++) {
                        if (buf[i] == '\n') {
                                client_line(c);
                                continue;
                        }
                        CHECK(c->len < CTLP_REPLY_LINE_MAX);
                        c->line[c->len++] = buf[i];
                }
        }
}

/* ---- operations ----------------------------------------------------------------------------- */

static struct client *pick_client(struct bench *b)
{
        return &b->cl[take(&b->in) % CLIENTS];
}

static void op_raw(struct bench *b)
{
        struct client *c = pick_client(b);
        char buf[RAW_MAX];
        size_t n = take(&b->in);

        for (size_t i = 0; i < n; i++)
                buf[i] = (char)take(&b->in);
        client_send(c, buf, n);
}

static const char *const vocabulary[] = {
        "ping", "hold", "stream", "data", "flood", "stats", "record", "x", " ", "  ", "\r",
        "wait=10", "0", "3", "17", "80",
};

static void op_lines(struct bench *b)
{
        struct client *c = pick_client(b);
        unsigned lines = 1 + take(&b->in) % LINES_OP_MAX;
        char buf[LINES_OP_MAX * (WORDS_OP_MAX * 9 + 2)];
        size_t len = 0;

        for (unsigned l = 0; l < lines; l++) {
                unsigned words = 1 + take(&b->in) % WORDS_OP_MAX;

                for (unsigned w = 0; w < words; w++) {
                        uint8_t pick = take(&b->in);

                        if (w > 0)
                                buf[len++] = ' ';
                        if (pick < 0xc0) {
                                const char *word = vocabulary[pick % (sizeof(vocabulary) /
                                                                      sizeof(vocabulary[0]))];

                                len += (size_t)snprintf(buf + len, sizeof(buf) - len, "%s",
                                                        word);
                        } else {
                                /* A word of the input's own bytes (any of them). */
                                unsigned n = 1 + pick % 8;

                                for (unsigned k = 0; k < n; k++)
                                        buf[len++] = (char)take(&b->in);
                        }
                }
                buf[len++] = '\n';
        }
        client_send(c, buf, len);
}

static void op_answer(struct bench *b)
{
        uint8_t how = take(&b->in);
        unsigned i;
        struct control_request *req;
        char text[TEXT_MAX + 1];
        size_t n = take(&b->in) % (TEXT_MAX + 1);
        int err;

        for (size_t k = 0; k < n; k++) {
                text[k] = (char)take(&b->in);
                if (!text[k])
                        text[k] = '\n';         /* any byte but the terminator */
        }
        text[n] = '\0';
        err = 1 + (int)(take(&b->in) * 16u % CTLP_ERRNO_MAX);
        if (b->n_held == 0)
                return;
        i = take(&b->in) % b->n_held;
        req = b->held[i].req;
        CHECK(control_request_queued(req) <= CONTROL_REPLY_MAX);
        (void)control_request_alive(req);
        switch (how % 5) {
        case 0:
                control_reply_data(req, "%s", text);
                return;                 /* still pending */
        case 1:
                for (unsigned k = 0; k < how % FLOOD_LINES_MAX; k++)
                        control_reply_data(req, "%s", flood_line);
                return;
        case 2:
                control_reply_ok(req, "%s", text);
                break;
        case 3:
                control_reply_ok(req, NULL);
                break;
        default:
                control_reply_error(req, how & 1 ? err : -err, "%s", text);
                break;
        }
        held_drop(b, i);
}

static void server_new(struct bench *b)
{
        CHECK(control_new(b->loop, sock_path, 0, 0, on_request, b, &b->ctl) == 0);
        control_set_idle_timeout(b->ctl, IDLE_FAR_MS);
}

static void op_idle(struct bench *b)
{
        control_set_idle_timeout(b->ctl, 0);
        pump(b);
        control_set_idle_timeout(b->ctl, IDLE_FAR_MS);
}

static void op_server_again(struct bench *b)
{
        b->ctl = control_free(b->ctl);
        server_new(b);
}

static void step(struct bench *b)
{
        struct client *c;

        switch (take(&b->in) % 10) {
        case 0:
                op_raw(b);
                break;
        case 1:
                op_lines(b);
                break;
        case 2:
                client_shut(pick_client(b));
                break;
        case 3:
                client_close(pick_client(b));
                break;
        case 4:
                c = pick_client(b);
                if (c->fd < 0)
                        client_connect(c);
                break;
        case 5:
                client_read(pick_client(b));
                break;
        case 6:
                op_answer(b);
                break;
        case 7:
                pump(b);
                break;
        case 8:
                op_idle(b);
                break;
        default:
                /* Rare: it ends every connection. */
                if (take(&b->in) == 0)
                        op_server_again(b);
                break;
        }
}

/* ---- one input ------------------------------------------------------------------------------ */

/* Every input's server unlinks its socket when freed: the directory is empty by then. */
static void remove_dir(void)
{
        rmdir(sock_dir);
}

static void init_once(void)
{
        static bool done;
        int null_fd;

        if (done)
                return;
        done = true;
        CHECK(mkdtemp(sock_dir) != NULL);
        atexit(remove_dir);
        snprintf(sock_path, sizeof(sock_path), "%s/c.sock", sock_dir);
        memset(flood_line, 'f', FLOOD_LINE);
        /* Quiet: slow readers and refusals are logged, thousands of times a second here. */
        null_fd = open("/dev/null", O_WRONLY | O_CLOEXEC);
        CHECK(null_fd >= 0);
        log_init(-1, null_fd);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        static struct bench b;
        struct control_stats st;

        init_once();
        memset(&b, 0, sizeof(b));
        b.in = (struct input){ data, size };
        CHECK(evloop_new(&b.loop) == 0);
        evloop_timer_init(&b.tick, b.loop, on_tick, NULL);
        server_new(&b);
        for (unsigned i = 0; i < CLIENTS; i++)
                b.cl[i].fd = -1;
        client_connect(&b.cl[0]);
        pump(&b);
        for (unsigned s = 0; s < STEPS_MAX && b.in.n > 0; s++) {
                step(&b);
                pump(&b);
        }

        /* Everybody leaves: the server must notice every one of them. */
        for (unsigned i = 0; i < CLIENTS; i++) {
                client_read(&b.cl[i]);
                client_close(&b.cl[i]);
        }
        pump(&b);
        control_get_stats(b.ctl, &st);
        CHECK(st.clients == 0);
        CHECK(st.orphan_answers <= st.orphaned);
        /* Answer what is still held (orphans now), some after the server is gone. */
        while (b.n_held > 0) {
                if (b.n_held % 2 && b.ctl)
                        b.ctl = control_free(b.ctl);
                control_reply_ok(b.held[b.n_held - 1].req, NULL);
                held_drop(&b, b.n_held - 1);
        }
        CHECK(b.answered == b.handed);
        b.ctl = control_free(b.ctl);
        evloop_timer_cancel(&b.tick);
        b.loop = evloop_free(b.loop);
        return 0;
}
