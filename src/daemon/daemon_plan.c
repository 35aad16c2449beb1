/*
 * Plans (daemon_plan.h): engines, group, socket path, declaration.
 */
#define _GNU_SOURCE     /* getgrnam_r */
#include "daemon/daemon_plan.h"

#include <errno.h>
#include <grp.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shm/table.h"

#define DAEMON_GROUP_BUF        16384   /* getgrnam_r buffer */
#define DAEMON_SOCKET_SUFFIX    ".sock"

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
        /* Said at -n as at a start: the reference configuration names the house's group, which
         * exists only once the sysusers.d snippet that make install puts in place was applied. */
        if (!res)
                return errf(err, errsz, -ENOENT, "group \"%s\" does not exist: create it "
                            "(groupadd --system %s; for \"sharedlink\", systemd-sysusers once "
                            "make install has put its sysusers.d file in place), or leave out "
                            "group:", name, name);
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

void daemon_plan_where(const struct daemon_plan *plan, const char *path, char *buf, size_t size)
{
        if (plan->err_line)
                snprintf(buf, size, "%s:%u:%u", path, plan->err_line, plan->err_column);
        else
                snprintf(buf, size, "%s", path);
}

void daemon_plan_clear(struct daemon_plan *plan)
{
        plan->decl = decl_free(plan->decl);
}

/* Room for what links learn at run time, as their engines say (link_ops.learning), which the
 * tables must hold beside the configured names: checked here, so that `-n` refuses a
 * configuration whose tables could not be created. */
static int plan_learned_room(const struct config *cfg, struct daemon_plan *plan, char *err,
                             size_t errsz)
{
        uint64_t learned = 0;

        plan->adhoc_capacity = DAEMON_ADHOC_CAPACITY;
        for (unsigned i = 0; i < cfg->n_links; i++) {
                struct link_learning learning = { 0 };

                if (!plan->ops[i]->learning)
                        continue;
                plan->ops[i]->learning(&cfg->links[i], &learning);
                learned += learning.adhoc;
                plan->out_spare += learning.out_spare;
        }
        if (plan->decl->nvars + DAEMON_ADHOC_CAPACITY + learned > SHM_CAPACITY_MAX)
                return errf(err, errsz, -E2BIG, "the links may learn %" PRIu64 " names at run "
                            "time; with the %" PRIu32 " configured and %u for ad hoc names "
                            "that is more than an instance's tables hold (%u): lower learn_max "
                            "or the number of peers that learn", learned, plan->decl->nvars,
                            DAEMON_ADHOC_CAPACITY, SHM_CAPACITY_MAX);
        plan->adhoc_capacity += (uint32_t)learned;
        return 0;
}

int daemon_plan_make(const struct config *cfg, struct daemon_plan *plan, char *err,
                     size_t errsz)
{
        int r;

        memset(plan, 0, sizeof(*plan));
        if (cfg->group[0]) {
                r = resolve_group(cfg->group, &plan->gid, err, errsz);
                if (r < 0) {
                        plan->err_line = cfg->group_line;
                        plan->err_column = cfg->group_column;
                        return r;
                }
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
        r = decl_build(cfg, plan, &plan->decl, err, errsz);
        if (r < 0)
                return r;
        return plan_learned_room(cfg, plan, err, errsz);
}

bool daemon_plan_same_tables(const struct daemon_plan *a, const struct daemon_plan *b)
{
        return decl_equal(a->decl, b->decl) && strcmp(a->socket_path, b->socket_path) == 0;
}

bool daemon_plan_same_socket(const struct daemon_plan *a, const struct daemon_plan *b)
{
        return strcmp(a->socket_path, b->socket_path) == 0 && a->has_group == b->has_group &&
               (!b->has_group || a->gid == b->gid);
}
