/*
 * How a SharedLink link session acts (link_sharedlink_session.h): the hooks its engine gives it
 * and the limits both sides know. A header of its own, so that the session's parts
 * (link_sharedlink_peers.c, link_sharedlink_pronto4.c) see the hooks without seeing the session's
 * interface, and nothing includes in a circle.
 */
#ifndef SHAREDLINK_DAEMON_LINK_SHAREDLINK_HOOKS_H
#define SHAREDLINK_DAEMON_LINK_SHAREDLINK_HOOKS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "svc/log.h"
#include "shm/layout.h"

#define LINK_SHAREDLINK_QUERIES_MAX     16      /* pending control queries per link */
#define LINK_SHAREDLINK_PINGS_MAX       8       /* pending control pings per link */
#define LINK_SHAREDLINK_ADHOC_MAX       1024    /* ad hoc variables one link creates */
#define LINK_SHAREDLINK_RETRY_MS        10      /* a refused on-change frame: retry */
#define LINK_SHAREDLINK_NEVER           UINT64_MAX
/* Longest one-line diagnostic the session hands to the diag hook. */
#define LINK_SHAREDLINK_DIAG_MAX        256u
/* Refused input after a reason's first warning is summed up in one line this often at most. */
#define LINK_SHAREDLINK_REFUSAL_SUMMARY_MS      60000u
/* Longest text the peer_state hook gets. */
#define LINK_SHAREDLINK_PEER_STATE_MAX  96u
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
        /* Retires a variable add() made (its name is gone for clients; the table may give its
         * entry to a later name); 0 or -errno. NULL: learned names stay for the table's life. */
        int (*retire)(void *arg, uint32_t id);
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
        /* A pong, G<value>, from the peer at address `peer` (NULL: a pong only shows the peer
         * alive). For link_sharedlink_session_ping(). */
        void (*pong)(void *arg, char peer, const char *value, size_t len);
        /* A one-line diagnostic worth a rate-limited log line. */
        void (*diag)(void *arg, enum log_prio prio, const char *text);
        /* Where the peer reaches us, "<ip>:<port>" (NUL-terminated in buf[size]), and the remote
         * port we send to: the text's length, or -errno when the link has no such address (not
         * UDP). For a pronto4 host's "SetIP" command. NULL: no address. */
        int (*local_address)(void *arg, char *buf, size_t size, unsigned *ret_remote_port);
        /* What the link's pronto4 peers have asked of it, for the link's state text ("peer A:
         * outbound off"; "" when nothing differs from normal). NULL: not shown. */
        void (*peer_state)(void *arg, const char *text);
};

#endif
