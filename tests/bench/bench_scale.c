/*
 * How the costs of a real sharedlinkd grow with the instance: 10, 100 and 1,000 configured
 * variables on 1, 4 and 16 SharedLink links (pty pairs whose master this benchmark holds, the
 * links busy at once), and one more row at the instance's caps. For each cell, through the public
 * API and the ptys only (so that it measures whatever the library and the daemon do inside):
 *
 *   sl_read         ns per sl_read() with metadata, the reads walking every variable of the
 *                   instance in turn (median of batch means; the daemon idle);
 *   sl_write        ns per sl_write(), walking every outbound variable in turn, while the daemon
 *                   sends what was written (median of batch means);
 *   write -> wire   one round: an sl_write() to one outbound variable of every link, back to
 *                   back; each sample is one link's write to the frame carrying the value read
 *                   whole on that link's master (median and p99 over all links' samples);
 *   frame -> wait   one round: a frame written into every link's master, back to back, each
 *                   setting one inbound variable; each sample is one frame's write to a client
 *                   blocked in sl_wait() having read the new value;
 *   CPU per write   the daemon's CPU time (utime + stime of every thread, read from its process
 *   CPU per frame   CPU clock in ns where /proc/PID/stat counts 10 ms ticks) over the write ->
 *                   wire rounds divided by their writes, and over the frame -> wait rounds
 *                   divided by their frames;
 *   RSS, shm        the daemon's resident memory after the cell's work, and the size of the
 *                   instance's two shm objects (/dev/shm/sharedlink.<instance>.{in,out}).
 *
 * Each cell's variables are split evenly over its links, and each link's half outbound, half
 * inbound; a link needs one of each, so 10 variables on 16 links are 32 (the table says so). A
 * list holds at most CONFIG_LIST_MAX variables, so a link with more gets more peers (addresses
 * B, C, ...), its lists split evenly between them. Variables change in turn: every round moves to
 * the next variable of each link, so the whole table is touched, not one hot slot.
 *
 * The cells run one after the other, PASSES times over; each figure is the median of its passes,
 * so that a busy spell of the machine weighs on different cells in different passes. Every row
 * is printed again as ratios to the first (10 variables, 1 link). Work is bounded by
 * counts (rounds, batches), never by time: a busy machine makes the run slower, not shorter. The
 * exit code is 0 unless something failed to run (a benchmark does not judge).
 *
 * Needs the optimised daemon: `make bench` runs it with SHAREDLINK_BUILD=build.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <poll.h>
#include <pthread.h>
#include <semaphore.h>
#include <signal.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <sharedlink.h>

#include "common/harness.h"
#include "common/wire.h"
#include "daemon/config_types.h"

#define LINK_ADDR       'A'             /* every link's own address; its peers are B, C, ... */
#define START_MS        10000
#define WAIT_MS         2000            /* one round must not take longer */
#define GAP_US          300             /* before each round: the waiting threads sleep again */
#define QUIET_MS        50              /* no byte on any master this long: the daemon is done */
#define SETTLE_MAX      200             /* quiet periods waited for at most (then go on anyway) */
#define SAMPLES_CELL    1600            /* latency samples per cell and direction, at least... */
#define ROUNDS_MIN      200             /* ...but never fewer rounds than this */
#define WARMUP_ROUNDS   20
#define READ_BATCH      256             /* sl_read calls per timed batch */
#define READ_BATCHES    2000
#define WRITE_BATCH     64              /* sl_write calls per timed batch */
#define WRITE_BATCHES   200
#define VALUE_MAX       32              /* the values this benchmark writes */
#define RXBUF           8192            /* per master: the bytes not yet matched */
#define RX_KEEP         256             /* kept when the buffer is cut: a needle split by a read */
#define YAML_MAX        (256 * 1024)
#define LOG_TAIL        2048            /* bytes of the daemon's log shown when a cell fails */
#define NS_PER_US       1000.0
#define NS_PER_S        1000000000ull

#define NCELLS          (3 * 3 + 1)
#define PASSES          3               /* each figure: the median of its passes */

/* One cell of the table: the instance's size. */
struct cell {
        unsigned vars, links;
        const char *note;
};

static const struct cell cells[NCELLS] = {
        { 10, 1, NULL },    { 100, 1, NULL },    { 1000, 1, NULL },
        { 10, 4, NULL },    { 100, 4, NULL },    { 1000, 4, NULL },
        { 10, 16, NULL },   { 100, 16, NULL },   { 1000, 16, NULL },
        { CONFIG_VARS_MAX, 1, "the instance's cap, every list full" },
};

/* What one cell measured. */
enum metric {
        M_READ, M_WRITE, M_OUT_P50, M_OUT_P99, M_IN_P50, M_IN_P99, M_CPU_WRITE, M_CPU_FRAME,
        M_RSS, M_SHM, M_COUNT
};

struct result {
        unsigned vars;                  /* configured, as run (a link needs two) */
        unsigned links, peers;
        double m[M_COUNT];
        int ok;
};

/* One link of a running cell. */
struct blink {
        int master, slave;
        unsigned nout, nin, peers;
        unsigned per_out, per_in;       /* positions per peer (the last may have fewer) */
        int *out_ids, *in_ids;          /* sl ids, by index within the link */
        /* the round in flight */
        unsigned cur;                   /* index of the variable it changes */
        char expect[VALUE_MAX];
        uint64_t t_cause, t_seen;       /* t_seen 0: not seen yet */
        /* outbound: what came on the master and is not matched yet */
        char rx[RXBUF];
        size_t rx_len;
};

struct bench {
        struct harness h;
        struct sl_client *c;
        struct blink *links;
        unsigned nlinks;
        /* the threads that see a round's values arrive */
        pthread_t thread;
        int started;
        sem_t go, done;
        _Atomic int stop;
        _Atomic int mode;               /* what the thread does on go */
        _Atomic int draining;           /* MODE_DRAIN: until this is 0 */
        int failed;
};

enum { MODE_OUT, MODE_IN, MODE_DRAIN };

static uint64_t now_ns(void)
{
        return harness_now_ns();
}

static int cmp_u64(const void *a, const void *b)
{
        uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;

        return (x > y) - (x < y);
}

static int cmp_double(const void *a, const void *b)
{
        double x = *(const double *)a, y = *(const double *)b;

        return (x > y) - (x < y);
}

/* ---------------------------------------------------------------------------------------------
 * The daemon's CPU time and memory */

/* CPU time of pid, every thread, user and system (what /proc/PID/stat counts in clock ticks as
 * utime + stime), in ns from the process's CPU clock; -1 when it cannot be read. */
static long long daemon_cpu_ns(pid_t pid)
{
        struct timespec ts;
        clockid_t clock;

        if (clock_getcpuclockid(pid, &clock) != 0 || clock_gettime(clock, &ts) < 0)
                return -1;
        return (long long)ts.tv_sec * (long long)NS_PER_S + ts.tv_nsec;
}

/* Resident memory of pid in KiB (the second field of /proc/PID/statm, in pages), or -1. */
static long long daemon_rss_kib(pid_t pid)
{
        char path[64];
        unsigned long long size, resident;
        long page = sysconf(_SC_PAGESIZE);
        FILE *f;
        int n;

        snprintf(path, sizeof(path), "/proc/%d/statm", (int)pid);
        f = fopen(path, "re");
        if (!f)
                return -1;
        n = fscanf(f, "%llu %llu", &size, &resident);
        fclose(f);
        return n == 2 ? (long long)(resident * (unsigned long long)page / 1024u) : -1;
}

/* The size of the instance's two shm objects together, in KiB, or -1. */
static long long shm_kib(const char *instance)
{
        static const char *const suffix[] = { "in", "out" };
        long long sum = 0;

        for (size_t i = 0; i < sizeof(suffix) / sizeof(suffix[0]); i++) {
                char path[HARNESS_PATH_MAX];
                struct stat st;

                snprintf(path, sizeof(path), "/dev/shm/sharedlink.%s.%s", instance, suffix[i]);
                if (stat(path, &st) < 0)
                        return -1;
                sum += (long long)st.st_size;
        }
        return sum / 1024;
}

/* ---------------------------------------------------------------------------------------------
 * The instance of a cell */

static int yaml_add(char *buf, size_t *len, const char *fmt, ...)
        __attribute__((format(printf, 3, 4)));

static int yaml_add(char *buf, size_t *len, const char *fmt, ...)
{
        va_list ap;
        int n;

        va_start(ap, fmt);
        n = vsnprintf(buf + *len, YAML_MAX - *len, fmt, ap);
        va_end(ap);
        if (n < 0 || (size_t)n >= YAML_MAX - *len)
                return -ENOSPC;
        *len += (size_t)n;
        return 0;
}

/* "[<prefix><link>_<first>, ...]" for the positions [first, end) of one peer's list. */
static int yaml_list(char *buf, size_t *len, const char *key, char prefix, unsigned link,
                     unsigned first, unsigned end)
{
        int r = yaml_add(buf, len, "        %s: [", key);

        for (unsigned j = first; r == 0 && j < end; j++)
                r = yaml_add(buf, len, "%s%c%u_%u", j > first ? ", " : "", prefix, link, j);
        return r < 0 ? r : yaml_add(buf, len, "]\n");
}

static unsigned div_up(unsigned a, unsigned b)
{
        return (a + b - 1) / b;
}

/* Splits vars over the links (at least one outbound and one inbound each) and their peers. */
static void plan_links(struct bench *b, unsigned vars)
{
        for (unsigned k = 0; k < b->nlinks; k++) {
                struct blink *l = &b->links[k];
                unsigned n = vars / b->nlinks + (k < vars % b->nlinks);

                if (n < 2)
                        n = 2;
                l->nout = div_up(n, 2);
                l->nin = n / 2;
                l->peers = div_up(l->nout > l->nin ? l->nout : l->nin, CONFIG_LIST_MAX);
                l->per_out = div_up(l->nout, l->peers);
                l->per_in = div_up(l->nin, l->peers);
        }
}

static int write_config(struct bench *b, char *path)
{
        char *yaml = malloc(YAML_MAX);
        char dev[HARNESS_PATH_MAX + 16], pts[HARNESS_PATH_MAX];
        size_t len = 0;
        int r;

        if (!yaml)
                return -ENOMEM;
        r = yaml_add(yaml, &len, "instance: %s\nruntime_dir: %s\nlinks:\n", b->h.instance,
                     b->h.dir);
        for (unsigned k = 0; r == 0 && k < b->nlinks; k++) {
                struct blink *l = &b->links[k];

                r = harness_openpty(&l->master, &l->slave, pts);
                if (r < 0)
                        break;
                snprintf(dev, sizeof(dev), "%s/tty%u", b->h.dir, k);
                if (symlink(pts, dev) < 0) {
                        r = -errno;
                        break;
                }
                r = yaml_add(yaml, &len,
                             "  - name: l%u\n"
                             "    protocol: sharedlink\n"
                             "    transport: serial\n"
                             "    device: %s\n"
                             "    address: %c\n"
                             "    peers:\n", k, dev, LINK_ADDR);
                for (unsigned p = 0; r == 0 && p < l->peers; p++) {
                        unsigned o0 = p * l->per_out, i0 = p * l->per_in;
                        unsigned o1 = o0 + l->per_out < l->nout ? o0 + l->per_out : l->nout;
                        unsigned i1 = i0 + l->per_in < l->nin ? i0 + l->per_in : l->nin;

                        /* No periodic send, never stale, every write sent at once. */
                        r = yaml_add(yaml, &len,
                                     "      - address: %c\n"
                                     "        period_ms: 0\n"
                                     "        stale_ms: 0\n"
                                     "        on_change: true\n"
                                     "        min_interval_ms: 0\n", LINK_ADDR + 1 + (int)p);
                        if (r == 0 && o1 > o0)
                                r = yaml_list(yaml, &len, "outbound", 'o', k, o0, o1);
                        if (r == 0 && i1 > i0)
                                r = yaml_list(yaml, &len, "inbound", 'i', k, i0, i1);
                }
        }
        if (r == 0)
                r = harness_write_file(&b->h, "scale.yaml", yaml, path);
        free(yaml);
        return r;
}

/* The ids of every variable, by link and index. */
static int find_ids(struct bench *b)
{
        char name[SL_NAME_SIZE];

        for (unsigned k = 0; k < b->nlinks; k++) {
                struct blink *l = &b->links[k];

                l->out_ids = calloc(l->nout, sizeof(int));
                l->in_ids = calloc(l->nin, sizeof(int));
                if (!l->out_ids || !l->in_ids)
                        return -ENOMEM;
                for (unsigned j = 0; j < l->nout; j++) {
                        snprintf(name, sizeof(name), "o%u_%u", k, j);
                        l->out_ids[j] = sl_find(b->c, name);
                        if (l->out_ids[j] < 0)
                                return l->out_ids[j];
                }
                for (unsigned j = 0; j < l->nin; j++) {
                        snprintf(name, sizeof(name), "i%u_%u", k, j);
                        l->in_ids[j] = sl_find(b->c, name);
                        if (l->in_ids[j] < 0)
                                return l->in_ids[j];
                }
        }
        return 0;
}

/* Reads every master until none has had a byte for QUIET_MS (what the daemon sends at link up,
 * or after a burst of writes), at most SETTLE_MAX periods. */
static void settle(struct bench *b)
{
        struct pollfd p[CONFIG_LINKS_MAX];
        char buf[4096];

        for (unsigned k = 0; k < b->nlinks; k++)
                p[k] = (struct pollfd){ .fd = b->links[k].master, .events = POLLIN };
        for (unsigned i = 0; i < SETTLE_MAX && poll(p, b->nlinks, QUIET_MS) > 0; i++)
                for (unsigned k = 0; k < b->nlinks; k++)
                        while (read(p[k].fd, buf, sizeof(buf)) > 0)
                                ;
}

/* ---------------------------------------------------------------------------------------------
 * The thread that sees a round arrive: on the masters (outbound) or through sl_wait (inbound) */

/* Appends what master k has and looks for the frame carrying its expected value, whole. */
static void out_take(struct blink *l, int drain)
{
        char needle[VALUE_MAX + 4];
        ssize_t n;

        snprintf(needle, sizeof(needle), "|D%s|", l->expect);
        while ((n = read(l->master, l->rx + l->rx_len, sizeof(l->rx) - l->rx_len)) > 0) {
                l->rx_len += (size_t)n;
                if (!drain && !l->t_seen) {
                        char *found = memmem(l->rx, l->rx_len, needle, strlen(needle));
                        /* ']' ends the frame; no value may hold one */
                        char *end = found ? memchr(found, ']',
                                                   l->rx_len - (size_t)(found - l->rx)) : NULL;

                        if (end) {
                                l->t_seen = now_ns();
                                l->rx_len = 0;
                                continue;
                        }
                }
                if (drain || l->rx_len > sizeof(l->rx) - RX_KEEP) {
                        size_t keep = drain ? 0 : RX_KEEP;

                        memmove(l->rx, l->rx + l->rx_len - keep, keep);
                        l->rx_len = keep;
                }
        }
}

static int round_out(struct bench *b)
{
        struct pollfd p[CONFIG_LINKS_MAX];
        unsigned left = b->nlinks;

        for (unsigned k = 0; k < b->nlinks; k++)
                p[k] = (struct pollfd){ .fd = b->links[k].master, .events = POLLIN };
        while (left > 0) {
                if (poll(p, b->nlinks, WAIT_MS) <= 0)
                        return -ETIMEDOUT;
                left = 0;
                for (unsigned k = 0; k < b->nlinks; k++) {
                        if (p[k].revents)
                                out_take(&b->links[k], 0);
                        left += !b->links[k].t_seen;
                }
        }
        return 0;
}

static int round_in(struct bench *b, uint32_t *cursor)
{
        char value[SL_VALUE_SIZE];
        uint64_t deadline = now_ns() + (uint64_t)WAIT_MS * 1000000u;
        unsigned left;

        for (;;) {
                left = 0;
                for (unsigned k = 0; k < b->nlinks; k++) {
                        struct blink *l = &b->links[k];

                        if (l->t_seen)
                                continue;
                        if (sl_read(b->c, l->in_ids[l->cur], value, sizeof(value), NULL) >= 0 &&
                            strcmp(value, l->expect) == 0)
                                l->t_seen = now_ns();
                        else
                                left++;
                }
                if (left == 0)
                        return 0;
                if (now_ns() > deadline)
                        return -ETIMEDOUT;
                sl_wait(b->c, cursor, WAIT_MS);
        }
}

static void *watch_main(void *arg)
{
        struct bench *b = arg;
        uint32_t cursor = 0;

        sl_wait(b->c, &cursor, 0);
        while (sem_wait(&b->go) == 0 && !atomic_load(&b->stop)) {
                int r = 0;

                if (b->mode == MODE_OUT) {
                        r = round_out(b);
                } else if (b->mode == MODE_IN) {
                        r = round_in(b, &cursor);
                } else {
                        /* Drain until told to stop: the daemon's frames during the write burst. */
                        struct pollfd p[CONFIG_LINKS_MAX];

                        for (unsigned k = 0; k < b->nlinks; k++)
                                p[k] = (struct pollfd){ .fd = b->links[k].master,
                                                        .events = POLLIN };
                        while (atomic_load(&b->draining))
                                if (poll(p, b->nlinks, QUIET_MS) > 0)
                                        for (unsigned k = 0; k < b->nlinks; k++)
                                                out_take(&b->links[k], 1);
                }
                if (r < 0)
                        b->failed = r;
                sem_post(&b->done);
        }
        return NULL;
}

/* ---------------------------------------------------------------------------------------------
 * The measurements */

/* ns per call: the median of batch means, n batches of per calls. */
static double batch_median(double *means, unsigned n)
{
        qsort(means, n, sizeof(*means), cmp_double);
        return means[n / 2];
}

static double measure_read(struct bench *b, const int *ids, unsigned nids)
{
        static double means[READ_BATCHES];
        char value[SL_VALUE_SIZE];
        unsigned at = 0;

        for (unsigned i = 0; i < READ_BATCHES; i++) {
                uint64_t t0 = now_ns();

                for (unsigned j = 0; j < READ_BATCH; j++) {
                        struct sl_meta meta = { .size = sizeof(meta) };

                        sl_read(b->c, ids[at], value, sizeof(value), &meta);
                        at = at + 1 == nids ? 0 : at + 1;
                }
                means[i] = (double)(now_ns() - t0) / READ_BATCH;
        }
        return batch_median(means, READ_BATCHES);
}

static double measure_write(struct bench *b, const int *ids, unsigned nids, int *ret_err)
{
        static double means[WRITE_BATCHES];
        char value[VALUE_MAX];
        unsigned at = 0, seq = 0;

        *ret_err = 0;
        for (unsigned i = 0; i < WRITE_BATCHES; i++) {
                uint64_t t0 = now_ns();

                for (unsigned j = 0; j < WRITE_BATCH; j++) {
                        int r;

                        snprintf(value, sizeof(value), "s%u", seq++);
                        r = sl_write(b->c, ids[at], value);
                        if (r < 0)
                                *ret_err = r;
                        at = at + 1 == nids ? 0 : at + 1;
                }
                means[i] = (double)(now_ns() - t0) / WRITE_BATCH;
        }
        return batch_median(means, WRITE_BATCHES);
}

/* Causes one round on every link, back to back: sl_write (outbound) or a frame (inbound). */
static int cause_round(struct bench *b, int mode)
{
        for (unsigned k = 0; k < b->nlinks; k++) {
                struct blink *l = &b->links[k];
                int r;

                l->t_cause = now_ns();
                if (mode == MODE_OUT) {
                        r = sl_write(b->c, l->out_ids[l->cur], l->expect);
                } else {
                        unsigned j = l->cur;
                        char body[VALUE_MAX + 32], frame[VALUE_MAX + 64];
                        size_t n;

                        snprintf(body, sizeof(body), "N%u|D%s", j % l->per_in, l->expect);
                        n = wire_slp_frame(frame, sizeof(frame), LINK_ADDR,
                                           (char)(LINK_ADDR + 1 + (int)(j / l->per_in)), body,
                                           true);
                        r = harness_write_all(l->master, frame, n, WAIT_MS);
                }
                if (r < 0)
                        return r;
        }
        return 0;
}

/* Rounds of one direction: latency samples of every link, and the daemon's CPU per event. */
static int measure_rounds(struct bench *b, int mode, unsigned rounds, double *ret_p50,
                          double *ret_p99, double *ret_cpu_us)
{
        size_t cap = (size_t)rounds * b->nlinks, n = 0;
        uint64_t *s = malloc(cap * sizeof(*s));
        long long cpu0 = -1, cpu1;
        int r = 0;

        if (!s)
                return -ENOMEM;
        b->mode = mode;
        for (unsigned i = 0; r == 0 && i < WARMUP_ROUNDS + rounds; i++) {
                if (i == WARMUP_ROUNDS)
                        cpu0 = daemon_cpu_ns(b->h.pid);
                for (unsigned k = 0; k < b->nlinks; k++) {
                        struct blink *l = &b->links[k];

                        snprintf(l->expect, sizeof(l->expect), "%c%u",
                                 mode == MODE_OUT ? 'w' : 'f', i);
                        l->cur = i % (mode == MODE_OUT ? l->nout : l->nin);
                        l->t_seen = 0;
                }
                sem_post(&b->go);
                usleep(GAP_US);         /* the watcher sleeps before the first cause */
                r = cause_round(b, mode);
                sem_wait(&b->done);
                if (r == 0 && b->failed)
                        r = b->failed;
                if (r < 0 || i < WARMUP_ROUNDS)
                        continue;
                for (unsigned k = 0; k < b->nlinks; k++)
                        s[n++] = b->links[k].t_seen - b->links[k].t_cause;
        }
        cpu1 = daemon_cpu_ns(b->h.pid);
        if (r == 0) {
                qsort(s, n, sizeof(*s), cmp_u64);
                *ret_p50 = (double)s[n / 2] / NS_PER_US;
                *ret_p99 = (double)s[(n * 99) / 100] / NS_PER_US;
                *ret_cpu_us = cpu0 >= 0 && cpu1 >= cpu0 ? (double)(cpu1 - cpu0) / (double)n /
                                                          NS_PER_US : -1.0;
        }
        free(s);
        return r;
}

/* The end of the daemon's captured log, to stderr. */
static void print_log_tail(const char *path)
{
        char buf[LOG_TAIL];
        size_t n;
        FILE *f = fopen(path, "re");

        if (!f)
                return;
        if (fseek(f, -(long)sizeof(buf), SEEK_END) < 0)
                rewind(f);
        n = fread(buf, 1, sizeof(buf), f);
        fclose(f);
        fprintf(stderr, "bench_scale: the daemon's log (%s), its end:\n%.*s\n", path, (int)n, buf);
}

static void bench_free(struct bench *b)
{
        if (b->started) {
                atomic_store(&b->stop, 1);
                b->mode = -1;
                sem_post(&b->go);
                pthread_join(b->thread, NULL);
        }
        sem_destroy(&b->go);
        sem_destroy(&b->done);
        sl_close(b->c);
        for (unsigned k = 0; b->links && k < b->nlinks; k++) {
                harness_close_fd(&b->links[k].master);
                harness_close_fd(&b->links[k].slave);
                free(b->links[k].out_ids);
                free(b->links[k].in_ids);
        }
        free(b->links);
        harness_cleanup(&b->h);
}

static int run_cell(const struct cell *cell, struct result *res)
{
        struct bench b = { .nlinks = cell->links };
        char path[HARNESS_PATH_MAX];
        int *all_ids = NULL, *out_ids = NULL, err;
        unsigned nall = 0, nout = 0, rounds;
        const char *phase = "start";
        int r;

        sem_init(&b.go, 0, 0);
        sem_init(&b.done, 0, 0);
        b.links = calloc(b.nlinks, sizeof(*b.links));
        if (!b.links) {
                sem_destroy(&b.go);
                sem_destroy(&b.done);
                return -ENOMEM;
        }
        for (unsigned k = 0; k < b.nlinks; k++)
                b.links[k].master = b.links[k].slave = -1;
        r = harness_init(&b.h, "scale");
        if (r < 0)
                goto out;
        /* Thirty daemons' start and stop lines would bury the tables; shown when a cell fails. */
        b.h.capture_log = 1;
        plan_links(&b, cell->vars);
        r = write_config(&b, path);
        if (r == 0)
                r = harness_start_daemon(&b.h, path, START_MS, NULL, NULL);
        if (r == 0)
                r = sl_open(b.h.instance, &b.c);
        if (r == 0)
                r = find_ids(&b);
        if (r < 0)
                goto out;
        res->links = b.nlinks;
        res->vars = res->peers = 0;
        for (unsigned k = 0; k < b.nlinks; k++) {
                res->vars += b.links[k].nout + b.links[k].nin;
                res->peers += b.links[k].peers;
        }
        all_ids = calloc(res->vars, sizeof(int));
        out_ids = calloc(res->vars, sizeof(int));
        if (!all_ids || !out_ids) {
                r = -ENOMEM;
                goto out;
        }
        /* Link by link, variable by variable: the order of the directory. */
        for (unsigned k = 0; k < b.nlinks; k++) {
                for (unsigned j = 0; j < b.links[k].nout; j++)
                        all_ids[nall++] = out_ids[nout++] = b.links[k].out_ids[j];
                for (unsigned j = 0; j < b.links[k].nin; j++)
                        all_ids[nall++] = b.links[k].in_ids[j];
        }
        phase = "sl_read, sl_write";
        settle(&b);             /* the full lists sent at link up */
        r = -pthread_create(&b.thread, NULL, watch_main, &b);
        if (r < 0)
                goto out;
        b.started = 1;

        res->m[M_READ] = measure_read(&b, all_ids, nall);
        b.mode = MODE_DRAIN;
        atomic_store(&b.draining, 1);
        sem_post(&b.go);
        res->m[M_WRITE] = measure_write(&b, out_ids, nout, &err);
        atomic_store(&b.draining, 0);
        sem_wait(&b.done);
        settle(&b);
        r = err;
        phase = "write -> wire";
        rounds = SAMPLES_CELL / b.nlinks > ROUNDS_MIN ? SAMPLES_CELL / b.nlinks : ROUNDS_MIN;
        if (r == 0)
                r = measure_rounds(&b, MODE_OUT, rounds, &res->m[M_OUT_P50], &res->m[M_OUT_P99],
                                   &res->m[M_CPU_WRITE]);
        if (r == 0)
                phase = "frame -> wait";
        if (r == 0)
                r = measure_rounds(&b, MODE_IN, rounds, &res->m[M_IN_P50], &res->m[M_IN_P99],
                                   &res->m[M_CPU_FRAME]);
        res->m[M_RSS] = (double)daemon_rss_kib(b.h.pid);
        res->m[M_SHM] = (double)shm_kib(b.h.instance);
        res->ok = r == 0;
out:
        if (r < 0) {
                fprintf(stderr, "bench_scale: %u variables, %u links, %s: %s\n", cell->vars,
                        cell->links, phase, strerror(-r));
                print_log_tail(b.h.log_path);
        }
        free(all_ids);
        free(out_ids);
        bench_free(&b);
        return r;
}

/* ---------------------------------------------------------------------------------------------
 * The table */

static const char *const metric_head[M_COUNT] = {
        "read ns", "write ns", "w>wire", "p99", "fr>wait", "p99", "cpu/wr", "cpu/fr", "RSS KiB",
        "shm KiB",
};

static void print_row(const struct result *r, const struct result *base, int ratio)
{
        printf("  %5u %5u %5u ", r->vars, r->links, r->peers);
        for (int m = 0; m < M_COUNT; m++) {
                if (!r->ok || r->m[m] < 0 || (ratio && !(base->m[m] > 0)))
                        printf(" %8s", "-");
                else if (ratio)
                        printf(" %7.2fx", r->m[m] / base->m[m]);
                else
                        printf(" %8.*f", m == M_RSS || m == M_SHM ? 0 : 1, r->m[m]);
        }
        printf("\n");
}

static void print_head(const char *what)
{
        printf("%s%s   vars links peers", what, *what ? "\n" : "");
        for (int m = 0; m < M_COUNT; m++)
                printf(" %8s", metric_head[m]);
        printf("\n");
}

static void print_figure(const char *key, const char *label, double value, const char *unit,
                         const char *goal)
{
        printf("FIGURE|%s|%s|%.*f|%s|%s\n", key, label, value < 10.0 ? 2 : 1, value, unit, goal);
}

static void print_figures(const struct result *res)
{
        const struct result *base = &res[0], *big = &res[2], *wide = &res[8];

        if (base->ok && big->ok) {
                print_figure("scale_out_p50_ratio", "scale: write -> wire median, 1,000 / 10 vars "
                             "(1 link)", big->m[M_OUT_P50] / base->m[M_OUT_P50], "x", "<=1.2");
                print_figure("scale_out_p99_ratio", "scale: write -> wire p99, 1,000 / 10 vars "
                             "(1 link)", big->m[M_OUT_P99] / base->m[M_OUT_P99], "x", "<=1.2");
                print_figure("scale_out_p99", "scale: write -> wire p99, 1,000 vars (1 link)",
                             big->m[M_OUT_P99], "us", "<=500");
                print_figure("scale_in_p50_ratio", "scale: frame -> sl_wait median, 1,000 / 10 "
                             "vars (1 link)", big->m[M_IN_P50] / base->m[M_IN_P50], "x", "-");
        }
        if (base->ok && wide->ok) {
                print_figure("scale_out_p99_wide", "scale: write -> wire p99, 1,000 vars on 16 "
                             "links", wide->m[M_OUT_P99], "us", "-");
                print_figure("scale_in_p99_wide", "scale: frame -> sl_wait p99, 1,000 vars on 16 "
                             "links", wide->m[M_IN_P99], "us", "-");
                print_figure("scale_cpu_write_wide", "scale: daemon CPU per write, 1,000 vars on "
                             "16 links", wide->m[M_CPU_WRITE], "us", "-");
                print_figure("scale_cpu_frame_wide", "scale: daemon CPU per frame, 1,000 vars on "
                             "16 links", wide->m[M_CPU_FRAME], "us", "-");
                print_figure("scale_rss_wide", "scale: daemon RSS, 1,000 vars on 16 links",
                             wide->m[M_RSS], "KiB", "-");
        }
}

/* Each figure of a cell: the median of the passes that ran (other work on the machine hits
 * different cells in different passes). */
static void merge_passes(struct result pass[PASSES][NCELLS], struct result *ret)
{
        for (int i = 0; i < NCELLS; i++) {
                struct result *out = &ret[i];
                double v[PASSES];

                *out = (struct result){ 0 };
                for (int p = 0; p < PASSES; p++)
                        if (pass[p][i].ok) {
                                *out = pass[p][i];
                                break;
                        }
                for (int m = 0; out->ok && m < M_COUNT; m++) {
                        int n = 0;

                        for (int p = 0; p < PASSES; p++)
                                if (pass[p][i].ok && pass[p][i].m[m] >= 0)
                                        v[n++] = pass[p][i].m[m];
                        if (n > 0) {
                                qsort(v, (size_t)n, sizeof(v[0]), cmp_double);
                                /* of two, the lower: waiting only ever adds time */
                                out->m[m] = v[(n - 1) / 2];
                        } else {
                                out->m[m] = -1.0;
                        }
                }
        }
}

int main(void)
{
        static struct result pass[PASSES][NCELLS], res[NCELLS];
        int failed = 0;

        signal(SIGPIPE, SIG_IGN);
        printf("caps of an instance (src/daemon/config_types.h): %u variables per list, %u "
               "configured per instance, %u links, %u peers per link\n", CONFIG_LIST_MAX,
               CONFIG_VARS_MAX, CONFIG_LINKS_MAX, CONFIG_PEERS_MAX);
        for (int p = 0; p < PASSES; p++)
                for (int i = 0; i < NCELLS; i++)
                        if (run_cell(&cells[i], &pass[p][i]) < 0)
                                failed = 1;
        merge_passes(pass, res);
        for (int i = 0; i < NCELLS; i++)
                if (res[i].ok && res[i].vars != cells[i].vars)
                        printf("  (%u variables on %u links: %u, one outbound and one inbound "
                               "each)\n", cells[i].vars, cells[i].links, res[i].vars);
        printf("\n");
        printf("scaling, real daemon, links busy at once, each figure the median of %d passes\n"
               "(read, write: ns per call, median of batch means; w>wire, fr>wait: us, median "
               "and p99;\ncpu: daemon us per write, per frame; shm: the two objects)\n",
               PASSES);
        print_head("");
        for (int i = 0; i < NCELLS; i++) {
                print_row(&res[i], &res[0], 0);
                if (cells[i].note && res[i].ok)
                        printf("        ^ %s\n", cells[i].note);
        }
        print_head("the same, each next to the first row (10 variables, 1 link)");
        for (int i = 0; i < NCELLS; i++)
                print_row(&res[i], &res[0], 1);
        print_figures(res);
        return failed;
}
