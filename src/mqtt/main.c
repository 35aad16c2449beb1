/*
 * sharedlink-mqtt: bridges a sharedlinkd instance to an MQTT broker (see bridge.h for what goes
 * where, bridge_mqtt.h for the connection).
 *
 *   sharedlink-mqtt [-c FILE] [-n] [-v] [-V]
 *
 * One thread runs everything (the tables, libmosquitto, the cursor) on the service's event loop
 * (svc/service.h, svc/evloop.h); the toolkit's waker (svc/waker.h) tells it when the tables
 * changed. Init: log, configuration, service (loop, notify, signals, watchdog), bridge, MQTT
 * client, the waker once attached; teardown in reverse.
 * A stop drains (drain_ms); SIGHUP has no reload here (logged). Always in the foreground,
 * logging to stderr with <N> priority prefixes. Exit status: 0 after a clean stop (SIGTERM,
 * SIGINT) or a good -n check, 1 on a bad configuration or a failed start, 2 on a usage error,
 * 3 when another sharedlink-mqtt bridges the same instance to the same topics (svc/lockfile.h).
 */
#include <errno.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <mosquitto.h>
#include <sharedlink.h>

#include "mqtt/bridge.h"
#include "mqtt/bridge_config.h"
#include "mqtt/bridge_format.h"
#include "mqtt/bridge_mqtt.h"
#include "svc/lockfile.h"
#include "svc/log.h"
#include "svc/service.h"
#include "svc/backoff.h"
#include "svc/waker.h"

#define NS_PER_MS               1000000ull
#define TICK_MS                 1000u   /* rescan anyway (staleness by heartbeat), stats */
#define STATUS_MAX              320     /* a state and a reason per side */

#ifndef SHAREDLINK_VERSION
#define SHAREDLINK_VERSION      "unknown"
#endif

struct main_ctx {
        struct bridge_config cfg;
        struct service *svc;
        struct evloop *loop;            /* the service's */
        struct bridge *b;
        struct bridge_mqtt *bm;
        int sock_fd;                    /* libmosquitto's socket as watched on the loop, or -1 */
        struct evloop_timer step;       /* the next thing due (see turn()) */
        struct waker *waker;            /* once attached */
        bool ready;
        uint64_t stop_deadline_ns;
        struct backoff attach;          /* sl_open retries while no daemon runs */
        uint64_t tick_ns;
        uint64_t sync_ns;               /* next fsync of the cursor */
        uint64_t stats_version;
        bool dirty;                     /* the tables changed since the last scan */
        struct lockfile single;         /* one bridge per instance and prefix */
        bool held_elsewhere;            /* another holds it: SERVICE_EXIT_HELD */
};

/* The waker: the tables changed. */
static void on_change(void *arg)
{
        struct main_ctx *ctx = arg;

        ctx->dirty = true;
        evloop_timer_arm(&ctx->step, 0, 0);
}

static void attach_due(struct main_ctx *ctx, uint64_t now)
{
        int r;

        if (bridge_attached(ctx->b) || !backoff_due(&ctx->attach, now / NS_PER_MS))
                return;
        r = bridge_attach(ctx->b);
        if (r < 0) {
                if (backoff_failed(&ctx->attach, now / NS_PER_MS))
                        log_msg(LOG_PRIO_WARNING, "sharedlinkd instance: %s; retrying",
                                sl_strerror(r));
                return;
        }
        backoff_reset(&ctx->attach);
        if (waker_start(ctx->loop, bridge_client(ctx->b), on_change, ctx, &ctx->waker) < 0)
                log_msg(LOG_PRIO_WARNING, "rescanning every %u ms only", TICK_MS);
        ctx->dirty = true;
}

/* STATUS= (with READY=1 the first time): only states and reasons, no counts, since every change
 * is a datagram to the service manager and a count would change with every event. */
static void status_update(struct main_ctx *ctx)
{
        const char *why = bridge_mqtt_error(ctx->bm);
        char s[STATUS_MAX];

        snprintf(s, sizeof(s), "broker %s%s%s%s, sharedlinkd %s",
                 bridge_mqtt_connected(ctx->bm) ? "connected" : "disconnected",
                 why[0] ? " (" : "", why, why[0] ? ")" : "",
                 !bridge_attached(ctx->b) ? "not found" :
                 !strcmp(bridge_status(ctx->b), "online") ? "running" : "not running");
        if (ctx->ready) {
                service_status(ctx->svc, s);
                return;
        }
        /* Ready once the configuration is in and the first attempts were made: a broker or
         * daemon that is down is retried, not fatal. */
        service_ready(ctx->svc, s);
        ctx->ready = true;
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
        bridge_format_topic(topic, sizeof(topic), bridge_base(ctx->b), BRIDGE_TOPIC_BRIDGE, NULL);
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
        if (!service_stopping(ctx->svc))
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

static uint64_t timeout_ms(struct main_ctx *ctx, uint64_t now)
{
        uint64_t at = ctx->tick_ns, t, m;

        if (!bridge_attached(ctx->b) && backoff_due_ms(&ctx->attach) * NS_PER_MS < at)
                at = backoff_due_ms(&ctx->attach) * NS_PER_MS;
        if (service_stopping(ctx->svc) && ctx->stop_deadline_ns < at)
                at = ctx->stop_deadline_ns;
        t = at <= now ? 0 : (at - now + NS_PER_MS - 1u) / NS_PER_MS;
        m = (uint64_t)bridge_mqtt_timeout_ms(ctx->bm, now);
        return m < t ? m : t;
}

/* A stop waits for the broker to acknowledge what was sent (bounded by drain_ms). */
static bool drained(struct main_ctx *ctx, uint64_t now)
{
        return bridge_unacked(ctx->b) == 0 || now >= ctx->stop_deadline_ns ||
               !bridge_mqtt_connected(ctx->bm);
}

static void on_socket(struct evloop *loop, int fd, unsigned revents, void *arg);

/* Watches libmosquitto's socket as it is now: another one after a reconnection, POLLOUT only
 * while output is queued. */
static int watch_socket(struct main_ctx *ctx)
{
        unsigned events = POLLIN | (bridge_mqtt_want_write(ctx->bm) ? POLLOUT : 0u);
        int fd = bridge_mqtt_fd(ctx->bm), r;

        if (fd == ctx->sock_fd && fd >= 0) {
                r = evloop_mod_fd(ctx->loop, fd, events);
                if (r != -ENOENT)       /* -ENOENT: dropped by the loop after POLLNVAL */
                        return r;
        } else if (ctx->sock_fd >= 0) {
                evloop_del_fd(ctx->loop, ctx->sock_fd);
        }
        ctx->sock_fd = -1;
        if (fd < 0)
                return 0;
        r = evloop_add_fd(ctx->loop, fd, events, on_socket, ctx);
        if (r == 0)
                ctx->sock_fd = fd;
        return r;
}

/*
 * What the loop does between two waits, in this order: attach to sharedlinkd, connect to the
 * broker, publish, flush the cursor, end a drained stop, report the status; then watch the
 * socket and sleep until the next thing due (tick, attach retry, broker keepalive or backoff,
 * drain deadline). It runs after every socket event (step()) and from the step timer; the
 * waker and the stop signal only arm that timer, so the socket's readiness is never used
 * after a turn that may have replaced the socket.
 */
static void turn(struct main_ctx *ctx)
{
        uint64_t now = evloop_clock_ns();
        int r;

        attach_due(ctx, now);
        if (!service_stopping(ctx->svc))
                bridge_mqtt_connect_due(ctx->bm, now);
        work(ctx, now);
        cursor_work(ctx, now);
        if (service_stopping(ctx->svc) && drained(ctx, now)) {
                service_exit(ctx->svc, SERVICE_EXIT_OK);
                return;
        }
        status_update(ctx);
        r = watch_socket(ctx);
        if (r == 0)
                r = evloop_timer_arm(&ctx->step, timeout_ms(ctx, now), 0);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "event loop: %s", strerror(-r));
                service_exit(ctx->svc, SERVICE_EXIT_FAILURE);
        }
}

/* The socket's poll result (or none) to libmosquitto, then a turn. */
static void step(struct main_ctx *ctx, unsigned revents)
{
        if (evloop_exiting(ctx->loop))
                return;
        bridge_mqtt_io(ctx->bm, (short)revents, evloop_clock_ns());
        turn(ctx);
}

static void on_socket(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        (void)loop;
        (void)fd;
        step(arg, revents);
}

static void on_step(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        (void)loop;
        (void)t;
        step(arg, 0);
}

/* The tables changed: a scan at the next turn (the next round). */
/* SIGTERM/SIGINT: stop reading events, wait up to drain_ms for the acknowledgements. */
static int on_stop(void *arg, char *note, size_t note_size)
{
        struct main_ctx *ctx = arg;

        snprintf(note, note_size, " (%u events to be acknowledged)", bridge_unacked(ctx->b));
        ctx->stop_deadline_ns = evloop_clock_ns() + ctx->cfg.drain_ms * NS_PER_MS;
        evloop_timer_arm(&ctx->step, 0, 0);
        return SERVICE_STOP_DRAIN;
}

static int check_only(const char *path)
{
        char err[BRIDGE_ERROR_MAX];
        struct bridge_config cfg;

        if (bridge_config_load(path, &cfg, err, sizeof(err)) < 0) {
                fprintf(stderr, "%s\n", err);
                return SERVICE_EXIT_FAILURE;
        }
        return service_check_ok();
}

/* One bridge per instance and topic prefix (svc/lockfile.h), before the broker sees us: a second
 * one would publish everything twice and fight the first over every write. */
static int take_lock(struct main_ctx *ctx, const char *program)
{
        const char *parts[] = { "mqtt", bridge_base(ctx->b) };
        char what[BRIDGE_TOPIC_MAX + 32];
        int r;

        snprintf(what, sizeof(what), "bridges topics %s/...", bridge_base(ctx->b));
        r = lockfile_take_service(&ctx->single, program, what, parts, 2);
        ctx->held_elsewhere = r == -EBUSY;
        return r;
}

static int setup(struct main_ctx *ctx, const struct service_desc *desc, const char *path)
{
        static const struct service_ops ops = { .stop = on_stop };      /* no reload */
        char err[BRIDGE_ERROR_MAX];
        int r;

        if (bridge_config_load(path, &ctx->cfg, err, sizeof(err)) < 0) {
                log_msg(LOG_PRIO_ERR, "%s", err);
                return -EINVAL;
        }
        r = service_new(desc, &ops, ctx, &ctx->svc);
        if (r < 0)
                return r;
        ctx->loop = service_loop(ctx->svc);
        evloop_timer_init(&ctx->step, ctx->loop, on_step, ctx);        /* teardown cancels it */
        r = bridge_new(&ctx->cfg, &ctx->b);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "%s: %s", path, r == -EINVAL ?
                        "instance or prefix too long for a topic" : strerror(-r));
                return r;
        }
        r = take_lock(ctx, desc->name);
        if (r < 0)
                return r;
        r = bridge_mqtt_new(&ctx->cfg, ctx->b, &ctx->bm, err, sizeof(err));
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "%s: %s", path, err);
                return r;
        }
        backoff_reset(&ctx->attach);
        log_msg(LOG_PRIO_INFO, "sharedlink-mqtt %s: %s -> %s:%d, topics %s/...",
                SHAREDLINK_VERSION, path, ctx->cfg.host, ctx->cfg.port, bridge_base(ctx->b));
        return 0;
}

static void teardown(struct main_ctx *ctx)
{
        if (ctx->loop) {
                evloop_timer_cancel(&ctx->step);
                if (ctx->sock_fd >= 0)
                        evloop_del_fd(ctx->loop, ctx->sock_fd);
        }
        ctx->waker = waker_stop(ctx->waker);
        if (ctx->bm)
                bridge_mqtt_disconnect(ctx->bm);
        if (ctx->b && bridge_unacked(ctx->b))
                log_msg(LOG_PRIO_WARNING, "stopped with %u events unacknowledged: they "
                        "are sent again at the next start", bridge_unacked(ctx->b));
        if (ctx->b)
                bridge_cursor_flush(ctx->b, true);
        ctx->bm = bridge_mqtt_free(ctx->bm);
        lockfile_release(&ctx->single);
        ctx->b = bridge_free(ctx->b);
        ctx->svc = service_free(ctx->svc);
}

int main(int argc, char **argv)
{
        static const struct service_desc desc = {
                .name = "sharedlink-mqtt", .version = SHAREDLINK_VERSION,
                .config_default = BRIDGE_CONFIG_DEFAULT, .check = check_only,
        };
        static struct main_ctx ctx = { .sock_fd = -1 };
        struct service_args args;
        int r = service_args(&desc, argc, argv, &args);

        if (r != SERVICE_CONTINUE)
                return r;
        service_start(&args);
        mosquitto_lib_init();
        lockfile_init(&ctx.single);
        r = SERVICE_EXIT_FAILURE;
        if (setup(&ctx, &desc, args.config) == 0) {
                turn(&ctx);
                r = service_run(ctx.svc);
        } else if (ctx.held_elsewhere) {
                r = SERVICE_EXIT_HELD;
        }
        teardown(&ctx);
        mosquitto_lib_cleanup();
        return r;
}
