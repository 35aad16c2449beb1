/*
 * The sharedlinkd instance: start, stop and reload (see daemon.h for the start order and the
 * reload rules). What each step does lives in its own file (daemon_internal.h lists them); here
 * is only their order, and which of them a reload repeats.
 */
#include "daemon/daemon.h"

#include <errno.h>
#include <inttypes.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "daemon/control.h"
#include "daemon/daemon_config.h"
#include "daemon/daemon_internal.h"
#include "daemon/daemon_link.h"
#include "daemon/daemon_out.h"
#include "daemon/daemon_plan.h"
#include "daemon/daemon_request.h"
#include "daemon/daemon_socket.h"
#include "daemon/daemon_status.h"
#include "daemon/daemon_tables.h"
#include "daemon/replay.h"
#include "shm/table.h"
#include "svc/log.h"

int daemon_check_config(const struct config *config, const char *path, char *err, size_t errsz)
{
        char why[DAEMON_ERROR_MAX], where[DAEMON_WHERE_MAX];
        struct daemon_plan plan;
        int r = daemon_plan_make(config, &plan, why, sizeof(why));

        daemon_plan_where(&plan, path, where, sizeof(where));
        daemon_plan_clear(&plan);
        if (r < 0 && err && errsz)
                snprintf(err, errsz, "%s: %s", where, why);
        /* Only here, not at start: there a broken recording fails its link, not the daemon. */
        for (unsigned i = 0; r == 0 && i < config->n_links; i++) {
                const struct config_link *l = &config->links[i];
                char broken[TRANSPORT_ERR_MAX];

                if (l->transport != CONFIG_TRANSPORT_REPLAY)
                        continue;
                r = replay_check_file(l->replay_file, broken, sizeof(broken));
                if (r < 0 && err && errsz)
                        snprintf(err, errsz, "%s: link %s: %s", path, l->name, broken);
        }
        return r;
}

/* ---------------------------------------------------------------------------------------------
 * Links */

static void link_stop(struct daemon *d, unsigned i)
{
        d->links[i] = daemon_link_free(d->links[i]);
}

/* Creates link i of dc's configuration. Only memory trouble fails; an engine that does not
 * start leaves a link marked failed (STATUS, shm state) until the next reload. */
static int link_start(struct daemon *d, unsigned i, struct daemon_config *dc,
                      const struct link_ops *ops)
{
        return daemon_link_new(d->loop, d->table, &d->rec_stats, i, dc, ops, &d->links[i]);
}

static void links_stop_all(struct daemon *d)
{
        for (unsigned i = d->n_links; i-- > 0;)
                link_stop(d, i);
        d->n_links = 0;
}

static int links_start_all(struct daemon *d, struct daemon_config *dc,
                           const struct daemon_plan *plan)
{
        for (unsigned i = 0; i < dc->config->n_links; i++) {
                int r = link_start(d, i, dc, plan->ops[i]);

                d->n_links = i + 1;
                if (r < 0)
                        return r;
        }
        return 0;
}

static int socket_open(struct daemon *d, const struct daemon_plan *plan)
{
        return daemon_socket_open(d->loop, plan, daemon_on_request, d, &d->control);
}

/* ---------------------------------------------------------------------------------------------
 * Start and stop */

static void daemon_ready(struct daemon *d)
{
        daemon_status(d, true);
}

struct daemon *daemon_free(struct daemon *d)
{
        if (!d)
                return NULL;
        daemon_status_stop(d);
        daemon_out_stop(d);
        links_stop_all(d);
        d->control = control_free(d->control);
        d->table = shm_table_destroy(d->table);
        daemon_plan_clear(&d->plan);
        d->dc = daemon_config_unref(d->dc);
        free(d->config_path);
        free(d);
        return NULL;
}

int daemon_new(struct service *svc, const char *config_path, struct config *config,
               struct daemon **ret_daemon)
{
        char err[DAEMON_ERROR_MAX];
        struct daemon *d = calloc(1, sizeof(*d));
        int r;

        if (!d || !(d->config_path = strdup(config_path))) {
                free(d);
                config_free(config);
                return -ENOMEM;
        }
        d->svc = svc;
        d->loop = service_loop(svc);
        daemon_out_init(d);
        daemon_status_init(d);
        d->dc = daemon_config_new(config);
        if (!d->dc) {
                r = -ENOMEM;
                goto fail;
        }
        r = daemon_plan_make(config, &d->plan, err, sizeof(err));
        if (r < 0) {
                char where[DAEMON_WHERE_MAX];

                daemon_plan_where(&d->plan, config_path, where, sizeof(where));
                log_warnx("%s: %s", where, err);
                goto fail;
        }
        r = daemon_tables_create(config, &d->plan, &d->table);
        if (r < 0)
                goto fail;
        r = socket_open(d, &d->plan);
        if (r < 0)
                goto fail;
        r = links_start_all(d, d->dc, &d->plan);
        if (r < 0)
                goto fail;
        r = daemon_out_start(d);
        if (r < 0)
                goto fail;
        r = daemon_status_start(d);
        if (r < 0)
                goto fail;
        daemon_ready(d);
        *ret_daemon = d;
        return 0;

fail:
        daemon_free(d);
        return r;
}

/* ---------------------------------------------------------------------------------------------
 * Reload */

/* Puts the new configuration in force (a link left untouched keeps a ref on the old one). */
static void reload_install(struct daemon *d, struct daemon_config *ndc, struct daemon_plan *np)
{
        daemon_plan_clear(&d->plan);
        d->plan = *np;
        memset(np, 0, sizeof(*np));
        daemon_config_unref(d->dc);
        d->dc = ndc;
}

/* Same tables, new socket path or group: move the socket, links keep running. 0, or -errno
 * with the old socket back (or none, logged, if even that failed: links go on regardless). */
static int reload_socket(struct daemon *d, const struct daemon_plan *np)
{
        int r;

        d->control = control_free(d->control);
        r = socket_open(d, np);
        if (r < 0 && socket_open(d, &d->plan) < 0)
                log_warnx("reload: no control socket any more; links keep running");
        return r;
}

/* Same tables: restart only the links whose settings changed (the new configuration is already
 * in force). */
static void reload_links(struct daemon *d)
{
        const struct config *nc = d->dc->config;
        unsigned restarted = 0;

        for (unsigned i = 0; i < nc->n_links; i++) {
                struct daemon_link *dl = d->links[i];

                if (dl && config_link_equal(dl->env.cfg, &nc->links[i])) {
                        log_debug("link %s: unchanged", nc->links[i].name);
                        continue;
                }
                log_info("link %s: settings changed, restarting it", nc->links[i].name);
                link_stop(d, i);
                if (link_start(d, i, d->dc, d->plan.ops[i]) < 0)
                        log_warnx("link %s: out of memory", nc->links[i].name);
                restarted++;
        }
        log_notice("reload: tables kept (epoch %" PRIu64 "), %u of %u links restarted",
                   shm_table_epoch(d->table), restarted, nc->n_links);
}

/*
 * Something the tables depend on changed: stop everything, recreate the tables (and the socket
 * when new_socket), start everything. Returns 1 when the new configuration was put in force,
 * 0 when the old one was put back; if even that fails the daemon exits 1.
 */
static int reload_tables(struct daemon *d, struct daemon_config *ndc, struct daemon_plan *np,
                         bool new_socket)
{
        int installed = 0, r;

        daemon_status_stop(d);
        daemon_out_stop(d);
        links_stop_all(d);
        if (new_socket)
                d->control = control_free(d->control);
        d->table = shm_table_destroy(d->table);

        r = daemon_tables_create(ndc->config, np, &d->table);
        if (r == 0 && new_socket)
                r = socket_open(d, np);
        if (r == 0) {
                reload_install(d, ndc, np);
                installed = 1;
        } else {
                log_warnx("reload: cannot apply the new configuration; restoring the old one");
                d->table = shm_table_destroy(d->table);
                if (daemon_tables_create(d->dc->config, &d->plan, &d->table) < 0) {
                        log_warnx("reload: cannot restore the old tables either; exiting");
                        evloop_exit(d->loop, 1);
                        return 0;
                }
                if (!d->control && socket_open(d, &d->plan) < 0)
                        log_warnx("reload: no control socket any more; links keep running");
        }
        if (links_start_all(d, d->dc, &d->plan) < 0 || daemon_out_start(d) < 0 ||
            daemon_status_start(d) < 0) {
                log_warnx("reload: out of resources restarting the links; exiting");
                evloop_exit(d->loop, 1);
                return installed;
        }
        if (installed)
                log_notice("reload: tables recreated (epoch %" PRIu64 "), %u links restarted",
                           shm_table_epoch(d->table), d->n_links);
        return installed;
}

int daemon_reload(struct daemon *d)
{
        char err[DAEMON_ERROR_MAX];
        struct config_error cerr;
        struct config *nc = NULL;
        struct daemon_config *ndc = NULL;
        struct daemon_plan np;
        bool same_tables, same_socket;
        int r;

        log_notice("reload: reading %s", d->config_path);
        memset(&np, 0, sizeof(np));
        r = config_load_file(d->config_path, &nc, &cerr);
        if (r < 0) {
                log_warnx("reload: %s; keeping the running configuration", cerr.message);
                goto done;
        }
        ndc = daemon_config_new(nc);
        if (!ndc) {
                r = -ENOMEM;
                goto done;
        }
        r = daemon_plan_make(nc, &np, err, sizeof(err));
        if (r < 0) {
                char where[DAEMON_WHERE_MAX];

                daemon_plan_where(&np, d->config_path, where, sizeof(where));
                log_warnx("reload: %s: %s; keeping the running configuration", where, err);
                goto done;
        }
        same_socket = daemon_plan_same_socket(&d->plan, &np);
        /* The header publishes the socket path once (layout 1.2): moving it takes new tables. */
        same_tables = daemon_plan_same_tables(&d->plan, &np);
        if (!same_tables) {
                if (!reload_tables(d, ndc, &np, !same_socket))
                        r = -EAGAIN;
                else
                        ndc = NULL;
                goto done;
        }
        if (!same_socket) {
                r = reload_socket(d, &np);
                if (r < 0)
                        goto done;
        }
        reload_install(d, ndc, &np);
        ndc = NULL;
        reload_links(d);
done:
        daemon_plan_clear(&np);
        daemon_config_unref(ndc);
        if (!evloop_exiting(d->loop))
                daemon_ready(d);
        return r;
}
