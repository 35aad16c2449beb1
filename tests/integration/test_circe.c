/*
 * CIRCE links end to end: the real sharedlinkd (build/asan) started by the harness, its control
 * socket, its shm tables read through the client library, and ptys.
 *
 *  - back to back: a controller link and a mediator-emulator link of one daemon joined by the
 *    emulator's pty (the `make demo` pair): devices appear, a gate passage injected on the
 *    emulator arrives as an action event on the controller, a visualize command changes the
 *    emulated display, a clock synchronisation succeeds for every device, commands are checked
 *    (and the same through `slctl circe` when slctl is built);
 *  - a controller facing the test, which plays the mediator on a pty pair: Login, the values and
 *    events of what the test sends, an operation's exact bytes, Logout when the daemon stops.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <errno.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include <sharedlink.h>

#include "common/harness.h"

#define T_START_MS      15000   /* READY=1 (ASan build) */
#define T_WAIT_MS       10000   /* one awaited value or event */
#define T_REPLY_MS      10000   /* one control reply (sync-clocks takes up to 3 s) */
#define T_STOP_MS       10000
#define CONFIG_MAX      4096
#define REPLY_MAX       4096
#define PATH_BUF        512

struct fx {
        struct harness h;
        struct sl_client *cl;
        int ctl;                        /* control connection */
        uint64_t ev_cursor;
        int master, slave;              /* the test's pty pair (controller test) */
        char dev[PATH_BUF];
};

static int setup(void **state)
{
        struct fx *f = calloc(1, sizeof(*f));

        if (!f || harness_init(&f->h, "circe") < 0)
                return -1;
        f->ctl = -1;
        f->master = f->slave = -1;
        *state = f;
        return 0;
}

static int teardown(void **state)
{
        struct fx *f = *state;

        sl_close(f->cl);
        if (f->ctl >= 0)
                close(f->ctl);
        if (f->master >= 0)
                close(f->master);
        if (f->slave >= 0)
                close(f->slave);
        harness_cleanup(&f->h);
        free(f);
        return 0;
}

static void start(struct fx *f, const char *links)
{
        char text[CONFIG_MAX], path[PATH_BUF], sock[PATH_BUF];
        int st = 0;

        snprintf(text, sizeof(text), "instance: %s\nlinks:\n%s", f->h.instance, links);
        assert_int_equal(harness_write_file(&f->h, "circe.yaml", text, path), 0);
        f->h.capture_log = 1;
        if (harness_start_daemon(&f->h, path, T_START_MS, &st, NULL) != 0) {
                /* A build whose link registry does not have the CIRCE engine yet. */
                if (harness_log_contains(&f->h, "not available in this build") == 1)
                        skip();
                char log[2048] = "";
                FILE *fp = fopen(f->h.log_path, "r");

                if (fp) {
                        size_t n = fread(log, 1, sizeof(log) - 1, fp);

                        log[n] = '\0';
                        fclose(fp);
                }
                fail_msg("sharedlinkd did not start (status %d): %s", st, log);
        }
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
        char buf[SL_VALUE_SIZE];
        int id = sl_find(f->cl, name);

        return id >= 0 && sl_read(f->cl, id, buf, sizeof(buf), NULL) >= 0 &&
               strcmp(buf, want) == 0;
}

static void wait_value(struct fx *f, const char *name, const char *want)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)T_WAIT_MS * 1000000u;
        uint32_t cursor = 0;

        while (!value_is(f, name, want)) {
                if (harness_now_ns() > deadline)
                        fail_msg("%s never became \"%s\"", name, want);
                sl_wait(f->cl, &cursor, 200);
        }
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

static void pair_links(struct fx *f, char *buf, size_t size)
{
        snprintf(buf, size,
                 "  - name: arena\n"
                 "    protocol: circe\n"
                 "    role: mediator\n"
                 "    transport: pty\n"
                 "    device: %s/arena.tty\n"
                 "    version: \"0.2.3\"\n"
                 "    keepalive_ms: 750\n"
                 "    emulate:\n"
                 "      - {address: E1E1E1, capabilities: 32, signal: 150, battery: 200}\n"
                 "      - {address: AAAAAA, capabilities: 31}\n"
                 "      - {address: D15D15, capabilities: 64}\n"
                 "  - name: agility\n"
                 "    protocol: circe\n"
                 "    role: controller\n"
                 "    transport: serial\n"
                 "    device: %s/arena.tty\n"
                 "    expect_version: \"0.2\"\n",
                 f->h.dir, f->h.dir);
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
                            "ERR 22 bad address \"E1E1E\": six hex digits expected (FFFFFF is "
                            "reserved)\n");
        assert_string_equal(request(f, "circe arena alert E1E1E1"),
                            "ERR 95 link arena is a mediator emulator: alert is for controller "
                            "links\n");
        assert_string_equal(request(f, "circe arena emulate action 999999"),
                            "ERR 2 link arena emulates no device 999999\n");
        r = request(f, "circe nosuch alert E1E1E1");
        assert_true(strncmp(r, "ERR 2 ", 6) == 0);
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

static size_t pkt(const char *body, char *out)
{
        unsigned sum = 0x02;
        size_t n = 0;

        out[n++] = 0x02;
        for (const char *p = body; *p; p++) {
                out[n++] = *p;
                sum += (uint8_t)*p;
        }
        n += (size_t)sprintf(out + n, "%02X", sum & 0xFF);
        out[n++] = 0x03;
        out[n] = '\0';
        return n;
}

static void put(struct fx *f, const char *body)
{
        char buf[512];

        assert_int_equal(harness_write_all(f->master, buf, pkt(body, buf), T_WAIT_MS), 0);
}

/* Reads the next packet from the daemon and compares it with body (+ checksum). */
static void expect(struct fx *f, const char *body)
{
        char want[512], got[512];
        size_t wn = pkt(body, want);
        ssize_t gn = harness_read_until(f->master, got, sizeof(got), 0x03, T_WAIT_MS);

        assert_true(gn > 0);
        assert_int_equal((size_t)gn, wn);
        assert_memory_equal(got, want, wn);
}

static void test_controller_facing_test(void **state)
{
        struct fx *f = *state;
        char links[CONFIG_MAX], slave_path[PATH_BUF], text[SL_EVENT_TEXT_SIZE];

        assert_int_equal(harness_openpty(&f->master, &f->slave, slave_path), 0);
        snprintf(f->dev, sizeof(f->dev), "%s/mediator.tty", f->h.dir);
        assert_int_equal(symlink(slave_path, f->dev), 0);
        snprintf(links, sizeof(links),
                 "  - name: agility\n"
                 "    protocol: circe\n"
                 "    role: controller\n"
                 "    transport: serial\n"
                 "    device: %s\n"
                 "    expect_version: \"1.2\"\n"
                 "    idle_timeout_ms: 60000\n", f->dev);
        start(f, links);
        expect(f, "01\t");
        put(f, "51\t010:1.2.34\t012:0\t");
        wait_value(f, "agility.state", "connected");
        put(f, "52\t015:E1E1E1\t016:0\t019:32\t020:0\t021:150\t");
        wait_value(f, "agility.device.E1E1E1.signal", "150");
        put(f, "53\t015:E1E1E1\t025:5000\t");
        wait_event(f, "agility", "action", "device=E1E1E1", text);
        assert_string_equal(text, "device=E1E1E1 sensor_time=5000");
        assert_string_equal(request(f, "circe agility device-setup 222222 - 32"), "OK\n");
        expect(f, "05\t026:222222\t019:32\t");
        assert_string_equal(request(f, "circe agility network-setup E1E1E1 join 2"), "OK\n");
        expect(f, "04\t014:E1E1E1\t017:1\t020:2\t");
        /* A clean stop ends the session with Logout. */
        assert_int_equal(harness_stop_daemon(&f->h, SIGTERM, T_STOP_MS), 0);
        expect(f, "02\t");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_back_to_back, setup, teardown),
                cmocka_unit_test_setup_teardown(test_back_to_back_slctl, setup, teardown),
                cmocka_unit_test_setup_teardown(test_controller_facing_test, setup, teardown),
        };

        return cmocka_run_group_tests_name("circe (integration)", tests, NULL, NULL);
}
