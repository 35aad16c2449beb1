/*
 * Control socket server (see control.h for the rules, proto/control.h for the wire format).
 *
 * One struct control_client per connection: an input buffer of one line (CTLP_LINE_MAX), an
 * output queue (at most CONTROL_REPLY_MAX bytes) and at most one pending request. Nothing here
 * blocks: replies are written with MSG_DONTWAIT, the rest is queued and POLLOUT is asked for only
 * while the queue is not empty (OpenBSD style). A client that lets its queue grow past the bound
 * is disconnected.
 *
 * Requests are answered in order, one at a time: while one is pending, later lines wait in the
 * input buffer (reading stops when it is full, so the kernel's socket buffer pushes back). An
 * answer can come long after the request (an engine waiting for its peer), from any callback of
 * the loop; the next buffered line is then taken up from a zero-delay timer, never from inside
 * the control_reply_*() call, so an engine is never re-entered while it answers.
 *
 * Lifetimes: a request outlives its client (and the whole server): when the client goes, the
 * request is orphaned (req->client = NULL), its gone callback (if any) is told, and its answer
 * goes nowhere; the request is freed when it is answered. A client is closed only outside its own
 * processing (the `busy` flag defers it).
 *
 * A peer that is gone is noticed at once, whatever it asked: the fd stays polled for POLLHUP
 * (EVLOOP_HANGUP) also after EOF, when nothing else is asked of it. A peer that only shut its
 * sending side (shutdown(SHUT_WR), socat at the end of its input) is still reading and keeps its
 * answers; one that closed altogether is dropped, and a stream it asked for (a recorder) ends
 * through the gone callback, not at its next write, which on a silent link may never come.
 *
 * Admission (control.h): the peer's credentials are read before a slot is given, so that the
 * bound per uid and the slots kept for root and the daemon's user are decided at accept(), and a
 * refused peer is told why. Every client has an idle timer that runs while it has no request
 * pending (from its accept, then from each answer): a connection that holds a slot without
 * asking anything is closed after the idle timeout, a partial line notwithstanding (a line
 * dribbled in a byte at a time does not keep it).
 */
#define _GNU_SOURCE     /* struct ucred, SO_PEERCRED, accept4 */
#include "daemon/control.h"

#include <errno.h>
#include <grp.h>
#include <inttypes.h>
#include <poll.h>
#include <pwd.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "proto/control.h"
#include "svc/log.h"

#ifndef SO_PEERGROUPS
#define SO_PEERGROUPS           59      /* Linux 4.13; the value is the same on every arch */
#endif

#define CONTROL_BACKLOG         16
#define CONTROL_SOCKET_MODE     0660
#define CONTROL_BIND_UMASK      0117    /* bind() creates the node 0660 at once, no window */
#define CONTROL_ACCEPT_BUDGET   16      /* accepts per readiness of the listening socket */
/* A reply line as formatted here, '\n' and NUL included: with its '\n' it never passes
 * CTLP_REPLY_LINE_MAX, the most a client reads. */
#define CONTROL_REPLY_LINE_MAX  (CTLP_REPLY_LINE_MAX + 1)
#define CONTROL_GROUPS_STACK    64      /* peer groups looked at without allocating */
#define CONTROL_GROUPS_MAX      65536   /* NGROUPS_MAX on Linux */
#define CONTROL_PW_BUF          16384   /* getpwuid_r buffer */
#define CONTROL_ACCEPT_PAUSE_MS 100     /* out of fds: stop accepting this long (no spinning) */
#define CONTROL_IDLE_WHY_MAX    80      /* "no request for N ms: closing the connection" */

#define CONTROL_ERR_DENIED      "ERR 13 permission denied\n"
#define CONTROL_ERR_BUSY        "ERR 87 too many control connections\n"
#define CONTROL_STR(x)          #x
#define CONTROL_XSTR(x)         CONTROL_STR(x)
#define CONTROL_ERR_USER        "ERR 87 too many control connections from this user (at most " \
                                CONTROL_XSTR(CONTROL_CLIENTS_PER_UID) " each)\n"
#define CONTROL_ERR_RESERVED    "ERR 87 too many control connections (the last " \
                                CONTROL_XSTR(CONTROL_CLIENTS_RESERVED) " are kept for root " \
                                "and the daemon's user)\n"

struct control_client {
        struct control *ctl;
        int fd;
        struct ucred cred;
        bool authorized;
        bool eof;                       /* the peer shut its sending side: finish, then close */
        bool closing;                   /* close once the output queue is empty */
        bool broken;                    /* write failed or the peer is gone: close at once */
        bool busy;                      /* inside client_process(): closing is deferred */
        struct evloop_timer idle;       /* runs while no request is pending */
        size_t in_len;
        char in[CTLP_LINE_MAX];
        char *out;                      /* queued bytes are out[out_off..out_len) */
        size_t out_off, out_len, out_cap;
        struct control_request *pending;
};

struct control_request {
        struct control_client *client;  /* NULL once the client is gone */
        struct control *ctl;            /* NULL once the server is gone */
        struct control_request *prev, *next;    /* in ctl->orphans while orphaned */
        control_gone_fn on_gone;        /* control_request_on_gone() */
        void *gone_arg;
        int argc;
        char *argv[CTLP_WORDS_MAX + 1];
        char line[CTLP_LINE_MAX];
};

struct control {
        struct evloop *loop;
        int fd;
        char path[sizeof(((struct sockaddr_un *)NULL)->sun_path)];
        dev_t dev;                      /* identity of the node we bound, so that we never */
        ino_t ino;                      /* unlink a successor's socket */
        uid_t uid;
        gid_t group;
        bool has_group;
        control_request_fn fn;
        void *arg;
        struct evloop_timer kick;       /* resumes clients whose answer came asynchronously */
        struct evloop_timer resume;     /* accepting again after running out of fds */
        struct log_ratelimit accept_rl;
        struct log_ratelimit refuse_rl;         /* peers refused a slot */
        uint64_t idle_ms;                       /* CONTROL_IDLE_TIMEOUT_MS unless a test says */
        struct control_client *clients[CONTROL_CLIENTS_MAX];
        struct control_request *orphans;        /* requests whose client left, unanswered */
        struct control_stats stats;
};

static void client_on_event(struct evloop *loop, int fd, unsigned revents, void *arg);
static void client_on_idle(struct evloop *loop, struct evloop_timer *t, void *arg);

/* ---------------------------------------------------------------------------------------------
 * Peer credentials */

static bool gid_in(gid_t g, const gid_t *list, size_t n)
{
        for (size_t i = 0; i < n; i++)
                if (list[i] == g)
                        return true;
        return false;
}

/* Supplementary groups of the peer as they were at connect() (SO_PEERGROUPS): 1 member,
 * 0 not, -errno when the kernel cannot tell (older than 4.13). */
static int peer_groups_has(int fd, gid_t group)
{
        gid_t stack[CONTROL_GROUPS_STACK], *list = stack;
        socklen_t len = sizeof(stack);
        int r;

        if (getsockopt(fd, SOL_SOCKET, SO_PEERGROUPS, list, &len) < 0) {
                if (errno != ERANGE || len > CONTROL_GROUPS_MAX * sizeof(gid_t))
                        return -errno;
                list = malloc(len);
                if (!list)
                        return -ENOMEM;
                if (getsockopt(fd, SOL_SOCKET, SO_PEERGROUPS, list, &len) < 0) {
                        r = -errno;
                        free(list);
                        return r;
                }
        }
        r = gid_in(group, list, len / sizeof(gid_t));
        if (list != stack)
                free(list);
        return r;
}

/* Fallback: the groups the user database gives the peer's uid. */
static bool user_groups_has(uid_t uid, gid_t primary, gid_t group)
{
        struct passwd pw, *res = NULL;
        gid_t stack[CONTROL_GROUPS_STACK], *list = stack;
        int n = CONTROL_GROUPS_STACK;
        char *buf = malloc(CONTROL_PW_BUF);
        bool yes = false;

        if (!buf)
                return false;
        if (getpwuid_r(uid, &pw, buf, CONTROL_PW_BUF, &res) != 0 || !res)
                goto out;
        if (getgrouplist(pw.pw_name, primary, list, &n) < 0) {
                if (n <= 0 || n > CONTROL_GROUPS_MAX)
                        goto out;
                list = malloc((size_t)n * sizeof(gid_t));
                if (!list || getgrouplist(pw.pw_name, primary, list, &n) < 0)
                        goto out;
        }
        yes = gid_in(group, list, (size_t)n);
out:
        if (list != stack)
                free(list);
        free(buf);
        return yes;
}

/* Root and the daemon's own user: always served, not bound per uid, and the only ones that may
 * take the last CONTROL_CLIENTS_RESERVED slots. */
static bool peer_privileged(const struct control *c, const struct ucred *cred)
{
        return cred->uid == 0 || cred->uid == c->uid;
}

/* The rule of control.h: the daemon's uid, root, or a member of the configured group. */
static bool peer_allowed(const struct control *c, int fd, const struct ucred *cred)
{
        int r;

        if (peer_privileged(c, cred))
                return true;
        if (!c->has_group)
                return false;
        if (cred->gid == c->group)
                return true;
        r = peer_groups_has(fd, c->group);
        if (r >= 0)
                return r == 1;
        return user_groups_has(cred->uid, cred->gid, c->group);
}

/* ---------------------------------------------------------------------------------------------
 * Clients: output */

static void client_update_events(struct control_client *cl)
{
        /* Also after EOF, when nothing else is asked: a peer gone for good must be seen. */
        unsigned ev = EVLOOP_HANGUP;

        if (cl->broken)
                return;
        if (!cl->eof && !cl->closing && cl->in_len < sizeof(cl->in))
                ev |= POLLIN;
        if (cl->out_len > cl->out_off)
                ev |= POLLOUT;
        evloop_mod_fd(cl->ctl->loop, cl->fd, ev);
}

/* Writes what is queued; marks the client broken on a fatal error. */
static void client_flush(struct control_client *cl)
{
        while (!cl->broken && cl->out_len > cl->out_off) {
                ssize_t n = send(cl->fd, cl->out + cl->out_off, cl->out_len - cl->out_off,
                                 MSG_DONTWAIT | MSG_NOSIGNAL);

                if (n < 0) {
                        if (errno == EINTR)
                                continue;
                        if (errno != EAGAIN && errno != EWOULDBLOCK)
                                cl->broken = true;
                        break;
                }
                cl->out_off += (size_t)n;
        }
        if (cl->out_off == cl->out_len)
                cl->out_off = cl->out_len = 0;
}

/* Queues bytes (writing at once when nothing is queued). A client whose queue would pass
 * CONTROL_REPLY_MAX stopped reading: it is disconnected. */
static void client_queue(struct control_client *cl, const char *data, size_t len)
{
        size_t queued;

        if (cl->broken)
                return;
        queued = cl->out_len - cl->out_off;
        if (queued + len > CONTROL_REPLY_MAX) {
                cl->ctl->stats.slow_readers++;
                log_warnx("control: client pid %ld does not read its replies; disconnecting",
                          (long)cl->cred.pid);
                cl->broken = true;
                return;
        }
        if (cl->out_off > 0) {
                memmove(cl->out, cl->out + cl->out_off, queued);
                cl->out_off = 0;
                cl->out_len = queued;
        }
        if (cl->out_len + len > cl->out_cap) {
                size_t cap = cl->out_cap ? cl->out_cap : CONTROL_REPLY_LINE_MAX;
                char *p;

                while (cap < cl->out_len + len)
                        cap *= 2;
                if (cap > CONTROL_REPLY_MAX)
                        cap = CONTROL_REPLY_MAX;
                p = realloc(cl->out, cap);
                if (!p) {
                        cl->broken = true;
                        return;
                }
                cl->out = p;
                cl->out_cap = cap;
        }
        memcpy(cl->out + cl->out_len, data, len);
        cl->out_len += len;
        client_flush(cl);
}

/* Formats one reply line (proto/control.h) into buf[CONTROL_REPLY_LINE_MAX] with fmt as its text
 * (NULL: none). Returns the length. */
static size_t reply_format(char *buf, enum ctlp_reply_kind kind, int err, const char *fmt,
                           va_list ap)
{
        char text[CONTROL_REPLY_LINE_MAX];

        if (!fmt)
                return ctlp_reply_format(buf, CONTROL_REPLY_LINE_MAX, kind, err, NULL);
        vsnprintf(text, sizeof(text), fmt, ap);
        return ctlp_reply_format(buf, CONTROL_REPLY_LINE_MAX, kind, err, text);
}

/* ---------------------------------------------------------------------------------------------
 * Clients: life cycle */

/* The client left before the answer: keep the request (the engine still holds it) on the
 * orphan list, so that the server can count its answer or, if it goes first, forget it. */
static void request_orphan(struct control_request *req)
{
        struct control *c = req->ctl;

        req->client = NULL;
        c->stats.orphaned++;
        req->prev = NULL;
        req->next = c->orphans;
        if (c->orphans)
                c->orphans->prev = req;
        c->orphans = req;
}

static void client_close(struct control_client *cl)
{
        struct control *c = cl->ctl;
        struct control_request *gone = cl->pending;

        if (gone)
                request_orphan(gone);
        for (unsigned i = 0; i < CONTROL_CLIENTS_MAX; i++)
                if (c->clients[i] == cl)
                        c->clients[i] = NULL;
        c->stats.clients--;
        evloop_timer_cancel(&cl->idle);
        evloop_del_fd(c->loop, cl->fd);
        close(cl->fd);
        free(cl->out);
        free(cl);
        /* Last: the callee may answer (and so free) the request at once. */
        if (gone && gone->on_gone)
                gone->on_gone(gone, gone->gone_arg);
}

/* (Re)starts the idle clock of a client that has no request pending. */
static void client_idle_arm(struct control_client *cl)
{
        /* Cannot fail short of EVLOOP_TIMERS_MAX, far above CONTROL_CLIENTS_MAX; the client
         * would then merely keep its slot until it leaves. */
        evloop_timer_arm(&cl->idle, cl->ctl->idle_ms, 0);
}

/* Closes the client if it is done or broken; returns true if it did. */
static bool client_settle(struct control_client *cl)
{
        bool done;

        if (cl->busy)
                return false;
        /* At EOF client_process() takes even a last line without '\n', so "done" means an
         * empty input buffer. */
        done = cl->broken ||
               (!cl->pending && cl->out_len == cl->out_off &&
                (cl->closing || (cl->eof && cl->in_len == 0)));
        if (done) {
                client_close(cl);
                return true;
        }
        client_update_events(cl);
        return false;
}

/* ---------------------------------------------------------------------------------------------
 * Requests */

static void client_send_error(struct control_client *cl, int err, const char *why)
{
        char buf[CONTROL_REPLY_LINE_MAX];

        client_queue(cl, buf, ctlp_reply_format(buf, sizeof(buf), CTLP_REPLY_ERR, err, why));
}

/* Answers a request line proto/control.h refuses, with the daemon's errno and message. */
static void client_refuse(struct control_client *cl, enum ctlp_reason reason)
{
        switch (reason) {
        case CTLP_REASON_TOO_MANY_WORDS:
                client_send_error(cl, -E2BIG, "too many words in the request");
                return;
        case CTLP_REASON_EMPTY:
                client_send_error(cl, -EINVAL, "empty request");
                return;
        case CTLP_REASON_TOO_LONG:
                client_send_error(cl, -EMSGSIZE, "request line too long");
                return;
        case CTLP_REASON_NONE:
        case CTLP_REASON_BAD_BYTE:
        case CTLP_REASON_BAD_SPACE:
                break;
        }
        client_send_error(cl, -EINVAL, "request contains a byte outside printable ASCII");
}

/* One complete line (without its '\n'): check, split, hand to the handler. */
static void client_handle_line(struct control_client *cl, const char *line, size_t len)
{
        struct control *c = cl->ctl;
        struct control_request *req;
        enum ctlp_reason reason;

        /* A line answered is activity: the idle clock starts again (stopped below if the line
         * becomes a pending request). */
        client_idle_arm(cl);
        if (!cl->authorized) {
                c->stats.denied++;
                log_info("control: pid %ld uid %ld: permission denied", (long)cl->cred.pid,
                         (long)cl->cred.uid);
                client_queue(cl, CONTROL_ERR_DENIED, strlen(CONTROL_ERR_DENIED));
                cl->closing = true;
                return;
        }
        req = calloc(1, sizeof(*req));
        if (!req) {
                client_send_error(cl, -ENOMEM, "out of memory");
                return;
        }
        memcpy(req->line, line, len);
        req->line[len] = '\0';
        /* Split by length: a NUL inside is refused, "ping\0rm" is not "ping". */
        reason = ctlp_request_split(req->line, len, req->argv, &req->argc);
        if (reason != CTLP_REASON_NONE) {
                c->stats.bad_requests++;
                client_refuse(cl, reason);
                free(req);
                return;
        }
        req->client = cl;
        req->ctl = c;
        cl->pending = req;
        evloop_timer_cancel(&cl->idle);
        c->stats.requests++;
        log_debug("control: pid %ld: %s", (long)cl->cred.pid, req->argv[0]);
        c->fn(req, req->argc, req->argv, c->arg);
}

/* Takes complete lines from the input buffer while no request is pending. */
static void client_process(struct control_client *cl)
{
        cl->busy = true;
        while (!cl->pending && !cl->closing && !cl->broken && cl->in_len > 0) {
                char *nl = memchr(cl->in, '\n', cl->in_len);
                size_t len, used;

                if (!nl) {
                        if (cl->in_len < sizeof(cl->in) && !cl->eof)
                                break;          /* wait for the rest of the line */
                        if (cl->in_len == sizeof(cl->in)) {
                                cl->ctl->stats.overlong++;
                                client_refuse(cl, CTLP_REASON_TOO_LONG);
                                cl->closing = true;
                                break;
                        }
                        /* A last line without '\n' before EOF ("printf ping | socat"): take it. */
                        nl = cl->in + cl->in_len;
                        used = cl->in_len;
                } else {
                        used = (size_t)(nl - cl->in) + 1;
                }
                len = (size_t)(nl - cl->in);
                if (len > 0 && cl->in[len - 1] == '\r')
                        len--;
                {
                        char line[CTLP_LINE_MAX];

                        memcpy(line, cl->in, len);
                        memmove(cl->in, cl->in + used, cl->in_len - used);
                        cl->in_len -= used;
                        client_handle_line(cl, line, len);
                }
        }
        cl->busy = false;
}

/* Whether a peer that sent EOF is gone altogether (POLLHUP) rather than half-closed. */
static bool peer_hung_up(int fd)
{
        struct pollfd p = { .fd = fd, .events = 0 };

        return poll(&p, 1, 0) > 0 && (p.revents & (POLLHUP | POLLERR));
}

static void client_read(struct control_client *cl)
{
        while (!cl->eof && cl->in_len < sizeof(cl->in)) {
                ssize_t n = recv(cl->fd, cl->in + cl->in_len, sizeof(cl->in) - cl->in_len,
                                 MSG_DONTWAIT);

                if (n > 0) {
                        cl->in_len += (size_t)n;
                        continue;
                }
                if (n == 0) {
                        cl->eof = true;
                        break;
                }
                if (errno == EINTR)
                        continue;
                if (errno != EAGAIN && errno != EWOULDBLOCK)
                        cl->broken = true;
                break;
        }
}

static void client_on_event(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct control_client *cl = arg;

        (void)loop;
        (void)fd;
        if (revents & (POLLERR | POLLNVAL)) {
                cl->broken = true;
        } else {
                if (revents & POLLOUT)
                        client_flush(cl);
                if (revents & (POLLIN | POLLHUP))
                        client_read(cl);
                /* Lines that arrived whole are handed out even if their client has left since
                 * (a command is not cancelled by closing early); only then is a client that is
                 * gone for good (not just half-closed) dropped, orphaning what it sent. */
                client_process(cl);
                /* POLLHUP without EOF: the input buffer is full behind a pending request and
                 * cannot be read to EOF; poll reports POLLHUP always, so waiting would spin. */
                if ((cl->eof || (revents & POLLHUP)) && !cl->broken && peer_hung_up(cl->fd))
                        cl->broken = true;
        }
        client_settle(cl);
}

/* Resumes clients whose pending request was answered from outside client_process(). */
static void control_on_kick(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        struct control *c = arg;

        (void)loop;
        (void)t;
        for (unsigned i = 0; i < CONTROL_CLIENTS_MAX; i++) {
                struct control_client *cl = c->clients[i];

                if (!cl || cl->pending)
                        continue;
                client_process(cl);
                client_settle(cl);
        }
}

/* A client held its slot for the idle timeout without a request pending: told why, closed. */
static void client_on_idle(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        struct control_client *cl = arg;
        char why[CONTROL_IDLE_WHY_MAX];

        (void)loop;
        (void)t;
        cl->ctl->stats.idle_closed++;
        log_debug("control: pid %ld uid %ld: idle for %" PRIu64 " ms, closing",
                  (long)cl->cred.pid, (long)cl->cred.uid, cl->ctl->idle_ms);
        snprintf(why, sizeof(why), "no request for %" PRIu64 " ms: closing the connection",
                 cl->ctl->idle_ms);
        client_send_error(cl, -ETIMEDOUT, why);
        /* At once, even with an old reply still unread: a client that neither asks nor reads
         * for that long has no claim on its slot. */
        cl->broken = true;
        client_settle(cl);
}

/* A request was answered: the client may take its next line, or be done. */
static void request_finish(struct control_request *req)
{
        struct control_client *cl = req->client;
        struct control *c = req->ctl;

        if (!cl && c) {
                c->stats.orphan_answers++;
                if (req->prev)
                        req->prev->next = req->next;
                else
                        c->orphans = req->next;
                if (req->next)
                        req->next->prev = req->prev;
        }
        if (cl) {
                cl->pending = NULL;
                client_idle_arm(cl);
                /* Buffered input (a next line, an overlong one, a last one before EOF) is
                 * taken up from the loop, not from inside the engine's reply call. */
                if (!cl->busy && !client_settle(cl) && (cl->eof || cl->in_len > 0))
                        evloop_timer_arm(&cl->ctl->kick, 0, 0);
        }
        free(req);
}

/* ---------------------------------------------------------------------------------------------
 * Reply API */

void control_reply_data(struct control_request *req, const char *fmt, ...)
{
        char buf[CONTROL_REPLY_LINE_MAX];
        va_list ap;
        size_t len;

        if (!req->client)
                return;
        va_start(ap, fmt);
        len = reply_format(buf, CTLP_REPLY_DATA, 0, fmt, ap);
        va_end(ap);
        client_queue(req->client, buf, len);
}

void control_reply_ok(struct control_request *req, const char *fmt, ...)
{
        char buf[CONTROL_REPLY_LINE_MAX];
        va_list ap;
        size_t len;

        if (req->client) {
                va_start(ap, fmt);
                len = reply_format(buf, CTLP_REPLY_OK, 0, fmt, ap);
                va_end(ap);
                client_queue(req->client, buf, len);
        }
        request_finish(req);
}

void control_reply_error(struct control_request *req, int err, const char *fmt, ...)
{
        char buf[CONTROL_REPLY_LINE_MAX];
        va_list ap;
        size_t len;

        if (req->client) {
                va_start(ap, fmt);
                len = reply_format(buf, CTLP_REPLY_ERR, err, fmt, ap);
                va_end(ap);
                client_queue(req->client, buf, len);
        }
        request_finish(req);
}

void control_request_on_gone(struct control_request *req, control_gone_fn fn, void *arg)
{
        req->on_gone = fn;
        req->gone_arg = arg;
}

int control_request_alive(const struct control_request *req)
{
        return req->client && !req->client->broken;
}

size_t control_request_queued(const struct control_request *req)
{
        if (!req->client)
                return 0;
        return req->client->out_len - req->client->out_off;
}

void control_get_stats(const struct control *c, struct control_stats *ret_stats)
{
        *ret_stats = c->stats;
}

void control_set_idle_timeout(struct control *c, unsigned ms)
{
        c->idle_ms = ms;
        for (unsigned i = 0; i < CONTROL_CLIENTS_MAX; i++)
                if (c->clients[i] && !c->clients[i]->pending)
                        client_idle_arm(c->clients[i]);
}

/* ---------------------------------------------------------------------------------------------
 * Listening socket */

static void control_refuse(struct control *c, int fd, const char *msg)
{
        (void)c;
        /* Best effort: a client that cannot take one short line at once gets nothing. */
        if (send(fd, msg, strlen(msg), MSG_DONTWAIT | MSG_NOSIGNAL) < 0)
                log_debug("control: refusing a client: %s", strerror(errno));
        close(fd);
}

/* Whether a peer with these credentials may have a slot (control.h): NULL and the free slot in
 * ret_slot, or the refusal line that says why (counted). */
static const char *control_admit(struct control *c, const struct ucred *cred, unsigned *ret_slot)
{
        unsigned slot = CONTROL_CLIENTS_MAX, used = 0, same_uid = 0;

        for (unsigned i = 0; i < CONTROL_CLIENTS_MAX; i++) {
                if (!c->clients[i]) {
                        if (slot == CONTROL_CLIENTS_MAX)
                                slot = i;
                        continue;
                }
                used++;
                same_uid += c->clients[i]->cred.uid == cred->uid;
        }
        if (slot == CONTROL_CLIENTS_MAX) {
                c->stats.refused_full++;
                return CONTROL_ERR_BUSY;
        }
        if (!peer_privileged(c, cred)) {
                if (same_uid >= CONTROL_CLIENTS_PER_UID) {
                        c->stats.refused_user++;
                        log_ratelimited(&c->refuse_rl, LOG_PRIO_WARNING, "control: refusing "
                                        "pid %ld: uid %ld holds %u connections already",
                                        (long)cred->pid, (long)cred->uid, same_uid);
                        return CONTROL_ERR_USER;
                }
                if (CONTROL_CLIENTS_MAX - used <= CONTROL_CLIENTS_RESERVED) {
                        c->stats.refused_reserved++;
                        log_ratelimited(&c->refuse_rl, LOG_PRIO_WARNING, "control: refusing "
                                        "pid %ld uid %ld: only the slots kept for root and the "
                                        "daemon's user are free", (long)cred->pid,
                                        (long)cred->uid);
                        return CONTROL_ERR_RESERVED;
                }
        }
        *ret_slot = slot;
        return NULL;
}

static void control_accept_one(struct control *c, int fd)
{
        struct control_client *cl;
        struct ucred cred;
        socklen_t len = sizeof(cred);
        const char *refusal;
        unsigned slot;

        if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) < 0) {
                log_warn("control: SO_PEERCRED");
                close(fd);
                return;
        }
        refusal = control_admit(c, &cred, &slot);
        if (refusal) {
                control_refuse(c, fd, refusal);
                return;
        }
        cl = calloc(1, sizeof(*cl));
        if (!cl) {
                close(fd);
                return;
        }
        cl->ctl = c;
        cl->fd = fd;
        cl->cred = cred;
        cl->authorized = peer_allowed(c, fd, &cl->cred);
        if (evloop_add_fd(c->loop, fd, POLLIN | EVLOOP_HANGUP, client_on_event, cl) < 0) {
                free(cl);
                close(fd);
                return;
        }
        evloop_timer_init(&cl->idle, c->loop, client_on_idle, cl);
        client_idle_arm(cl);
        c->clients[slot] = cl;
        c->stats.accepted++;
        c->stats.clients++;
}

static void control_on_accept(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct control *c = arg;

        (void)loop;
        (void)revents;
        for (unsigned i = 0; i < CONTROL_ACCEPT_BUDGET; i++) {
                int cfd = accept4(fd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);

                if (cfd < 0) {
                        if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR ||
                            errno == ECONNABORTED)
                                return;
                        /* EMFILE and the like: the connection stays pending and the socket
                         * readable, so polling it now would spin. Pause, then try again. */
                        log_ratelimited(&c->accept_rl, LOG_PRIO_WARNING, "control: accept: %s",
                                        strerror(errno));
                        evloop_mod_fd(c->loop, c->fd, 0);
                        evloop_timer_arm(&c->resume, CONTROL_ACCEPT_PAUSE_MS, 0);
                        return;
                }
                control_accept_one(c, cfd);
        }
}

static void control_on_resume(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        struct control *c = arg;

        (void)t;
        evloop_mod_fd(loop, c->fd, POLLIN);
}

/* Whether path is a socket nobody listens on any more (a dead daemon's): 1 stale, 0 alive or
 * not a socket, -errno. */
static int control_path_stale(const char *path)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        struct stat st;
        int fd, r;

        if (lstat(path, &st) < 0)
                return errno == ENOENT ? 1 : -errno;
        if (!S_ISSOCK(st.st_mode))
                return 0;
        fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
        if (fd < 0)
                return -errno;
        memcpy(sa.sun_path, path, strlen(path) + 1);
        r = connect(fd, (struct sockaddr *)&sa, sizeof(sa));
        /* A live daemon with a full backlog answers EAGAIN: alive too. */
        r = r < 0 && errno == ECONNREFUSED ? 1 : 0;
        close(fd);
        return r;
}

static int control_bind(struct control *c)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        mode_t old;
        int r;

        memcpy(sa.sun_path, c->path, strlen(c->path) + 1);
        old = umask(CONTROL_BIND_UMASK);
        r = bind(c->fd, (struct sockaddr *)&sa, sizeof(sa)) < 0 ? -errno : 0;
        umask(old);
        return r;
}

int control_new(struct evloop *loop, const char *path, gid_t group, int has_group,
                control_request_fn fn, void *arg, struct control **ret_control)
{
        struct control *c;
        struct stat st;
        int r;

        if (!path || !fn || strlen(path) >= sizeof(c->path))
                return -ENAMETOOLONG;
        c = calloc(1, sizeof(*c));
        if (!c)
                return -ENOMEM;
        c->loop = loop;
        strcpy(c->path, path);
        c->uid = geteuid();
        c->group = group;
        c->has_group = has_group != 0;
        c->fn = fn;
        c->arg = arg;
        c->idle_ms = CONTROL_IDLE_TIMEOUT_MS;
        evloop_timer_init(&c->kick, loop, control_on_kick, c);
        evloop_timer_init(&c->resume, loop, control_on_resume, c);
        log_ratelimit_init(&c->accept_rl, "control accept", LOG_RATELIMIT_INTERVAL_MS,
                           LOG_RATELIMIT_BURST);
        log_ratelimit_init(&c->refuse_rl, "control refusals", LOG_RATELIMIT_INTERVAL_MS,
                           LOG_RATELIMIT_BURST);
        c->fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
        if (c->fd < 0) {
                r = -errno;
                goto fail;
        }
        r = control_bind(c);
        if (r == -EADDRINUSE) {
                r = control_path_stale(path);
                if (r == 1) {
                        log_info("control: replacing the stale socket %s", path);
                        if (unlink(path) < 0 && errno != ENOENT) {
                                r = -errno;
                                goto fail;
                        }
                        r = control_bind(c);
                } else if (r == 0) {
                        r = -EADDRINUSE;
                }
        }
        if (r < 0)
                goto fail_fd;
        if (lstat(path, &st) < 0) {
                r = -errno;
                goto fail_fd;
        }
        c->dev = st.st_dev;
        c->ino = st.st_ino;
        if ((has_group && chown(path, (uid_t)-1, group) < 0) ||
            chmod(path, CONTROL_SOCKET_MODE) < 0) {
                r = -errno;
                goto fail_unlink;
        }
        if (listen(c->fd, CONTROL_BACKLOG) < 0) {
                r = -errno;
                goto fail_unlink;
        }
        r = evloop_add_fd(loop, c->fd, POLLIN, control_on_accept, c);
        if (r < 0)
                goto fail_unlink;
        *ret_control = c;
        return 0;

fail_unlink:
        unlink(path);
fail_fd:
        close(c->fd);
fail:
        free(c);
        return r;
}

struct control *control_free(struct control *c)
{
        struct stat st;

        if (!c)
                return NULL;
        for (unsigned i = 0; i < CONTROL_CLIENTS_MAX; i++) {
                struct control_client *cl = c->clients[i];

                if (!cl)
                        continue;
                client_close(cl);
        }
        for (struct control_request *req = c->orphans; req; req = req->next)
                req->ctl = NULL;
        evloop_timer_cancel(&c->kick);
        evloop_timer_cancel(&c->resume);
        evloop_del_fd(c->loop, c->fd);
        close(c->fd);
        if (lstat(c->path, &st) == 0 && st.st_dev == c->dev && st.st_ino == c->ino)
                unlink(c->path);
        free(c);
        return NULL;
}
