/*
 * Channel: a transport that keeps itself open, driven by the event loop. What a link engine
 * talks to.
 *
 * - Opens the transport; when it fails or later breaks (hang-up, unplug: EIO, POLLHUP,
 *   POLLERR, read returning 0; a missing device; a failing write), it closes it, reports
 *   `down` with a reason, waits (100 ms, doubling up to 5 s) and reopens, trying the next of
 *   several serial devices each time. A link that stayed up for at least the maximum backoff
 *   starts again at the minimum delay. A transport that does not reopen (transport_reopens():
 *   a replay) reports `down` with retry 0 and the channel is STOPPED.
 * - Reads whatever arrives and hands it to `input`: bytes for a tty or pty, exactly one
 *   datagram per call for UDP.
 * - Sends frames: channel_send() writes at once when nothing is queued (no extra wakeup),
 *   queues the rest (bounded) and asks for POLLOUT only while the queue is not empty. A frame
 *   goes out whole or not at all: a full queue refuses it with -ENOBUFS, counted. The queue is
 *   dropped when the transport goes down: the engines resend state after `up`.
 *
 * Callbacks run only from the event loop (the channel's fd and timer), never from inside a
 * channel_*() call: channel_start() returns the result of the first attempt instead of calling
 * `up`/`down`, and channel_send(), channel_fail() and channel_stop() call nothing. Callbacks
 * may call any channel_*() function on their channel, channel_free() included (the memory is
 * released when the callback returns).
 */
#ifndef SHAREDLINK_DAEMON_CHANNEL_H
#define SHAREDLINK_DAEMON_CHANNEL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "svc/evloop.h"
#include "daemon/transport.h"

#define CHANNEL_BACKOFF_MIN_MS  100     /* first retry delay */
#define CHANNEL_BACKOFF_MAX_MS  5000    /* doubling stops here */
#define CHANNEL_OUTQ_DEFAULT    16384   /* bytes of queued output per channel */
#define CHANNEL_OUTQ_MAX        (1u << 20)
#define CHANNEL_READ_BUDGET     16      /* reads per readiness, so one busy link cannot starve
                                         * the others */
#define CHANNEL_REASON_MAX      (TRANSPORT_ERR_MAX + 32)

enum channel_state {
        CHANNEL_STATE_STOPPED,          /* not started, or stopped */
        CHANNEL_STATE_UP,               /* transport open */
        CHANNEL_STATE_BACKOFF,          /* closed; a reopen is scheduled */
};

struct channel;

/* A copy of every chunk read from (out false) or written to (out true) the transport, as it
 * passes: what `record` taps (recorder.h). It must not call channel_*() functions. */
typedef void (*channel_tap_fn)(void *arg, bool out, const uint8_t *data, size_t len);

/* Each may be NULL. */
struct channel_ops {
        /* The transport is open again (after a down or a failed first attempt). */
        void (*up)(struct channel *ch, void *arg);
        /* The transport broke, or an attempt to open it failed; the next try is in retry_ms. */
        void (*down)(struct channel *ch, const char *reason, unsigned retry_ms, void *arg);
        /* Bytes arrived (stream), or one datagram (udp; len may be 0). */
        void (*input)(struct channel *ch, const uint8_t *data, size_t len, void *arg);
};

/* Zero fields take the defaults above. */
struct channel_options {
        size_t outq_bytes;
        unsigned backoff_min_ms;
        unsigned backoff_max_ms;
};

/* Counters since channel_new(). */
struct channel_stats {
        uint64_t opens;                 /* successful opens */
        uint64_t reopens;               /* successful opens after the first */
        uint64_t open_failures;
        uint64_t downs;                 /* up -> closed transitions */
        uint64_t io_errors;             /* read/write errors, fatal or per-datagram */
        uint64_t bytes_in, bytes_out;
        uint64_t datagrams_in, datagrams_out;
        uint64_t tx_dropped;            /* frames refused: down, queue full, too large, error */
        uint64_t rx_dropped;            /* datagrams dropped: larger than TRANSPORT_DATAGRAM_MAX */
        uint64_t refused;               /* udp: ICMP port unreachable (nobody listening there,
                                         * e.g. the peer not started yet): not an io_error */
};

/* Creates a stopped channel over a copy of params; 0, -EINVAL (bad params or options) or
 * -ENOMEM. ops is copied; arg is passed to every callback. */
int channel_new(struct evloop *loop, const struct transport_params *params,
                const struct channel_options *options, const struct channel_ops *ops, void *arg,
                struct channel **ret_channel);

/* Stops the channel and frees it (deferred when called from one of its callbacks). NULL ok. */
struct channel *channel_free(struct channel *ch);

/* Makes the first attempt now: 0 when up, else its -errno (the reason is in channel_reason()
 * and a retry is scheduled); -EALREADY if not stopped. Calls no callback. */
int channel_start(struct channel *ch);

/* Closes the transport and cancels any retry; the channel is STOPPED. Calls no callback. */
void channel_stop(struct channel *ch);

/* Sends one frame (a datagram for udp). 0 when written or queued; -ENOTCONN (not up),
 * -ENOBUFS (queue full), -EMSGSIZE (larger than the queue or a datagram), or the write error
 * (-EDESTADDRREQ: udp peer unknown yet; a fatal one takes the channel down from the loop). */
int channel_send(struct channel *ch, const void *data, size_t len);

/* An engine-level failure (no login reply, idle timeout): closes, backs off, then tries the
 * next device. Ignored unless up. Calls no callback. */
void channel_fail(struct channel *ch, const char *reason);

/* Sets (fn NULL: clears) the tap that sees every chunk read or written. */
void channel_set_tap(struct channel *ch, channel_tap_fn fn, void *arg);

/* Whether the channel reads and writes whole datagrams (udp, a replay of udp): known from its
 * parameters, before it is started. */
bool channel_datagram(const struct channel *ch);

/* Current state. */
enum channel_state channel_state(const struct channel *ch);

/* Why the channel last went down or failed to open ("" if never). */
const char *channel_reason(const struct channel *ch);

/* The device (or udp endpoint) open now, or the one the next attempt will try. */
const char *channel_device(const struct channel *ch);

/* The transport while up (for transport_pty_slave() and the like), else NULL. */
struct transport *channel_transport(const struct channel *ch);

/* Delay of the scheduled retry in ms (0 unless in backoff). */
unsigned channel_retry_ms(const struct channel *ch);

/* Bytes waiting in the output queue. */
size_t channel_queued(const struct channel *ch);

/* Copies the counters. */
void channel_get_stats(const struct channel *ch, struct channel_stats *ret_stats);

#endif
