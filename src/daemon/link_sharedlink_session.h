/*
 * SharedLink link session: the protocol logic of one SharedLink link (link_sharedlink.h says
 * what it promises), with no file descriptor, timer or shm table of its own. It is fed received
 * bytes, client writes, queries and the time, and acts through the hooks below: send a frame,
 * find or add a variable, read or publish a value, mark one stale, raise an event, count. So the
 * fuzzer (tests/fuzz/fuzz_sharedlink_session.c) and the unit tests
 * (tests/unit/test_link_sharedlink_session.c) drive it with any input and any clock.
 *
 * The engine (link_sharedlink.c) wires the hooks to the channel, the table and the control
 * socket, and calls tick() once the time deadline() asks for has come.
 *
 * The session owns: the peers' outbound and inbound lists and their positional mapping, every
 * per-peer schedule as a deadline (period, full refresh under compression, the on-change rate
 * limit and its retry, stale after silence), the pending queries with their timeouts, inbound
 * apply (N, D, R, Q, P, G), ad hoc variables, reply packing and every counter, by reason; and,
 * for a peer with dialect pronto4 (docs/pronto4.md, in link_sharedlink_pronto4.c): declarations
 * (sent, or learned into variables), acknowledgements, list queries, self-describing frames, E
 * and MU commands as events, type checks, whole-list data and the host's connect sequence.
 *
 * Time is CLOCK_MONOTONIC in milliseconds; LINK_SHAREDLINK_NEVER means "no deadline".
 */
#ifndef SHAREDLINK_DAEMON_LINK_SHAREDLINK_SESSION_H
#define SHAREDLINK_DAEMON_LINK_SHAREDLINK_SESSION_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/config.h"
#include "svc/log.h"
#include "shm/layout.h"

#define LINK_SHAREDLINK_QUERIES_MAX     16      /* pending control queries per link */
#define LINK_SHAREDLINK_ADHOC_MAX       1024    /* ad hoc variables one link creates */
#define LINK_SHAREDLINK_RETRY_MS        10      /* a refused on-change frame: retry */
#define LINK_SHAREDLINK_NEVER           UINT64_MAX
/* Longest one-line diagnostic the session hands to the diag hook. */
#define LINK_SHAREDLINK_DIAG_MAX        160u
/* Longest reason text the answer hook gets with an error. */
#define LINK_SHAREDLINK_WHY_MAX         96u

struct link_sharedlink_session;

/*
 * How a session acts. Every hook gets the arg given to new(); each may be NULL except send,
 * find and publish. Hooks are called synchronously from the session's own functions and must
 * not call back into the session.
 */
struct link_sharedlink_hooks {
        /* Send one encoded frame; 0 or -errno (-ENOBUFS, -EAGAIN: the queue is full, the
         * session retries). The session counts frames_out itself. */
        int (*send)(void *arg, const char *buf, size_t len);
        /* The id of the variable called name, or -ENOENT. */
        int (*find)(void *arg, const char *name);
        /* Creates a variable of shm type `type` for peer address `peer`: inbound (an ad hoc name,
         * a learned inbound position) or outbound (a learned outbound position, which clients may
         * then write), at list position `position` or SHM_POSITION_NONE; its id or -errno
         * (-ENOSPC: no room). NULL: ad hoc names are full, nothing is learned. */
        int (*add)(void *arg, const char *name, unsigned type, char peer, bool outbound,
                   int32_t position);
        /* The value of variable id as published (NUL-terminated in buf[size]): its length, or
         * -errno when it holds no valid value. NULL: every Q is answered empty. */
        int (*get)(void *arg, uint32_t id, char *buf, size_t size);
        /* Publishes value[0..len) to variable id (valid, fresh); 0 or -errno. */
        int (*publish)(void *arg, uint32_t id, const char *value, size_t len);
        /* Marks variable id stale. */
        void (*stale)(void *arg, uint32_t id);
        /* Brackets publish/stale calls that clients must see at once (begin true, then false). */
        void (*batch)(void *arg, bool begin);
        /* An event for the table's ring ("key=value ..." text). */
        void (*event)(void *arg, enum shm_event_type type, const char *text);
        /* Adds n to a link counter. */
        void (*count)(void *arg, enum shm_counter counter, uint64_t n);
        /* A query given to link_sharedlink_session_query() ended: err 0 and the value, or a
         * positive errno and a reason. Called exactly once per query accepted. */
        void (*answer)(void *arg, void *token, int err, const char *text);
        /* Whether the client behind a query's token is still there (NULL: always). */
        bool (*alive)(void *arg, void *token);
        /* A one-line diagnostic worth a rate-limited log line. */
        void (*diag)(void *arg, enum log_prio prio, const char *text);
        /* Where the peer reaches us, "<ip>:<port>" (NUL-terminated in buf[size]), and the remote
         * port we send to: the text's length, or -errno when the link has no such address (not
         * UDP). For a pronto4 host's "SetIP" command. NULL: no address. */
        int (*local_address)(void *arg, char *buf, size_t size, unsigned *ret_remote_port);
};

/*
 * Creates the session of a SharedLink link (cfg must outlive it), resolving each configured
 * list entry through find(). It starts down: call up() when the channel is open. 0, -EINVAL (not
 * a SharedLink link), -ENOENT (a configured variable is unknown to find()) or -ENOMEM.
 */
int link_sharedlink_session_new(const struct config_link *cfg, bool datagram,
                                const struct link_sharedlink_hooks *hooks, void *arg,
                                struct link_sharedlink_session **ret_session);

/* Ends every pending query with ECANCELED through answer(), frees. NULL ok; returns NULL. */
struct link_sharedlink_session *link_sharedlink_session_free(struct link_sharedlink_session *s);

/* The channel is open: every peer gets its full list, periods start. */
void link_sharedlink_session_up(struct link_sharedlink_session *s, uint64_t now_ms);

/* The channel closed: schedules stop, sent queries end with ENOTCONN. (The engine marks the
 * link's variables stale: that is one table call for all of them.) */
void link_sharedlink_session_down(struct link_sharedlink_session *s, uint64_t now_ms);

/* Bytes from the channel (a whole datagram when the session was made with datagram true);
 * ignored while down. */
void link_sharedlink_session_input(struct link_sharedlink_session *s, uint64_t now_ms,
                                   const uint8_t *data, size_t len);

/* A client wrote value to outbound variable id (ignored when it is not in one of the lists). */
void link_sharedlink_session_outbound(struct link_sharedlink_session *s, uint64_t now_ms,
                                      uint32_t id, const char *value);

/* The index of the configured peer at address (one letter), or -1. */
int link_sharedlink_session_peer(const struct link_sharedlink_session *s, const char *address);

/*
 * Sends Q<name> to peer (an index from link_sharedlink_session_peer()) and follows the answer
 * for timeout_ms; answer(token) is called once later. Returns 0, or -ENOTCONN (down), -EBUSY
 * (LINK_SHAREDLINK_QUERIES_MAX pending; queries whose client left are ended first to make room),
 * -EINVAL (bad peer or name), -EMSGSIZE (the Q frame is longer than the peer's max_frame) or
 * the send error, with nothing pending.
 */
int link_sharedlink_session_query(struct link_sharedlink_session *s, uint64_t now_ms,
                                  void *token, int peer, const char *name, unsigned timeout_ms);

/*
 * Sends the command E<module>|D<text> to peer (an index from link_sharedlink_session_peer()),
 * or to every pronto4 peer when peer is -1. Returns 0, -EOPNOTSUPP (no such pronto4 peer),
 * -EINVAL (a bad peer index, module or text: slp_encode_command()), -ENOTCONN (down) or the
 * send error.
 */
int link_sharedlink_session_command(struct link_sharedlink_session *s, uint64_t now_ms, int peer,
                                    const char *module, const char *text);

/* Handles every deadline that has passed. */
void link_sharedlink_session_tick(struct link_sharedlink_session *s, uint64_t now_ms);

/* The earliest pending deadline, or LINK_SHAREDLINK_NEVER. */
uint64_t link_sharedlink_session_deadline(const struct link_sharedlink_session *s);

/* Whether up() was called last (rather than down()). */
bool link_sharedlink_session_is_up(const struct link_sharedlink_session *s);

#endif
