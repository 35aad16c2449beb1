/*
 * sharedlink-mqtt end to end: a private mosquitto broker on 127.0.0.1 (tests/common/mqtt.h), the
 * real sharedlinkd (build/asan) with a SharedLink pair back to back over a pty and a CIRCE
 * controller whose mediator is this test (on a pty pair), the real bridge, and a real MQTT
 * client (libmosquitto) that records what arrives.
 *
 *  - values round-trip both ways: an MQTT set/ reaches the peer over the wire and comes back as
 *    the peer's inbound variable; an sl_write comes out on MQTT; a broker that is down when the
 *    bridge starts is waited for;
 *  - refused writes (inbound, not writable, too long (64 bytes and 256 KiB), not UTF-8, bad
 *    characters, unknown name, extra topic levels) get an error reply, are counted, and change
 *    nothing; set/ topics MQTT forbids (wildcards, not UTF-8), sent by a raw client, are
 *    dropped by the broker and change nothing, and the bridge goes on;
 *  - old writes never come back over a later local write: a retained set/ is refused
 *    ("retained") when published and again after a bridge restart; one published while the
 *    bridge is stopped is refused ("queued") when an older bridge's persistent session kept it,
 *    and otherwise never delivered (the writes' session is clean);
 *  - a daemon that stops makes values stale and the status offline; its restart is followed;
 *  - values changed while the bridge is stopped between two wake-ups, with more changes than
 *    the daemon's change record holds, and across a daemon restart, all go out;
 *  - 10,000 gate passages across a bridge restart and a broker restart, each in mid-burst,
 *    arrive at a persistent-session QoS 2 subscriber exactly once and in order (QoS 2; the
 *    broker configured as sharedlink-mqtt(8) requires: max_inflight_messages large and
 *    finite, tests/common/mqtt.c says why); and with QoS 1 across a bridge restart, exactly
 *    once;
 *  - the broker drops the bridge's connection in mid-burst (a session takeover) and stays up:
 *    10,000 events exactly once, in order (QoS 2);
 *  - a bridge killed in mid-burst (QoS 1) loses nothing and repeats at most its window;
 *  - more events than the ring holds while the bridge is away: one "overrun" notice with the
 *    exact number lost, where the gap is; a daemon restart: a "daemon-restarted" notice;
 *  - TLS and passwords: a broker with a TLS listener (a throwaway CA and server certificate
 *    made with openssl) and a mosquitto_passwd file; the bridge with tls: {ca_file} and
 *    username/password_file round-trips a value; a wrong password or a CA that did not sign
 *    the broker's certificate: the reason in the log (once) and in STATUS=, retries backing off
 *    to reconnect_max_ms, nothing published, a clean stop;
 *  - `sharedlink-mqtt -n` reports FILE:LINE:COL.
 */
#define _GNU_SOURCE
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <errno.h>
#include <inttypes.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <sharedlink.h>

#include "common/harness.h"
#include "common/mqtt.h"
#include "common/slwait.h"

#define T_START_MS      15000   /* READY=1 (ASan build), a broker accepting connections */
#define T_WAIT_MS       15000   /* one awaited message */
#define T_STOP_MS       15000
#define T_EVENTS_MS     60000  /* every event of a run arrived */
#define CONFIG_MAX      4096
#define PATH_BUF        512
#define PKT_MAX         64
#define EVENTS_TOTAL    10000
#define EVENTS_AHEAD    200     /* sent and not yet received ... */
#define BURST           200     /* ... then sent while the bridge or broker stops ... */
#define AWAY            300     /* ... and while it is away: 700 < the 1024-event ring */
#define BATCH           100     /* packets per write */
#define RING_EVENTS     1024    /* the daemon's event ring (SHM_EVENTS_DEFAULT) */
#define OVERRUN_AWAY    1500    /* passages while the bridge is away: more than the ring */
#define BRIDGE_WINDOW   64      /* events_window's default */
#define HUGE_PAYLOAD    (256 * 1024)    /* a set/ payload far over the value size */
#define KEEPALIVE_S     5       /* the bridge's MQTT keepalive, unless a test sets its own */
#define LONG_KEEPALIVE_S 120    /* a bridge stopped this long is not taken for dead */
#define FLOOD_MAX       40000   /* passages before the change record must have overrun */

struct fx {
        struct harness h;
        struct mqtt_broker broker;
        struct mqtt_bridge bridge;
        struct mqtt_client sub;
        struct sl_client *cl;
        char broker_dir[PATH_BUF];
        char bridge_conf[PATH_BUF];
        char base[128];
        int master, slave;              /* the test as the CIRCE mediator */
        int keepalive_s;                /* 0: KEEPALIVE_S */
};

static int setup(void **state)
{
        struct fx *f = calloc(1, sizeof(*f));

        if (!f)
                return -1;
        f->master = f->slave = -1;
        f->bridge.notify_fd = -1;
        *state = f;
        if (!mqtt_broker_available()) {
                print_message("mosquitto is not installed (make deps): skipped\n");
                return 0;
        }
        if (harness_init(&f->h, "mqtt") < 0)
                return -1;
        snprintf(f->broker_dir, sizeof(f->broker_dir), "%s/broker", f->h.dir);
        snprintf(f->base, sizeof(f->base), "sharedlink/%s", f->h.instance);
        return mkdir(f->broker_dir, 0755);
}

static int teardown(void **state)
{
        struct fx *f = *state;

        mqtt_client_stop(&f->sub);
        mqtt_bridge_cleanup(&f->bridge);
        mqtt_broker_stop(&f->broker, T_STOP_MS);
        sl_close(f->cl);
        if (f->master >= 0)
                close(f->master);
        if (f->slave >= 0)
                close(f->slave);
        if (f->h.dir[0])
                harness_cleanup(&f->h);
        free(f);
        return 0;
}

static void need_broker(void)
{
        if (!mqtt_broker_available())
                skip();
}

static void start_daemon(struct fx *f)
{
        char text[CONFIG_MAX], path[PATH_BUF], slave[PATH_BUF], dev[PATH_BUF];
        int st = 0;

        if (f->master < 0) {
                assert_int_equal(harness_openpty(&f->master, &f->slave, slave), 0);
                snprintf(dev, sizeof(dev), "%s/dev0", f->h.dir);
                assert_int_equal(symlink(slave, dev), 0);
        }
        snprintf(text, sizeof(text),
                 "instance: %s\n"
                 "links:\n"
                 "  - {name: node_a, protocol: sharedlink, transport: pty, device: %s/a.tty,\n"
                 "     address: A, peers: [{address: B, period_ms: 100, on_change: true,\n"
                 "       outbound: [{name: a.Lat, type: double}, {name: a.Lon, type: double}],\n"
                 "       inbound: [{name: a.Throttle, type: long}]}]}\n"
                 "  - {name: node_b, protocol: sharedlink, transport: serial, device: %s/a.tty,\n"
                 "     address: B, peers: [{address: A, period_ms: 100, on_change: true,\n"
                 "       outbound: [{name: b.Throttle, type: long}],\n"
                 "       inbound: [{name: b.Lat, type: double}, {name: b.Lon, type: double}]}]}\n"
                 "  - {name: agility, protocol: circe, role: controller, transport: serial,\n"
                 "     device: %s/dev0, login_timeout_ms: 60000, idle_timeout_ms: 60000}\n",
                 f->h.instance, f->h.dir, f->h.dir, f->h.dir);
        assert_int_equal(harness_write_file(&f->h, "daemon.yaml", text, path), 0);
        f->h.capture_log = 1;
        if (harness_start_daemon(&f->h, path, T_START_MS, &st, NULL) != 0)
                fail_msg("sharedlinkd did not start (status %d)", st);
        if (!f->cl)
                assert_int_equal(sl_open(f->h.instance, &f->cl), 0);
}

/* broker_extra: more keys of broker: (indented by two), extra: more top-level keys. */
static void write_bridge_conf_broker(struct fx *f, int events_qos, const char *broker_extra,
                                     const char *extra)
{
        char text[CONFIG_MAX];

        snprintf(text, sizeof(text),
                 "instance: %s\n"
                 "broker:\n"
                 "  host: 127.0.0.1\n"
                 "  port: %d\n"
                 "  keepalive_s: %d\n"
                 "  reconnect_min_ms: 50\n"
                 "  reconnect_max_ms: 400\n%s"
                 "cursor_file: %s/cursor\n"
                 "writable: [\"a.*\"]\n"
                 "events_qos: %d\n"
                 "drain_ms: 20000\n%s",
                 f->h.instance, f->broker.port, f->keepalive_s ? f->keepalive_s : KEEPALIVE_S,
                 broker_extra ? broker_extra : "", f->h.dir,
                 events_qos, extra ? extra : "");
        assert_int_equal(harness_write_file(&f->h, "bridge.yaml", text, f->bridge_conf), 0);
}

static void write_bridge_conf(struct fx *f, int events_qos, const char *extra)
{
        write_bridge_conf_broker(f, events_qos, NULL, extra);
}

static void start_bridge(struct fx *f)
{
        int st = 0, r = mqtt_bridge_start(&f->bridge, &f->h, f->bridge_conf, T_START_MS, &st);

        if (r != 0)
                fail_msg("sharedlink-mqtt did not start (%d, status %d)", r, st);
}

static void stop_bridge(struct fx *f, int sig)
{
        int st = mqtt_bridge_stop(&f->bridge, sig, T_STOP_MS);

        assert_true(st >= 0);
        if (sig == SIGTERM)
                assert_true(WIFEXITED(st) && WEXITSTATUS(st) == 0);
}

static void start_broker(struct fx *f)
{
        assert_int_equal(mqtt_broker_start(&f->broker, f->broker_dir, f->broker.port,
                                           T_START_MS), 0);
}

static void start_sub(struct fx *f, const char *id, bool clean, int qos)
{
        char sub[MQTT_TOPIC_MAX];

        snprintf(sub, sizeof(sub), "%s/#", f->base);
        assert_int_equal(mqtt_client_start(&f->sub, f->broker.port, id, clean, sub, qos,
                                           T_START_MS), 0);
}

static const char *topic(struct fx *f, const char *a, const char *b)
{
        static char t[2][MQTT_TOPIC_MAX];
        static int next;
        char *out = t[next++ % 2];

        if (b)
                snprintf(out, MQTT_TOPIC_MAX, "%s/%s/%s", f->base, a, b);
        else
                snprintf(out, MQTT_TOPIC_MAX, "%s/%s", f->base, a);
        return out;
}

static void wait_value(struct fx *f, const char *t, const char *want)
{
        if (mqtt_client_wait_value(&f->sub, t, want, T_WAIT_MS) != 0)
                fail_msg("%s never became \"%s\"", t, want);
}

static void wait_contains(struct fx *f, const char *t, const char *needle, char *out,
                          size_t size)
{
        if (mqtt_client_wait_contains(&f->sub, t, needle, out, size, T_WAIT_MS) != 0)
                fail_msg("%s never contained %s", t, needle);
}

static void set(struct fx *f, const char *name, const void *payload, size_t len)
{
        assert_int_equal(mqtt_client_publish(&f->sub, topic(f, "set", name), payload, len, 1,
                                             false), 0);
}

static void read_value(struct fx *f, const char *name, char *buf, struct sl_meta *meta)
{
        int id = sl_find(f->cl, name);

        assert_true(id >= 0);
        meta->size = sizeof(*meta);
        assert_true(sl_read(f->cl, id, buf, SL_VALUE_SIZE, meta) >= 0);
}

/* Daemon, broker, bridge (events QoS 1) and a clean-session subscriber, all up. */
static void start_all(struct fx *f, const char *sub_id)
{
        need_broker();
        start_daemon(f);
        f->broker.port = 0;
        start_broker(f);
        write_bridge_conf(f, 1, NULL);
        start_bridge(f);
        start_sub(f, sub_id, true, 1);
        wait_value(f, topic(f, "status", NULL), "online");
}

/* Values both ways, with a broker that is down when the bridge starts. */
static void test_values_round_trip(void **state)
{
        struct fx *f = *state;
        char json[MQTT_PAYLOAD_MAX];
        int id;

        need_broker();
        start_daemon(f);
        f->broker.port = 0;
        /* Pick the port, then stop: the bridge starts against a broker that is not there. */
        start_broker(f);
        assert_int_equal(mqtt_broker_stop(&f->broker, T_STOP_MS), 0);
        write_bridge_conf(f, 1, NULL);
        start_bridge(f);
        start_broker(f);
        start_sub(f, "test-values", true, 1);
        wait_value(f, topic(f, "status", NULL), "online");
        wait_value(f, topic(f, "links", "node_b"), "up");

        /* MQTT -> a.Lat (outbound on node A) -> wire -> b.Lat (inbound on node B) -> MQTT. */
        set(f, "a.Lat", "41.25", 5);
        wait_value(f, topic(f, "b.Lat", NULL), "41.25");
        wait_value(f, topic(f, "a.Lat", NULL), "41.25");
        wait_contains(f, topic(f, "b.Lat", "meta"), "\"valid\":true", json, sizeof(json));
        assert_non_null(strstr(json, "\"stale\":false"));
        assert_non_null(strstr(json, "\"direction\":\"in\""));
        assert_non_null(strstr(json, "\"link\":\"node_b\""));

        /* sl_write b.Throttle (outbound on node B) -> wire -> a.Throttle -> MQTT. */
        id = sl_find(f->cl, "b.Throttle");
        assert_true(id >= 0);
        assert_int_equal(sl_write(f->cl, id, "-17"), 0);
        wait_value(f, topic(f, "a.Throttle", NULL), "-17");
        wait_contains(f, topic(f, "a.Throttle", "meta"), "\"type\":\"long\"", NULL, 0);
}

/* Each refused write: an error reply with its code; counted; the variable unchanged. */
static void refused(struct fx *f, const char *name, const void *payload, size_t len,
                    const char *code)
{
        char want[64], before[SL_VALUE_SIZE] = "", after[SL_VALUE_SIZE] = "";
        char t[MQTT_TOPIC_MAX];
        struct sl_meta mb, ma;
        uint64_t replies;
        bool known = sl_find(f->cl, name) >= 0;

        if (known)
                read_value(f, name, before, &mb);
        snprintf(want, sizeof(want), "\"code\":\"%s\"", code);
        snprintf(t, sizeof(t), "%s/error", topic(f, "set", name));
        replies = mqtt_client_count(&f->sub, t);
        set(f, name, payload, len);
        if (mqtt_client_wait_count(&f->sub, t, replies + 1, T_WAIT_MS) != 0)
                fail_msg("no reply on %s", t);
        wait_contains(f, t, want, NULL, 0);
        if (known) {
                read_value(f, name, after, &ma);
                assert_string_equal(before, after);
                assert_int_equal(mb.sequence, ma.sequence);
        }
}

static void test_refused_writes(void **state)
{
        struct fx *f = *state;
        static char huge[HUGE_PAYLOAD];
        char long_value[80], json[MQTT_PAYLOAD_MAX];
        struct sl_meta meta;
        char v[SL_VALUE_SIZE];

        start_all(f, "test-refused");
        set(f, "a.Lon", "7.5", 3);
        wait_value(f, topic(f, "b.Lon", NULL), "7.5");

        memset(long_value, '9', sizeof(long_value));
        memset(huge, '9', HUGE_PAYLOAD);
        refused(f, "b.Lat", "1", 1, "inbound");                 /* inbound: read only */
        refused(f, "b.Throttle", "1", 1, "not-writable");       /* outbound, not in writable */
        refused(f, "a.Lon", long_value, SL_VALUE_SIZE, "too-long");     /* 64 bytes */
        refused(f, "a.Lon", huge, HUGE_PAYLOAD, "too-long");
        refused(f, "a.Lon", "\xff\xfe", 2, "not-utf8");
        refused(f, "a.Lon", "\xc0\xaf", 2, "not-utf8");         /* overlong '/' */
        refused(f, "a.Lon", "1|2", 3, "bad-value");             /* UTF-8, not wire text */
        refused(f, "a.Lon", "\xc3\xa9", 2, "bad-value");        /* UTF-8 é: not ASCII */
        refused(f, "a.Nope", "1", 1, "unknown");
        /* Extra levels under set/: refused and counted, no reply (no name to answer on). */
        assert_int_equal(mqtt_client_publish(&f->sub, topic(f, "set", "a.Lon/x/y"), "2", 1, 1,
                                             false), 0);
        /* 63 bytes is the largest value: accepted. */
        set(f, "a.Lon", long_value, SL_VALUE_SIZE - 1);
        long_value[SL_VALUE_SIZE - 1] = '\0';
        wait_value(f, topic(f, "b.Lon", NULL), long_value);
        read_value(f, "a.Lon", v, &meta);
        assert_string_equal(v, long_value);

        wait_contains(f, topic(f, "bridge", NULL), "\"set_refused\":10", json, sizeof(json));
        assert_non_null(strstr(json, "\"set_written\":2"));
}

/* Topics MQTT forbids in a PUBLISH (wildcards, not UTF-8) under set/, sent raw: the broker
 * drops the client that sends them, the bridge never sees them, nothing changes; the bridge
 * goes on (a later write works). bridge_format_set_topic refuses them too (unit test). */
static void test_set_bad_topics(void **state)
{
        struct fx *f = *state;
        const char *bad[] = { "a.Lon+", "+", "#", "a.L#", "+/error", "a.Lon\xff", "\xc0\xae" };
        char t[MQTT_TOPIC_MAX], json[MQTT_PAYLOAD_MAX], v[SL_VALUE_SIZE];
        struct sl_meta meta;

        start_all(f, "test-bad-topics");
        set(f, "a.Lon", "1.5", 3);
        wait_value(f, topic(f, "b.Lon", NULL), "1.5");
        /* The same raw client with a good topic: the broker takes it (the test can tell). */
        snprintf(t, sizeof(t), "%s", topic(f, "set", "a.Lon"));
        assert_int_equal(mqtt_raw_publish(f->broker.port, t, strlen(t), "2.5", 3, T_WAIT_MS), 0);
        wait_value(f, topic(f, "b.Lon", NULL), "2.5");
        for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
                snprintf(t, sizeof(t), "%s", topic(f, "set", bad[i]));
                if (mqtt_raw_publish(f->broker.port, t, strlen(t), "9", 1, T_WAIT_MS) != 1)
                        fail_msg("the broker took a PUBLISH to %s", t);
        }
        read_value(f, "a.Lon", v, &meta);
        assert_string_equal(v, "2.5");
        set(f, "a.Lon", "3.5", 3);
        wait_value(f, topic(f, "b.Lon", NULL), "3.5");
        wait_contains(f, topic(f, "bridge", NULL), "\"set_written\":3", json, sizeof(json));
        assert_non_null(strstr(json, "\"set_refused\":0"));
        /* The bridge's own connection was never disturbed. */
        assert_int_equal(mqtt_bridge_log_contains(&f->bridge, "retrying in"), 0);
}

/* The daemon stops: values stale, status offline; it restarts: followed, writes flow again. */
static void test_stale_and_daemon_restart(void **state)
{
        struct fx *f = *state;

        start_all(f, "test-stale");
        set(f, "a.Lat", "3.5", 3);
        wait_value(f, topic(f, "b.Lat", NULL), "3.5");
        wait_contains(f, topic(f, "b.Lat", "meta"), "\"stale\":false", NULL, 0);

        assert_true(harness_stop_daemon(&f->h, SIGTERM, T_STOP_MS) >= 0);
        wait_value(f, topic(f, "status", NULL), "offline");
        wait_contains(f, topic(f, "b.Lat", "meta"), "\"stale\":true", NULL, 0);

        start_daemon(f);
        wait_value(f, topic(f, "status", NULL), "online");
        /* The new run's first event comes with a notice: the old run's unread tail is gone. */
        assert_int_equal(mqtt_client_wait_event_type(&f->sub, "daemon-restarted", T_WAIT_MS), 0);
        set(f, "a.Lat", "4.5", 3);
        wait_value(f, topic(f, "b.Lat", NULL), "4.5");
        wait_contains(f, topic(f, "b.Lat", "meta"), "\"stale\":false", NULL, 0);
}

/* The last lines of the bridge's and the broker's logs, for a failure message. */
static void dump_logs(struct fx *f)
{
        const char *logs[] = { f->bridge.log_path, f->broker.log };

        for (size_t i = 0; i < 2; i++) {
                char cmd[PATH_BUF * 2];

                snprintf(cmd, sizeof(cmd), "tail -n 40 %s >&2", logs[i]);
                if (system(cmd) != 0)
                        print_message("(no log %s)\n", logs[i]);
        }
}

/* ---- old writes never come back ------------------------------------------------------------- */

/* The bridge's own client id (its persistent session): the default, sharedlink-mqtt-<instance>. */
#define BRIDGE_CLIENT_ID_PREFIX "sharedlink-mqtt-"

/* Publishes a write (QoS 1) and waits until the broker has taken it: the subscriber, which
 * subscribes to everything under base, sees it come back. */
static void set_taken(struct fx *f, const char *name, const char *value, bool retain)
{
        const char *t = topic(f, "set", name);
        uint64_t seen = mqtt_client_count(&f->sub, t);

        assert_int_equal(mqtt_client_publish(&f->sub, t, value, strlen(value), 1, retain), 0);
        if (mqtt_client_wait_count(&f->sub, t, seen + 1, T_WAIT_MS) != 0)
                fail_msg("the broker never passed %s on", t);
}

/* Waits for the n-th reply on base/set/<name>/error and checks its code. */
static void wait_refusal(struct fx *f, const char *name, uint64_t n, const char *code)
{
        char t[MQTT_TOPIC_MAX], want[64];

        snprintf(t, sizeof(t), "%s/error", topic(f, "set", name));
        snprintf(want, sizeof(want), "\"code\":\"%s\"", code);
        if (mqtt_client_wait_count(&f->sub, t, n, T_WAIT_MS) != 0) {
                dump_logs(f);
                fail_msg("no reply %" PRIu64 " on %s (expected %s)", n, t, want);
        }
        wait_contains(f, t, want, NULL, 0);
}

static uint64_t refusals(struct fx *f, const char *name)
{
        char t[MQTT_TOPIC_MAX];

        snprintf(t, sizeof(t), "%s/error", topic(f, "set", name));
        return mqtt_client_count(&f->sub, t);
}

static void write_local(struct fx *f, const char *name, const char *value)
{
        int id = sl_find(f->cl, name);

        assert_true(id >= 0);
        assert_int_equal(sl_write(f->cl, id, value), 0);
}

static void assert_value(struct fx *f, const char *name, const char *want)
{
        char v[SL_VALUE_SIZE];
        struct sl_meta meta;

        read_value(f, name, v, &meta);
        if (strcmp(v, want) != 0)
                fail_msg("%s is \"%s\", not \"%s\": an old write came back", name, v, want);
}

/* A live write of a.Lon that the bridge applied: what the broker had for the bridge's writes
 * before it has been handled (one publisher, one connection: in order). */
static void barrier(struct fx *f, const char *value)
{
        set(f, "a.Lon", value, strlen(value));
        wait_value(f, topic(f, "b.Lon", NULL), value);
}

static void restart_bridge(struct fx *f)
{
        stop_bridge(f, SIGTERM);
        wait_value(f, topic(f, "status", NULL), "offline");
        start_bridge(f);
        wait_value(f, topic(f, "status", NULL), "online");
}

/* The bridge's own session subscribed to base/set/#, as a bridge before the writes' connection
 * left it (made while the bridge is stopped). */
static void legacy_subscription(struct fx *f)
{
        struct mqtt_client legacy = { 0 };
        char id[MQTT_TOPIC_MAX], sub[MQTT_TOPIC_MAX];

        snprintf(id, sizeof(id), BRIDGE_CLIENT_ID_PREFIX "%s", f->h.instance);
        snprintf(sub, sizeof(sub), "%s/#", topic(f, "set", NULL));
        assert_int_equal(mqtt_client_start(&legacy, f->broker.port, id, false, sub, 1,
                                           T_START_MS), 0);
        mqtt_client_stop(&legacy);
}

/* While the bridge is stopped, a.Lat is written through MQTT (remote), then locally (local); the
 * bridge starts again, and after a barrier write a.Lat still holds the local value. */
static void write_while_away(struct fx *f, const char *remote, const char *local, bool legacy,
                             const char *barrier_value)
{
        stop_bridge(f, SIGTERM);
        wait_value(f, topic(f, "status", NULL), "offline");
        if (legacy)
                legacy_subscription(f);
        set_taken(f, "a.Lat", remote, false);
        write_local(f, "a.Lat", local);
        start_bridge(f);
        wait_value(f, topic(f, "status", NULL), "online");
        barrier(f, barrier_value);
        assert_value(f, "a.Lat", local);
}

/* Everything up, a.Lat written through MQTT; the replies on its error topic so far. */
static uint64_t start_writes(struct fx *f, const char *sub_id)
{
        start_all(f, sub_id);
        set(f, "a.Lat", "1.5", 3);
        wait_value(f, topic(f, "b.Lat", NULL), "1.5");
        return refusals(f, "a.Lat");
}

/* A retained set/ is never a write: refused with its reason when it is published (the writes'
 * subscription keeps the retain flag of a message as published) and again whenever the bridge
 * subscribes, here after a restart, while a later local write stands. An empty retained message
 * (the publisher clearing it) is neither a write nor refused. */
static void test_set_retained(void **state)
{
        struct fx *f = *state;
        uint64_t n;

        n = start_writes(f, "test-retained");

        set_taken(f, "a.Lat", "9.5", true);
        barrier(f, "2.5");
        assert_value(f, "a.Lat", "1.5");
        wait_refusal(f, "a.Lat", n + 1, "retained");

        write_local(f, "a.Lat", "2.5");
        restart_bridge(f);
        barrier(f, "3.5");
        assert_value(f, "a.Lat", "2.5");
        wait_refusal(f, "a.Lat", n + 2, "retained");

        set_taken(f, "a.Lat", "", true);        /* cleared */
        barrier(f, "4.5");
        assert_int_equal(refusals(f, "a.Lat"), n + 2);
        assert_value(f, "a.Lat", "2.5");
}

/* A write published while the bridge is away never comes back after a later local write:
 *  - in the persistent session an older bridge left subscribed to set/# (here made by hand) it
 *    waits, arrives on the bridge's own connection at its start and is refused, "queued";
 *  - the bridge then drops that subscription, and its writes' session is clean: a write
 *    published while it is away again is dropped by the broker, neither applied nor answered. */
static void test_set_queued(void **state)
{
        struct fx *f = *state;
        uint64_t n;

        n = start_writes(f, "test-queued");

        write_while_away(f, "7.5", "2.5", true, "3.5");
        wait_refusal(f, "a.Lat", n + 1, "queued");

        write_while_away(f, "8.5", "4.5", false, "5.5");
        assert_int_equal(refusals(f, "a.Lat"), n + 1);
}

/* ---- events ---------------------------------------------------------------------------------- */

static size_t pkt(const char *body, char *out)
{
        return harness_circe_packet(body, out);
}

/* Plays the mediator: answers the controller's Login with a Keep Alive. */
static void mediator_login(struct fx *f)
{
        char buf[PKT_MAX];
        size_t n;

        assert_true(harness_read_until(f->master, buf, sizeof(buf), 0x03, T_WAIT_MS) > 0);
        assert_non_null(strstr(buf, "01\t"));
        n = pkt("51\t010:0.2.3\t012:0\t", buf);
        assert_int_equal(harness_write_all(f->master, buf, n, T_WAIT_MS), 0);
}

/* The CIRCE link's counters, for a failure message: did the daemon get every packet? */
static void dump_link(struct fx *f)
{
        struct sl_link_info li = { .size = sizeof(li) };
        int n = sl_link_count(f->cl);

        for (int l = 0; l < n; l++) {
                if (sl_link_info(f->cl, l, &li) < 0 || strcmp(li.name, "agility") != 0)
                        continue;
                print_message("link %s: %s for %llu ms\n", li.name, li.state_name,
                              (unsigned long long)(li.state_age_ns / 1000000u));
                for (unsigned k = 0; k < li.counter_count; k++)
                        if (li.counters[k].value)
                                print_message("  %s %llu\n", li.counters[k].name,
                                              (unsigned long long)li.counters[k].value);
        }
}

/* Gate passages first..last-1 (sensor time = number), in batches, never more than EVENTS_AHEAD
 * ahead of the subscriber unless the bridge or the broker is down (then `ahead` is raised). */
static void passages(struct fx *f, int first, int last, bool wait_subscriber)
{
        char buf[BATCH * PKT_MAX + 1], body[PKT_MAX];

        for (int i = first; i < last;) {
                size_t len = 0;

                if (wait_subscriber &&
                    mqtt_client_wait_events(&f->sub, (size_t)(i > EVENTS_AHEAD ?
                                                               i - EVENTS_AHEAD : 0),
                                            T_EVENTS_MS) != 0) {
                        dump_logs(f);
                        fail_msg("subscriber stuck at %zu events (sent %d)",
                                 mqtt_client_events(&f->sub), i);
                }
                for (int k = 0; k < BATCH && i < last; k++, i++) {
                        snprintf(body, sizeof(body), "53\t015:E1E1E1\t025:%d\t", i);
                        len += pkt(body, buf + len);
                }
                assert_int_equal(harness_write_all(f->master, buf, len, T_WAIT_MS), 0);
        }
}

/* What a check allows to come twice. */
enum repeats {
        REPEATS_NONE,                   /* exactly once */
        REPEATS_BRIDGE,                 /* a killed bridge's unconfirmed tail */
};

/* A copy of what the subscriber recorded: a failure jumps out of the caller, which must not
 * hold the client's lock then. Free it. */
static struct mqtt_event *events_copy(struct fx *f, size_t *ret_n)
{
        struct mqtt_event *events;

        pthread_mutex_lock(&f->sub.lock);
        *ret_n = f->sub.n_events;
        events = malloc(*ret_n * sizeof(*events) + 1);
        if (events)
                memcpy(events, f->sub.events, *ret_n * sizeof(*events));
        pthread_mutex_unlock(&f->sub.lock);
        assert_non_null(events);
        return events;
}

/* Sends the fence (passage number `fence`) and waits for it: everything before it is in. */
static void fence(struct fx *f, int number)
{
        passages(f, number, number + 1, false);
        if (mqtt_client_wait_sensor_time(&f->sub, number, T_EVENTS_MS) != 0) {
                dump_logs(f);
                fail_msg("the fence never arrived (%zu events)", mqtt_client_events(&f->sub));
        }
}

/* Exactly EVENTS_TOTAL actions, sensor times 0..N-1 in order, seq strictly increasing, no
 * overrun: nothing lost, nothing reordered, and nothing repeated beyond what `allow` says.
 * Other events (link-state) may come in between. Returns the repeats seen. */
static size_t check_events(struct fx *f, enum repeats allow)
{
        struct mqtt_event *events;
        long next = 0;
        uint64_t last_seq = 0;
        size_t repeats = 0, n;

        fence(f, EVENTS_TOTAL);
        events = events_copy(f, &n);
        for (size_t i = 0; i < n; i++) {
                const struct mqtt_event *e = &events[i];

                if (e->sensor_time == EVENTS_TOTAL)
                        break;
                if (strcmp(e->type, "overrun") == 0 || strcmp(e->type, "daemon-restarted") == 0)
                        fail_msg("unexpected %s notice before seq %llu", e->type,
                                 (unsigned long long)e->seq);
                if (allow != REPEATS_NONE && e->seq <= last_seq) {
                        /* Only something already received may come again. */
                        size_t k = i;

                        while (k-- > 0 && events[k].seq != e->seq)
                                ;
                        if (k == SIZE_MAX)
                                fail_msg("event %zu: seq %llu out of order", i,
                                         (unsigned long long)e->seq);
                        repeats++;
                        continue;
                }
                if (e->seq <= last_seq) {
                        dump_logs(f);
                        fail_msg("event %zu: seq %llu (message id %d) after %llu", i,
                                 (unsigned long long)e->seq, e->mid,
                                 (unsigned long long)last_seq);
                }
                last_seq = e->seq;
                if (strcmp(e->type, "action") != 0)
                        continue;
                if (e->sensor_time != next) {
                        dump_logs(f);
                        dump_link(f);
                        fail_msg("event %zu: gate passage %ld (seq %llu), expected %ld; the one "
                                 "before: seq %llu", i, e->sensor_time,
                                 (unsigned long long)e->seq, next,
                                 (unsigned long long)(i ? events[i - 1].seq : 0));
                }
                next++;
        }
        free(events);
        assert_int_equal(next, EVENTS_TOTAL);
        if (allow != REPEATS_NONE)
                print_message("%zu events repeated (the killed bridge's unconfirmed tail)\n",
                              repeats);
        return repeats;
}

static void events_start(struct fx *f, int qos, const char *sub_id)
{
        need_broker();
        start_daemon(f);
        f->broker.port = 0;
        start_broker(f);
        /* The subscriber keeps its session (QoS qos) across the broker's restart. */
        start_sub(f, sub_id, false, qos);
        mediator_login(f);
        write_bridge_conf(f, qos, NULL);
        start_bridge(f);
        wait_value(f, topic(f, "status", NULL), "online");
}

/* QoS 2: a bridge restart and a broker restart, each in the middle of a burst: every event
 * exactly once, in order, at a subscriber with a persistent session (what the broker queued
 * for it while it was away included), as a ground station would subscribe. */
static void test_events_exactly_once(void **state)
{
        struct fx *f = *state;
        uint64_t connects;
        int i = 3000;

        events_start(f, 2, "test-events-2");
        passages(f, 0, i, true);
        passages(f, i, i + BURST, false);               /* a burst ... */
        stop_bridge(f, SIGTERM);                        /* ... the bridge stops in it */
        passages(f, i + BURST, i + BURST + AWAY, false);        /* events while it is away */
        start_bridge(f);
        i = 6500;
        passages(f, 3000 + BURST + AWAY, i, true);
        passages(f, i, i + BURST, false);               /* a burst ... */
        connects = f->sub.connects;
        assert_int_equal(mqtt_broker_stop(&f->broker, T_STOP_MS), 0);  /* ... broker gone */
        passages(f, i + BURST, i + BURST + AWAY, false);        /* events while it is away */
        start_broker(f);
        assert_int_equal(mqtt_client_wait_connects(&f->sub, connects, T_WAIT_MS), 0);
        passages(f, i + BURST + AWAY, EVENTS_TOTAL, true);
        check_events(f, REPEATS_NONE);
        assert_int_equal(mqtt_bridge_log_contains(&f->bridge, "resuming after event"), 1);
}

/* QoS 2: the broker drops the bridge's connection in mid-burst (another client takes its
 * session over with the bridge's client id, then leaves) while the broker stays up: the
 * bridge reconnects, libmosquitto sends the unacknowledged messages again with their ids, and
 * the broker recognises them: exactly once, in order. */
static void test_events_connection_dropped(void **state)
{
        struct fx *f = *state;
        struct mqtt_client thief;
        char id[MQTT_TOPIC_MAX];
        int i = 5000;

        events_start(f, 2, "test-events-drop");
        passages(f, 0, i, true);
        assert_int_equal(mqtt_bridge_log_contains(&f->bridge, "retrying in"), 0);
        passages(f, i, i + BURST, false);
        snprintf(id, sizeof(id), "sharedlink-mqtt-%s", f->h.instance);
        memset(&thief, 0, sizeof(thief));
        assert_int_equal(mqtt_client_start(&thief, f->broker.port, id, false, NULL, 0,
                                           T_START_MS), 0);
        mqtt_client_stop(&thief);
        passages(f, i + BURST, EVENTS_TOTAL, true);
        check_events(f, REPEATS_NONE);
        /* The drop happened, and the bridge came back by itself and counted it. */
        assert_int_equal(mqtt_bridge_wait_log(&f->bridge, "retrying in", 1, T_WAIT_MS), 0);
        /* The last member: "1}" is exactly one (a plain 1 would also match 10..19). */
        wait_contains(f, topic(f, "bridge", NULL), "\"broker_errors\":1}", NULL, 0);
}

/* QoS 1: a clean bridge restart in mid-burst loses and repeats nothing. */
static void test_events_qos1_bridge_restart(void **state)
{
        struct fx *f = *state;
        int i = 4000;

        events_start(f, 1, "test-events-1");
        passages(f, 0, i, true);
        passages(f, i, i + BURST, false);
        stop_bridge(f, SIGTERM);
        passages(f, i + BURST, i + BURST + AWAY, false);
        start_bridge(f);
        passages(f, i + BURST + AWAY, EVENTS_TOTAL, true);
        check_events(f, REPEATS_NONE);
}

/* QoS 1, a bridge killed in mid-burst: nothing lost; what it had not seen confirmed (at most
 * its window of 64) comes again after its restart, with the same seq. */
static void test_events_bridge_killed(void **state)
{
        struct fx *f = *state;
        int i = 3000;

        events_start(f, 1, "test-events-kill");
        passages(f, 0, i, true);
        passages(f, i, i + BURST, false);
        stop_bridge(f, SIGKILL);
        passages(f, i + BURST, i + BURST + AWAY, false);
        start_bridge(f);
        passages(f, i + BURST + AWAY, EVENTS_TOTAL, true);
        assert_true(check_events(f, REPEATS_BRIDGE) <= BRIDGE_WINDOW);
}

/*
 * Values changed while the bridge is stopped (SIGSTOP: between two of its wake-ups, its cursor
 * kept): one value, then more changes than the daemon's change record holds (gate passages),
 * which the bridge learns as an overrun and answers by reading everything once, so the value
 * goes out; then only what changes. Then a daemon restart while it is stopped: what the new
 * daemon has goes out, and what changes after. The keepalive is long so that the broker never
 * drops the stopped bridge (a reconnection would publish everything anyway).
 */
static void test_values_overrun_restart(void **state)
{
        struct fx *f = *state;
        uint64_t cursor;
        int sent = 0;

        f->keepalive_s = LONG_KEEPALIVE_S;
        events_start(f, 1, "test-values-overrun");
        write_local(f, "b.Throttle", "-4");
        wait_value(f, topic(f, "a.Throttle", NULL), "-4");

        assert_int_equal(kill(f->bridge.pid, SIGSTOP), 0);
        assert_int_equal(slwait_changes_now(f->cl, &cursor), 0);
        write_local(f, "b.Throttle", "-5");
        assert_int_equal(slwait_value(f->cl, "a.Throttle", "-5", T_WAIT_MS, NULL, 0), 0);
        while (slwait_changes_overrun(f->cl, cursor) == 0) {
                char last[16];

                assert_true(sent < FLOOD_MAX);
                passages(f, sent, sent + BATCH, false);
                sent += BATCH;
                snprintf(last, sizeof(last), "%d", sent - 1);
                assert_int_equal(slwait_value(f->cl, "agility.device.E1E1E1.sensor_time", last,
                                              T_WAIT_MS, NULL, 0), 0);
        }
        assert_int_equal(kill(f->bridge.pid, SIGCONT), 0);
        wait_value(f, topic(f, "a.Throttle", NULL), "-5");
        wait_value(f, topic(f, "b.Throttle", NULL), "-5");
        write_local(f, "b.Throttle", "-6");
        wait_value(f, topic(f, "a.Throttle", NULL), "-6");

        assert_int_equal(kill(f->bridge.pid, SIGSTOP), 0);
        assert_true(harness_stop_daemon(&f->h, SIGTERM, T_STOP_MS) >= 0);
        start_daemon(f);
        write_local(f, "b.Throttle", "-7");
        assert_int_equal(slwait_value(f->cl, "a.Throttle", "-7", T_WAIT_MS, NULL, 0), 0);
        assert_int_equal(kill(f->bridge.pid, SIGCONT), 0);
        wait_value(f, topic(f, "a.Throttle", NULL), "-7");
        write_local(f, "b.Throttle", "-8");
        wait_value(f, topic(f, "a.Throttle", NULL), "-8");
        /* The bridge's connection to the broker held all along. */
        assert_int_equal(mqtt_bridge_log_contains(&f->bridge, "retrying in"), 0);
}

/* More events than the ring holds while the bridge is away: an "overrun" notice with the exact
 * number lost, right where the gap is, then everything after it in order. */
static void test_events_overrun(void **state)
{
        struct fx *f = *state;
        struct mqtt_event *events;
        size_t n, notices = 0;
        long next = 0;
        uint64_t lost = 0;

        events_start(f, 1, "test-events-overrun");
        passages(f, 0, 100, true);
        fence(f, 100);
        stop_bridge(f, SIGTERM);
        passages(f, 101, 101 + OVERRUN_AWAY, false);
        start_bridge(f);
        fence(f, 101 + OVERRUN_AWAY);
        events = events_copy(f, &n);
        for (size_t i = 0; i < n; i++) {
                const struct mqtt_event *e = &events[i];

                if (!strcmp(e->type, "overrun")) {
                        notices++;
                        lost = e->lost;
                        next += (long)e->lost;  /* only passages were written meanwhile */
                        continue;
                }
                if (strcmp(e->type, "action") != 0)
                        continue;
                if (e->sensor_time != next)
                        fail_msg("event %zu: gate passage %ld, expected %ld", i,
                                 e->sensor_time, next);
                next++;
        }
        free(events);
        assert_int_equal(notices, 1);
        assert_true(lost >= OVERRUN_AWAY - RING_EVENTS);
        assert_int_equal(next, 101 + OVERRUN_AWAY + 1);
}

/* ---- TLS and passwords ----------------------------------------------------------------------- */

#define TLS_USER        "truck7"
#define TLS_PASSWORD    "s3cret"
#define RETRIES         3       /* refused attempts seen before "it never published" */

/* A throwaway CA, a server certificate it signs (CN 127.0.0.1: libmosquitto checks the host
 * name, and OpenSSL compares the CN when there is no DNS subjectAltName), a second CA that
 * signed nothing of ours, and a mosquitto password file; all in the test's directory. */
static int tls_files(struct fx *f)
{
        char cmd[PATH_BUF * 4 + 1024];
        int r;

        if (access("/usr/bin/openssl", X_OK) != 0 || access("/usr/bin/mosquitto_passwd", X_OK))
                return -ENOENT;
        r = snprintf(cmd, sizeof(cmd),
                     "cd %s && { "
                     "openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes "
                     "-keyout ca.key -out ca.crt -days 2 -subj /CN=sharedlink-test-ca && "
                     "openssl req -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes "
                     "-keyout server.key -out server.csr -subj /CN=127.0.0.1 && "
                     "openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial "
                     "-out server.crt -days 2 && "
                     "openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes "
                     "-keyout other.key -out other.crt -days 2 -subj /CN=some-other-ca && "
                     "mosquitto_passwd -c -b passwd %s %s && "
                     "printf '%%s\\n' %s > password && printf 'wrong\\n' > wrong-password; "
                     "} >tls.log 2>&1",
                     f->h.dir, TLS_USER, TLS_PASSWORD, TLS_PASSWORD);
        if (r < 0 || (size_t)r >= sizeof(cmd))
                return -ENAMETOOLONG;
        return system(cmd) == 0 ? 0 : -EIO;
}

/* A broker with a TLS listener that wants a username and password, and a subscriber that has
 * both; the bridge gets the password in password_file and the CA in ca_file (names in the
 * test's directory). */
static void tls_start(struct fx *f, const char *password_file, const char *ca_file)
{
        static char listener[PATH_BUF * 4];
        char ca[PATH_BUF], extra[CONFIG_MAX / 2];
        struct mqtt_client_auth auth = { .ca_file = ca, .username = TLS_USER,
                                         .password = TLS_PASSWORD };
        char sub[MQTT_TOPIC_MAX];

        need_broker();
        if (tls_files(f) < 0) {
                print_message("openssl or mosquitto_passwd missing (make deps): skipped\n");
                skip();
        }
        start_daemon(f);
        snprintf(listener, sizeof(listener),
                 "cafile %s/ca.crt\ncertfile %s/server.crt\nkeyfile %s/server.key\n"
                 "password_file %s/passwd\nallow_anonymous false\n",
                 f->h.dir, f->h.dir, f->h.dir, f->h.dir);
        f->broker.listener_conf = listener;
        f->broker.port = 0;
        start_broker(f);
        snprintf(ca, sizeof(ca), "%s/ca.crt", f->h.dir);
        snprintf(sub, sizeof(sub), "%s/#", f->base);
        assert_int_equal(mqtt_client_start_auth(&f->sub, f->broker.port, "test-tls", true, sub, 1,
                                                &auth, T_START_MS), 0);
        snprintf(extra, sizeof(extra), "  username: %s\n  password_file: %s/%s\n"
                 "  tls: {ca_file: %s/%s}\n", TLS_USER, f->h.dir, password_file, f->h.dir,
                 ca_file);
        write_bridge_conf_broker(f, 1, extra, NULL);
        start_bridge(f);
}

/* TLS (ca_file) and username/password_file: values round-trip through the broker. */
static void test_tls_password(void **state)
{
        struct fx *f = *state;

        tls_start(f, "password", "ca.crt");
        wait_value(f, topic(f, "status", NULL), "online");
        set(f, "a.Lat", "12.5", 4);
        wait_value(f, topic(f, "b.Lat", NULL), "12.5");
        assert_int_equal(mqtt_bridge_wait_status(&f->bridge, "STATUS=broker connected,",
                                                 T_WAIT_MS), 0);
}

/* Refused attempts: the reason logged (once as an error) and in the service status, retries
 * backing off to reconnect_max_ms, nothing published; then a clean stop. */
static void refused_connections(struct fx *f, const char *why)
{
        char status[128];

        if (mqtt_bridge_wait_log(&f->bridge, why, RETRIES, T_WAIT_MS) != 0) {
                dump_logs(f);
                fail_msg("the bridge's log does not say \"%s\" %d times", why, RETRIES);
        }
        snprintf(status, sizeof(status), "STATUS=broker disconnected (%s", why);
        assert_int_equal(mqtt_bridge_wait_status(&f->bridge, status, T_WAIT_MS), 0);
        /* The backoff doubles from 50 ms up to reconnect_max_ms (400), and stays there. */
        assert_int_equal(mqtt_bridge_wait_log(&f->bridge, "retrying in 400 ms", 2, T_WAIT_MS),
                         0);
        assert_int_equal(mqtt_bridge_log_contains(&f->bridge, "retrying in 200 ms"), 1);
        assert_int_equal(mqtt_client_count(&f->sub, topic(f, "status", NULL)), 0);
        assert_int_equal(mqtt_client_count(&f->sub, topic(f, "bridge", NULL)), 0);
        stop_bridge(f, SIGTERM);
}

static void test_wrong_password(void **state)
{
        struct fx *f = *state;

        tls_start(f, "wrong-password", "ca.crt");
        refused_connections(f, "refused the connection: Connection Refused: not authorised");
        /* An error and a warning once, then quieter: no log flood while it retries. */
        assert_int_equal(mqtt_bridge_wait_log(&f->bridge, "<3>broker", 1, T_WAIT_MS), 0);
        assert_true(mqtt_bridge_wait_log(&f->bridge, "<3>broker", 2, 0) != 0);
        assert_true(mqtt_bridge_wait_log(&f->bridge, "<4>broker", 2, 0) != 0);
}

static void test_wrong_ca(void **state)
{
        struct fx *f = *state;

        tls_start(f, "password", "other.crt");
        /* OpenSSL's words; the error code in front of them differs between its versions. */
        refused_connections(f, "TLS: OpenSSL Error");
        assert_int_equal(mqtt_bridge_log_contains(&f->bridge, "certificate verify failed"), 1);
}

/*
 * One bridge per instance and topic prefix: a second sharedlink-mqtt on the same ones refuses to
 * start (exit 3), naming the first by its pid, and publishes nothing; one with another prefix runs
 * beside it; once the first is killed with SIGKILL (no cleanup), its successor starts at once.
 */
static void test_second_bridge(void **state)
{
        struct fx *f = *state;
        char want[PATH_BUF], why[HARNESS_WHY_MAX], text[CONFIG_MAX], other[PATH_BUF];
        const char *argv[] = { mqtt_bridge_path(), "-c", f->bridge_conf, NULL };
        struct harness second;
        int st = 0;

        need_broker();
        start_broker(f);
        write_bridge_conf(f, 1, NULL);
        start_bridge(f);
        snprintf(want, sizeof(want), "another sharedlink-mqtt (pid %ld) already bridges topics "
                 "%s/... (lock %s/", (long)f->bridge.pid, f->base, f->h.dir);
        if (harness_start_refused(&f->h, "mqtt2", argv, T_START_MS, 3, want, why,
                                  sizeof(why)) < 0)
                fail_msg("%s", why);

        assert_int_equal(harness_init(&second, "mqtt3"), 0);
        snprintf(text, sizeof(text), "instance: %s\nprefix: other\nbroker: {host: 127.0.0.1, "
                 "port: %d}\ncursor_file: %s/cursor2\n", f->h.instance, f->broker.port,
                 second.dir);
        assert_int_equal(harness_write_file(&second, "other.yaml", text, other), 0);
        argv[2] = other;
        assert_int_equal(harness_start_program(&second, &f->h, argv, T_START_MS, &st), 0);
        assert_int_equal(harness_stop_daemon(&second, SIGTERM, T_STOP_MS), 0);
        harness_cleanup(&second);

        assert_true(mqtt_bridge_stop(&f->bridge, SIGKILL, T_STOP_MS) >= 0);
        start_bridge(f);
        stop_bridge(f, SIGTERM);
}

static void test_check_config(void **state)
{
        struct fx *f = *state;
        char path[PATH_BUF], out[1024], err[1024], want[PATH_BUF + 64];
        const char *argv[] = { mqtt_bridge_path(), "-n", "-c", path, NULL };

        if (!f->h.dir[0])
                assert_int_equal(harness_init(&f->h, "mqttcfg"), 0);
        assert_int_equal(harness_write_file(&f->h, "bad.yaml",
                                            "broker:\n  host: x\n  port: 70000\n", path), 0);
        assert_int_equal(harness_run_capture(&f->h, out, sizeof(out), err, sizeof(err), T_WAIT_MS,
                                             argv), 1);
        snprintf(want, sizeof(want), "%s:3:9: port 70000 out of range (1..65535)", path);
        assert_non_null(strstr(err, want));
        assert_int_equal(harness_write_file(&f->h, "good.yaml", "prefix: fleet/car1\n", path), 0);
        assert_int_equal(harness_run_capture(&f->h, out, sizeof(out), err, sizeof(err), T_WAIT_MS,
                                             argv), 0);
        assert_string_equal(out, "configuration OK\n");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_check_config, setup, teardown),
                cmocka_unit_test_setup_teardown(test_second_bridge, setup, teardown),
                cmocka_unit_test_setup_teardown(test_values_round_trip, setup, teardown),
                cmocka_unit_test_setup_teardown(test_refused_writes, setup, teardown),
                cmocka_unit_test_setup_teardown(test_stale_and_daemon_restart, setup, teardown),
                cmocka_unit_test_setup_teardown(test_values_overrun_restart, setup, teardown),
                cmocka_unit_test_setup_teardown(test_events_exactly_once, setup, teardown),
                cmocka_unit_test_setup_teardown(test_events_qos1_bridge_restart, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_events_bridge_killed, setup, teardown),
                cmocka_unit_test_setup_teardown(test_events_overrun, setup, teardown),
                cmocka_unit_test_setup_teardown(test_events_connection_dropped, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_set_bad_topics, setup, teardown),
                cmocka_unit_test_setup_teardown(test_set_retained, setup, teardown),
                cmocka_unit_test_setup_teardown(test_set_queued, setup, teardown),
                cmocka_unit_test_setup_teardown(test_tls_password, setup, teardown),
                cmocka_unit_test_setup_teardown(test_wrong_password, setup, teardown),
                cmocka_unit_test_setup_teardown(test_wrong_ca, setup, teardown),
        };

        /* MQTT_TEST_FILTER=test_values* runs only the matching tests (debugging). */
        if (getenv("MQTT_TEST_FILTER"))
                cmocka_set_test_filter(getenv("MQTT_TEST_FILTER"));
        return cmocka_run_group_tests(tests, NULL, NULL);
}
