/*
 * End-to-end latency and idle cost of a real sharedlinkd (SharedLink links over pty pairs whose
 * master the benchmark holds), measured side by side in one run:
 *
 *   floor     a frame written into a pty master -> a thread blocked in poll() on the slave has
 *             read its last byte (what any program pays to get bytes through a pty). Measured
 *             like the daemon's side of inbound: the same frame bytes, the slave opened and set
 *             up by the daemon's own serial_open() (non-blocking, raw, VMIN=1 VTIME=0, exclusive,
 *             flushed), a second descriptor on it held open by us as for the daemon's link, and
 *             a reader that sleeps in poll() and then read()s, as the daemon's loop does;
 *   wake-up   one futex wake-up from a thread to another (what handing a value from the daemon
 *             to a client costs at least, on top of the floor);
 *   inbound   a frame written into the master of the daemon's link -> a client thread blocked
 *             in sl_wait() reads the new value (pty + daemon decode + table + futex wake); the
 *             value's own time stamp splits it at the moment the daemon applied the frame;
 *   outbound  sl_write() with on_change and min_interval_ms 0 -> the frame's last byte is read
 *             on the master by a thread blocked in poll();
 *   idle      a second daemon with 4 SharedLink links and no periodic send, left alone for
 *             IDLE_S seconds: its CPU time (/proc/PID/stat) and its threads' context switches
 *             (/proc/PID/task/N/status), and the loop's own wakeup counters from the control
 *             socket's `stats` request when the daemon answers it.
 *
 * The latency probes take one sample each in turn (interleaved), so a machine whose load changes
 * during the run weighs on all of them alike.
 *
 * Targets (the issue): inbound median within 1.5x of the floor, outbound p99 under 1 ms, no
 * wakeups beyond the configured timers when idle. Prints the figures and the ratios; the exit
 * code is 0 unless something failed to run (a benchmark does not judge).
 *
 * Needs the optimised daemon: `make bench` runs it with SHAREDLINK_BUILD=build.
 */
#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <semaphore.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include <sharedlink.h>

#include "common/harness.h"
#include "common/wire.h"
#include "daemon/serial.h"
#include "shm/table.h"

#define SAMPLES         3000
#define WARMUP          200
#define GAP_US          300             /* between samples: no queueing between them */
#define IDLE_LINKS      4
#define IDLE_S          10
#define START_MS        10000
#define WAIT_MS         2000            /* one sample must not take longer */
#define FRAME_MAX       128
#define LINE_MAX_BENCH  1024
#define NS_PER_US       1000ull
#define YAML_MAX        (64 * 1024)
#define EXTRA_PEER_VARS 250             /* extra outbound variables per extra peer (list: 256) */
#define EXTRA_PEER_FIRST 'C'            /* their addresses: C, D, ... (A and B are taken) */
#define SCALE_SMALL     10u             /* outbound variables of the two tables compared */
#define SCALE_LARGE     1000u
#define SCALE_RATIO_MAX 1.2             /* the target, large / small */
#define SCALE_P99_MAX_US 500.0

struct sample_set {
        uint64_t v[SAMPLES];
        size_t n;
};

static uint64_t now_ns(void)
{
        return harness_now_ns();
}

static int cmp_u64(const void *a, const void *b)
{
        uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;

        return (x > y) - (x < y);
}

static void percentiles(struct sample_set *s, double *ret_med_us, double *ret_p99_us)
{
        qsort(s->v, s->n, sizeof(s->v[0]), cmp_u64);
        *ret_med_us = (double)s->v[s->n / 2] / NS_PER_US;
        *ret_p99_us = (double)s->v[(s->n * 99) / 100] / NS_PER_US;
}

static int write_all(int fd, const char *buf, size_t len)
{
        return harness_write_all(fd, buf, len, WAIT_MS);
}

/* ---------------------------------------------------------------------------------------------
 * A thread that waits for one event per sample and stamps it. */

struct waiter {
        pthread_t thread;
        sem_t go, done;
        _Atomic int stop;
        _Atomic uint64_t stamp;         /* when the event was seen */
        _Atomic uint64_t mid;           /* inbound: the daemon's time stamp of the value */
        char expect[64];                /* what the event must carry */
        int fd;                         /* floor: pty slave; outbound: the link's master */
        struct sl_client *client;       /* inbound */
        const struct sl_wait_opts *opts;        /* inbound: NULL, or the spin */
        uint64_t cpu_ns;                /* inbound: this thread's CPU time while waiting */
        int id;
        int failed;
        int started;
};

/* Floor: read the slave until the frame's last byte. */
static void *floor_thread(void *arg)
{
        struct waiter *w = arg;
        char buf[FRAME_MAX];

        while (sem_wait(&w->go) == 0 && !atomic_load(&w->stop)) {
                size_t len = 0;

                for (;;) {
                        struct pollfd p = { .fd = w->fd, .events = POLLIN };
                        ssize_t n;

                        if (poll(&p, 1, WAIT_MS) <= 0) {
                                w->failed = 1;
                                break;
                        }
                        n = read(w->fd, buf + len, sizeof(buf) - len);
                        if (n <= 0)
                                continue;
                        len += (size_t)n;
                        if (buf[len - 1] == '\n' || len == sizeof(buf))
                                break;
                }
                atomic_store(&w->stamp, now_ns());
                sem_post(&w->done);
        }
        return NULL;
}

/* Wake-up hop: a thread blocked on a futex (a semaphore) woken by another thread. */
static sem_t hop_sem;

static void *hop_thread(void *arg)
{
        struct waiter *w = arg;

        while (sem_wait(&w->go) == 0 && !atomic_load(&w->stop)) {
                while (sem_wait(&hop_sem) < 0 && errno == EINTR)
                        ;
                atomic_store(&w->stamp, now_ns());
                sem_post(&w->done);
        }
        return NULL;
}

static int cause_hop(void *arg, unsigned i)
{
        (void)arg;
        (void)i;
        return sem_post(&hop_sem) < 0 ? -errno : 0;
}

/* CPU time of the calling thread, ns. */
static uint64_t thread_cpu_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
        return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

/* Inbound: a client blocked in sl_wait (or spinning first, with opts) until the value is the
 * expected one. */
static void *inbound_thread(void *arg)
{
        struct waiter *w = arg;
        uint32_t cursor = 0;
        char value[SL_VALUE_SIZE];

        sl_wait(w->client, &cursor, 0);
        while (sem_wait(&w->go) == 0 && !atomic_load(&w->stop)) {
                uint64_t deadline = now_ns() + (uint64_t)WAIT_MS * 1000000u;
                uint64_t cpu0 = thread_cpu_ns();

                for (;;) {
                        struct sl_meta meta = { .size = sizeof(meta) };

                        if (sl_read(w->client, w->id, value, sizeof(value), &meta) >= 0 &&
                            strcmp(value, w->expect) == 0) {
                                /* The daemon stamps a frame's values when it starts applying
                                 * them (CLOCK_MONOTONIC, like ours). */
                                atomic_store(&w->mid, meta.mono_ns);
                                break;
                        }
                        if (now_ns() > deadline) {
                                w->failed = 1;
                                break;
                        }
                        sl_wait_with(w->client, &cursor, WAIT_MS, w->opts);
                }
                atomic_store(&w->stamp, now_ns());
                w->cpu_ns += thread_cpu_ns() - cpu0;
                sem_post(&w->done);
        }
        return NULL;
}

/* Outbound: read the master until a frame carrying the value has been read whole. */
static void *outbound_thread(void *arg)
{
        struct waiter *w = arg;
        char buf[4096], needle[80];
        size_t len = 0;

        while (sem_wait(&w->go) == 0 && !atomic_load(&w->stop)) {
                snprintf(needle, sizeof(needle), "|D%s|", w->expect);
                for (;;) {
                        struct pollfd p = { .fd = w->fd, .events = POLLIN };
                        char *found, *end;
                        ssize_t n;

                        found = len ? memmem(buf, len, needle, strlen(needle)) : NULL;
                        end = found ? memchr(found, '\n', len - (size_t)(found - buf)) : NULL;
                        if (end) {
                                len = 0;        /* frames before it are stale ones */
                                break;
                        }
                        if (len > sizeof(buf) / 2)
                                len = 0;
                        if (poll(&p, 1, WAIT_MS) <= 0) {
                                w->failed = 1;
                                break;
                        }
                        n = read(w->fd, buf + len, sizeof(buf) - len);
                        if (n > 0)
                                len += (size_t)n;
                }
                atomic_store(&w->stamp, now_ns());
                sem_post(&w->done);
        }
        return NULL;
}

static int waiter_start(struct waiter *w, void *(*fn)(void *))
{
        int r;

        sem_init(&w->go, 0, 0);
        sem_init(&w->done, 0, 0);
        atomic_store(&w->stop, 0);
        r = -pthread_create(&w->thread, NULL, fn, w);
        w->started = r == 0;
        return r;
}

static void waiter_stop(struct waiter *w)
{
        if (!w->started)
                return;
        w->started = 0;
        atomic_store(&w->stop, 1);
        sem_post(&w->go);
        pthread_join(w->thread, NULL);
        sem_destroy(&w->go);
        sem_destroy(&w->done);
}

/* One sample: arm the waiter, take t0, cause the event, wait for the stamp. Returns the delay
 * in ns (and the daemon's stamp relative to t0 in *ret_mid when asked), or -errno. */
static int64_t sample_one(struct waiter *w, int (*cause)(void *, unsigned), void *arg,
                          unsigned i, uint64_t *ret_mid)
{
        uint64_t t0;
        int r;

        snprintf(w->expect, sizeof(w->expect), "v%u", i);
        sem_post(&w->go);
        usleep(GAP_US);         /* the waiter is blocked again before t0 */
        t0 = now_ns();
        r = cause(arg, i);
        if (r < 0)
                return r;
        sem_wait(&w->done);
        if (w->failed)
                return -ETIMEDOUT;
        if (ret_mid)
                *ret_mid = atomic_load(&w->mid) - t0;
        return (int64_t)(atomic_load(&w->stamp) - t0);
}

/* ---------------------------------------------------------------------------------------------
 * Causes */

struct frame_cause {
        int fd;
        char dst, src;
};

static int cause_frame(void *arg, unsigned i)
{
        struct frame_cause *c = arg;
        char body[32], frame[FRAME_MAX];
        size_t n;

        snprintf(body, sizeof(body), "N0|Dv%u", i);
        n = wire_slp_frame(frame, sizeof(frame), c->dst, c->src, body, true);
        return write_all(c->fd, frame, n);
}

struct write_cause {
        struct sl_client *client;
        int id;
};

static int cause_write(void *arg, unsigned i)
{
        struct write_cause *c = arg;
        char v[16];

        snprintf(v, sizeof(v), "v%u", i);
        return sl_write(c->client, c->id, v);
}

/* ---------------------------------------------------------------------------------------------
 * Daemon helpers */

/* Writes the YAML of extra_out more outbound variables on more peers of the same link, at most
 * EXTRA_PEER_VARS each (one list holds 256), that nobody writes: they only make .out bigger. */
static size_t extra_peers(char *yaml, size_t size, unsigned extra_out)
{
        size_t n = 0;

        for (unsigned v = 0; v < extra_out && n < size; v++) {
                if (v % EXTRA_PEER_VARS == 0)
                        n += (size_t)snprintf(yaml + n, size - n,
                                "%s      - address: %c\n"
                                "        period_ms: 0\n"
                                "        stale_ms: 0\n"
                                "        outbound: [", v ? "]\n" : "",
                                EXTRA_PEER_FIRST + (int)(v / EXTRA_PEER_VARS));
                if (n < size)
                        n += (size_t)snprintf(yaml + n, size - n, "%sX%u",
                                              v % EXTRA_PEER_VARS ? ", " : "", v);
        }
        if (extra_out && n < size)
                n += (size_t)snprintf(yaml + n, size - n, "]\n");
        return n;
}

/* A daemon with `links` SharedLink links over pty pairs (peer A of link i: Out<i>, In<i>); link
 * 0 has extra_out more outbound variables (extra_peers). */
static int daemon_start(struct harness *h, const char *tag, unsigned links, unsigned extra_out,
                        int *masters, int *slaves)
{
        static char yaml[YAML_MAX];
        char path[HARNESS_PATH_MAX], dev[HARNESS_PATH_MAX + 16];
        char pts[HARNESS_PATH_MAX];
        size_t n;
        int r;

        r = harness_init(h, tag);
        if (r < 0)
                return r;
        n = (size_t)snprintf(yaml, sizeof(yaml), "instance: %s\nruntime_dir: %s\nlinks:\n",
                             h->instance, h->dir);
        for (unsigned i = 0; i < links; i++) {
                r = harness_openpty(&masters[i], &slaves[i], pts);
                if (r < 0)
                        return r;
                snprintf(dev, sizeof(dev), "%s/tty%u", h->dir, i);
                if (symlink(pts, dev) < 0)
                        return -errno;
                n += (size_t)snprintf(yaml + n, sizeof(yaml) - n,
                        "  - name: l%u\n"
                        "    protocol: sharedlink\n"
                        "    transport: serial\n"
                        "    device: %s\n"
                        "    address: B\n"
                        "    peers:\n"
                        "      - address: A\n"
                        "        period_ms: 0\n"
                        "        stale_ms: 0\n"
                        "        on_change: true\n"
                        "        min_interval_ms: 0\n"
                        "        outbound: [Out%u]\n"
                        "        inbound: [In%u]\n", i, dev, i, i);
                if (i == 0)
                        n += extra_peers(yaml + n, sizeof(yaml) - n, extra_out);
        }
        if (n >= sizeof(yaml))
                return -ENOBUFS;
        r = harness_write_file(h, "bench.yaml", yaml, path);
        if (r < 0)
                return r;
        return harness_start_daemon(h, path, START_MS, NULL, NULL);
}

/* Drains whatever the daemon sent so far (the full list at link up). */
static void drain(int fd)
{
        char buf[4096];

        while (read(fd, buf, sizeof(buf)) > 0)
                ;
}

/* utime + stime of a process, in clock ticks. */
static long long cpu_ticks(pid_t pid)
{
        char path[64], buf[2048], *p;
        unsigned long long ut, st;
        FILE *f;

        snprintf(path, sizeof(path), "/proc/%d/stat", (int)pid);
        f = fopen(path, "re");
        if (!f)
                return -1;
        p = fgets(buf, sizeof(buf), f) ? strrchr(buf, ')') : NULL;
        fclose(f);
        /* After "(comm)": state is field 3; utime and stime are fields 14 and 15. */
        if (!p || sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %llu %llu", &ut,
                         &st) != 2)
                return -1;
        return (long long)(ut + st);
}

/* VmRSS of a process in KiB, or -1. */
static long long rss_kib(pid_t pid)
{
        char path[64], line[256];
        long long kib = -1;
        FILE *f;

        snprintf(path, sizeof(path), "/proc/%d/status", (int)pid);
        f = fopen(path, "re");
        if (!f)
                return -1;
        while (fgets(line, sizeof(line), f))
                if (sscanf(line, "VmRSS: %lld kB", &kib) == 1)
                        break;
        fclose(f);
        return kib;
}

/* Context switches (voluntary + involuntary) of every thread of a process. */
static long long ctx_switches(pid_t pid)
{
        char path[320], line[256];
        long long sum = 0;
        struct dirent *e;
        DIR *d;

        snprintf(path, sizeof(path), "/proc/%d/task", (int)pid);
        d = opendir(path);
        if (!d)
                return -1;
        while ((e = readdir(d))) {
                FILE *f;

                if (e->d_name[0] == '.')
                        continue;
                snprintf(path, sizeof(path), "/proc/%d/task/%s/status", (int)pid, e->d_name);
                f = fopen(path, "re");
                if (!f)
                        continue;
                while (fgets(line, sizeof(line), f)) {
                        long long v;

                        if (sscanf(line, "voluntary_ctxt_switches: %lld", &v) == 1 ||
                            sscanf(line, "nonvoluntary_ctxt_switches: %lld", &v) == 1)
                                sum += v;
                }
                fclose(f);
        }
        closedir(d);
        return sum;
}

/* Sends one control request and copies the reply lines (DATA ... OK/ERR) into out. */
static int control_request(struct harness *h, const char *req, char *out, size_t size)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        size_t len = 0;
        int fd, r = -EIO;

        if (strlen(h->dir) + strlen(h->instance) + sizeof("/.sock") > sizeof(sa.sun_path))
                return -ENAMETOOLONG;
        snprintf(sa.sun_path, sizeof(sa.sun_path), "%.*s/%.*s.sock", (int)strlen(h->dir), h->dir,
                 (int)strlen(h->instance), h->instance);
        fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (fd < 0)
                return -errno;
        if (connect(fd, (struct sockaddr *)&sa, sizeof(sa)) < 0 ||
            write(fd, req, strlen(req)) != (ssize_t)strlen(req)) {
                r = -errno;
                close(fd);
                return r;
        }
        out[0] = '\0';
        while (len < size - 1) {
                ssize_t n = harness_read_until(fd, out + len, size - len, '\n', WAIT_MS);
                char *last;

                if (n <= 0)
                        break;
                last = out + len;
                len += (size_t)n;
                if (strncmp(last, "OK", 2) == 0 || strncmp(last, "ERR", 3) == 0) {
                        r = strncmp(last, "OK", 2) == 0 ? 0 : -EPROTO;
                        break;
                }
        }
        close(fd);
        return r;
}

/* "key=N" in text, or -1. */
static long long stat_field(const char *text, const char *key)
{
        char pat[64];
        const char *p;

        snprintf(pat, sizeof(pat), " %s=", key);
        p = strstr(text, pat);
        return p ? atoll(p + strlen(pat)) : -1;
}

/* The outbound stages the daemon timed itself, from its `stats` reply ("outbound_stage NAME
 * samples=N p50_ns=N p99_ns=N max_ns=N"): the same cuts as the in-process run below, but in the
 * real daemon, over its last writes (all of this run's outbound samples, warm-up included). */
/* One outbound stage of a `stats` reply: 0, or -ENOENT when the daemon did not report it. */
static int daemon_stage(const char *reply, const char *key, unsigned long long *ret_n,
                        unsigned long long *ret_p50, unsigned long long *ret_p99,
                        unsigned long long *ret_max)
{
        char pat[64];
        const char *p;

        snprintf(pat, sizeof(pat), "outbound_stage %s ", key);
        p = strstr(reply, pat);
        if (!p || sscanf(p + strlen(pat), "samples=%llu p50_ns=%llu p99_ns=%llu max_ns=%llu",
                         ret_n, ret_p50, ret_p99, ret_max) != 4)
                return -ENOENT;
        return 0;
}

static void print_daemon_stages(struct harness *h)
{
        static const char *const keys[] = { "write_to_wake", "wake_to_loop", "loop_to_sent" };
        static const char *const what[] = {
                "sl_write -> wake thread signals", "eventfd -> poll loop runs",
                "scan + frame handed to the link",
        };
        char reply[LINE_MAX_BENCH * 4];

        if (control_request(h, "stats\n", reply, sizeof(reply)) < 0) {
                printf("  (the daemon did not answer `stats`: no stages from the daemon)\n");
                return;
        }
        printf("outbound stage by stage, measured in the daemon (us)     median      p99      max\n");
        for (size_t k = 0; k < sizeof(keys) / sizeof(keys[0]); k++) {
                unsigned long long n, p50, p99, max;

                if (daemon_stage(reply, keys[k], &n, &p50, &p99, &max) < 0) {
                        printf("  %-34s (not reported)\n", what[k]);
                        continue;
                }
                printf("  %-34s %19.1f %8.1f %8.1f   (%llu writes)\n", what[k],
                       (double)p50 / NS_PER_US, (double)p99 / NS_PER_US, (double)max / NS_PER_US, n);
                printf("FIGURE|dstage%zu|outbound stage in the daemon: %s (p99)|%.1f|us|-\n", k + 1,
                       what[k], (double)p99 / NS_PER_US);
        }
}

/* ---------------------------------------------------------------------------------------------
 * Runs */

/* Spin budget of the opt-in inbound probe: the largest, so that the frame comes within it even
 * when the GAP_US sleep before it oversleeps on a loaded machine; the client's CPU time per
 * sample says what the spin cost. */
#define SPIN_US         SL_WAIT_SPIN_MAX_US

static int run_latency(void)
{
        static struct sample_set floor_s, hop_s, in_s, mid_s, spin_s, out_s;
        const struct sl_wait_opts spin = { .size = sizeof(spin), .flags = SL_WAIT_SPIN,
                                           .spin_us = SPIN_US };
        struct harness h;
        struct waiter wf, wh, wi, ws, wo;
        struct frame_cause fc, ffc;
        struct write_cause wc;
        struct sl_client *c = NULL;
        double fmed, fp99, hmed, hp99, imed, ip99, mmed, mp99, smed, sp99, omed, op99;
        int master, slave, fm, fs, r;
        char pts[HARNESS_PATH_MAX], err[SERIAL_ERR_MAX];
        struct serial_config floor_cfg;
        struct serial_port floor_port;

        r = daemon_start(&h, "e2e", 1, 0, &master, &slave);
        if (r < 0) {
                fprintf(stderr, "bench_e2e: daemon start: %s\n", strerror(-r));
                harness_cleanup(&h);
                return r;
        }
        r = sl_open(h.instance, &c);
        if (r < 0)
                goto out;
        usleep(100000);
        drain(master);

        /* The five probes run interleaved, one sample of each in turn, so that whatever else
         * the machine does weighs on all of them alike. */
        r = harness_openpty(&fm, &fs, pts);
        if (r < 0)
                goto out;
        /* Floor: a pty pair of our own, its slave opened the way the daemon opens a link's. */
        serial_config_default(&floor_cfg);
        r = serial_open(pts, &floor_cfg, &floor_port, err, sizeof(err));
        if (r < 0) {
                fprintf(stderr, "bench_e2e: floor pty: %s\n", err);
                close(fm);
                close(fs);
                goto out;
        }
        sem_init(&hop_sem, 0, 0);
        wf = (struct waiter){ .fd = floor_port.fd };
        ffc = (struct frame_cause){ .fd = fm, .dst = 'B', .src = 'A' };
        /* One futex wake-up between two threads: what the table adds to the pty, at least. */
        wh = (struct waiter){ 0 };
        /* Inbound through the daemon: blocking sl_wait, and the opt-in spin first. */
        wi = (struct waiter){ .client = c, .id = sl_find(c, "In0") };
        ws = (struct waiter){ .client = c, .id = wi.id, .opts = &spin };
        fc = (struct frame_cause){ .fd = master, .dst = 'B', .src = 'A' };
        /* Outbound, on_change with no rate limit. */
        wo = (struct waiter){ .fd = master };
        wc = (struct write_cause){ .client = c, .id = sl_find(c, "Out0") };
        r = wi.id < 0 ? wi.id : wc.id < 0 ? wc.id : 0;
        if (r == 0)
                r = waiter_start(&wf, floor_thread);
        if (r == 0)
                r = waiter_start(&wh, hop_thread);
        if (r == 0)
                r = waiter_start(&wi, inbound_thread);
        if (r == 0)
                r = waiter_start(&ws, inbound_thread);
        if (r == 0)
                r = waiter_start(&wo, outbound_thread);
        for (unsigned i = 0; r == 0 && i < WARMUP + SAMPLES; i++) {
                int64_t d[5];
                uint64_t mid = 0;

                if (i == WARMUP)
                        wi.cpu_ns = ws.cpu_ns = 0;
                d[0] = sample_one(&wf, cause_frame, &ffc, i, NULL);
                d[1] = sample_one(&wh, cause_hop, NULL, i, NULL);
                d[2] = sample_one(&wi, cause_frame, &fc, 2 * i, &mid);
                d[3] = sample_one(&ws, cause_frame, &fc, 2 * i + 1, NULL);
                d[4] = sample_one(&wo, cause_write, &wc, i, NULL);
                for (int k = 0; k < 5; k++)
                        if (d[k] < 0)
                                r = (int)d[k];
                if (r < 0 || i < WARMUP)
                        continue;
                floor_s.v[floor_s.n++] = (uint64_t)d[0];
                hop_s.v[hop_s.n++] = (uint64_t)d[1];
                in_s.v[in_s.n++] = (uint64_t)d[2];
                mid_s.v[mid_s.n++] = mid;
                spin_s.v[spin_s.n++] = (uint64_t)d[3];
                out_s.v[out_s.n++] = (uint64_t)d[4];
        }
        waiter_stop(&wf);
        waiter_stop(&wh);
        waiter_stop(&wi);
        waiter_stop(&ws);
        waiter_stop(&wo);
        sem_destroy(&hop_sem);
        serial_close(&floor_port);
        close(fm);
        close(fs);
        if (r < 0)
                goto out;

        percentiles(&floor_s, &fmed, &fp99);
        percentiles(&hop_s, &hmed, &hp99);
        percentiles(&in_s, &imed, &ip99);
        percentiles(&mid_s, &mmed, &mp99);
        percentiles(&spin_s, &smed, &sp99);
        percentiles(&out_s, &omed, &op99);
        printf("latency, %d samples each (us)          median      p99\n", SAMPLES);
        printf("  floor: pty master -> slave reader  %8.1f %8.1f\n", fmed, fp99);
        printf("  futex wake-up, thread to thread    %8.1f %8.1f   (floor + this = %.2fx floor)\n",
               hmed, hp99, (fmed + hmed) / fmed);
        printf("  inbound: pty -> sl_wait client     %8.1f %8.1f   median %.2fx floor "
               "(target <= 1.5x)\n", imed, ip99, imed / fmed);
        printf("    of which pty -> daemon applies   %8.1f %8.1f\n", mmed, mp99);
        printf("  inbound, SL_WAIT_SPIN %5d us     %8.1f %8.1f   median %.2fx floor "
               "(target <= 1.5x)\n", SPIN_US, smed, sp99, smed / fmed);
        /* The client starts waiting GAP_US before the frame is written: that much spinning. */
        printf("    CPU of the waiting client per sample: spin %.1f us, blocking %.1f us "
               "(it waits ~%d us for each frame)\n", (double)ws.cpu_ns / SAMPLES / NS_PER_US,
               (double)wi.cpu_ns / SAMPLES / NS_PER_US, GAP_US);
        printf("  outbound: sl_write -> pty master   %8.1f %8.1f   p99 %s 1 ms target\n", omed,
               op99, op99 < 1000.0 ? "under" : "OVER");
        print_daemon_stages(&h);
        printf("FIGURE|pty_floor|pty floor (median)|%.1f|us|-\n", fmed);
        printf("FIGURE|inbound|inbound, blocking sl_wait (median)|%.1f|us|-\n", imed);
        printf("FIGURE|inbound_ratio|inbound blocking / floor|%.2f|x|<=1.5\n", imed / fmed);
        printf("FIGURE|inbound_spin|inbound, SL_WAIT_SPIN (median)|%.1f|us|-\n", smed);
        printf("FIGURE|inbound_spin_ratio|inbound spin / floor|%.2f|x|<=1.5\n", smed / fmed);
        printf("FIGURE|inbound_spin_cpu|CPU per spin wake-up (client)|%.1f|us|-\n",
               (double)ws.cpu_ns / SAMPLES / NS_PER_US);
        printf("FIGURE|outbound_p50|outbound sl_write -> pty (median)|%.1f|us|-\n", omed);
        printf("FIGURE|outbound_p99|outbound sl_write -> pty (p99)|%.1f|us|<1000\n", op99);
out:
        if (r < 0)
                fprintf(stderr, "bench_e2e: latency run failed: %s\n", strerror(-r));
        sl_close(c);
        close(master);
        close(slave);
        harness_cleanup(&h);
        return r;
}

/* ---------------------------------------------------------------------------------------------
 * Outbound at two table sizes, side by side (issue 23): sl_write -> pty master, as above, from a
 * daemon with SCALE_SMALL outbound variables and one with SCALE_LARGE, one sample of each in
 * turn. The written variable and its frame are the same in both (peer A's list holds it alone);
 * the others only make .out bigger, which a wake-up's scan must not pay for. */

struct scale_side {
        struct harness h;
        struct sl_client *client;
        struct waiter w;
        struct write_cause wc;
        int master, slave;
        int up;                         /* daemon started */
};

static int scale_side_start(struct scale_side *sd, const char *tag, unsigned nout)
{
        int r = daemon_start(&sd->h, tag, 1, nout - 1u, &sd->master, &sd->slave);

        sd->up = 1;
        if (r == 0)
                r = sl_open(sd->h.instance, &sd->client);
        if (r < 0)
                return r;
        sd->w = (struct waiter){ .fd = sd->master };
        sd->wc = (struct write_cause){ .client = sd->client, .id = sl_find(sd->client, "Out0") };
        return sd->wc.id < 0 ? sd->wc.id : 0;
}

/* The daemon's own "scan + frame handed to the link" stage (median, p99 in us); -1 when not
 * reported. */
static void scale_side_stage(struct scale_side *sd, double *ret_p50, double *ret_p99)
{
        char reply[LINE_MAX_BENCH * 4];
        unsigned long long n, p50, p99, max;

        *ret_p50 = *ret_p99 = -1.0;
        if (control_request(&sd->h, "stats\n", reply, sizeof(reply)) == 0 &&
            daemon_stage(reply, "loop_to_sent", &n, &p50, &p99, &max) == 0) {
                *ret_p50 = (double)p50 / NS_PER_US;
                *ret_p99 = (double)p99 / NS_PER_US;
        }
}

static void scale_side_stop(struct scale_side *sd)
{
        waiter_stop(&sd->w);
        sl_close(sd->client);
        if (sd->up) {
                close(sd->master);
                close(sd->slave);
                harness_cleanup(&sd->h);
        }
}

/* The 1-minute load average, or -1. */
static double load_average(void)
{
        FILE *f = fopen("/proc/loadavg", "r");
        double load = -1.0;

        if (f) {
                if (fscanf(f, "%lf", &load) != 1)
                        load = -1.0;
                fclose(f);
        }
        return load;
}

static int run_outscale(void)
{
        static struct sample_set small_s, large_s;
        static struct scale_side small, large;
        double smed, sp99, lmed, lp99, load0 = load_average();
        double sdmed, sdp99, ldmed, ldp99;
        int r;

        r = scale_side_start(&small, "osmall", SCALE_SMALL);
        if (r == 0)
                r = scale_side_start(&large, "olarge", SCALE_LARGE);
        if (r < 0)
                goto out;
        usleep(100000);
        drain(small.master);
        drain(large.master);
        r = waiter_start(&small.w, outbound_thread);
        if (r == 0)
                r = waiter_start(&large.w, outbound_thread);
        for (unsigned i = 0; r == 0 && i < WARMUP + SAMPLES; i++) {
                int64_t ds = sample_one(&small.w, cause_write, &small.wc, i, NULL);
                int64_t dl = sample_one(&large.w, cause_write, &large.wc, i, NULL);

                r = ds < 0 ? (int)ds : dl < 0 ? (int)dl : 0;
                if (r < 0 || i < WARMUP)
                        continue;
                small_s.v[small_s.n++] = (uint64_t)ds;
                large_s.v[large_s.n++] = (uint64_t)dl;
        }
        if (r < 0)
                goto out;
        percentiles(&small_s, &smed, &sp99);
        percentiles(&large_s, &lmed, &lp99);
        scale_side_stage(&small, &sdmed, &sdp99);
        scale_side_stage(&large, &ldmed, &ldp99);
        printf("outbound by table size, %d samples each (us)   median      p99   (load average "
               "%.2f -> %.2f)\n", SAMPLES, load0, load_average());
        printf("  sl_write -> pty, %4u outbound variables %8.1f %8.1f\n", SCALE_SMALL, smed, sp99);
        printf("  sl_write -> pty, %4u outbound variables %8.1f %8.1f\n", SCALE_LARGE, lmed, lp99);
        printf("  ratio %u / %u                         %8.2fx %7.2fx  (target <= %.1fx; p99 "
               "<= %.0f us)\n", SCALE_LARGE, SCALE_SMALL, lmed / smed, lp99 / sp99,
               SCALE_RATIO_MAX, SCALE_P99_MAX_US);
        /* The part the table's size weighs on, without the pty and the scheduler around it. */
        printf("  in the daemon: scan + frame handed to the link (median, p99)\n");
        printf("                   %4u outbound variables %8.1f %8.1f\n", SCALE_SMALL, sdmed,
               sdp99);
        printf("                   %4u outbound variables %8.1f %8.1f\n", SCALE_LARGE, ldmed,
               ldp99);
        printf("FIGURE|outbound_scale_p99|outbound sl_write -> pty, %u outbound (p99)|%.1f|us|"
               "<=%.0f\n", SCALE_LARGE, lp99, SCALE_P99_MAX_US);
        printf("FIGURE|outbound_scale_p50_ratio|outbound median, %u / %u outbound|%.2f|x|<=%.1f\n",
               SCALE_LARGE, SCALE_SMALL, lmed / smed, SCALE_RATIO_MAX);
        printf("FIGURE|outbound_scale_p99_ratio|outbound p99, %u / %u outbound|%.2f|x|<=%.1f\n",
               SCALE_LARGE, SCALE_SMALL, lp99 / sp99, SCALE_RATIO_MAX);
out:
        if (r < 0)
                fprintf(stderr, "bench_e2e: outbound by table size failed: %s\n", strerror(-r));
        scale_side_stop(&small);
        scale_side_stop(&large);
        return r;
}

/* ---------------------------------------------------------------------------------------------
 * Outbound stage by stage: the daemon's own pieces in this process (the table, its wake thread,
 * a poll loop, a pty), each stage time-stamped: sl_write -> the wake thread signals its eventfd
 * -> the poll loop returns -> scan + write() of the frame done -> the reader has the last byte. */

#define STAGES          4
#define STAGE_SAMPLES   2000

struct stage_loop {
        pthread_t thread;
        struct shm_table *t;
        int wake_fd;
        int tx_fd;                      /* the loop writes frames here (a pty master) */
        _Atomic int stop;
        _Atomic uint32_t done;          /* frames written */
        _Atomic uint64_t woke_ns, polled_ns, written_ns;
        int failed;
};

static void stage_on_change(void *userdata, const struct shm_out_change *change)
{
        struct stage_loop *l = userdata;
        char frame[FRAME_MAX], body[SL_VALUE_SIZE + 8];
        size_t n;

        if (change->status != SHM_OUT_CHANGED)
                return;
        snprintf(body, sizeof(body), "N0|D%s", change->value);
        n = wire_slp_frame(frame, sizeof(frame), 'A', 'B', body, true);
        if (write_all(l->tx_fd, frame, n) < 0)
                l->failed = 1;
}

static void *stage_loop_main(void *arg)
{
        struct stage_loop *l = arg;

        while (!atomic_load(&l->stop)) {
                struct pollfd p = { .fd = l->wake_fd, .events = POLLIN };
                uint64_t polled;

                if (poll(&p, 1, 100) <= 0)
                        continue;
                polled = now_ns();
                shm_table_out_wake_ack(l->t);
                atomic_store(&l->woke_ns, shm_table_out_wake_stamp(l->t));
                atomic_store(&l->polled_ns, polled);
                if (shm_table_out_scan(l->t, stage_on_change, l) > 0) {
                        atomic_store(&l->written_ns, now_ns());
                        atomic_fetch_add(&l->done, 1u);
                }
        }
        return NULL;
}

static int run_stages(void)
{
        static const struct shm_var var = { "Out0", SHM_DIR_OUT, SHM_TYPE_STRING, SHM_LINK_NONE,
                                            NULL, SHM_POSITION_NONE };
        static const char *const names[STAGES] = {
                "sl_write -> wake thread signals", "eventfd -> poll loop runs",
                "scan + frame write()", "pty -> reader has last byte",
        };
        static struct sample_set st[STAGES];
        struct shm_table_config cfg = { .vars = &var, .nvars = 1 };
        struct stage_loop l = { 0 };
        struct sl_client *c = NULL;
        struct waiter wr;
        char instance[64], pts[HARNESS_PATH_MAX];
        int fm = -1, fs = -1, r;

        snprintf(instance, sizeof(instance), "bench-stages-%d", (int)getpid());
        cfg.instance = instance;
        r = shm_table_create(&cfg, &l.t);
        if (r < 0)
                return r;
        r = sl_open(instance, &c);
        if (r == 0)
                r = harness_openpty(&fm, &fs, pts);
        if (r == 0) {
                fcntl(fs, F_SETFL, fcntl(fs, F_GETFL) | O_NONBLOCK);
                l.tx_fd = fm;
                l.wake_fd = shm_table_out_wake_fd(l.t);
                r = l.wake_fd < 0 ? l.wake_fd : -pthread_create(&l.thread, NULL,
                                                                 stage_loop_main, &l);
        }
        wr = (struct waiter){ .fd = fs };
        if (r == 0)
                r = waiter_start(&wr, floor_thread);
        for (unsigned i = 0; r == 0 && i < WARMUP + STAGE_SAMPLES; i++) {
                uint32_t done = atomic_load(&l.done);
                uint64_t t[STAGES + 1];
                char v[16];

                sem_post(&wr.go);
                usleep(GAP_US);         /* the reader, the loop and the wake thread sleep again */
                snprintf(v, sizeof(v), "v%u", i);
                t[0] = now_ns();
                r = sl_write(c, 0, v);
                if (r < 0)
                        break;
                sem_wait(&wr.done);
                while (atomic_load(&l.done) == done && !wr.failed)
                        sched_yield();  /* its stamps are stored before the frame is read */
                if (wr.failed || l.failed) {
                        r = -ETIMEDOUT;
                        break;
                }
                t[1] = atomic_load(&l.woke_ns);
                t[2] = atomic_load(&l.polled_ns);
                t[3] = atomic_load(&l.written_ns);
                t[4] = atomic_load(&wr.stamp);
                if (i < WARMUP)
                        continue;
                for (int k = 0; k < STAGES; k++)
                        st[k].v[st[k].n++] = t[k + 1] > t[k] ? t[k + 1] - t[k] : 0;
        }
        waiter_stop(&wr);
        if (l.wake_fd > 0) {
                atomic_store(&l.stop, 1);
                pthread_join(l.thread, NULL);
        }
        if (r == 0) {
                printf("outbound stage by stage, in process (the daemon's table, wake thread, a "
                       "poll loop, a pty), %d samples (us)\n", STAGE_SAMPLES);
                for (int k = 0; k < STAGES; k++) {
                        double med, p99;

                        percentiles(&st[k], &med, &p99);
                        printf("  %-34s %8.1f %8.1f\n", names[k], med, p99);
                        printf("FIGURE|stage%d|outbound stage: %s (p99)|%.1f|us|-\n", k + 1,
                               names[k], p99);
                }
        } else {
                fprintf(stderr, "bench_e2e: stage run failed: %s\n", strerror(-r));
        }
        if (fm >= 0)
                close(fm);
        if (fs >= 0)
                close(fs);
        sl_close(c);
        shm_table_destroy(l.t);
        return r;
}

static int run_idle(void)
{
        int masters[IDLE_LINKS], slaves[IDLE_LINKS], r;
        long long cpu0, cpu1, cs0, cs1, w0 = -1, w1 = -1, t0 = -1, t1 = -1, i0 = -1, i1 = -1;
        char reply[LINE_MAX_BENCH * 4];
        struct harness h;
        long hz = sysconf(_SC_CLK_TCK);

        r = daemon_start(&h, "idle", IDLE_LINKS, 0, masters, slaves);
        if (r < 0) {
                fprintf(stderr, "bench_e2e: idle daemon start: %s\n", strerror(-r));
                harness_cleanup(&h);
                return r;
        }
        usleep(200000);         /* let start-up settle: full lists sent, nothing pending */
        if (control_request(&h, "stats\n", reply, sizeof(reply)) == 0) {
                w0 = stat_field(reply, "wakeups");
                t0 = stat_field(reply, "timer_fires");
                i0 = stat_field(reply, "idle_wakeups");
        }
        cpu0 = cpu_ticks(h.pid);
        cs0 = ctx_switches(h.pid);
        sleep(IDLE_S);
        cpu1 = cpu_ticks(h.pid);
        cs1 = ctx_switches(h.pid);
        if (control_request(&h, "stats\n", reply, sizeof(reply)) == 0) {
                w1 = stat_field(reply, "wakeups");
                t1 = stat_field(reply, "timer_fires");
                i1 = stat_field(reply, "idle_wakeups");
        }
        printf("idle daemon, %d SharedLink links without periodic send, %d s\n", IDLE_LINKS,
               IDLE_S);
        printf("  cpu: %.3f s (%.3f%% of one core)\n", (double)(cpu1 - cpu0) / (double)hz,
               100.0 * (double)(cpu1 - cpu0) / (double)hz / IDLE_S);
        printf("  context switches, all threads: %.1f /s\n", (double)(cs1 - cs0) / IDLE_S);
        printf("  resident memory: %lld KiB\n", rss_kib(h.pid));
        printf("FIGURE|idle_switches|idle daemon: context switches, all threads|%.1f|/s|-\n",
               (double)(cs1 - cs0) / IDLE_S);
        printf("FIGURE|daemon_rss|idle daemon resident memory (4 links)|%lld|KiB|-\n",
               rss_kib(h.pid));
        if (w0 >= 0 && w1 >= 0)
                /* The two stats requests themselves wake the loop (accept, read, reply). */
                printf("  loop wakeups: %.1f /s, timer fires %.1f /s, idle wakeups %lld; "
                       "beyond timers: %lld (the stats request's own)\n",
                       (double)(w1 - w0) / IDLE_S, (double)(t1 - t0) / IDLE_S, i1 - i0,
                       (w1 - w0) - (t1 - t0));
        if (w0 >= 0 && w1 >= 0)
                printf("FIGURE|idle_wakeups|idle daemon: loop wake-ups|%.1f|/s|-\n",
                       (double)(w1 - w0) / IDLE_S);
        else
                printf("  loop wakeups: (the daemon does not answer `stats`)\n");
        for (unsigned i = 0; i < IDLE_LINKS; i++) {
                close(masters[i]);
                close(slaves[i]);
        }
        harness_cleanup(&h);
        return 0;
}

int main(int argc, char **argv)
{
        int r;

        signal(SIGPIPE, SIG_IGN);
        /* `bench_e2e outscale`: that comparison alone (an A/B between two builds). */
        if (argc > 1 && strcmp(argv[1], "outscale") == 0)
                return run_outscale() < 0 ? 1 : 0;
        r = run_latency();
        if (run_outscale() < 0)
                r = -1;
        if (run_stages() < 0)
                r = -1;
        if (run_idle() < 0)
                r = -1;
        return r < 0 ? 1 : 0;
}
