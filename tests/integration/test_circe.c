/*
 * CIRCE links end to end: the real sharedlinkd (build/asan) started by the harness, its control
 * socket, its shm tables read through the client library, and ptys.
 *
 *  - back to back: a controller link and a mediator-emulator link of one daemon joined by the
 *    emulator's pty (the `make demo` pair): devices appear, a gate passage injected on the
 *    emulator arrives as an action event on the controller, a visualize command changes the
 *    emulated display, a clock synchronisation succeeds for every device, commands are checked
 *    (and the same through `slctl circe` when slctl is built);
 *  - a controller facing the test, which plays the mediator on two pty pairs: the CIRCE spec's
 *    example sessions byte for byte (tests/common/circe_sessions.h, the vectors the unit test
 *    replays in process), operations sent through `slctl circe` and checked on the wire, the
 *    outcome read through `slctl get / events / stats --json`; idle timeout, version mismatch
 *    and bad input between valid packets.
 */
#define _GNU_SOURCE     /* pipe2 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include <sharedlink.h>

#include "common/circe_garbage.h"
#include "common/circe_sessions.h"
#include "common/harness.h"
#include "common/slwait.h"
#include "common/testdata.h"
#include "common/wire.h"
#include "proto/circe.h"

#define T_START_MS      15000   /* READY=1 (ASan build) */
#define T_WAIT_MS       10000   /* one awaited value or event */
#define T_REPLY_MS      10000   /* one control reply (sync-clocks takes up to 3 s) */
#define T_STOP_MS       10000
#define CONFIG_MAX      4096
#define REPLY_MAX       4096
#define PATH_BUF        512
#define PTYS            2       /* pty pairs of the test as the mediator: dev0, dev1 */
#define PKT_MAX         512     /* one packet the test sends or expects (spec sessions) */
#define SLCTL_ARGS_MAX  32
#define EVENTS_MAX      16384   /* an `slctl events` listing */
#define STATS_MAX       16384   /* an `slctl stats --json` document */

struct fx {
        struct harness h;
        struct sl_client *cl;
        int ctl;                        /* control connection */
        uint64_t ev_cursor;
        int master[PTYS], slave[PTYS];  /* the test's pty pairs (the test as the mediator) */
        char dev[PTYS][PATH_BUF];       /* symlinks to their slaves: the link's devices */
        pid_t bg_pid;                   /* a background slctl, 0 when none */
        int bg_fd;                      /* its stdout, -1 when none */
};

static int setup(void **state)
{
        struct fx *f = calloc(1, sizeof(*f));

        if (!f || harness_init(&f->h, "circe") < 0)
                return -1;
        f->ctl = -1;
        f->bg_fd = -1;
        for (int i = 0; i < PTYS; i++)
                f->master[i] = f->slave[i] = -1;
        *state = f;
        return 0;
}

static int teardown(void **state)
{
        struct fx *f = *state;

        if (f->bg_pid > 0) {
                /* A test that failed while its slctl still waited. */
                kill(f->bg_pid, SIGKILL);
                waitpid(f->bg_pid, NULL, 0);
        }
        if (f->bg_fd >= 0)
                close(f->bg_fd);
        sl_close(f->cl);
        if (f->ctl >= 0)
                close(f->ctl);
        for (int i = 0; i < PTYS; i++) {
                if (f->master[i] >= 0)
                        close(f->master[i]);
                if (f->slave[i] >= 0)
                        close(f->slave[i]);
        }
        harness_cleanup(&f->h);
        free(f);
        return 0;
}

/* Starts the daemon on links (a "links:" document) under the test's instance. */
static void start(struct fx *f, const char *links)
{
        char why[HARNESS_WHY_MAX], sock[PATH_BUF];
        int r;

        f->h.capture_log = 1;
        r = harness_start_config(&f->h, "circe.yaml", links, T_START_MS, why, sizeof(why));
        if (r == -ENOTSUP)
                skip();         /* a build whose link registry does not have the CIRCE engine */
        if (r < 0)
                fail_msg("sharedlinkd did not start: %s", why);
        assert_int_equal(sl_open(f->h.instance, &f->cl), 0);
        snprintf(sock, sizeof(sock), "%s/%s.sock", f->h.dir, f->h.instance);
        f->ctl = harness_connect_unix(sock);
        assert_true(f->ctl >= 0);
}

static const char *request(struct fx *f, const char *line)
{
        static char reply[REPLY_MAX];

        if (harness_control_request(f->ctl, line, reply, sizeof(reply), T_REPLY_MS) < 0)
                fail_msg("no reply to \"%s\"", line);
        return reply;
}

/* ---- waiting through the library ------------------------------------------------------------- */

static bool value_is(struct fx *f, const char *name, const char *want)
{
        return slwait_value_is(f->cl, name, want);
}

static void wait_value(struct fx *f, const char *name, const char *want)
{
        char last[SL_VALUE_SIZE];

        if (slwait_value(f->cl, name, want, T_WAIT_MS, last, sizeof(last)) < 0)
                fail_msg("%s never became \"%s\" (last \"%s\")", name, want, last);
}

/* Waits for an event of that type on that link whose text contains needle. */
static void wait_event(struct fx *f, const char *link, const char *type, const char *needle,
                       char *ret_text)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)T_WAIT_MS * 1000000u;
        uint32_t cursor = 0;
        struct sl_event ev[8];

        for (;;) {
                int n;

                for (int i = 0; i < 8; i++)
                        ev[i].size = sizeof(ev[i]);
                while ((n = sl_events_read(f->cl, &f->ev_cursor, ev, 8)) > 0)
                        for (int i = 0; i < n; i++)
                                if (strcmp(ev[i].link_name, link) == 0 &&
                                    strcmp(ev[i].type_name, type) == 0 &&
                                    strstr(ev[i].text, needle)) {
                                        if (ret_text)
                                                snprintf(ret_text, SL_EVENT_TEXT_SIZE, "%s",
                                                         ev[i].text);
                                        return;
                                }
                if (harness_now_ns() > deadline)
                        fail_msg("no %s %s event with \"%s\"", link, type, needle);
                sl_wait(f->cl, &cursor, 200);
        }
}

/* ---- back to back ---------------------------------------------------------------------------- */

/* The mediator emulator and a controller on its pty (tests/data/circe_pair.yaml). */
static void pair_links(struct fx *f, char *buf, size_t size)
{
        const char *const subst[] = { "@DIR@", f->h.dir, NULL };

        assert_true(testdata_load("circe_pair.yaml", subst, buf, size) > 0);
}

static void test_back_to_back(void **state)
{
        struct fx *f = *state;
        char links[CONFIG_MAX], text[SL_EVENT_TEXT_SIZE];
        const char *r;

        pair_links(f, links, sizeof(links));
        start(f, links);
        wait_value(f, "agility.state", "connected");
        wait_value(f, "agility.device.E1E1E1.online", "1");
        wait_value(f, "agility.device.D15D15.online", "1");
        wait_value(f, "agility.device.AAAAAA.capabilities", "31");
        assert_true(value_is(f, "agility.mediator.version", "0.2.3"));
        assert_true(value_is(f, "agility.device.E1E1E1.battery", "200"));
        wait_event(f, "agility", "device-online", "device=E1E1E1", NULL);

        /* A gate passage injected on the emulator is an action event on the controller. */
        assert_string_equal(request(f, "circe arena emulate action E1E1E1 sensor-time=5000"),
                            "OK\n");
        wait_event(f, "agility", "action", "device=E1E1E1", text);
        assert_string_equal(text, "device=E1E1E1 sensor_time=5000");
        wait_value(f, "agility.device.E1E1E1.sensor_time", "5000");

        /* A visualize command changes the emulated display. */
        assert_string_equal(request(f, "circe agility visualize D15D15 current=42 next=43 "
                                       "start-timer"), "OK\n");
        wait_value(f, "arena.device.D15D15.current_competitor", "42");
        assert_true(value_is(f, "arena.device.D15D15.next_competitor", "43"));
        assert_true(value_is(f, "arena.device.D15D15.timer_running", "1"));

        /* Network setup, then a clock synchronisation every device passes. */
        assert_string_equal(request(f, "circe agility network-setup E1E1E1 join 2"), "OK\n");
        wait_value(f, "arena.device.E1E1E1.membership", "1");
        wait_value(f, "agility.device.E1E1E1.roles", "2");
        r = request(f, "circe agility sync-clocks");
        assert_non_null(strstr(r, "DATA E1E1E1 succeeded\n"));
        assert_non_null(strstr(r, "DATA AAAAAA succeeded\n"));
        assert_non_null(strstr(r, "DATA D15D15 succeeded\n"));
        assert_non_null(strstr(r, "OK\n"));
        wait_event(f, "agility", "clock-sync", "device=E1E1E1 result=succeeded", NULL);

        /* Refusals, each with its reason, and nothing sent for them. */
        assert_string_equal(request(f, "circe agility alert E1E1E"),
                            "ERR 22 bad address \"E1E1E\": six uppercase hex digits expected\n");
        /* Upper case only, as the library and the configuration want it (PROTOCOLS.md 2.3). */
        assert_string_equal(request(f, "circe agility alert e1e1e1"),
                            "ERR 22 bad address \"e1e1e1\": six uppercase hex digits expected\n");
        assert_string_equal(request(f, "circe arena emulate action e1e1e1"),
                            "ERR 22 bad device \"e1e1e1\": six uppercase hex digits expected\n");
        assert_string_equal(request(f, "circe arena alert E1E1E1"),
                            "ERR 95 link arena is a mediator emulator: alert is for controller "
                            "links\n");
        assert_string_equal(request(f, "circe arena emulate action 999999"),
                            "ERR 2 link arena emulates no device 999999\n");
        r = request(f, "circe nosuch alert E1E1E1");
        assert_true(strncmp(r, "ERR 2 ", 6) == 0);

        /* wait=MS is the core's: checked before the link is looked at, taken off for the
         * engine; the link is ready, so it runs at once. */
        assert_string_equal(request(f, "circe agility alert E1E1E1 wait=60001"),
                            "ERR 22 bad wait \"60001\": a decimal number 0..60000 expected\n");
        assert_string_equal(request(f, "circe agility alert E1E1E1 wait=5000"), "OK\n");
        assert_string_equal(request(f, "query agility A X wait=5"),
                            "ERR 95 link agility speaks circe: query is for sharedlink links "
                            "(operation not supported on this link's protocol)\n");
}

/* The same operations through slctl, when it is built (the slctl branch). */
static void test_back_to_back_slctl(void **state)
{
        struct fx *f = *state;
        char links[CONFIG_MAX], out[REPLY_MAX];
        const char *slctl = harness_slctl_path();

        if (access(slctl, X_OK) != 0)
                skip();
        pair_links(f, links, sizeof(links));
        start(f, links);
        wait_value(f, "agility.device.D15D15.online", "1");
        {
                const char *argv[] = { slctl, "circe", "arena", "emulate", "action", "E1E1E1",
                                       "--sensor-time", "6000", NULL };

                assert_int_equal(harness_run(&f->h, out, sizeof(out), T_REPLY_MS, argv), 0);
        }
        wait_event(f, "agility", "action", "device=E1E1E1 sensor_time=6000", NULL);
        {
                const char *argv[] = { slctl, "circe", "agility", "visualize", "D15D15",
                                       "--current", "7", NULL };

                assert_int_equal(harness_run(&f->h, out, sizeof(out), T_REPLY_MS, argv), 0);
        }
        wait_value(f, "arena.device.D15D15.current_competitor", "7");
        {
                const char *argv[] = { slctl, "circe", "agility", "sync-clocks", NULL };

                assert_int_equal(harness_run(&f->h, out, sizeof(out), T_REPLY_MS, argv), 0);
                assert_non_null(strstr(out, "D15D15 succeeded"));
        }
        {
                const char *argv[] = { slctl, "circe", "agility", "alert", "XYZ", NULL };

                assert_int_equal(harness_run(&f->h, out, sizeof(out), T_REPLY_MS, argv), 1);
        }
}

/* ---- the test as the mediator ---------------------------------------------------------------- */

/*
 * The test plays the mediator on the master side of two pty pairs; the daemon's controller link
 * has the slaves (through symlinks) as its devices, dev0 first. The packets are the CIRCE spec's
 * example sessions, byte for byte, from tests/common/circe_sessions.h (the unit test replays the
 * same ones into the engine in process). What the daemon made of them is read the way a user
 * would: slctl get / events / stats --json, and the library.
 */

static void put_raw(struct fx *f, int side, const void *data, size_t len)
{
        assert_int_equal(harness_write_all(f->master[side], data, len, T_WAIT_MS), 0);
}

/* Sends one packet (with checksum) to the daemon on dev<side>. */
static void put(struct fx *f, int side, const char *body)
{
        uint8_t buf[PKT_MAX];

        put_raw(f, side, buf, wire_circe_str(buf, sizeof(buf), body, WIRE_CS_UPPER));
}

/* Reads the next packet the daemon sent on dev<side>; it must be exactly body (+ checksum). */
static void expect(struct fx *f, int side, const char *body)
{
        uint8_t want[PKT_MAX];
        char got[PKT_MAX], a[2 * PKT_MAX], b[2 * PKT_MAX];
        size_t wn = wire_circe_str(want, sizeof(want), body, WIRE_CS_UPPER);
        ssize_t gn = harness_read_until(f->master[side], got, sizeof(got), 0x03, T_WAIT_MS);

        wire_circe_show(want, wn, a, sizeof(a));
        if (gn <= 0)
                fail_msg("dev%d: no packet (%zd); expected %s", side, gn, a);
        wire_circe_show((const uint8_t *)got, (size_t)gn, b, sizeof(b));
        if ((size_t)gn != wn || memcmp(got, want, wn) != 0)
                fail_msg("dev%d: got %s, expected %s", side, b, a);
}

/* Nothing more is waiting on dev<side> (checked once the daemon answered what came before). */
static void expect_nothing(struct fx *f, int side)
{
        char c;
        ssize_t n = read(f->master[side], &c, 1);
        int e = errno;

        if (n >= 0 || e != EAGAIN)
                fail_msg("dev%d: unexpected input (read %zd, errno %d)", side, n, n < 0 ? e : 0);
}

/* Starts a daemon with one controller link on dev0, dev1 and reads its Login on dev0. */
static void mediator_start(struct fx *f, const char *expect_version, int idle_timeout_ms)
{
        char links[CONFIG_MAX], slave_path[PATH_BUF], dev[PATH_BUF];

        for (int i = 0; i < PTYS; i++) {
                assert_int_equal(harness_openpty(&f->master[i], &f->slave[i], slave_path), 0);
                snprintf(dev, sizeof(dev), "%s/dev%d", f->h.dir, i);
                assert_int_equal(symlink(slave_path, dev), 0);
                memcpy(f->dev[i], dev, sizeof(dev));
        }
        /* A generous login timeout: the test answers at once, an ASan build is slow. */
        snprintf(links, sizeof(links),
                 "links:\n"
                 "  - name: agility\n"
                 "    protocol: circe\n"
                 "    role: controller\n"
                 "    transport: serial\n"
                 "    devices: [%s, %s]\n"
                 "    expect_version: \"%s\"\n"
                 "    login_timeout_ms: 5000\n"
                 "    idle_timeout_ms: %d\n",
                 f->dev[0], f->dev[1], expect_version, idle_timeout_ms);
        start(f, links);
        expect(f, 0, CIRCE_S_LOGIN);
}

/* ---- slctl ----------------------------------------------------------------------------------- */

/* Runs slctl with words (NULL-terminated) under the test's instance; its exit code, stdout in out
 * and stderr in err. */
static int slctl_run(struct fx *f, char *out, size_t size, char *err, size_t errsize,
                     const char *const *words)
{
        const char *argv[SLCTL_ARGS_MAX];
        size_t n = 0;

        argv[n++] = harness_slctl_path();
        for (size_t i = 0; words[i]; i++) {
                assert_true(n < SLCTL_ARGS_MAX - 1);
                argv[n++] = words[i];
        }
        argv[n] = NULL;
        return harness_run_capture(&f->h, out, size, err, errsize, T_REPLY_MS, argv);
}

#define SLCTL(f, out, ...) \
        slctl_run((f), (out), sizeof(out), NULL, 0, (const char *const[]){ __VA_ARGS__, NULL })
#define SLCTL_N(f, out, size, ...) \
        slctl_run((f), (out), (size), NULL, 0, (const char *const[]){ __VA_ARGS__, NULL })
#define SLCTL_ERR(f, out, err, ...) \
        slctl_run((f), (out), sizeof(out), (err), sizeof(err), \
                  (const char *const[]){ __VA_ARGS__, NULL })

static void need_slctl(void)
{
        if (access(harness_slctl_path(), X_OK) != 0)
                skip();
}

/*
 * Runs `slctl cmd` until its output contains needle (whole output when exact), waking on the
 * table's change counter between tries (an event, not a sleep); fails after T_WAIT_MS. The last
 * output stays in out.
 */
static void slctl_wait(struct fx *f, const char *const *words, const char *needle, bool exact,
                       char *out, size_t size)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)T_WAIT_MS * 1000000u;
        uint32_t cursor = 0;

        sl_wait(f->cl, &cursor, 0);
        for (;;) {
                int r = slctl_run(f, out, size, NULL, 0, words);

                if (r == 0 && (exact ? strcmp(out, needle) == 0 : strstr(out, needle) != NULL))
                        return;
                if (harness_now_ns() > deadline)
                        fail_msg("slctl %s %s: exit %d, \"%s\"; waited for \"%s\"", words[0],
                                 words[1] ? words[1] : "", r, out, needle);
                sl_wait(f->cl, &cursor, 200);
        }
}

/* Waits until `slctl get name` prints want. */
static void wait_get(struct fx *f, const char *name, const char *want)
{
        char out[REPLY_MAX], line[SL_VALUE_SIZE + 2];

        snprintf(line, sizeof(line), "%s\n", want);
        slctl_wait(f, (const char *const[]){ "get", name, NULL }, line, true, out, sizeof(out));
}

/* Checks what `slctl get name` prints now. */
static void assert_get(struct fx *f, const char *name, const char *want)
{
        char out[REPLY_MAX];

        assert_int_equal(SLCTL(f, out, "get", name), 0);
        if (strlen(out) != strlen(want) + 1 || strncmp(out, want, strlen(want)) != 0 ||
            out[strlen(want)] != '\n')
                fail_msg("slctl get %s: \"%s\", expected \"%s\"", name, out, want);
}

/* Waits until `slctl events` shows the line "SEQ text"; the whole listing goes to out
 * (EVENTS_MAX). */
static void wait_events(struct fx *f, const char *text, char *out)
{
        char needle[SL_EVENT_TEXT_SIZE + 8];

        snprintf(needle, sizeof(needle), " %s\n", text);
        slctl_wait(f, (const char *const[]){ "events", NULL }, needle, false, out, EVENTS_MAX);
}

/* Waits until `slctl events` shows the line "SEQ then" after the line "SEQ first". */
static void wait_events_after(struct fx *f, const char *first, const char *then, char *out)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)T_WAIT_MS * 1000000u;
        char n1[SL_EVENT_TEXT_SIZE + 8], n2[SL_EVENT_TEXT_SIZE + 8];
        uint32_t cursor = 0;

        snprintf(n1, sizeof(n1), " %s\n", first);
        snprintf(n2, sizeof(n2), " %s\n", then);
        sl_wait(f->cl, &cursor, 0);
        for (;;) {
                const char *p;

                assert_int_equal(SLCTL_N(f, out, EVENTS_MAX, "events"), 0);
                p = strstr(out, n1);
                if (p && strstr(p + strlen(n1), n2))
                        return;
                if (harness_now_ns() > deadline)
                        fail_msg("no event \"%s\" after \"%s\" in:\n%s", then, first, out);
                sl_wait(f->cl, &cursor, 200);
        }
}

/* Where " text\n" is in an events listing; fails when it is not there. */
static const char *event_at(const char *listing, const char *text)
{
        char needle[SL_EVENT_TEXT_SIZE + 8];
        const char *p;

        snprintf(needle, sizeof(needle), " %s\n", text);
        p = strstr(listing, needle);
        if (!p)
                fail_msg("no event \"%s\" in:\n%s", text, listing);
        return p;
}

static unsigned count_lines(const char *listing, const char *needle)
{
        unsigned n = 0;

        for (const char *p = listing; (p = strstr(p, needle)); p++)
                n++;
        return n;
}

/* A counter of link from `slctl stats --json`: {"links": [{"name": "agility", ...,
 * "counters": {"noise_bytes": 8, ...}}]} (no nested objects inside "counters"). */
static uint64_t counter(struct fx *f, const char *link, const char *name)
{
        static char out[STATS_MAX];
        char key[96];
        const char *p, *end;

        assert_int_equal(SLCTL(f, out, "stats", "--json"), 0);
        p = strstr(out, "\"links\":");
        assert_non_null(p);
        snprintf(key, sizeof(key), "\"name\":\"%s\"", link);
        p = strstr(p, key);
        assert_non_null(p);
        p = strstr(p, "\"counters\":{");
        assert_non_null(p);
        end = strchr(p, '}');
        assert_non_null(end);
        snprintf(key, sizeof(key), "\"%s\":", name);
        p = strstr(p, key);
        if (!p || p > end)
                fail_msg("link %s has no counter %s in %s", link, name, out);
        return strtoull(p + strlen(key), NULL, 10);
}

/* slctl in the background, for a request the test must answer on the wire before it returns. */
static void slctl_spawn(struct fx *f, const char *const *words)
{
        const char *argv[SLCTL_ARGS_MAX];
        int fds[2];
        size_t n = 0;
        pid_t pid;

        argv[n++] = harness_slctl_path();
        for (size_t i = 0; words[i]; i++) {
                assert_true(n < SLCTL_ARGS_MAX - 1);
                argv[n++] = words[i];
        }
        argv[n] = NULL;
        assert_int_equal(pipe2(fds, O_CLOEXEC), 0);
        pid = fork();
        assert_true(pid >= 0);
        if (pid == 0) {
                union { const char *const *c; char *const *m; } u = { .c = argv };

                setenv("SHAREDLINK_INSTANCE", f->h.instance, 1);
                setenv("SHAREDLINK_RUNTIME_DIR", f->h.dir, 1);
                dup2(fds[1], STDOUT_FILENO);
                execv(u.m[0], u.m);
                _exit(127);
        }
        close(fds[1]);
        f->bg_pid = pid;
        f->bg_fd = fds[0];
}

/* Collects the background slctl's output until it exits; its exit code. */
static int slctl_collect(struct fx *f, char *out, size_t size)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)T_REPLY_MS * 1000000u;
        size_t len = 0;
        int st;

        for (;;) {
                struct pollfd p = { .fd = f->bg_fd, .events = POLLIN };
                ssize_t n;

                if (harness_now_ns() > deadline)
                        fail_msg("slctl still running; output so far \"%.*s\"", (int)len, out);
                if (poll(&p, 1, 100) <= 0)
                        continue;
                n = read(f->bg_fd, out + len, size - 1 - len);
                if (n < 0 && (errno == EINTR || errno == EAGAIN))
                        continue;
                if (n <= 0 || len + (size_t)n >= size - 1) {
                        if (n > 0)
                                len += (size_t)n;
                        break;
                }
                len += (size_t)n;
        }
        out[len] = '\0';
        close(f->bg_fd);
        f->bg_fd = -1;
        assert_int_equal(waitpid(f->bg_pid, &st, 0), f->bg_pid);
        f->bg_pid = 0;
        return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

/* ---- the spec's sessions against the real daemon --------------------------------------------- */

/* Login, Keep Alive, connected (seen through slctl and the library); the values and events of
 * what the test sends; an operation's exact bytes; Logout when the daemon stops. */
static void test_controller_facing_test(void **state)
{
        struct fx *f = *state;
        char text[SL_EVENT_TEXT_SIZE];

        need_slctl();
        mediator_start(f, "1.2", 60000);
        put(f, 0, CIRCE_S_KA);
        wait_get(f, "agility.state", "connected");
        assert_true(value_is(f, "agility.state", "connected"));
        assert_get(f, "agility.mediator.version", "1.2.34");
        assert_get(f, "agility.mediator.status", "0");
        put(f, 0, CIRCE_S_NET_STATUS_E1E1E1);
        wait_value(f, "agility.device.E1E1E1.signal", "150");
        put(f, 0, CIRCE_S_RACE_START);
        wait_event(f, "agility", "action", "device=E1E1E1", text);
        assert_string_equal(text, "device=E1E1E1 sensor_time=5000");
        assert_string_equal(request(f, "circe agility device-setup 222222 - 32"), "OK\n");
        expect(f, 0, CIRCE_S_ASSIGN_GATE);
        assert_string_equal(request(f, "circe agility network-setup E1E1E1 join 2"), "OK\n");
        expect(f, 0, CIRCE_S_NET_JOIN_E1E1E1);
        /* A clean stop ends the session with Logout. */
        assert_int_equal(harness_stop_daemon(&f->h, SIGTERM, T_STOP_MS), 0);
        expect(f, 0, CIRCE_S_LOGOUT);
}

/* "Assigning unique network addresses": an unconfigured mediator gets its address, a new gate
 * gets one and the time-sensor capability, both through slctl; Logout at the end. */
static void test_spec_assigning_addresses(void **state)
{
        struct fx *f = *state;
        char out[REPLY_MAX], events[EVENTS_MAX];

        need_slctl();
        mediator_start(f, "1.2", 60000);
        put(f, 0, CIRCE_S_KA_UNCONF);
        wait_get(f, "agility.state", "unconfigured");
        assert_get(f, "agility.mediator.version", "1.2.34");
        assert_get(f, "agility.mediator.status", "1");
        wait_events(f, "agility link-state state=unconfigured version=1.2.34 status=1",
                    events);

        /* Operations work on an unconfigured mediator: that is how it gets configured. */
        assert_int_equal(SLCTL(f, out, "circe", "agility", "device-setup", "--assign", "123456"),
                         0);
        expect(f, 0, CIRCE_S_ASSIGN_MEDIATOR);
        put(f, 0, CIRCE_S_KA);
        wait_get(f, "agility.state", "connected");
        assert_get(f, "agility.mediator.status", "0");

        assert_int_equal(SLCTL(f, out, "circe", "agility", "device-setup", "--assign", "222222",
                               "--capabilities", "32"), 0);
        expect(f, 0, CIRCE_S_ASSIGN_GATE);
        expect_nothing(f, 0);
        put(f, 0, CIRCE_S_ASSIGN_GATE_STATUS);
        wait_get(f, "agility.device.222222.online", "1");
        assert_int_equal(SLCTL(f, out, "get", "agility.device.222222.membership",
                               "agility.device.222222.capabilities", "agility.device.222222.roles",
                               "agility.device.222222.signal", "agility.device.222222.battery"),
                         0);
        assert_string_equal(out, "0\n32\n0\n150\n\n");
        wait_events(f, "agility device-online device=222222 capabilities=32 roles=0", events);
        assert_int_equal(counter(f, "agility", "frames_out"), 3);

        assert_int_equal(harness_stop_daemon(&f->h, SIGTERM, T_STOP_MS), 0);
        expect(f, 0, CIRCE_S_LOGOUT);
}

/* "Forming a logical network": three devices appear, the controller alerts one and builds the
 * network, every operation through slctl and checked on the wire. */
static void test_spec_forming_network(void **state)
{
        struct fx *f = *state;
        char out[REPLY_MAX], events[EVENTS_MAX];

        need_slctl();
        mediator_start(f, "1.2", 60000);
        put(f, 0, CIRCE_S_KA);
        wait_get(f, "agility.state", "connected");
        put(f, 0, CIRCE_S_NET_STATUS_AAAAAA);
        put(f, 0, CIRCE_S_NET_STATUS_E1E1E1);
        put(f, 0, CIRCE_S_NET_STATUS_E2E2E2);
        wait_events(f, "agility device-online device=E2E2E2 capabilities=32 roles=0", events);
        assert_int_equal(count_lines(events, " agility device-online "), 3);
        wait_get(f, "agility.device.E2E2E2.signal", "130");
        assert_int_equal(SLCTL(f, out, "get", "agility.device.AAAAAA.capabilities",
                               "agility.device.AAAAAA.signal", "agility.device.E1E1E1.signal",
                               "agility.device.E2E2E2.signal"), 0);
        assert_string_equal(out, "1\n200\n150\n130\n");

        assert_int_equal(SLCTL(f, out, "circe", "agility", "alert", "E1E1E1"), 0);
        expect(f, 0, CIRCE_S_NET_ALERT_E1E1E1);
        assert_int_equal(SLCTL(f, out, "circe", "agility", "network-setup", "AAAAAA", "--join",
                               "--roles", "1"), 0);
        expect(f, 0, CIRCE_S_NET_JOIN_AAAAAA);
        /* slctl takes lower case and sends upper case. */
        assert_int_equal(SLCTL(f, out, "circe", "agility", "network-setup", "e1e1e1", "--join",
                               "--roles", "2"), 0);
        expect(f, 0, CIRCE_S_NET_JOIN_E1E1E1);
        assert_int_equal(SLCTL(f, out, "circe", "agility", "network-setup", "E2E2E2", "--join",
                               "--roles", "4"), 0);
        expect(f, 0, CIRCE_S_NET_JOIN_E2E2E2);
        expect_nothing(f, 0);
        assert_int_equal(counter(f, "agility", "frames_out"), 5);
        assert_int_equal(counter(f, "agility", "frames_in"), 4);
}

/* "Synchronizing hardware clocks": slctl sync-clocks waits while the test answers the 06 with
 * the devices' statuses; it prints one "ADDR succeeded" line per device. */
static void test_spec_clock_sync(void **state)
{
        struct fx *f = *state;
        char out[REPLY_MAX], events[EVENTS_MAX];

        need_slctl();
        mediator_start(f, "1.2", 60000);
        put(f, 0, CIRCE_S_KA);
        put(f, 0, CIRCE_S_SYNC_STATUS_AAAAAA);
        put(f, 0, CIRCE_S_SYNC_STATUS_E1E1E1);
        wait_get(f, "agility.device.E1E1E1.clock_sync", "1");
        slctl_spawn(f, (const char *const[]){ "circe", "agility", "sync-clocks", NULL });
        expect(f, 0, CIRCE_S_SYNC_CLOCKS);
        put(f, 0, CIRCE_S_SYNC_DONE_AAAAAA);
        put(f, 0, CIRCE_S_SYNC_DONE_E1E1E1);
        assert_int_equal(slctl_collect(f, out, sizeof(out)), 0);
        assert_string_equal(out, "AAAAAA succeeded\nE1E1E1 succeeded\n");
        wait_get(f, "agility.device.E1E1E1.clock_sync", "2");
        wait_events(f, "agility clock-sync device=E1E1E1 result=succeeded", events);
        event_at(events, "agility clock-sync device=AAAAAA result=succeeded");
}

/* "Race events during a competition run": every Notify Action is an event with the device, the
 * keys and the sensor time, in the order sent. */
static void test_spec_race(void **state)
{
        struct fx *f = *state;
        char out[REPLY_MAX], events[EVENTS_MAX];
        const char *a, *b, *c, *d;

        need_slctl();
        mediator_start(f, "1.2", 60000);
        put(f, 0, CIRCE_S_KA);
        put(f, 0, CIRCE_S_RACE_READY_DOWN);
        put(f, 0, CIRCE_S_RACE_READY_UP);
        put(f, 0, CIRCE_S_RACE_START);
        put(f, 0, CIRCE_S_RACE_FINISH);
        wait_events(f, "agility action device=E2E2E2 sensor_time=32000", events);
        a = event_at(events, "agility action device=AAAAAA keys=32768");
        b = event_at(events, "agility action device=AAAAAA keys=0");
        c = event_at(events, "agility action device=E1E1E1 sensor_time=5000");
        d = event_at(events, "agility action device=E2E2E2 sensor_time=32000");
        assert_true(a < b && b < c && c < d);
        assert_int_equal(count_lines(events, " agility action "), 4);
        wait_get(f, "agility.device.E2E2E2.sensor_time", "32000");
        assert_int_equal(SLCTL(f, out, "get", "agility.device.AAAAAA.keys",
                               "agility.device.E1E1E1.sensor_time",
                               "agility.device.E2E2E2.sensor_time", "agility.device.E2E2E2.online",
                               "agility.device.E2E2E2.signal"), 0);
        /* Seen through actions only: the variables exist, the device is not online. */
        assert_string_equal(out, "0\n5000\n32000\n0\n\n");
}

/* Connected, then nothing valid for idle_timeout_ms (a Log does not count): Logout on dev0,
 * Login on dev1, connected again once answered there. */
static void test_idle_timeout_reconnect(void **state)
{
        struct fx *f = *state;
        char events[EVENTS_MAX];

        need_slctl();
        mediator_start(f, "0.2", 1000);
        put(f, 0, CIRCE_S_KA_023);
        wait_get(f, "agility.state", "connected");
        put(f, 0, CIRCE_S_LOG_ALIVE);
        expect(f, 0, CIRCE_S_LOGOUT);
        expect(f, 1, CIRCE_S_LOGIN);
        wait_events_after(f, "agility link-state state=disconnected reason=idle-timeout",
                          "agility link-state state=connecting", events);
        assert_int_equal(counter(f, "agility", "timeouts"), 1);
        assert_true(counter(f, "agility", "log_messages") >= 1);
        put(f, 1, CIRCE_S_KA_023);
        wait_get(f, "agility.state", "connected");
        wait_events_after(f, "agility link-state state=disconnected reason=idle-timeout",
                          "agility link-state state=connected version=0.2.3 status=0", events);
}

/* A mediator speaking another major.minor: reported, Logout, the next port; a later patch level
 * of the expected version is fine. */
static void test_version_mismatch(void **state)
{
        struct fx *f = *state;
        char events[EVENTS_MAX];

        need_slctl();
        mediator_start(f, "0.2", 60000);
        put(f, 0, CIRCE_S_KA);
        expect(f, 0, CIRCE_S_LOGOUT);
        wait_events(f, "agility link-state state=version-mismatch version=1.2.34 status=0 "
                       "expected=0.2", events);
        assert_get(f, "agility.mediator.version", "1.2.34");
        expect(f, 1, CIRCE_S_LOGIN);
        put(f, 1, CIRCE_S_KA_029);
        wait_get(f, "agility.state", "connected");
        assert_get(f, "agility.mediator.version", "0.2.9");
        wait_events_after(f, "agility link-state state=version-mismatch version=1.2.34 status=0 "
                             "expected=0.2",
                          "agility link-state state=connected version=0.2.9 status=0", events);
        expect_nothing(f, 0);
}

/* Bad input of every kind between valid packets (the unit test's sequence): each dropped or
 * skipped as PROTOCOLS.md 2.3 says, counted by reason in `slctl stats --json`, and the valid
 * packets around it all land. */
static void test_bad_input(void **state)
{
        static const char *const landed[] = {
                "agility action device=A00001 sensor_time=1",
                "agility action device=A00002 sensor_time=2",
                "agility action device=A0000A sensor_time=3",
                "agility action device=A0000B sensor_time=4",
                "agility action device=A00003 sensor_time=7",
                "agility action device=A00004 sensor_time=9",
                "agility action device=A00005 sensor_time=10",
                "agility action device=A00006 sensor_time=11",
        };
        struct fx *f = *state;
        uint8_t p[CIRCE_PACKET_MAX * 2];
        char events[EVENTS_MAX];

        need_slctl();
        mediator_start(f, "1.2", 60000);
        put(f, 0, CIRCE_S_KA);
        wait_get(f, "agility.state", "connected");

        for (unsigned k = 0; k < CIRCE_GARBAGE_STEPS; k++)
                put_raw(f, 0, p, circe_garbage_bytes(k, p, sizeof(p)));

        wait_get(f, "agility.device.A00008.online", "1");
        wait_events(f, "agility device-online device=A00008 capabilities=31 roles=0", events);
        for (size_t k = 0; k < sizeof(landed) / sizeof(landed[0]); k++)
                event_at(events, landed[k]);
        assert_null(strstr(events, "device=B"));
        assert_null(strstr(events, "device=C"));
        assert_null(strstr(events, "device=000000"));
        assert_null(strstr(events, "device=A00007"));

        for (unsigned k = 0; k < CIRCE_GARBAGE_COUNTERS; k++) {
                const struct circe_garbage_count *c = &circe_garbage_counts[k];

                if (counter(f, "agility", c->counter) != c->value)
                        fail_msg("%s: %llu, expected %llu", c->counter,
                                 (unsigned long long)counter(f, "agility", c->counter),
                                 (unsigned long long)c->value);
        }
        assert_get(f, "agility.state", "connected");
}

/* Operations on the wire as slctl sends them: refused (with the daemon's reason, nothing sent)
 * while the mediator has not answered, sent once it has when the request may wait, Visualize's
 * fields in the precedence order of PROTOCOLS.md 2.2 and one 014 per display. */
static void test_commands_on_the_wire(void **state)
{
        struct fx *f = *state;
        char out[REPLY_MAX], err[REPLY_MAX];

        need_slctl();
        mediator_start(f, "1.2", 60000);
        assert_int_equal(SLCTL_ERR(f, out, err, "circe", "agility", "alert", "E1E1E1"), 1);
        assert_string_equal(err, "slctl: link agility is not connected (state connecting)\n");
        assert_int_equal(SLCTL_ERR(f, out, err, "circe", "agility", "alert", "E1E1E"), 1);
        assert_non_null(strstr(err, "E1E1E"));
        /* A request that may wait goes out as soon as the mediator answers. */
        slctl_spawn(f, (const char *const[]){ "circe", "agility", "visualize", "D15D15",
                                              "--current", "7", "--wait", "5000", NULL });
        put(f, 0, CIRCE_S_KA);
        assert_int_equal(slctl_collect(f, out, sizeof(out)), 0);
        expect(f, 0, "07\t028:7\t014:D15D15\t");
        assert_int_equal(SLCTL(f, out, "circe", "agility", "visualize", "D15D15", "--next", "13",
                               "--current", "12", "--start-timer", "--eliminated", "0"), 0);
        expect(f, 0, "07\t034:0\t028:12\t029:13\t030:1\t014:D15D15\t");
        assert_int_equal(SLCTL(f, out, "circe", "agility", "visualize", "D15D15,E1E1E1",
                               "--placement", "3", "--refusals", "2", "--faults", "1",
                               "--secondary", "999999", "--primary", "31250", "--eliminated",
                               "1"), 0);
        expect(f, 0, "07\t034:1\t031:31250\t038:999999\t032:1\t033:2\t035:3\t014:D15D15\t"
                     "014:E1E1E1\t");
        expect_nothing(f, 0);
        /* Login and the three Visualize: nothing for the refused ones. */
        assert_int_equal(counter(f, "agility", "frames_out"), 4);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_back_to_back, setup, teardown),
                cmocka_unit_test_setup_teardown(test_back_to_back_slctl, setup, teardown),
                cmocka_unit_test_setup_teardown(test_controller_facing_test, setup, teardown),
                cmocka_unit_test_setup_teardown(test_spec_assigning_addresses, setup, teardown),
                cmocka_unit_test_setup_teardown(test_spec_forming_network, setup, teardown),
                cmocka_unit_test_setup_teardown(test_spec_clock_sync, setup, teardown),
                cmocka_unit_test_setup_teardown(test_spec_race, setup, teardown),
                cmocka_unit_test_setup_teardown(test_idle_timeout_reconnect, setup, teardown),
                cmocka_unit_test_setup_teardown(test_version_mismatch, setup, teardown),
                cmocka_unit_test_setup_teardown(test_bad_input, setup, teardown),
                cmocka_unit_test_setup_teardown(test_commands_on_the_wire, setup, teardown),
        };

        return cmocka_run_group_tests_name("circe (integration)", tests, NULL, NULL);
}
