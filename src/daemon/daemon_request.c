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
#include "proto/request.h"
#include "shm/layout.h"
#include "shm/table.h"

_Static_assert(REQP_LINK_SIZE == SHM_LINK_NAME_SIZE, "a request's link name is a table's");
_Static_assert(REQP_NAME_SIZE == SHM_NAME_SIZE, "a request's variable name is a table's");

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
                           " orphan_answers=%" PRIu64 " refused_user=%" PRIu64
                           " refused_reserved=%" PRIu64 " idle_closed=%" PRIu64, cs.clients,
                           cs.accepted, cs.refused_full, cs.denied, cs.requests, cs.bad_requests,
                           cs.overlong, cs.slow_readers, cs.orphaned, cs.orphan_answers,
                           cs.refused_user, cs.refused_reserved, cs.idle_closed);
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
static void request_record(struct daemon *d, struct control_request *req,
                           const struct reqp_request *r)
{
        struct daemon_link *dl = link_by_name(d, r->link);
        int rc;

        if (!dl) {
                control_reply_error(req, ENOENT, "no link named \"%s\"", r->link);
                return;
        }
        rc = recorder_add(dl->tap, req);
        if (rc == -EBUSY)
                control_reply_error(req, EBUSY, "link %s has %u recorders already", r->link,
                                    RECORDER_PER_LINK_MAX);
        else if (rc < 0)
                control_reply_error(req, -rc, "cannot record link %s: %s", r->link,
                                    strerror(-rc));
}

/* "<command word> LINK ... [wait=MS]", decoded: to the engine of LINK. */
static void request_link(struct daemon *d, struct control_request *req,
                         const struct reqp_request *r)
{
        const char *verb = reqp_verb(r->kind);
        enum config_protocol protocol;
        struct daemon_link *dl;

        if (link_protocol_for_command(verb, &protocol) < 0) {
                control_reply_error(req, EINVAL, "unknown request \"%s\"", verb);
                return;
        }
        dl = link_by_name(d, r->link);
        if (!dl) {
                control_reply_error(req, ENOENT, "no link named \"%s\"", r->link);
                return;
        }
        /* Well formed, for a link that exists: not a bad argument but an operation the link's
         * protocol does not have. */
        if (dl->env.cfg->protocol != protocol) {
                control_reply_error(req, EOPNOTSUPP, "link %s speaks %s: %s is for %s links "
                                    "(operation not supported on this link's protocol)",
                                    r->link, config_protocol_name(dl->env.cfg->protocol), verb,
                                    config_protocol_name(protocol));
                return;
        }
        if (!dl->engine) {
                control_reply_error(req, ENOTCONN, "link %s is not running (%s)", r->link,
                                    dl->failure);
                return;
        }
        if (!dl->ops->command) {
                control_reply_error(req, ENOSYS, "link %s takes no commands", r->link);
                return;
        }
        dl->ops->command(dl->engine, req, r);
}

/* Every request is decoded whole (proto/request.h) before a link is looked at. */
void daemon_on_request(struct control_request *req, int argc, char **argv, void *arg)
{
        char err[REQP_ERR_MAX];
        struct daemon *d = arg;
        struct reqp_request r;

        if (reqp_decode(argc, argv, &r, err, sizeof(err)) < 0) {
                control_reply_error(req, EINVAL, "%s", err);
                return;
        }
        daemon_out_catch_up(d);
        switch (r.kind) {
        case REQP_PING:
                control_reply_ok(req, "%ld %" PRIu64, (long)getpid(),
                                 d->table ? shm_table_epoch(d->table) : 0);
                break;
        case REQP_STATS:
                request_stats(d, req);
                break;
        case REQP_RECORD:
                request_record(d, req, &r);
                break;
        default:
                request_link(d, req, &r);
                break;
        }
}
