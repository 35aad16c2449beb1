/*
 * The sharedlinkd instance (see daemon.h for the start order and the reload rules).
 *
 * A "plan" is everything derived from one configuration before anything is touched: the engine
 * of each link, the group id, the socket path, and the declaration (the variables and links the
 * tables are created with). Start and reload both make a plan first, so a configuration that
 * cannot work is refused while the running one is still intact.
 *
 * Configurations are reference counted: a link keeps the configuration it was created with
 * (its link_env points into it), so a reload that leaves a link untouched does not pull its
 * settings from under it; the old configuration is freed when its last link stops.
 */
#define _GNU_SOURCE     /* getgrnam_r */
#include "daemon/daemon.h"

#include <errno.h>
#include <grp.h>
#include <inttypes.h>
#include <poll.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "daemon/control.h"
#include "daemon/link.h"
#include "daemon/log.h"
#include "daemon/recorder.h"
#include "daemon/replay.h"
#include "daemon/stages.h"
#include "shm/table.h"

#define DAEMON_GROUP_BUF        16384   /* getgrnam_r buffer */
#define DAEMON_SOCKET_SUFFIX    ".sock"
#define DAEMON_LINK_FAILED      0u      /* shm link state of a link whose engine did not start */

/* A configuration shared by the daemon and the links created from it. */
struct daemon_config {
        struct config *config;
        unsigned refs;
};

/* What the tables were created with; compared on reload to decide whether to keep them. */
struct daemon_decl {
        char instance[CONFIG_INSTANCE_MAX + 1];
        bool has_group;
        gid_t gid;
        unsigned nlinks;
        char link_names[CONFIG_LINKS_MAX][CONFIG_LINK_NAME_MAX + 1];
        enum config_protocol protocols[CONFIG_LINKS_MAX];
        struct shm_var *vars;           /* names and peers point into strings */
        uint32_t nvars;
        char *strings;
};

struct daemon_plan {
        const struct link_ops *ops[CONFIG_LINKS_MAX];
        bool has_group;
        gid_t gid;
        char runtime_dir[CONFIG_PATH_MAX];
        char socket_path[CONFIG_SOCKET_PATH_MAX];
        struct daemon_decl *decl;
};

/* The socket path is published in the .in header (layout 1.2): the field must hold any path. */
_Static_assert(CONFIG_SOCKET_PATH_MAX <= SHM_SOCKET_PATH_SIZE, "socket path field");

struct daemon_link {
        struct daemon *d;
        const struct link_ops *ops;
        struct daemon_config *dc;       /* the configuration it was created with */
        struct link_env env;            /* handed to the engine; stable address */
        void *engine;                   /* NULL when create() failed */
        struct recorder_tap *tap;       /* `record LINK` (recorder.h) */
        char failure[DAEMON_ERROR_MAX]; /* why, for STATUS and commands */
};

struct daemon {
        struct evloop *loop;
        struct notify *notify;
        char *config_path;
        struct daemon_config *dc;       /* in force */
        struct daemon_plan plan;        /* of dc */
        struct shm_table *table;
        struct control *control;
        struct daemon_link *links[CONFIG_LINKS_MAX];
        unsigned n_links;
        int wake_fd;                    /* -1 when not on the loop */
        /* The outbound path timed in here, reported by `stats`: client write -> wake thread
         * signals -> poll loop runs -> frame handed to the link. While a scan answers a wake-up,
         * wake_stamps holds its signal and poll stamps (else 0: nothing is recorded). */
        struct stages out_stages;
        uint64_t wake_stamps[2];
        struct evloop_timer heartbeat;
        struct evloop_timer watchdog;
        struct log_ratelimit out_rl;    /* outbound object trouble */
        struct recorder_stats rec_stats;        /* every link's recorders */
        char status[NOTIFY_STATUS_MAX];
};

/* The stages of d->out_stages, as `stats` names them. */
#define DAEMON_OUT_STAGES       3
static const char *const daemon_out_stage_names[DAEMON_OUT_STAGES] = {
        "write_to_wake",        /* sl_write's time stamp -> the wake thread signals its eventfd */
        "wake_to_loop",         /* -> the poll loop returns with it */
        "loop_to_sent",         /* -> out scan done and the frame handed to the link's channel */
};

static void daemon_on_request(struct control_request *req, int argc, char **argv, void *arg);

/* ---------------------------------------------------------------------------------------------
 * Configurations */

static struct daemon_config *dconfig_new(struct config *config)
{
        struct daemon_config *dc = calloc(1, sizeof(*dc));

        if (!dc) {
                config_free(config);
                return NULL;
        }
        dc->config = config;
        dc->refs = 1;
        return dc;
}

static struct daemon_config *dconfig_ref(struct daemon_config *dc)
{
        dc->refs++;
        return dc;
}

static struct daemon_config *dconfig_unref(struct daemon_config *dc)
{
        if (dc && --dc->refs == 0) {
                config_free(dc->config);
                free(dc);
        }
        return NULL;
}

/* ---------------------------------------------------------------------------------------------
 * Plans: engines, group, socket path, declaration */

static int errf(char *err, size_t errsz, int r, const char *fmt, ...)
        __attribute__((format(printf, 4, 5)));

static int errf(char *err, size_t errsz, int r, const char *fmt, ...)
{
        va_list ap;

        if (err && errsz) {
                va_start(ap, fmt);
                vsnprintf(err, errsz, fmt, ap);
                va_end(ap);
        }
        return r;
}

static struct daemon_decl *decl_free(struct daemon_decl *dl)
{
        if (dl) {
                free(dl->vars);
                free(dl->strings);
                free(dl);
        }
        return NULL;
}

static int name_cmp(const void *a, const void *b)
{
        const struct shm_var *const *x = a, *const *y = b;

        return strcmp((*x)->name, (*y)->name);
}

/* Checks what engines declared before shm_table_create sees it, for a message naming the link. */
static int decl_check(const struct config *cfg, const struct shm_var *vars, size_t n, char *err,
                      size_t errsz)
{
        const struct shm_var **sorted;
        int r = 0;

        for (size_t i = 0; i < n; i++) {
                const struct shm_var *v = &vars[i];
                const char *ln = v->link < cfg->n_links ? cfg->links[v->link].name : "?";

                if (!v->name || shm_layout_name_check(v->name) < 0)
                        return errf(err, errsz, -EINVAL, "link %s: bad variable name \"%s\"", ln,
                                    v->name ? v->name : "(null)");
                if (v->peer && strlen(v->peer) >= SHM_PEER_SIZE)
                        return errf(err, errsz, -EINVAL, "link %s: variable %s: peer too long",
                                    ln, v->name);
        }
        sorted = malloc((n ? n : 1) * sizeof(*sorted));
        if (!sorted)
                return errf(err, errsz, -ENOMEM, "out of memory");
        for (size_t i = 0; i < n; i++)
                sorted[i] = &vars[i];
        qsort(sorted, n, sizeof(*sorted), name_cmp);
        for (size_t i = 1; i < n; i++)
                if (strcmp(sorted[i - 1]->name, sorted[i]->name) == 0) {
                        r = errf(err, errsz, -EEXIST, "variable %s is declared twice",
                                 sorted[i]->name);
                        break;
                }
        free(sorted);
        return r;
}

/* Copies the declared variables with their strings into one owned block. */
static int decl_copy(struct daemon_decl *dl, const struct shm_var *vars, size_t n)
{
        size_t total = 0, pos = 0;

        for (size_t i = 0; i < n; i++)
                total += strlen(vars[i].name) + 1 + (vars[i].peer ? strlen(vars[i].peer) : 0) + 1;
        dl->vars = calloc(n ? n : 1, sizeof(*dl->vars));
        dl->strings = malloc(total ? total : 1);
        if (!dl->vars || !dl->strings)
                return -ENOMEM;
        for (size_t i = 0; i < n; i++) {
                size_t ln = strlen(vars[i].name) + 1;
                size_t lp = (vars[i].peer ? strlen(vars[i].peer) : 0) + 1;

                dl->vars[i] = vars[i];
                memcpy(dl->strings + pos, vars[i].name, ln);
                dl->vars[i].name = dl->strings + pos;
                pos += ln;
                memcpy(dl->strings + pos, vars[i].peer ? vars[i].peer : "", lp);
                dl->vars[i].peer = dl->strings + pos;
                pos += lp;
        }
        dl->nvars = (uint32_t)n;
        return 0;
}

/* Asks every link's engine for its variables, in link order (ids are positions). */
static int decl_build(const struct config *cfg, const struct daemon_plan *plan,
                      struct daemon_decl **ret_decl, char *err, size_t errsz)
{
        struct shm_var *vars = calloc(DAEMON_VARS_MAX, sizeof(*vars));
        char *names = malloc(DAEMON_NAMES_SIZE);
        struct daemon_decl *dl = calloc(1, sizeof(*dl));
        size_t n = 0, used = 0;
        int r;

        if (!vars || !names || !dl) {
                r = errf(err, errsz, -ENOMEM, "out of memory");
                goto out;
        }
        snprintf(dl->instance, sizeof(dl->instance), "%s", cfg->instance);
        dl->has_group = plan->has_group;
        dl->gid = plan->gid;
        dl->nlinks = cfg->n_links;
        for (unsigned i = 0; i < cfg->n_links; i++) {
                const struct config_link *l = &cfg->links[i];
                size_t before = n;

                snprintf(dl->link_names[i], sizeof(dl->link_names[i]), "%s", l->name);
                dl->protocols[i] = l->protocol;
                r = plan->ops[i]->declare(l, i, vars, &n, DAEMON_VARS_MAX, names,
                                          DAEMON_NAMES_SIZE, &used);
                if (r < 0) {
                        r = errf(err, errsz, r, "link %s: cannot declare its variables: %s",
                                 l->name, r == -ENOSPC ? "too many variables" : strerror(-r));
                        goto out;
                }
                for (size_t k = before; k < n; k++)
                        if (vars[k].link != i) {
                                r = errf(err, errsz, -EINVAL, "link %s: variable %s declared "
                                         "for another link", l->name, vars[k].name);
                                goto out;
                        }
        }
        r = decl_check(cfg, vars, n, err, errsz);
        if (r < 0)
                goto out;
        r = decl_copy(dl, vars, n);
        if (r < 0) {
                errf(err, errsz, r, "out of memory");
                goto out;
        }
        *ret_decl = dl;
        dl = NULL;
out:
        decl_free(dl);
        free(names);
        free(vars);
        return r;
}

static bool decl_equal(const struct daemon_decl *a, const struct daemon_decl *b)
{
        if (strcmp(a->instance, b->instance) != 0 || a->has_group != b->has_group ||
            (a->has_group && a->gid != b->gid) || a->nlinks != b->nlinks ||
            a->nvars != b->nvars)
                return false;
        for (unsigned i = 0; i < a->nlinks; i++)
                if (strcmp(a->link_names[i], b->link_names[i]) != 0 ||
                    a->protocols[i] != b->protocols[i])
                        return false;
        for (uint32_t i = 0; i < a->nvars; i++) {
                const struct shm_var *x = &a->vars[i], *y = &b->vars[i];

                if (strcmp(x->name, y->name) != 0 || x->direction != y->direction ||
                    x->type != y->type || x->link != y->link || x->position != y->position ||
                    strcmp(x->peer, y->peer) != 0)
                        return false;
        }
        return true;
}

static int resolve_group(const char *name, gid_t *ret_gid, char *err, size_t errsz)
{
        struct group gr, *res = NULL;
        char *buf = malloc(DAEMON_GROUP_BUF);
        int r;

        if (!buf)
                return errf(err, errsz, -ENOMEM, "out of memory");
        r = getgrnam_r(name, &gr, buf, DAEMON_GROUP_BUF, &res);
        if (r == 0 && res)
                *ret_gid = gr.gr_gid;
        free(buf);
        if (r != 0)
                return errf(err, errsz, -r, "group \"%s\": %s", name, strerror(r));
        if (!res)
                return errf(err, errsz, -ENOENT, "group \"%s\" does not exist", name);
        return 0;
}

static int plan_paths(const struct config *cfg, struct daemon_plan *plan, char *err, size_t errsz)
{
        const char *dir = cfg->runtime_dir, *env = getenv(DAEMON_RUNTIME_DIR_ENV);
        size_t n;

        if (!cfg->runtime_dir_set && env && *env) {
                if (env[0] != '/')
                        return errf(err, errsz, -EINVAL, "%s=%s is not an absolute path",
                                    DAEMON_RUNTIME_DIR_ENV, env);
                dir = env;
        }
        if (strlen(dir) >= sizeof(plan->runtime_dir))
                return errf(err, errsz, -ENAMETOOLONG, "runtime directory %s too long", dir);
        strcpy(plan->runtime_dir, dir);
        n = (size_t)snprintf(plan->socket_path, sizeof(plan->socket_path), "%s/%s%s", dir,
                             cfg->instance, DAEMON_SOCKET_SUFFIX);
        if (n >= sizeof(plan->socket_path))
                return errf(err, errsz, -ENAMETOOLONG, "control socket path %s/%s%s too long "
                            "(at most %u bytes)", dir, cfg->instance, DAEMON_SOCKET_SUFFIX,
                            CONFIG_SOCKET_PATH_MAX - 1);
        return 0;
}

static void plan_clear(struct daemon_plan *plan)
{
        plan->decl = decl_free(plan->decl);
}

static int plan_make(const struct config *cfg, struct daemon_plan *plan, char *err, size_t errsz)
{
        int r;

        memset(plan, 0, sizeof(*plan));
        if (cfg->group[0]) {
                r = resolve_group(cfg->group, &plan->gid, err, errsz);
                if (r < 0)
                        return r;
                plan->has_group = true;
        }
        r = plan_paths(cfg, plan, err, errsz);
        if (r < 0)
                return r;
        for (unsigned i = 0; i < cfg->n_links; i++) {
                plan->ops[i] = link_ops_for(cfg->links[i].protocol);
                if (!plan->ops[i] || !plan->ops[i]->declare || !plan->ops[i]->create ||
                    !plan->ops[i]->destroy)
                        return errf(err, errsz, -EPROTONOSUPPORT, "link %s: protocol %s not "
                                    "available in this build", cfg->links[i].name,
                                    config_protocol_name(cfg->links[i].protocol));
        }
        return decl_build(cfg, plan, &plan->decl, err, errsz);
}

int daemon_check_config(const struct config *config, char *err, size_t errsz)
{
        struct daemon_plan plan;
        int r = plan_make(config, &plan, err, errsz);

        plan_clear(&plan);
        /* Only here, not at start: there a broken recording fails its link, not the daemon. */
        for (unsigned i = 0; r == 0 && i < config->n_links; i++) {
                const struct config_link *l = &config->links[i];
                char why[TRANSPORT_ERR_MAX];

                if (l->transport != CONFIG_TRANSPORT_REPLAY)
                        continue;
                r = replay_check_file(l->replay_file, why, sizeof(why));
                if (r < 0)
                        errf(err, errsz, r, "link %s: %s", l->name, why);
        }
        return r;
}

/* ---------------------------------------------------------------------------------------------
 * Tables */

/*
 * Room for what links learn at run time: each learned Pronto4 list may add learn_max names (in
 * ad hoc room), and a learned outbound one as many spare .out slots clients can write.
 */
static void tables_learned_room(const struct config *cfg, uint32_t *adhoc, uint32_t *out_spare)
{
        for (unsigned i = 0; i < cfg->n_links; i++) {
                const struct config_link *l = &cfg->links[i];

                if (l->protocol != CONFIG_PROTOCOL_SHAREDLINK)
                        continue;
                for (unsigned k = 0; k < l->sl.n_peers; k++) {
                        const struct config_peer *p = &l->sl.peers[k];

                        if (p->dialect != CONFIG_DIALECT_PRONTO4)
                                continue;
                        *adhoc += (p->outbound_learn + p->inbound_learn) * p->learn_max;
                        *out_spare += p->outbound_learn * p->learn_max;
                }
        }
}

static int tables_create(struct daemon *d, const struct config *cfg,
                         const struct daemon_plan *plan)
{
        struct shm_link_def links[CONFIG_LINKS_MAX];
        struct shm_table_config tc = {
                .instance = cfg->instance,
                .vars = plan->decl->vars,
                .nvars = plan->decl->nvars,
                .links = links,
                .nlinks = cfg->n_links,
                .adhoc_capacity = DAEMON_ADHOC_CAPACITY,
                .heartbeat_interval_ms = DAEMON_HEARTBEAT_MS,
                .has_group = plan->has_group,
                .gid = plan->gid,
                .control_socket = plan->socket_path,
        };
        int r;

        tables_learned_room(cfg, &tc.adhoc_capacity, &tc.out_spare);
        for (unsigned i = 0; i < cfg->n_links; i++) {
                links[i].name = cfg->links[i].name;
                links[i].protocol = config_protocol_name(cfg->links[i].protocol);
        }
        r = shm_table_create(&tc, &d->table);
        if (r < 0) {
                log_warnx("cannot create the shared memory tables of instance %s: %s%s",
                          cfg->instance, strerror(-r),
                          r == -EBUSY ? " (another sharedlinkd runs this instance)" : "");
                return r;
        }
        log_info("tables /sharedlink.%s.{in,out}: %" PRIu32 " variables, epoch %" PRIu64,
                 cfg->instance, plan->decl->nvars, shm_table_epoch(d->table));
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Control socket */

/* mkdir -p with mode for the directories it creates (not subject to the umask). */
static int mkdir_parents(const char *path, mode_t mode)
{
        char buf[CONFIG_PATH_MAX];
        struct stat st;

        if (strlen(path) >= sizeof(buf))
                return -ENAMETOOLONG;
        strcpy(buf, path);
        for (char *p = buf + 1;; p++) {
                char c = *p;

                if (c != '/' && c != '\0')
                        continue;
                *p = '\0';
                if (mkdir(buf, mode) == 0) {
                        if (chmod(buf, mode) < 0)
                                return -errno;
                } else if (errno != EEXIST) {
                        return -errno;
                }
                *p = c;
                if (!c)
                        break;
        }
        if (stat(path, &st) < 0)
                return -errno;
        return S_ISDIR(st.st_mode) ? 0 : -ENOTDIR;
}

static int control_open(struct daemon *d, const struct daemon_plan *plan)
{
        int r = mkdir_parents(plan->runtime_dir, DAEMON_RUNTIME_DIR_MODE);

        if (r < 0) {
                log_warnx("runtime directory %s: %s", plan->runtime_dir, strerror(-r));
                return r;
        }
        r = control_new(d->loop, plan->socket_path, plan->gid, plan->has_group,
                        daemon_on_request, d, &d->control);
        if (r < 0) {
                log_warnx("control socket %s: %s%s", plan->socket_path, strerror(-r),
                          r == -EADDRINUSE ? " (another daemon answers on it)" : "");
                return r;
        }
        log_info("control socket %s", plan->socket_path);
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Links */

static const char *link_status_text(const struct daemon_link *dl)
{
        const char *s;

        if (!dl->engine)
                return dl->failure;
        s = dl->ops->status ? dl->ops->status(dl->engine) : NULL;
        return s && *s ? s : "running";
}

/* The first word of the status text is "up". */
static bool link_is_up(const struct daemon_link *dl)
{
        const char *s = link_status_text(dl);

        return dl->engine && strncmp(s, "up", 2) == 0 &&
               (s[2] == '\0' || s[2] == ' ' || s[2] == ':' || s[2] == ',' || s[2] == ';');
}

static void link_stop(struct daemon *d, unsigned i)
{
        struct daemon_link *dl = d->links[i];

        if (!dl)
                return;
        if (dl->engine) {
                log_debug("link %s: stopping", dl->env.cfg->name);
                dl->ops->destroy(dl->engine);
        }
        recorder_tap_free(dl->tap, "link stopped");
        dconfig_unref(dl->dc);
        free(dl);
        d->links[i] = NULL;
}

/* Creates link i of dc's configuration. Only memory trouble fails; an engine that does not
 * start leaves a link marked failed (STATUS, shm state) until the next reload. */
static int link_start(struct daemon *d, unsigned i, struct daemon_config *dc,
                      const struct link_ops *ops)
{
        struct daemon_link *dl = calloc(1, sizeof(*dl));
        const struct config_link *l = &dc->config->links[i];
        struct recorder_link_info info = {
                .link = l->name,
                .protocol = config_protocol_name(l->protocol),
                .transport = config_transport_name(l->transport),
                .instance = dc->config->instance,
        };
        int r;

        if (!dl)
                return -ENOMEM;
        dl->tap = recorder_tap_new(&info, &d->rec_stats);
        if (!dl->tap) {
                free(dl);
                return -ENOMEM;
        }
        dl->d = d;
        dl->ops = ops;
        dl->dc = dconfig_ref(dc);
        dl->env.loop = d->loop;
        dl->env.table = d->table;
        dl->env.shm_link = i;
        dl->env.config = dc->config;
        dl->env.cfg = l;
        dl->env.tap = dl->tap;
        d->links[i] = dl;
        r = ops->create(&dl->env, &dl->engine);
        if (r < 0) {
                dl->engine = NULL;
                snprintf(dl->failure, sizeof(dl->failure), "failed: %s", strerror(-r));
                log_warnx("link %s (%s over %s): cannot start: %s", l->name,
                          config_protocol_name(l->protocol), config_transport_name(l->transport),
                          strerror(-r));
                shm_table_link_state(d->table, i, DAEMON_LINK_FAILED, "failed");
                return 0;
        }
        log_info("link %s (%s over %s): started", l->name, config_protocol_name(l->protocol),
                 config_transport_name(l->transport));
        return 0;
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

/* ---------------------------------------------------------------------------------------------
 * Outbound: client writes -> the engine of the variable's link */

/* Whether a link learns an outbound list at run time (a Pronto4 peer's outbound: learn). */
static bool link_learns_outbound(const struct config_link *cfg)
{
        if (cfg->protocol != CONFIG_PROTOCOL_SHAREDLINK)
                return false;
        for (unsigned i = 0; i < cfg->sl.n_peers; i++)
                if (cfg->sl.peers[i].outbound_learn)
                        return true;
        return false;
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

        /* An outbound name added at run time was learned by a SharedLink link: each link that
         * learns outbound lists gets it and ignores an id that is not one of its own. */
        if (change->id >= decl->nvars) {
                for (unsigned i = 0; i < d->n_links; i++) {
                        dl = d->links[i];
                        if (dl && dl->engine && dl->ops->outbound &&
                            link_learns_outbound(dl->env.cfg))
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

static void daemon_out_scan(struct daemon *d)
{
        int r = shm_table_out_scan(d->table, daemon_on_out_change, d);

        if (r == -EBADMSG)
                log_ratelimited(&d->out_rl, LOG_PRIO_WARNING, "outbound table of instance %s was "
                                "truncated or overwritten by a client: recreated empty",
                                d->dc->config->instance);
}

static void daemon_on_wake(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct daemon *d = arg;

        (void)fd;
        (void)revents;
        shm_table_out_wake_ack(d->table);
        d->wake_stamps[0] = shm_table_out_wake_stamp(d->table);
        d->wake_stamps[1] = evloop_now_ns(loop);
        daemon_out_scan(d);
        d->wake_stamps[0] = d->wake_stamps[1] = 0;
}

static int wake_start(struct daemon *d)
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

static void wake_stop(struct daemon *d)
{
        if (d->wake_fd >= 0)
                evloop_del_fd(d->loop, d->wake_fd);
        d->wake_fd = -1;    /* the fd belongs to the table, closed by shm_table_destroy */
}

/* ---------------------------------------------------------------------------------------------
 * Status, heartbeat, watchdog */

/* "N of M links up", then what is wrong with the others while it fits. With ready, sent in one
 * datagram with READY=1 (so that whoever waits for READY=1 also has the status it came with). */
static void daemon_status(struct daemon *d, bool ready)
{
        char buf[NOTIFY_STATUS_MAX];
        unsigned up = 0;
        size_t len;

        for (unsigned i = 0; i < d->n_links; i++)
                if (d->links[i] && link_is_up(d->links[i]))
                        up++;
        len = (size_t)snprintf(buf, sizeof(buf), "%u of %u links up", up, d->n_links);
        for (unsigned i = 0; i < d->n_links && len < sizeof(buf); i++) {
                const struct daemon_link *dl = d->links[i];

                if (!dl || link_is_up(dl))
                        continue;
                len += (size_t)snprintf(buf + len, sizeof(buf) - len, "; %s: %s",
                                        dl->env.cfg->name, link_status_text(dl));
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

static int timers_start(struct daemon *d)
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

static void timers_stop(struct daemon *d)
{
        evloop_timer_cancel(&d->watchdog);
        evloop_timer_cancel(&d->heartbeat);
}

/* ---------------------------------------------------------------------------------------------
 * Control requests answered by the core, and routing to the engines */

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

static void daemon_on_request(struct control_request *req, int argc, char **argv, void *arg)
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
        timers_stop(d);
        wake_stop(d);
        links_stop_all(d);
        d->control = control_free(d->control);
        d->table = shm_table_destroy(d->table);
        plan_clear(&d->plan);
        d->dc = dconfig_unref(d->dc);
        free(d->config_path);
        free(d);
        return NULL;
}

int daemon_new(struct evloop *loop, struct notify *notify, const char *config_path,
               struct config *config, struct daemon **ret_daemon)
{
        char err[DAEMON_ERROR_MAX];
        struct daemon *d = calloc(1, sizeof(*d));
        int r;

        if (!d || !(d->config_path = strdup(config_path))) {
                free(d);
                config_free(config);
                return -ENOMEM;
        }
        d->loop = loop;
        d->notify = notify;
        d->wake_fd = -1;
        stages_init(&d->out_stages, DAEMON_OUT_STAGES);
        evloop_timer_init(&d->heartbeat, loop, daemon_on_heartbeat, d);
        evloop_timer_init(&d->watchdog, loop, daemon_on_watchdog, d);
        log_ratelimit_init(&d->out_rl, "outbound table", LOG_RATELIMIT_INTERVAL_MS,
                           LOG_RATELIMIT_BURST);
        d->dc = dconfig_new(config);
        if (!d->dc) {
                r = -ENOMEM;
                goto fail;
        }
        r = plan_make(config, &d->plan, err, sizeof(err));
        if (r < 0) {
                log_warnx("%s: %s", config_path, err);
                goto fail;
        }
        r = tables_create(d, config, &d->plan);
        if (r < 0)
                goto fail;
        r = control_open(d, &d->plan);
        if (r < 0)
                goto fail;
        r = links_start_all(d, d->dc, &d->plan);
        if (r < 0)
                goto fail;
        r = wake_start(d);
        if (r < 0)
                goto fail;
        r = timers_start(d);
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
        plan_clear(&d->plan);
        d->plan = *np;
        memset(np, 0, sizeof(*np));
        dconfig_unref(d->dc);
        d->dc = ndc;
}

/* Same tables, new socket path or group: move the socket, links keep running. 0, or -errno
 * with the old socket back (or none, logged, if even that failed: links go on regardless). */
static int reload_socket(struct daemon *d, const struct daemon_plan *np)
{
        int r;

        d->control = control_free(d->control);
        r = control_open(d, np);
        if (r < 0 && control_open(d, &d->plan) < 0)
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

        timers_stop(d);
        wake_stop(d);
        links_stop_all(d);
        if (new_socket)
                d->control = control_free(d->control);
        d->table = shm_table_destroy(d->table);

        r = tables_create(d, ndc->config, np);
        if (r == 0 && new_socket)
                r = control_open(d, np);
        if (r == 0) {
                reload_install(d, ndc, np);
                installed = 1;
        } else {
                log_warnx("reload: cannot apply the new configuration; restoring the old one");
                d->table = shm_table_destroy(d->table);
                if (tables_create(d, d->dc->config, &d->plan) < 0) {
                        log_warnx("reload: cannot restore the old tables either; exiting");
                        evloop_exit(d->loop, 1);
                        return 0;
                }
                if (!d->control && control_open(d, &d->plan) < 0)
                        log_warnx("reload: no control socket any more; links keep running");
        }
        if (links_start_all(d, d->dc, &d->plan) < 0 || wake_start(d) < 0 ||
            timers_start(d) < 0) {
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

        notify_reloading(d->notify);
        log_notice("reload: reading %s", d->config_path);
        memset(&np, 0, sizeof(np));
        r = config_load_file(d->config_path, &nc, &cerr);
        if (r < 0) {
                log_warnx("reload: %s; keeping the running configuration", cerr.message);
                goto done;
        }
        ndc = dconfig_new(nc);
        if (!ndc) {
                r = -ENOMEM;
                goto done;
        }
        r = plan_make(nc, &np, err, sizeof(err));
        if (r < 0) {
                log_warnx("reload: %s: %s; keeping the running configuration", d->config_path,
                          err);
                goto done;
        }
        same_socket = strcmp(d->plan.socket_path, np.socket_path) == 0 &&
                      d->plan.has_group == np.has_group &&
                      (!np.has_group || d->plan.gid == np.gid);
        /* The header publishes the socket path once (layout 1.2): moving it takes new tables. */
        same_tables = decl_equal(d->plan.decl, np.decl) &&
                      strcmp(d->plan.socket_path, np.socket_path) == 0;
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
        plan_clear(&np);
        dconfig_unref(ndc);
        if (!evloop_exiting(d->loop))
                daemon_ready(d);
        return r;
}
