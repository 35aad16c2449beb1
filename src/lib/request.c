/*
 * Commands through the daemon's control socket (wire format: src/proto/control.h): one
 * connection per request, every word checked before it is sent, the reply read line by line
 * within one deadline. Of the shared-memory tables, only the socket path the header publishes
 * (layout 1.2) is read here.
 */
#include "lib/request.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <sharedlink.h>

#include "lib/client.h"
#include "lib/export.h"
#include "lib/sockpath.h"
#include "proto/circe.h"
#include "proto/control.h"
#include "proto/request.h"

#define REQUEST_READ_CHUNK      1024
#define REQUEST_BACKLOG_PAUSE_MS 5      /* connect found the daemon's backlog full: try again */
#define REQUEST_SYNC_EXTRA_MS   10000   /* sync-clocks follows devices for 3 s, plus slack */
#define NS_PER_MS               1000000ull

/* The public limits are the protocols' (proto/control.h, proto/circe.h, proto/request.h), word
 * for word. */
_Static_assert(SL_REQUEST_LINE_MAX + 1 == CTLP_LINE_MAX, "request line limit");
_Static_assert(SL_REQUEST_WORDS_MAX == CTLP_WORDS_MAX, "request word limit");
_Static_assert(SL_REPLY_LINE_MAX == CTLP_REPLY_LINE_MAX, "reply line limit");
_Static_assert(SL_WAIT_MAX_MS == CTLP_WAIT_MAX_MS, "wait limit");
_Static_assert(SL_CIRCE_ADDRESS_SIZE == CIRCE_ADDRESS_LEN + 1, "address size");
_Static_assert(SL_CIRCE_DESTS_MAX == CIRCE_VISUALIZE_DEST_MAX, "visualize destinations");
_Static_assert(SL_COMMAND_TEXT_MAX + 1 == REQP_TEXT_SIZE, "command text limit");
_Static_assert(SL_COMMAND_WORDS_MAX == REQP_TEXT_WORDS_MAX, "command text words");
_Static_assert(SL_QUERY_TIMEOUT_MAX_MS == REQP_QUERY_TIMEOUT_MAX_MS, "query timeout");
_Static_assert(SL_LINK_NAME_SIZE == REQP_LINK_SIZE, "link name size");
_Static_assert(SL_NAME_SIZE == REQP_NAME_SIZE, "variable name size");

#define SL_VISUALIZE_SIZE_V1    sizeof(struct sl_circe_visualize)

/* ---- messages ------------------------------------------------------------------------------ */

static void say(char *buf, size_t size, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* Writes a message into a caller's buffer (NULL/0 allowed), cut to fit. */
static void say(char *buf, size_t size, const char *fmt, ...)
{
        va_list ap;

        if (!buf || size == 0)
                return;
        va_start(ap, fmt);
        vsnprintf(buf, size, fmt, ap);
        va_end(ap);
}

/* Copies text[0..len) into a caller's buffer (NULL/0 allowed), cut to fit. */
static void say_text(char *buf, size_t size, const char *text, size_t len)
{
        if (!buf || size == 0)
                return;
        if (len > size - 1u)
                len = size - 1u;
        memcpy(buf, text, len);
        buf[len] = '\0';
}

/* ---- where the socket is ------------------------------------------------------------------- */

SL_EXPORT int sl_set_runtime_dir(struct sl_client *c, const char *dir)
{
        int r;

        if (!c || (dir && !*dir))
                return -EINVAL;
        client_wrlock(c);
        r = dir ? sockpath_set(&c->sock, c->instance, dir) : sockpath_default(&c->sock, c->instance);
        client_wrunlock(c);
        return r;
}

SL_EXPORT int sl_set_command_wait(struct sl_client *c, int wait_ms)
{
        if (!c || wait_ms < 0 || wait_ms > SL_WAIT_MAX_MS)
                return -EINVAL;
        atomic_store_explicit(&c->command_wait_ms, wait_ms, memory_order_relaxed);
        return 0;
}

/* The socket address of c's daemon (sockpath_address); 0 or -ENAMETOOLONG. */
static int socket_address(struct sl_client *c, struct sockaddr_un *ret_sa)
{
        int r;

        client_rdlock(c);
        r = sockpath_address(&c->sock, c->map->in, c->instance, ret_sa);
        client_unlock(c);
        return r;
}

/* ---- checking what is sent ----------------------------------------------------------------- */

int request_line_check(const char *line, char *why, size_t why_size)
{
        size_t pos = 0, len = line ? strnlen(line, CTLP_LINE_MAX) : 0;

        switch (ctlp_request_check(line, len, &pos)) {
        case CTLP_REASON_NONE:
                return 0;
        case CTLP_REASON_EMPTY:
                say(why, why_size, "empty request");
                break;
        case CTLP_REASON_TOO_LONG:
                say(why, why_size, "request longer than %d bytes", SL_REQUEST_LINE_MAX);
                break;
        case CTLP_REASON_BAD_SPACE:
                say(why, why_size, "request has a leading, trailing or double space");
                break;
        case CTLP_REASON_BAD_BYTE:
                say(why, why_size, "request byte %zu (0x%02x) is not printable ASCII", pos,
                    (unsigned char)line[pos]);
                break;
        case CTLP_REASON_TOO_MANY_WORDS:
                say(why, why_size, "request has more than %d words", SL_REQUEST_WORDS_MAX);
                break;
        }
        return -EINVAL;
}

static int check_range(const char *what, long v, long min, long max, char *why, size_t why_size)
{
        if (v >= min && v <= max)
                return 0;
        say(why, why_size, "bad %s %ld: %ld..%ld expected", what, v, min, max);
        return -EINVAL;
}

/* ---- the exchange -------------------------------------------------------------------------- */

/* Milliseconds left before deadline (0: none), -1 for no deadline. */
static int time_left(uint64_t deadline)
{
        uint64_t now;

        if (!deadline)
                return -1;
        now = client_now(CLOCK_MONOTONIC);
        if (now >= deadline)
                return 0;
        return (int)((deadline - now + NS_PER_MS - 1u) / NS_PER_MS);
}

/* Waits for events on fd until the deadline: 1 ready, 0 timed out, -errno. */
static int wait_fd(int fd, short events, uint64_t deadline)
{
        for (;;) {
                struct pollfd p = { .fd = fd, .events = events };
                int left = time_left(deadline), r;

                if (left == 0)
                        return 0;
                r = poll(&p, 1, left);
                if (r > 0)
                        return 1;
                if (r < 0 && errno != EINTR)
                        return -errno;
        }
}

/* Connects to the daemon's socket; returns the fd (CLOEXEC, non-blocking) or -errno. */
static int connect_daemon(const struct sockaddr_un *sa, uint64_t deadline, char *why,
                          size_t why_size)
{
        int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
        int r;

        if (fd < 0) {
                r = -errno;
                say(why, why_size, "socket: %s", strerror(-r));
                return r;
        }
        for (;;) {
                if (connect(fd, (const struct sockaddr *)sa, sizeof(*sa)) == 0)
                        return fd;
                r = -errno;
                /* A Unix socket's connect never goes in progress; EAGAIN is a full backlog. */
                if (r == -EAGAIN && time_left(deadline) != 0) {
                        poll(NULL, 0, REQUEST_BACKLOG_PAUSE_MS);
                        continue;
                }
                if (r != -EINTR)
                        break;
        }
        close(fd);
        switch (-r) {
        case ENOENT:
        case ENOTDIR:
        case ECONNREFUSED:
                say(why, why_size, "sharedlinkd is not running (nothing listens on %s)",
                    sa->sun_path);
                return -ECONNREFUSED;
        case EACCES:
        case EPERM:
                say(why, why_size, "permission denied on %s (commands need the daemon's group)",
                    sa->sun_path);
                return -EACCES;
        case EAGAIN:
                say(why, why_size, "timed out connecting to %s", sa->sun_path);
                return -ETIMEDOUT;
        default:
                say(why, why_size, "connect %s: %s", sa->sun_path, strerror(-r));
                return r;
        }
}

/* Sends all of buf; 0, -ETIMEDOUT, or -errno (-EPIPE: the daemon closed its end). */
static int send_all(int fd, const char *buf, size_t len, uint64_t deadline)
{
        while (len > 0) {
                ssize_t n = send(fd, buf, len, MSG_NOSIGNAL);

                if (n > 0) {
                        buf += n;
                        len -= (size_t)n;
                        continue;
                }
                if (n < 0 && errno == EINTR)
                        continue;
                if (n < 0 && errno != EAGAIN)
                        return -errno;
                n = wait_fd(fd, POLLOUT, deadline);
                if (n <= 0)
                        return n == 0 ? -ETIMEDOUT : (int)n;
        }
        return 0;
}

/* What the reading of one reply needs. */
struct exchange {
        int fd;
        uint64_t deadline;
        sl_data_fn on_data;
        void *arg;
        char *reply;
        size_t reply_size;
        char line[SL_REPLY_LINE_MAX + 1];
        size_t len;
};

/* Handles one complete line: 1 to read on, 0 (OK) or -errno when the reply is complete. */
static int exchange_line(struct exchange *x)
{
        const char *text;
        int err = 0, kind, r;

        x->line[x->len] = '\0';
        kind = ctlp_reply_parse(x->line, x->len, &text, &err);
        switch (kind) {
        case CTLP_REPLY_DATA:
                r = x->on_data ? x->on_data(text, x->arg) : 0;
                if (r < 0) {
                        say(x->reply, x->reply_size, "at the reply line \"%.200s\": %s", text,
                            strerror(-r));
                        return r;
                }
                return 1;
        case CTLP_REPLY_OK:
                say_text(x->reply, x->reply_size, text, strlen(text));
                return 0;
        case CTLP_REPLY_ERR:
                if (*text)
                        say_text(x->reply, x->reply_size, text, strlen(text));
                else
                        say(x->reply, x->reply_size, "%s", strerror(err));
                return -err;
        default:
                say(x->reply, x->reply_size, "reply not understood: \"%.80s\"", x->line);
                return -EPROTO;
        }
}

/* Reads reply lines until the final one; 0 or -errno. */
static int exchange_read(struct exchange *x)
{
        char chunk[REQUEST_READ_CHUNK];

        for (;;) {
                ssize_t n;

                /* Checked on every chunk, not only when the socket runs dry: a daemon that keeps
                 * sending never lets recv say EAGAIN. */
                if (time_left(x->deadline) == 0) {
                        say(x->reply, x->reply_size, "no complete reply in time");
                        return -ETIMEDOUT;
                }
                n = recv(x->fd, chunk, sizeof(chunk), 0);
                if (n < 0 && errno == EINTR)
                        continue;
                if (n < 0 && errno == EAGAIN) {
                        int w = wait_fd(x->fd, POLLIN, x->deadline);

                        if (w == 0) {
                                say(x->reply, x->reply_size, "no complete reply in time");
                                return -ETIMEDOUT;
                        }
                        if (w < 0)
                                return w;
                        continue;
                }
                if (n < 0 && errno != ECONNRESET) {
                        int r = -errno;

                        say(x->reply, x->reply_size, "reading the reply: %s", strerror(-r));
                        return r;
                }
                if (n <= 0) {
                        say(x->reply, x->reply_size, "the daemon closed the connection before "
                            "its reply was complete");
                        return -ECONNRESET;
                }
                for (ssize_t i = 0; i < n; i++) {
                        int r;

                        if (chunk[i] != '\n') {
                                if (x->len == SL_REPLY_LINE_MAX) {
                                        say(x->reply, x->reply_size, "reply line longer than "
                                            "%d bytes", SL_REPLY_LINE_MAX);
                                        return -EPROTO;
                                }
                                x->line[x->len++] = chunk[i];
                                continue;
                        }
                        r = exchange_line(x);
                        x->len = 0;
                        if (r <= 0)
                                return r;       /* bytes after the final line are ignored */
                }
        }
}

SL_EXPORT int sl_request(struct sl_client *c, const char *line, int timeout_ms,
                         sl_data_fn on_data, void *arg, char *reply, size_t reply_size)
{
        struct exchange *x;
        struct sockaddr_un sa;
        uint64_t deadline = 0;
        size_t len;
        int r;

        if (!c) {
                say(reply, reply_size, "no handle");
                return -EINVAL;
        }
        r = request_line_check(line, reply, reply_size);
        if (r < 0)
                return r;
        r = socket_address(c, &sa);
        if (r < 0) {
                say(reply, reply_size, "the runtime directory is too long for a socket path");
                return r;
        }
        if (timeout_ms == 0)
                timeout_ms = SL_REQUEST_TIMEOUT_MS;
        if (timeout_ms > 0)
                deadline = client_now(CLOCK_MONOTONIC) + (uint64_t)timeout_ms * NS_PER_MS;
        x = calloc(1, sizeof(*x));      /* ~4 KiB: not on the caller's stack */
        if (!x) {
                say(reply, reply_size, "out of memory");
                return -ENOMEM;
        }
        x->deadline = deadline;
        x->on_data = on_data;
        x->arg = arg;
        x->reply = reply;
        x->reply_size = reply_size;
        x->fd = connect_daemon(&sa, deadline, reply, reply_size);
        if (x->fd < 0) {
                r = x->fd;
                free(x);
                return r;
        }
        len = strlen(line);
        memcpy(x->line, line, len);
        x->line[len++] = '\n';
        r = send_all(x->fd, x->line, len, deadline);
        x->len = 0;
        /* A daemon that refuses us (credentials) answers and closes: its answer says why. */
        if (r == 0 || r == -EPIPE || r == -ECONNRESET)
                r = exchange_read(x);
        else
                say(reply, reply_size, "sending the request: %s", strerror(-r));
        close(x->fd);
        free(x);
        return r;
}

/* ---- typed commands ------------------------------------------------------------------------ */

/*
 * Encodes r (proto/request.h checks every argument the way the daemon will) with the handle's
 * wait=MS and sends it, within base_ms plus the wait.
 */
static int command(struct sl_client *c, struct reqp_request *r, int base_ms,
                   sl_data_fn on_data, void *arg, char *reply, size_t reply_size)
{
        int wait_ms = atomic_load_explicit(&c->command_wait_ms, memory_order_relaxed);
        char line[CTLP_LINE_MAX];
        int n;

        r->wait_ms = (uint32_t)wait_ms;
        n = reqp_encode(r, line, sizeof(line), reply, reply_size);
        if (n < 0)
                return -EINVAL;         /* a bad argument, or more than one line holds */
        return sl_request(c, line, base_ms + wait_ms, on_data, arg, reply, reply_size);
}

/* Starts a request of kind on link. */
static int begin(struct sl_client *c, struct reqp_request *r, enum reqp_kind kind,
                 const char *link, char *reply, size_t reply_size)
{
        reqp_init(r, kind);
        if (!c) {
                say(reply, reply_size, "no handle");
                return -EINVAL;
        }
        return reqp_set_link(r, link, reply, reply_size);
}

/* Starts a request of kind to peer on link that the peer has timeout_ms to answer (0: the
 * daemon's default, no TIMEOUT_MS word). */
static int begin_peer(struct sl_client *c, struct reqp_request *r, enum reqp_kind kind,
                      const char *link, const char *peer, int timeout_ms, char *reply,
                      size_t reply_size)
{
        int rc = begin(c, r, kind, link, reply, reply_size);

        if (rc == 0)
                rc = reqp_set_text(r, "peer", peer, reply, reply_size);
        if (rc == 0)
                rc = check_range("timeout (ms)", timeout_ms, 0, SL_QUERY_TIMEOUT_MAX_MS, reply,
                                 reply_size);
        if (rc == 0 && timeout_ms > 0)
                rc = reqp_set_number(r, "timeout", timeout_ms, reply, reply_size);
        return rc;
}

/* Receives the query's answer: "OK <value>". */
SL_EXPORT int sl_query(struct sl_client *c, const char *link, const char *peer, const char *name,
                       int timeout_ms, char *reply, size_t reply_size)
{
        char value[SL_REPLY_LINE_MAX + 1];
        struct reqp_request q;
        size_t len;
        int r;

        if (!c || !reply || reply_size == 0) {
                say(reply, reply_size, "no handle or no buffer for the value");
                return -EINVAL;
        }
        r = begin_peer(c, &q, REQP_QUERY, link, peer, timeout_ms, reply, reply_size);
        if (r == 0)
                r = reqp_set_text(&q, "variable name", name, reply, reply_size);
        if (r < 0)
                return r;
        r = command(c, &q, (timeout_ms ? timeout_ms : SL_REQUEST_TIMEOUT_MS) +
                    SL_REQUEST_TIMEOUT_MS, NULL, NULL, value, sizeof(value));
        if (r < 0) {
                say_text(reply, reply_size, value, strlen(value));
                return r;
        }
        len = strlen(value);
        if (len + 1u > reply_size) {
                say(reply, reply_size, "buffer too small for the value");
                return -ENOBUFS;
        }
        memcpy(reply, value, len + 1u);
        return (int)len;
}

/* The ping's round trip: "OK <nanoseconds>", decimal digits only. */
static int rtt_parse(const char *text, uint64_t *ret_ns)
{
        uint64_t v = 0;
        size_t i = 0;

        for (; text[i] >= '0' && text[i] <= '9'; i++) {
                if (v > (UINT64_MAX - 9u) / 10u)
                        return -EPROTO;
                v = v * 10u + (uint64_t)(text[i] - '0');
        }
        if (i == 0 || text[i] != '\0')
                return -EPROTO;
        *ret_ns = v;
        return 0;
}

SL_EXPORT int sl_ping(struct sl_client *c, const char *link, const char *peer, int timeout_ms,
                      uint64_t *ret_rtt_ns, char *reply, size_t reply_size)
{
        char text[SL_REPLY_LINE_MAX + 1];
        struct reqp_request q;
        uint64_t rtt = 0;
        int r = begin_peer(c, &q, REQP_PEER_PING, link, peer, timeout_ms, reply, reply_size);

        if (r < 0)
                return r;
        r = command(c, &q, (timeout_ms ? timeout_ms : SL_REQUEST_TIMEOUT_MS) +
                    SL_REQUEST_TIMEOUT_MS, NULL, NULL, text, sizeof(text));
        if (r == 0 && rtt_parse(text, &rtt) < 0) {
                say(reply, reply_size, "a ping's reply not understood: \"%.64s\"", text);
                return -EPROTO;
        }
        say_text(reply, reply_size, text, strlen(text));
        if (r == 0 && ret_rtt_ns)
                *ret_rtt_ns = rtt;
        return r;
}

SL_EXPORT int sl_command(struct sl_client *c, const char *link, const char *module,
                         const char *text)
{
        struct reqp_request r;
        int rc = begin(c, &r, REQP_COMMAND, link, NULL, 0);

        if (rc == 0)
                rc = reqp_set_text(&r, "module", module, NULL, 0);
        if (rc == 0)
                rc = reqp_set_text(&r, "command text", text ? text : "", NULL, 0);
        if (rc < 0)
                return rc;
        return command(c, &r, SL_REQUEST_TIMEOUT_MS, NULL, NULL, NULL, 0);
}

SL_EXPORT int sl_circe_alert(struct sl_client *c, const char *link, const char *addr, char *reply,
                             size_t reply_size)
{
        struct reqp_request r;
        int rc = begin(c, &r, REQP_CIRCE_ALERT, link, reply, reply_size);

        if (rc == 0)
                rc = reqp_set_text(&r, "address", addr, reply, reply_size);
        if (rc < 0)
                return rc;
        return command(c, &r, SL_REQUEST_TIMEOUT_MS, NULL, NULL, reply, reply_size);
}

SL_EXPORT int sl_circe_network_setup(struct sl_client *c, const char *link, const char *addr,
                                     int join, int roles, char *reply, size_t reply_size)
{
        struct reqp_request r;
        int rc = begin(c, &r, REQP_CIRCE_NETWORK_SETUP, link, reply, reply_size);

        if (rc == 0)
                rc = reqp_set_text(&r, "address", addr, reply, reply_size);
        if (rc == 0)
                rc = reqp_set_number(&r, "membership", join, reply, reply_size);
        if (rc == 0)
                rc = reqp_set_number(&r, "roles", roles, reply, reply_size);
        if (rc < 0)
                return rc;
        return command(c, &r, SL_REQUEST_TIMEOUT_MS, NULL, NULL, reply, reply_size);
}

SL_EXPORT int sl_circe_device_setup(struct sl_client *c, const char *link, const char *assign,
                                    int has_dest, const char *dest, int has_caps, int caps,
                                    char *reply, size_t reply_size)
{
        struct reqp_request r;
        int rc = begin(c, &r, REQP_CIRCE_DEVICE_SETUP, link, reply, reply_size);

        if (rc == 0)
                rc = reqp_set_text(&r, "address to assign", assign, reply, reply_size);
        if (rc == 0 && has_dest)
                rc = reqp_set_text(&r, "destination", dest, reply, reply_size);
        if (rc == 0 && has_caps)
                rc = reqp_set_number(&r, "capabilities", caps, reply, reply_size);
        if (rc < 0)
                return rc;
        return command(c, &r, SL_REQUEST_TIMEOUT_MS, NULL, NULL, reply, reply_size);
}

/* Where sync-clocks results go. */
struct sync_results {
        sl_sync_fn fn;
        void *arg;
};

/* One device's result (proto/request.h: REQP_REPLY_SYNC). */
static int sync_line(const char *text, void *arg)
{
        const struct sync_results *s = arg;
        char addr[SL_CIRCE_ADDRESS_SIZE];
        uint32_t address;
        bool succeeded;

        if (reqp_sync_result_parse(text, &address, &succeeded) < 0)
                return -EPROTO;
        circe_address_format(address, addr);
        return s->fn ? s->fn(addr, succeeded, s->arg) : 0;
}

SL_EXPORT int sl_circe_sync_clocks(struct sl_client *c, const char *link, sl_sync_fn on_result,
                                   void *arg, char *reply, size_t reply_size)
{
        struct sync_results s = { .fn = on_result, .arg = arg };
        struct reqp_request r;
        int rc = begin(c, &r, REQP_CIRCE_SYNC_CLOCKS, link, reply, reply_size);

        if (rc < 0)
                return rc;
        return command(c, &r, SL_REQUEST_TIMEOUT_MS + REQUEST_SYNC_EXTRA_MS, sync_line, &s,
                       reply, reply_size);
}

/* One optional display field of a Visualize: the vocabulary's key, when has is set. */
struct vis_field {
        const char *key;
        int has;
        long value;
};

SL_EXPORT int sl_circe_visualize(struct sl_client *c, const char *link,
                                 const struct sl_circe_visualize *v, char *reply,
                                 size_t reply_size)
{
        struct sl_circe_visualize full;
        struct reqp_request r;
        int rc;

        if (!v || v->size < SL_VISUALIZE_SIZE_V1) {
                say(reply, reply_size, "no visualize fields, or their size is not set");
                return -EINVAL;
        }
        /* Fields past the caller's size (a newer header than the caller's) read as absent. */
        memset(&full, 0, sizeof(full));
        memcpy(&full, v, v->size < sizeof(full) ? v->size : sizeof(full));
        rc = begin(c, &r, REQP_CIRCE_VISUALIZE, link, reply, reply_size);
        if (rc < 0)
                return rc;
        if (!full.dests || full.dest_count < 1 || full.dest_count > SL_CIRCE_DESTS_MAX) {
                say(reply, reply_size, "bad destination count %u: 1..%d expected",
                    full.dests ? full.dest_count : 0u, SL_CIRCE_DESTS_MAX);
                return -EINVAL;
        }
        for (unsigned i = 0; i < full.dest_count; i++) {
                rc = reqp_set_text(&r, "destination", full.dests[i], reply, reply_size);
                if (rc < 0)
                        return rc;
        }
        {
                const struct vis_field fields[] = {
                        { "current", full.has_current, full.current },
                        { "next", full.has_next, full.next },
                        { "start-timer", full.start_timer, full.start_timer },
                        { "primary", full.has_primary, full.primary_ms },
                        { "secondary", full.has_secondary, full.secondary_ms },
                        { "faults", full.has_faults, full.faults },
                        { "refusals", full.has_refusals, full.refusals },
                        { "eliminated", full.has_eliminated, full.eliminated },
                        { "placement", full.has_placement, full.placement },
                };

                for (size_t i = 0; i < sizeof(fields) / sizeof(fields[0]); i++) {
                        if (!fields[i].has)
                                continue;
                        rc = reqp_set_number(&r, fields[i].key, fields[i].value, reply,
                                             reply_size);
                        if (rc < 0)
                                return rc;
                }
        }
        return command(c, &r, SL_REQUEST_TIMEOUT_MS, NULL, NULL, reply, reply_size);
}

SL_EXPORT int sl_circe_emulate_action(struct sl_client *c, const char *link, const char *addr,
                                      int has_keys, int keys, int has_sensor_time,
                                      long sensor_time_ms, char *reply, size_t reply_size)
{
        struct reqp_request r;
        int rc = begin(c, &r, REQP_CIRCE_EMULATE_ACTION, link, reply, reply_size);

        if (rc == 0)
                rc = reqp_set_text(&r, "device", addr, reply, reply_size);
        if (rc == 0 && has_keys)
                rc = reqp_set_number(&r, "keys", keys, reply, reply_size);
        if (rc == 0 && has_sensor_time)
                rc = reqp_set_number(&r, "sensor-time", sensor_time_ms, reply, reply_size);
        if (rc < 0)
                return rc;
        return command(c, &r, SL_REQUEST_TIMEOUT_MS, NULL, NULL, reply, reply_size);
}
