/*
 * The state of a SharedLink link session and the acts its parts share (a private header):
 * link_sharedlink_session.c (lists, schedules, queries, the bulletin's field walk) and
 * link_sharedlink_pronto4.c (what a pronto4 peer adds, docs/pronto4.md) both work on the
 * structures below through the helpers of link_sharedlink_peers.c: the hooks with their
 * counters, the variables a link makes (ad hoc, learned) and retires, and the frames of an
 * outbound list. The session calls the dialect; neither the dialect nor these helpers call the
 * session back, so the three files depend on each other in one direction only:
 *     session -> pronto4 -> peers,    session -> peers.
 * Nothing outside these three files includes it.
 */
#ifndef SHAREDLINK_DAEMON_LINK_SHAREDLINK_PEERS_H
#define SHAREDLINK_DAEMON_LINK_SHAREDLINK_PEERS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/config.h"
#include "daemon/link_sharedlink_hooks.h"
#include "proto/pronto4.h"
#include "proto/sharedlink.h"

/* A list position nothing of ours fills (a declared name we do not have, a conflict). */
#define SLS_UNMAPPED            UINT32_MAX
/* A declared name as it goes on the wire (slp_name_check(): at most SLP_VALUE_MAX bytes). */
#define SLS_NAME_SIZE           (SLP_VALUE_MAX + 1)
/* Positions of any list: configured lists and learn_max are both bounded by it. */
#define SLS_LIST_MAX            CONFIG_LIST_MAX
#define SLS_REPLY_FIELDS_MAX    (SLP_FRAME_MAX / 2)

/* One list of a peer, position 0 first: what we send it (out) or what it sends us (in). */
struct sls_list {
        size_t n, cap;                          /* positions now, most ever (cap >= n) */
        uint32_t *ids;                          /* variable of each position, or SLS_UNMAPPED */
        enum slp_type *types;                   /* pronto4: the type each position carries */
        char (*names)[SLS_NAME_SIZE];           /* pronto4: the name each position declares */
        const char **name_ptrs;                 /* names[k], for struct slp_named_list */
        bool learn;                             /* learned from the peer's declarations */
        bool declared;                          /* the peer declared it at least once */
        size_t n_cfg;                           /* the configured list: its ids, in cfg order */
        uint32_t *cfg_ids;
};

/* One peer of the link. */
struct sls_peer {
        const struct config_peer *cfg;
        unsigned index;
        bool p4;                                /* dialect: pronto4 */

        struct sls_list out, in;
        char (*out_values)[SHM_VALUE_SIZE];     /* last value a client wrote, "" before */
        const char **out_ptrs;                  /* out_values[k], for struct slp_list */
        bool *out_dirty;                        /* written (or never sent) since last sent */

        unsigned refresh_every;                 /* periods between full lists (>= 1) */
        unsigned since_full;                    /* periods since the last full list */
        bool change_sent;                       /* an on-change frame went out already */
        uint64_t last_change_ms;
        bool went_stale;                        /* pronto4 host: silent for stale_ms */
        bool out_off, in_off;                   /* pronto4 vehicle: the host's ELink said off */

        uint64_t period_at;                     /* next periodic list */
        uint64_t change_at;                     /* on-change frame held by the rate limit */
        uint64_t stale_at;                      /* silence long enough to mark stale */
        uint64_t connect_at;                    /* pronto4 host: the connect sequence again */
};

/* Where an outbound variable id lives, for outbound(); sorted by id. */
struct sls_outref {
        uint32_t id;
        uint16_t peer;
        uint16_t pos;
};

/* What a variable this link created at run time is. */
enum sls_made {
        SLS_MADE_ADHOC,                         /* a name it answered (R|D) or described */
        SLS_MADE_LEARNED_IN,                    /* a position of a learned inbound list */
        SLS_MADE_LEARNED_OUT,                   /* a position of a learned outbound list */
};

/* A variable this link created, "<link>.<peer>.<name>". */
struct sls_adhoc {
        uint32_t id;
        unsigned peer;
        enum sls_made made;
};

/* A query sent, waiting for its answer. */
struct sls_query {
        void *token;                            /* NULL: free slot */
        unsigned peer;
        char name[SHM_NAME_SIZE];
        unsigned timeout_ms;
        uint64_t deadline;
};

/* Answers and pongs to one received frame, packed into frames of the peer's max_frame. */
struct sls_reply {
        struct sls_peer *peer;
        struct slp_field fields[SLS_REPLY_FIELDS_MAX];
        size_t nfields;
        char text[SLP_FRAME_MAX];               /* copies of the field values */
        size_t text_used;
        size_t frame_len;                       /* encoded length of fields[0..nfields) */
};

/* What a declaration is rebuilt into before it replaces a list whole. */
struct sls_scratch {
        uint32_t ids[SLS_LIST_MAX];
        enum slp_type types[SLS_LIST_MAX];
        char names[SLS_LIST_MAX][SLS_NAME_SIZE];
        bool named[SLS_LIST_MAX];               /* a good [T] Q entry: its variable to find */
        char values[SLS_LIST_MAX][SHM_VALUE_SIZE];
        const char *ptrs[SLS_LIST_MAX];
};

/*
 * Refusals (docs/pronto4.md §11): each reason's first occurrence on a link is a warning that says
 * what to check; later ones are counted and summed up in one line at most every
 * LINK_SHAREDLINK_REFUSAL_SUMMARY_MS, so a peer that sends nothing but refused frames never
 * floods the log.
 */
struct sls_refusals {
        bool warned[SHM_COUNTER_COUNT];         /* its first occurrence was logged */
        uint64_t pending[SHM_COUNTER_COUNT];    /* since the last warning or summary */
        uint64_t summary_at;                    /* LINK_SHAREDLINK_NEVER: nothing pending */
};

struct link_sharedlink_session {
        const struct link_sharedlink_hooks *h;
        void *arg;
        const struct config_link *cfg;
        char addr;
        bool crlf;                              /* end frames with CR LF */
        bool datagram;
        bool up;
        uint64_t now;                           /* the time of the call being handled */

        struct sls_peer peers[CONFIG_PEERS_MAX];
        unsigned n_peers;
        int peer_of_addr[SLP_ADDR_COUNT];       /* peer index, -1 when not a peer */

        struct sls_outref *outrefs;
        size_t n_outrefs, cap_outrefs;

        struct sls_adhoc *adhoc;
        size_t n_adhoc, cap_adhoc;

        struct sls_query queries[LINK_SHAREDLINK_QUERIES_MAX];

        struct sls_refusals refusals;
        unsigned remade;                        /* ad hoc names a declaration made anew */
        struct sls_reply reply;
        struct sls_scratch scratch;
        char txbuf[SLP_FRAME_MAX];
        struct slp_decoder dec;                 /* about 40 KiB: the session lives on the heap */
        struct p4_message p4;                   /* the frame of a pronto4 peer, taken apart */
};

/* ---- the helpers (link_sharedlink_peers.c) ------------------------------------------------ */

void sls_count(struct link_sharedlink_session *s, enum shm_counter c, uint64_t n);
void sls_eventf(struct link_sharedlink_session *s, enum shm_event_type type, const char *fmt, ...)
        __attribute__((format(printf, 3, 4)));
void sls_diagf(struct link_sharedlink_session *s, enum log_prio prio, const char *fmt, ...)
        __attribute__((format(printf, 3, 4)));
/*
 * Counts n refusals of reason c (a counter); the first on this link is logged at warning with the
 * text of fmt, which says what to check; the rest wait for the next summary
 * (sls_refusals_summary()). The text is formatted only when it is logged.
 */
void sls_refuse(struct link_sharedlink_session *s, enum shm_counter c, uint64_t n,
                const char *fmt, ...) __attribute__((format(printf, 4, 5)));
/* Logs the refusals counted since the last warning or summary, one line with the count of each
 * reason, and clears them (the session's tick, at refusals.summary_at). */
void sls_refusals_summary(struct link_sharedlink_session *s);
/* Sends one encoded frame, counting frames_out; 0 or the send hook's error. */
int sls_send_frame(struct link_sharedlink_session *s, const char *buf, size_t len);
unsigned sls_encode_flags(const struct link_sharedlink_session *s);
/* Publishes a received value, counting bad_value when the table refuses it. */
void sls_publish(struct link_sharedlink_session *s, uint32_t id, const char *value, size_t len);
/*
 * The variable "<link>.<peer>.<name>" this link made for p as `made` (found or created with shm
 * type `type`, list position `pos` or SHM_POSITION_NONE): its id, or -1 with the reason counted
 * (full: full_counter; a name taken by anything else: conflict_counter).
 */
int sls_made_id(struct link_sharedlink_session *s, struct sls_peer *p, const char *name,
                size_t len, enum sls_made made, unsigned type, int32_t pos,
                enum shm_counter full_counter, enum shm_counter conflict_counter);
/* Retires variable id if this link learned it for p (a list position, not an ad hoc name):
 * its name is gone and its table entry free for the next one. */
void sls_retire_learned(struct link_sharedlink_session *s, const struct sls_peer *p, uint32_t id);
/* Rebuilds the id -> (peer, position) map of every outbound list. */
void sls_outrefs_build(struct link_sharedlink_session *s);
/* Orders struct sls_outref by id (qsort, bsearch). */
int sls_outref_cmp(const void *a, const void *b);
/*
 * Sends positions [first, end) of a peer's outbound list (full: every value; else written ones,
 * the others empty when compressing), split into frames; to a pronto4 peer the whole list in one
 * N0 frame instead (docs/pronto4.md §7). Positions of frames that went out are no longer dirty.
 * Returns 0, or the first error (positions not sent stay dirty).
 */
int sls_send_range(struct link_sharedlink_session *s, struct sls_peer *p, size_t first,
                   size_t end, bool full);
/* Tells the engine what the pronto4 peers asked of the link (the peer_state hook). */
void sls_peer_state_update(struct link_sharedlink_session *s);
/* Sends the whole outbound list of p now (full: no compression); 0 or -errno. */
int sls_send_full(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now);

#endif
