/*
 * sharedlink-agility: times dog-agility runs from CIRCE gate passages and remote-control keys,
 * stores every completed run in SQLite and drives the wireless displays (docs/agility.md).
 *
 *   sharedlink-agility [-c FILE] [-n] [-v] [-V]
 *
 * A client of sharedlinkd through the public library only: events through sl_events_read, clock
 * synchronisation and displays through sl_circe_*. The rules are the pure engine's
 * (agility_run.h); this file feeds it and carries out what it asks (docs/agility.md §9).
 *
 * One thread runs the engine on the service's loop (svc/service.h: signals, SIGHUP the next
 * class, the watchdog, READY/STATUS), woken by the toolkit's waker when the tables changed
 * (svc/waker.h, as sharedlink-mqtt is), by one timer at the next thing due (the engine's
 * deadline, a retry) and by the request workers' results; libmicrohttpd's threads serve the
 * scoreboard (agilityd_http.h). The loop itself only reads the tables and the event ring
 * (shared memory, no waiting on the daemon): every control request (the clock sync, a display's
 * Visualize) is a round trip that a slow or stopped daemon holds for its whole timeout, so it
 * runs on a worker (agilityd_worker.h), one for the sync and one for the displays, each with its
 * own handle. Always
 * in the foreground, logging to stderr with <N> priority prefixes. Exit status: 0 after a clean
 * stop (SIGTERM, SIGINT) or a good -n check, 1 on a bad configuration or a failed start, 2 on a
 * usage error, 3 when another sharedlink-agility times the same link of the instance
 * (svc/lockfile.h).
 */
#include <errno.h>
#include <inttypes.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sharedlink.h>

#include "agility/agility_export.h"
#include "agility/agility_run.h"
#include "agility/agilityd_config.h"
#include "agility/agilityd_http.h"
#include "agility/agilityd_store.h"
#include "agility/agilityd_worker.h"
#include "svc/evloop.h"
#include "svc/lockfile.h"
#include "svc/log.h"
#include "svc/service.h"
#include "svc/backoff.h"
#include "svc/waker.h"

#define NS_PER_MS               1000000ull
#define STORE_RETRY_MS          5000u   /* a run the database refused is tried again */
#define EVENTS_BATCH            32
#define STATUS_MAX              256
#define COMMAND_WAIT_MS         0       /* a command to a link that is down fails at once */
#define CLOCK_SYNC_REQUIRED     "1"     /* 027:1, as the link publishes it */
/* "LINK.device.ADDR.FIELD" with any link name; one longer than a variable name finds nothing. */
#define VAR_NAME_BUF            (AGILITYD_NAME_MAX + 32)

#ifndef SHAREDLINK_VERSION
#define SHAREDLINK_VERSION      "unknown"
#endif

/* A worker's own handle on sharedlinkd, used on the worker's thread only (opened at its first
 * job; closed after the worker stopped, unless a job of it was abandoned). */
struct lane {
        char instance[AGILITYD_NAME_MAX];       /* "" : the default (taken once, at start) */
        struct sl_client *cl;
};

struct main_ctx {
        struct agilityd_config *cfg;    /* the running class; a reload replaces it whole */
        const char *path;               /* -c */
        struct agility_result results[AGILITY_COMPETITORS_MAX];
        bool unsaved[AGILITY_COMPETITORS_MAX];  /* completed, the database refused it */
        struct agility_run run;
        struct agilityd_store *store;
        struct agilityd_http *http;
        struct sl_client *cl;
        uint64_t ev_cursor;
        char display_addr[AGILITYD_DISPLAYS_MAX][SL_CIRCE_ADDRESS_SIZE];
        struct agility_display shown[AGILITYD_DISPLAYS_MAX];
        /* Each gate's LINK.device.ADDR.clock_sync variable (-1: not found yet) and its last
         * value: a change to 027:1 (a restarted device) is a lost synchronisation. */
        int sync_var[AGILITY_GATES_MAX];
        char sync_last[AGILITY_GATES_MAX][SL_VALUE_SIZE];
        struct service *svc;
        struct evloop *loop;
        struct evloop_timer step;       /* the next thing due (see turn()) */
        struct waker *waker;            /* once attached */
        /* The daemon's round trips run on two workers (agilityd_worker.h), never on the loop:
         * a clock sync may take 3 s, and a stopped daemon holds any request for its timeout.
         * One for the clock sync, one for the displays, so a Visualize never queues behind a
         * sync. */
        struct agilityd_worker *sync_worker, *display_worker;
        struct lane sync_lane, display_lane;
        bool sync_wanted;               /* the engine asked, not submitted yet */
        bool sync_busy;                 /* a sync is queued or running on the worker: more
                                         * asked for meanwhile make one sync after it */
        /* Bumped at every sync the engine asks for and at every class installed: a result of
         * another generation (a sync a reload overtook) is not this engine's. */
        uint64_t sync_gen;
        bool display_busy[AGILITYD_DISPLAYS_MAX];       /* a Visualize on its way */
        bool display_dirty[AGILITYD_DISPLAYS_MAX];      /* changed since: sent when it is back */
        bool db_error;                  /* the last store failed: said in STATUS= */
        bool ready;                     /* READY=1 sent */
        uint64_t last_ms;               /* the engine's clock never goes back */
        struct backoff attach;          /* sl_open retries while no daemon runs */
        uint64_t retry_at_ms;           /* next store retry, 0: none due */
        struct log_ratelimit display_rl;
        struct lockfile single;         /* one sharedlink-agility per link of an instance */
        char lock_instance[AGILITYD_NAME_MAX];  /* the instance of its name (from the start) */
        bool held_elsewhere;            /* another holds it: SERVICE_EXIT_HELD */
};

static void handle(struct main_ctx *ctx, struct agility_actions *acts);
static void reload(struct main_ctx *ctx);

static uint64_t now_ms(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / NS_PER_MS;
}

/* The engine's "now": the time something happened, never before what it was last told. */
static uint64_t engine_ms(struct main_ctx *ctx, uint64_t t)
{
        if (t < ctx->last_ms)
                t = ctx->last_ms;
        ctx->last_ms = t;
        return t;
}

/* ---- status ---------------------------------------------------------------------------------- */

/* The status text: states and reasons only, no counts (every change is a datagram to the
 * service manager). */
static void status_text(struct main_ctx *ctx, char *s, size_t size)
{
        snprintf(s, size, "class %s: %s, competitor %u%s%s",
                 ctx->cfg->class_name, agility_run_state_name(ctx->run.state),
                 (unsigned)ctx->run.current, ctx->cl ? "" : ", sharedlinkd not found",
                 ctx->db_error ? ", DATABASE NOT WRITABLE: completed runs kept in memory" : "");
}

/* READY=1 with the status: at start (the class is in, sharedlinkd was tried: one that is not
 * running is retried, not fatal) and after a reload. */
static void ready(struct main_ctx *ctx)
{
        char s[STATUS_MAX];

        status_text(ctx, s, sizeof(s));
        service_ready(ctx->svc, s);
        ctx->ready = true;
}

static void status_update(struct main_ctx *ctx)
{
        char s[STATUS_MAX];

        if (!ctx->ready)
                return;
        status_text(ctx, s, sizeof(s));
        service_status(ctx->svc, s);
}

/* ---- displays -------------------------------------------------------------------------------- */

/* Sends each display the fields that differ from what it shows, through the display worker. A
 * display has at most one Visualize on its way: what the engine changes meanwhile is sent,
 * as the difference from it, once that one is back (so the queue never holds more than one
 * job a display, and a display never gets a difference computed against a state it was not
 * sent). A display is taken to show what was sent; one that did not take it is unknown again
 * (it gets every field next time). */
static void displays_update(struct main_ctx *ctx)
{
        struct agility_display want;

        if (!ctx->cl || ctx->cfg->display_count == 0)
                return;
        agility_run_display(&ctx->run, &want);
        for (unsigned i = 0; i < ctx->cfg->display_count; i++) {
                struct agilityd_job job = { .kind = AGILITYD_JOB_VISUALIZE, .tag = i,
                                            .vis = { .size = sizeof(job.vis) } };
                struct agility_display next;
                int r;

                if (ctx->display_busy[i]) {
                        ctx->display_dirty[i] = true;
                        continue;
                }
                ctx->display_dirty[i] = false;
                if (agility_display_diff(&ctx->shown[i], &want, &job.vis, &next) == 0)
                        continue;
                snprintf(job.link, sizeof(job.link), "%s", ctx->cfg->link);
                snprintf(job.dest, sizeof(job.dest), "%s", ctx->display_addr[i]);
                r = agilityd_worker_submit(ctx->display_worker, &job);
                if (r == 0) {
                        ctx->shown[i] = next;
                        ctx->display_busy[i] = true;
                        continue;
                }
                agility_display_unknown(&ctx->shown[i]);
                log_ratelimited(&ctx->display_rl, LOG_PRIO_WARNING, "display %s: not sent: %s",
                                job.dest, strerror(-r));
        }
}

/* A Visualize is back (on the loop). */
static void display_done(struct main_ctx *ctx, const struct agilityd_result *res)
{
        unsigned i = (unsigned)res->tag;

        /* The class may have changed meanwhile: the index is the new class's display then,
         * and at worst that display gets every field again. */
        if (i >= AGILITYD_DISPLAYS_MAX)
                return;
        ctx->display_busy[i] = false;
        if (res->err < 0 && i < ctx->cfg->display_count) {
                agility_display_unknown(&ctx->shown[i]);
                log_ratelimited(&ctx->display_rl, LOG_PRIO_WARNING, "display %s: %s",
                                ctx->display_addr[i],
                                res->text[0] ? res->text : sl_strerror(res->err));
        }
        if (ctx->display_dirty[i])
                displays_update(ctx);
}

static int display_index(const struct main_ctx *ctx, uint32_t addr)
{
        for (unsigned i = 0; i < ctx->cfg->display_count; i++)
                if (ctx->cfg->displays[i] == addr)
                        return (int)i;
        return -1;
}

/* ---- results --------------------------------------------------------------------------------- */

/* A completed run goes to the database before anything shows it; one the database refuses
 * stays in memory (and on the displays), is tried again, and the error is loud. */
static void store_result(struct main_ctx *ctx, size_t index)
{
        char err[AGILITYD_STORE_ERROR_MAX];
        int r = agilityd_store_save(ctx->store, ctx->results, ctx->run.count, index, err,
                                    sizeof(err));

        if (r == 0) {
                const struct agility_result *res = &ctx->results[index];
                char t[AGILITY_EXPORT_TIME_MAX] = "no finish";

                ctx->unsaved[index] = false;
                if (res->finished)
                        agility_export_time(t, sizeof(t), res->finish_ms, res->finish_precision);
                log_msg(LOG_PRIO_INFO, "competitor %u: run stored: %s, faults %u, refusals %u%s, "
                        "placement %u", (unsigned)res->competitor, t, (unsigned)res->faults,
                        (unsigned)res->refusals, res->eliminated ? ", eliminated" : "",
                        (unsigned)res->placement);
                return;
        }
        ctx->unsaved[index] = true;
        ctx->db_error = true;
        ctx->retry_at_ms = now_ms() + STORE_RETRY_MS;
        log_msg(LOG_PRIO_ERR, "competitor %u: the run is NOT stored (kept in memory, retried "
                "every %u s): %s", (unsigned)ctx->results[index].competitor,
                STORE_RETRY_MS / 1000u, err);
}

static void store_retry(struct main_ctx *ctx, uint64_t now)
{
        bool left = false;

        if (!ctx->retry_at_ms || now < ctx->retry_at_ms)
                return;
        ctx->retry_at_ms = 0;
        ctx->db_error = false;
        for (size_t i = 0; i < ctx->run.count; i++)
                if (ctx->unsaved[i])
                        store_result(ctx, i);
        for (size_t i = 0; i < ctx->run.count; i++)
                left |= ctx->unsaved[i];
        if (!left)
                log_msg(LOG_PRIO_NOTICE, "database writable again: every completed run stored");
}

/* ---- clock synchronisation ------------------------------------------------------------------- */

/* Synchronize Clocks, on the sync worker: the loop goes on meanwhile, so events that come are
 * fed to the engine at once (in WaitingForSync a passage does not count: docs/agility.md §2).
 * One sync at a time (the daemon refuses a second on the link; the worker runs one job at a
 * time anyway): one the engine asks for while another is on its way starts when that one ends,
 * and however many it asks for meanwhile, one is sent. */
static void sync_start(struct main_ctx *ctx)
{
        struct agilityd_job job = { .kind = AGILITYD_JOB_SYNC_CLOCKS };
        struct agility_actions acts;
        int r = -ENOTCONN;

        if (!ctx->sync_wanted || ctx->sync_busy)
                return;
        ctx->sync_wanted = false;
        job.tag = ctx->sync_gen;
        snprintf(job.link, sizeof(job.link), "%s", ctx->cfg->link);
        if (ctx->cl)
                r = agilityd_worker_submit(ctx->sync_worker, &job);
        if (r == 0) {
                ctx->sync_busy = true;
                return;
        }
        log_msg(LOG_PRIO_WARNING, "clock sync on link %s: %s", ctx->cfg->link,
                r == -ENOTCONN ? "sharedlinkd not found" : strerror(-r));
        agility_run_sync_done(&ctx->run, engine_ms(ctx, now_ms()), &acts);
        handle(ctx, &acts);
}

/* A sync's result (on the loop): each device's outcome into the engine, then the end, in the
 * order the daemon gave them. */
static void sync_result(struct main_ctx *ctx, const struct agilityd_result *res)
{
        struct agility_actions acts;
        uint32_t dev;
        bool stale = res->tag != ctx->sync_gen;

        if (res->kind == AGILITYD_RESULT_DEVICE) {
                log_msg(LOG_PRIO_DEBUG, "clock sync: %s %s%s", res->addr,
                        res->succeeded ? "succeeded" : "timed out",
                        stale ? " (an earlier sync: ignored)" : "");
                if (stale || agilityd_address_parse(res->addr, &dev) < 0)
                        return;
                agility_run_sync_device(&ctx->run, engine_ms(ctx, now_ms()), dev,
                                        res->succeeded, &acts);
                handle(ctx, &acts);
                return;
        }
        ctx->sync_busy = false;
        if (res->err < 0)
                log_msg(LOG_PRIO_WARNING, "clock sync on link %s: %s", ctx->cfg->link,
                        res->text[0] ? res->text : sl_strerror(res->err));
        if (!stale) {
                agility_run_sync_done(&ctx->run, engine_ms(ctx, now_ms()), &acts);
                handle(ctx, &acts);
        }
        sync_start(ctx);                /* one asked for meanwhile */
}

/* A worker's result: the engine may have new deadlines, so a turn follows. */
static void on_result(const struct agilityd_result *res, void *arg)
{
        struct main_ctx *ctx = arg;

        if (res->job == AGILITYD_JOB_SYNC_CLOCKS)
                sync_result(ctx, res);
        else
                display_done(ctx, res);
        evloop_timer_arm(&ctx->step, 0, 0);
}

/* ---- the workers' side (their threads) ------------------------------------------------------- */

static int exec_sync_device(const char *addr, int succeeded, void *arg)
{
        struct agilityd_result res = { .kind = AGILITYD_RESULT_DEVICE,
                                       .succeeded = succeeded != 0 };

        snprintf(res.addr, sizeof(res.addr), "%s", addr);
        return agilityd_worker_post(arg, &res);        /* -ECANCELED ends the request */
}

/* Runs one job with the lane's own handle. */
static void exec_request(const struct agilityd_job *job, struct agilityd_worker_post *post,
                         struct agilityd_result *ret_done, void *arg)
{
        struct lane *lane = arg;
        int r = 0;

        if (!lane->cl) {
                r = sl_open(lane->instance[0] ? lane->instance : NULL, &lane->cl);
                if (r == 0)
                        r = sl_set_command_wait(lane->cl, COMMAND_WAIT_MS);
                if (r < 0)
                        lane->cl = sl_close(lane->cl);
        }
        if (r == 0 && job->kind == AGILITYD_JOB_SYNC_CLOCKS) {
                r = sl_circe_sync_clocks(lane->cl, job->link, exec_sync_device, post,
                                         ret_done->text, sizeof(ret_done->text));
        } else if (r == 0) {
                struct sl_circe_visualize vis = job->vis;
                const char *dest = job->dest;

                vis.dests = &dest;
                vis.dest_count = 1;
                r = sl_circe_visualize(lane->cl, job->link, &vis, ret_done->text,
                                       sizeof(ret_done->text));
        }
        ret_done->err = r;
}

/* ---- the engine's actions -------------------------------------------------------------------- */

static void notice(struct main_ctx *ctx, const struct agility_action *a)
{
        char dev[SL_CIRCE_ADDRESS_SIZE] = "-", name[VAR_NAME_BUF];

        if (a->device)
                agilityd_address_format(a->device, dev);
        snprintf(name, sizeof(name), "%s.device.%s.online", ctx->cfg->link, dev);
        /* A gate the link has never heard of is a wrong address in the class file, or a
         * device that is off: say so, rather than only that its sync failed. */
        if (a->notice == AGILITY_NOTICE_SYNC_FAILED && ctx->cl && sl_find(ctx->cl, name) < 0)
                log_msg(LOG_PRIO_ERR, "gate %s is not in the network of link %s: no device "
                        "with that address has reported (check gates: in %s)", dev,
                        ctx->cfg->link, ctx->path);
        log_msg(a->notice == AGILITY_NOTICE_SYNC_FAILED ? LOG_PRIO_WARNING : LOG_PRIO_NOTICE,
                "%s (device %s, competitor %u, state %s)", agility_run_notice_name(a->notice),
                dev, (unsigned)a->number, agility_run_state_name(ctx->run.state));
}

static void handle(struct main_ctx *ctx, struct agility_actions *acts)
{
        for (unsigned i = 0; i < acts->count; i++) {
                const struct agility_action *a = &acts->a[i];

                switch (a->kind) {
                case AGILITY_ACT_STATE:
                        log_msg(LOG_PRIO_INFO, "state %s -> %s, competitor %u",
                                agility_run_state_name(a->from), agility_run_state_name(a->to),
                                (unsigned)ctx->run.current);
                        break;
                case AGILITY_ACT_SYNC_CLOCKS:
                        ctx->sync_wanted = true;
                        ctx->sync_gen++;
                        break;
                case AGILITY_ACT_STORE_RESULT:
                        store_result(ctx, a->index);
                        break;
                case AGILITY_ACT_DISPLAY:
                        displays_update(ctx);
                        break;
                case AGILITY_ACT_NOTICE:
                        notice(ctx, a);
                        break;
                }
        }
        if (acts->overflow)
                log_msg(LOG_PRIO_WARNING, "some notices were dropped (too many at once)");
        agilityd_http_publish(ctx->http, ctx->cfg, &ctx->run, ctx->last_ms);
        status_update(ctx);
}

/* ---- a gate that needs a sync ---------------------------------------------------------------- */

static void sync_watch_reset(struct main_ctx *ctx)
{
        for (unsigned g = 0; g < AGILITY_GATES_MAX; g++) {
                ctx->sync_var[g] = -1;
                ctx->sync_last[g][0] = '\0';
        }
}

/* A gate whose Notify Status now says 027:1 (it restarted, or left and joined the network)
 * needs a clock sync: its passages are low precision until the next one (docs/agility.md §2). */
static void sync_watch(struct main_ctx *ctx)
{
        struct agility_actions acts;
        char name[VAR_NAME_BUF], addr[SL_CIRCE_ADDRESS_SIZE], v[SL_VALUE_SIZE];

        if (!ctx->cl)
                return;
        for (unsigned g = 0; g < ctx->run.gate_count; g++) {
                agilityd_address_format(ctx->run.gates[g], addr);
                if (ctx->sync_var[g] < 0) {
                        snprintf(name, sizeof(name), "%s.device.%s.clock_sync", ctx->cfg->link,
                                 addr);
                        ctx->sync_var[g] = sl_find(ctx->cl, name);
                        if (ctx->sync_var[g] < 0)
                                continue;       /* the gate has not reported yet */
                }
                if (sl_read(ctx->cl, ctx->sync_var[g], v, sizeof(v), NULL) < 0)
                        continue;
                if (strcmp(v, CLOCK_SYNC_REQUIRED) == 0 &&
                    strcmp(ctx->sync_last[g], CLOCK_SYNC_REQUIRED) != 0) {
                        log_msg(LOG_PRIO_INFO, "gate %s needs a clock sync", addr);
                        agility_run_sync_lost(&ctx->run, engine_ms(ctx, now_ms()),
                                              ctx->run.gates[g], &acts);
                        handle(ctx, &acts);
                }
                memcpy(ctx->sync_last[g], v, sizeof(v));
        }
}

/* ---- events ---------------------------------------------------------------------------------- */

/* The value of "key=" in an event's "key=value ..." text; false when absent. */
static bool event_field(const char *text, const char *key, char *out, size_t size)
{
        size_t kl = strlen(key);

        for (const char *p = text; *p; ) {
                size_t wl = strcspn(p, " ");

                if (wl > kl && strncmp(p, key, kl) == 0 && p[kl] == '=') {
                        size_t vl = wl - kl - 1;

                        if (vl >= size)
                                return false;
                        memcpy(out, p + kl + 1, vl);
                        out[vl] = '\0';
                        return true;
                }
                p += wl;
                p += strspn(p, " ");
        }
        return false;
}

static bool event_number(const char *text, const char *key, unsigned long max,
                         unsigned long *ret)
{
        char v[16], *end;

        if (!event_field(text, key, v, sizeof(v)) || v[0] < '0' || v[0] > '9')
                return false;
        errno = 0;
        *ret = strtoul(v, &end, 10);
        return !*end && !errno && *ret <= max;
}

static void on_event(struct main_ctx *ctx, const struct sl_event *ev)
{
        struct agility_actions acts;
        char addr[SL_CIRCE_ADDRESS_SIZE + 1];
        unsigned long keys = 0, sensor = 0;
        bool has_keys, has_sensor;
        uint32_t dev;
        int di;

        if (strcmp(ev->link_name, ctx->cfg->link) != 0 ||
            !event_field(ev->text, "device", addr, sizeof(addr)) ||
            agilityd_address_parse(addr, &dev) < 0)
                return;
        if (strcmp(ev->type_name, "action") == 0) {
                has_keys = event_number(ev->text, "keys", UINT16_MAX, &keys);
                has_sensor = event_number(ev->text, "sensor_time", UINT32_MAX, &sensor);
                log_msg(LOG_PRIO_DEBUG, "action %s", ev->text);
                /* The passage's received time is when the link heard it, not when we read
                 * the event: the low-precision time does not grow with our latency. */
                agility_run_action(&ctx->run, engine_ms(ctx, ev->mono_ns / NS_PER_MS), dev,
                                   has_keys, (uint16_t)keys, has_sensor, (uint32_t)sensor, &acts);
                handle(ctx, &acts);
        } else if (strcmp(ev->type_name, "device-online") == 0 &&
                   (di = display_index(ctx, dev)) >= 0) {
                /* A display back online shows what it showed at power-up: send everything. */
                agility_display_unknown(&ctx->shown[di]);
                displays_update(ctx);
        }
}

static void events_pump(struct main_ctx *ctx)
{
        struct sl_event ev[EVENTS_BATCH];
        int n;

        if (!ctx->cl)
                return;
        do {
                for (int i = 0; i < EVENTS_BATCH; i++)
                        ev[i].size = sizeof(ev[i]);
                n = sl_events_read(ctx->cl, &ctx->ev_cursor, ev, EVENTS_BATCH);
                for (int i = 0; i < n; i++) {
                        if (ev[i].lost)
                                log_msg(LOG_PRIO_ERR, "%" PRIu64 " events were lost before "
                                        "they could be read", ev[i].lost);
                        on_event(ctx, &ev[i]);
                        sync_start(ctx);
                }
        } while (n == EVENTS_BATCH);
        if (n < 0)
                log_msg(LOG_PRIO_WARNING, "events: %s", sl_strerror(n));
}

/* ---- attaching to sharedlinkd ---------------------------------------------------------------- */

/* The waker: the tables changed. */
static void on_change(void *arg)
{
        struct main_ctx *ctx = arg;

        evloop_timer_arm(&ctx->step, 0, 0);
}

static void attach_due(struct main_ctx *ctx, uint64_t now)
{
        const char *inst = ctx->cfg->instance[0] ? ctx->cfg->instance : NULL;
        int r;

        if (ctx->cl || !backoff_due(&ctx->attach, now))
                return;
        r = sl_open(inst, &ctx->cl);
        if (r == 0)
                r = sl_events_now(ctx->cl, &ctx->ev_cursor);
        if (r < 0) {
                ctx->cl = sl_close(ctx->cl);
                if (backoff_failed(&ctx->attach, now))
                        log_msg(LOG_PRIO_WARNING, "sharedlinkd instance %s: %s; retrying",
                                inst ? inst : "(default)", sl_strerror(r));
                return;
        }
        backoff_reset(&ctx->attach);
        if (waker_start(ctx->loop, ctx->cl, on_change, ctx, &ctx->waker) < 0)
                log_msg(LOG_PRIO_ERR, "no waker: changes are seen only at the next timer");
        log_msg(LOG_PRIO_INFO, "attached to sharedlinkd, link %s", ctx->cfg->link);
        for (unsigned i = 0; i < ctx->cfg->display_count; i++)
                agility_display_unknown(&ctx->shown[i]);
        displays_update(ctx);
}

/* ---- the loop -------------------------------------------------------------------------------- */

static uint64_t timeout_ms(struct main_ctx *ctx, uint64_t now)
{
        uint64_t at = agility_run_next_deadline(&ctx->run);

        if (!ctx->cl && backoff_due_ms(&ctx->attach) < at)
                at = backoff_due_ms(&ctx->attach);
        if (ctx->retry_at_ms && ctx->retry_at_ms < at)
                at = ctx->retry_at_ms;
        if (at == UINT64_MAX)
                return UINT64_MAX;
        return at <= now ? 0 : at - now;
}

/* What the loop does whenever something happened (the tables changed) or came due: attach to
 * sharedlinkd, the events into the engine, the engine's timers, a clock sync it asked for, a
 * store retry, the status; then the step timer at the next thing due. */
static void turn(struct main_ctx *ctx)
{
        struct agility_actions acts;
        uint64_t now = now_ms(), wait;
        int r;

        attach_due(ctx, now);
        /* Before the events: a passage after a restart counts as unsynchronised. */
        sync_watch(ctx);
        events_pump(ctx);
        if (agility_run_next_deadline(&ctx->run) <= now) {
                agility_run_tick(&ctx->run, engine_ms(ctx, now), &acts);
                handle(ctx, &acts);
        }
        sync_start(ctx);
        store_retry(ctx, now);
        status_update(ctx);
        wait = timeout_ms(ctx, now_ms());
        r = 0;
        if (wait == UINT64_MAX)
                evloop_timer_cancel(&ctx->step);        /* nothing due: the tables wake us */
        else
                r = evloop_timer_arm(&ctx->step, wait, 0);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "event loop: %s", strerror(-r));
                service_exit(ctx->svc, SERVICE_EXIT_FAILURE);
        }
}

static void on_step(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        (void)loop;
        (void)t;
        turn(arg);
}

/* The tables changed: a turn in the next round. */
static void on_reload(void *arg)
{
        reload(arg);
}

/* ---- start and stop -------------------------------------------------------------------------- */

static int check_only(const char *path)
{
        static struct agilityd_config cfg;     /* 200 KB: not on the stack */
        static struct agility_result results[AGILITY_COMPETITORS_MAX];
        static struct agility_run run;
        char err[AGILITYD_ERROR_MAX];

        if (agilityd_config_load(path, &cfg, err, sizeof(err)) < 0) {
                fprintf(stderr, "%s\n", err);
                return SERVICE_EXIT_FAILURE;
        }
        if (agility_run_init(&run, &cfg.cls, cfg.competitors, cfg.competitor_count, results,
                             0) < 0) {
                fprintf(stderr, "%s: the class breaks a rule of docs/agility.md §1\n", path);
                return SERVICE_EXIT_FAILURE;
        }
        return service_check_ok();
}

/* A class ready to run: its file, its database, its stored results. */
struct class_load {
        struct agilityd_config *cfg;
        struct agilityd_store *store;
        struct agility_result results[AGILITY_COMPETITORS_MAX];
        uint16_t last;
        struct agility_run check;       /* the class checked against the engine's rules */
};

static struct class_load *class_load_free(struct class_load *cl)
{
        if (cl) {
                agilityd_store_close(cl->store);
                free(cl->cfg);
                free(cl);
        }
        return NULL;
}

/* Reads the class file path, opens its database and loads its runs; NULL after logging why. */
static struct class_load *class_prepare(const char *path)
{
        char err[AGILITYD_ERROR_MAX > AGILITYD_STORE_ERROR_MAX ? AGILITYD_ERROR_MAX :
                 AGILITYD_STORE_ERROR_MAX];
        struct class_load *cl = calloc(1, sizeof(*cl));
        unsigned skipped = 0;
        int r = -ENOMEM;

        if (!cl || !(cl->cfg = malloc(sizeof(*cl->cfg)))) {
                log_msg(LOG_PRIO_ERR, "%s: out of memory", path);
                return class_load_free(cl);
        }
        r = agilityd_config_load(path, cl->cfg, err, sizeof(err));
        if (r == 0)
                r = agilityd_store_open(cl->cfg->database, cl->cfg->class_name, &cl->store, err,
                                        sizeof(err));
        if (r == 0)
                r = agilityd_store_load(cl->store, cl->cfg->competitors,
                                        cl->cfg->competitor_count, cl->results, &cl->last,
                                        &skipped, err, sizeof(err));
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "%s", err);
                return class_load_free(cl);
        }
        if (skipped)
                log_msg(LOG_PRIO_WARNING, "%s: %u stored runs of class %s are of competitors "
                        "no longer in %s: not shown", cl->cfg->database, skipped,
                        cl->cfg->class_name, cl->cfg->competitors_path);
        if (agility_run_init(&cl->check, &cl->cfg->cls, cl->cfg->competitors,
                             cl->cfg->competitor_count, cl->results, cl->last) < 0) {
                log_msg(LOG_PRIO_ERR, "%s: the class breaks a rule of docs/agility.md §1", path);
                return class_load_free(cl);
        }
        return cl;
}

/* Makes cl the running class (Offline: the caller starts it); cl is consumed. */
/*
 * Takes the lock of link of the instance (svc/lockfile.h) into l: two sharedlink-agility on one
 * CIRCE controller link would both drive its displays and both record every run. The database
 * is SQLite's to share (its own locking; runs are stored by class). 0 or -errno (logged).
 */
static int take_lock(struct main_ctx *ctx, struct lockfile *l, const char *link)
{
        const char *parts[] = { ctx->lock_instance, "agility", link };
        char what[2 * AGILITYD_NAME_MAX + 32];

        lockfile_init(l);
        snprintf(what, sizeof(what), "times link %s of instance %s", link, ctx->lock_instance);
        return lockfile_take_service(l, "sharedlink-agility", what, parts, 3);
}

/* A reload that names another link moves the lock to it first; 0 or -errno (logged). */
static int move_lock(struct main_ctx *ctx, const char *link)
{
        struct lockfile l;
        int r;

        if (strcmp(link, ctx->cfg->link) == 0)
                return 0;
        r = take_lock(ctx, &l, link);
        if (r < 0)
                return r;
        lockfile_release(&ctx->single);
        ctx->single = l;
        return 0;
}

static void class_install(struct main_ctx *ctx, struct class_load *cl)
{
        struct agilityd_config *old = ctx->cfg;
        unsigned stored = 0;

        agilityd_store_close(ctx->store);
        ctx->cfg = cl->cfg;
        ctx->store = cl->store;
        cl->cfg = NULL;
        cl->store = NULL;
        memcpy(ctx->results, cl->results, sizeof(ctx->results));
        memset(ctx->unsaved, 0, sizeof(ctx->unsaved));
        /* Checked in class_prepare: the same class, competitors and results pass again. */
        agility_run_init(&ctx->run, &ctx->cfg->cls, ctx->cfg->competitors,
                         ctx->cfg->competitor_count, ctx->results, cl->last);
        class_load_free(cl);
        /* The scoreboard's threads read the names under its lock: they move to the new class
         * before the old one is freed. */
        agilityd_http_publish(ctx->http, ctx->cfg, &ctx->run, ctx->last_ms);
        free(old);
        for (size_t i = 0; i < ctx->run.count; i++)
                stored += ctx->results[i].completed;
        for (unsigned i = 0; i < ctx->cfg->display_count; i++) {
                agilityd_address_format(ctx->cfg->displays[i], ctx->display_addr[i]);
                agility_display_unknown(&ctx->shown[i]);
        }
        sync_watch_reset(ctx);
        /* A sync still on its way was the old class's: its results are not the new one's. */
        ctx->sync_wanted = false;
        ctx->sync_gen++;
        log_msg(LOG_PRIO_INFO, "%s: class %s, %zu competitors, %u runs stored in %s", ctx->path,
                ctx->cfg->class_name, ctx->run.count, stored, ctx->cfg->database);
}

/* SIGHUP: the next class. A file that does not load leaves the running class as it is; so does
 * a run in progress or a completed run the database has not taken yet (they would be lost). */
static void reload(struct main_ctx *ctx)
{
        struct agility_actions acts;
        struct class_load *cl;
        char old_host[AGILITYD_HOST_MAX], old_instance[AGILITYD_NAME_MAX];
        uint16_t old_port = ctx->cfg->http_port;

        if (ctx->run.state >= AGILITY_START_PASSED && ctx->run.state <= AGILITY_FINISH_PASSED) {
                log_msg(LOG_PRIO_WARNING, "SIGHUP: a run is in progress (%s): complete or reset "
                        "it, then reload; the class %s stays",
                        agility_run_state_name(ctx->run.state), ctx->cfg->class_name);
                ready(ctx);
                return;
        }
        for (size_t i = 0; i < ctx->run.count; i++)
                if (ctx->unsaved[i]) {
                        log_msg(LOG_PRIO_ERR, "SIGHUP: competitor %u's run is not stored yet: "
                                "the class %s stays", (unsigned)ctx->results[i].competitor,
                                ctx->cfg->class_name);
                        ready(ctx);
                        return;
                }
        cl = class_prepare(ctx->path);
        if (!cl) {
                log_msg(LOG_PRIO_ERR, "SIGHUP: %s not loaded: the class %s stays", ctx->path,
                        ctx->cfg->class_name);
                ready(ctx);
                return;
        }
        if (move_lock(ctx, cl->cfg->link) < 0) {
                log_msg(LOG_PRIO_ERR, "SIGHUP: link %s is taken: the class %s stays",
                        cl->cfg->link, ctx->cfg->class_name);
                class_load_free(cl);
                ready(ctx);
                return;
        }
        snprintf(old_host, sizeof(old_host), "%s", ctx->cfg->http_host);
        snprintf(old_instance, sizeof(old_instance), "%s", ctx->cfg->instance);
        if (strcmp(old_host, cl->cfg->http_host) != 0 || old_port != cl->cfg->http_port ||
            strcmp(old_instance, cl->cfg->instance) != 0)
                log_msg(LOG_PRIO_WARNING, "SIGHUP: instance and http take effect at the next "
                        "start only");
        log_msg(LOG_PRIO_NOTICE, "SIGHUP: class %s ends, class %s loaded", ctx->cfg->class_name,
                cl->cfg->class_name);
        class_install(ctx, cl);
        agility_run_start_class(&ctx->run, engine_ms(ctx, now_ms()), &acts);
        handle(ctx, &acts);
        ready(ctx);
        evloop_timer_arm(&ctx->step, 0, 0);     /* the new class's timers */
}

static int setup(struct main_ctx *ctx, const struct service_desc *desc, const char *path)
{
        static const struct service_ops ops = { .reload = on_reload };   /* stop: at once */
        char err[AGILITYD_ERROR_MAX];
        struct class_load *cl;
        const char *inst;
        uint16_t port = 0;
        int r;

        ctx->path = path;
        cl = class_prepare(path);
        if (!cl)
                return -EINVAL;
        class_install(ctx, cl);
        /* Before the link and the scoreboard see us. The instance is the one sl_open takes. */
        inst = ctx->cfg->instance[0] ? ctx->cfg->instance : getenv("SHAREDLINK_INSTANCE");
        snprintf(ctx->lock_instance, sizeof(ctx->lock_instance), "%s",
                 inst && inst[0] ? inst : "default");
        r = take_lock(ctx, &ctx->single, ctx->cfg->link);
        ctx->held_elsewhere = r == -EBUSY;
        if (r < 0)
                return r;
        log_ratelimit_init(&ctx->display_rl, "displays", LOG_RATELIMIT_INTERVAL_MS,
                           LOG_RATELIMIT_BURST);
        /* The signals are blocked from here on: the threads below inherit the mask. */
        r = service_new(desc, &ops, ctx, &ctx->svc);
        if (r < 0)
                return r;
        ctx->loop = service_loop(ctx->svc);
        evloop_timer_init(&ctx->step, ctx->loop, on_step, ctx);
        backoff_reset(&ctx->attach);
        snprintf(ctx->sync_lane.instance, sizeof(ctx->sync_lane.instance), "%s",
                 ctx->cfg->instance);
        ctx->display_lane = ctx->sync_lane;
        r = agilityd_worker_start(ctx->loop, exec_request, &ctx->sync_lane, on_result, ctx,
                                  &ctx->sync_worker);
        if (r == 0)
                r = agilityd_worker_start(ctx->loop, exec_request, &ctx->display_lane, on_result,
                                          ctx, &ctx->display_worker);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "request workers: %s", strerror(-r));
                return r;
        }
        r = agilityd_http_start(ctx->cfg, &ctx->http, &port, err, sizeof(err));
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "%s", err);
                return r;
        }
        log_msg(LOG_PRIO_INFO, "scoreboard at http://%s%s%s:%u/",
                strchr(ctx->cfg->http_host, ':') ? "[" : "", ctx->cfg->http_host,
                strchr(ctx->cfg->http_host, ':') ? "]" : "", (unsigned)port);
        log_msg(LOG_PRIO_INFO, "sharedlink-agility %s: link %s of instance %s", SHAREDLINK_VERSION,
                ctx->cfg->link, ctx->cfg->instance[0] ? ctx->cfg->instance : "(default)");
        return 0;
}

/* The class starts (SetupCompleted, the displays), sharedlinkd is tried, READY=1. */
static void start(struct main_ctx *ctx)
{
        struct agility_actions acts;

        agility_run_start_class(&ctx->run, engine_ms(ctx, now_ms()), &acts);
        handle(ctx, &acts);
        attach_due(ctx, now_ms());
        ready(ctx);
        turn(ctx);
}

/* Stops a worker (docs/agility.md §9: never waits for a request on its way) and says what it
 * left; its lane's handle is closed unless a request still uses it. */
static struct agilityd_worker *worker_stop(struct agilityd_worker *w, struct lane *lane)
{
        struct agilityd_worker_stats st;

        if (!w)
                return NULL;
        agilityd_worker_stop(w, &st);
        if (st.abandoned)
                log_msg(LOG_PRIO_NOTICE, "stopping with a %s on its way to sharedlinkd: not "
                        "waited for, its result is dropped",
                        st.abandoned_kind == AGILITYD_JOB_SYNC_CLOCKS ? "clock sync" :
                        "display update");
        else
                lane->cl = sl_close(lane->cl);
        if (st.dropped)
                log_msg(LOG_PRIO_NOTICE, "stopping: %" PRIu64 " queued requests not sent",
                        st.dropped);
        if (st.refused)
                log_msg(LOG_PRIO_WARNING, "%" PRIu64 " requests were refused (queue full)",
                        st.refused);
        return NULL;
}

static void teardown(struct main_ctx *ctx)
{
        if (ctx->loop)
                evloop_timer_cancel(&ctx->step);
        ctx->waker = waker_stop(ctx->waker);
        for (size_t i = 0; i < ctx->run.count; i++)
                if (ctx->unsaved[i])
                        log_msg(LOG_PRIO_ERR, "competitor %u: stopping with the run NOT stored",
                                (unsigned)ctx->results[i].competitor);
        ctx->http = agilityd_http_stop(ctx->http);
        ctx->display_worker = worker_stop(ctx->display_worker, &ctx->display_lane);
        ctx->sync_worker = worker_stop(ctx->sync_worker, &ctx->sync_lane);
        ctx->cl = sl_close(ctx->cl);
        ctx->store = agilityd_store_close(ctx->store);
        lockfile_release(&ctx->single);
        ctx->svc = service_free(ctx->svc);
        free(ctx->cfg);
}

int main(int argc, char **argv)
{
        static const struct service_desc desc = {
                .name = "sharedlink-agility", .version = SHAREDLINK_VERSION,
                .config_default = AGILITYD_CONFIG_DEFAULT, .check = check_only,
        };
        static struct main_ctx ctx = { 0 };
        struct service_args args;
        int r = service_args(&desc, argc, argv, &args);

        if (r != SERVICE_CONTINUE)
                return r;
        service_start(&args);
        lockfile_init(&ctx.single);
        r = SERVICE_EXIT_FAILURE;
        if (setup(&ctx, &desc, args.config) == 0) {
                start(&ctx);
                r = service_run(ctx.svc);
        } else if (ctx.held_elsewhere) {
                r = SERVICE_EXIT_HELD;
        }
        teardown(&ctx);
        return r;
}
