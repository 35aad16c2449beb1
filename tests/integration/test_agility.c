/*
 * sharedlink-agility end to end: the real sharedlinkd (build/asan) with a CIRCE controller link
 * facing its own mediator emulator (tests/data/agility_links.yaml: start gate E1E1E1, finish
 * gate E2E2E2, remote AAAAAA, display D15D15), the real sharedlink-agility on that link, runs
 * played by the emulator's `circe arena emulate action` commands, and the outcome read where a
 * user would find it: the SQLite database (through sqlite3's C API), the emulated display's
 * variables (what the Visualize packets made it show), sd_notify STATUS=.
 *
 *  - -n: "configuration OK", or "FILE:LINE:COL: message" and exit 1;
 *  - the specification's run: Ready on the remote, start at sensor time 5000, finish at 32000:
 *    27.000 s at high precision, stored, placement 1, on the display;
 *  - SIGKILL after a completed run and in the middle of the next one: nothing completed is lost,
 *    and the restarted daemon resumes the class with the next competitor;
 *  - a database another process keeps locked: the run stays in memory and on the display, the
 *    error is loud (STATUS=, the log), and it is stored once the lock goes;
 *  - the loop never waits for sharedlinkd (docs/agility.md §9), with a controller link whose
 *    mediator side the test plays on a pty (so its devices can be made never to answer a clock
 *    sync): while a sync takes its whole window, a number typed on the remote reaches the
 *    scoreboard (/events shows it with the state still WaitingForSync), and the sync's results
 *    still come after it; SIGTERM while a stopped (SIGSTOP) sharedlinkd holds the sync request
 *    ends sharedlink-agility cleanly with the daemon still stopped and no result of the sync;
 *    a sync a SIGHUP overtook, answered late, is not the new class's. Asserted on the order of
 *    what happened, not on durations;
 *  - the scoreboard page in a real headless Chromium (Debian chromium, `make deps`; skipped when
 *    it is not installed): after two competitors' runs its DOM has the final time and both
 *    placements. SHAREDLINK_SCREENSHOT=FILE also saves a screenshot of that page there (how
 *    docs/agility-scoreboard.png is made).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <sqlite3.h>
#include <sharedlink.h>

#include "common/circe_sessions.h"
#include "common/harness.h"
#include "common/slwait.h"
#include "common/testdata.h"

#define T_START_MS      15000   /* READY=1 (ASan build) */
#define T_WAIT_MS       15000   /* one state, value or log line (a clock sync takes up to 3 s) */
#define T_REPLY_MS      10000
#define T_STOP_MS       10000
#define CONFIG_MAX      4096
#define REPLY_MAX       1024
#define PATH_BUF        512
#define OUT_MAX         4096
#define HTTP_MAX        65536   /* one response */
#define LOG_MAX         (1 << 20)
#define NS_PER_MS       1000000ull
#define DOM_MAX         (256 * 1024)
#define T_BROWSER_MS    60000   /* one Chromium run, start to exit, on a busy machine */
#define CHROMIUM        "/usr/bin/chromium"

#define T_HANG_MS       60000   /* a hang guard only, where the order of events is asserted */
#define PKT_MAX         512

#define KEY_READY       "32768"
#define SPEC_START_MS   5000    /* the specification's example session */
#define SPEC_FINISH_MS  32000
#define SPEC_RUN_MS     (SPEC_FINISH_MS - SPEC_START_MS)

struct fx {
        struct harness h;               /* sharedlinkd */
        struct harness a;               /* sharedlink-agility: its notify socket, log, pid */
        struct sl_client *cl;
        int ctl;
        char conf[HARNESS_PATH_MAX];
        char db[PATH_BUF];
        sqlite3 *lock;                  /* the test's own connection holding the write lock */
        int port;                       /* the scoreboard's, from the log */
        int sse;                        /* an open /events stream, -1 when none */
        const char *class_name;         /* what write_conf writes */
        const char *gates;
        const char *times;              /* the class's course times */
        int master, slave;              /* a pty whose mediator side the test plays, or -1 */
        bool daemon_stopped;            /* sharedlinkd got SIGSTOP: teardown continues it */
};

static const char *agility_path(void)
{
        static char path[HARNESS_PATH_MAX];
        const char *b = getenv("SHAREDLINK_BUILD");

        snprintf(path, sizeof(path), "%s/sharedlink-agility", b ? b : "build/asan");
        return path;
}

static int setup(void **state)
{
        struct fx *f = calloc(1, sizeof(*f));

        if (!f || harness_init(&f->h, "agility") < 0 || harness_init(&f->a, "agilityd") < 0)
                return -1;
        f->ctl = -1;
        f->sse = -1;
        f->master = f->slave = -1;
        f->class_name = "Jumping A";
        f->gates = "{start: E1E1E1, finish: E2E2E2}";
        f->times = "standard_course_time_ms: 40000, max_course_time_ms: 80000";
        snprintf(f->db, sizeof(f->db), "%s/results.db", f->a.dir);
        *state = f;
        return 0;
}

static int teardown(void **state)
{
        struct fx *f = *state;

        if (f->daemon_stopped && f->h.pid > 0)
                kill(f->h.pid, SIGCONT);
        sl_close(f->cl);
        sqlite3_close(f->lock);
        harness_close_fd(&f->ctl);
        harness_close_fd(&f->sse);
        harness_cleanup(&f->a);
        harness_cleanup(&f->h);
        harness_close_fd(&f->master);
        harness_close_fd(&f->slave);
        free(f);
        return 0;
}

/* ---- the pieces ------------------------------------------------------------------------------ */

static const char competitors_csv[] =
        "CompetitorNumber;HandlerName;DogName;CountryCode\n"
        "1;Anna Smith;Rex;NL\n"
        "2;Bert Jones;Fly;BE\n"
        "3;Cora Diaz;Zip;ES\n";

/* The class file; extra: more top-level keys. */
static void write_conf(struct fx *f, const char *extra)
{
        char text[CONFIG_MAX], csv[HARNESS_PATH_MAX];

        assert_int_equal(harness_write_file(&f->a, "dogs.csv", competitors_csv, csv), 0);
        snprintf(text, sizeof(text),
                 "instance: %s\n"
                 "link: agility\n"
                 "class: {name: \"%s\", %s, intermediates: 0}\n"
                 "gates: %s\n"
                 "keypads: [AAAAAA]\n"
                 "displays: [D15D15]\n"
                 "competitors: %s\n"
                 "database: %s\n"
                 "http: \"127.0.0.1:0\"\n%s",
                 f->h.instance, f->class_name, f->times, f->gates, csv, f->db, extra ? extra : "");
        assert_int_equal(harness_write_file(&f->a, "agility.yaml", text, f->conf), 0);
}

/* sharedlinkd on links (a "links:" document), the test's handle and control connection. */
static void start_sharedlinkd_on(struct fx *f, const char *links)
{
        char why[HARNESS_WHY_MAX], sock[PATH_BUF];
        int r;

        f->h.capture_log = 1;
        r = harness_start_config(&f->h, "circe.yaml", links, T_START_MS, why, sizeof(why));
        if (r == -ENOTSUP)
                skip();
        if (r < 0)
                fail_msg("sharedlinkd did not start: %s", why);
        assert_int_equal(sl_open(f->h.instance, &f->cl), 0);
        snprintf(sock, sizeof(sock), "%s/%s.sock", f->h.dir, f->h.instance);
        f->ctl = harness_connect_unix(sock);
        assert_true(f->ctl >= 0);
}

/* sharedlinkd with the emulated course (tests/data/agility_links.yaml). */
static void start_sharedlinkd(struct fx *f)
{
        char links[CONFIG_MAX];
        const char *const subst[] = { "@DIR@", f->h.dir, NULL };

        assert_true(testdata_load("agility_links.yaml", subst, links, sizeof(links)) > 0);
        start_sharedlinkd_on(f, links);
}

/* The port of the last "scoreboard at http://127.0.0.1:PORT/" in the log (the class file asks
 * for any free port). */
static int scoreboard_port(struct fx *f)
{
        static const char needle[] = "scoreboard at http://127.0.0.1:";
        char *log = malloc(LOG_MAX + 1), *p, *last = NULL;
        int fd = open(f->a.log_path, O_RDONLY | O_CLOEXEC), port = -1;
        ssize_t n;

        assert_non_null(log);
        assert_true(fd >= 0);
        n = read(fd, log, LOG_MAX);
        close(fd);
        assert_true(n > 0);
        log[n] = '\0';
        for (p = strstr(log, needle); p; p = strstr(p + 1, needle))
                last = p;
        if (last)
                port = atoi(last + strlen(needle));
        free(log);
        if (port <= 0)
                fail_msg("no scoreboard address in %s", f->a.log_path);
        return port;
}

static void start_agility(struct fx *f)
{
        const char *argv[] = { agility_path(), "-c", f->conf, "-v", NULL };
        int st = 0, r;

        f->a.capture_log = 1;
        r = harness_start_program(&f->a, &f->h, argv, T_START_MS, &st);
        if (r < 0)
                fail_msg("sharedlink-agility did not start (%d, status %d); log %s", r, st,
                         f->a.log_path);
        f->port = scoreboard_port(f);
}

static const char *request(struct fx *f, const char *line)
{
        static char reply[REPLY_MAX];

        if (harness_control_request(f->ctl, line, reply, sizeof(reply), T_REPLY_MS) < 0)
                fail_msg("no reply to \"%s\"", line);
        return reply;
}

static void emulate(struct fx *f, const char *addr, const char *what)
{
        char line[REPLY_MAX];

        snprintf(line, sizeof(line), "circe arena emulate action %s %s", addr, what);
        assert_string_equal(request(f, line), "OK\n");
}

/* A key pressed and released on the remote. */
static void press(struct fx *f, const char *keys)
{
        char k[32];

        snprintf(k, sizeof(k), "keys=%s", keys);
        emulate(f, "AAAAAA", k);
        emulate(f, "AAAAAA", "keys=0");
}

static void passage(struct fx *f, const char *gate, unsigned sensor_ms)
{
        char st[32];

        snprintf(st, sizeof(st), "sensor-time=%u", sensor_ms);
        emulate(f, gate, st);
}

/* Waits for sharedlink-agility's STATUS= to say "STATE, competitor N". */
static void wait_state(struct fx *f, const char *state, unsigned competitor)
{
        char needle[128];

        snprintf(needle, sizeof(needle), "STATUS=class %s: %s, competitor %u", f->class_name,
                 state, competitor);
        if (harness_wait_notify(&f->a, needle, T_WAIT_MS) < 0)
                fail_msg("sharedlink-agility never reported \"%s\"; last \"%s\"; log %s", needle,
                         f->a.last_notify, f->a.log_path);
}

/* Right after a start: READY=1 came with the first STATUS= in one message. */
static void wait_started(struct fx *f, const char *state, unsigned competitor)
{
        char needle[128];

        snprintf(needle, sizeof(needle), "STATUS=class %s: %s, competitor %u", f->class_name,
                 state, competitor);
        if (!strstr(f->a.last_notify, needle))
                wait_state(f, state, competitor);
}

static void wait_value(struct fx *f, const char *name, const char *want)
{
        char last[SL_VALUE_SIZE];

        if (slwait_value(f->cl, name, want, T_WAIT_MS, last, sizeof(last)) < 0)
                fail_msg("%s never became \"%s\" (last \"%s\")", name, want, last);
}

/* The course is up: the gates, the remote and (with display) the display are online at the
 * controller. */
static void wait_course(struct fx *f, bool display)
{
        wait_value(f, "agility.state", "connected");
        wait_value(f, "agility.device.E1E1E1.online", "1");
        wait_value(f, "agility.device.E2E2E2.online", "1");
        wait_value(f, "agility.device.AAAAAA.online", "1");
        if (display)
                wait_value(f, "agility.device.D15D15.online", "1");
}

/* sharedlinkd, then sharedlink-agility on the class file, in SetupCompleted with competitor 1
 * and every device of the course online. */
static void bring_up(struct fx *f)
{
        start_sharedlinkd(f);
        write_conf(f, NULL);
        start_agility(f);
        wait_started(f, "SetupCompleted", 1);
        wait_course(f, true);
}

static void wait_until_ms(uint64_t at_ns)
{
        for (uint64_t now = harness_now_ns(); now < at_ns; now = harness_now_ns())
                poll(NULL, 0, (int)((at_ns - now + NS_PER_MS - 1) / NS_PER_MS));
}

/* ---- HTTP, with a plain client ----------------------------------------------------------------- */

static int http_connect(struct fx *f)
{
        struct sockaddr_in sa = { .sin_family = AF_INET, .sin_port = htons((uint16_t)f->port),
                                  .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
        int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);

        assert_true(fd >= 0);
        assert_int_equal(connect(fd, (struct sockaddr *)&sa, sizeof(sa)), 0);
        return fd;
}

/* Reads what fd sends into buf[*len..] until needle is in it (NULL: until EOF), or the time
 * is up. */
static bool read_until(int fd, char *buf, size_t size, size_t *len, const char *needle)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)T_WAIT_MS * NS_PER_MS;

        for (;;) {
                struct pollfd p = { .fd = fd, .events = POLLIN };
                uint64_t now = harness_now_ns();
                ssize_t n;

                if (needle && strstr(buf, needle))
                        return true;
                if (now >= deadline || *len + 1 >= size)
                        return false;
                if (poll(&p, 1, (int)((deadline - now) / NS_PER_MS) + 1) <= 0)
                        continue;
                n = read(fd, buf + *len, size - 1 - *len);
                if (n <= 0)
                        return needle == NULL;
                *len += (size_t)n;
                buf[*len] = '\0';
        }
}

/* METHOD path: the status line, headers and body (the server closes after an HTTP/1.0 reply). */
static const char *http_get(struct fx *f, const char *method, const char *path)
{
        static char buf[HTTP_MAX];
        char req[256];
        size_t len = 0;
        int fd = http_connect(f);

        buf[0] = '\0';
        snprintf(req, sizeof(req), "%s %s HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n", method, path);
        assert_int_equal(harness_write_all(fd, req, strlen(req), T_WAIT_MS), 0);
        assert_true(read_until(fd, buf, sizeof(buf), &len, NULL));
        close(fd);
        return buf;
}

static void assert_has(const char *text, const char *needle)
{
        if (!strstr(text, needle))
                fail_msg("\"%s\" not in:\n%s", needle, text);
}

/* Opens /events; the first update comes at once. */
static void sse_open(struct fx *f)
{
        static const char req[] = "GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";

        f->sse = http_connect(f);
        assert_int_equal(harness_write_all(f->sse, req, strlen(req), T_WAIT_MS), 0);
}

/* Reads the stream until an update contains needle; what was read (valid until the next
 * call). */
static const char *sse_wait(struct fx *f, const char *needle)
{
        static char buf[HTTP_MAX * 4];
        size_t len = 0;

        buf[0] = '\0';
        if (!read_until(f->sse, buf, sizeof(buf), &len, needle))
                fail_msg("no update with %s on /events; got:\n%.2000s", needle, buf);
        return buf;
}

/* The first update (its "data:" line) in what sse_wait read that contains needle. */
static void sse_update_with(const char *read, const char *needle, char *line, size_t size)
{
        const char *hit = strstr(read, needle), *start, *end;

        assert_non_null(hit);
        for (start = hit; start > read && start[-1] != '\n'; start--)
                ;
        end = strchr(hit, '\n');
        if (!end)
                end = hit + strlen(hit);
        assert_true((size_t)(end - start) < size);
        memcpy(line, start, (size_t)(end - start));
        line[end - start] = '\0';
}

/* ---- the database, read as a user would -------------------------------------------------------- */

struct row {
        bool found;
        int finished, eliminated, faults, refusals, placement;
        long long finish_ms, penalty_ms;
        char precision[8];
};

static struct row db_row(struct fx *f, int competitor)
{
        struct row r = { 0 };
        sqlite3 *db;
        sqlite3_stmt *st;

        assert_int_equal(sqlite3_open_v2(f->db, &db, SQLITE_OPEN_READONLY, NULL), SQLITE_OK);
        assert_int_equal(sqlite3_prepare_v2(db, "SELECT finished, eliminated, faults, refusals, "
                                            "IFNULL(placement, 0), IFNULL(finish_ms, -1), "
                                            "IFNULL(finish_precision, ''), penalty_ms FROM runs "
                                            "WHERE class = 'Jumping A' AND competitor = ?1",
                                            -1, &st, NULL), SQLITE_OK);
        sqlite3_bind_int(st, 1, competitor);
        if (sqlite3_step(st) == SQLITE_ROW) {
                r.found = true;
                r.finished = sqlite3_column_int(st, 0);
                r.eliminated = sqlite3_column_int(st, 1);
                r.faults = sqlite3_column_int(st, 2);
                r.refusals = sqlite3_column_int(st, 3);
                r.placement = sqlite3_column_int(st, 4);
                r.finish_ms = sqlite3_column_int64(st, 5);
                snprintf(r.precision, sizeof(r.precision), "%s", sqlite3_column_text(st, 6));
                r.penalty_ms = sqlite3_column_int64(st, 7);
        }
        sqlite3_finalize(st);
        sqlite3_close(db);
        return r;
}

static int db_count(struct fx *f)
{
        sqlite3 *db;
        sqlite3_stmt *st;
        int n = -1;

        assert_int_equal(sqlite3_open_v2(f->db, &db, SQLITE_OPEN_READONLY, NULL), SQLITE_OK);
        assert_int_equal(sqlite3_prepare_v2(db, "SELECT COUNT(*) FROM runs", -1, &st, NULL),
                         SQLITE_OK);
        if (sqlite3_step(st) == SQLITE_ROW)
                n = sqlite3_column_int(st, 0);
        sqlite3_finalize(st);
        sqlite3_close(db);
        return n;
}

/* ---- tests ----------------------------------------------------------------------------------- */

static void test_check(void **state)
{
        struct fx *f = *state;
        char out[OUT_MAX], err[OUT_MAX], csv[HARNESS_PATH_MAX], bad[PATH_BUF];
        const char *argv[] = { agility_path(), "-n", "-c", f->conf, NULL };

        write_conf(f, NULL);
        assert_int_equal(harness_run_capture(&f->h, out, sizeof(out), err, sizeof(err),
                                             T_REPLY_MS, argv), 0);
        assert_string_equal(out, "configuration OK\n");

        /* The class file: FILE:LINE:COL. */
        write_conf(f, "keypads: [AAAAAA]\n");
        assert_int_equal(harness_run_capture(&f->h, out, sizeof(out), err, sizeof(err),
                                             T_REPLY_MS, argv), 1);
        snprintf(bad, sizeof(bad), "%s:10:1: duplicate key \"keypads\"", f->conf);
        if (!strstr(err, bad))
                fail_msg("got \"%s\", expected \"%s\"", err, bad);

        /* The competitor list: FILE:LINE. */
        write_conf(f, NULL);
        assert_int_equal(harness_write_file(&f->a, "dogs.csv",
                                            "CompetitorNumber,HandlerName,DogName,CountryCode\n"
                                            "1,A,B,NL\n1,C,D,BE\n", csv), 0);
        assert_int_equal(harness_run_capture(&f->h, out, sizeof(out), err, sizeof(err),
                                             T_REPLY_MS, argv), 1);
        snprintf(bad, sizeof(bad), "%s:3: competitor number 1 is already on line 2", csv);
        if (!strstr(err, bad))
                fail_msg("got \"%s\", expected \"%s\"", err, bad);
}

/* Ready, start at sensor time 5000, finish at 32000: 27.000 s, high precision. The sensor
 * difference is checked against the received times (within 4 s, docs/agility.md §4), so the
 * finish is sent 27 s after the start, as a dog would run it. */
static void test_spec_run(void **state)
{
        struct fx *f = *state;
        struct row r;
        uint64_t started;
        const char *body;

        bring_up(f);
        sse_open(f);
        sse_wait(f, "\"state\":\"SetupCompleted\"");
        wait_value(f, "arena.device.D15D15.current_competitor", "1");
        wait_value(f, "arena.device.D15D15.next_competitor", "2");

        press(f, KEY_READY);
        wait_state(f, "ReadyToStart", 1);
        started = harness_now_ns();
        passage(f, "E1E1E1", SPEC_START_MS);
        wait_state(f, "StartPassed", 1);
        wait_value(f, "arena.device.D15D15.timer_running", "1");
        sse_wait(f, "\"state\":\"StartPassed\"");
        body = http_get(f, "GET", "/api/state");
        assert_has(body, "HTTP/1.1 200 OK");
        assert_has(body, "\"elapsed_ms\":null");
        assert_has(body, "\"current\":1,\"next\":2");
        assert_has(body, "\"handler\":\"Anna Smith\"");
        wait_until_ms(started + (uint64_t)SPEC_RUN_MS * NS_PER_MS);
        passage(f, "E2E2E2", SPEC_FINISH_MS);
        wait_state(f, "FinishPassed", 1);
        wait_value(f, "arena.device.D15D15.primary_time", "27000");
        assert_int_equal(db_count(f), 0);       /* stored when the run completes: Ready */

        press(f, KEY_READY);
        wait_state(f, "RunCompleted", 1);
        r = db_row(f, 1);
        assert_true(r.found);
        assert_int_equal(r.finished, 1);
        assert_int_equal(r.eliminated, 0);
        assert_int_equal(r.finish_ms, SPEC_RUN_MS);
        assert_string_equal(r.precision, "high");
        assert_int_equal(r.placement, 1);
        assert_int_equal(r.penalty_ms, 0);
        assert_int_equal(harness_log_contains(&f->a, "competitor 1: run stored: 27.000, faults 0, "
                                              "refusals 0, placement 1"), 1);
        wait_value(f, "arena.device.D15D15.placement", "1");
        sse_wait(f, "\"state\":\"RunCompleted\"");

        /* The scoreboard: state, results, CSV, the page; read-only. */
        body = http_get(f, "GET", "/api/state");
        assert_has(body, "\"state\":\"RunCompleted\"");
        assert_has(body, "\"faults\":0,\"refusals\":0,\"eliminated\":false");
        assert_has(body, "\"elapsed_ms\":27000,\"precision\":\"high\"");
        body = http_get(f, "GET", "/api/results");
        assert_has(body, "Content-Type: application/json");
        assert_has(body, "[{\"competitor\":1,\"handler\":\"Anna Smith\",\"dog\":\"Rex\","
                   "\"country\":\"NL\",\"intermediate_ms\":[],\"finish_ms\":27000,"
                   "\"precision\":\"high\",\"faults\":0,\"refusals\":0,"
                   "\"eliminated\":false,\"penalty\":0,\"placement\":1}]");
        body = http_get(f, "GET", "/api/results.csv");
        assert_has(body, "CompetitorNumber,HandlerName,DogName,CountryCode,IntermediateTime1,");
        assert_has(body, "\r\n1,Anna Smith,Rex,NL,,,,27.000,0,0,False,1\r\n");
        assert_has(body, "\r\n2,Bert Jones,Fly,BE,,,,,,,,\r\n");
        body = http_get(f, "GET", "/");
        assert_has(body, "new EventSource('/events')");
        assert_true(strstr(body, "http://") == NULL && strstr(body, "https://") == NULL);
        assert_has(http_get(f, "POST", "/api/state"), "HTTP/1.1 405");
        assert_has(http_get(f, "GET", "/nosuch"), "HTTP/1.1 404");

        /* The next Ready moves on to the next competitor; the previous placement stays. */
        press(f, KEY_READY);
        wait_state(f, "ReadyToStart", 2);
        wait_value(f, "arena.device.D15D15.current_competitor", "2");
        assert_true(slwait_value_is(f->cl, "arena.device.D15D15.placement", "1"));
        assert_int_equal(harness_stop_daemon(&f->a, SIGTERM, T_STOP_MS), 0);
}

/* One quick run of competitor n with faults: start, finish 1.5 s later by the sensors. From
 * SetupCompleted or RunCompleted (the previous competitor's) to FinishPassed. */
static void quick_run(struct fx *f, unsigned n, unsigned start_ms)
{
        press(f, KEY_READY);
        wait_state(f, "ReadyToStart", n);
        passage(f, "E1E1E1", start_ms);
        wait_state(f, "StartPassed", n);
        press(f, "256");        /* faults + 5 */
        passage(f, "E2E2E2", start_ms + 1500);
        wait_state(f, "FinishPassed", n);
}

static void test_sigkill(void **state)
{
        struct fx *f = *state;
        struct row r;

        bring_up(f);

        /* Competitor 1 completes; the daemon is killed right after the Ready that stored it. */
        quick_run(f, 1, 100000);
        press(f, KEY_READY);
        wait_state(f, "RunCompleted", 1);
        assert_int_equal(harness_stop_daemon(&f->a, SIGKILL, T_STOP_MS), SIGKILL);
        r = db_row(f, 1);
        assert_true(r.found);
        assert_int_equal(r.finish_ms, 1500);
        assert_int_equal(r.faults, 5);
        assert_int_equal(r.penalty_ms, 5000);

        /* The restart resumes the class with competitor 2; killed in the middle of its run. */
        start_agility(f);
        wait_started(f, "SetupCompleted", 2);
        wait_value(f, "arena.device.D15D15.current_competitor", "2");
        wait_value(f, "arena.device.D15D15.placement", "1");
        press(f, KEY_READY);
        wait_state(f, "ReadyToStart", 2);
        passage(f, "E1E1E1", 200000);
        wait_state(f, "StartPassed", 2);
        assert_int_equal(harness_stop_daemon(&f->a, SIGKILL, T_STOP_MS), SIGKILL);
        assert_int_equal(db_count(f), 1);
        assert_true(db_row(f, 1).found);

        /* Again: competitor 2 runs from the start, and both runs are there, ranked. */
        start_agility(f);
        wait_started(f, "SetupCompleted", 2);
        quick_run(f, 2, 300000);
        press(f, KEY_READY);
        wait_state(f, "RunCompleted", 2);
        assert_int_equal(db_count(f), 2);
        assert_int_equal(db_row(f, 1).placement, 1);
        assert_int_equal(db_row(f, 2).placement, 1);    /* the same result: a shared place */
        assert_int_equal(harness_stop_daemon(&f->a, SIGTERM, T_STOP_MS), 0);
}

/* Another process holds the database's write lock while a run completes. */
static void test_database_locked(void **state)
{
        struct fx *f = *state;

        bring_up(f);
        quick_run(f, 1, 100000);

        assert_int_equal(sqlite3_open_v2(f->db, &f->lock, SQLITE_OPEN_READWRITE, NULL),
                         SQLITE_OK);
        assert_int_equal(sqlite3_exec(f->lock, "BEGIN EXCLUSIVE", NULL, NULL, NULL), SQLITE_OK);
        press(f, KEY_READY);
        if (harness_wait_notify(&f->a, "STATUS=class Jumping A: RunCompleted, competitor 1, "
                                "DATABASE NOT WRITABLE", T_WAIT_MS) < 0)
                fail_msg("no loud error; last \"%s\"", f->a.last_notify);
        assert_int_equal(harness_wait_log(&f->a, "competitor 1: the run is NOT stored",
                                          T_WAIT_MS), 0);
        /* The run goes on: the display shows its result, the class moves on. */
        wait_value(f, "arena.device.D15D15.placement", "1");
        press(f, KEY_READY);
        wait_state(f, "ReadyToStart", 2);

        assert_int_equal(sqlite3_exec(f->lock, "ROLLBACK", NULL, NULL, NULL), SQLITE_OK);
        f->lock = sqlite3_close(f->lock) == SQLITE_OK ? NULL : f->lock;
        assert_int_equal(harness_wait_log(&f->a, "every completed run stored", T_WAIT_MS), 0);
        assert_int_equal(db_row(f, 1).finish_ms, 1500);
        assert_int_equal(harness_stop_daemon(&f->a, SIGTERM, T_STOP_MS), 0);
}

/* A gate that reports 027:1 after the sync (here: it joined the network again, as a restarted
 * device does) has lost it: the run is timed from the received times, low precision. */
static void test_sync_lost(void **state)
{
        struct fx *f = *state;
        struct row r;

        bring_up(f);
        press(f, KEY_READY);
        wait_state(f, "ReadyToStart", 1);
        wait_value(f, "agility.device.E2E2E2.clock_sync", "2");
        assert_string_equal(request(f, "circe agility network-setup E2E2E2 join 2"), "OK\n");
        wait_value(f, "agility.device.E2E2E2.clock_sync", "1");
        passage(f, "E1E1E1", 100000);
        wait_state(f, "StartPassed", 1);
        passage(f, "E2E2E2", 101500);
        wait_state(f, "FinishPassed", 1);
        press(f, KEY_READY);
        wait_state(f, "RunCompleted", 1);
        r = db_row(f, 1);
        assert_true(r.found);
        assert_string_equal(r.precision, "low");
        assert_true(r.finish_ms != 1500);       /* not the sensor difference */
        assert_int_equal(harness_log_contains(&f->a, "gate E2E2E2 needs a clock sync"), 1);
        assert_int_equal(harness_stop_daemon(&f->a, SIGTERM, T_STOP_MS), 0);
}

/* The maximum course time passes with the dog still on the course: the engine's timer (armed at
 * agility_run_next_deadline) eliminates the run with nothing else happening. */
static void test_max_course_time(void **state)
{
        struct fx *f = *state;

        f->times = "standard_course_time_ms: 1000, max_course_time_ms: 1500";
        bring_up(f);
        sse_open(f);
        press(f, KEY_READY);
        wait_state(f, "ReadyToStart", 1);
        passage(f, "E1E1E1", 100000);
        wait_state(f, "StartPassed", 1);
        sse_wait(f, "\"eliminated\":true");
        assert_int_equal(harness_wait_log(&f->a, "max-course-time", T_WAIT_MS), 0);
        wait_value(f, "arena.device.D15D15.eliminated", "1");
        press(f, KEY_READY);            /* an eliminated run completes on Ready */
        wait_state(f, "RunCompleted", 1);
        assert_int_equal(db_row(f, 1).eliminated, 1);
        assert_int_equal(harness_stop_daemon(&f->a, SIGTERM, T_STOP_MS), 0);
}

/* A gate address that no device of the network has: the sync fails naming it, and the log says
 * that the address is not in the network. */
static void test_gate_not_in_network(void **state)
{
        struct fx *f = *state;

        f->gates = "{start: E1E1E1, finish: E3E3E3}";
        bring_up(f);
        press(f, KEY_READY);
        wait_state(f, "WaitingForSync", 1);
        wait_state(f, "SetupCompleted", 1);
        assert_int_equal(harness_wait_log(&f->a, "gate E3E3E3 is not in the network of link "
                                          "agility", T_WAIT_MS), 0);
        assert_int_equal(harness_log_contains(&f->a, "sync-failed (device E3E3E3"), 1);
        assert_int_equal(harness_log_contains(&f->a, "gate E1E1E1 is not in the network"), 0);
        assert_int_equal(harness_stop_daemon(&f->a, SIGTERM, T_STOP_MS), 0);
}

/* SIGHUP loads the next class; a run in progress or a file that does not load keeps the one
 * that runs. */
static void test_reload(void **state)
{
        struct fx *f = *state;
        char conf[HARNESS_PATH_MAX];

        bring_up(f);
        quick_run(f, 1, 100000);
        assert_int_equal(kill(f->a.pid, SIGHUP), 0);
        assert_int_equal(harness_wait_log(&f->a, "SIGHUP: a run is in progress (FinishPassed)",
                                          T_WAIT_MS), 0);
        press(f, KEY_READY);
        wait_state(f, "RunCompleted", 1);

        f->class_name = "Agility B";
        write_conf(f, NULL);
        assert_int_equal(kill(f->a.pid, SIGHUP), 0);
        wait_state(f, "SetupCompleted", 1);
        assert_has(http_get(f, "GET", "/api/state"), "\"class\":\"Agility B\"");
        assert_has(http_get(f, "GET", "/api/results"), "[]");
        wait_value(f, "arena.device.D15D15.placement", "0");

        assert_int_equal(harness_write_file(&f->a, "agility.yaml", "link: [\n", conf), 0);
        assert_int_equal(kill(f->a.pid, SIGHUP), 0);
        assert_int_equal(harness_wait_log(&f->a, "not loaded: the class Agility B stays",
                                          T_WAIT_MS), 0);
        assert_int_equal(harness_log_contains(&f->a, "agility.yaml:2:1: "), 1);
        assert_has(http_get(f, "GET", "/api/state"), "\"class\":\"Agility B\"");

        /* Back to the first class: its stored run is there, the next competitor is called. */
        f->class_name = "Jumping A";
        write_conf(f, NULL);
        assert_int_equal(kill(f->a.pid, SIGHUP), 0);
        wait_state(f, "SetupCompleted", 2);
        assert_has(http_get(f, "GET", "/api/results"), "[{\"competitor\":1,");
        assert_int_equal(harness_stop_daemon(&f->a, SIGTERM, T_STOP_MS), 0);
}

/* Chromium, headless, on the scoreboard: what it prints (the DOM, or nothing for a screenshot)
 * into out. Its profile is a fresh directory of the test's; nothing reaches beyond 127.0.0.1.
 * It dumps (or shoots) the page once loaded: what the page's script rendered from the update
 * served inside it. No --virtual-time-budget: the /events stream the page then opens never
 * ends, and virtual time does not move while a request is open. */
static void chromium(struct fx *f, const char *what, char *out, size_t size)
{
        char url[64], profile[PATH_BUF], err[OUT_MAX];
        const char *argv[] = { CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu",
                               "--disable-quic", "--no-first-run",
                               "--disable-background-networking", "--disable-component-update",
                               "--disable-sync", "--window-size=1280,800", profile, what,
                               url, NULL };
        int r;

        snprintf(url, sizeof(url), "http://127.0.0.1:%d/", f->port);
        snprintf(profile, sizeof(profile), "--user-data-dir=%s/chromium", f->a.dir);
        r = harness_run_capture(&f->a, out, size, err, sizeof(err), T_BROWSER_MS, argv);
        if (r != 0)
                fail_msg("chromium %s: status %d; stderr:\n%s", what, r, err);
}

/* The text of the first element after from with the attribute attr ("class=\"place\"") must be
 * want; dom is the whole page, for the message. */
static void dom_expect(const char *dom, const char *from, const char *attr, const char *want)
{
        const char *p = strstr(from, attr), *end = NULL;

        if (p && (p = strchr(p, '>')))
                end = strchr(++p, '<');
        if (!end)
                fail_msg("no element with %s in the page:\n%s", attr, dom);
        if ((size_t)(end - p) != strlen(want) || strncmp(p, want, strlen(want)) != 0)
                fail_msg("%s: \"%.*s\", expected \"%s\", in the page:\n%s", attr, (int)(end - p),
                         p, want, dom);
}

/* The run of competitor n: start at sensor time start_ms, finish run_ms later; faults and
 * refusals pressed on the remote during it. From SetupCompleted or RunCompleted to the
 * completed run. */
static void run_with(struct fx *f, unsigned n, unsigned start_ms, unsigned run_ms,
                     const char *const *keys)
{
        press(f, KEY_READY);
        wait_state(f, "ReadyToStart", n);
        passage(f, "E1E1E1", start_ms);
        wait_state(f, "StartPassed", n);
        for (; keys && *keys; keys++)
                press(f, *keys);
        passage(f, "E2E2E2", start_ms + run_ms);
        wait_state(f, "FinishPassed", n);
        press(f, KEY_READY);
        wait_state(f, "RunCompleted", n);
}

/* Two competitors' runs, then the page as a browser renders it: the last run's final time in
 * the clock, its faults and refusals, and both placements in the ranking. */
static void test_browser(void **state)
{
        static const char *const faulty[] = { "256", "32", NULL };  /* faults +5, refusals +1 */
        struct fx *f = *state;
        static char dom[DOM_MAX];
        char row[64], png[8] = "";
        const char *shot = getenv("SHAREDLINK_SCREENSHOT"), *p;

        if (access(CHROMIUM, X_OK) != 0) {
                print_message("chromium is not installed (make deps): the browser test skips\n");
                skip();
        }
        bring_up(f);
        run_with(f, 1, 100000, 1500, NULL);
        run_with(f, 2, 200000, 2250, faulty);
        /* The page reads what the API serves: both runs are there before Chromium starts. */
        assert_has(http_get(f, "GET", "/api/results"), "\"competitor\":2,");

        chromium(f, "--dump-dom", dom, sizeof(dom));
        dom_expect(dom, dom, "id=\"clock\"", "2.250");
        dom_expect(dom, dom, "id=\"faults\"", "5");
        dom_expect(dom, dom, "id=\"refusals\"", "5");   /* one refusal: 5 */
        dom_expect(dom, dom, "id=\"state\"", "RunCompleted");
        dom_expect(dom, dom, "id=\"next\"", "3 Cora Diaz / Zip");
        for (unsigned n = 1; n <= 2; n++) {
                snprintf(row, sizeof(row), "<tr data-competitor=\"%u\">", n);
                p = strstr(dom, row);
                if (!p)
                        fail_msg("no ranking row for competitor %u in:\n%s", n, dom);
                dom_expect(dom, p, "class=\"place\"", n == 1 ? "1" : "2");
                dom_expect(dom, p, "class=\"time\"", n == 1 ? "1.500" : "2.250");
        }

        if (shot) {
                char arg[PATH_BUF + 16];
                int fd;

                snprintf(arg, sizeof(arg), "--screenshot=%s", shot);
                chromium(f, arg, dom, sizeof(dom));
                fd = open(shot, O_RDONLY | O_CLOEXEC);
                assert_true(fd >= 0);
                assert_int_equal(read(fd, png, 4), 4);
                close(fd);
                assert_memory_equal(png, "\x89PNG", 4);
        }
        assert_int_equal(harness_stop_daemon(&f->a, SIGTERM, T_STOP_MS), 0);
}

/* A second sharedlink-agility on the same link of the instance refuses to start: exit 3, naming
 * the first by its pid; the first carries on (its successor after a SIGKILL: test_sigkill). */
static void test_second_refused(void **state)
{
        struct fx *f = *state;
        const char *argv[] = { agility_path(), "-c", f->conf, NULL };
        char want[PATH_BUF], why[HARNESS_WHY_MAX];

        bring_up(f);
        snprintf(want, sizeof(want), "another sharedlink-agility (pid %ld) already times link "
                 "agility of instance %s (lock %s/", (long)f->a.pid, f->h.instance, f->h.dir);
        if (harness_start_refused(&f->h, "agility2", argv, T_START_MS, 3, want, why,
                                  sizeof(why)) < 0)
                fail_msg("%s", why);
        assert_true(kill(f->a.pid, 0) == 0);
        assert_int_equal(harness_stop_daemon(&f->a, SIGTERM, T_STOP_MS), 0);
}

/* ---- the loop and a daemon that takes its time ---------------------------------------------- */

/* The remote AAAAAA enters the next competitor, 3: the modifier, digit 3 (key bit 4) down and up,
 * the modifier released (docs/agility.md §3). */
#define KEYS_ENTER_NEXT         "53\t015:AAAAAA\t024:1024\t"
#define KEYS_ENTER_NEXT_3       "53\t015:AAAAAA\t024:1028\t"
#define KEYS_RELEASED           "53\t015:AAAAAA\t024:0\t"
/* The finish gate, online, not asking for a sync; and its Sync Succeeded. */
#define STATUS_E2E2E2           "52\t015:E2E2E2\t016:0\t019:32\t020:4\t021:130\t"
#define SYNC_DONE_E2E2E2        "52\t015:E2E2E2\t016:0\t019:32\t020:4\t021:130\t027:2\t"

/* Sends one packet to the controller, as the mediator. */
static void put(struct fx *f, const char *body)
{
        char pkt[PKT_MAX];
        size_t n = harness_circe_packet(body, pkt);

        assert_int_equal(harness_write_all(f->master, pkt, n, T_WAIT_MS), 0);
}

/* Reads what the controller sends until the packet body comes (others are skipped). */
static void wait_packet(struct fx *f, const char *body)
{
        char want[PKT_MAX], got[PKT_MAX];
        size_t wn = harness_circe_packet(body, want);

        for (;;) {
                ssize_t gn = harness_read_until(f->master, got, sizeof(got), 0x03, T_WAIT_MS);
                const char *stx;

                if (gn <= 0)
                        fail_msg("the controller never sent \"%s\" (%zd)", body, gn);
                stx = memchr(got, 0x02, (size_t)gn);
                if (stx && (size_t)(got + gn - stx) == wn && memcmp(stx, want, wn) == 0)
                        return;
        }
}

/* sharedlinkd with only the controller link, on a pty whose mediator side the test plays:
 * logged in, the remote and both gates online (the start gate asking for a sync, 027:1). */
static void start_mediated(struct fx *f)
{
        char links[CONFIG_MAX], slave_path[PATH_BUF], dev[PATH_BUF];

        assert_int_equal(harness_openpty(&f->master, &f->slave, slave_path), 0);
        snprintf(dev, sizeof(dev), "%s/arena.tty", f->h.dir);
        assert_int_equal(symlink(slave_path, dev), 0);
        /* Long timeouts: this mediator sends only what a step needs. */
        snprintf(links, sizeof(links),
                 "links:\n"
                 "  - name: agility\n"
                 "    protocol: circe\n"
                 "    role: controller\n"
                 "    transport: serial\n"
                 "    device: %s\n"
                 "    expect_version: \"1.2\"\n"
                 "    login_timeout_ms: 5000\n"
                 "    idle_timeout_ms: 60000\n", dev);
        start_sharedlinkd_on(f, links);
        wait_packet(f, CIRCE_S_LOGIN);
        put(f, CIRCE_S_KA);
        put(f, CIRCE_S_SYNC_STATUS_AAAAAA);
        put(f, CIRCE_S_SYNC_STATUS_E1E1E1);
        put(f, STATUS_E2E2E2);
        wait_course(f, false);
}

/* sharedlinkd, sharedlink-agility, Ready on the remote: the sync request has reached the daemon
 * once the controller sends Synchronize Clocks; the test's devices never answer it. */
static void sync_outstanding(struct fx *f)
{
        start_mediated(f);
        write_conf(f, NULL);
        start_agility(f);
        wait_started(f, "SetupCompleted", 1);
        sse_open(f);
        /* A device is offline 3 s after its last status: the course is fresh at the sync. */
        put(f, CIRCE_S_SYNC_STATUS_AAAAAA);
        put(f, CIRCE_S_SYNC_STATUS_E1E1E1);
        put(f, STATUS_E2E2E2);
        put(f, CIRCE_S_RACE_READY_DOWN);
        put(f, CIRCE_S_RACE_READY_UP);
        wait_packet(f, CIRCE_S_SYNC_CLOCKS);
}

/* While the sync is outstanding (its devices never answer, so it takes the whole window), the
 * loop goes on: a number typed on the remote is on the scoreboard while the state is still
 * WaitingForSync, and a start passage is refused as the engine refuses it there (a notice, no
 * run). Then the sync's results arrive: every gate timed out, back to SetupCompleted,
 * the typed next competitor kept. Before the request worker the loop waited inside the sync
 * and read the keys and the passage only after its end, so both came in SetupCompleted. */
static void test_loop_serves_during_sync(void **state)
{
        static char line[HTTP_MAX];
        struct fx *f = *state;
        const char *read;

        sync_outstanding(f);
        put(f, KEYS_ENTER_NEXT);
        put(f, KEYS_ENTER_NEXT_3);
        put(f, KEYS_ENTER_NEXT);
        put(f, KEYS_RELEASED);
        put(f, CIRCE_S_RACE_START);     /* the dog goes early: no start while syncing */
        read = sse_wait(f, "\"next\":3,");
        sse_update_with(read, "\"next\":3,", line, sizeof(line));
        if (!strstr(line, "\"state\":\"WaitingForSync\""))
                fail_msg("the typed number reached the scoreboard only with the sync's "
                         "result:\n%s", line);
        assert_int_equal(harness_wait_log(&f->a, "out-of-order (device E1E1E1, competitor 0, "
                                          "state WaitingForSync)", T_WAIT_MS), 0);

        /* The sync's results, each gate and then the end. */
        wait_state(f, "SetupCompleted", 1);
        assert_has(http_get(f, "GET", "/api/state"), "\"next\":3,");
        assert_int_equal(harness_log_contains(&f->a, "clock sync: E1E1E1 timed out"), 1);
        assert_int_equal(harness_log_contains(&f->a, "clock sync: E2E2E2 timed out"), 1);
        assert_int_equal(harness_log_contains(&f->a, "sync-failed (device E1E1E1"), 1);
        assert_int_equal(harness_stop_daemon(&f->a, SIGTERM, T_STOP_MS), 0);
}

/* SIGTERM while sharedlinkd, stopped with SIGSTOP, holds the sync request: sharedlink-agility
 * exits 0 while the daemon is still stopped, with no result of the sync, and says what it left.
 * Before the request worker it stayed inside the request until the library's timeout and saw
 * the signal only then: its log had the failed sync before the stop. */
static void test_sigterm_during_sync(void **state)
{
        struct fx *f = *state;
        int st;

        sync_outstanding(f);
        assert_int_equal(kill(f->h.pid, SIGSTOP), 0);
        f->daemon_stopped = true;
        st = harness_stop_daemon(&f->a, SIGTERM, T_HANG_MS);
        if (st != 0)
                fail_msg("sharedlink-agility did not stop cleanly (%d); log %s", st,
                         f->a.log_path);
        assert_int_equal(harness_log_contains(&f->a, "clock sync on link"), 0);
        assert_int_equal(harness_log_contains(&f->a, "sync-failed"), 0);
        assert_int_equal(harness_log_contains(&f->a, "stopping with a clock sync on its way"),
                         1);
        assert_int_equal(harness_log_contains(&f->a, "stopped"), 1);
        assert_int_equal(kill(f->h.pid, SIGCONT), 0);
        f->daemon_stopped = false;
}

/* SIGHUP while a sync is outstanding, then Ready in the new class: its sync waits for the old one
 * (the daemon takes one at a time). The devices then answer the old one: its results (every gate
 * succeeded) are not the new class's, so the new class stays WaitingForSync until its own sync,
 * sent only once the old one's results were all on the loop, is answered. Fed to the new class,
 * the old results would have made it ReadyToStart before its own sync was even sent. */
static void test_reload_during_sync(void **state)
{
        struct fx *f = *state;

        sync_outstanding(f);
        assert_int_equal(kill(f->a.pid, SIGHUP), 0);
        assert_int_equal(harness_wait_log(&f->a, "SIGHUP: class Jumping A ends, class Jumping A "
                                          "loaded", T_WAIT_MS), 0);
        put(f, CIRCE_S_RACE_READY_DOWN);
        put(f, CIRCE_S_RACE_READY_UP);
        wait_state(f, "WaitingForSync", 1);
        put(f, CIRCE_S_SYNC_DONE_AAAAAA);       /* the old sync ends: every device succeeded */
        put(f, CIRCE_S_SYNC_DONE_E1E1E1);
        put(f, SYNC_DONE_E2E2E2);
        wait_packet(f, CIRCE_S_SYNC_CLOCKS);    /* the new class's */
        assert_has(http_get(f, "GET", "/api/state"), "\"state\":\"WaitingForSync\"");
        /* Its answers: a status without 027, then Sync Succeeded (PROTOCOLS.md §2.4). */
        put(f, CIRCE_S_SYNC_STATUS_AAAAAA);
        put(f, CIRCE_S_NET_STATUS_E1E1E1);
        put(f, STATUS_E2E2E2);
        put(f, CIRCE_S_SYNC_DONE_AAAAAA);
        put(f, CIRCE_S_SYNC_DONE_E1E1E1);
        put(f, SYNC_DONE_E2E2E2);
        wait_state(f, "ReadyToStart", 1);
        assert_int_equal(harness_log_contains(&f->a, "(an earlier sync: ignored)"), 1);
        assert_int_equal(harness_log_contains(&f->a, "sync-failed"), 0);
        assert_int_equal(harness_stop_daemon(&f->a, SIGTERM, T_STOP_MS), 0);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_check, setup, teardown),
                cmocka_unit_test_setup_teardown(test_spec_run, setup, teardown),
                cmocka_unit_test_setup_teardown(test_sigkill, setup, teardown),
                cmocka_unit_test_setup_teardown(test_second_refused, setup, teardown),
                cmocka_unit_test_setup_teardown(test_database_locked, setup, teardown),
                cmocka_unit_test_setup_teardown(test_reload, setup, teardown),
                cmocka_unit_test_setup_teardown(test_sync_lost, setup, teardown),
                cmocka_unit_test_setup_teardown(test_gate_not_in_network, setup, teardown),
                cmocka_unit_test_setup_teardown(test_max_course_time, setup, teardown),
                cmocka_unit_test_setup_teardown(test_loop_serves_during_sync, setup, teardown),
                cmocka_unit_test_setup_teardown(test_sigterm_during_sync, setup, teardown),
                cmocka_unit_test_setup_teardown(test_reload_during_sync, setup, teardown),
                cmocka_unit_test_setup_teardown(test_browser, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
