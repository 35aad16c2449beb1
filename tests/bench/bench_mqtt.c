/*
 * sharedlink-mqtt: latency and throughput of the bridge, with a real sharedlinkd (one SharedLink
 * link on a pty pair whose master the benchmark holds, playing the peer), a private mosquitto on
 * 127.0.0.1 and a libmosquitto subscriber, measured side by side in one run:
 *
 *   floor     an MQTT publish by a client of the benchmark -> the subscriber (the broker's own
 *             cost: what any MQTT path pays);
 *   write     sl_write() of an outbound variable -> the subscriber has its value (library,
 *             the bridge's wake-up and scan, the broker);
 *   frame     a SharedLink frame written into the pty master -> the subscriber has the new
 *             inbound value (pty, daemon decode, table, bridge, broker);
 *   rate      1,000 inbound variables all changed in every round of frames, as fast as the pty
 *             takes them, for RATE_S seconds: the value messages per second the bridge gets out
 *             (changes between two scans coalesce: the latest value wins), and the bridge's CPU
 *             time per 1,000 MQTT messages (values + meta);
 *   wake      the bridge's CPU per wake-up with 1,000 variables and one of them changing (v0, one
 *             frame, its sample awaited before the next), side by side in three alternating
 *             rounds: the bridge restarted with SHAREDLINK_CHANGES=all (every wake-up reads all
 *             1,000 variables, as before the change record: forced), then without (it reads only
 *             what sl_changed names); the medians of the rounds are the figures.
 *
 * The latency probes take one sample each in turn (interleaved). Prints the figures and ratios;
 * exit status 0 unless something failed to run. Needs mosquitto (make deps); skipped otherwise.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <sharedlink.h>

#include "common/benchlat.h"
#include "common/benchlink.h"
#include "common/harness.h"
#include "common/mqtt.h"

#define SAMPLES         1000
#define WARMUP          50
#define GAP_US          500             /* between samples: no queueing between them */
#define VARS            BENCHLINK_VARS
#define RATE_S          3
#define START_MS        10000
#define WAIT_MS         3000            /* one sample must not take longer */
#define CONFIG_MAX      (64 * 1024)
#define NS_PER_S        1000000000ull
#define WAKES           1000            /* wake-ups measured in each series of `wake` */

enum probe { P_FLOOR, P_WRITE, P_FRAME, P_COUNT };

static const char *const probe_name[P_COUNT] = { "floor", "write", "frame" };

struct bench {
        struct harness h;
        struct mqtt_broker broker;
        struct mqtt_bridge bridge;
        struct mqtt_client sub, pub;
        struct sl_client *cl;
        int master, slave;
        char base[128];
        char topic[P_COUNT][MQTT_TOPIC_MAX];
        _Atomic long want[P_COUNT];     /* the sample number awaited on each probe's topic */
        _Atomic uint64_t got_ns[P_COUNT];
        _Atomic uint64_t values, metas;  /* rate: messages on v* topics */
        atomic_bool drain_stop;
        int id_cmd;                     /* o.Cmd */
};

static struct bench B;

/* "[:" dst src "|" body "|C" hh "]\r\n" */
static size_t make_frame(char *out, size_t size, char src, const char *body)
{
        unsigned sum = ':' + 'A' + (unsigned char)src + '|' + '|' + 'C';

        for (const char *p = body; *p; p++)
                sum += (unsigned char)*p;
        return (size_t)snprintf(out, size, "[:A%c|%s|C%02X]\r\n", src, body, sum & 0xffu);
}

static void on_message(void *arg, const char *topic, const void *payload, size_t len)
{
        struct bench *b = arg;
        uint64_t now = harness_now_ns();
        char text[32];
        size_t bl = strlen(b->base);

        (void)arg;
        if (!strncmp(topic, b->base, bl) && topic[bl] == '/' && topic[bl + 1] == 'v') {
                if (strstr(topic, "/meta"))
                        atomic_fetch_add(&b->metas, 1);
                else
                        atomic_fetch_add(&b->values, 1);
        }
        if (len == 0 || len >= sizeof(text))
                return;
        memcpy(text, payload, len);
        text[len] = '\0';
        for (int p = 0; p < P_COUNT; p++)
                if (!strcmp(topic, b->topic[p]) && strtol(text, NULL, 10) == atomic_load(&b->want[p]))
                        atomic_store(&b->got_ns[p], now);
}

/* The daemon answers nothing we need; its bytes are read and dropped so the pty never fills. */
static void *drain_main(void *arg)
{
        struct bench *b = arg;
        char buf[4096];

        while (!atomic_load(&b->drain_stop)) {
                struct pollfd p = { .fd = b->master, .events = POLLIN };

                if (poll(&p, 1, 100) > 0 && read(b->master, buf, sizeof(buf)) < 0 &&
                    errno != EAGAIN)
                        break;
        }
        return NULL;
}

static int start(struct bench *b)
{
        static char text[CONFIG_MAX];
        char path[HARNESS_PATH_MAX], slave[HARNESS_PATH_MAX], dev[HARNESS_PATH_MAX + 8];
        char bdir[HARNESS_PATH_MAX + 8];
        size_t n;
        int st = 0;

        if (harness_init(&b->h, "bmqtt") < 0 || harness_openpty(&b->master, &b->slave, slave) < 0)
                return -1;
        snprintf(dev, sizeof(dev), "%s/dev0", b->h.dir);
        if (symlink(slave, dev) < 0)
                return -1;
        n = benchlink_config(text, sizeof(text), b->h.instance, dev, NULL, "o.Cmd");
        if (n == 0 || harness_write_file(&b->h, "daemon.yaml", text, path) < 0)
                return -1;
        b->h.capture_log = 1;
        if (harness_start_daemon(&b->h, path, START_MS, &st, NULL) != 0) {
                fprintf(stderr, "bench_mqtt: sharedlinkd did not start (%d)\n", st);
                return -1;
        }
        if (sl_open(b->h.instance, &b->cl) < 0)
                return -1;
        snprintf(bdir, sizeof(bdir), "%s/broker", b->h.dir);
        mkdir(bdir, 0755);
        if (mqtt_broker_start(&b->broker, bdir, 0, START_MS) < 0) {
                fprintf(stderr, "bench_mqtt: mosquitto did not start\n");
                return -1;
        }
        snprintf(text, sizeof(text), "instance: %s\nbroker: {host: 127.0.0.1, port: %d}\n"
                 "cursor_file: %s/cursor\n", b->h.instance, b->broker.port, b->h.dir);
        if (harness_write_file(&b->h, "bridge.yaml", text, path) < 0)
                return -1;
        b->bridge.notify_fd = -1;
        if (mqtt_bridge_start(&b->bridge, &b->h, path, START_MS, &st) != 0) {
                fprintf(stderr, "bench_mqtt: sharedlink-mqtt did not start (%d)\n", st);
                return -1;
        }
        snprintf(b->base, sizeof(b->base), "sharedlink/%s", b->h.instance);
        snprintf(b->topic[P_FLOOR], MQTT_TOPIC_MAX, "%s/floor", b->base);
        snprintf(b->topic[P_WRITE], MQTT_TOPIC_MAX, "%s/o.Cmd", b->base);
        snprintf(b->topic[P_FRAME], MQTT_TOPIC_MAX, "%s/v0", b->base);
        for (int p = 0; p < P_COUNT; p++)
                atomic_store(&b->want[p], -1);
        {
                char sub[MQTT_TOPIC_MAX];

                snprintf(sub, sizeof(sub), "%s/#", b->base);
                if (mqtt_client_start(&b->sub, b->broker.port, "bench-sub", true, sub, 0,
                                      START_MS) < 0 ||
                    mqtt_client_start(&b->pub, b->broker.port, "bench-pub", true, NULL, 0,
                                      START_MS) < 0)
                        return -1;
        }
        b->sub.on_message_arg = b;
        b->sub.on_message = on_message;
        return 0;
}

/* One sample of probe p with value v: its latency in ns, or 0 when it never arrived. */
static uint64_t sample(struct bench *b, enum probe p, long v, int id_cmd)
{
        char text[32], body[64], frame[128];
        uint64_t t0, deadline;

        snprintf(text, sizeof(text), "%ld", v);
        atomic_store(&b->got_ns[p], 0);
        atomic_store(&b->want[p], v);
        t0 = harness_now_ns();
        switch (p) {
        case P_FLOOR:
                mqtt_client_publish(&b->pub, b->topic[P_FLOOR], text, strlen(text), 0, false);
                break;
        case P_WRITE:
                sl_write(b->cl, id_cmd, text);
                break;
        case P_FRAME:
                snprintf(body, sizeof(body), "N0|D%s", text);
                harness_write_all(b->master, frame, make_frame(frame, sizeof(frame), 'B', body),
                                  WAIT_MS);
                break;
        case P_COUNT:
                break;
        }
        deadline = t0 + WAIT_MS * 1000000ull;
        while (!atomic_load(&b->got_ns[p]) && harness_now_ns() < deadline)
                ;       /* spin: the sample is microseconds; a sleep would dominate it */
        return atomic_load(&b->got_ns[p]) ? atomic_load(&b->got_ns[p]) - t0 : 0;
}

static uint64_t sample_probe(void *arg, int p, long v)
{
        struct bench *b = arg;

        return sample(b, (enum probe)p, v, b->id_cmd);
}

static void latency(struct bench *b)
{
        struct benchlat l = { .probes = P_COUNT, .names = probe_name, .samples = SAMPLES,
                              .warmup = WARMUP, .gap_us = GAP_US, .first_value = 100000,
                              .sample = sample_probe, .arg = b };

        b->id_cmd = sl_find(b->cl, "o.Cmd");
        if (benchlat_run(&l) < 0)
                return;
        printf("  write/floor median %.2fx, frame/floor median %.2fx\n",
               l.median_us[P_WRITE] / l.median_us[P_FLOOR],
               l.median_us[P_FRAME] / l.median_us[P_FLOOR]);
}

static int cpu_ticks(pid_t pid, uint64_t *ret)
{
        char path[64], buf[1024], *p;
        unsigned long ut, st;
        FILE *f;

        snprintf(path, sizeof(path), "/proc/%ld/stat", (long)pid);
        f = fopen(path, "r");
        if (!f)
                return -errno;
        if (!fgets(buf, sizeof(buf), f)) {
                fclose(f);
                return -EIO;
        }
        fclose(f);
        p = strrchr(buf, ')');
        if (!p || sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %lu %lu", &ut,
                         &st) != 2)
                return -EIO;
        *ret = ut + st;
        return 0;
}

static void rate(struct bench *b)
{
        uint64_t t0, t1, c0, c1, v0, m0, v, m, rounds = 0;
        long hz = sysconf(_SC_CLK_TCK);
        double secs, cpu_s;

        cpu_ticks(b->bridge.pid, &c0);
        v0 = atomic_load(&b->values);
        m0 = atomic_load(&b->metas);
        t0 = harness_now_ns();
        rounds = benchlink_offer(b->master, RATE_S, WAIT_MS);
        t1 = harness_now_ns();
        /* What was sent is out within a moment; the count stops growing. */
        for (uint64_t last = UINT64_MAX; last != atomic_load(&b->values);) {
                last = atomic_load(&b->values);
                usleep(200000);
        }
        cpu_ticks(b->bridge.pid, &c1);
        v = atomic_load(&b->values) - v0;
        m = atomic_load(&b->metas) - m0;
        secs = (double)(t1 - t0) / NS_PER_S;
        cpu_s = (double)(c1 - c0) / (double)hz;
        printf("rate, %d variables, %d s:\n", VARS, RATE_S);
        printf("  offered  %10.0f changes/s (%llu rounds of %d)\n", (double)rounds * VARS / secs,
               (unsigned long long)rounds, VARS);
        printf("  bridged  %10.0f value messages/s (+ %.0f meta/s), %.0f%% of the changes\n",
               (double)v / secs, (double)m / secs, 100.0 * (double)v / ((double)rounds * VARS));
        printf("  bridge CPU %.2f s: %.1f ms per 1,000 MQTT messages (values + meta)\n", cpu_s,
               (v + m) ? 1000.0 * cpu_s * 1000.0 / (double)(v + m) : 0.0);
}

/* Stops the bridge and starts it again, with SHAREDLINK_CHANGES=all in its environment when
 * full_read (benchlat_restart_fn); its pid, or -1. */
static pid_t restart_bridge(void *arg, bool full_read)
{
        struct bench *b = arg;
        char path[HARNESS_PATH_MAX + 16];
        int st = 0, r;

        mqtt_bridge_stop(&b->bridge, SIGTERM, START_MS);
        snprintf(path, sizeof(path), "%s/bridge.yaml", b->h.dir);
        if (full_read)
                setenv("SHAREDLINK_CHANGES", "all", 1);
        r = mqtt_bridge_start(&b->bridge, &b->h, path, START_MS, &st);
        unsetenv("SHAREDLINK_CHANGES");
        if (r != 0) {
                fprintf(stderr, "bench_mqtt: sharedlink-mqtt did not start again (%d)\n", st);
                return -1;
        }
        return b->bridge.pid;
}

/* `wake`: the bridge's CPU per wake-up, full read (forced) and changed only (benchlat.h). */
static int wake(struct bench *b)
{
        struct benchlat l = { .samples = WAKES, .gap_us = GAP_US, .sample = sample_probe,
                              .arg = b };
        long value = 500000;

        printf("wake, %d variables:\n", VARS);
        return benchlat_wake_compare(&l, P_FRAME, restart_bridge, &value, "mqtt", "MQTT");
}

int main(void)
{
        int rc = 0;
        struct bench *b = &B;
        pthread_t drain;
        char load[128] = "";
        FILE *f;

        if (!mqtt_broker_available()) {
                printf("bench_mqtt: mosquitto not installed (make deps): skipped\n");
                return 0;
        }
        b->master = b->slave = -1;
        if (start(b) < 0)
                return 1;
        if (pthread_create(&drain, NULL, drain_main, b) != 0)
                return 1;
        f = fopen("/proc/loadavg", "r");
        if (f && fgets(load, sizeof(load), f))
                load[strcspn(load, "\n")] = '\0';
        if (f)
                fclose(f);
        printf("sharedlink-mqtt bench (load average at start: %s)\n", load);
        latency(b);
        rate(b);
        if (wake(b) < 0)
                rc = 1;
        atomic_store(&b->drain_stop, true);
        pthread_join(drain, NULL);
        mqtt_client_stop(&b->sub);
        mqtt_client_stop(&b->pub);
        mqtt_bridge_stop(&b->bridge, SIGTERM, START_MS);
        mqtt_bridge_cleanup(&b->bridge);
        mqtt_broker_stop(&b->broker, START_MS);
        sl_close(b->cl);
        harness_cleanup(&b->h);
        return rc;
}
