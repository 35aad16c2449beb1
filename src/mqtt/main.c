/*
 * sharedlink-mqtt: bridges a sharedlinkd instance to an MQTT broker (see bridge.h for what goes
 * where, bridge_mqtt.h for the connection).
 *
 *   sharedlink-mqtt [-c FILE] [-n] [-v] [-V]
 *
 * One thread runs everything (the tables, libmosquitto, the cursor) from one poll loop. A
 * second, tiny thread only sleeps in sl_wait (a futex, which poll cannot watch) and rings an
 * eventfd when the tables changed. Always in the foreground, logging to stderr with <N>
 * priority prefixes. Exit status: 0 after a clean stop (SIGTERM, SIGINT) or a good -n check, 1 on
 * a bad configuration or a failed start, 2 on a usage error.
 */
#include <errno.h>
#include <inttypes.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <sys/signalfd.h>
#include <time.h>
#include <unistd.h>

#include <mosquitto.h>
#include <sharedlink.h>

#include "mqtt/bridge.h"
#include "mqtt/bridge_config.h"
#include "mqtt/bridge_format.h"
#include "mqtt/bridge_mqtt.h"
#include "svc/log.h"
#include "svc/notify.h"
#include "svc/service.h"

#define NS_PER_MS               1000000ull
#define WAKER_SLICE_MS          250     /* sl_wait slice: how soon the waker sees a stop */
#define TICK_MS                 1000u   /* rescan anyway (staleness by heartbeat), stats */
#define ATTACH_MIN_MS           100u    /* sl_open retries while no daemon runs ... */
#define ATTACH_MAX_MS           5000u   /* ... doubling to this */
#define STATUS_MAX              320     /* a state and a reason per side */

#ifndef SHAREDLINK_VERSION
#define SHAREDLINK_VERSION      "unknown"
#endif

struct main_ctx {
        struct bridge_config cfg;
        struct bridge *b;
        struct bridge_mqtt *bm;
        struct notify *notify;
        int sig_fd, wake_fd;
        pthread_t waker;
        bool waker_running;
        atomic_bool stop_waker;
        bool stopping;
        uint64_t stop_deadline_ns;
        unsigned attach_ms;
        uint64_t attach_ns;             /* next sl_open attempt */
        uint64_t tick_ns;
        uint64_t sync_ns;               /* next fsync of the cursor */
        uint64_t watchdog_ns, watchdog_interval_ns;
        uint64_t stats_version;
        bool dirty;                     /* the tables changed since the last scan */
        char status[STATUS_MAX];
};

static uint64_t now_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

/* Sleeps on the change word; every change rings the eventfd the poll loop watches. */
static void *waker_main(void *arg)
{
        struct main_ctx *ctx = arg;
        struct sl_client *cl = bridge_client(ctx->b);
        uint32_t cursor = 0;
        uint64_t one = 1;

        while (!atomic_load(&ctx->stop_waker)) {
                int r = sl_wait(cl, &cursor, WAKER_SLICE_MS);

                if (r == 1 && write(ctx->wake_fd, &one, sizeof(one)) < 0 && errno != EAGAIN)
                        break;
                if (r < 0)
                        poll(NULL, 0, WAKER_SLICE_MS);  /* e.g. -ENOMEM: do not spin */
        }
        return NULL;
}

static void attach_due(struct main_ctx *ctx, uint64_t now)
{
        int r;

        if (bridge_attached(ctx->b) || now < ctx->attach_ns)
                return;
        r = bridge_attach(ctx->b);
        if (r < 0) {
                if (ctx->attach_ms == ATTACH_MIN_MS)
                        log_msg(LOG_PRIO_WARNING, "sharedlinkd instance: %s; retrying",
                                sl_strerror(r));
                ctx->attach_ns = now + ctx->attach_ms * NS_PER_MS;
                ctx->attach_ms = ctx->attach_ms * 2u > ATTACH_MAX_MS ? ATTACH_MAX_MS :
                                 ctx->attach_ms * 2u;
                return;
        }
        atomic_store(&ctx->stop_waker, false);
        if (pthread_create(&ctx->waker, NULL, waker_main, ctx) == 0)
                ctx->waker_running = true;
        else
                log_msg(LOG_PRIO_WARNING, "waker thread: %s: rescanning every %u ms only",
                        strerror(errno), TICK_MS);
        ctx->dirty = true;
}

static void status_update(struct main_ctx *ctx)
{
        char s[STATUS_MAX];

        /* Only states and reasons, no counts: sd_notify blocks when nobody reads fast enough,
         * and a count would change with every event. */
        const char *why = bridge_mqtt_error(ctx->bm);

        snprintf(s, sizeof(s), "STATUS=broker %s%s%s%s, sharedlinkd %s",
                 bridge_mqtt_connected(ctx->bm) ? "connected" : "disconnected",
                 why[0] ? " (" : "", why, why[0] ? ")" : "",
                 !bridge_attached(ctx->b) ? "not found" :
                 !strcmp(bridge_status(ctx->b), "online") ? "running" : "not running");
        if (strcmp(s, ctx->status) != 0) {
                memcpy(ctx->status, s, sizeof(s));
                notify_send(ctx->notify, s);
        }
}

static void publish_stats(struct main_ctx *ctx)
{
        char topic[BRIDGE_TOPIC_MAX], json[BRIDGE_JSON_MAX];
        const struct bridge_sink *sink = bridge_mqtt_sink(ctx->bm);
        uint64_t v = bridge_counters_version(ctx->b);
        int n;

        if (v == ctx->stats_version)
                return;
        n = bridge_counters_json(ctx->b, json, sizeof(json));
        bridge_format_topic(topic, sizeof(topic), bridge_base(ctx->b), "bridge", NULL);
        if (n >= 0 && sink->publish(sink->arg, topic, json, (size_t)n, 1, true, NULL) == 0)
                ctx->stats_version = v;
}

/* What the loop does once the socket is quiet: publish what changed, then events. Values wait
 * while earlier output is still unsent: changes then coalesce in the tables (the latest value
 * wins) instead of piling up in memory. */
static void work(struct main_ctx *ctx, uint64_t now)
{
        const struct bridge_sink *sink = bridge_mqtt_sink(ctx->bm);
        bool fresh = bridge_mqtt_take_fresh(ctx->bm), tick = now >= ctx->tick_ns;

        if (tick)
                ctx->tick_ns = now + TICK_MS * NS_PER_MS;
        if (!bridge_mqtt_connected(ctx->bm))
                return;
        if (fresh || ((ctx->dirty || tick) && !bridge_mqtt_want_write(ctx->bm))) {
                if (bridge_scan(ctx->b, sink, fresh) >= 0)
                        ctx->dirty = false;
        }
        if (!ctx->stopping)
                bridge_pump(ctx->b, sink);
        if (tick || fresh)
                publish_stats(ctx);
}

static void cursor_work(struct main_ctx *ctx, uint64_t now)
{
        bool sync = ctx->cfg.cursor_sync_ms > 0 && now >= ctx->sync_ns;

        if (sync)
                ctx->sync_ns = now + ctx->cfg.cursor_sync_ms * NS_PER_MS;
        bridge_cursor_flush(ctx->b, false);
        if (sync)
                bridge_cursor_flush(ctx->b, true);
}

static int timeout_ms(struct main_ctx *ctx, uint64_t now)
{
        uint64_t at = ctx->tick_ns;
        int t, m;

        if (!bridge_attached(ctx->b) && ctx->attach_ns < at)
                at = ctx->attach_ns;
        if (ctx->watchdog_interval_ns && ctx->watchdog_ns < at)
                at = ctx->watchdog_ns;
        if (ctx->stopping && ctx->stop_deadline_ns < at)
                at = ctx->stop_deadline_ns;
        t = at <= now ? 0 : (int)((at - now + NS_PER_MS - 1u) / NS_PER_MS);
        m = bridge_mqtt_timeout_ms(ctx->bm, now);
        return m < t ? m : t;
}

/* A stop waits for the broker to acknowledge what was sent (bounded by drain_ms). */
static bool drained(struct main_ctx *ctx, uint64_t now)
{
        return bridge_unacked(ctx->b) == 0 || now >= ctx->stop_deadline_ns ||
               !bridge_mqtt_connected(ctx->bm);
}

static void on_signal(struct main_ctx *ctx, uint64_t now)
{
        struct signalfd_siginfo si;

        if (read(ctx->sig_fd, &si, sizeof(si)) != sizeof(si) || ctx->stopping)
                return;
        log_msg(LOG_PRIO_NOTICE, "%s: stopping (%u events to be acknowledged)",
                strsignal((int)si.ssi_signo), bridge_unacked(ctx->b));
        notify_stopping(ctx->notify);
        ctx->stopping = true;
        ctx->stop_deadline_ns = now + ctx->cfg.drain_ms * NS_PER_MS;
}

static int run(struct main_ctx *ctx)
{
        bool ready = false;

        for (;;) {
                uint64_t now = now_ns();
                struct pollfd p[3];
                int fd, n;

                attach_due(ctx, now);
                if (!ctx->stopping)
                        bridge_mqtt_connect_due(ctx->bm, now);
                work(ctx, now);
                cursor_work(ctx, now);
                if (ctx->stopping && drained(ctx, now))
                        break;
                status_update(ctx);
                if (!ready) {
                        /* Ready once the configuration is in and the first attempts were made:
                         * a broker or daemon that is down is retried, not fatal. */
                        notify_ready(ctx->notify);
                        ready = true;
                }
                if (ctx->watchdog_interval_ns && now >= ctx->watchdog_ns) {
                        notify_watchdog(ctx->notify);
                        ctx->watchdog_ns = now + ctx->watchdog_interval_ns;
                }
                fd = bridge_mqtt_fd(ctx->bm);
                p[0] = (struct pollfd){ .fd = ctx->sig_fd, .events = POLLIN };
                p[1] = (struct pollfd){ .fd = ctx->wake_fd, .events = POLLIN };
                p[2] = (struct pollfd){ .fd = fd, .events = (short)(POLLIN |
                                        (bridge_mqtt_want_write(ctx->bm) ? POLLOUT : 0)) };
                n = poll(p, fd >= 0 ? 3 : 2, timeout_ms(ctx, now));
                if (n < 0 && errno != EINTR) {
                        log_msg(LOG_PRIO_ERR, "poll: %s", strerror(errno));
                        return 1;
                }
                now = now_ns();
                if (n > 0 && p[0].revents)
                        on_signal(ctx, now);
                if (n > 0 && p[1].revents) {
                        uint64_t v;

                        if (read(ctx->wake_fd, &v, sizeof(v)) == sizeof(v))
                                ctx->dirty = true;
                }
                bridge_mqtt_io(ctx->bm, n > 0 && fd >= 0 ? p[2].revents : 0, now);
        }
        return 0;
}

static int check_only(const char *path)
{
        char err[BRIDGE_ERROR_MAX];
        struct bridge_config cfg;

        if (bridge_config_load(path, &cfg, err, sizeof(err)) < 0) {
                fprintf(stderr, "%s\n", err);
                return 1;
        }
        return service_check_ok();
}

static int setup(struct main_ctx *ctx, const char *path)
{
        char err[BRIDGE_ERROR_MAX];
        sigset_t set;
        int r;

        if (bridge_config_load(path, &ctx->cfg, err, sizeof(err)) < 0) {
                log_msg(LOG_PRIO_ERR, "%s", err);
                return -EINVAL;
        }
        r = bridge_new(&ctx->cfg, &ctx->b);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "%s: %s", path, r == -EINVAL ?
                        "instance or prefix too long for a topic" : strerror(-r));
                return r;
        }
        r = bridge_mqtt_new(&ctx->cfg, ctx->b, &ctx->bm, err, sizeof(err));
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "%s: %s", path, err);
                return r;
        }
        sigemptyset(&set);
        sigaddset(&set, SIGTERM);
        sigaddset(&set, SIGINT);
        sigaddset(&set, SIGHUP);        /* no reload: a restart; ignored, not fatal */
        pthread_sigmask(SIG_BLOCK, &set, NULL);
        sigdelset(&set, SIGHUP);
        ctx->sig_fd = signalfd(-1, &set, SFD_CLOEXEC | SFD_NONBLOCK);
        ctx->wake_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
        if (ctx->sig_fd < 0 || ctx->wake_fd < 0) {
                log_msg(LOG_PRIO_ERR, "signalfd/eventfd: %s", strerror(errno));
                return -errno;
        }
        ctx->attach_ms = ATTACH_MIN_MS;
        r = notify_new(&ctx->notify);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "%s", strerror(-r));
                return r;
        }
        ctx->watchdog_interval_ns = notify_watchdog_interval_ms(ctx->notify) * NS_PER_MS;
        log_msg(LOG_PRIO_INFO, "sharedlink-mqtt %s: %s -> %s:%d, topics %s/...",
                SHAREDLINK_VERSION, path, ctx->cfg.host, ctx->cfg.port, bridge_base(ctx->b));
        return 0;
}

static void teardown(struct main_ctx *ctx)
{
        if (ctx->waker_running) {
                atomic_store(&ctx->stop_waker, true);
                pthread_join(ctx->waker, NULL);
        }
        if (ctx->bm)
                bridge_mqtt_disconnect(ctx->bm);
        if (ctx->b && bridge_unacked(ctx->b))
                log_msg(LOG_PRIO_WARNING, "stopped with %u events unacknowledged: they "
                        "are sent again at the next start", bridge_unacked(ctx->b));
        if (ctx->b)
                bridge_cursor_flush(ctx->b, true);
        ctx->bm = bridge_mqtt_free(ctx->bm);
        ctx->b = bridge_free(ctx->b);
        ctx->notify = notify_free(ctx->notify);
        if (ctx->wake_fd >= 0)
                close(ctx->wake_fd);
        if (ctx->sig_fd >= 0)
                close(ctx->sig_fd);
}

int main(int argc, char **argv)
{
        static const struct service_desc desc = {
                .name = "sharedlink-mqtt", .version = SHAREDLINK_VERSION,
                .config_default = BRIDGE_CONFIG_DEFAULT, .check = check_only,
        };
        static struct main_ctx ctx = { .sig_fd = -1, .wake_fd = -1 };
        struct service_args args;
        int r = service_args(&desc, argc, argv, &args);

        if (r != SERVICE_CONTINUE)
                return r;
        service_start(&args);
        mosquitto_lib_init();
        r = setup(&ctx, args.config) < 0 ? 1 : run(&ctx);
        teardown(&ctx);
        mosquitto_lib_cleanup();
        return r;
}
