/*
 * Record and replay end to end (docs/recording.md): the real sharedlinkd on a pty pair with the
 * test playing the peer, `slctl record` writing the link's traffic to a file, then a fresh daemon
 * whose link has `transport: replay` on that file (speed max and 1.0). The inbound values (read
 * through the real library) and the link's receive counters must come out the same as in the
 * recorded run. Also: broken recordings refused with FILE:LINE: message (-n and at start), record
 * errors and permissions, a stalled recorder that must not stall the link (its drops counted and
 * marked), several recorders at once, and a CIRCE controller recorded and replayed.
 *
 * Waits are for events (a log line, a change word, a process exit) with timeouts.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <grp.h>
#include <poll.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>
#include <sharedlink.h>

#include "common/harness.h"
#include "common/wire.h"
#include "proto/recording.h"

#define START_MS        20000
#define WAIT_MS         10000
#define CONF_MAX        4096
#define PATH_BUF        (HARNESS_PATH_MAX + 64)
#define OUT_MAX         16384
#define FILE_MAX        (4u << 20)      /* a recording the tests read back */
#define FRAME_MAX       512
#define NOBODY_ID       65534
#define FLOOD_FRAMES    8000            /* about 550 KB through a link with a stalled recorder,
                                         * more than its socket buffer and queue hold */
#define RECORD_REQ      "record veh\n"

/* The configuration of the demo's node_b (conf/demo.yaml), on the test's pty or on a replay. */
static const char veh_links[] =
        "links:\n"
        "  - name: veh\n"
        "    protocol: sharedlink\n"
        "%s"
        "    baud: 115200\n"
        "    address: B\n"
        "    peers:\n"
        "      - address: A\n"
        "        period_ms: 100\n"
        "        refresh_ms: 1000\n"
        "        on_change: true\n"
        "        outbound:\n"
        "          - {name: CmdThrottle, type: long}\n"
        "          - {name: CmdSteer, type: long}\n"
        "        inbound:\n"
        "          - {name: AutoGpsLat, type: double}\n"
        "          - {name: AutoGpsLon, type: double}\n"
        "          - {name: AutoGpsHead, type: double}\n"
        "          - {name: AutoGpsVel, type: double}\n";

static const char *const veh_inbound[] = { "AutoGpsLat", "AutoGpsLon", "AutoGpsHead",
                                           "AutoGpsVel", NULL };

/* What the engine counts on receive: these must be the same after a replay. (bytes_in is
 * published lazily, at I/O bursts and heartbeats: not compared here.) */
static const char *const rx_counters[] = {
        "frames_in", "noise_bytes", "bad_checksum", "resync", "overlong",
        "bad_address", "bad_field", "unknown_field", "empty_field", "list_mismatch",
        "unknown_peer", "not_for_us", "queries_in", "bad_header", "unknown_op", "bad_value",
        "missing_param", "skipped_param", "repeated_param", NULL,
};

struct it {
        struct harness h;
        struct sl_client *c;
        int master, slave;
        char dev[PATH_BUF];
        char rec[PATH_BUF];             /* the recording */
        pid_t rec_pid;                  /* slctl record in the background, 0 when none */
        char rec_err[PATH_BUF];         /* its stderr */
        char *buf;                      /* FILE_MAX scratch */
};

struct snapshot {
        char values[8][SL_VALUE_SIZE];
        uint64_t counters[32];
};

static int setup(void **state)
{
        struct it *t = calloc(1, sizeof(*t));

        if (!t || harness_init(&t->h, "rp") < 0)
                return -1;
        t->h.capture_log = 1;
        t->master = t->slave = -1;
        t->buf = malloc(FILE_MAX + 1);
        if (!t->buf)
                return -1;
        snprintf(t->rec, sizeof(t->rec), "%s/veh.rec", t->h.dir);
        *state = t;
        return 0;
}

static int teardown(void **state)
{
        struct it *t = *state;

        if (t->rec_pid > 0) {
                kill(t->rec_pid, SIGKILL);
                waitpid(t->rec_pid, NULL, 0);
        }
        sl_close(t->c);
        harness_cleanup(&t->h);
        if (t->master >= 0)
                close(t->master);
        if (t->slave >= 0)
                close(t->slave);
        free(t->buf);
        free(t);
        return 0;
}

/* ---- helpers -------------------------------------------------------------------------------- */

/* A pty pair; the daemon's serial link opens the slave through <dir>/tty0. */
static void plug(struct it *t)
{
        char pts[HARNESS_PATH_MAX];

        snprintf(t->dev, sizeof(t->dev), "%s/tty0", t->h.dir);
        assert_int_equal(harness_openpty(&t->master, &t->slave, pts), 0);
        unlink(t->dev);
        assert_int_equal(symlink(pts, t->dev), 0);
}

/* Writes the configuration (links text after the instance) and starts the daemon on it, with a
 * fresh log. */
static void start(struct it *t, const char *links)
{
        char yaml[CONF_MAX * 2], path[PATH_BUF];
        int st = 0, r;

        sl_close(t->c);
        t->c = NULL;
        snprintf(yaml, sizeof(yaml), "instance: %s\nruntime_dir: %s\n%s", t->h.instance,
                 t->h.dir, links);
        assert_int_equal(harness_write_file(&t->h, "rp.yaml", yaml, path), 0);
        if (truncate(t->h.log_path, 0) < 0)
                assert_int_equal(errno, ENOENT);
        r = harness_start_daemon(&t->h, path, START_MS, &st, NULL);
        if (r < 0)
                fail_msg("daemon did not start: %s (status %d)", strerror(-r), st);
        assert_int_equal(sl_open(t->h.instance, &t->c), 0);
}

static void stop(struct it *t)
{
        int st = harness_stop_daemon(&t->h, SIGTERM, WAIT_MS);

        assert_true(st >= 0 && WIFEXITED(st) && WEXITSTATUS(st) == 0);
}

/* The veh configuration on the pty, or on the recording with speed. */
static void veh_config(struct it *t, char *out, size_t size, const char *speed)
{
        char transport[PATH_BUF * 4];

        if (speed)      /* device and baud stay: a replay takes the recorded transport's keys */
                snprintf(transport, sizeof(transport), "    transport: replay\n    file: %s\n"
                         "    speed: %s\n    device: %s\n", t->rec, speed, t->dev);
        else
                snprintf(transport, sizeof(transport), "    transport: serial\n    device: %s\n",
                         t->dev);
        snprintf(out, size, veh_links, transport);
}

/* Starts `slctl record [extra] LINK FILE` in the background, stderr to a file. */
static void record_start(struct it *t, const char *link, const char *extra)
{
        const char *argv[8];
        int n = 0;

        snprintf(t->rec_err, sizeof(t->rec_err), "%s/record.err", t->h.dir);
        argv[n++] = harness_slctl_path();
        argv[n++] = "record";
        if (extra)
                argv[n++] = extra;
        argv[n++] = link;
        argv[n++] = t->rec;
        argv[n] = NULL;
        t->rec_pid = fork();
        assert_true(t->rec_pid >= 0);
        if (t->rec_pid == 0) {
                int fd = open(t->rec_err, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
                union { const char *const *c; char *const *m; } u = { .c = argv };

                setenv("SHAREDLINK_RUNTIME_DIR", t->h.dir, 1);
                setenv("SHAREDLINK_INSTANCE", t->h.instance, 1);
                if (fd < 0 || dup2(fd, STDERR_FILENO) < 0)
                        _exit(126);
                execv(u.m[0], u.m);
                _exit(127);
        }
        assert_int_equal(harness_wait_log(&t->h, "recorder started", WAIT_MS), 0);
}

/* Stops the recorder with sig (0: waits for it to end by itself); returns its stderr. */
static const char *record_stop(struct it *t, int sig, char *err, size_t size)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)WAIT_MS * 1000000u;
        int st = 0, fd;
        ssize_t n;
        pid_t p;

        if (sig)
                assert_int_equal(kill(t->rec_pid, sig), 0);
        while ((p = waitpid(t->rec_pid, &st, WNOHANG)) == 0 && harness_now_ns() < deadline)
                poll(NULL, 0, 10);
        assert_int_equal(p, t->rec_pid);
        t->rec_pid = 0;
        fd = open(t->rec_err, O_RDONLY | O_CLOEXEC);
        assert_true(fd >= 0);
        n = read(fd, err, size - 1);
        close(fd);
        err[n > 0 ? n : 0] = '\0';
        if (!WIFEXITED(st) || WEXITSTATUS(st) != 0)
                fail_msg("slctl record: status %d: %s", st, err);
        return err;
}

static size_t read_file(const char *path, char *buf, size_t size)
{
        int fd = open(path, O_RDONLY | O_CLOEXEC);
        ssize_t n;

        assert_true(fd >= 0);
        n = read(fd, buf, size);
        close(fd);
        assert_true(n >= 0);
        buf[n] = '\0';
        return (size_t)n;
}

static void send_frame(struct it *t, const char *body)
{
        char buf[FRAME_MAX];
        size_t n = wire_slp_frame(buf, sizeof(buf), 'B', 'A', body, true);

        assert_int_equal(harness_write_all(t->master, buf, n, WAIT_MS), 0);
}

/* Reads and drops what the daemon wrote to the master, so its writes never block. */
static void drain(struct it *t)
{
        char junk[4096];

        while (read(t->master, junk, sizeof(junk)) > 0)
                ;
}

static uint64_t counter(const struct sl_link_info *li, const char *name)
{
        for (unsigned i = 0; i < li->counter_count; i++)
                if (strcmp(li->counters[i].name, name) == 0)
                        return li->counters[i].value;
        fail_msg("no counter %s", name);
        return 0;
}

static void link_info(struct it *t, struct sl_link_info *li)
{
        memset(li, 0, sizeof(*li));
        li->size = sizeof(*li);
        assert_int_equal(sl_link_info(t->c, 0, li), 0);
}

/* Waits until the link has counted n frames in. */
static void wait_frames_in(struct it *t, uint64_t n)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)WAIT_MS * 1000000u;
        struct sl_link_info li;
        uint32_t cursor = 0;

        while (harness_now_ns() < deadline) {
                drain(t);
                link_info(t, &li);
                if (counter(&li, "frames_in") >= n)
                        return;
                sl_wait(t->c, &cursor, 50);
        }
        fail_msg("frames_in never reached %llu", (unsigned long long)n);
}

static void wait_value(struct it *t, const char *name, const char *value)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)WAIT_MS * 1000000u;
        char buf[SL_VALUE_SIZE];
        uint32_t cursor = 0;

        while (harness_now_ns() < deadline) {
                int id = sl_find(t->c, name);

                drain(t);
                if (id >= 0 && sl_read(t->c, id, buf, sizeof(buf), NULL) >= 0 &&
                    strcmp(buf, value) == 0)
                        return;
                sl_wait(t->c, &cursor, 50);
        }
        fail_msg("%s never read %s", name, value);
}

static void snap(struct it *t, const char *const *names, const char *const *counters,
                 struct snapshot *s)
{
        struct sl_link_info li;

        memset(s, 0, sizeof(*s));
        for (int i = 0; names[i]; i++) {
                int id = sl_find(t->c, names[i]);

                assert_true(id >= 0);
                assert_true(sl_read(t->c, id, s->values[i], sizeof(s->values[i]), NULL) >= 0);
        }
        link_info(t, &li);
        for (int i = 0; counters[i]; i++)
                s->counters[i] = counter(&li, counters[i]);
}

static void snap_equal(const struct snapshot *a, const struct snapshot *b,
                       const char *const *names, const char *const *counters, const char *what)
{
        for (int i = 0; names[i]; i++)
                if (strcmp(a->values[i], b->values[i]) != 0)
                        fail_msg("%s: %s is \"%s\", recorded \"%s\"", what, names[i],
                                 b->values[i], a->values[i]);
        for (int i = 0; counters[i]; i++)
                if (a->counters[i] != b->counters[i])
                        fail_msg("%s: counter %s is %llu, recorded %llu", what, counters[i],
                                 (unsigned long long)b->counters[i],
                                 (unsigned long long)a->counters[i]);
}

/* Starts a replay daemon on the recording and waits for its end. */
static void replay(struct it *t, const char *speed)
{
        char links[CONF_MAX];
        struct sl_link_info li;

        veh_config(t, links, sizeof(links), speed);
        start(t, links);
        assert_int_equal(harness_wait_log(&t->h, "replay done", WAIT_MS), 0);
        assert_int_equal(harness_wait_log(&t->h, "end of recording", WAIT_MS), 0);
        link_info(t, &li);
        assert_memory_equal(li.state_name, "down", 4);
}

/* ---- tests ---------------------------------------------------------------------------------- */

/* Record the demo link's traffic from a peer, replay it twice: same values, same counters. */
static void test_record_replay_sharedlink(void **state)
{
        struct it *t = *state;
        struct snapshot rec, got;
        char links[CONF_MAX], err[1024], junk[] = "\x01garbage\xff";
        struct rec_reader *rd;
        size_t len;

        plug(t);
        veh_config(t, links, sizeof(links), NULL);
        start(t, links);
        record_start(t, "veh", NULL);

        send_frame(t, "N0|D40.5|D-105.25|D90|D1.5");
        wait_value(t, "AutoGpsVel", "1.5");
        send_frame(t, "N2|D180");               /* AutoGpsHead alone */
        wait_value(t, "AutoGpsHead", "180");
        /* Garbage, then a frame with a bad checksum, then one split over two writes. */
        assert_int_equal(harness_write_all(t->master, junk, sizeof(junk) - 1, WAIT_MS), 0);
        assert_int_equal(harness_write_all(t->master, "[:BA|N0|D1|C00]\r\n", 17, WAIT_MS), 0);
        {
                char buf[FRAME_MAX];
                size_t n = wire_slp_frame(buf, sizeof(buf), 'B', 'A', "N0|D41.25|D-106|D270|D2",
                                          true);

                assert_int_equal(harness_write_all(t->master, buf, 7, WAIT_MS), 0);
                assert_int_equal(harness_write_all(t->master, buf + 7, n - 7, WAIT_MS), 0);
        }
        wait_value(t, "AutoGpsVel", "2");
        snap(t, veh_inbound, rx_counters, &rec);
        assert_true(rec.counters[0] >= 3);      /* frames_in */
        assert_int_equal(rec.counters[2], 1);   /* bad_checksum */
        assert_true(rec.counters[1] > 0);       /* noise_bytes: the garbage */
        record_stop(t, SIGINT, err, sizeof(err));
        assert_non_null(strstr(err, "slctl: recorded "));
        stop(t);

        /* The file is a good recording, with the header and what the peer sent. */
        len = read_file(t->rec, t->buf, FILE_MAX);
        assert_memory_equal(t->buf, REC_HEADER "\n# link: veh\n", strlen(REC_HEADER) + 13);
        assert_non_null(strstr(t->buf, "\\x01garbage\\xff"));
        rd = calloc(1, sizeof(*rd));
        assert_non_null(rd);
        rec_reader_init(rd);
        len = (size_t)rec_parse_text(rd, t->buf, len, NULL, NULL);
        free(rd);
        assert_int_equal(len, 0);

        replay(t, "max");
        snap(t, veh_inbound, rx_counters, &got);
        snap_equal(&rec, &got, veh_inbound, rx_counters, "speed max");
        assert_int_equal(harness_log_contains(&t->h, "engine sent"), 1);
        stop(t);

        replay(t, "1.0");
        snap(t, veh_inbound, rx_counters, &got);
        snap_equal(&rec, &got, veh_inbound, rx_counters, "speed 1.0");
        stop(t);
}

/* A broken line: -n names FILE:LINE; at start the link fails with it, the daemon runs on. */
static void test_broken_recording(void **state)
{
        struct it *t = *state;
        char links[CONF_MAX], path[PATH_BUF], out[OUT_MAX], err[OUT_MAX], want[PATH_BUF + 64];
        char yaml[CONF_MAX * 2];
        const char *argv[] = { harness_daemon_path(), "-n", "-c", path, NULL };
        struct sl_link_info li;
        int fd;

        snprintf(t->dev, sizeof(t->dev), "%s/tty0", t->h.dir);
        assert_int_equal(harness_write_file(&t->h, "veh.rec",
                                            REC_HEADER "\n# link: veh\n0.000100 < [:BA|N0|D1\n"
                                            "0.000200 > x\n0.000300 < bad\\q\n", NULL), 0);
        veh_config(t, links, sizeof(links), "max");
        snprintf(yaml, sizeof(yaml), "instance: %s\nruntime_dir: %s\n%s", t->h.instance,
                 t->h.dir, links);
        assert_int_equal(harness_write_file(&t->h, "rp.yaml", yaml, path), 0);
        assert_int_equal(harness_run_capture(&t->h, out, sizeof(out), err, sizeof(err), WAIT_MS,
                                             argv), 1);
        snprintf(want, sizeof(want), "%s:5: bad escape", t->rec);
        if (!strstr(err, want))
                fail_msg("-n said \"%s\", not %s", err, want);

        /* Time going backwards on line 4. */
        assert_int_equal(harness_write_file(&t->h, "veh.rec", REC_HEADER "\n# x\n0.5 < A\n",
                                            NULL), 0);
        assert_int_equal(harness_run_capture(&t->h, out, sizeof(out), err, sizeof(err), WAIT_MS,
                                             argv), 1);
        snprintf(want, sizeof(want), "%s:3: time: 6 digits", t->rec);
        assert_non_null(strstr(err, want));

        /* Over the size limit (a sparse file): refused before it is read. */
        fd = open(t->rec, O_WRONLY | O_TRUNC | O_CLOEXEC);
        assert_true(fd >= 0);
        assert_int_equal(ftruncate(fd, (off_t)(64u << 20) + 1), 0);
        close(fd);
        assert_int_equal(harness_run_capture(&t->h, out, sizeof(out), err, sizeof(err), WAIT_MS,
                                             argv), 1);
        assert_non_null(strstr(err, "larger than 64 MiB"));

        /* At start: the daemon comes up, the link is down with the reason, no retries. */
        assert_int_equal(harness_write_file(&t->h, "veh.rec",
                                            REC_HEADER "\n0.000001 < A\n0.000002 ? B\n", NULL),
                         0);
        start(t, links);
        snprintf(want, sizeof(want), "%s:3: unknown direction", t->rec);
        assert_int_equal(harness_wait_log(&t->h, want, WAIT_MS), 0);
        link_info(t, &li);
        assert_memory_equal(li.state_name, "down", 4);
        assert_int_equal(counter(&li, "reopens"), 0);
        stop(t);
}

/* As uid nobody through a socket opened up: the daemon's own check answers ERR 13. */
static int record_as_nobody(const char *sock)
{
        pid_t pid = fork();
        int st;

        assert_true(pid >= 0);
        if (pid == 0) {
                char buf[256];
                int fd;

                if (setgroups(0, NULL) < 0 || setgid(NOBODY_ID) < 0 || setuid(NOBODY_ID) < 0)
                        _exit(10);
                fd = harness_connect_unix(sock);
                if (fd < 0)
                        _exit(11);
                if (harness_control_request(fd, "record veh", buf, sizeof(buf), WAIT_MS) < 0)
                        _exit(12);
                _exit(strcmp(buf, "ERR 13 permission denied\n") == 0 ? 0 : 13);
        }
        assert_int_equal(waitpid(pid, &st, 0), pid);
        return WIFEXITED(st) ? WEXITSTATUS(st) : 100;
}

/* Unknown link, bad usage, permissions; a stalled recorder does not stall the link. */
static void test_record_errors_and_slow_recorder(void **state)
{
        struct it *t = *state;
        char links[CONF_MAX], out[OUT_MAX], err[OUT_MAX], sock[PATH_BUF], body[128];
        const char *argv[] = { harness_slctl_path(), "record", "nosuch", t->rec, NULL };
        struct sl_link_info li;
        char *p, *reply = t->buf;
        int fd, sndbuf = 4096;
        size_t len = 0;

        plug(t);
        veh_config(t, links, sizeof(links), NULL);
        start(t, links);
        assert_int_equal(harness_run_capture(&t->h, out, sizeof(out), err, sizeof(err), WAIT_MS,
                                             argv), 1);
        assert_non_null(strstr(err, "no link named \"nosuch\""));
        assert_int_equal(access(t->rec, F_OK), -1);     /* nothing written */

        snprintf(sock, sizeof(sock), "%s/%s.sock", t->h.dir, t->h.instance);
        fd = harness_connect_unix(sock);
        assert_true(fd >= 0);
        assert_true(harness_control_request(fd, "record", out, sizeof(out), WAIT_MS) > 0);
        assert_memory_equal(out, "ERR 22 usage: record LINK", 25);
        close(fd);
        if (geteuid() == 0) {
                assert_int_equal(chmod(sock, 0666), 0);
                assert_int_equal(record_as_nobody(sock), 0);
                assert_int_equal(chmod(sock, 0660), 0);
        } else {
                print_message("not root: the refusal as another user is not tried\n");
        }

        /* One recorder that never reads (a small receive buffer), one slctl that does. */
        fd = harness_connect_unix(sock);
        assert_true(fd >= 0);
        assert_int_equal(setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &sndbuf, sizeof(sndbuf)), 0);
        assert_int_equal(write(fd, RECORD_REQ, strlen(RECORD_REQ)), (ssize_t)strlen(RECORD_REQ));
        assert_int_equal(harness_wait_log(&t->h, "recorder started", WAIT_MS), 0);
        assert_int_equal(truncate(t->h.log_path, 0), 0);
        record_start(t, "veh", NULL);
        for (int i = 1; i <= FLOOD_FRAMES; i++) {
                snprintf(body, sizeof(body), "N0|D%d.123456789|D-%d.987654321|D%d|D%d", i, i,
                         i % 360, i);
                send_frame(t, body);
                drain(t);
        }
        snprintf(body, sizeof(body), "%d", FLOOD_FRAMES);
        wait_value(t, "AutoGpsVel", body);
        wait_frames_in(t, FLOOD_FRAMES);
        link_info(t, &li);
        assert_int_equal(counter(&li, "frames_in"), FLOOD_FRAMES);
        assert_int_equal(counter(&li, "bad_checksum"), 0);

        /* The stalled one dropped chunks, counted; it was not taken for a dead client. */
        {
                int sfd = harness_connect_unix(sock);

                assert_true(sfd >= 0);
                assert_true(harness_control_request(sfd, "stats", out, sizeof(out), WAIT_MS) >
                            0);
                close(sfd);
        }
        p = strstr(out, "dropped=");
        assert_non_null(p);
        assert_true(strtoull(p + 8, NULL, 10) > 0);
        assert_non_null(strstr(out, "slow_readers=0"));
        assert_non_null(strstr(out, "recorders=2"));
        /* Once it reads again, the gap is marked in its stream. */
        while (!strstr(reply, "DATA # dropped ")) {
                ssize_t n;
                struct pollfd pf = { .fd = fd, .events = POLLIN };

                assert_true(poll(&pf, 1, WAIT_MS) == 1);
                n = read(fd, reply + len, FILE_MAX - len);
                assert_true(n > 0);
                len += (size_t)n;
                reply[len] = '\0';
                if (len > FILE_MAX / 2) {       /* keep the tail only */
                        memmove(reply, reply + len - 4096, 4096);
                        len = 4096;
                        reply[len] = '\0';
                }
        }
        close(fd);
        record_stop(t, SIGTERM, err, sizeof(err));
        assert_non_null(strstr(err, "slctl: recorded "));
        stop(t);
}

/* CIRCE: the demo's controller and mediator back to back; the controller link is recorded, then
 * replayed alone: the mediator and device values and the receive counters match. */
static void test_record_replay_circe(void **state)
{
        static const char *const names[] = {
                "agility.mediator.version", "agility.mediator.status",
                "agility.device.E1E1E1.capabilities", "agility.device.E1E1E1.signal",
                "agility.device.E1E1E1.battery", "agility.device.AAAAAA.capabilities", NULL,
        };
        static const char *const counters[] = {
                "frames_in", "bytes_in", "bad_checksum", "bad_header", "unknown_op", "bad_value",
                "missing_param", NULL,
        };
        struct it *t = *state;
        char links[CONF_MAX * 3], err[1024], arena[PATH_BUF];
        struct snapshot rec, got;
        static const char mediator[] =
                "  - name: arena\n"
                "    protocol: circe\n"
                "    role: mediator\n"
                "    transport: pty\n"
                "    device: %s\n"
                "    version: \"0.2.3\"\n"
                "    keepalive_ms: 750\n"
                "    emulate:\n"
                "      - {address: E1E1E1, capabilities: 32, signal: 150, battery: 200}\n"
                "      - {address: AAAAAA, capabilities: 31}\n";
        static const char controller[] =
                "  - name: agility\n"
                "    protocol: circe\n"
                "    role: controller\n"
                "    %s"
                "    device: %s\n";
        char part1[CONF_MAX], part2[CONF_MAX], tr[PATH_BUF * 2];

        snprintf(arena, sizeof(arena), "%s/arena.tty", t->h.dir);
        snprintf(t->rec, sizeof(t->rec), "%s/agility.rec", t->h.dir);
        /* The controller comes first: its link index is 0 in both runs. */
        snprintf(part1, sizeof(part1), controller, "transport: serial\n", arena);
        snprintf(part2, sizeof(part2), mediator, arena);
        snprintf(links, sizeof(links), "links:\n%s%s", part1, part2);
        start(t, links);
        record_start(t, "agility", NULL);
        {
                uint64_t deadline = harness_now_ns() + (uint64_t)WAIT_MS * 1000000u;
                char v[SL_VALUE_SIZE] = "";
                uint32_t cursor = 0;

                while (harness_now_ns() < deadline) {
                        int id = sl_find(t->c, "agility.device.AAAAAA.capabilities");

                        if (id >= 0 && sl_read(t->c, id, v, sizeof(v), NULL) >= 0 &&
                            strcmp(v, "31") == 0)
                                break;
                        sl_wait(t->c, &cursor, 50);
                }
                assert_string_equal(v, "31");
        }
        record_stop(t, SIGINT, err, sizeof(err));
        snap(t, names, counters, &rec);
        stop(t);
        /* Keep-alives go on while the recorder stops: the counters are compared with what the
         * recording holds (bytes_in: the sum of its "<" chunks), the values with the table. */
        {
                struct rec_reader *rd = calloc(1, sizeof(*rd));
                size_t len = read_file(t->rec, t->buf, FILE_MAX);
                uint64_t in_bytes = 0;
                const char *line = t->buf;

                assert_non_null(rd);
                rec_reader_init(rd);
                while (*line) {
                        const char *nl = strchr(line, '\n');

                        assert_non_null(nl);
                        if (rec_reader_line(rd, line, (size_t)(nl - line)) == 1 &&
                            rd->dir == REC_DIR_IN)
                                in_bytes += rd->len;
                        line = nl + 1;
                }
                assert_int_equal(rec_reader_end(rd), 0);
                free(rd);
                assert_true(len > 0 && in_bytes > 0);
                rec.counters[1] = in_bytes;     /* bytes_in as recorded */
        }
        snprintf(tr, sizeof(tr), "transport: replay\n    file: %s\n    speed: max\n", t->rec);
        snprintf(part1, sizeof(part1), controller, tr, arena);
        snprintf(links, sizeof(links), "links:\n%s", part1);
        start(t, links);
        assert_int_equal(harness_wait_log(&t->h, "replay done", WAIT_MS), 0);
        assert_int_equal(harness_wait_log(&t->h, "end of recording", WAIT_MS), 0);
        snap(t, names, counters, &got);
        /* frames_in: through bytes_in (the first daemon counted keep-alives after the stop). */
        assert_true(got.counters[0] > 0 && got.counters[0] <= rec.counters[0]);
        got.counters[0] = rec.counters[0];
        snap_equal(&rec, &got, names, counters, "circe replay");
        stop(t);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_record_replay_sharedlink, setup, teardown),
                cmocka_unit_test_setup_teardown(test_broken_recording, setup, teardown),
                cmocka_unit_test_setup_teardown(test_record_errors_and_slow_recorder, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_record_replay_circe, setup, teardown),
        };

        signal(SIGPIPE, SIG_IGN);
        return cmocka_run_group_tests(tests, NULL, NULL);
}
