/*
 * sharedlink-agility: how long a gate passage takes to reach a browser's scoreboard and the
 * venue's display, with a real sharedlinkd (its CIRCE mediator emulator with a course: start gate
 * E1E1E1, finish gate E2E2E2, remote AAAAAA, display D15D15, joined by a pty to the controller
 * link `agility`) and a real sharedlink-agility on that link. One passage of the start gate,
 * emulated by a control request `circe arena emulate action E1E1E1 sensor-time=N`, is timed
 * from the moment that request is written, three ways at once:
 *
 *   floor     -> the `action` event of E1E1E1 read with sl_events_read (the controller link has
 *             the passage: the path any reader of events pays, no agility in it);
 *   sse       -> an `update` with "StartPassed" arriving on an HTTP client connected to /events,
 *             as a browser's EventSource gets it (agility's engine, its publish, libmicrohttpd);
 *   display   -> the emulated display's arena.device.D15D15.timer_running is 1, seen with
 *             sl_wait (agility's Visualize through the controller link, the radio emulation,
 *             the display's table: what the venue's display shows).
 *
 * Each sample starts from ReadyToStart and is undone with the remote's reset key (back to
 * ReadyToStart without a clock sync); the next starts once the stream and the display show the
 * reset. Three threads each block on their own path (no spinning: the machine has two CPUs and
 * three processes that need them). Prints median and p99 of each, the ratios to the floor, the
 * load average; exit status 0 unless something failed to run.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <sharedlink.h>

#include "common/harness.h"
#include "common/slwait.h"

#define SAMPLES         1000
#define WARMUP          20
#define START_MS        15000
#define WAIT_MS         10000           /* one sample, or one reset, must not take longer */
#define SENSOR_BASE_MS  100000u         /* the passages' sensor times */
#define SENSOR_STEP_MS  1000u
#define SENSOR_WRAP_MS  1000000u        /* a sensor clock counts 0..999999 */
#define CONFIG_MAX      4096
#define REPLY_MAX       1024
#define LOG_MAX         (1 << 20)
#define SSE_BUF         (256 * 1024)
#define NS_PER_US       1000ull
#define NS_PER_MS       1000000ull

#define KEY_READY       "32768"
#define KEY_RESET       "16384"
#define DISPLAY_TIMER   "arena.device.D15D15.timer_running"

enum probe { P_FLOOR, P_SSE, P_DISPLAY, P_COUNT };

static const char *const probe_name[P_COUNT] = { "floor", "sse", "display" };
static const char *const probe_what[P_COUNT] = { "action event, no agility (floor)",
                                                 "SSE update on /events",
                                                 "display timer_running (Visualize)" };

enum sse_state { SSE_NONE, SSE_READY, SSE_STARTED };

struct bench {
        struct harness h;               /* sharedlinkd */
        struct harness a;               /* sharedlink-agility */
        struct sl_client *cl, *ev;      /* the display's reader; the events' reader */
        int ctl, sse;
        int port;
        _Atomic int sse_state;          /* the state of the last update on the stream */
        _Atomic uint64_t got_ns[P_COUNT];
        atomic_bool armed;              /* a passage is on its way: stamp what arrives */
        atomic_bool stop;
        uint64_t lat[P_COUNT][SAMPLES];
};

static struct bench B;

static int cmp_u64(const void *a, const void *b)
{
        uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;

        return (x > y) - (x < y);
}

static void stamp(struct bench *b, enum probe p)
{
        uint64_t none = 0;

        if (atomic_load(&b->armed))
                atomic_compare_exchange_strong(&b->got_ns[p], &none, harness_now_ns());
}

/* ---- the three readers ----------------------------------------------------------------------- */

/* The /events stream: every complete message ("\n\n"-terminated), its state. */
static void *sse_main(void *arg)
{
        struct bench *b = arg;
        static char buf[SSE_BUF];
        size_t len = 0;

        while (!atomic_load(&b->stop)) {
                ssize_t n = read(b->sse, buf + len, sizeof(buf) - 1 - len);
                char *end;

                if (n <= 0)
                        break;
                len += (size_t)n;
                buf[len] = '\0';
                while ((end = strstr(buf, "\n\n"))) {
                        *end = '\0';
                        if (strstr(buf, "\"state\":\"StartPassed\"")) {
                                stamp(b, P_SSE);
                                atomic_store(&b->sse_state, SSE_STARTED);
                        } else if (strstr(buf, "\"state\":\"ReadyToStart\"")) {
                                atomic_store(&b->sse_state, SSE_READY);
                        }
                        len -= (size_t)(end + 2 - buf);
                        memmove(buf, end + 2, len + 1);
                }
                if (len + 1 >= sizeof(buf))
                        len = 0;        /* no message is that long: drop, resynchronise */
        }
        return NULL;
}

/* The event ring: the start gate's action. */
static void *events_main(void *arg)
{
        struct bench *b = arg;
        uint64_t cursor = 0;
        uint32_t wcur = 0;

        sl_events_now(b->ev, &cursor);
        while (!atomic_load(&b->stop)) {
                struct sl_event e[16];
                int n;

                for (size_t i = 0; i < 16; i++)
                        e[i].size = sizeof(e[i]);
                n = sl_events_read(b->ev, &cursor, e, 16);
                for (int i = 0; i < n; i++)
                        if (strcmp(e[i].type_name, "action") == 0 &&
                            strstr(e[i].text, "device=E1E1E1"))
                                stamp(b, P_FLOOR);
                if (n <= 0)
                        sl_wait(b->ev, &wcur, 100);
        }
        return NULL;
}

/* sharedlink-agility's sd_notify datagrams (a STATUS= at every state): read and dropped, as
 * systemd would read them. Unread, the datagram queue (net.unix.max_dgram_qlen) fills within a
 * few samples and the daemon's next notify blocks its loop. */
static void *notify_main(void *arg)
{
        struct bench *b = arg;
        char msg[HARNESS_NOTIFY_MAX];

        while (!atomic_load(&b->stop)) {
                struct pollfd p = { .fd = b->a.notify_fd, .events = POLLIN };

                if (poll(&p, 1, 100) > 0 && recv(b->a.notify_fd, msg, sizeof(msg), 0) < 0)
                        break;
        }
        return NULL;
}

/* ---- setting up ------------------------------------------------------------------------------ */

static int scoreboard_port(struct bench *b)
{
        static const char needle[] = "scoreboard at http://127.0.0.1:";
        char *log = malloc(LOG_MAX + 1), *p;
        int fd = open(b->a.log_path, O_RDONLY | O_CLOEXEC), port = -1;
        ssize_t n = fd >= 0 && log ? read(fd, log, LOG_MAX) : -1;

        if (fd >= 0)
                close(fd);
        if (n > 0) {
                log[n] = '\0';
                p = strstr(log, needle);
                if (p)
                        port = atoi(p + strlen(needle));
        }
        free(log);
        return port;
}

static int request(struct bench *b, const char *line)
{
        char reply[REPLY_MAX];

        if (harness_control_request(b->ctl, line, reply, sizeof(reply), WAIT_MS) < 0 ||
            strcmp(reply, "OK\n") != 0) {
                fprintf(stderr, "bench_agility: \"%s\": %s\n", line, reply);
                return -1;
        }
        return 0;
}

static int emulate(struct bench *b, const char *addr, const char *what)
{
        char line[REPLY_MAX];

        snprintf(line, sizeof(line), "circe arena emulate action %s %s", addr, what);
        return request(b, line);
}

static int press(struct bench *b, const char *key)
{
        char k[32];

        snprintf(k, sizeof(k), "keys=%s", key);
        return emulate(b, "AAAAAA", k) < 0 ? -1 : emulate(b, "AAAAAA", "keys=0");
}

static int value_is(struct bench *b, const char *name, const char *want)
{
        char last[SL_VALUE_SIZE];

        if (slwait_value(b->cl, name, want, WAIT_MS, last, sizeof(last)) < 0) {
                fprintf(stderr, "bench_agility: %s never became %s (last %s)\n", name, want,
                        last);
                return -1;
        }
        return 0;
}

static int start(struct bench *b, const char *build)
{
        static const char links[] =
                "links:\n"
                "  - name: arena\n    protocol: circe\n    role: mediator\n    transport: pty\n"
                "    device: %s/arena.tty\n    version: \"0.2.3\"\n    keepalive_ms: 750\n"
                "    emulate:\n"
                "      - {address: E1E1E1, capabilities: 32}\n"
                "      - {address: E2E2E2, capabilities: 32}\n"
                "      - {address: AAAAAA, capabilities: 3}\n"
                "      - {address: D15D15, capabilities: 64}\n"
                "  - name: agility\n    protocol: circe\n    role: controller\n"
                "    transport: serial\n    device: %s/arena.tty\n    expect_version: \"0.2\"\n";
        char text[CONFIG_MAX], why[HARNESS_WHY_MAX], path[HARNESS_PATH_MAX];
        char csv[HARNESS_PATH_MAX], agility[HARNESS_PATH_MAX], sock[2 * HARNESS_PATH_MAX];
        const char *argv[] = { agility, "-c", path, NULL };
        struct sockaddr_in sa = { .sin_family = AF_INET,
                                  .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
        static const char get[] = "GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
        int st = 0;

        if (harness_init(&b->h, "bagility") < 0 || harness_init(&b->a, "bagilityd") < 0)
                return -1;
        snprintf(text, sizeof(text), links, b->h.dir, b->h.dir);
        b->h.capture_log = 1;
        if (harness_start_config(&b->h, "circe.yaml", text, START_MS, why, sizeof(why)) < 0) {
                fprintf(stderr, "bench_agility: sharedlinkd did not start: %s\n", why);
                return -1;
        }
        if (sl_open(b->h.instance, &b->cl) < 0 || sl_open(b->h.instance, &b->ev) < 0)
                return -1;
        snprintf(sock, sizeof(sock), "%s/%s.sock", b->h.dir, b->h.instance);
        b->ctl = harness_connect_unix(sock);
        if (b->ctl < 0)
                return -1;
        if (harness_write_file(&b->a, "dogs.csv", "CompetitorNumber;HandlerName;DogName;"
                               "CountryCode\n1;Anna Smith;Rex;NL\n2;Bert Jones;Fly;BE\n",
                               csv) < 0)
                return -1;
        snprintf(text, sizeof(text),
                 "instance: %s\nlink: agility\n"
                 "class: {name: Bench, standard_course_time_ms: 40000, "
                 "max_course_time_ms: 0, intermediates: 0}\n"
                 "gates: {start: E1E1E1, finish: E2E2E2}\nkeypads: [AAAAAA]\n"
                 "displays: [D15D15]\ncompetitors: %s\ndatabase: %s/results.db\n"
                 "http: \"127.0.0.1:0\"\n", b->h.instance, csv, b->a.dir);
        if (harness_write_file(&b->a, "agility.yaml", text, path) < 0)
                return -1;
        snprintf(agility, sizeof(agility), "%s/sharedlink-agility", build);
        b->a.capture_log = 1;
        if (harness_start_program(&b->a, &b->h, argv, START_MS, &st) != 0) {
                fprintf(stderr, "bench_agility: sharedlink-agility did not start (%d); log %s\n",
                        st, b->a.log_path);
                return -1;
        }
        b->port = scoreboard_port(b);
        if (b->port <= 0)
                return -1;
        sa.sin_port = htons((uint16_t)b->port);
        b->sse = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (b->sse < 0 || connect(b->sse, (struct sockaddr *)&sa, sizeof(sa)) < 0 ||
            harness_write_all(b->sse, get, strlen(get), WAIT_MS) < 0)
                return -1;
        if (value_is(b, "agility.device.E1E1E1.online", "1") < 0 ||
            value_is(b, "agility.device.AAAAAA.online", "1") < 0 ||
            value_is(b, "agility.device.D15D15.online", "1") < 0)
                return -1;
        return 0;
}

/* Waits (untimed) for what the previous step must have reached before the next. */
static int settle(struct bench *b, int sse_state, const char *timer)
{
        uint64_t deadline = harness_now_ns() + WAIT_MS * NS_PER_MS;

        while (atomic_load(&b->sse_state) != sse_state) {
                if (harness_now_ns() > deadline) {
                        fprintf(stderr, "bench_agility: the stream never showed state %d\n",
                                sse_state);
                        return -1;
                }
                poll(NULL, 0, 1);
        }
        return value_is(b, DISPLAY_TIMER, timer);
}

/* One passage: 0 with the three latencies in ns, or -1. */
static int sample(struct bench *b, unsigned i, uint64_t ns[P_COUNT])
{
        char what[48];
        uint64_t t0, deadline;

        for (int p = 0; p < P_COUNT; p++)
                atomic_store(&b->got_ns[p], 0);
        snprintf(what, sizeof(what), "sensor-time=%u",
                 (SENSOR_BASE_MS + i * SENSOR_STEP_MS) % SENSOR_WRAP_MS);
        atomic_store(&b->armed, true);
        t0 = harness_now_ns();
        if (emulate(b, "E1E1E1", what) < 0)
                return -1;
        if (value_is(b, DISPLAY_TIMER, "1") < 0)
                return -1;
        stamp(b, P_DISPLAY);
        deadline = t0 + WAIT_MS * NS_PER_MS;
        while ((!atomic_load(&b->got_ns[P_FLOOR]) || !atomic_load(&b->got_ns[P_SSE])) &&
               harness_now_ns() < deadline)
                poll(NULL, 0, 1);       /* untimed: the stamps are taken by the readers */
        atomic_store(&b->armed, false);
        for (int p = 0; p < P_COUNT; p++) {
                uint64_t got = atomic_load(&b->got_ns[p]);

                if (!got) {
                        fprintf(stderr, "bench_agility: no %s for passage %u\n", probe_name[p],
                                i);
                        return -1;
                }
                ns[p] = got - t0;
        }
        /* Back to ReadyToStart for the next one. */
        if (press(b, KEY_RESET) < 0)
                return -1;
        return settle(b, SSE_READY, "0");
}

static int run(struct bench *b)
{
        double med[P_COUNT], p99[P_COUNT];
        size_t n = 0;

        if (press(b, KEY_READY) < 0 || settle(b, SSE_READY, "0") < 0) {
                fprintf(stderr, "bench_agility: no ReadyToStart; log %s\n", b->a.log_path);
                return -1;
        }
        for (unsigned i = 0; i < SAMPLES + WARMUP; i++) {
                uint64_t ns[P_COUNT];

                if (sample(b, i, ns) < 0)
                        return -1;
                if (i < WARMUP)
                        continue;
                for (int p = 0; p < P_COUNT; p++)
                        b->lat[p][n] = ns[p];
                n++;
        }
        printf("a start-gate passage emulated at the mediator (a control request) -> (us), "
               "%zu passages:\n", n);
        printf("  %-8s %9s %9s\n", "probe", "median", "p99");
        for (int p = 0; p < P_COUNT; p++) {
                qsort(b->lat[p], n, sizeof(uint64_t), cmp_u64);
                med[p] = (double)b->lat[p][n / 2] / NS_PER_US;
                p99[p] = (double)b->lat[p][n * 99 / 100] / NS_PER_US;
                printf("  %-8s %9.1f %9.1f\n", probe_name[p], med[p], p99[p]);
        }
        printf("  sse/floor median %.2fx, display/floor median %.2fx\n", med[P_SSE] / med[P_FLOOR],
               med[P_DISPLAY] / med[P_FLOOR]);
        for (int p = 0; p < P_COUNT; p++) {
                printf("FIGURE|agility_%s_p50|passage -> %s, median|%.1f|us|-\n",
                       probe_name[p], probe_what[p], med[p]);
                printf("FIGURE|agility_%s_p99|passage -> %s, p99|%.1f|us|-\n",
                       probe_name[p], probe_what[p], p99[p]);
        }
        return 0;
}

int main(void)
{
        struct bench *b = &B;
        const char *build = getenv("SHAREDLINK_BUILD");
        pthread_t sse, events, notify;
        char load[128] = "";
        FILE *f;
        int r;

        b->ctl = b->sse = -1;
        if (!build)
                build = "build/asan";
        if (start(b, build) < 0) {
                harness_cleanup(&b->a);
                harness_cleanup(&b->h);
                return 1;
        }
        if (pthread_create(&sse, NULL, sse_main, b) != 0 ||
            pthread_create(&events, NULL, events_main, b) != 0 ||
            pthread_create(&notify, NULL, notify_main, b) != 0)
                return 1;
        f = fopen("/proc/loadavg", "r");
        if (f && fgets(load, sizeof(load), f))
                load[strcspn(load, "\n")] = '\0';
        if (f)
                fclose(f);
        printf("sharedlink-agility bench (load average at start: %s)\n", load);
        r = run(b);
        atomic_store(&b->stop, true);
        harness_stop_daemon(&b->a, SIGTERM, START_MS);  /* ends the stream: sse_main returns */
        shutdown(b->sse, SHUT_RDWR);
        pthread_join(sse, NULL);
        pthread_join(events, NULL);
        pthread_join(notify, NULL);
        harness_close_fd(&b->sse);
        harness_close_fd(&b->ctl);
        sl_close(b->ev);
        sl_close(b->cl);
        harness_cleanup(&b->a);
        harness_cleanup(&b->h);
        return r < 0 ? 1 : 0;
}
