/*
 * Links: the seam between the daemon core (daemon.c) and the protocol engines
 * (link_sharedlink.c, link_circe.c).
 *
 * The core owns one struct link per configured link. For each it asks the engine to declare its
 * variables (before the shm tables exist), then creates the engine with a struct link_env, tells it
 * about client writes to its outbound variables, hands it control-socket commands, and destroys it
 * on reload or shutdown. An engine opens its own channel with link_channel_new(), which maps the
 * link's configuration onto transport parameters, so no engine deals with config-to-termios
 * mapping.
 *
 * Data flows one way (DESIGN.md §1):
 *     channel input -> codec decode -> engine -> shm_table_set/commit, events, counters
 *     client write -> core (outbound scan) -> engine ->outbound() -> codec encode -> channel_send
 *     control command -> core -> engine ->command() -> ... -> control_reply_*()
 *
 * Engines run on the core's event loop thread only; nothing here is thread-safe.
 */
#ifndef SHAREDLINK_DAEMON_LINK_H
#define SHAREDLINK_DAEMON_LINK_H

#include <stddef.h>
#include <stdint.h>

#include "daemon/channel.h"
#include "daemon/config.h"
#include "daemon/evloop.h"

struct shm_table;
struct shm_var;
struct shm_out_change;
struct control_request;

/* Everything an engine gets from the core; valid until the engine's destroy() returns. */
struct link_env {
        struct evloop *loop;
        struct shm_table *table;
        uint32_t shm_link;                      /* this link's index in the table's link area */
        const struct config *config;            /* the whole configuration in force */
        const struct config_link *cfg;          /* this link's settings (points into config) */
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

        /*
         * A control command addressed to this link (argv[0] is the command word, e.g. "query" or
         * "circe"; argv[1] is the link name). The engine must eventually answer req exactly once
         * with control_reply_ok() or control_reply_error() (it may send control_reply_data()
         * lines first), now or later, and always within a bounded time.
         */
        void (*command)(void *engine, struct control_request *req, int argc, char **argv);

        /* One line for `STATUS=` and logs: "up", "connecting", "down: hang-up" ... The core
         * counts a link as up when the first word of this text is "up". */
        const char *(*status)(void *engine);

        /* Optional (NULL: nothing to do): called at every core heartbeat (DAEMON_HEARTBEAT_MS),
         * so the engine publishes its channel counters with link_publish_channel_stats() even
         * when no I/O burst happened (reopens while down, say). The core cannot do it itself:
         * the channel belongs to the engine. */
        void (*heartbeat)(void *engine);
};

/* The engine of a protocol: &link_sharedlink_ops or &link_circe_ops. NULL for an unknown one. */
const struct link_ops *link_ops_for(enum config_protocol protocol);

/*
 * Creates (stopped) the channel of env's link from its configuration (serial settings, devices,
 * pty path, udp endpoints), with the given callbacks. The engine then calls channel_start().
 * 0 or -errno (-EINVAL with a log line when the configuration cannot be mapped).
 */
int link_channel_new(const struct link_env *env, const struct channel_ops *ops, void *arg,
                     struct channel **ret_channel);

/* Copies the channel's counters into the link's shm counters (bytes, reopens, io errors, tx
 * drops); engines call it after I/O bursts and from ops->heartbeat. */
void link_publish_channel_stats(const struct link_env *env, const struct channel *ch);

#endif
