/*
 * Recorders: `record LINK` on the control socket streams what a link receives and sends, one
 * line of the recording format (proto/recording.h, docs/recording.md) per DATA reply line, until
 * the client leaves, the link stops or the daemon does. `slctl record` writes the lines to a file.
 *
 * A link's tap (one per configured link, owned by the core) is called by the link's channel for
 * every chunk read from or written to its transport (channel_set_tap). It formats each chunk once
 * and queues it to every recorder of the link. A recorder never slows the link down: when its
 * client's reply queue already holds RECORDER_QUEUE_MAX bytes the chunk is dropped for it and
 * counted; a "# dropped N chunks" comment goes out as soon as there is room again (at the next
 * chunk or the next heartbeat). RECORDER_QUEUE_MAX is half of CONTROL_REPLY_MAX, so that a slow
 * recorder is never taken for a client that stopped reading (that one is disconnected).
 *
 * The request is served to the same peers as any other (the control socket's SO_PEERCRED rule:
 * the daemon's uid, root or the configured group), which is the rule for commands and writes.
 */
#ifndef SHAREDLINK_DAEMON_RECORDER_H
#define SHAREDLINK_DAEMON_RECORDER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/control.h"

#define RECORDER_PER_LINK_MAX   8u      /* recorders on one link at once */
#define RECORDER_QUEUE_MAX      (CONTROL_REPLY_MAX / 2)     /* reply bytes queued per recorder */

struct recorder_tap;

/* What the header comments of a recording say about the link (copied). */
struct recorder_link_info {
        const char *link;
        const char *protocol;
        const char *transport;
        const char *instance;
};

/* Counters of all taps, for the `stats` request. */
struct recorder_stats {
        uint64_t started;               /* record requests served */
        uint64_t chunks;                /* chunk lines queued, all recorders */
        uint64_t dropped;               /* chunks dropped for slow recorders */
        unsigned active;                /* recorders now */
};

/* A tap for one link, with no recorder yet; stats (may be NULL) is shared by every tap. NULL on
 * out of memory. */
struct recorder_tap *recorder_tap_new(const struct recorder_link_info *info,
                                      struct recorder_stats *stats);

/* The link's channel takes whole datagrams (udp, a replay of a udp recording): recordings then
 * say "# transport: udp", so that they replay as datagrams too, whatever the link's own transport
 * (a replay of a udp recording, recorded again). */
void recorder_tap_set_datagram(struct recorder_tap *tap, bool datagram);

/* Ends every recorder of the tap ("OK <N> chunks, <why>") and frees it; returns NULL. NULL ok. */
struct recorder_tap *recorder_tap_free(struct recorder_tap *tap, const char *why);

/* Starts a recorder answering req: the header lines now, chunk lines from now on. 0, or -EBUSY
 * (RECORDER_PER_LINK_MAX) / -ENOMEM, and req is then still the caller's to answer. */
int recorder_add(struct recorder_tap *tap, struct control_request *req);

/* The channel tap (channel_tap_fn): a chunk the link read (out false) or wrote (out true). */
void recorder_chunk(void *tap, bool out, const uint8_t *data, size_t len);

/* Ends recorders whose client left and writes the pending "# dropped" comments that now fit
 * (the core calls it at every heartbeat). A recorder whose client closes ends at once anyway
 * (control_request_on_gone); this catches one whose client broke without closing yet. */
void recorder_sweep(struct recorder_tap *tap);

/* Whether the tap has a recorder (the channel skips formatting when none). */
bool recorder_active(const struct recorder_tap *tap);

#endif
