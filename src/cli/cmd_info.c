/*
 * slctl events and stats: the event ring, the daemon and its links, from the shared tables.
 */
#include "cli/cmd_info.h"

#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cli/counters.h"
#include "svc/json.h"
#include "cli/slctl.h"

#define NS_PER_S                1000000000ull
#define NS_PER_MS               1000000ull
#define EVENTS_BATCH            16
#define COUNTER_COLUMNS         3
#define AGE_SIZE                32
#define TIME_SIZE               48

static uint64_t now_mono_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * NS_PER_S + (uint64_t)ts.tv_nsec;
}

/* ---- events -------------------------------------------------------------------------------- */

/* Prints one event, and before it what was lost or a restart. */
static void event_print(const struct sl_event *ev)
{
        if (ev->flags & SL_EVENT_RESTARTED)
                printf("- - restart\n");
        if (ev->lost)
                printf("- - overrun lost=%" PRIu64 "\n", ev->lost);
        printf("%" PRIu64 " %s %s", ev->seq, ev->link_name[0] ? ev->link_name : "-",
               ev->type_name[0] ? ev->type_name : "unknown");
        if (ev->text[0])
                printf(" %s", ev->text);
        if (ev->flags & SL_EVENT_TRUNCATED)
                printf(" truncated=1");
        putchar('\n');
}

/* Milliseconds until deadline (-1: no deadline), or 0 when it passed. */
static int left_ms(uint64_t deadline)
{
        uint64_t now;

        if (!deadline)
                return -1;
        now = now_mono_ns();
        if (now >= deadline)
                return 0;
        return (int)((deadline - now + NS_PER_MS - 1u) / NS_PER_MS);
}

int cmd_info_events(struct slctl *s, int argc, char **argv)
{
        enum { O_COUNT, O_TIMEOUT, O_FOLLOW, O_NEW };
        static const struct args_opt opts[] = {
                [O_COUNT] = { "count", 1 }, [O_TIMEOUT] = { "timeout", 1 },
                [O_FOLLOW] = { "follow", 0 }, [O_NEW] = { "new", 0 }, { NULL, 0 },
        };
        struct sl_event *ev;
        struct args a;
        long count, timeout_ms, printed = 0;
        uint64_t cursor = 0, deadline = 0;
        uint32_t changes = 0;
        int code;

        code = slctl_args(s, argc, argv, opts, &a);
        if (code >= 0)
                return code;
        if (a.npos > 0)
                return slctl_usage(s, "events takes no arguments");
        if (a.given[O_TIMEOUT] && !a.given[O_FOLLOW])
                return slctl_usage(s, "--timeout bounds --follow: give both");
        code = slctl_count_timeout(s, a.value[O_COUNT], a.value[O_TIMEOUT], &count, &timeout_ms);
        if (code >= 0)
                return code;
        code = slctl_open(s, 0);
        if (code >= 0)
                return code;
        ev = calloc(EVENTS_BATCH, sizeof(*ev));
        if (!ev)
                return slctl_error(s, "out of memory");
        if (a.given[O_FOLLOW]) {
                setvbuf(stdout, NULL, _IOLBF, 0);
                slctl_interruptible();
        }
        if (timeout_ms >= 0)
                deadline = now_mono_ns() + (uint64_t)timeout_ms * NS_PER_MS;
        if (a.given[O_NEW])
                sl_events_now(s->c, &cursor);
        /* Change cursor before the first read: an event after it wakes the first wait. */
        sl_wait(s->c, &changes, 0);
        code = SLCTL_EXIT_OK;
        while (!count || printed < count) {
                int n, left, r;

                for (int i = 0; i < EVENTS_BATCH; i++)
                        ev[i].size = sizeof(ev[i]);
                n = sl_events_read(s->c, &cursor, ev, EVENTS_BATCH);
                if (n < 0) {
                        code = slctl_error(s, "reading events: %s", sl_strerror(n));
                        break;
                }
                for (int i = 0; i < n && (!count || printed < count); i++, printed++)
                        event_print(&ev[i]);
                if (n > 0)
                        continue;
                if (!a.given[O_FOLLOW])
                        break;
                left = left_ms(deadline);
                if (left == 0) {
                        if (count)
                                code = slctl_error(s, "%ld of %ld events within %ld ms", printed,
                                                   count, timeout_ms);
                        break;
                }
                r = sl_wait(s->c, &changes, left);
                if (r < 0) {
                        code = slctl_error(s, "waiting for events: %s", sl_strerror(r));
                        break;
                }
        }
        free(ev);
        return code;
}

/* ---- stats --------------------------------------------------------------------------------- */

/* The counters in scope, non-zero first, COUNTER_COLUMNS to a line. */
static void counters_text(const struct sl_counter *counters, unsigned n, unsigned scope)
{
        const struct sl_counter *shown[SL_COUNTERS_MAX];
        unsigned count;

        if (n > SL_COUNTERS_MAX)
                n = SL_COUNTERS_MAX;
        count = counters_select(counters, n, scope, shown);
        for (unsigned i = 0; i < count; i++) {
                int last = i + 1 == count || (i + 1) % COUNTER_COLUMNS == 0;

                printf("  %-20s %10" PRIu64 "%s", shown[i]->name, shown[i]->value,
                       last ? "\n" : "");
        }
}

static void counters_json(const struct sl_counter *counters, unsigned n)
{
        fputc('{', stdout);
        for (unsigned i = 0; i < n; i++)
                json_member_u64(stdout, i == 0, counters[i].name, counters[i].value);
        fputc('}', stdout);
}

static void format_real(char *buf, size_t size, uint64_t real_ns)
{
        time_t t = (time_t)(real_ns / NS_PER_S);
        struct tm tm;

        localtime_r(&t, &tm);
        strftime(buf, size, "%Y-%m-%dT%H:%M:%S", &tm);
}

static void daemon_text(struct slctl *s, const struct sl_daemon_info *d, int all)
{
        char age[AGE_SIZE], started[TIME_SIZE];

        slctl_format_age(age, sizeof(age), d->heartbeat_age_ns, 1);
        format_real(started, sizeof(started), d->started_real_ns);
        printf("instance %s: sharedlinkd pid %d, %s\n", s->instance, d->pid,
               d->alive ? "running" : "not running");
        printf("  epoch %016" PRIx64 ", started %s, ", d->epoch, started);
        if (d->heartbeat_interval_ms)
                printf("heartbeat %s ago (every %u ms)\n", age, d->heartbeat_interval_ms);
        else
                printf("no heartbeat\n");
        counters_text(d->counters, d->counter_count, all ? COUNTERS_ALL : COUNTERS_DAEMON);
}

static void link_text(const struct sl_link_info *l, int all)
{
        char age[AGE_SIZE];

        slctl_format_age(age, sizeof(age), l->state_age_ns, 1);
        printf("link %s (%s): ", l->name, l->protocol[0] ? l->protocol : "-");
        if (l->state_text[0])
                printf("%s for %s (state %d)\n", l->state_text, age, l->state);
        else
                printf("no state yet\n");      /* its engine never set one */
        counters_text(l->counters, l->counter_count,
                      all ? COUNTERS_ALL : counters_protocol_scope(l->protocol));
}

static void daemon_json(struct slctl *s, const struct sl_daemon_info *d)
{
        char epoch[24];

        json_member_string(stdout, 1, "instance", s->instance);
        json_key(stdout, 0, "daemon");
        fputc('{', stdout);
        json_key(stdout, 1, "pid");
        printf("%d", d->pid);
        json_member_bool(stdout, 0, "alive", d->alive);
        /* Hex text: a 64-bit epoch would lose bits as a JSON number in many parsers. */
        snprintf(epoch, sizeof(epoch), "%016" PRIx64, d->epoch);
        json_member_string(stdout, 0, "epoch", epoch);
        json_member_u64(stdout, 0, "heartbeat_age_ns", d->heartbeat_age_ns);
        json_member_u64(stdout, 0, "heartbeat_interval_ms", d->heartbeat_interval_ms);
        json_member_u64(stdout, 0, "started_real_ns", d->started_real_ns);
        json_key(stdout, 0, "counters");
        counters_json(d->counters, d->counter_count);
        fputc('}', stdout);
}

static void link_json(const struct sl_link_info *l, int first)
{
        fputs(first ? "\n{" : ",\n{", stdout);
        json_member_string(stdout, 1, "name", l->name);
        json_member_string(stdout, 0, "protocol", l->protocol);
        json_key(stdout, 0, "state");
        printf("%d", l->state);
        json_member_string(stdout, 0, "state_name", l->state_name);
        json_member_string(stdout, 0, "state_text", l->state_text);
        json_member_u64(stdout, 0, "state_age_ns", l->state_age_ns);
        json_key(stdout, 0, "counters");
        counters_json(l->counters, l->counter_count);
        fputc('}', stdout);
}

int cmd_info_stats(struct slctl *s, int argc, char **argv)
{
        enum { O_JSON, O_ALL };
        static const struct args_opt opts[] = {
                [O_JSON] = { "json", 0 }, [O_ALL] = { "all", 0 }, { NULL, 0 },
        };
        struct sl_daemon_info *d;
        struct sl_link_info *l;
        struct args a;
        int code, links, json, all;

        code = slctl_args(s, argc, argv, opts, &a);
        if (code >= 0)
                return code;
        if (a.npos > 0)
                return slctl_usage(s, "stats takes no arguments");
        json = a.given[O_JSON];
        all = a.given[O_ALL];           /* JSON always has every counter: a fixed set of keys */
        code = slctl_open(s, 1);
        if (code >= 0)
                return code;
        d = calloc(1, sizeof(*d));
        l = calloc(1, sizeof(*l));
        if (!d || !l) {
                free(d);
                free(l);
                return slctl_error(s, "out of memory");
        }
        d->size = sizeof(*d);
        code = sl_daemon_info(s->c, d);
        if (code < 0) {
                code = slctl_error(s, "reading the daemon's state: %s", sl_strerror(code));
                goto out;
        }
        if (json) {
                fputc('{', stdout);
                daemon_json(s, d);
                json_key(stdout, 0, "links");
                fputc('[', stdout);
        } else {
                daemon_text(s, d, all);
        }
        links = sl_link_count(s->c);
        for (int i = 0, shown = 0; i < links; i++) {
                int r = -EAGAIN;

                for (int t = 0; t < SLCTL_READ_TRIES && r == -EAGAIN; t++) {
                        memset(l, 0, sizeof(*l));
                        l->size = sizeof(*l);
                        r = sl_link_info(s->c, i, l);
                }
                if (r < 0) {
                        code = slctl_error(s, "reading link %d: %s", i, sl_strerror(r));
                        goto out;
                }
                if (json)
                        link_json(l, shown++ == 0);
                else
                        link_text(l, all);
        }
        if (json)
                fputs("]}\n", stdout);
        code = d->alive ? SLCTL_EXIT_OK : slctl_not_running(s, "these are the tables it left");
out:
        free(d);
        free(l);
        return code;
}
