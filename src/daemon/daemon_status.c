/*
 * Status and heartbeat (daemon_status.h).
 */
#include "daemon/daemon_status.h"

#include <stdio.h>
#include <string.h>

#include "daemon/daemon_internal.h"
#include "daemon/daemon_out.h"
#include "daemon/daemon_tables.h"
#include "shm/table.h"

void daemon_status(struct daemon *d, bool ready)
{
        char buf[NOTIFY_STATUS_MAX];
        unsigned up = 0;
        size_t len;

        for (unsigned i = 0; i < d->n_links; i++)
                if (d->links[i] && daemon_link_is_up(d->links[i]))
                        up++;
        len = (size_t)snprintf(buf, sizeof(buf), "%u of %u links up", up, d->n_links);
        for (unsigned i = 0; i < d->n_links && len < sizeof(buf); i++) {
                const struct daemon_link *dl = d->links[i];

                if (!dl || daemon_link_is_up(dl))
                        continue;
                len += (size_t)snprintf(buf + len, sizeof(buf) - len, "; %s: %s",
                                        dl->env.cfg->name, daemon_link_status_text(dl));
        }
        for (char *p = buf; *p; p++)
                if (*p == '\n' || *p == '\r')
                        *p = ' ';
        if (ready ? service_ready(d->svc, buf) : service_status(d->svc, buf))
                log_info("status: %s", buf);
}

static void daemon_on_heartbeat(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        struct daemon *d = arg;

        (void)loop;
        (void)t;
        if (!d->table)
                return;
        shm_table_heartbeat(d->table);
        /* On our own clock too: a truncated .out (or a dead writer's slot) may have no client
         * left that can wake us (shm_table_out_scan). */
        daemon_out_scan(d);
        for (unsigned i = 0; i < d->n_links; i++) {
                struct daemon_link *dl = d->links[i];

                if (dl && dl->engine && dl->ops->heartbeat)
                        dl->ops->heartbeat(dl->engine);
                if (dl)
                        recorder_sweep(dl->tap);
        }
        log_ratelimit_flush(&d->out_rl);
        daemon_status(d, false);
}

void daemon_status_init(struct daemon *d)
{
        evloop_timer_init(&d->heartbeat, d->loop, daemon_on_heartbeat, d);
}

int daemon_status_start(struct daemon *d)
{
        return evloop_timer_arm(&d->heartbeat, DAEMON_HEARTBEAT_MS, DAEMON_HEARTBEAT_MS);
}

void daemon_status_stop(struct daemon *d)
{
        evloop_timer_cancel(&d->heartbeat);
}
