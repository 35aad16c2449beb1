/*
 * slctl list, get, set, watch: the shared variables, straight from the shared-memory tables.
 */
#include "cli/cmd_vars.h"

#include <errno.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "svc/json.h"
#include "cli/slctl.h"

#define NS_PER_S                1000000000ull
#define NS_PER_MS               1000000ull
#define AGE_SIZE                32
#define FLAGS_SIZE              64
#define TIME_SIZE               48

static const char *direction_name(int direction)
{
        return direction == SL_DIR_OUT ? "out" : "in";
}

static const char *type_name(int type)
{
        switch (type) {
        case SL_VAR_LONG:       return "long";
        case SL_VAR_DOUBLE:     return "double";
        default:                return "string";
        }
}

/* Link names by index, read once (links are few: their count is bounded by the layout). */
struct link_names {
        int n;
        char (*name)[SL_LINK_NAME_SIZE];
};

static void link_names_load(struct slctl *s, struct link_names *ln)
{
        struct sl_link_info *info = calloc(1, sizeof(*info));
        int n = sl_link_count(s->c);

        ln->n = 0;
        ln->name = n > 0 ? calloc((size_t)n, sizeof(*ln->name)) : NULL;
        if (!info || !ln->name) {
                free(info);
                return;
        }
        for (int i = 0; i < n; i++) {
                info->size = sizeof(*info);
                if (sl_link_info(s->c, i, info) == 0)
                        snprintf(ln->name[i], sizeof(ln->name[i]), "%s", info->name);
        }
        ln->n = n;
        free(info);
}

/* The name of link index link, "" when none or unknown. */
static const char *link_names_get(const struct link_names *ln, int link)
{
        return link >= 0 && link < ln->n ? ln->name[link] : "";
}

/* "valid,stale,..." or "-". */
static void flags_text(char *buf, size_t size, uint32_t meta_flags, uint32_t var_flags)
{
        static const struct {
                uint32_t bit;
                const char *name;
        } meta_names[] = {
                { SL_FLAG_VALID, "valid" },
                { SL_FLAG_STALE, "stale" },
                { SL_FLAG_OUTBOUND, "outbound" },
                { SL_FLAG_REPAIRED, "repaired" },
        };
        size_t len = 0;

        buf[0] = '\0';
        for (size_t i = 0; i < sizeof(meta_names) / sizeof(meta_names[0]); i++)
                if (meta_flags & meta_names[i].bit)
                        len += (size_t)snprintf(buf + len, size - len, "%s%s", len ? "," : "",
                                                meta_names[i].name);
        if (var_flags & SL_VAR_ADHOC)
                len += (size_t)snprintf(buf + len, size - len, "%sadhoc", len ? "," : "");
        if (len == 0)
                snprintf(buf, size, "-");
}

/* ---- list ---------------------------------------------------------------------------------- */

struct row {
        struct sl_var_info info;
        struct sl_meta meta;
        char link[SL_LINK_NAME_SIZE];
        char value[SL_VALUE_SIZE];
        char age[AGE_SIZE];
        char flags[FLAGS_SIZE];
};

/* Reads every variable into rows (ids that read -ENOENT are left out); returns how many, or -1. */
static int rows_collect(struct slctl *s, struct row **ret_rows)
{
        int count = sl_count(s->c), n = 0;
        struct link_names ln;
        struct row *rows;

        if (count < 0)
                return -1;
        rows = calloc((size_t)count + 1u, sizeof(*rows));
        if (!rows)
                return -1;
        link_names_load(s, &ln);
        for (int id = 0; id < count; id++) {
                struct row *r = &rows[n];
                int len;

                r->info.size = sizeof(r->info);
                r->meta.size = sizeof(r->meta);
                if (sl_info(s->c, id, &r->info) < 0)
                        continue;
                len = slctl_read(s, id, r->value, sizeof(r->value), &r->meta);
                if (len < 0)
                        continue;
                snprintf(r->link, sizeof(r->link), "%s", link_names_get(&ln, r->info.link));
                slctl_format_age(r->age, sizeof(r->age), r->meta.age_ns, r->meta.mono_ns != 0);
                flags_text(r->flags, sizeof(r->flags), r->meta.flags, r->info.flags);
                n++;
        }
        free(ln.name);
        *ret_rows = rows;
        return n;
}

static const char *or_dash(const char *s)
{
        return *s ? s : "-";
}

static int width(int w, const char *s)
{
        int len = (int)strlen(s);

        return len > w ? len : w;
}

static void list_text(const struct row *rows, int n)
{
        int wn = 4, wl = 4, wp = 4, wa = 3, wf = 5;

        for (int i = 0; i < n; i++) {
                wn = width(wn, rows[i].info.name);
                wl = width(wl, or_dash(rows[i].link));
                wp = width(wp, or_dash(rows[i].info.peer));
                wa = width(wa, rows[i].age);
                wf = width(wf, rows[i].flags);
        }
        printf("%-*s %-3s %-*s %-*s %-6s %*s %-*s %s\n", wn, "NAME", "DIR", wl, "LINK", wp, "PEER",
               "TYPE", wa, "AGE", wf, "FLAGS", "VALUE");
        for (int i = 0; i < n; i++) {
                const struct row *r = &rows[i];

                /* No padding after the flags when there is no value: no trailing blanks. */
                printf("%-*s %-3s %-*s %-*s %-6s %*s %-*s%s%s\n", wn, r->info.name,
                       direction_name(r->info.direction), wl, or_dash(r->link), wp,
                       or_dash(r->info.peer), type_name(r->info.type), wa, r->age,
                       r->value[0] ? wf : 0, r->flags, r->value[0] ? " " : "", r->value);
        }
}

static void json_member_or_null(FILE *f, const char *key, const char *value)
{
        json_key(f, 0, key);
        if (*value)
                json_string(f, value);
        else
                fputs("null", f);
}

static void list_json(struct slctl *s, const struct row *rows, int n)
{
        fputc('{', stdout);
        json_member_string(stdout, 1, "instance", s->instance);
        json_key(stdout, 0, "variables");
        fputc('[', stdout);
        for (int i = 0; i < n; i++) {
                const struct row *r = &rows[i];

                fputs(i ? ",\n{" : "\n{", stdout);
                json_member_string(stdout, 1, "name", r->info.name);
                json_member_string(stdout, 0, "direction", direction_name(r->info.direction));
                json_member_or_null(stdout, "link", r->link);
                json_member_or_null(stdout, "peer", r->info.peer);
                json_member_string(stdout, 0, "type", type_name(r->info.type));
                json_key(stdout, 0, "position");
                if (r->info.position >= 0)
                        printf("%d", r->info.position);
                else
                        fputs("null", stdout);
                json_member_string(stdout, 0, "value", r->value);
                json_member_bool(stdout, 0, "valid", !!(r->meta.flags & SL_FLAG_VALID));
                json_member_bool(stdout, 0, "stale", !!(r->meta.flags & SL_FLAG_STALE));
                json_member_bool(stdout, 0, "outbound", !!(r->meta.flags & SL_FLAG_OUTBOUND));
                json_member_bool(stdout, 0, "repaired", !!(r->meta.flags & SL_FLAG_REPAIRED));
                json_member_bool(stdout, 0, "adhoc", !!(r->info.flags & SL_VAR_ADHOC));
                json_key(stdout, 0, "age_ns");
                if (r->meta.mono_ns)
                        printf("%llu", (unsigned long long)r->meta.age_ns);
                else
                        fputs("null", stdout);
                json_member_u64(stdout, 0, "sequence", r->meta.sequence);
                json_member_u64(stdout, 0, "updated_real_ns", r->meta.real_ns);
                fputc('}', stdout);
        }
        fputs("]}\n", stdout);
}

int cmd_vars_list(struct slctl *s, int argc, char **argv)
{
        static const struct args_opt opts[] = { { "json", 0 }, { NULL, 0 } };
        struct row *rows = NULL;
        struct args a;
        int code, n;

        code = slctl_args(s, argc, argv, opts, &a);
        if (code >= 0)
                return code;
        if (a.npos > 0)
                return slctl_usage(s, "list takes no names (try `slctl get NAME`)");
        code = slctl_open(s, 0);
        if (code >= 0)
                return code;
        n = rows_collect(s, &rows);
        if (n < 0)
                return slctl_error(s, "out of memory");
        if (a.given[0])
                list_json(s, rows, n);
        else
                list_text(rows, n);
        free(rows);
        return SLCTL_EXIT_OK;
}

/* ---- get ----------------------------------------------------------------------------------- */

int cmd_vars_get(struct slctl *s, int argc, char **argv)
{
        static const struct args_opt opts[] = { { "strict", 0 }, { NULL, 0 } };
        char (*values)[SL_VALUE_SIZE];
        struct args a;
        int code, bad = 0;

        code = slctl_args(s, argc, argv, opts, &a);
        if (code >= 0)
                return code;
        if (a.npos == 0)
                return slctl_usage(s, "give at least one variable name");
        code = slctl_open(s, 0);
        if (code >= 0)
                return code;
        values = calloc((size_t)a.npos, sizeof(*values));
        if (!values)
                return slctl_error(s, "out of memory");
        /* Everything is read before anything is printed: a failure prints nothing. */
        for (int i = 0; i < a.npos; i++) {
                struct sl_meta meta = { .size = sizeof(meta) };
                int id = sl_find(s->c, a.pos[i]), r;

                if (id < 0) {
                        slctl_error(s, "no variable called \"%s\" (see `slctl list`)", a.pos[i]);
                        bad = 1;
                        continue;
                }
                r = slctl_read(s, id, values[i], sizeof(values[i]), &meta);
                if (r < 0) {
                        slctl_error(s, "%s: %s", a.pos[i], sl_strerror(r));
                        bad = 1;
                } else if (a.given[0] && !(meta.flags & SL_FLAG_VALID)) {
                        slctl_error(s, "%s: no valid value", a.pos[i]);
                        bad = 1;
                } else if (a.given[0] && (meta.flags & SL_FLAG_STALE)) {
                        slctl_error(s, "%s: the value is stale (link down or peer silent)",
                                    a.pos[i]);
                        bad = 1;
                }
        }
        if (!bad)
                for (int i = 0; i < a.npos; i++)
                        printf("%s\n", values[i]);
        free(values);
        return bad ? SLCTL_EXIT_ERROR : SLCTL_EXIT_OK;
}

/* ---- set ----------------------------------------------------------------------------------- */

int cmd_vars_set(struct slctl *s, int argc, char **argv)
{
        struct args a;
        const char *name, *value;
        char why[SL_WRITE_REASON_SIZE];
        int code, id, r;

        code = slctl_args(s, argc, argv, NULL, &a);
        if (code >= 0)
                return code;
        if (a.npos != 2)
                return slctl_usage(s, "give a name and a value");
        name = a.pos[0];
        value = a.pos[1];
        code = slctl_open(s, 0);
        if (code >= 0)
                return code;
        id = sl_find(s->c, name);
        if (id < 0)
                return slctl_error(s, "no variable called \"%s\" (see `slctl list`)", name);
        r = slctl_write(s, id, value);
        switch (r) {
        case 0:
                return SLCTL_EXIT_OK;
        case -EPERM:
                return slctl_error(s, "%s is an inbound variable: only the daemon writes it "
                                   "(outbound ones say \"out\" in `slctl list`)", name);
        case -EINVAL:
                if (sl_write_check(s->c, id, value, why, sizeof(why)) == -EINVAL)
                        return slctl_error(s, "%s: value refused: %s", name, why);
                return slctl_error(s, "value refused: the wire carries printable ASCII except "
                                   "| [ ], at most %d bytes (this one: %zu bytes)",
                                   SL_VALUE_SIZE - 1, strlen(value));
        case -EACCES:
                return slctl_error(s, "permission denied: writing %s needs the daemon's group",
                                   name);
        case -ENOTCONN:
                return slctl_not_running(s, "nobody would send the value");
        default:
                return slctl_error(s, "%s: %s", name, sl_strerror(r));
        }
}

/* ---- watch --------------------------------------------------------------------------------- */

struct watched {
        int id;
        const char *name;               /* argv, or NULL: from sl_info */
        int known;                      /* a first value was printed */
        int fresh;                      /* appeared while watching: its first value is a change */
        uint32_t flags;
        char value[SL_VALUE_SIZE];
};

struct watch {
        struct watched *vars;
        int n;
        int all;                        /* no names given: follow new ids too */
};

static uint64_t now_ns(clockid_t clock)
{
        struct timespec ts;

        clock_gettime(clock, &ts);
        return (uint64_t)ts.tv_sec * NS_PER_S + (uint64_t)ts.tv_nsec;
}

/* Local time, ISO 8601 with milliseconds. */
static void format_time(char *buf, size_t size, uint64_t real_ns)
{
        time_t t = (time_t)(real_ns / NS_PER_S);
        struct tm tm;
        size_t len;

        localtime_r(&t, &tm);
        len = strftime(buf, size, "%Y-%m-%dT%H:%M:%S", &tm);
        snprintf(buf + len, size - len, ".%03u", (unsigned)(real_ns % NS_PER_S / NS_PER_MS));
}

/* Adds ids up to sl_count (all) once; fresh: they appeared while watching. 0 or -ENOMEM. */
static int watch_grow(struct slctl *s, struct watch *w, int fresh)
{
        int count = sl_count(s->c);
        struct watched *vars;

        if (!w->all || count <= w->n)
                return 0;
        vars = realloc(w->vars, (size_t)count * sizeof(*vars));
        if (!vars)
                return -ENOMEM;
        w->vars = vars;
        for (int id = w->n; id < count; id++) {
                memset(&vars[id], 0, sizeof(vars[id]));
                vars[id].id = id;
                vars[id].fresh = fresh;
        }
        w->n = count;
        return 0;
}

/*
 * Reads one variable; prints a line when its value or its state (valid, stale) changed. A
 * periodic refresh that rewrites the same value is not a change. Returns 1 if a change (not the
 * first value) was printed.
 */
static int watch_one(struct slctl *s, struct watched *v)
{
        struct sl_meta meta = { .size = sizeof(meta) };
        struct sl_var_info info = { .size = sizeof(info) };
        char value[SL_VALUE_SIZE], when[TIME_SIZE];
        const char *name = v->name;
        int r, new_value;

        r = slctl_read(s, v->id, value, sizeof(value), &meta);
        if (r < 0)
                return 0;       /* gone with a daemon restart, or busy: seen at the next change */
        if (!name) {
                if (sl_info(s->c, v->id, &info) < 0)
                        return 0;
                name = info.name;
        }
        new_value = !v->known || strcmp(value, v->value) != 0;
        if (!new_value && meta.flags == v->flags)
                return 0;
        /* A new value carries the time it was updated; a change of state, the time it was seen. */
        format_time(when, sizeof(when),
                    new_value && meta.real_ns ? meta.real_ns : now_ns(CLOCK_REALTIME));
        if (!(meta.flags & SL_FLAG_VALID))
                printf("%s %s [invalid]%s\n", when, name,
                       meta.flags & SL_FLAG_STALE ? " [stale]" : "");
        else
                printf("%s %s%s%s%s\n", when, name, value[0] ? " " : "", value,
                       meta.flags & SL_FLAG_STALE ? " [stale]" : "");
        r = v->known || v->fresh;
        v->known = 1;
        v->flags = meta.flags;
        memcpy(v->value, value, sizeof(value));
        return r;
}

/* Resolves the names given (all, when none). Returns -1 or an exit code. */
static int watch_setup(struct slctl *s, const struct args *a, struct watch *w)
{
        memset(w, 0, sizeof(*w));
        if (a->npos == 0) {
                w->all = 1;
                return watch_grow(s, w, 0) < 0 ? slctl_error(s, "out of memory") : -1;
        }
        w->vars = calloc((size_t)a->npos, sizeof(*w->vars));
        if (!w->vars)
                return slctl_error(s, "out of memory");
        w->n = a->npos;
        for (int i = 0; i < a->npos; i++) {
                w->vars[i].id = sl_find(s->c, a->pos[i]);
                w->vars[i].name = a->pos[i];
                if (w->vars[i].id < 0)
                        return slctl_error(s, "no variable called \"%s\" (see `slctl list`)",
                                           a->pos[i]);
        }
        return -1;
}

int cmd_vars_watch(struct slctl *s, int argc, char **argv)
{
        static const struct args_opt opts[] = { { "count", 1 }, { "timeout", 1 }, { NULL, 0 } };
        struct watch w;
        struct args a;
        long count, timeout_ms, changes = 0;
        uint64_t deadline = 0;
        uint32_t cursor = 0;
        int code;

        code = slctl_args(s, argc, argv, opts, &a);
        if (code >= 0)
                return code;
        code = slctl_count_timeout(s, a.value[0], a.value[1], &count, &timeout_ms);
        if (code >= 0)
                return code;
        code = slctl_open(s, 0);
        if (code >= 0)
                return code;
        setvbuf(stdout, NULL, _IOLBF, 0);       /* a reader on a pipe sees each change at once */
        slctl_interruptible();
        if (timeout_ms >= 0)
                deadline = now_ns(CLOCK_MONOTONIC) + (uint64_t)timeout_ms * NS_PER_MS;
        code = watch_setup(s, &a, &w);
        if (code >= 0) {
                free(w.vars);
                return code;
        }
        /* Cursor first, values second: a change in between shows at the first wait. */
        sl_wait(s->c, &cursor, 0);
        for (int i = 0; i < w.n; i++)
                watch_one(s, &w.vars[i]);
        code = SLCTL_EXIT_OK;
        while (!count || changes < count) {
                int left = -1, r;

                if (deadline) {
                        uint64_t now = now_ns(CLOCK_MONOTONIC);

                        if (now >= deadline) {
                                if (count)
                                        code = slctl_error(s, "%ld of %ld changes within %ld ms",
                                                           changes, count, timeout_ms);
                                break;
                        }
                        left = (int)((deadline - now + NS_PER_MS - 1u) / NS_PER_MS);
                }
                r = sl_wait(s->c, &cursor, left);
                if (r < 0) {
                        code = slctl_error(s, "waiting for changes: %s", sl_strerror(r));
                        break;
                }
                if (r == 0)
                        continue;
                if (watch_grow(s, &w, 1) < 0) {
                        code = slctl_error(s, "out of memory");
                        break;
                }
                for (int i = 0; i < w.n && (!count || changes < count); i++)
                        changes += watch_one(s, &w.vars[i]);
        }
        free(w.vars);
        return code;
}
