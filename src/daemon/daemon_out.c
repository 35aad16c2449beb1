/*
 * Outbound routing (daemon_out.h).
 */
#include "daemon/daemon_out.h"

#include <errno.h>
#include <poll.h>
#include <stdbool.h>
#include <string.h>

#include "daemon/daemon_internal.h"
#include "shm/table.h"

const char *const daemon_out_stage_names[DAEMON_OUT_STAGES] = {
        "write_to_wake",        /* sl_write's time stamp -> the wake thread signals its eventfd */
        "wake_to_loop",         /* -> the poll loop returns with it */
        "loop_to_sent",         /* -> out scan done and the frame handed to the link's channel */
};

/* Whether a link learns outbound names at run time, as its engine says (link_ops.learning). */
static bool link_learns_outbound(const struct daemon_link *dl)
{
        struct link_learning learning = { 0 };

        if (!dl->ops->learning)
                return false;
        dl->ops->learning(dl->env.cfg, &learning);
        return learning.outbound;
}

/* One outbound change handed to its link in a scan that answered a wake-up: its stages. */
static void daemon_time_out_change(struct daemon *d, const struct shm_out_change *change)
{
        uint64_t stamps[DAEMON_OUT_STAGES + 1];

        if (change->status != SHM_OUT_CHANGED || d->wake_stamps[0] == 0)
                return;
        stamps[0] = change->mono_ns;
        stamps[1] = d->wake_stamps[0];
        stamps[2] = d->wake_stamps[1];
        stamps[3] = evloop_clock_ns();
        stages_record(&d->out_stages, stamps);
}

static void daemon_on_out_change(void *userdata, const struct shm_out_change *change)
{
        struct daemon *d = userdata;
        const struct daemon_decl *decl = d->plan.decl;
        struct daemon_link *dl;
        uint32_t link;

        if (change->status == SHM_OUT_REPAIRED && change->taken_over)
                log_ratelimited(&d->out_rl, LOG_PRIO_WARNING, "outbound variable %s: pid %u "
                                "held its slot mid-write for %u heartbeats (stopped, or a reused "
                                "or forged pid): taken over, that write is lost",
                                change->name, change->writer_pid, SHM_TABLE_HELD_HEARTBEATS);
        /* An outbound name added at run time was learned by a link: each link that learns
         * outbound names gets it and ignores an id that is not one of its own. */
        if (change->id >= decl->nvars) {
                for (unsigned i = 0; i < d->n_links; i++) {
                        dl = d->links[i];
                        if (dl && dl->engine && dl->ops->outbound &&
                            link_learns_outbound(dl))
                                dl->ops->outbound(dl->engine, change);
                }
                return;
        }
        link = decl->vars[change->id].link;
        if (link >= d->n_links)
                return;
        dl = d->links[link];
        if (dl && dl->engine && dl->ops->outbound) {
                dl->ops->outbound(dl->engine, change);
                daemon_time_out_change(d, change);
        }
}

static void daemon_out_scanned(struct daemon *d, int r)
{
        if (r == -EBADMSG)
                log_ratelimited(&d->out_rl, LOG_PRIO_WARNING, "outbound table of instance %s was "
                                "truncated or overwritten by a client: recreated empty",
                                d->dc->config->instance);
}

/* Every slot: at start and at every heartbeat, which bounds how late a write whose touched mark
 * was lost (layout 1.6) goes out. */
void daemon_out_scan(struct daemon *d)
{
        daemon_out_scanned(d, shm_table_out_scan(d->table, daemon_on_out_change, d));
}

/* The slots marked written, before a control request: the request sees every write its client
 * (or any other) finished before sending it, whatever order the loop takes the wake-up and the
 * request in. A query answered right after `slctl set` answers the value set. */
void daemon_out_catch_up(struct daemon *d)
{
        if (d->table)
                daemon_out_scanned(d, shm_table_out_scan_touched(d->table, daemon_on_out_change,
                                                                 d));
}

static void daemon_on_wake(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct daemon *d = arg;

        (void)fd;
        (void)revents;
        shm_table_out_wake_ack(d->table);
        d->wake_stamps[0] = shm_table_out_wake_stamp(d->table);
        d->wake_stamps[1] = evloop_now_ns(loop);
        /* The slots written since: the cost of a wake-up grows with the writes, not the table. */
        daemon_out_scanned(d, shm_table_out_scan_touched(d->table, daemon_on_out_change, d));
        d->wake_stamps[0] = d->wake_stamps[1] = 0;
}

void daemon_out_init(struct daemon *d)
{
        d->wake_fd = -1;
        stages_init(&d->out_stages, DAEMON_OUT_STAGES);
        log_ratelimit_init(&d->out_rl, "outbound table", LOG_RATELIMIT_INTERVAL_MS,
                           LOG_RATELIMIT_BURST);
}

int daemon_out_start(struct daemon *d)
{
        int fd = shm_table_out_wake_fd(d->table);
        int r;

        if (fd < 0) {
                log_warnx("outbound wake thread: %s", strerror(-fd));
                return fd;
        }
        r = evloop_add_fd(d->loop, fd, POLLIN, daemon_on_wake, d);
        if (r < 0)
                return r;
        d->wake_fd = fd;
        /* Writes made between the table's creation and now woke nobody: look once. */
        daemon_out_scan(d);
        return 0;
}

void daemon_out_stop(struct daemon *d)
{
        if (d->wake_fd >= 0)
                evloop_del_fd(d->loop, d->wake_fd);
        d->wake_fd = -1;    /* the fd belongs to the table, closed by shm_table_destroy */
}
