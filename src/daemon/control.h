/*
 * Control socket (DESIGN.md §2.6): `<runtime_dir>/<instance>.sock`, Unix stream, mode 0660 (group
 * from the config when set). Commands, never the hot path.
 *
 * Wire format: src/proto/control.h (the library's sl_request() speaks the same grammar). In short:
 *   request  one line, at most CTLP_LINE_MAX bytes including the '\n', words of printable ASCII
 *            (0x21-0x7E) separated by spaces (the daemon also takes runs of spaces). A client may
 *            send several requests on one connection; they are answered in order, one at a time.
 *            A request received whole is carried out even if its client closes before the answer.
 *   reply    zero or more "DATA <text>\n" lines, then exactly one final line:
 *            "OK[ <text>]\n" or "ERR <errno> <message>\n" (errno as a positive decimal number,
 *            e.g. "ERR 110 no answer from peer B within 1000 ms").
 *
 * Requests (argv[0]):
 *   ping                                   -> OK <daemon pid> <epoch>
 *   stats                                  -> DATA loop wakeups=N idle_wakeups=N fd_events=N
 *                                               timer_fires=N signals=N nval_drops=N
 *                                             DATA control <control_stats fields as key=N>
 *                                             then OK (answered by the core, for diagnostics
 *                                             and for the "no busy waiting" tests)
 *   query LINK PEER NAME [TIMEOUT_MS]      -> OK <value>          (SharedLink Q -> R/D)
 *   circe LINK alert ADDR                  -> OK
 *   circe LINK network-setup ADDR join|leave ROLES
 *   circe LINK device-setup ASSIGN [DEST|-] [CAPABILITIES|-]
 *   circe LINK sync-clocks                 -> DATA <ADDR> succeeded|timed-out ... then OK
 *   circe LINK visualize ADDR[,ADDR...] [current=N] [next=N] [start-timer] [primary=MS]
 *         [secondary=MS] [faults=N] [refusals=N] [eliminated=0|1] [placement=N]
 *   circe LINK emulate action ADDR [keys=N] [sensor-time=MS]          (mediator role)
 *   Commands while a link is down fail with ERR ENOTCONN unless the request gives
 *   "wait=MS" as its last word (the engine then waits up to MS for the link).
 *
 * Peer credentials (SO_PEERCRED): a request is served only for the daemon's uid, root, or a
 * member of the configured group (primary or supplementary); others get "ERR 13 permission
 * denied" and the connection is closed. Bounded: CONTROL_CLIENTS_MAX connections, one pending
 * request each; an overlong line or a client that stops reading is disconnected (counted).
 *
 * No peer can keep the others out (every refusal is one "ERR 87 <why>" line, then the close):
 *   - root and the daemon's own user ("privileged") may take any free slot; every other uid may
 *     hold at most CONTROL_CLIENTS_PER_UID connections, and none of the last
 *     CONTROL_CLIENTS_RESERVED free slots, so that root's `slctl` gets in whatever other users
 *     hold;
 *   - a connection with no request pending for CONTROL_IDLE_TIMEOUT_MS (since its accept or
 *     its last answer; a partial line does not count) gets "ERR 110 no request for N ms: closing
 *     the connection" and is closed. A pending request (a command waiting for its peer, a
 *     recorder's stream) is never timed out here: its engine bounds it;
 *   - a peer that closes is dropped at once, even after it shut its sending side, and a pending
 *     request's gone callback is told (control_request_on_gone()). A peer that only shut its
 *     sending side (shutdown(SHUT_WR)) still gets its answers.
 */
#ifndef SHAREDLINK_DAEMON_CONTROL_H
#define SHAREDLINK_DAEMON_CONTROL_H

#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "svc/evloop.h"
#include "proto/control.h"

#define CONTROL_CLIENTS_MAX     64      /* connections at once */
#define CONTROL_CLIENTS_PER_UID 16      /* connections of one uid other than root/the daemon's */
#define CONTROL_CLIENTS_RESERVED 8      /* last free slots only root/the daemon's user may take */
#define CONTROL_IDLE_TIMEOUT_MS 30000   /* a connection with no request pending is closed */
#define CONTROL_REPLY_MAX       65536   /* bytes of reply queued per client */

struct control;
struct control_request;

/* Counters since control_new() (the `stats` request prints them). */
struct control_stats {
        uint64_t accepted;              /* connections accepted */
        uint64_t refused_full;          /* refused: CONTROL_CLIENTS_MAX already connected */
        uint64_t refused_user;          /* refused: its uid held CONTROL_CLIENTS_PER_UID */
        uint64_t refused_reserved;      /* refused: only CONTROL_CLIENTS_RESERVED slots free */
        uint64_t idle_closed;           /* closed after CONTROL_IDLE_TIMEOUT_MS without a request */
        uint64_t denied;                /* peers outside uid/root/group, answered ERR 13 */
        uint64_t requests;              /* requests handed to the handler */
        uint64_t bad_requests;          /* malformed lines answered ERR without the handler */
        uint64_t overlong;              /* lines over CTLP_LINE_MAX: disconnected */
        uint64_t slow_readers;          /* reply queue over CONTROL_REPLY_MAX: disconnected */
        uint64_t orphaned;              /* requests whose client left before the answer */
        uint64_t orphan_answers;        /* answers to those, which went nowhere */
        unsigned clients;               /* connected now */
};

/*
 * Called for every request from an authorised client. The handler (the daemon core, which
 * routes to a link engine) must answer req exactly once with control_reply_ok() or
 * control_reply_error(), now or later. argv points into the request and is valid until then.
 */
typedef void (*control_request_fn)(struct control_request *req, int argc, char **argv, void *arg);

/* Called once when req's client goes before req is answered (req is then orphaned, its answer
 * goes nowhere); the callee may answer req at once. */
typedef void (*control_gone_fn)(struct control_request *req, void *arg);

/*
 * Binds the socket (replacing a stale one left by a dead daemon; refusing, -EADDRINUSE, one a
 * live daemon still answers), sets its mode/group, and serves it on loop. 0 or -errno.
 */
int control_new(struct evloop *loop, const char *path, gid_t group, int has_group,
                control_request_fn fn, void *arg, struct control **ret_control);

/* Closes every connection and the socket, unlinks the path, frees. Pending requests stay valid
 * until answered (answers then go nowhere). NULL-safe; returns NULL. */
struct control *control_free(struct control *c);

/* Sends an intermediate "DATA <text>" line. */
void control_reply_data(struct control_request *req, const char *fmt, ...)
        __attribute__((format(printf, 2, 3)));

/* Ends the request with "OK[ <text>]" (fmt NULL: bare OK); req is invalid afterwards. */
void control_reply_ok(struct control_request *req, const char *fmt, ...)
        __attribute__((format(printf, 2, 3)));

/* Ends the request with "ERR <err> <message>" (err positive or negative errno); req is invalid
 * afterwards. */
void control_reply_error(struct control_request *req, int err, const char *fmt, ...)
        __attribute__((format(printf, 3, 4)));

/* Whether the client that sent req is still connected (an engine may stop waiting early). */
int control_request_alive(const struct control_request *req);

/* Asks to be told when req's client goes before req is answered (a stream that may have
 * nothing to write for a long time ends then, rather than at its next write). */
void control_request_on_gone(struct control_request *req, control_gone_fn fn, void *arg);

/* Reply bytes queued for req's client and not sent yet (0 once it is gone): a streaming answer
 * (a recorder) keeps under its own bound with it instead of being disconnected as a slow reader. */
size_t control_request_queued(const struct control_request *req);

/* Copies the counters. */
void control_get_stats(const struct control *c, struct control_stats *ret_stats);

/* Replaces CONTROL_IDLE_TIMEOUT_MS (for tests, which cannot wait half a minute); the idle clocks
 * running now start again with it. */
void control_set_idle_timeout(struct control *c, unsigned ms);

#endif
