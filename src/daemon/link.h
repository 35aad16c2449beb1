/*
 * Links: the seam between the daemon core (daemon.c, daemon_*.c) and the protocol engines
 * (link_sharedlink.c, link_circe.c).
 *
 * The core owns one struct daemon_link per configured link. For each it asks the engine to declare
 * its variables and what it may learn at run time (before the shm tables exist), then creates the engine with a struct link_env, tells it
 * about client writes to its outbound variables, hands it control-socket commands, and destroys it
 * on reload or shutdown. An engine opens its own channel with link_channel_new(), which maps the
 * link's configuration onto transport parameters, so no engine deals with config-to-termios
 * mapping.
 *
 * Data flows one way (DESIGN.md §1):
 *     channel input -> codec decode -> engine -> shm_table_set/commit, events, counters
 *     client write -> core (outbound scan) -> engine ->outbound() -> codec encode -> channel_send
 *     control request -> core (reqp_decode) -> engine ->command() -> ... -> control_reply_*()
 *
 * Engines run on the core's event loop thread only; nothing here is thread-safe.
 */
#ifndef SHAREDLINK_DAEMON_LINK_H
#define SHAREDLINK_DAEMON_LINK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/channel.h"
#include "daemon/config.h"
#include "daemon/evloop.h"
#include "proto/request.h"
#include "shm/layout.h"

struct shm_table;
struct shm_var;
struct shm_out_change;
struct control_request;
struct recorder_tap;

/* Everything an engine gets from the core; valid until the engine's destroy() returns. */
struct link_env {
        struct evloop *loop;
        struct shm_table *table;
        uint32_t shm_link;                      /* this link's index in the table's link area */
        const struct config *config;            /* the whole configuration in force */
        const struct config_link *cfg;          /* this link's settings (points into config) */
        struct recorder_tap *tap;               /* `record` listens here (NULL: nobody can) */
};

/*
 * What a link may learn at run time beyond what it declared (link_ops.learning): the core makes
 * room for it in the tables and routes client writes to learned outbound names to it.
 */
struct link_learning {
        uint32_t adhoc;         /* names it may add at run time (ad hoc room, either direction) */
        uint32_t out_spare;     /* outbound ones among them: spare .out slots clients may write */
        bool outbound;          /* learns outbound names: gets client writes to names added at run
                                 * time (and ignores the ids that are not its own) */
};

struct link_ops {
        /*
         * Appends the variables this link declares at start-up (names, direction, type, link =
         * link_index, peer, list position) to vars[*n..max). String storage for names must live
         * as long as cfg (e.g. point into cfg) or in names_buf (a scratch area the core keeps
         * until shm_table_create() returns). Returns 0, -ENOSPC or -EINVAL.
         */
        int (*declare)(const struct config_link *cfg, uint32_t link_index, struct shm_var *vars,
                       size_t *n, size_t max, char *names_buf, size_t names_size,
                       size_t *names_used);

        /* Creates the engine and starts its channel (the first open attempt may fail: the
         * channel retries by itself). 0 or -errno. */
        int (*create)(const struct link_env *env, void **ret_engine);

        /* Stops the channel, fails pending control requests with -ECANCELED, frees. NULL ok. */
        void (*destroy)(void *engine);

        /* A client wrote (or an abandoned write was repaired on) one of this link's outbound
         * variables. Called once per changed slot, after the core's outbound scan. */
        void (*outbound)(void *engine, const struct shm_out_change *change);

        /* The control request words that address this engine's links ("query", "command";
         * "circe"), NULL-terminated: the core routes "<word> LINK ..." to the engine of LINK. */
        const char *const *command_words;

        /*
         * A control request addressed to this link (r->kind's verb one of command_words,
         * r->link its name), decoded and checked by the core (proto/request.h). r->wait_ms > 0
         * asks the engine to hold the request up to that long while the link is not ready
         * (link_waitq_*), 0 to refuse it at once. The engine must eventually answer req exactly
         * once with control_reply_ok() or control_reply_error() (it may send
         * control_reply_data() lines first), now or later, and always within a bounded time.
         */
        void (*command)(void *engine, struct control_request *req,
                        const struct reqp_request *r);

        /* One line for `STATUS=` and logs: "up", "connecting", "down: hang-up" ... The core
         * counts a link as up when the first word of this text is "up". */
        const char *(*status)(void *engine);

        /* Optional (NULL: nothing to do): called at every core heartbeat (DAEMON_HEARTBEAT_MS),
         * so the engine publishes its channel counters with link_publish_channel_stats() even
         * when no I/O burst happened (reopens while down, say). The core cannot do it itself:
         * the channel belongs to the engine. */
        void (*heartbeat)(void *engine);

        /* Optional (NULL: learns nothing): what a link with settings cfg may learn at run time
         * (a SharedLink link's Pronto4 peers with learned lists). ret is zeroed by the caller. */
        void (*learning)(const struct config_link *cfg, struct link_learning *ret);
};

/* The engine of a protocol: &link_sharedlink_ops or &link_circe_ops. NULL for an unknown one. */
const struct link_ops *link_ops_for(enum config_protocol protocol);

/* The protocol whose engine has word among its command_words: 0 and *ret_protocol, or -ENOENT. */
int link_protocol_for_command(const char *word, enum config_protocol *ret_protocol);

/* Whether word is one of ops' command_words. */
bool link_ops_has_word(const struct link_ops *ops, const char *word);

/*
 * Creates (stopped) the channel of env's link from its configuration (serial settings, devices,
 * pty path, udp endpoints, replay file), with the given callbacks and env's recorder tap. The
 * engine then calls channel_start().
 * 0 or -errno (-EINVAL with a log line when the configuration cannot be mapped).
 */
int link_channel_new(const struct link_env *env, const struct channel_ops *ops, void *arg,
                     struct channel **ret_channel);

/* Copies the channel's counters into the link's shm counters (bytes, reopens, io errors, tx
 * drops); engines call it after I/O bursts and from ops->heartbeat. */
void link_publish_channel_stats(const struct link_env *env, const struct channel *ch);

/*
 * Session hooks every engine wires the same way. arg is the engine, whose first member must be
 * its struct link_env: an event for the table's ring on this link, and a link counter.
 */
void link_hook_event(void *arg, enum shm_event_type type, const char *text);
void link_hook_count(void *arg, enum shm_counter counter, uint64_t n);

/*
 * Requests waiting for their link to be ready ("wait=MS"), the same for every engine: a bounded
 * FIFO of (request, deadline, the engine's parsed command). The engine adds a request its link
 * cannot serve yet, calls link_waitq_run() whenever readiness may have changed or the earliest
 * deadline (link_waitq_deadline()) has passed, and link_waitq_cancel() when it stops.
 */
#define LINK_WAITQ_MAX          16u     /* requests one link holds waiting */
#define LINK_WAITQ_DATA_MAX     1024u   /* room for one engine's parsed command */

struct link_waiting {
        struct control_request *req;
        uint64_t deadline_ms;
        unsigned wait_ms;
        _Alignas(max_align_t) unsigned char data[LINK_WAITQ_DATA_MAX];
};

struct link_waitq {
        struct link_waiting q[LINK_WAITQ_MAX];
        unsigned n;
};

struct link_waitq_ops {
        /* Whether the link can serve a request now (asked before each one). */
        bool (*ready)(void *engine);
        /* Serve req now, with the data given to link_waitq_add(). */
        void (*run)(void *engine, struct control_request *req, const void *data);
        /* Answer req with the engine's error: its wait_ms passed (or its client left). */
        void (*expire)(void *engine, struct control_request *req, const void *data,
                       unsigned wait_ms);
};

/* Queues req until now_ms + wait_ms with size bytes of data (copied); 0, -EBUSY (full) or
 * -EINVAL (size over LINK_WAITQ_DATA_MAX). */
int link_waitq_add(struct link_waitq *q, struct control_request *req, uint64_t now_ms,
                   unsigned wait_ms, const void *data, size_t size);

/* In order: runs each waiting request once the link is ready, expires those whose deadline
 * passed or whose client left, keeps the others. */
void link_waitq_run(struct link_waitq *q, uint64_t now_ms, const struct link_waitq_ops *ops,
                    void *engine);

/* The earliest deadline of a waiting request, or UINT64_MAX. */
uint64_t link_waitq_deadline(const struct link_waitq *q);

/* Ends every waiting request with ERR err why (the engine stops). */
void link_waitq_cancel(struct link_waitq *q, int err, const char *why);

#endif
