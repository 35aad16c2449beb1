/*
 * SharedLink links end to end: the real sharedlinkd (tests/common/harness.h), the test playing
 * the peer on pty masters and a loopback UDP socket, values checked through the client library,
 * queries through the control socket (raw requests, as the wire format in control.h says).
 *
 * Every wait is for an event (a byte on a master, a change word, a notify datagram) with a
 * timeout; nothing sleeps to let things happen.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cmocka.h>
#include <sharedlink.h>

#include "common/harness.h"

#define START_MS        20000
#define WAIT_MS         10000
#define YAML_MAX        4096
#define LINE_MAX_T      1024

struct it {
        struct harness h;
        struct sl_client *c;
        int master, slave;              /* the pty pair the daemon's serial link opens */
        char dev[HARNESS_PATH_MAX + 8];
        int udp;                        /* the test's UDP socket, -1 when none */
        uint16_t udp_port;
};

static int setup(void **state)
{
        struct it *t = calloc(1, sizeof(*t));

        if (!t || harness_init(&t->h, "sl") < 0)
                return -1;
        t->master = t->slave = t->udp = -1;
        *state = t;
        return 0;
}

static int teardown(void **state)
{
        struct it *t = *state;

        sl_close(t->c);
        harness_cleanup(&t->h);
        if (t->master >= 0)
                close(t->master);
        if (t->slave >= 0)
                close(t->slave);
        if (t->udp >= 0)
                close(t->udp);
        free(t);
        return 0;
}

/* "[" text "|C" hh "]" (+ CR LF); text starts at the ':'. */
static size_t mkraw(char *out, size_t size, const char *text, int crlf)
{
        unsigned sum = '|' + 'C';
        int n;

        for (const char *p = text; *p; p++)
                sum += (unsigned char)*p;
        n = snprintf(out, size, "[%s|C%02X]%s", text, sum & 0xffu, crlf ? "\r\n" : "");
        assert_true(n > 0 && (size_t)n < size);
        return (size_t)n;
}

/* A new pty pair behind <dir>/tty0 (the link's device). */
static void plug(struct it *t)
{
        char pts[HARNESS_PATH_MAX], tmp[HARNESS_PATH_MAX + 16];

        snprintf(t->dev, sizeof(t->dev), "%s/tty0", t->h.dir);
        assert_int_equal(harness_openpty(&t->master, &t->slave, pts), 0);
        snprintf(tmp, sizeof(tmp), "%s.new", t->dev);
        unlink(tmp);
        assert_int_equal(symlink(pts, tmp), 0);
        assert_int_equal(rename(tmp, t->dev), 0);
}

static void unplug(struct it *t)
{
        char tmp[HARNESS_PATH_MAX + 16];

        snprintf(tmp, sizeof(tmp), "%s.new", t->dev);
        unlink(tmp);
        assert_int_equal(symlink("/nonexistent-sharedlink-test", tmp), 0);
        assert_int_equal(rename(tmp, t->dev), 0);
        close(t->master);
        close(t->slave);
        t->master = t->slave = -1;
}

static void start(struct it *t, const char *links_yaml)
{
        char yaml[YAML_MAX], path[HARNESS_PATH_MAX];
        int st = 0, r;

        snprintf(yaml, sizeof(yaml), "instance: %s\nruntime_dir: %s\nlinks:\n%s", t->h.instance,
                 t->h.dir, links_yaml);
        assert_int_equal(harness_write_file(&t->h, "sl.yaml", yaml, path), 0);
        r = harness_start_daemon(&t->h, path, START_MS, &st, NULL);
        if (r < 0)
                fail_msg("daemon did not start: %s (status %d)", strerror(-r), st);
        assert_int_equal(sl_open(t->h.instance, &t->c), 0);
}

/* Reads frames from the master until one equals want (CR LF stripped); fails on timeout. */
static void expect_frame(struct it *t, const char *text)
{
        char want[512], line[LINE_MAX_T];
        uint64_t deadline = harness_now_ns() + (uint64_t)WAIT_MS * 1000000u;

        mkraw(want, sizeof(want), text, 0);
        while (harness_now_ns() < deadline) {
                ssize_t n = harness_read_until(t->master, line, sizeof(line), '\n', WAIT_MS);
                char *s;

                assert_true(n > 0);
                s = strchr(line, '[');
                if (s && strncmp(s, want, strlen(want)) == 0 &&
                    strcmp(s + strlen(want), "\r\n") == 0)
                        return;
        }
        fail_msg("frame %s never came", want);
}

static void send_frame(int fd, const char *text)
{
        char buf[512];
        size_t n = mkraw(buf, sizeof(buf), text, 1);

        assert_int_equal(harness_write_all(fd, buf, n, WAIT_MS), 0);
}

/* Waits (on the change word) until name reads value. */
static void wait_value(struct it *t, const char *name, const char *value)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)WAIT_MS * 1000000u;
        uint32_t cursor = 0;
        char buf[SL_VALUE_SIZE];

        while (harness_now_ns() < deadline) {
                int id = sl_find(t->c, name);

                if (id >= 0 && sl_read(t->c, id, buf, sizeof(buf), NULL) >= 0 &&
                    strcmp(buf, value) == 0)
                        return;
                sl_wait(t->c, &cursor, 100);
        }
        fail_msg("%s never read %s", name, value);
}

static void wait_state(struct it *t, int link, const char *prefix)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)WAIT_MS * 1000000u;
        uint32_t cursor = 0;

        while (harness_now_ns() < deadline) {
                struct sl_link_info li = { .size = sizeof(li) };

                if (sl_link_info(t->c, link, &li) == 0 &&
                    strncmp(li.state_name, prefix, strlen(prefix)) == 0)
                        return;
                sl_wait(t->c, &cursor, 100);
        }
        fail_msg("link %d never became %s", link, prefix);
}

static void client_write(struct it *t, const char *name, const char *value)
{
        int id = sl_find(t->c, name);

        assert_true(id >= 0);
        assert_int_equal(sl_write(t->c, id, value), 0);
}

static uint32_t read_flags(struct it *t, const char *name)
{
        struct sl_meta meta = { .size = sizeof(meta) };
        char buf[SL_VALUE_SIZE];

        assert_true(sl_read(t->c, sl_find(t->c, name), buf, sizeof(buf), &meta) >= 0);
        return meta.flags;
}

/* Opens a control connection and sends one request line (without waiting for the reply). */
static int control_send(struct it *t, const char *line)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        int fd;

        assert_true(strlen(t->h.dir) + strlen(t->h.instance) + sizeof("/.sock") <=
                    sizeof(sa.sun_path));
        snprintf(sa.sun_path, sizeof(sa.sun_path), "%.*s/%.*s.sock", (int)strlen(t->h.dir),
                 t->h.dir, (int)strlen(t->h.instance), t->h.instance);
        fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        assert_true(fd >= 0);
        assert_int_equal(connect(fd, (struct sockaddr *)&sa, sizeof(sa)), 0);
        assert_int_equal(write(fd, line, strlen(line)), (ssize_t)strlen(line));
        return fd;
}

/* Reads the final reply line ("OK ..." or "ERR ...") into out, without the '\n'; closes fd. */
static void control_reply(int fd, char *out, size_t size)
{
        for (;;) {
                ssize_t n = harness_read_until(fd, out, size, '\n', WAIT_MS);

                assert_true(n > 0);
                if (strncmp(out, "DATA ", 5) != 0)
                        break;
        }
        out[strcspn(out, "\n")] = '\0';
        close(fd);
}

/* ---------------------------------------------------------------------------------------------
 * Tests */

static const char link_serial[] =
        "  - name: veh\n"
        "    protocol: sharedlink\n"
        "    transport: serial\n"
        "    device: %s\n"
        "    address: B\n"
        "    peers:\n"
        "      - address: A\n"
        "        period_ms: 0\n"
        "        on_change: true\n"
        "        min_interval_ms: 0\n"
        "        stale_ms: 0\n"
        "        outbound: [CmdThrottle, CmdSteer]\n"
        "        inbound: [AutoGpsLat, AutoGpsLon]\n";

/* The test plays peer A on a pty master: frames in, values out, Q/R through the control socket,
 * unplug and recovery. */
static void test_peer_on_pty(void **state)
{
        struct it *t = *state;
        char links[YAML_MAX], reply[LINE_MAX_T];
        int fd;

        plug(t);
        snprintf(links, sizeof(links), link_serial, t->dev);
        start(t, links);
        expect_frame(t, ":AB|N0|D|D");         /* up: the full list at once */
        wait_state(t, 0, "up");

        /* Inbound: the spec example, checksum and all. */
        assert_int_equal(harness_write_all(t->master, "[:BA|RAutoGpsLat|D40.12345678|C24]\r\n",
                                           36, WAIT_MS), 0);
        wait_value(t, "AutoGpsLat", "40.12345678");
        send_frame(t->master, ":BA|N1|D-113.5");
        wait_value(t, "AutoGpsLon", "-113.5");
        assert_false(read_flags(t, "AutoGpsLon") & SL_FLAG_STALE);

        /* Outbound on change. */
        client_write(t, "CmdSteer", "12");
        expect_frame(t, ":AB|N1|D12");

        /* Q from the peer, answered by the daemon from the table. */
        send_frame(t->master, ":BA|QCmdSteer");
        expect_frame(t, ":AB|RCmdSteer|D12");

        /* Q through the control socket; the test answers as the peer. */
        fd = control_send(t, "query veh A AutoGpsHead 5000\n");
        expect_frame(t, ":AB|QAutoGpsHead");
        send_frame(t->master, ":BA|RAutoGpsHead|D85.6");
        control_reply(fd, reply, sizeof(reply));
        assert_string_equal(reply, "OK 85.6");
        wait_value(t, "veh.A.AutoGpsHead", "85.6");     /* and stored, ad hoc */
        /* No answer: ETIMEDOUT; a bad peer: EINVAL. */
        fd = control_send(t, "query veh A Nothing 200\n");
        expect_frame(t, ":AB|QNothing");
        control_reply(fd, reply, sizeof(reply));
        assert_true(strncmp(reply, "ERR 110 ", 8) == 0);
        fd = control_send(t, "query veh C AutoGpsLat\n");
        control_reply(fd, reply, sizeof(reply));
        assert_true(strncmp(reply, "ERR 22 ", 7) == 0);

        /* Unplug: down, stale, ENOTCONN; plug back: up, the full list at once. */
        unplug(t);
        wait_state(t, 0, "down");
        assert_true(read_flags(t, "AutoGpsLat") & SL_FLAG_STALE);
        fd = control_send(t, "query veh A AutoGpsLat\n");
        control_reply(fd, reply, sizeof(reply));
        assert_true(strncmp(reply, "ERR 107 ", 8) == 0);
        plug(t);
        wait_state(t, 0, "up");
        expect_frame(t, ":AB|N0|D|D12");
        send_frame(t->master, ":BA|N0|D41");
        wait_value(t, "AutoGpsLat", "41");
        assert_false(read_flags(t, "AutoGpsLat") & SL_FLAG_STALE);
}

/* Two links of one daemon back to back over a pty: node_a makes it, node_b opens it. */
static void test_back_to_back(void **state)
{
        static const char fmt[] =
                "  - name: node_a\n"
                "    protocol: sharedlink\n"
                "    transport: pty\n"
                "    device: %s/node-a.tty\n"
                "    address: A\n"
                "    peers:\n"
                "      - address: B\n"
                "        period_ms: 100\n"
                "        on_change: true\n"
                "        outbound: [a.AutoGpsLat, a.AutoGpsLon]\n"
                "        inbound: [a.CmdThrottle]\n"
                "  - name: node_b\n"
                "    protocol: sharedlink\n"
                "    transport: serial\n"
                "    device: %s/node-a.tty\n"
                "    address: B\n"
                "    peers:\n"
                "      - address: A\n"
                "        period_ms: 100\n"
                "        on_change: true\n"
                "        outbound: [b.CmdThrottle]\n"
                "        inbound: [b.AutoGpsLat, b.AutoGpsLon]\n";
        struct it *t = *state;
        char links[YAML_MAX], reply[LINE_MAX_T];
        int fd;

        snprintf(links, sizeof(links), fmt, t->h.dir, t->h.dir);
        start(t, links);
        wait_state(t, 0, "up");
        wait_state(t, 1, "up");
        client_write(t, "a.AutoGpsLat", "40.12345678");
        client_write(t, "a.AutoGpsLon", "-113.12345678");
        client_write(t, "b.CmdThrottle", "25");
        wait_value(t, "b.AutoGpsLat", "40.12345678");
        wait_value(t, "b.AutoGpsLon", "-113.12345678");
        wait_value(t, "a.CmdThrottle", "25");
        assert_false(read_flags(t, "b.AutoGpsLat") & SL_FLAG_STALE);

        /* Q/R round trip across the two links: node_b asks node_a. */
        fd = control_send(t, "query node_b A a.AutoGpsLon\n");
        control_reply(fd, reply, sizeof(reply));
        assert_string_equal(reply, "OK -113.12345678");
        /* A name node_a does not know: the empty answer ("OK " and nothing). */
        fd = control_send(t, "query node_b A NoSuchName\n");
        control_reply(fd, reply, sizeof(reply));
        assert_true(strcmp(reply, "OK ") == 0 || strcmp(reply, "OK") == 0);
}

/* A UDP link on loopback: the test is the remote. */
static void test_udp_loopback(void **state)
{
        static const char fmt[] =
                "  - name: pronto\n"
                "    protocol: sharedlink\n"
                "    transport: udp\n"
                "    local: \"127.0.0.1:0\"\n"
                "    remote: \"127.0.0.1:%u\"\n"
                "    address: B\n"
                "    peers:\n"
                "      - address: A\n"
                "        period_ms: 0\n"
                "        on_change: true\n"
                "        min_interval_ms: 0\n"
                "        stale_ms: 0\n"
                "        outbound: [veh_start]\n"
                "        inbound: [sys_speed]\n";
        struct it *t = *state;
        struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
        struct sockaddr_in from;
        socklen_t alen = sizeof(a), flen = sizeof(from);
        char links[YAML_MAX], buf[512], want[512];
        struct pollfd p;
        ssize_t n;
        size_t len;

        t->udp = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        assert_true(t->udp >= 0);
        assert_int_equal(bind(t->udp, (struct sockaddr *)&a, sizeof(a)), 0);
        assert_int_equal(getsockname(t->udp, (struct sockaddr *)&a, &alen), 0);
        snprintf(links, sizeof(links), fmt, ntohs(a.sin_port));
        start(t, links);

        /* Up: the full list, one datagram, no CR LF; it tells us the daemon's port. */
        p = (struct pollfd){ .fd = t->udp, .events = POLLIN };
        assert_int_equal(poll(&p, 1, WAIT_MS), 1);
        n = recvfrom(t->udp, buf, sizeof(buf) - 1, 0, (struct sockaddr *)&from, &flen);
        assert_true(n > 0);
        buf[n] = '\0';
        mkraw(want, sizeof(want), ":AB|N0|D", 0);
        assert_string_equal(buf, want);

        len = mkraw(buf, sizeof(buf), ":BA|N0|D12.5", 0);
        assert_int_equal(sendto(t->udp, buf, len, 0, (struct sockaddr *)&from, flen),
                         (ssize_t)len);
        wait_value(t, "sys_speed", "12.5");

        client_write(t, "veh_start", "1");
        assert_int_equal(poll(&p, 1, WAIT_MS), 1);
        n = recv(t->udp, buf, sizeof(buf) - 1, 0);
        assert_true(n > 0);
        buf[n] = '\0';
        mkraw(want, sizeof(want), ":AB|N0|D1", 0);
        assert_string_equal(buf, want);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_peer_on_pty, setup, teardown),
                cmocka_unit_test_setup_teardown(test_back_to_back, setup, teardown),
                cmocka_unit_test_setup_teardown(test_udp_loopback, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
