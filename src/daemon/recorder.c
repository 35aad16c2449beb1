/*
 * Recorders of a link's traffic (see recorder.h; the format is proto/recording.h's).
 */
#include "daemon/recorder.h"

#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "svc/evloop.h"
#include "svc/log.h"
#include "proto/recording.h"

#define RECORDER_NS_PER_US      1000ull
#define RECORDER_INFO_MAX       64      /* a name in the header comments */
#define RECORDER_TIME_MAX       48      /* "2026-12-02T08:00:00.123456Z" */
#define RECORDER_DATA_OVERHEAD  6       /* "DATA " and '\n' around each line */
/* What one line may add to its piece's escaped bytes: time, direction, spaces. */
#define RECORDER_LINE_HEAD      (REC_LINE_MAX - REC_PIECE_MAX * REC_ESCAPE_MAX)
#define RECORDER_COMMENT_MAX    64      /* "# dropped N chunks" */

_Static_assert(RECORDER_QUEUE_MAX + 2 * (CTLP_REPLY_LINE_MAX + 1) <= CONTROL_REPLY_MAX,
               "room for the final line and a comment past a full recorder queue");
_Static_assert(REC_LINE_MAX + RECORDER_DATA_OVERHEAD <= CTLP_REPLY_LINE_MAX + 1,
               "a recording line fits one DATA line");

struct recorder {
        struct control_request *req;
        uint64_t start_ns;
        uint64_t chunks, bytes;
        uint64_t dropped;               /* in all */
        uint64_t dropped_unsaid;        /* not yet told by a "# dropped" comment */
};

struct recorder_tap {
        char link[RECORDER_INFO_MAX], protocol[RECORDER_INFO_MAX];
        char transport[RECORDER_INFO_MAX], instance[RECORDER_INFO_MAX];
        bool datagram;                  /* recorder_tap_set_datagram() */
        struct recorder_stats *stats;
        struct recorder_stats own;      /* when the caller gives none */
        struct recorder rec[RECORDER_PER_LINK_MAX];
        unsigned n;
        char line[REC_LINE_MAX + 1];
};

struct recorder_tap *recorder_tap_new(const struct recorder_link_info *info,
                                      struct recorder_stats *stats)
{
        struct recorder_tap *tap = calloc(1, sizeof(*tap));

        if (!tap)
                return NULL;
        snprintf(tap->link, sizeof(tap->link), "%s", info->link ? info->link : "");
        snprintf(tap->protocol, sizeof(tap->protocol), "%s", info->protocol ? info->protocol : "");
        snprintf(tap->transport, sizeof(tap->transport), "%s",
                 info->transport ? info->transport : "");
        snprintf(tap->instance, sizeof(tap->instance), "%s", info->instance ? info->instance : "");
        tap->stats = stats ? stats : &tap->own;
        return tap;
}

void recorder_tap_set_datagram(struct recorder_tap *tap, bool datagram)
{
        tap->datagram = datagram;
}

/* Answers recorder i and takes it out of the tap. */
static void recorder_end(struct recorder_tap *tap, unsigned i, const char *why)
{
        struct recorder *r = &tap->rec[i];

        control_reply_ok(r->req, "%" PRIu64 " chunks %" PRIu64 " bytes %" PRIu64 " dropped; %s",
                         r->chunks, r->bytes, r->dropped, why);
        log_info("link %s: recorder stopped (%s): %" PRIu64 " chunks, %" PRIu64 " dropped",
                 tap->link, why, r->chunks, r->dropped);
        tap->stats->active--;
        tap->rec[i] = tap->rec[--tap->n];
}

struct recorder_tap *recorder_tap_free(struct recorder_tap *tap, const char *why)
{
        if (!tap)
                return NULL;
        while (tap->n > 0)
                recorder_end(tap, tap->n - 1, why);
        free(tap);
        return NULL;
}

/* The client of a recorder left (control_request_on_gone): the recorder ends now, not at the
 * link's next chunk, which on a silent link may never come, so its slot of
 * RECORDER_PER_LINK_MAX is free again at once. */
static void recorder_on_gone(struct control_request *req, void *arg)
{
        struct recorder_tap *tap = arg;

        for (unsigned i = 0; i < tap->n; i++) {
                if (tap->rec[i].req == req) {
                        recorder_end(tap, i, "client gone");
                        return;
                }
        }
}

/* The wall-clock time now, UTC, ISO 8601 with microseconds. */
static void recorder_utc_now(char *buf, size_t size)
{
        struct timespec ts;
        struct tm tm;
        size_t n;

        clock_gettime(CLOCK_REALTIME, &ts);
        gmtime_r(&ts.tv_sec, &tm);
        n = strftime(buf, size, "%Y-%m-%dT%H:%M:%S", &tm);
        snprintf(buf + n, size - n, ".%06ldZ", ts.tv_nsec / 1000L);
}

int recorder_add(struct recorder_tap *tap, struct control_request *req)
{
        char start[RECORDER_TIME_MAX];
        struct recorder *r;

        if (tap->n >= RECORDER_PER_LINK_MAX)
                return -EBUSY;
        r = &tap->rec[tap->n++];
        memset(r, 0, sizeof(*r));
        r->req = req;
        r->start_ns = evloop_clock_ns();
        control_request_on_gone(req, recorder_on_gone, tap);
        recorder_utc_now(start, sizeof(start));
        control_reply_data(req, "%s", REC_HEADER);
        control_reply_data(req, "# link: %s", tap->link);
        control_reply_data(req, "# protocol: %s", tap->protocol);
        control_reply_data(req, REC_TRANSPORT_PREFIX "%s",
                           tap->datagram ? REC_TRANSPORT_DATAGRAM : tap->transport);
        control_reply_data(req, "# instance: %s", tap->instance);
        control_reply_data(req, "# start: %s", start);
        control_reply_data(req, "# time: CLOCK_MONOTONIC seconds since the start; < received, "
                           "> sent");
        tap->stats->started++;
        tap->stats->active++;
        log_info("link %s: recorder started", tap->link);
        return 0;
}

bool recorder_active(const struct recorder_tap *tap)
{
        return tap && tap->n > 0;
}

/* Says how many chunks were dropped, when there is room for that and `more` bytes after it. */
static bool recorder_tell_dropped(struct recorder *r, size_t more)
{
        char text[RECORDER_COMMENT_MAX];
        int n;

        if (!r->dropped_unsaid)
                return true;
        n = snprintf(text, sizeof(text), REC_DROPPED_PREFIX "%" PRIu64 " chunks",
                     r->dropped_unsaid);
        if (control_request_queued(r->req) + (size_t)n + RECORDER_DATA_OVERHEAD + more >
            RECORDER_QUEUE_MAX)
                return false;
        control_reply_data(r->req, "%s", text);
        r->dropped_unsaid = 0;
        return true;
}

/* Queues the chunk's lines to r, or drops the chunk for r when they might not fit. */
static void recorder_put(struct recorder_tap *tap, struct recorder *r, bool out,
                         const uint8_t *data, size_t len)
{
        size_t pieces = (len + REC_PIECE_MAX - 1) / REC_PIECE_MAX;
        size_t most = len * REC_ESCAPE_MAX + pieces * (RECORDER_LINE_HEAD + RECORDER_DATA_OVERHEAD);
        uint64_t t_us = (evloop_clock_ns() - r->start_ns) / RECORDER_NS_PER_US;
        size_t off = 0;

        if (!recorder_tell_dropped(r, most) ||
            control_request_queued(r->req) + most > RECORDER_QUEUE_MAX) {
                r->dropped++;
                r->dropped_unsaid++;
                tap->stats->dropped++;
                return;
        }
        while (off < len) {
                size_t used;

                rec_format_chunk(tap->line, t_us, out ? REC_DIR_OUT : REC_DIR_IN,
                                 len - off > REC_PIECE_MAX, data + off, len - off, &used);
                control_reply_data(r->req, "%s", tap->line);
                off += used;
        }
        r->chunks++;
        r->bytes += len;
        tap->stats->chunks++;
}

void recorder_chunk(void *arg, bool out, const uint8_t *data, size_t len)
{
        struct recorder_tap *tap = arg;

        /* Empty datagrams carry nothing a replay could give back: not recorded. */
        if (!tap || len == 0)
                return;
        for (unsigned i = tap->n; i-- > 0;) {
                if (!control_request_alive(tap->rec[i].req)) {
                        recorder_end(tap, i, "client gone");
                        continue;
                }
                /* A stream write may be longer than a recorded chunk can be: a byte stream is
                 * the same cut anywhere, so it becomes several chunks. */
                for (size_t off = 0; off < len; off += REC_CHUNK_MAX)
                        recorder_put(tap, &tap->rec[i], out, data + off,
                                     len - off < REC_CHUNK_MAX ? len - off : REC_CHUNK_MAX);
        }
}

void recorder_sweep(struct recorder_tap *tap)
{
        if (!tap)
                return;
        for (unsigned i = tap->n; i-- > 0;) {
                if (!control_request_alive(tap->rec[i].req))
                        recorder_end(tap, i, "client gone");
                else
                        recorder_tell_dropped(&tap->rec[i], 0);
        }
}
