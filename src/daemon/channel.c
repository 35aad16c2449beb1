/*
 * Channel: a self-reopening transport on the event loop (see channel.h).
 *
 * Output queue: one linear buffer, data between head and tail, moved to the front when the
 * tail reaches the end. Byte streams queue raw bytes (a partial write just advances head);
 * datagram transports queue records of a 16-bit length and the payload, one send() each, so
 * datagram boundaries survive queueing.
 */
#include "daemon/channel.h"

#include <errno.h>
#include <poll.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CHANNEL_REC_HDR         2       /* datagram record header: length, little endian */
#define CHANNEL_NSEC_PER_MSEC   1000000ull

_Static_assert(TRANSPORT_DATAGRAM_MAX <= UINT16_MAX, "datagram length must fit the record header");

struct channel_outq {
        uint8_t *buf;
        size_t cap, head, tail;
};

struct channel {
        struct evloop *loop;
        struct transport_params params;
        struct channel_ops ops;
        void *arg;
        channel_tap_fn tap;             /* NULL unless a recorder may listen */
        void *tap_arg;

        enum channel_state state;
        struct transport *tp;           /* open while UP */
        int fd;                         /* its fd, registered with the loop while UP */
        unsigned events;                /* what the loop polls fd for */
        unsigned device_index;          /* serial: which of params.devices is open / next */
        int write_error;                /* fatal error met by channel_send(), for the loop */
        unsigned gen;                   /* bumped at every close: callbacks detect it */

        unsigned backoff_min, backoff_max;
        unsigned backoff_next;          /* delay of the next retry */
        unsigned retry_ms;              /* delay of the scheduled retry */
        uint64_t up_since_ns;
        struct evloop_timer retry;

        unsigned depth;                 /* our loop callbacks on the stack */
        bool free_pending;              /* channel_free() called from inside one */

        struct channel_outq q;
        struct channel_stats stats;
        char reason[CHANNEL_REASON_MAX];
        uint8_t rbuf[TRANSPORT_DATAGRAM_MAX];
};

__attribute__((format(printf, 2, 3)))
static void channel_set_reason(struct channel *ch, const char *fmt, ...)
{
        va_list ap;

        va_start(ap, fmt);
        vsnprintf(ch->reason, sizeof(ch->reason), fmt, ap);
        va_end(ap);
}

static void channel_tap(struct channel *ch, bool out, const void *data, size_t len)
{
        if (ch->tap && len > 0)
                ch->tap(ch->tap_arg, out, data, len);
}

/* ---------------------------------------------------------------------------------------------
 * Output queue */

static size_t channel_q_len(const struct channel_outq *q)
{
        return q->tail - q->head;
}

static bool channel_q_push(struct channel_outq *q, const void *hdr, size_t hdrlen,
                           const void *data, size_t len)
{
        size_t need = hdrlen + len;

        if (need > q->cap - channel_q_len(q))
                return false;
        if (need > q->cap - q->tail) {
                memmove(q->buf, q->buf + q->head, channel_q_len(q));
                q->tail -= q->head;
                q->head = 0;
        }
        if (hdrlen)
                memcpy(q->buf + q->tail, hdr, hdrlen);
        memcpy(q->buf + q->tail + hdrlen, data, len);
        q->tail += need;
        return true;
}

static void channel_q_drop(struct channel_outq *q, size_t n)
{
        q->head += n;
        if (q->head == q->tail)
                q->head = q->tail = 0;
}

/* Queues a frame whole; false when it does not fit. */
static bool channel_q_frame(struct channel *ch, const uint8_t *data, size_t len)
{
        uint8_t hdr[CHANNEL_REC_HDR] = { (uint8_t)(len & 0xff), (uint8_t)(len >> 8) };

        if (transport_is_datagram(ch->tp))
                return channel_q_push(&ch->q, hdr, sizeof(hdr), data, len);
        return channel_q_push(&ch->q, NULL, 0, data, len);
}

/* ---------------------------------------------------------------------------------------------
 * State changes */

static void channel_on_io(struct evloop *loop, int fd, unsigned revents, void *arg);
static void channel_on_retry(struct evloop *loop, struct evloop_timer *timer, void *arg);

/* Polls for input always, for output while something is queued or a write error waits. */
static void channel_update_events(struct channel *ch)
{
        unsigned want = POLLIN;

        if (!ch->tp)
                return;
        if (channel_q_len(&ch->q) > 0 || ch->write_error)
                want |= POLLOUT;
        if (want != ch->events && evloop_mod_fd(ch->loop, ch->fd, want) == 0)
                ch->events = want;
}

static void channel_close_transport(struct channel *ch)
{
        if (!ch->tp)
                return;
        evloop_del_fd(ch->loop, ch->fd);
        ch->tp = transport_close(ch->tp);
        ch->fd = -1;
        ch->events = 0;
        ch->write_error = 0;
        ch->q.head = ch->q.tail = 0;
        ch->gen++;
}

/* Closed or failed: arm the retry with the current delay and double the next one. */
static void channel_schedule_retry(struct channel *ch)
{
        unsigned delay = ch->backoff_next;

        if (!transport_reopens(ch->params.kind)) {
                /* A replay's end, or a recording that cannot be played: final. */
                ch->state = CHANNEL_STATE_STOPPED;
                ch->retry_ms = 0;
                return;
        }
        ch->backoff_next = delay >= ch->backoff_max / 2 ? ch->backoff_max : delay * 2;
        ch->retry_ms = delay;
        ch->state = CHANNEL_STATE_BACKOFF;
        if (ch->params.kind == TRANSPORT_SERIAL)
                ch->device_index = (ch->device_index + 1) % ch->params.n_devices;
        /* Fails only with EVLOOP_TIMERS_MAX timers armed: main keeps links far below that. */
        evloop_timer_arm(&ch->retry, delay, 0);
}

static void channel_notify_down(struct channel *ch, bool notify)
{
        if (notify && ch->ops.down)
                ch->ops.down(ch, ch->reason, ch->retry_ms, ch->arg);
}

/* UP -> BACKOFF. `notify`: call `down` (only from our own loop callbacks). */
static void channel_go_down(struct channel *ch, bool notify)
{
        uint64_t now = evloop_clock_ns();

        if (ch->state != CHANNEL_STATE_UP)
                return;
        channel_close_transport(ch);
        ch->stats.downs++;
        /* Stable for a while: this is a new failure, not a flapping device. */
        if (now - ch->up_since_ns >= (uint64_t)ch->backoff_max * CHANNEL_NSEC_PER_MSEC)
                ch->backoff_next = ch->backoff_min;
        channel_schedule_retry(ch);
        channel_notify_down(ch, notify);
}

/* One attempt to open; 0 when up. `notify`: call `up`/`down` (only from the retry timer). */
static int channel_try_open(struct channel *ch, bool notify)
{
        char err[TRANSPORT_ERR_MAX];
        int r;

        r = transport_open(&ch->params, ch->device_index, &ch->tp, err, sizeof(err));
        if (r == 0) {
                ch->fd = transport_fd(ch->tp);
                r = evloop_add_fd(ch->loop, ch->fd, POLLIN, channel_on_io, ch);
                if (r < 0) {
                        snprintf(err, sizeof(err), "event loop: %s", strerror(-r));
                        ch->tp = transport_close(ch->tp);
                        ch->fd = -1;
                }
        }
        if (r < 0) {
                ch->stats.open_failures++;
                channel_set_reason(ch, "%s", err);
                channel_schedule_retry(ch);
                channel_notify_down(ch, notify);
                return r;
        }
        ch->events = POLLIN;
        ch->state = CHANNEL_STATE_UP;
        ch->retry_ms = 0;
        ch->up_since_ns = evloop_clock_ns();
        if (ch->stats.opens++ > 0)
                ch->stats.reopens++;
        if (notify && ch->ops.up)
                ch->ops.up(ch, ch->arg);
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Loop callbacks */

static void channel_release(struct channel *ch)
{
        free(ch->q.buf);
        free(ch);
}

/* Every loop callback of ours is bracketed by these, so channel_free() from inside a user
 * callback only marks the channel and the outermost frame releases it. */
static void channel_enter(struct channel *ch)
{
        ch->depth++;
}

static void channel_leave(struct channel *ch)
{
        if (--ch->depth == 0 && ch->free_pending)
                channel_release(ch);
}

static void channel_on_retry(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        struct channel *ch = arg;

        (void)loop;
        (void)timer;
        channel_enter(ch);
        ch->retry_ms = 0;
        channel_try_open(ch, true);
        channel_leave(ch);
}

/*
 * transport_write(), where an ECONNREFUSED on a datagram socket is not an error of this
 * datagram: it reports the ICMP port unreachable an earlier one got (the peer's socket did not
 * exist yet, as at start-up), and the kernel then drops this one unsent. The error is cleared by
 * being reported, so the datagram goes again, once; the refusal is counted apart from io_errors.
 */
static ssize_t channel_write(struct channel *ch, const void *data, size_t len)
{
        ssize_t n = transport_write(ch->tp, data, len);

        if (n == -ECONNREFUSED && transport_is_datagram(ch->tp)) {
                ch->stats.refused++;
                n = transport_write(ch->tp, data, len);
        }
        return n;
}

/* Writes queued output until it blocks. Returns false if the channel went down. */
static bool channel_flush(struct channel *ch)
{
        bool dgram = transport_is_datagram(ch->tp);

        while (channel_q_len(&ch->q) > 0) {
                const uint8_t *p = ch->q.buf + ch->q.head;
                size_t len = channel_q_len(&ch->q), hdr = 0;
                ssize_t n;

                if (dgram) {
                        hdr = CHANNEL_REC_HDR;
                        len = (size_t)p[0] | (size_t)p[1] << 8;
                        p += hdr;
                }
                n = channel_write(ch, p, len);
                if (n == -EAGAIN)
                        break;
                if (n < 0) {
                        ch->stats.io_errors++;
                        if (transport_error_fatal(ch->tp, (int)n)) {
                                channel_set_reason(ch, "write: %s", strerror((int)-n));
                                channel_go_down(ch, true);
                                return false;
                        }
                        ch->stats.tx_dropped++;
                        channel_q_drop(&ch->q, hdr + len);
                        continue;
                }
                ch->stats.bytes_out += (uint64_t)n;
                channel_tap(ch, true, p, (size_t)n);
                if (dgram) {
                        ch->stats.datagrams_out++;
                        channel_q_drop(&ch->q, hdr + len);
                } else {
                        channel_q_drop(&ch->q, (size_t)n);
                }
        }
        channel_update_events(ch);
        return true;
}

/* Reads until EAGAIN or the budget; returns false if the channel went down or was stopped /
 * freed by the input callback. */
static bool channel_read(struct channel *ch, unsigned revents)
{
        bool dgram = transport_is_datagram(ch->tp);
        unsigned gen = ch->gen;
        ssize_t n = 0;

        for (unsigned i = 0; i < CHANNEL_READ_BUDGET; i++) {
                n = transport_read(ch->tp, ch->rbuf, sizeof(ch->rbuf));
                if (n == -EAGAIN)
                        break;
                if (n == -ECONNREFUSED && dgram) {
                        /* The ICMP answer to a datagram of ours: see channel_write(). */
                        ch->stats.refused++;
                        continue;
                }
                if (n < 0) {
                        const char *end = transport_end_reason(ch->tp, (int)n);

                        if (!end)               /* a replay's end is no I/O error */
                                ch->stats.io_errors++;
                        if (transport_error_fatal(ch->tp, (int)n)) {
                                if (end)
                                        channel_set_reason(ch, "%s", end);
                                else if (n == -EPIPE)
                                        channel_set_reason(ch, "hang-up");
                                else
                                        channel_set_reason(ch, "read: %s", strerror((int)-n));
                                channel_go_down(ch, true);
                                return false;
                        }
                        if (n == -EMSGSIZE)
                                ch->stats.rx_dropped++;
                        continue;
                }
                ch->stats.bytes_in += (uint64_t)n;
                if (dgram)
                        ch->stats.datagrams_in++;
                channel_tap(ch, false, ch->rbuf, (size_t)n);
                if (ch->ops.input)
                        ch->ops.input(ch, ch->rbuf, (size_t)n, ch->arg);
                if (ch->gen != gen || ch->free_pending || ch->state != CHANNEL_STATE_UP)
                        return false;
                /* A byte stream that gave less than asked for had nothing more right then: the
                 * read that would only say EAGAIN is one syscall per frame saved (poll is level
                 * triggered, so bytes that come later are reported again). Not with a hang-up or
                 * an error pending: that read is what tells it below. */
                if (!dgram && (size_t)n < sizeof(ch->rbuf) && !(revents & (POLLHUP | POLLERR)))
                        return true;
        }
        /* A tty that reports a hang-up or an error but has nothing to read would make poll()
         * return at once forever: that is a dead device too. (A UDP socket's POLLERR is an
         * ICMP error, consumed by the read above.) */
        if (!dgram && n == -EAGAIN && (revents & (POLLHUP | POLLERR))) {
                channel_set_reason(ch, (revents & POLLHUP) ? "hang-up" : "device error");
                channel_go_down(ch, true);
                return false;
        }
        return true;
}

static void channel_on_io(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct channel *ch = arg;

        (void)loop;
        (void)fd;
        channel_enter(ch);
        if (revents & POLLNVAL) {
                channel_set_reason(ch, "descriptor closed behind our back");
                channel_go_down(ch, true);
        } else if (ch->write_error) {
                channel_set_reason(ch, "write: %s", strerror(-ch->write_error));
                channel_go_down(ch, true);
        } else if (!(revents & (POLLIN | POLLHUP | POLLERR)) || channel_read(ch, revents)) {
                if (revents & POLLOUT)
                        channel_flush(ch);
        }
        channel_leave(ch);
}

/* ---------------------------------------------------------------------------------------------
 * API */

int channel_new(struct evloop *loop, const struct transport_params *params,
                const struct channel_options *options, const struct channel_ops *ops, void *arg,
                struct channel **ret_channel)
{
        struct channel_options o = options ? *options : (struct channel_options){ 0 };
        struct channel *ch;

        if (!loop || transport_params_check(params))
                return -EINVAL;
        if (o.outq_bytes == 0)
                o.outq_bytes = CHANNEL_OUTQ_DEFAULT;
        if (o.backoff_min_ms == 0)
                o.backoff_min_ms = CHANNEL_BACKOFF_MIN_MS;
        if (o.backoff_max_ms == 0)
                o.backoff_max_ms = CHANNEL_BACKOFF_MAX_MS;
        if (o.outq_bytes > CHANNEL_OUTQ_MAX || o.backoff_min_ms > o.backoff_max_ms)
                return -EINVAL;
        ch = calloc(1, sizeof(*ch));
        if (!ch)
                return -ENOMEM;
        ch->q.buf = malloc(o.outq_bytes);
        if (!ch->q.buf) {
                free(ch);
                return -ENOMEM;
        }
        ch->q.cap = o.outq_bytes;
        ch->loop = loop;
        ch->params = *params;
        if (ops)
                ch->ops = *ops;
        ch->arg = arg;
        ch->fd = -1;
        ch->state = CHANNEL_STATE_STOPPED;
        ch->backoff_min = o.backoff_min_ms;
        ch->backoff_max = o.backoff_max_ms;
        ch->backoff_next = o.backoff_min_ms;
        evloop_timer_init(&ch->retry, loop, channel_on_retry, ch);
        *ret_channel = ch;
        return 0;
}

int channel_start(struct channel *ch)
{
        if (ch->state != CHANNEL_STATE_STOPPED)
                return -EALREADY;
        return channel_try_open(ch, false);
}

void channel_stop(struct channel *ch)
{
        evloop_timer_cancel(&ch->retry);
        channel_close_transport(ch);
        ch->state = CHANNEL_STATE_STOPPED;
        ch->retry_ms = 0;
        ch->backoff_next = ch->backoff_min;
}

struct channel *channel_free(struct channel *ch)
{
        if (!ch)
                return NULL;
        channel_stop(ch);
        if (ch->depth > 0)
                ch->free_pending = true;
        else
                channel_release(ch);
        return NULL;
}

int channel_send(struct channel *ch, const void *data, size_t len)
{
        bool dgram;
        ssize_t n = -EAGAIN;

        if (ch->state != CHANNEL_STATE_UP || ch->write_error) {
                ch->stats.tx_dropped++;
                return -ENOTCONN;
        }
        dgram = transport_is_datagram(ch->tp);
        if (len > (dgram ? TRANSPORT_DATAGRAM_MAX : ch->q.cap) ||
            (dgram && len + CHANNEL_REC_HDR > ch->q.cap)) {
                ch->stats.tx_dropped++;
                return -EMSGSIZE;
        }
        if (!dgram && len == 0)
                return 0;
        /* Nothing queued: write now, which saves a POLLOUT round trip (and its wakeup). */
        if (channel_q_len(&ch->q) == 0)
                n = channel_write(ch, data, len);
        if (n >= 0) {
                ch->stats.bytes_out += (uint64_t)n;
                channel_tap(ch, true, data, (size_t)n);
                if (dgram) {
                        ch->stats.datagrams_out++;
                        return 0;
                }
                data = (const uint8_t *)data + n;
                len -= (size_t)n;
                if (len == 0)
                        return 0;
                /* The rest of a partly written frame always fits: the queue was empty. */
        } else if (n != -EAGAIN) {
                ch->stats.io_errors++;
                ch->stats.tx_dropped++;
                if (transport_error_fatal(ch->tp, (int)n)) {
                        /* Go down from the loop, not under the caller's feet. */
                        ch->write_error = (int)n;
                        channel_update_events(ch);
                }
                return (int)n;
        }
        if (!channel_q_frame(ch, data, len)) {
                ch->stats.tx_dropped++;
                return -ENOBUFS;
        }
        channel_update_events(ch);
        return 0;
}

void channel_fail(struct channel *ch, const char *reason)
{
        if (ch->state != CHANNEL_STATE_UP)
                return;
        channel_set_reason(ch, "%s", reason ? reason : "failed");
        channel_go_down(ch, false);
}

void channel_set_tap(struct channel *ch, channel_tap_fn fn, void *arg)
{
        ch->tap = fn;
        ch->tap_arg = fn ? arg : NULL;
}

bool channel_datagram(const struct channel *ch)
{
        return transport_params_datagram(&ch->params);
}

enum channel_state channel_state(const struct channel *ch)
{
        return ch->state;
}

const char *channel_reason(const struct channel *ch)
{
        return ch->reason;
}

const char *channel_device(const struct channel *ch)
{
        if (ch->tp)
                return transport_name(ch->tp);
        if (ch->params.kind == TRANSPORT_UDP)
                return ch->params.remote[0] ? ch->params.remote : ch->params.local;
        return ch->params.devices[ch->device_index];
}

struct transport *channel_transport(const struct channel *ch)
{
        return ch->tp;
}

unsigned channel_retry_ms(const struct channel *ch)
{
        return ch->retry_ms;
}

size_t channel_queued(const struct channel *ch)
{
        return channel_q_len(&ch->q);
}

void channel_get_stats(const struct channel *ch, struct channel_stats *ret_stats)
{
        *ret_stats = ch->stats;
}
