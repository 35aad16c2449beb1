/*
 * One configured link of the instance: its engine (link.h), the configuration it was created
 * with, its recorder tap, and why it failed when its engine did not start. A link that cannot
 * start is reported (STATUS, the shm link state, commands), never fatal; it stays failed until
 * the next reload.
 */
#ifndef SHAREDLINK_DAEMON_DAEMON_LINK_H
#define SHAREDLINK_DAEMON_DAEMON_LINK_H

#include <stdbool.h>

#include "daemon/daemon_config.h"
#include "daemon/daemon_plan.h"
#include "daemon/evloop.h"
#include "daemon/link.h"
#include "daemon/recorder.h"

struct shm_table;

struct daemon_link {
        const struct link_ops *ops;
        struct daemon_config *dc;       /* the configuration it was created with */
        struct link_env env;            /* handed to the engine; stable address */
        void *engine;                   /* NULL when create() failed */
        struct recorder_tap *tap;       /* `record LINK` (recorder.h) */
        char failure[DAEMON_ERROR_MAX]; /* why, for STATUS and commands */
};

/*
 * Creates link i of dc's configuration (taking a reference on dc) with ops, its engine on loop
 * and table, its tap counted in rec_stats. Only memory trouble fails (-ENOMEM); an engine that
 * does not start leaves a link marked failed.
 */
int daemon_link_new(struct evloop *loop, struct shm_table *table,
                    struct recorder_stats *rec_stats, unsigned i, struct daemon_config *dc,
                    const struct link_ops *ops, struct daemon_link **ret_link);

/* Stops the engine, ends the link's recorders, drops its configuration. NULL ok; returns NULL. */
struct daemon_link *daemon_link_free(struct daemon_link *dl);

/* The engine's status line ("running" when it has none), or why the link failed. */
const char *daemon_link_status_text(const struct daemon_link *dl);

/* Whether the first word of the status text is "up". */
bool daemon_link_is_up(const struct daemon_link *dl);

#endif
