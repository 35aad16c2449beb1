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
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>
#include <sharedlink.h>

#include "common/harness.h"
#include "common/slwait.h"
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
#define GAP_MS          150             /* between the frames of a recording with real gaps */
#define NS_PER_US       1000u
#define NS_PER_MS       1000000u
#define LOOP_PASSES     3               /* a looping replay is looked at after this many */
#define LOOP_END_S      "0.300000"      /* a looping recording's quiet tail, then over again */
#define HOUR_S          "3600.000000"   /* a recording that would take an hour at speed 1 */
#define REPLY_BUF       4096

/* The configuration of the demo's node_b (conf/demo.yaml), on the test's pty or on a replay. */
static const char veh_links[] =
        "links:\n"
        "  - name: veh\n"
        "    protocol: sharedlink\n"
        "%s"
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
 * published after each read's frames: snap() waits for that with a control round trip.) */
static const char *const rx_counters[] = {
        "frames_in", "bytes_in", "noise_bytes", "bad_checksum", "resync", "overlong",
        "bad_address", "bad_field", "unknown_field", "empty_field", "list_mismatch",
        "unknown_peer", "not_for_us", "queries_in", "bad_header", "unknown_op", "bad_value",
        "missing_param", "skipped_param", "repeated_param", NULL,
};

struct it {
        struct harness h;
        struct sl_client *c;
        int master, slave;
        int udp;                        /* the peer's UDP socket, -1 when none */
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
        t->master = t->slave = t->udp = -1;
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
        harness_close_fd(&t->master);
        harness_close_fd(&t->slave);
        harness_close_fd(&t->udp);
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
        char why[HARNESS_WHY_MAX];

        sl_close(t->c);
        t->c = NULL;
        if (truncate(t->h.log_path, 0) < 0)
                assert_int_equal(errno, ENOENT);
        if (harness_start_config(&t->h, "rp.yaml", links, START_MS, why, sizeof(why)) < 0)
                fail_msg("daemon did not start: %s", why);
        assert_int_equal(sl_open(t->h.instance, &t->c), 0);
}

static void stop(struct it *t)
{
        int st = harness_stop_daemon(&t->h, SIGTERM, WAIT_MS);

        assert_true(st >= 0 && WIFEXITED(st) && WEXITSTATUS(st) == 0);
}

/* Where the veh link is: the test's pty (serial), a UDP socket pair, or a replay of the
 * recording (which keeps the recorded transport's keys: a replay takes and ignores them). */
enum veh_wire { VEH_SERIAL, VEH_UDP };

struct veh_opts {
        enum veh_wire wire;
        const char *speed;              /* NULL: live; else a replay at this speed */
        bool loop;
        uint16_t port, peer_port;       /* VEH_UDP: the daemon's and the test's */
};

static void veh_config_with(struct it *t, char *out, size_t size, const struct veh_opts *o)
{
        char transport[PATH_BUF * 4], keys[PATH_BUF * 2];

        if (o->wire == VEH_UDP)
                snprintf(keys, sizeof(keys), "    local: \"127.0.0.1:%u\"\n"
                         "    remote: \"127.0.0.1:%u\"\n", o->port, o->peer_port);
        else
                snprintf(keys, sizeof(keys), "    device: %s\n    baud: 115200\n", t->dev);
        if (o->speed)
                snprintf(transport, sizeof(transport), "    transport: replay\n    file: %s\n"
                         "    speed: %s\n    loop: %s\n%s", t->rec, o->speed,
                         o->loop ? "true" : "false", keys);
        else
                snprintf(transport, sizeof(transport), "    transport: %s\n%s",
                         o->wire == VEH_UDP ? "udp" : "serial", keys);
        snprintf(out, size, veh_links, transport);
}

/* The veh configuration on the pty, or on the recording with speed. */
static void veh_config(struct it *t, char *out, size_t size, const char *speed)
{
        const struct veh_opts o = { .wire = VEH_SERIAL, .speed = speed };

        veh_config_with(t, out, size, &o);
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

/* A control round trip. The daemon runs one event loop: once it answers, what it did for the
 * input before (the values we saw, and the channel counters such as bytes_in that it publishes
 * right after them, in the same callback) is all in the tables. */
static void settle(struct it *t)
{
        char sock[sizeof(t->h.dir) + sizeof(t->h.instance) + 8], reply[REPLY_BUF];
        int fd;

        snprintf(sock, sizeof(sock), "%s/%s.sock", t->h.dir, t->h.instance);
        fd = harness_connect_unix(sock);
        assert_true(fd >= 0);
        assert_true(harness_control_request(fd, "ping", reply, sizeof(reply), WAIT_MS) > 0);
        close(fd);
        assert_memory_equal(reply, "OK", 2);
}

static void snap(struct it *t, const char *const *names, const char *const *counters,
                 struct snapshot *s)
{
        struct sl_link_info li;

        settle(t);
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

/* How many times the captured daemon log holds needle. */
static unsigned log_count(struct it *t, const char *needle)
{
        unsigned n = 0;
        const char *p = t->buf;

        read_file(t->h.log_path, t->buf, FILE_MAX);
        while ((p = strstr(p, needle)) != NULL) {
                n++;
                p += strlen(needle);
        }
        return n;
}

/* Appends a chunk line (at most REC_PIECE_MAX bytes) to a recording being written in text. */
static void rec_add(char *text, size_t size, uint64_t t_us, enum rec_dir dir, const void *data,
                    size_t len)
{
        char line[REC_LINE_MAX + 1];
        size_t used, n = strlen(text);

        assert_true(len <= REC_PIECE_MAX);
        rec_format_chunk(line, t_us, dir, false, data, len, &used);
        assert_int_equal(used, len);
        assert_true(n + strlen(line) + 2 < size);
        snprintf(text + n, size - n, "%s\n", line);
}

/* Appends the frame B<-A with body, CR LF included, received at t_us. */
static void rec_add_frame(char *text, size_t size, uint64_t t_us, const char *body)
{
        char buf[FRAME_MAX];
        size_t n = wire_slp_frame(buf, sizeof(buf), 'B', 'A', body, true);

        rec_add(text, size, t_us, REC_DIR_IN, buf, n);
}

/* rec_parse_text() callback: the time of the first and the last "<" chunk. */
struct in_span {
        uint64_t first_us, last_us;
        unsigned chunks;
};

static int take_span(void *arg, const struct rec_reader *r)
{
        struct in_span *sp = arg;

        if (r->dir != REC_DIR_IN)
                return 0;
        if (sp->chunks++ == 0)
                sp->first_us = r->last_t_us;
        sp->last_us = r->last_t_us;
        return 0;
}

/* Checks the recording t->rec and returns the span of its "<" chunks. */
static struct in_span rec_span(struct it *t)
{
        struct rec_reader *rd = calloc(1, sizeof(*rd));
        struct in_span sp = { 0, 0, 0 };
        size_t len = read_file(t->rec, t->buf, FILE_MAX);

        assert_non_null(rd);
        rec_reader_init(rd);
        assert_int_equal(rec_parse_text(rd, t->buf, len, take_span, &sp), 0);
        free(rd);
        return sp;
}

/* ---- tests ---------------------------------------------------------------------------------- */

/* Record the demo link's traffic from a peer, with real gaps between the frames, replay it twice:
 * same values, same counters (bytes_in too); at speed 1.0 no chunk comes before its time. */
static void test_record_replay_sharedlink(void **state)
{
        struct it *t = *state;
        struct snapshot rec, got;
        char links[CONF_MAX], err[1024], junk[] = "\x01garbage\xff";
        struct sl_meta meta = { .size = sizeof(meta) };
        struct rec_reader *rd;
        struct in_span span;
        uint64_t t0;
        size_t len;

        plug(t);
        veh_config(t, links, sizeof(links), NULL);
        start(t, links);
        record_start(t, "veh", NULL);

        /* The gaps make the recording span hundreds of ms, for the pace check below. */
        send_frame(t, "N0|D40.5|D-105.25|D90|D1.5");
        wait_value(t, "AutoGpsVel", "1.5");
        poll(NULL, 0, GAP_MS);
        send_frame(t, "N2|D180");               /* AutoGpsHead alone */
        wait_value(t, "AutoGpsHead", "180");
        poll(NULL, 0, GAP_MS);
        /* Garbage, then a frame with a bad checksum, then one split over two writes. */
        assert_int_equal(harness_write_all(t->master, junk, sizeof(junk) - 1, WAIT_MS), 0);
        assert_int_equal(harness_write_all(t->master, "[:BA|N0|D1|C00]\r\n", 17, WAIT_MS), 0);
        poll(NULL, 0, GAP_MS);
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
        assert_true(rec.counters[1] > 0);       /* bytes_in */
        assert_int_equal(rec.counters[3], 1);   /* bad_checksum */
        assert_true(rec.counters[2] > 0);       /* noise_bytes: the garbage */
        record_stop(t, SIGINT, err, sizeof(err));
        assert_non_null(strstr(err, "slctl: recorded "));
        stop(t);

        /* The file is a good recording, with the header and what the peer sent. */
        len = read_file(t->rec, t->buf, FILE_MAX);
        assert_memory_equal(t->buf, REC_HEADER "\n# link: veh\n", strlen(REC_HEADER) + 13);
        assert_non_null(strstr(t->buf, "\\x01garbage\\xff"));
        assert_non_null(strstr(t->buf, "\n# transport: serial\n"));
        rd = calloc(1, sizeof(*rd));
        assert_non_null(rd);
        rec_reader_init(rd);
        len = (size_t)rec_parse_text(rd, t->buf, len, NULL, NULL);
        free(rd);
        assert_int_equal(len, 0);
        span = rec_span(t);
        assert_true(span.last_us - span.first_us >= 3u * GAP_MS * 1000u);

        replay(t, "max");
        snap(t, veh_inbound, rx_counters, &got);
        snap_equal(&rec, &got, veh_inbound, rx_counters, "speed max");
        assert_int_equal(harness_log_contains(&t->h, "engine sent"), 1);
        stop(t);

        /* At 1.0 a chunk recorded at time T is played no sooner than T after the replay began
         * (after t0): the last value came at least span.last_us after t0. A lower bound only:
         * a busy machine may be later, never earlier. */
        t0 = harness_now_ns();
        replay(t, "1.0");
        snap(t, veh_inbound, rx_counters, &got);
        snap_equal(&rec, &got, veh_inbound, rx_counters, "speed 1.0");
        assert_true(sl_read(t->c, sl_find(t->c, "AutoGpsVel"), err, sizeof(err), &meta) >= 0);
        if (meta.mono_ns < t0 + span.last_us * NS_PER_US)
                fail_msg("speed 1.0: the last chunk came %llu us after the start, recorded at "
                         "%llu us", (unsigned long long)((meta.mono_ns - t0) / NS_PER_US),
                         (unsigned long long)span.last_us);
        stop(t);
}

/* speed: max does not wait for the recorded times: a recording an hour long plays at once. */
static void test_replay_max_does_not_wait(void **state)
{
        struct it *t = *state;
        char text[CONF_MAX] = REC_HEADER "\n# link: veh\n";
        struct snapshot got;
        static const char *const none[] = { NULL };

        rec_add_frame(text, sizeof(text), 1, "N0|D1|D2|D3|D4");
        rec_add_frame(text, sizeof(text), 1800u * 1000000u, "N2|D5");
        snprintf(text + strlen(text), sizeof(text) - strlen(text), HOUR_S " > x\n");
        assert_int_equal(harness_write_file(&t->h, "veh.rec", text, NULL), 0);
        snprintf(t->dev, sizeof(t->dev), "%s/tty0", t->h.dir);
        /* replay() waits WAIT_MS for the end: far less than the hour the recording spans. */
        replay(t, "max");
        snap(t, veh_inbound, none, &got);
        assert_string_equal(got.values[0], "1");
        assert_string_equal(got.values[2], "5");
        assert_string_equal(got.values[3], "4");
        stop(t);
}

/* loop: true plays the recording again and again: after n passes every receive counter is n
 * times one pass's, and the values are the recording's. */
static void test_replay_loop(void **state)
{
        struct it *t = *state;
        const struct veh_opts looping = { .wire = VEH_SERIAL, .speed = "1.0", .loop = true };
        char links[CONF_MAX], text[CONF_MAX] = REC_HEADER "\n# link: veh\n";
        uint64_t deadline = harness_now_ns() + (uint64_t)WAIT_MS * NS_PER_MS;
        struct snapshot one, got;
        uint32_t cursor = 0;
        unsigned done = 0;
        bool seen = false;

        /* Frames, noise before a frame, a bad checksum; every pass ends quiet (a ">" line). */
        rec_add_frame(text, sizeof(text), 1000, "N0|D40.5|D-105.25|D90|D1.5");
        rec_add(text, sizeof(text), 2000, REC_DIR_IN, "\x01junk[:BA|N0|D1|C00]\r\n", 22);
        rec_add_frame(text, sizeof(text), 3000, "N2|D180");
        snprintf(text + strlen(text), sizeof(text) - strlen(text), LOOP_END_S " > x\n");
        assert_int_equal(harness_write_file(&t->h, "veh.rec", text, NULL), 0);
        snprintf(t->dev, sizeof(t->dev), "%s/tty0", t->h.dir);

        /* One pass, not looping: what one pass counts. */
        replay(t, "max");
        snap(t, veh_inbound, rx_counters, &one);
        assert_int_equal(one.counters[0], 2);   /* frames_in */
        assert_int_equal(one.counters[3], 1);   /* bad_checksum */
        assert_true(one.counters[2] > 0);       /* noise_bytes */
        stop(t);

        veh_config_with(t, links, sizeof(links), &looping);
        start(t, links);
        assert_int_equal(harness_wait_log(&t->h, "looping", WAIT_MS), 0);
        /* Looked at between two passes: after `done` passes ended (the log says so at each
         * end), pass done + 1 has played all its frames, and the log still says done (no
         * further pass began while the counters were read). A pass that begins meanwhile
         * (a slow machine) only makes it look again. */
        while (!seen && harness_now_ns() < deadline) {
                struct sl_link_info li;

                done = log_count(t, "replay done");
                if (done < LOOP_PASSES - 1) {
                        sl_wait(t->c, &cursor, 50);
                        continue;
                }
                link_info(t, &li);
                if (counter(&li, "frames_in") < (done + 1) * one.counters[0]) {
                        sl_wait(t->c, &cursor, 50);
                        continue;
                }
                snap(t, veh_inbound, rx_counters, &got);
                seen = log_count(t, "replay done") == done;
        }
        assert_true(seen);
        for (int i = 0; rx_counters[i]; i++)
                one.counters[i] *= done + 1;
        snap_equal(&one, &got, veh_inbound, rx_counters, "looping");
        assert_int_equal(log_count(t, "end of recording"), 0);
        stop(t);
}

/* A UDP link: every datagram is one chunk, and the replay hands each to the engine as one
 * datagram again. A frame cut over two datagrams is two broken datagrams on UDP (a datagram
 * carries whole frames); played as a byte stream it would join into one good frame. */
static void test_record_replay_udp(void **state)
{
        struct it *t = *state;
        struct sockaddr_in daemon_addr = { .sin_family = AF_INET };
        struct sockaddr_in me = { .sin_family = AF_INET };
        socklen_t mlen = sizeof(me);
        struct veh_opts o = { .wire = VEH_UDP };
        char links[CONF_MAX], err[1024], buf[FRAME_MAX];
        struct snapshot rec, got;
        size_t n;
        int fd;

        /* The daemon's port: one the kernel had free a moment ago. */
        fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        me.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        assert_true(fd >= 0);
        assert_int_equal(bind(fd, (struct sockaddr *)&me, sizeof(me)), 0);
        assert_int_equal(getsockname(fd, (struct sockaddr *)&me, &mlen), 0);
        o.port = ntohs(me.sin_port);
        close(fd);
        t->udp = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        me.sin_port = 0;
        assert_true(t->udp >= 0);
        assert_int_equal(bind(t->udp, (struct sockaddr *)&me, sizeof(me)), 0);
        mlen = sizeof(me);
        assert_int_equal(getsockname(t->udp, (struct sockaddr *)&me, &mlen), 0);
        o.peer_port = ntohs(me.sin_port);
        daemon_addr.sin_port = htons(o.port);
        daemon_addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);

        veh_config_with(t, links, sizeof(links), &o);
        start(t, links);
        record_start(t, "veh", NULL);
#define SEND_DGRAM(p, len) \
        assert_int_equal(sendto(t->udp, (p), (len), 0, (struct sockaddr *)&daemon_addr, \
                                sizeof(daemon_addr)), (ssize_t)(len))
        n = wire_slp_frame(buf, sizeof(buf), 'B', 'A', "N0|D40.5|D-105.25|D90|D1.5", true);
        SEND_DGRAM(buf, n);
        wait_value(t, "AutoGpsVel", "1.5");
        /* The cut frame: a truncated frame, then noise; the values stay. */
        n = wire_slp_frame(buf, sizeof(buf), 'B', 'A', "N0|D7|D8|D9|D1", true);
        SEND_DGRAM(buf, 10);
        SEND_DGRAM(buf + 10, n - 10);
        /* Without CR LF, as a datagram may be. */
        n = wire_slp_frame(buf, sizeof(buf), 'B', 'A', "N2|D270", false);
        SEND_DGRAM(buf, n);
#undef SEND_DGRAM
        wait_value(t, "AutoGpsHead", "270");
        snap(t, veh_inbound, rx_counters, &rec);
        assert_string_equal(rec.values[0], "40.5");     /* the cut frame was not taken */
        assert_int_equal(rec.counters[0], 2);           /* frames_in */
        assert_int_equal(rec.counters[4], 1);           /* resync: the truncated frame */
        record_stop(t, SIGINT, err, sizeof(err));
        stop(t);
        read_file(t->rec, t->buf, FILE_MAX);
        assert_non_null(strstr(t->buf, "\n# transport: udp\n"));

        o.speed = "max";
        veh_config_with(t, links, sizeof(links), &o);
        start(t, links);
        assert_int_equal(harness_wait_log(&t->h, "as datagrams", WAIT_MS), 0);
        assert_int_equal(harness_wait_log(&t->h, "end of recording", WAIT_MS), 0);
        snap(t, veh_inbound, rx_counters, &got);
        snap_equal(&rec, &got, veh_inbound, rx_counters, "udp replay");
        /* Recorded in its turn, the replay says udp, not replay: that recording replays as
         * datagrams too. */
        snprintf(t->rec, sizeof(t->rec), "%s/again.rec", t->h.dir);
        record_start(t, "veh", "--duration=1");
        record_stop(t, 0, err, sizeof(err));
        read_file(t->rec, t->buf, FILE_MAX);
        assert_non_null(strstr(t->buf, "\n# transport: udp\n"));
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
        /* The whole reason, as docs/recording.md promises, in the link's state and in stats
         * (it was cut at 31 bytes: "down: /tmp/sltest.XXXXXX/veh.r"). */
        if (!strstr(li.state_text, want))
                fail_msg("link state \"%s\" lacks \"%s\"", li.state_text, want);
        {
                const char *stats[] = { harness_slctl_path(), "-i", t->h.instance, "stats",
                                        NULL };

                assert_int_equal(harness_run_capture(&t->h, out, sizeof(out), err, sizeof(err),
                                                     WAIT_MS, stats), 0);
                if (!strstr(out, want))
                        fail_msg("slctl stats said \"%s\", without \"%s\"", out, want);
        }
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
        char part1[CONF_MAX], part2[CONF_MAX], tr[PATH_BUF * 2], late[PATH_BUF];

        snprintf(arena, sizeof(arena), "%s/arena.tty", t->h.dir);
        snprintf(late, sizeof(late), "%s/late.tty", t->h.dir);
        snprintf(t->rec, sizeof(t->rec), "%s/agility.rec", t->h.dir);
        /* The controller comes first: its link index is 0 in both runs. It opens late.tty,
         * which leads to the mediator's pty only once the recorder listens: the whole session
         * is recorded, the login included (else a fast login could be over before). */
        snprintf(part1, sizeof(part1), controller, "transport: serial\n", late);
        snprintf(part2, sizeof(part2), mediator, arena);
        snprintf(links, sizeof(links), "links:\n%s%s", part1, part2);
        start(t, links);
        record_start(t, "agility", NULL);
        {
                char pts[PATH_BUF];
                ssize_t n = readlink(arena, pts, sizeof(pts) - 1);

                assert_true(n > 0);
                pts[n] = '\0';
                assert_int_equal(symlink(pts, late), 0);
        }
        assert_int_equal(slwait_value(t->c, "agility.device.AAAAAA.capabilities", "31", WAIT_MS,
                                      err, sizeof(err)), 0);
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
        snprintf(part1, sizeof(part1), controller, tr, late);
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
                cmocka_unit_test_setup_teardown(test_replay_max_does_not_wait, setup, teardown),
                cmocka_unit_test_setup_teardown(test_replay_loop, setup, teardown),
                cmocka_unit_test_setup_teardown(test_record_replay_udp, setup, teardown),
                cmocka_unit_test_setup_teardown(test_broken_recording, setup, teardown),
                cmocka_unit_test_setup_teardown(test_record_errors_and_slow_recorder, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_record_replay_circe, setup, teardown),
        };

        signal(SIGPIPE, SIG_IGN);
        return cmocka_run_group_tests(tests, NULL, NULL);
}
