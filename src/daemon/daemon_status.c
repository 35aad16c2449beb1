/*
 * Status, heartbeat, watchdog (daemon_status.h).
 */
#include "daemon/daemon_status.h"

#include <inttypes.h>
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
        if (ready) {
                char msg[NOTIFY_MESSAGE_MAX];

                snprintf(msg, sizeof(msg), "READY=1\nSTATUS=%s", buf);
                notify_send(d->notify, msg);
        } else if (strcmp(buf, d->status) != 0) {
                notify_status(d->notify, "%s", buf);
        }
        if (strcmp(buf, d->status) != 0)
                log_info("status: %s", buf);
        snprintf(d->status, sizeof(d->status), "%s", buf);
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

/* From the loop, so that a stuck loop stops the pings and systemd notices. */
static void daemon_on_watchdog(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        struct daemon *d = arg;

        (void)loop;
        (void)t;
        notify_watchdog(d->notify);
}

void daemon_status_init(struct daemon *d)
{
        evloop_timer_init(&d->heartbeat, d->loop, daemon_on_heartbeat, d);
        evloop_timer_init(&d->watchdog, d->loop, daemon_on_watchdog, d);
}

int daemon_status_start(struct daemon *d)
{
        uint64_t wd = notify_watchdog_interval_ms(d->notify);
        int r;

        r = evloop_timer_arm(&d->heartbeat, DAEMON_HEARTBEAT_MS, DAEMON_HEARTBEAT_MS);
        if (r < 0)
                return r;
        if (wd > 0) {
                r = evloop_timer_arm(&d->watchdog, wd, wd);
                if (r < 0)
                        return r;
                log_info("watchdog: WATCHDOG=1 every %" PRIu64 " ms", wd);
        }
        return 0;
}

void daemon_status_stop(struct daemon *d)
{
        evloop_timer_cancel(&d->watchdog);
        evloop_timer_cancel(&d->heartbeat);
}
