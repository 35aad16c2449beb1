/*
 * sharedlink-ros2: the tables of a sharedlinkd instance as ROS 2 topics over DDS (Cyclone DDS),
 * with no ROS installed (see ros2_bridge.h for what goes where, docs/ros2.md for the contract).
 *
 *   sharedlink-ros2 [-c FILE] [-n] [-v] [-V]
 *
 * The bridge runs on the service's event loop (svc/service.h), with one exception for speed: the
 * toolkit's waker thread (svc/waker.h), which hears first that the tables changed, publishes the
 * values and events itself (on_thread) instead of waking the loop to do it, since a wake-up of a
 * sleeping thread is the largest cost of the path on a virtual machine; it rings the loop only
 * for what the loop alone does (diagnostics due, a retry, STATUS=). ctx.lock keeps the bridge
 * single-owner at any moment: every call into it, on either thread, holds the lock. DDS's
 * listener threads ring an eventfd on the loop when a write or a writer arrived. Init: log,
 * configuration, service (loop, notify, signals, watchdog), bridge (the DDS participant), the
 * waker once attached; teardown in reverse. A
 * stop is at once (nothing is in flight that a later start could not redo); SIGHUP has no
 * reload (logged). -n checks the file, then, when the daemon runs, the variables it names and
 * the topics they map to. Exit status: 0 after a clean stop or a good -n check, 1 on a bad
 * configuration or a failed start (a DDS domain that cannot be created), 2 on a usage error, 3
 * when another sharedlink-ros2 bridges the same instance to the same namespace and DDS domain
 * (svc/lockfile.h).
 */
#include <errno.h>
#include <poll.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sharedlink.h>

#include "ros2/ros2_bridge.h"
#include "ros2/ros2_config.h"
#include "svc/cursor.h"
#include "svc/lockfile.h"
#include "svc/log.h"
#include "svc/service.h"
#include "svc/backoff.h"
#include "svc/waker.h"

#define NS_PER_MS               1000000ull
#define TICK_MS                 1000u   /* /diagnostics, rescan (staleness by heartbeat) */
#define RETRY_MS                20u     /* events history full, or written events not all
                                         * acknowledged (cursor_file): pump again this soon */
#define DRAIN_MS                2000    /* at a stop: the events readers' acknowledgements */

#ifndef SHAREDLINK_VERSION
#define SHAREDLINK_VERSION      "unknown"
#endif

struct main_ctx {
        struct ros2_config cfg;
        struct service *svc;
        struct evloop *loop;            /* the service's */
        struct ros2_bridge *b;
        struct evloop_timer step;       /* the next thing due */
        struct waker *waker;            /* once attached */
        bool fd_added;
        bool ready;
        struct backoff attach;          /* sl_open retries while no daemon runs */
        uint64_t tick_ns;
        pthread_mutex_t lock;           /* b and dirty: the loop's and the waker thread's */
        bool dirty;                     /* scan on the loop: attached, or a scan failed */
        struct lockfile single;         /* one bridge per instance, namespace and domain */
        bool held_elsewhere;            /* another holds it: SERVICE_EXIT_HELD */
};

static void turn(struct main_ctx *ctx);

/* Values that changed, then events; under ctx->lock, on either thread. */
static void publish(struct main_ctx *ctx)
{
        ctx->dirty = ros2_bridge_scan(ctx->b) < 0;
        ros2_bridge_pump(ctx->b);
}

/* On the waker's thread: the hot path, without the loop's wake-up. The loop is rung for what
 * only it does: a failed scan's retry, diagnostics (a link's state, a new plan), the events
 * history's retry timer, STATUS=. */
static bool on_change_thread(void *arg)
{
        struct main_ctx *ctx = arg;
        bool loop;

        pthread_mutex_lock(&ctx->lock);
        publish(ctx);
        loop = ctx->dirty || ros2_bridge_diag_due(ctx->b) || ros2_bridge_events_blocked(ctx->b) ||
               ros2_bridge_cursor_pending(ctx->b);
        pthread_mutex_unlock(&ctx->lock);
        return loop;
}

/* On the loop, after on_change_thread asked for it. */
static void on_change(void *arg)
{
        turn(arg);
}

static void on_dds(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct main_ctx *ctx = arg;

        (void)loop;
        (void)fd;
        (void)revents;
        pthread_mutex_lock(&ctx->lock);
        ros2_bridge_dds(ctx->b);
        pthread_mutex_unlock(&ctx->lock);
        turn(ctx);
}

static void on_step(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        (void)loop;
        (void)t;
        turn(arg);
}

static void attach_due(struct main_ctx *ctx, uint64_t now)
{
        const struct waker_opts opts = {
                .on_thread = on_change_thread, .spin_us = ctx->cfg.wait_spin_us,
        };
        int r;

        if (ros2_bridge_client(ctx->b) || !backoff_due(&ctx->attach, now / NS_PER_MS))
                return;
        r = ros2_bridge_attach(ctx->b);
        if (r < 0) {
                if (backoff_failed(&ctx->attach, now / NS_PER_MS))
                        log_msg(LOG_PRIO_WARNING, "sharedlinkd instance: %s; retrying",
                                sl_strerror(r));
                return;
        }
        backoff_reset(&ctx->attach);
        if (waker_start_with(ctx->loop, ros2_bridge_client(ctx->b), on_change, ctx, &opts,
                             &ctx->waker) < 0)
                log_msg(LOG_PRIO_WARNING, "rescanning every %u ms only", TICK_MS);
        ctx->dirty = true;
}

/* STATUS= with states only (READY=1 the first time: a daemon that is down is retried). */
static void status_update(struct main_ctx *ctx)
{
        char s[128];

        snprintf(s, sizeof(s), "namespace %s, %s", ros2_bridge_namespace(ctx->b),
                 ros2_bridge_status(ctx->b));
        if (ctx->ready) {
                service_status(ctx->svc, s);
                return;
        }
        service_ready(ctx->svc, s);
        ctx->ready = true;
}

/* Attach, a scan on the tick (staleness, and a waker that could not start) or after a failed
 * one, events, diagnostics when due; then sleep until the next tick, attach retry or events
 * retry. */
static void turn(struct main_ctx *ctx)
{
        uint64_t now = evloop_clock_ns(), at;
        bool tick = now >= ctx->tick_ns;
        int r;

        if (evloop_exiting(ctx->loop))
                return;
        pthread_mutex_lock(&ctx->lock);
        attach_due(ctx, now);
        if (tick)
                ctx->tick_ns = now + TICK_MS * NS_PER_MS;
        if (ctx->dirty || tick)
                publish(ctx);
        else
                ros2_bridge_pump(ctx->b);
        if (tick || ros2_bridge_diag_due(ctx->b))
                ros2_bridge_diagnostics(ctx->b);
        status_update(ctx);
        at = ctx->tick_ns;
        if (!ros2_bridge_client(ctx->b) && backoff_due_ms(&ctx->attach) * NS_PER_MS < at)
                at = backoff_due_ms(&ctx->attach) * NS_PER_MS;
        if ((ros2_bridge_events_blocked(ctx->b) || ros2_bridge_cursor_pending(ctx->b)) &&
            now + RETRY_MS * NS_PER_MS < at)
                at = now + RETRY_MS * NS_PER_MS;
        pthread_mutex_unlock(&ctx->lock);
        r = evloop_timer_arm(&ctx->step, at <= now ? 0 : (at - now + NS_PER_MS - 1) / NS_PER_MS,
                             0);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "event loop: %s", strerror(-r));
                service_exit(ctx->svc, SERVICE_EXIT_FAILURE);
        }
}

static int check_only(const char *path)
{
        char err[ROS2_ERROR_MAX];
        struct ros2_config cfg;
        int r;

        if (ros2_config_load(path, &cfg, err, sizeof(err)) < 0) {
                fprintf(stderr, "%s\n", err);
                return SERVICE_EXIT_FAILURE;
        }
        if (ros2_config_check_cursor(&cfg, path, err, sizeof(err)) < 0) {
                fprintf(stderr, "%s\n", err);
                return SERVICE_EXIT_FAILURE;
        }
        r = ros2_bridge_check(&cfg, path, err, sizeof(err));
        if (r == -ENOENT)
                fprintf(stderr, "%s: sharedlinkd is not running: variable names and topic "
                        "collisions not checked\n", path);
        else if (r < 0) {
                fprintf(stderr, "%s\n", err);
                return SERVICE_EXIT_FAILURE;
        }
        return service_check_ok();
}

/* cursor_file's default: beside the lock, under its name (instance, namespace and domain: one
 * bridge's place each), in the runtime directory. A cursor counts only within one daemon run,
 * which never outlives the runtime directory, so a place that survives a reboot buys nothing. */
static int cursor_default(struct main_ctx *ctx)
{
        size_t n = strlen(ctx->single.path), sl = strlen(LOCKFILE_SUFFIX);

        if (ctx->cfg.cursor_file[0])
                return 0;
        if (n < sl || n - sl + strlen(CURSOR_SUFFIX) >= sizeof(ctx->cfg.cursor_file)) {
                log_msg(LOG_PRIO_ERR, "%s: too long for the events' cursor: set cursor_file",
                        ctx->single.path);
                return -ENAMETOOLONG;
        }
        snprintf(ctx->cfg.cursor_file, sizeof(ctx->cfg.cursor_file), "%.*s" CURSOR_SUFFIX,
                 (int)(n - sl), ctx->single.path);
        return 0;
}

/* One bridge per instance, namespace and DDS domain (svc/lockfile.h), before DDS sees us: a
 * second one would publish everything twice and fight the first over every write. A name or
 * domain that does not resolve is left to ros2_bridge_new, which says why. */
static int take_lock(struct main_ctx *ctx, const char *program)
{
        char instance[ROS2_INSTANCE_MAX], ns[ROS2_NAMESPACE_MAX], domain[16];
        char what[ROS2_INSTANCE_MAX + ROS2_NAMESPACE_MAX + 64];
        const char *parts[] = { instance, "ros2", domain, ns };
        unsigned id;
        int r;

        if (ros2_config_names(&ctx->cfg, instance, ns) < 0 ||
            ros2_config_domain(&ctx->cfg, &id) < 0)
                return 0;
        snprintf(domain, sizeof(domain), "%u", id);
        snprintf(what, sizeof(what), "bridges instance %s to namespace %s on DDS domain %u",
                 instance, ns, id);
        r = lockfile_take_service(&ctx->single, program, what, parts, 4);
        ctx->held_elsewhere = r == -EBUSY;
        return r < 0 ? r : cursor_default(ctx);
}

static int setup(struct main_ctx *ctx, const struct service_desc *desc, const char *path)
{
        static const struct service_ops ops = { 0 };    /* stop at once, no reload */
        char err[ROS2_ERROR_MAX];
        int r;

        if (ros2_config_load(path, &ctx->cfg, err, sizeof(err)) < 0) {
                log_msg(LOG_PRIO_ERR, "%s", err);
                return -EINVAL;
        }
        r = service_new(desc, &ops, ctx, &ctx->svc);
        if (r < 0)
                return r;
        ctx->loop = service_loop(ctx->svc);
        evloop_timer_init(&ctx->step, ctx->loop, on_step, ctx);
        r = take_lock(ctx, desc->name);
        if (r < 0)
                return r;
        r = ros2_bridge_new(&ctx->cfg, &ctx->b, err, sizeof(err));
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "%s: %s", path, err);
                return r;
        }
        r = evloop_add_fd(ctx->loop, ros2_bridge_fd(ctx->b), POLLIN, on_dds, ctx);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "event loop: %s", strerror(-r));
                return r;
        }
        ctx->fd_added = true;
        backoff_reset(&ctx->attach);
        log_msg(LOG_PRIO_INFO, "sharedlink-ros2 %s: %s, topics %s/...", SHAREDLINK_VERSION, path,
                ros2_bridge_namespace(ctx->b));
        return 0;
}

static void teardown(struct main_ctx *ctx)
{
        if (ctx->loop)
                evloop_timer_cancel(&ctx->step);
        if (ctx->fd_added)
                evloop_del_fd(ctx->loop, ros2_bridge_fd(ctx->b));
        ctx->waker = waker_stop(ctx->waker);
        /* The events written are acknowledged by now, or soon: a restart repeats none. */
        if (ctx->b && ros2_bridge_cursor_flush(ctx->b, DRAIN_MS) == -EAGAIN)
                log_msg(LOG_PRIO_NOTICE, "events: not acknowledged within %d ms: a restart "
                        "repeats those since the last acknowledgement", DRAIN_MS);
        ctx->b = ros2_bridge_free(ctx->b);
        lockfile_release(&ctx->single);
        ctx->svc = service_free(ctx->svc);
}

int main(int argc, char **argv)
{
        static const struct service_desc desc = {
                .name = "sharedlink-ros2", .version = SHAREDLINK_VERSION,
                .config_default = ROS2_CONFIG_DEFAULT, .check = check_only,
        };
        static struct main_ctx ctx = { .lock = PTHREAD_MUTEX_INITIALIZER };
        struct service_args args;
        int r = service_args(&desc, argc, argv, &args);

        if (r != SERVICE_CONTINUE)
                return r;
        service_start(&args);
        lockfile_init(&ctx.single);
        r = SERVICE_EXIT_FAILURE;
        if (setup(&ctx, &desc, args.config) == 0) {
                turn(&ctx);
                r = service_run(ctx.svc);
        } else if (ctx.held_elsewhere) {
                r = SERVICE_EXIT_HELD;
        }
        teardown(&ctx);
        return r;
}
