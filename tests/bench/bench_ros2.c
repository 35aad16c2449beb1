/*
 * sharedlink-ros2: latency and rate of the ROS 2 bridge, with a real sharedlinkd (one SharedLink
 * link on a pty pair whose master the benchmark holds, playing the peer) and a real
 * sharedlink-ros2, seen by a Cyclone DDS subscriber in this process, measured side by side in
 * one run against the floors any such path pays:
 *
 *   pty       a frame written into the master of a second pty pair -> read on its slave by a
 *             thread blocked in read() (the pty hop, with no daemon);
 *   floor     dds_write() of an Int64 in a child process (plain Cyclone, the bridge's writer QoS:
 *             RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1) -> this process's reader listener (the
 *             DDS hop between two processes over loopback: what the bridge's publish pays);
 *   bridge    a SharedLink frame written into the daemon's pty master -> the reader listener has
 *             the new value of the long variable v0 on rt/bench/v0 (pty, daemon decode, table,
 *             sharedlink-ros2's wake-up and publish, Cyclone);
 *   rate      1,000 long variables v0..v999, all changed in every round of frames, as fast as the
 *             pty takes them, for RATE_S seconds: the samples per second 1,000 ROS-default readers
 *             get (changes between two scans coalesce: the latest value wins), and the bridge's
 *             CPU time (all its threads) per 1,000 samples;
 *   wake      the bridge's CPU per wake-up with 1,000 variables and one of them changing (v0, one
 *             frame, its sample awaited before the next), side by side in three alternating
 *             rounds: the bridge restarted with SHAREDLINK_CHANGES=all (every wake-up reads all
 *             1,000 variables, as before the change record: forced), then without (it reads only
 *             what sl_changed names); the medians of the rounds are the figures.
 *   spin      the three latency probes again with the bridge restarted on the opt-in
 *             `wait_spin_us: SPIN_US` (its waker polls the table before it sleeps), with the
 *             bridge's CPU per sample: what the spin buys and costs, next to the default above,
 *             which alone is the figure the goal is about.
 *
 * The readers are ROS-default subscribers (RELIABLE, VOLATILE, KEEP_LAST 10) of
 * std_msgs/msg/Int64 with the test peers' own copy of the type (tests/ros2peer/). The latency
 * probes take one sample each in turn (interleaved, GAP_US apart); each blocks on a condition
 * variable the listener signals (no spinning: two CPUs, and the daemon, the bridge and Cyclone's
 * threads need them). The goal (issue 22): bridge median <= 1.5 x (floor + pty) medians.
 *
 * Network: every participant (this process, the floor child, the bridge) runs on
 * tests/ros2peer/cyclonedds.xml, unicast on 127.0.0.1 only, on a domain id of this run's own.
 * Prints the figures, the ratio and the load average at start and end; exit status 0 unless
 * something failed to run. Without Cyclone DDS it is skipped; without a built sharedlink-ros2
 * only the floors are measured.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#if HAVE_CYCLONEDDS
#include <dds/dds.h>

#include <sharedlink.h>

#include "common/benchlat.h"
#include "common/benchlink.h"
#include "common/harness.h"
#include "common/wire.h"
#include "ros2peer_types.h"

#define SAMPLES         1000
#define WARMUP          50
#define GAP_US          500             /* between samples: no queueing between them */
#define VARS            BENCHLINK_VARS
#define RATE_S          3
#define START_MS        30000           /* a daemon's READY=1; every reader matched */
#define WAIT_MS         5000            /* one sample must not take longer */
#define SETTLE_MS       200             /* rate: the count has stopped growing for this long */
#define CONFIG_MAX      (64 * 1024)
#define TOPIC_MAX       64
#define DOMAIN_BASE     50              /* domain ids 50..99, by pid: this run's own */
#define DOMAIN_SPAN     50
#define CYCLONE_XML     "tests/ros2peer/cyclonedds.xml"
#define NAMESPACE       "/bench"
#define FLOOR_ARG       "--floor-publisher"
#define GOAL_RATIO      1.5
#define WAKES           1000            /* wake-ups measured in each series of `wake` */
#define SPIN_US         2000            /* the spin series' budget: longer than a round of probes,
                                         * so that its frame comes while the waker spins */
#define NS_PER_MS       1000000ull
#define NS_PER_S        1000000000ull

enum probe { P_PTY, P_FLOOR, P_BRIDGE, P_COUNT };

static const char *const probe_name[P_COUNT] = { "pty", "floor", "bridge" };

struct bench {
        struct harness h, r;            /* sharedlinkd, sharedlink-ros2 */
        bool bridge;                    /* sharedlink-ros2 is built: the bridge part runs */
        int master, slave;              /* the daemon's link */
        int pty_master, pty_slave;      /* the pty floor's pair */
        unsigned domain;
        char uri[PATH_MAX + 8];
        dds_entity_t pp, topic_floor;
        dds_entity_t readers[VARS];     /* rt/bench/v<i> */
        dds_entity_t reader_floor;
        pid_t floor_pid;
        int floor_cmd;                  /* pipe to the floor child: one byte per sample */
        pthread_mutex_t m;
        pthread_cond_t cv;
        long want[P_COUNT];             /* the value awaited on each probe (under m) */
        uint64_t got_ns[P_COUNT];       /* when it came; 0 before */
        atomic_ullong samples;          /* rate: samples taken by the v* readers */
        atomic_bool stop;
};

static struct bench B;

static uint64_t now_ns(void)
{
        return harness_now_ns();
}

/* A probe's value arrived at t (any thread). */
static void arrived(struct bench *b, enum probe p, long v, uint64_t t)
{
        pthread_mutex_lock(&b->m);
        if (v == b->want[p] && !b->got_ns[p]) {
                b->got_ns[p] = t;
                pthread_cond_broadcast(&b->cv);
        }
        pthread_mutex_unlock(&b->m);
}

/* ---- the floor child: plain Cyclone, one write per byte on its stdin ---- */

/* Writes Int64 samples whose value is the CLOCK_MONOTONIC time of the write (the clock is the
 * machine's, so the reader's arrival time minus it is the latency). */
static int floor_publisher(unsigned domain, const char *uri)
{
        dds_entity_t pp, topic, w;
        dds_qos_t *q = dds_create_qos();
        std_msgs_msg_dds__Int64_ s;
        char c;

        if (dds_create_domain(domain, uri) < 0)
                return 1;
        pp = dds_create_participant(domain, NULL, NULL);
        topic = dds_create_topic(pp, &std_msgs_msg_dds__Int64__desc, "rt/bench/floor", NULL, NULL);
        dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_INFINITY);
        dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
        dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
        w = dds_create_writer(pp, topic, q, NULL);
        dds_delete_qos(q);
        if (pp < 0 || topic < 0 || w < 0)
                return 1;
        while (read(STDIN_FILENO, &c, 1) == 1) {
                s.data = (int64_t)now_ns();
                dds_write(w, &s);
        }
        dds_delete(DDS_CYCLONEDDS_HANDLE);
        return 0;
}

static int start_floor_child(struct bench *b)
{
        char domain[16];
        int fds[2];

        snprintf(domain, sizeof(domain), "%u", b->domain);
        if (pipe2(fds, O_CLOEXEC) < 0)
                return -errno;
        b->floor_pid = fork();
        if (b->floor_pid < 0)
                return -errno;
        if (b->floor_pid == 0) {
                dup2(fds[0], STDIN_FILENO);
                execl("/proc/self/exe", "bench_ros2", FLOOR_ARG, domain, b->uri, (char *)NULL);
                _exit(127);
        }
        close(fds[0]);
        b->floor_cmd = fds[1];
        return 0;
}

/* ---- this process's readers ---- */

/* Takes one Int64 sample of rd into *ret with its arrival time; false when none is left. */
static bool take_int64(dds_entity_t rd, int64_t *ret, uint64_t *ret_t)
{
        std_msgs_msg_dds__Int64_ s;
        void *ptr = &s;
        dds_sample_info_t si;

        do {
                if (dds_take(rd, &ptr, &si, 1, 1) != 1)
                        return false;
        } while (!si.valid_data);
        *ret_t = now_ns();
        *ret = s.data;
        return true;
}

static void on_floor(dds_entity_t rd, void *arg)
{
        int64_t v;
        uint64_t t;

        while (take_int64(rd, &v, &t))
                arrived(arg, P_FLOOR, 0, t - (uint64_t)v);
}

static void on_var(dds_entity_t rd, void *arg)
{
        struct bench *b = arg;
        int64_t v;
        uint64_t t;

        while (take_int64(rd, &v, &t)) {
                atomic_fetch_add(&b->samples, 1);
                if (rd == b->readers[0])
                        arrived(b, P_BRIDGE, (long)v, t);
        }
}

/* A ROS-default reader (RELIABLE, VOLATILE, KEEP_LAST 10) with fn as its data listener. */
static dds_entity_t make_reader(struct bench *b, const char *name, dds_on_data_available_fn fn)
{
        dds_entity_t topic = dds_create_topic(b->pp, &std_msgs_msg_dds__Int64__desc, name, NULL,
                                              NULL);
        dds_qos_t *q = dds_create_qos();
        dds_listener_t *l = dds_create_listener(b);
        dds_entity_t rd;

        dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_INFINITY);
        dds_qset_durability(q, DDS_DURABILITY_VOLATILE);
        dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 10);
        dds_lset_data_available(l, fn);
        rd = topic < 0 ? topic : dds_create_reader(b->pp, topic, q, l);
        dds_delete_qos(q);
        dds_delete_listener(l);
        return rd;
}

/* Waits until each of the n readers has matched a writer. */
static int wait_matched(struct bench *b, const dds_entity_t *rd, size_t n)
{
        dds_entity_t ws = dds_create_waitset(b->pp);
        uint64_t deadline = now_ns() + START_MS * NS_PER_MS;
        size_t done = 0;
        int r = 0;

        for (size_t i = 0; i < n; i++) {
                dds_set_status_mask(rd[i], DDS_SUBSCRIPTION_MATCHED_STATUS);
                dds_waitset_attach(ws, rd[i], (dds_attach_t)i);
        }
        while (done < n) {
                dds_subscription_matched_status_t st;

                dds_get_subscription_matched_status(rd[done], &st);
                if (st.current_count > 0) {
                        done++;
                        continue;
                }
                if (now_ns() >= deadline) {
                        r = -ETIMEDOUT;
                        break;
                }
                dds_waitset_wait(ws, NULL, 0, (dds_duration_t)(deadline - now_ns()));
        }
        dds_delete(ws);
        /* Data again, for the listeners (the mask replaced theirs). */
        for (size_t i = 0; i < n; i++)
                dds_set_status_mask(rd[i], DDS_DATA_AVAILABLE_STATUS);
        return r;
}

/* ---- the daemon and the bridge ---- */

static int start_daemon(struct bench *b)
{
        static char text[CONFIG_MAX];
        char path[HARNESS_PATH_MAX], slave[HARNESS_PATH_MAX], dev[HARNESS_PATH_MAX + 8];
        size_t n;
        int st = 0;

        if (harness_openpty(&b->master, &b->slave, slave) < 0)
                return -1;
        snprintf(dev, sizeof(dev), "%s/dev0", b->h.dir);
        if (symlink(slave, dev) < 0)
                return -1;
        n = benchlink_config(text, sizeof(text), b->h.instance, dev, "long", NULL);
        if (n == 0 || harness_write_file(&b->h, "daemon.yaml", text, path) < 0)
                return -1;
        b->h.capture_log = 1;
        if (harness_start_daemon(&b->h, path, START_MS, &st, NULL) != 0) {
                fprintf(stderr, "bench_ros2: sharedlinkd did not start (%d)\n", st);
                return -1;
        }
        return 0;
}

static const char *bridge_path(void)
{
        static char path[PATH_MAX];
        const char *build = getenv("SHAREDLINK_BUILD");

        snprintf(path, sizeof(path), "%s/sharedlink-ros2", build ? build : "build");
        return path;
}

/* The bridge on NAMESPACE, with wait_spin_us: spin_us (0: the default configuration). */
static int start_bridge(struct bench *b, unsigned spin_us)
{
        char text[CONFIG_MAX], path[HARNESS_PATH_MAX];
        const char *argv[] = { bridge_path(), "-c", path, NULL };
        int st = 0;

        snprintf(text, sizeof(text), "instance: %s\nnamespace: %s\ndomain_id: %u\n"
                 "cyclonedds_uri: '%s'\n", b->h.instance, NAMESPACE, b->domain, b->uri);
        if (spin_us)
                snprintf(text + strlen(text), sizeof(text) - strlen(text),
                         "wait_spin_us: %u\n", spin_us);
        if (harness_init(&b->r, "bros2b") < 0 ||
            harness_write_file(&b->r, "bridge.yaml", text, path) < 0)
                return -1;
        b->r.capture_log = 1;
        if (harness_start_program(&b->r, &b->h, argv, START_MS, &st) != 0) {
                fprintf(stderr, "bench_ros2: sharedlink-ros2 did not start (%d); log %s\n", st,
                        b->r.log_path);
                return -1;
        }
        return 0;
}

/* The daemon answers nothing we need; its bytes are read and dropped so the pty never fills.
 * The same thread is the pty floor's reader: a blocked read() on the second pair's slave. */
static void *reader_main(void *arg)
{
        struct bench *b = arg;
        char buf[4096];

        while (!atomic_load(&b->stop)) {
                struct pollfd p[2] = { { .fd = b->master, .events = POLLIN },
                                       { .fd = b->pty_slave, .events = POLLIN } };

                if (poll(p, 2, 100) <= 0)
                        continue;
                if (p[1].revents & POLLIN) {
                        uint64_t t = now_ns();
                        ssize_t n = read(b->pty_slave, buf, sizeof(buf) - 1);

                        if (n > 0) {
                                buf[n] = '\0';
                                arrived(b, P_PTY, strtol(buf, NULL, 10), t);
                        }
                }
                if (b->master >= 0 && (p[0].revents & POLLIN))
                        (void)!read(b->master, buf, sizeof(buf));
        }
        return NULL;
}

/* ---- measurements ---- */

/* One sample of probe p with value v: its latency in ns, or 0 when it never arrived. */
static uint64_t sample(struct bench *b, enum probe p, long v)
{
        char body[64], frame[128], text[32];
        struct timespec until;
        uint64_t t0, got;
        size_t n;

        pthread_mutex_lock(&b->m);
        b->want[p] = p == P_FLOOR ? 0 : v;
        b->got_ns[p] = 0;
        pthread_mutex_unlock(&b->m);
        t0 = now_ns();
        switch (p) {
        case P_PTY:
                n = (size_t)snprintf(text, sizeof(text), "%ld\n", v);
                harness_write_all(b->pty_master, text, n, WAIT_MS);
                break;
        case P_FLOOR:
                (void)!write(b->floor_cmd, "w", 1);
                break;
        case P_BRIDGE:
                snprintf(body, sizeof(body), "N0|D%ld", v);
                n = wire_slp_frame(frame, sizeof(frame), BENCHLINK_DST, 'B', body, true);
                harness_write_all(b->master, frame, n, WAIT_MS);
                break;
        case P_COUNT:
                break;
        }
        clock_gettime(CLOCK_REALTIME, &until);
        until.tv_sec += WAIT_MS / 1000;
        pthread_mutex_lock(&b->m);
        while (!b->got_ns[p] && pthread_cond_timedwait(&b->cv, &b->m, &until) == 0)
                ;
        got = b->got_ns[p];
        pthread_mutex_unlock(&b->m);
        if (!got)
                return 0;
        /* The floor's listener stored the latency itself (the write time came in the sample). */
        return p == P_FLOOR ? got : got - t0;
}

static uint64_t sample_probe(void *arg, int p, long v)
{
        return sample(arg, (enum probe)p, v);
}

/* The three probes, interleaved; spin_us: the bridge's wait_spin_us (0: the default, the
 * figures the goal is about; else the opt-in series, reported under its own names). */
static void latency(struct bench *b, unsigned spin_us)
{
        struct benchlat l = { .probes = b->bridge ? P_COUNT : P_BRIDGE, .names = probe_name,
                              .samples = SAMPLES, .warmup = WARMUP, .gap_us = GAP_US,
                              .first_value = 100000, .sample = sample_probe, .arg = b };
        const double *med = l.median_us, *p99 = l.p99_us;
        uint64_t c0 = 0, c1 = 0;
        double ratio, cpu_us;

        if (spin_us)
                printf("opt-in: the bridge with wait_spin_us: %u\n", spin_us);
        if (b->bridge)
                benchlat_cpu_ns(b->r.pid, &c0);
        if (benchlat_run(&l) < 0)
                return;
        if (!spin_us) {
                printf("FIGURE|ros2_pty|pty hop, frame -> blocked read (median)|%.1f|us|-\n",
                       med[P_PTY]);
                printf("FIGURE|ros2_floor|Cyclone publish -> subscriber callback, 2 processes "
                       "(median)|%.1f|us|-\n", med[P_FLOOR]);
        }
        if (!b->bridge)
                return;
        benchlat_cpu_ns(b->r.pid, &c1);
        ratio = med[P_BRIDGE] / (med[P_FLOOR] + med[P_PTY]);
        cpu_us = (double)(c1 - c0) / 1000.0 / (double)(SAMPLES + WARMUP);
        if (spin_us)
                printf("  bridge/(floor+pty) median %.2fx (opt-in: the goal is the default's), "
                       "bridge/floor %.2fx\n", ratio, med[P_BRIDGE] / med[P_FLOOR]);
        else
                printf("  bridge/(floor+pty) median %.2fx (goal <= %.1fx), bridge/floor %.2fx\n",
                       ratio, GOAL_RATIO, med[P_BRIDGE] / med[P_FLOOR]);
        printf("  bridge CPU %.1f us per bridge sample (all its threads; one every %.1f ms or "
               "more)\n", cpu_us, (double)P_COUNT * GAP_US / 1000.0);
        if (spin_us) {
                printf("FIGURE|ros2_spin_p50|ROS 2, opt-in wait_spin_us %u: pty frame -> Cyclone "
                       "callback (median)|%.1f|us|-\n", spin_us, med[P_BRIDGE]);
                printf("FIGURE|ros2_spin_p99|ROS 2, opt-in wait_spin_us %u: pty frame -> Cyclone "
                       "callback (p99)|%.1f|us|-\n", spin_us, p99[P_BRIDGE]);
                printf("FIGURE|ros2_spin_ratio|ROS 2, opt-in spin: median / (floor + pty)|%.2f|x|"
                       "-\n", ratio);
                printf("FIGURE|ros2_spin_cpu|ROS 2, opt-in spin: bridge CPU per sample|%.1f|us|"
                       "-\n", cpu_us);
                return;
        }
        printf("FIGURE|ros2_bridge_p50|ROS 2: pty frame -> Cyclone callback (median)|%.1f|us|-\n",
               med[P_BRIDGE]);
        printf("FIGURE|ros2_bridge_p99|ROS 2: pty frame -> Cyclone callback (p99)|%.1f|us|-\n",
               p99[P_BRIDGE]);
        printf("FIGURE|ros2_ratio|ROS 2 median / (Cyclone floor + pty hop)|%.2f|x|<=%.1f\n",
               ratio, GOAL_RATIO);
}

static void rate(struct bench *b)
{
        uint64_t t0, t1, c0 = 0, c1 = 0, s0, s, rounds = 0;
        double secs;

        benchlat_cpu_ns(b->r.pid, &c0);
        s0 = atomic_load(&b->samples);
        t0 = now_ns();
        rounds = benchlink_offer(b->master, RATE_S, WAIT_MS);
        t1 = now_ns();
        /* What was sent is out within a moment: wait until the count stops growing. */
        for (uint64_t last = UINT64_MAX; last != atomic_load(&b->samples);) {
                last = atomic_load(&b->samples);
                usleep(SETTLE_MS * 1000);
        }
        benchlat_cpu_ns(b->r.pid, &c1);
        s = atomic_load(&b->samples) - s0;
        secs = (double)(t1 - t0) / NS_PER_S;
        printf("rate, %d variables, %d s:\n", VARS, RATE_S);
        printf("  offered  %10.0f changes/s (%llu rounds of %d)\n", (double)rounds * VARS / secs,
               (unsigned long long)rounds, VARS);
        printf("  received %10.0f samples/s by %d readers, %.0f%% of the changes\n",
               (double)s / secs, VARS, 100.0 * (double)s / ((double)rounds * VARS));
        printf("  bridge CPU %.2f s: %.1f ms per 1,000 samples\n", (double)(c1 - c0) / NS_PER_S,
               s ? (double)(c1 - c0) / NS_PER_MS * 1000.0 / (double)s : 0.0);
        printf("FIGURE|ros2_rate|ROS 2: samples/s, 1,000 variables changing|%.0f|/s|-\n",
               (double)s / secs);
        printf("FIGURE|ros2_cpu|ROS 2: bridge CPU per 1,000 samples|%.1f|ms|-\n",
               s ? (double)(c1 - c0) / NS_PER_MS * 1000.0 / (double)s : 0.0);
}

/* Stops the bridge and starts it again with wait_spin_us: spin_us, and SHAREDLINK_CHANGES=all in
 * its environment when full_read; every reader matched again. */
static int restart_bridge_env(struct bench *b, unsigned spin_us, bool full_read)
{
        int r;

        harness_cleanup(&b->r);
        if (full_read)
                setenv("SHAREDLINK_CHANGES", "all", 1);
        r = start_bridge(b, spin_us);
        unsetenv("SHAREDLINK_CHANGES");
        if (r < 0)
                return -1;
        if (wait_matched(b, b->readers, VARS) < 0) {
                fprintf(stderr, "bench_ros2: not every bridge topic matched a reader again\n");
                return -1;
        }
        return 0;
}

static int restart_bridge(struct bench *b, unsigned spin_us)
{
        return restart_bridge_env(b, spin_us, false);
}

/* benchlat_restart_fn: the bridge again, full_read as SHAREDLINK_CHANGES=all; its pid or -1. */
static pid_t restart_for_wake(void *arg, bool full_read)
{
        struct bench *b = arg;

        return restart_bridge_env(b, 0, full_read) == 0 ? b->r.pid : -1;
}

/* `wake`: the bridge's CPU per wake-up, full read (forced) and changed only (benchlat.h). */
static int wake(struct bench *b)
{
        struct benchlat l = { .samples = WAKES, .gap_us = GAP_US, .sample = sample_probe,
                              .arg = b };
        long value = 500000;

        printf("wake, %d variables:\n", VARS);
        return benchlat_wake_compare(&l, P_BRIDGE, restart_for_wake, &value, "ros2", "ROS 2");
}

/* ---- setup and the report of the machine ---- */

static void load_average(const char *when)
{
        double l1 = 0, l5 = 0, l15 = 0;
        long cpus = sysconf(_SC_NPROCESSORS_ONLN);
        FILE *f = fopen("/proc/loadavg", "r");

        if (!f || fscanf(f, "%lf %lf %lf", &l1, &l5, &l15) != 3)
                l1 = l5 = l15 = -1;
        if (f)
                fclose(f);
        /* Below half a CPU's worth of other work the figures are a quiet machine's. */
        printf("load average %s: %.2f %.2f %.2f on %ld CPUs (%s machine)\n", when, l1, l5, l15,
               cpus, l1 >= 0 && l1 < 0.5 * (double)cpus ? "quiet" : "busy");
}

static int setup(struct bench *b)
{
        char path[PATH_MAX];
        char topic[TOPIC_MAX];
        char pty_path[HARNESS_PATH_MAX];

        if (!realpath(CYCLONE_XML, path)) {
                fprintf(stderr, "bench_ros2: %s: %s (run from the source tree)\n", CYCLONE_XML,
                        strerror(errno));
                return -1;
        }
        snprintf(b->uri, sizeof(b->uri), "file://%s", path);
        b->domain = DOMAIN_BASE + (unsigned)getpid() % DOMAIN_SPAN;
        setenv("CYCLONEDDS_URI", b->uri, 1);
        unsetenv("ROS_DOMAIN_ID");
        b->bridge = access(bridge_path(), X_OK) == 0;
        if (harness_init(&b->h, "bros2") < 0 ||
            harness_openpty(&b->pty_master, &b->pty_slave, pty_path) < 0)
                return -1;
        if (b->bridge && (start_daemon(b) < 0 || start_bridge(b, 0) < 0))
                return -1;
        /* The child is started before this process's DDS threads exist. */
        if (start_floor_child(b) < 0)
                return -1;
        if (dds_create_domain(b->domain, b->uri) < 0)
                return -1;
        b->pp = dds_create_participant(b->domain, NULL, NULL);
        if (b->pp < 0)
                return -1;
        b->reader_floor = make_reader(b, "rt/bench/floor", on_floor);
        if (b->reader_floor < 0 || wait_matched(b, &b->reader_floor, 1) < 0) {
                fprintf(stderr, "bench_ros2: the floor publisher never matched\n");
                return -1;
        }
        if (!b->bridge)
                return 0;
        for (int i = 0; i < VARS; i++) {
                snprintf(topic, sizeof(topic), "rt%s/v%d", NAMESPACE, i);
                b->readers[i] = make_reader(b, topic, on_var);
                if (b->readers[i] < 0)
                        return -1;
        }
        if (wait_matched(b, b->readers, VARS) < 0) {
                fprintf(stderr, "bench_ros2: not every bridge topic matched a reader\n");
                return -1;
        }
        return 0;
}

int main(int argc, char **argv)
{
        struct bench *b = &B;
        pthread_t reader;
        int rc = 0;

        if (argc == 4 && strcmp(argv[1], FLOOR_ARG) == 0)
                return floor_publisher((unsigned)atoi(argv[2]), argv[3]);
        b->master = b->slave = b->pty_master = b->pty_slave = b->floor_cmd = -1;
        pthread_mutex_init(&b->m, NULL);
        pthread_cond_init(&b->cv, NULL);
        signal(SIGPIPE, SIG_IGN);
        printf("sharedlink-ros2 bench\n");
        load_average("at start");
        if (setup(b) < 0 || pthread_create(&reader, NULL, reader_main, b) != 0) {
                rc = 1;
                goto out;
        }
        if (!b->bridge)
                printf("%s not built: the floors only\n", bridge_path());
        latency(b, 0);
        if (b->bridge) {
                rate(b);
                if (wake(b) < 0)
                        rc = 1;
                if (restart_bridge(b, SPIN_US) == 0)
                        latency(b, SPIN_US);
                else
                        rc = 1;
        }
        atomic_store(&b->stop, true);
        pthread_join(reader, NULL);
        load_average("at end");
out:
        if (b->pp > 0)
                dds_delete(DDS_CYCLONEDDS_HANDLE);
        if (b->floor_cmd >= 0)
                close(b->floor_cmd);    /* end of input: the child exits */
        if (b->floor_pid > 0)
                waitpid(b->floor_pid, NULL, 0);
        if (b->r.dir[0])
                harness_cleanup(&b->r);         /* stops the bridge */
        harness_cleanup(&b->h);
        return rc;
}

#else

int main(void)
{
        printf("bench_ros2: Cyclone DDS not installed (make deps): skipped\n");
        return 0;
}

#endif
