/*
 * Control requests answered by the core, and routing to the engines (daemon_request.h).
 */
#include "daemon/daemon_request.h"

#include <errno.h>
#include <inttypes.h>
#include <string.h>
#include <unistd.h>

#include "daemon/daemon_internal.h"
#include "daemon/daemon_out.h"
#include "shm/table.h"

static void request_stats(struct daemon *d, struct control_request *req)
{
        struct evloop_stats es;
        struct control_stats cs;

        evloop_get_stats(d->loop, &es);
        control_reply_data(req, "loop wakeups=%" PRIu64 " idle_wakeups=%" PRIu64
                           " fd_events=%" PRIu64 " timer_fires=%" PRIu64 " signals=%" PRIu64
                           " nval_drops=%" PRIu64, es.wakeups, es.idle_wakeups, es.fd_events,
                           es.timer_fires, es.signals, es.nval_drops);
        control_get_stats(d->control, &cs);
        control_reply_data(req, "control clients=%u accepted=%" PRIu64 " refused_full=%" PRIu64
                           " denied=%" PRIu64 " requests=%" PRIu64 " bad_requests=%" PRIu64
                           " overlong=%" PRIu64 " slow_readers=%" PRIu64 " orphaned=%" PRIu64
                           " orphan_answers=%" PRIu64, cs.clients, cs.accepted, cs.refused_full,
                           cs.denied, cs.requests, cs.bad_requests, cs.overlong, cs.slow_readers,
                           cs.orphaned, cs.orphan_answers);
        for (unsigned k = 0; k < DAEMON_OUT_STAGES; k++) {
                struct stages_summary sum = { 0 };

                stages_summary(&d->out_stages, k, &sum);
                control_reply_data(req, "outbound_stage %s samples=%zu p50_ns=%" PRIu32
                                   " p99_ns=%" PRIu32 " max_ns=%" PRIu32, daemon_out_stage_names[k],
                                   sum.samples, sum.p50_ns, sum.p99_ns, sum.max_ns);
        }
        control_reply_data(req, "record recorders=%u started=%" PRIu64 " chunks=%" PRIu64
                           " dropped=%" PRIu64, d->rec_stats.active, d->rec_stats.started,
                           d->rec_stats.chunks, d->rec_stats.dropped);
        control_reply_ok(req, NULL);
}

static struct daemon_link *link_by_name(struct daemon *d, const char *name)
{
        for (unsigned i = 0; i < d->n_links; i++)
                if (d->links[i] && strcmp(d->links[i]->env.cfg->name, name) == 0)
                        return d->links[i];
        return NULL;
}

/* "record LINK": answered by the link's recorders until the client leaves (recorder.h). */
static void request_record(struct daemon *d, struct control_request *req, int argc, char **argv)
{
        struct daemon_link *dl;
        int r;

        if (argc != 2) {
                control_reply_error(req, EINVAL, "usage: record LINK");
                return;
        }
        dl = link_by_name(d, argv[1]);
        if (!dl) {
                control_reply_error(req, ENOENT, "no link named \"%s\"", argv[1]);
                return;
        }
        r = recorder_add(dl->tap, req);
        if (r == -EBUSY)
                control_reply_error(req, EBUSY, "link %s has %u recorders already", argv[1],
                                    RECORDER_PER_LINK_MAX);
        else if (r < 0)
                control_reply_error(req, -r, "cannot record link %s: %s", argv[1], strerror(-r));
}

/* "<command word> LINK ... [wait=MS]": the wait is parsed here, once, for every engine. */
static void request_link(struct daemon *d, struct control_request *req, int argc, char **argv,
                         enum config_protocol protocol)
{
        char err[DAEMON_ERROR_MAX];
        struct daemon_link *dl;
        unsigned wait_ms;

        if (argc < 3) {
                control_reply_error(req, EINVAL, "usage: %s LINK ...", argv[0]);
                return;
        }
        if (link_command_wait(&argc, argv, &wait_ms, err, sizeof(err)) < 0) {
                control_reply_error(req, EINVAL, "%s", err);
                return;
        }
        dl = link_by_name(d, argv[1]);
        if (!dl) {
                control_reply_error(req, ENOENT, "no link named \"%s\"", argv[1]);
                return;
        }
        /* Well formed, for a link that exists: not a bad argument but an operation the link's
         * protocol does not have. */
        if (dl->env.cfg->protocol != protocol) {
                control_reply_error(req, EOPNOTSUPP, "link %s speaks %s: %s is for %s links "
                                    "(operation not supported on this link's protocol)",
                                    argv[1], config_protocol_name(dl->env.cfg->protocol), argv[0],
                                    config_protocol_name(protocol));
                return;
        }
        if (!dl->engine) {
                control_reply_error(req, ENOTCONN, "link %s is not running (%s)", argv[1],
                                    dl->failure);
                return;
        }
        if (!dl->ops->command) {
                control_reply_error(req, ENOSYS, "link %s takes no commands", argv[1]);
                return;
        }
        dl->ops->command(dl->engine, req, argc, argv, wait_ms);
}

void daemon_on_request(struct control_request *req, int argc, char **argv, void *arg)
{
        struct daemon *d = arg;
        enum config_protocol protocol;

        if (strcmp(argv[0], "ping") == 0) {
                if (argc != 1)
                        control_reply_error(req, EINVAL, "usage: ping");
                else
                        control_reply_ok(req, "%ld %" PRIu64, (long)getpid(),
                                         d->table ? shm_table_epoch(d->table) : 0);
        } else if (strcmp(argv[0], "stats") == 0) {
                if (argc != 1)
                        control_reply_error(req, EINVAL, "usage: stats");
                else
                        request_stats(d, req);
        } else if (strcmp(argv[0], "record") == 0) {
                request_record(d, req, argc, argv);
        } else if (link_protocol_for_command(argv[0], &protocol) == 0) {
                request_link(d, req, argc, argv, protocol);
        } else {
                control_reply_error(req, EINVAL, "unknown request \"%s\"", argv[0]);
        }
}
