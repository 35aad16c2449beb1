/*
 * SharedLink links end to end: the real sharedlinkd (tests/common/harness.h), the test playing
 * the peer on pty masters and a loopback UDP socket, values checked through the client library,
 * queries through the control socket (raw requests, as the wire format in control.h says).
 * Frames from the daemon are decoded with the real codec (proto/sharedlink.h) and their checksum
 * recomputed; counters are read with `slctl stats --json` and compared with what the test sent.
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
#include <signal.h>
#include <stdbool.h>
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
#include "common/slwait.h"
#include "common/testdata.h"
#include "common/wire.h"
#include "proto/sharedlink.h"

#define START_MS        20000
#define WAIT_MS         10000
#define YAML_MAX        4096
#define LINE_MAX_T      1024
#define STATS_MAX       16384           /* `slctl stats --json` output */
#define POS_MAX         16              /* outbound positions a test list has */
#define MEM_MAX         8               /* buffers one test allocates through test_alloc() */
#define NOISE_BLOCK     (1024 * 1024)   /* the random block between valid frames */

struct it {
        struct harness h;
        struct sl_client *c;
        int master, slave;              /* the pty pair the daemon's serial link opens */
        char dev[HARNESS_PATH_MAX + 8];
        int udp;                        /* the test's UDP socket, -1 when none */
        uint16_t test_port;             /* its port: @PORT@ in the configuration */
        uint16_t udp_port;
        struct slp_decoder *dec;        /* the real codec, decoding what the daemon sends */
        uint8_t rbuf[4096];             /* bytes read from the master, not fed yet */
        size_t roff, rlen;
        size_t crlf_due;                /* bytes of the last frame's CR LF not checked yet */
        uint64_t frames_seen, bytes_seen;       /* what next_frame() got, CR LF included */
        void *mem[MEM_MAX];             /* test buffers, freed by teardown (also on failure) */
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
        harness_close_fd(&t->master);
        harness_close_fd(&t->slave);
        harness_close_fd(&t->udp);
        free(t->dec);
        for (int i = 0; i < MEM_MAX; i++)
                free(t->mem[i]);
        free(t);
        return 0;
}

/* Zeroed memory that teardown frees, so a failing assertion leaks nothing. */
static void *test_alloc(struct it *t, size_t size)
{
        for (int i = 0; i < MEM_MAX; i++)
                if (!t->mem[i]) {
                        t->mem[i] = calloc(1, size);
                        assert_non_null(t->mem[i]);
                        return t->mem[i];
                }
        fail_msg("test_alloc: more than %d buffers", MEM_MAX);
        return NULL;
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

/* Starts the daemon on tests/data/<file>, its links with @DEV@ (the pty), @DIR@ and @PORT@
 * replaced, under the test's instance and runtime dir. */
static void start(struct it *t, const char *file)
{
        char port[8], links[YAML_MAX], why[HARNESS_WHY_MAX];
        const char *const subst[] = { "@DEV@", t->dev, "@DIR@", t->h.dir, "@PORT@", port, NULL };

        snprintf(port, sizeof(port), "%u", t->test_port);
        assert_true(testdata_load(file, subst, links, sizeof(links)) > 0);
        if (harness_start_config(&t->h, "sl.yaml", links, START_MS, why, sizeof(why)) < 0)
                fail_msg("daemon did not start: %s", why);
        assert_int_equal(sl_open(t->h.instance, &t->c), 0);
}

/* Reads frames from the master until one equals want (CR LF stripped); fails on timeout. */
static void expect_frame(struct it *t, const char *text)
{
        char want[512], line[LINE_MAX_T];
        uint64_t deadline = harness_now_ns() + (uint64_t)WAIT_MS * 1000000u;

        wire_slp_raw(want, sizeof(want), text, 0);
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
        size_t n = wire_slp_raw(buf, sizeof(buf), text, 1);

        assert_int_equal(harness_write_all(fd, buf, n, WAIT_MS), 0);
}

/* Waits (on the change word) until name reads value. */
static void wait_value(struct it *t, const char *name, const char *value)
{
        char last[SL_VALUE_SIZE];

        if (slwait_value(t->c, name, value, WAIT_MS, last, sizeof(last)) < 0)
                fail_msg("%s never read %s (last \"%s\")", name, value, last);
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

/* The test plays peer A on a pty master: frames in, values out, Q/R through the control socket,
 * unplug and recovery. */
static void test_peer_on_pty(void **state)
{
        struct it *t = *state;
        char reply[LINE_MAX_T];
        int fd;

        plug(t);
        start(t, "sharedlink_peer_on_pty.yaml");
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
        struct it *t = *state;
        char reply[LINE_MAX_T];
        int fd;

        start(t, "sharedlink_back_to_back.yaml");
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
        struct it *t = *state;
        struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
        struct sockaddr_in from;
        socklen_t alen = sizeof(a), flen = sizeof(from);
        char buf[512], want[512];
        struct pollfd p;
        ssize_t n;
        size_t len;

        t->udp = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        assert_true(t->udp >= 0);
        assert_int_equal(bind(t->udp, (struct sockaddr *)&a, sizeof(a)), 0);
        assert_int_equal(getsockname(t->udp, (struct sockaddr *)&a, &alen), 0);
        t->test_port = ntohs(a.sin_port);
        start(t, "sharedlink_udp_loopback.yaml");

        /* Up: the full list, one datagram, no CR LF; it tells us the daemon's port. */
        p = (struct pollfd){ .fd = t->udp, .events = POLLIN };
        assert_int_equal(poll(&p, 1, WAIT_MS), 1);
        n = recvfrom(t->udp, buf, sizeof(buf) - 1, 0, (struct sockaddr *)&from, &flen);
        assert_true(n > 0);
        buf[n] = '\0';
        wire_slp_raw(want, sizeof(want), ":AB|N0|D", 0);
        assert_string_equal(buf, want);

        len = wire_slp_raw(buf, sizeof(buf), ":BA|N0|D12.5", 0);
        assert_int_equal(sendto(t->udp, buf, len, 0, (struct sockaddr *)&from, flen),
                         (ssize_t)len);
        wait_value(t, "sys_speed", "12.5");

        client_write(t, "veh_start", "1");
        assert_int_equal(poll(&p, 1, WAIT_MS), 1);
        n = recv(t->udp, buf, sizeof(buf) - 1, 0);
        assert_true(n > 0);
        buf[n] = '\0';
        wire_slp_raw(want, sizeof(want), ":AB|N0|D1", 0);
        assert_string_equal(buf, want);
}

/* ---------------------------------------------------------------------------------------------
 * What the daemon sends, through the real codec (src/proto/sharedlink.h) */

/* The frame's own checksum, recomputed here: exactly two uppercase hex digits (PROTOCOLS.md
 * §1.3 Decision) equal to the 8-bit sum of ':' through 'C'. */
static void check_raw(const struct slp_frame *f)
{
        const char *raw = f->raw;
        size_t len = f->raw_len;
        unsigned want;

        assert_true(len >= 9);
        assert_int_equal(raw[0], '[');
        assert_int_equal(raw[len - 1], ']');
        assert_int_equal(raw[len - 5], '|');
        assert_int_equal(raw[len - 4], 'C');
        for (size_t i = len - 3; i < len - 1; i++)
                assert_true((raw[i] >= '0' && raw[i] <= '9') || (raw[i] >= 'A' && raw[i] <= 'F'));
        assert_int_equal(sscanf(raw + len - 3, "%2X", &want), 1);
        assert_int_equal(wire_slp_sum(raw + 1, len - 4), want);
        assert_int_equal(f->unknown_fields, 0);
        assert_int_equal(f->empty_fields, 0);
}

/* The next frame the daemon sent on the master, decoded by the real codec; any byte the codec
 * rejects fails the test, and so does a frame not followed by exactly CR LF (which the codec
 * would take as whitespace). Valid until the next call. */
static const struct slp_frame *next_frame(struct it *t)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)WAIT_MS * 1000000u;
        struct slp_decode_result r;

        if (!t->dec) {
                t->dec = malloc(sizeof(*t->dec));
                assert_non_null(t->dec);
                assert_int_equal(slp_decoder_init(t->dec, SLP_FRAME_MAX), 0);
        }
        for (;;) {
                struct pollfd p = { .fd = t->master, .events = POLLIN };
                uint64_t now = harness_now_ns();
                ssize_t n;

                for (; t->crlf_due > 0 && t->roff < t->rlen; t->crlf_due--)
                        assert_int_equal(t->rbuf[t->roff++], "\r\n"[2 - t->crlf_due]);
                while (t->crlf_due == 0 && t->roff < t->rlen) {
                        t->roff += slp_decoder_feed(t->dec, t->rbuf + t->roff, t->rlen - t->roff,
                                                    &r);
                        if (r.kind == SLP_RESULT_REJECT)
                                fail_msg("the daemon sent %zu bad bytes: %s", r.bytes,
                                         slp_decode_reason_str(r.reason));
                        if (r.kind == SLP_RESULT_FRAME) {
                                check_raw(r.frame);
                                t->crlf_due = 2;
                                t->frames_seen++;
                                t->bytes_seen += r.frame->raw_len + 2;
                                return r.frame;
                        }
                }
                if (now >= deadline)
                        fail_msg("no frame from the daemon");
                assert_true(poll(&p, 1, (int)((deadline - now) / 1000000u) + 1) >= 0);
                n = read(t->master, t->rbuf, sizeof(t->rbuf));
                if (n < 0 && errno == EAGAIN)
                        continue;
                assert_true(n > 0);
                t->roff = 0;
                t->rlen = (size_t)n;
        }
}

/* One pass of an outbound list as received: values by position, frames it took. */
struct list_rx {
        size_t nframes;
        size_t nonempty;                        /* positions sent with a value */
        char value[POS_MAX][SLP_VALUE_MAX + 1]; /* "" for an empty D */
        size_t first_n[POS_MAX];                /* the N of each frame */
};

/* Reads frames until positions 0..count-1 of a list from `src` to `dst` came once: the first
 * frame must start at N0, every frame has exactly one N, first, at the position where the
 * previous frame stopped; every frame fits max_frame with its CR LF. */
static void read_list(struct it *t, char dst, char src, size_t count, size_t max_frame,
                      struct list_rx *ret)
{
        size_t pos = 0;

        memset(ret, 0, sizeof(*ret));
        while (pos < count) {
                const struct slp_frame *f = next_frame(t);

                assert_int_equal(f->dst, dst);
                assert_int_equal(f->src, src);
                assert_true(f->raw_len + 2 <= max_frame);
                assert_true(f->nfields >= 2);
                assert_int_equal(f->fields[0].type, SLP_FIELD_N);
                assert_int_equal(f->fields[0].index, pos);
                assert_true(ret->nframes < POS_MAX);
                ret->first_n[ret->nframes++] = pos;
                for (size_t i = 1; i < f->nfields; i++) {
                        const struct slp_field *fd = &f->fields[i];

                        assert_int_equal(fd->type, SLP_FIELD_D);
                        assert_true(pos < count);
                        assert_true(fd->len <= SLP_VALUE_MAX);
                        memcpy(ret->value[pos], fd->value, fd->len);
                        ret->value[pos][fd->len] = '\0';
                        ret->nonempty += fd->len > 0;
                        pos++;
                }
        }
}

/* Expects the next frame to be exactly "N<n>|D<value>" from B to A. */
static void expect_single(struct it *t, uint32_t n, const char *value)
{
        const struct slp_frame *f = next_frame(t);

        assert_int_equal(f->dst, 'A');
        assert_int_equal(f->src, 'B');
        assert_int_equal(f->nfields, 2);
        assert_int_equal(f->fields[0].type, SLP_FIELD_N);
        assert_int_equal(f->fields[0].index, n);
        assert_int_equal(f->fields[1].type, SLP_FIELD_D);
        assert_int_equal(f->fields[1].len, strlen(value));
        assert_memory_equal(f->fields[1].value, value, strlen(value));
}

/* Runs `slctl a1 [a2 [a3]]` (NULL ends the list) and expects exit code 0; stdout to out. */
static void slctl(struct it *t, char *out, size_t size, const char *a1, const char *a2,
                  const char *a3)
{
        const char *argv[] = { harness_slctl_path(), a1, a2, a3, NULL };
        int r = harness_run(&t->h, out, size, WAIT_MS, argv);

        if (r != 0)
                fail_msg("slctl %s %s: exit %d: %s", a1, a2 ? a2 : "", r, out);
}

/* The link counter `name` from `slctl stats --json` (the first link's section). */
static uint64_t stat_of(const char *json, const char *name)
{
        const char *links = strstr(json, "\"links\"");
        char key[64];
        const char *p;

        assert_non_null(links);
        snprintf(key, sizeof(key), "\"%s\":", name);
        p = strstr(links, key);
        if (!p)
                fail_msg("no counter %s in %s", name, json);
        return strtoull(p + strlen(key), NULL, 10);
}

static void stats_json(struct it *t, char *out, size_t size)
{
        slctl(t, out, size, "stats", "--json", NULL);
}

/* ---------------------------------------------------------------------------------------------
 * More tests: the issue's list against the real daemon */

/* The PROTOCOLS.md §1.3 worked examples, verbatim, through the real daemon: the daemon is A,
 * the test is B. The list frame sets all four values, the compressed one only position 2, and
 * the query is answered with exactly the spec's answer frame. */
static void test_spec_examples(void **state)
{
        static const char list[] = "[:AB|N0|D40.12345678|D-113.12345678|D85.6|D22.1|CD4]\r\n";
        static const char compressed[] = "[:AB|N0|D|D|D85.7|D|C48]\r\n";
        static const char query[] = "[:AB|QAutoGpsLat|C2D]\r\n";
        static const char answer[] = "[:BA|RAutoGpsLat|D40.12345678|C24]";
        struct it *t = *state;
        char out[LINE_MAX_T];
        struct sl_meta meta = { .size = sizeof(meta) };
        char buf[SL_VALUE_SIZE];
        const struct slp_frame *f;

        plug(t);
        start(t, "sharedlink_spec_examples.yaml");
        wait_state(t, 0, "up");

        assert_int_equal(harness_write_all(t->master, list, strlen(list), WAIT_MS), 0);
        wait_value(t, "g.speed", "22.1");
        wait_value(t, "g.lat", "40.12345678");
        wait_value(t, "g.lon", "-113.12345678");
        wait_value(t, "g.head", "85.6");
        assert_true(sl_read(t->c, sl_find(t->c, "g.lon"), buf, sizeof(buf), &meta) >= 0);
        assert_true(meta.flags & SL_FLAG_VALID);
        assert_false(meta.flags & SL_FLAG_STALE);
        slctl(t, out, sizeof(out), "get", "g.lat", "g.lon");
        assert_string_equal(out, "40.12345678\n-113.12345678\n");

        /* Compressed: empty D leaves a value alone. */
        assert_int_equal(harness_write_all(t->master, compressed, strlen(compressed), WAIT_MS), 0);
        wait_value(t, "g.head", "85.7");
        slctl(t, out, sizeof(out), "get", "g.lat", "g.speed");
        assert_string_equal(out, "40.12345678\n22.1\n");

        /* The query; the daemon's answer is the spec's third example, byte for byte. The
         * on_change frame of the write (after the up list) says the daemon has the value. */
        client_write(t, "AutoGpsLat", "40.12345678");
        do
                f = next_frame(t);
        while (f->nfields != 2 || f->fields[1].len == 0);
        assert_int_equal(f->fields[0].type, SLP_FIELD_N);
        assert_int_equal(f->fields[0].index, 0);
        assert_memory_equal(f->fields[1].value, "40.12345678", 11);
        assert_int_equal(harness_write_all(t->master, query, strlen(query), WAIT_MS), 0);
        f = next_frame(t);
        if (f->raw_len != strlen(answer) || memcmp(f->raw, answer, f->raw_len) != 0)
                fail_msg("answer %.*s, want %s", (int)f->raw_len, f->raw, answer);
}

/* Periodic sending with compression, decoded frame by frame: max_frame 64 splits the full
 * list of six 10-byte values into N0 (4 values) and N4 (2 values); unchanged periods go as one
 * frame of six empty D; with period_ms 50 and refresh_ms 200 exactly every 4th list is full.
 * The cadence is counted in lists, never timed. */
static void test_periodic_split_compress_refresh(void **state)
{
        static const char *const vals[] = { "value0.123", "value1.123", "value2.123",
                                            "value3.123", "value4.123", "value5.123" };
        enum { COUNT = 6, LISTS = 13, MAX_FRAME = 64, EVERY = 4, SKIP_MAX = 40 };
        struct it *t = *state;
        struct list_rx lr;
        int first_full = -1, fulls = 0, i;

        plug(t);
        start(t, "sharedlink_periodic.yaml");
        wait_state(t, 0, "up");
        for (i = 0; i < COUNT; i++) {
                char name[16];

                snprintf(name, sizeof(name), "o%d", i);
                client_write(t, name, vals[i]);
        }
        /* Lists from before the writes carry only empty D; skip to the first with a value,
         * then to the first that is all empty again: every write has been sent by then. */
        for (i = 0; i < SKIP_MAX; i++) {
                read_list(t, 'A', 'B', COUNT, MAX_FRAME, &lr);
                if (lr.nonempty > 0)
                        break;
        }
        assert_true(i < SKIP_MAX);
        for (i = 0; i < SKIP_MAX; i++) {
                read_list(t, 'A', 'B', COUNT, MAX_FRAME, &lr);
                if (lr.nonempty == 0)
                        break;
        }
        assert_true(i < SKIP_MAX);

        for (i = 0; i < LISTS; i++) {
                read_list(t, 'A', 'B', COUNT, MAX_FRAME, &lr);
                if (lr.nonempty == 0) {
                        assert_int_equal(lr.nframes, 1);        /* six empty D fit in one */
                        if (first_full >= 0)
                                assert_int_not_equal((i - first_full) % EVERY, 0);
                        continue;
                }
                assert_int_equal(lr.nonempty, COUNT);           /* full: every value */
                assert_int_equal(lr.nframes, 2);
                assert_int_equal(lr.first_n[0], 0);
                assert_int_equal(lr.first_n[1], 4);
                for (int k = 0; k < COUNT; k++)
                        assert_string_equal(lr.value[k], vals[k]);
                if (first_full < 0)
                        first_full = i;
                assert_int_equal((i - first_full) % EVERY, 0);
                fulls++;
        }
        /* 13 lists after a compressed one hold 3 or 4 full ones, 4 apart. */
        assert_true(first_full >= 0 && first_full < EVERY);
        assert_int_equal(fulls, (LISTS - 1 - first_full) / EVERY + 1);
}

/* on_change with period_ms 60000: after the up list, no periodic frame can come during the
 * test, so a frame carrying the value after `slctl set` (and after sl_write) can only be the
 * on_change frame: exactly "N<pos>|D<value>". */
static void test_on_change_frame(void **state)
{
        struct it *t = *state;
        char out[STATS_MAX];
        struct list_rx lr;

        plug(t);
        start(t, "sharedlink_on_change.yaml");
        read_list(t, 'A', 'B', 3, SLP_FRAME_DEFAULT, &lr);      /* up: the full list */
        assert_int_equal(lr.nonempty, 0);
        assert_int_equal(lr.nframes, 1);

        slctl(t, out, sizeof(out), "set", "o1", "hello");
        expect_single(t, 1, "hello");
        client_write(t, "o2", "-7.25");
        expect_single(t, 2, "-7.25");
        client_write(t, "o0", "0");
        expect_single(t, 0, "0");

        /* The daemon counted exactly the frames and bytes the test decoded. bytes_out is
         * published with the channel's counters on receive, link up/down and heartbeat, so a
         * frame from the peer (its value seen) brings it up to date. */
        send_frame(t->master, ":BA|N0|D1");
        wait_value(t, "i0", "1");
        stats_json(t, out, sizeof(out));
        assert_int_equal(stat_of(out, "frames_out"), t->frames_seen);
        assert_int_equal(stat_of(out, "bytes_out"), t->bytes_seen);
        assert_int_equal(t->frames_seen, 4);
}

/* Garbage between valid frames: the counters the daemon should show, tallied by feeding every
 * byte the test sends through the real codec with the daemon's max_frame, mapped as
 * link_sharedlink.h documents (link B, its one peer A, two inbound positions). */
enum tally_counter {
        TC_FRAMES_IN, TC_BYTES_IN, TC_NOISE_BYTES, TC_BAD_CHECKSUM, TC_RESYNC, TC_OVERLONG,
        TC_BAD_HEADER, TC_BAD_ADDRESS, TC_BAD_FIELD, TC_UNKNOWN_FIELD, TC_EMPTY_FIELD,
        TC_LIST_MISMATCH, TC_NOT_FOR_US, TC_UNKNOWN_PEER, TC_COUNT
};

static const char *const tally_name[TC_COUNT] = {
        [TC_FRAMES_IN] = "frames_in", [TC_BYTES_IN] = "bytes_in",
        [TC_NOISE_BYTES] = "noise_bytes", [TC_BAD_CHECKSUM] = "bad_checksum",
        [TC_RESYNC] = "resync", [TC_OVERLONG] = "overlong", [TC_BAD_HEADER] = "bad_header",
        [TC_BAD_ADDRESS] = "bad_address", [TC_BAD_FIELD] = "bad_field",
        [TC_UNKNOWN_FIELD] = "unknown_field", [TC_EMPTY_FIELD] = "empty_field",
        [TC_LIST_MISMATCH] = "list_mismatch", [TC_NOT_FOR_US] = "not_for_us",
        [TC_UNKNOWN_PEER] = "unknown_peer",
};

#define TALLY_INBOUND   2

struct tally {
        struct slp_decoder dec;
        uint64_t c[TC_COUNT];
        size_t frames;                  /* valid frames seen, wherever they were going */
};

static void tally_frame(struct tally *y, const struct slp_frame *f)
{
        size_t pos = 0;

        y->frames++;
        y->c[TC_FRAMES_IN]++;
        if (f->dst != 'B') {
                y->c[TC_NOT_FOR_US]++;
                return;
        }
        if (f->src != 'A') {
                y->c[TC_UNKNOWN_PEER]++;
                return;
        }
        y->c[TC_UNKNOWN_FIELD] += f->unknown_fields;
        y->c[TC_EMPTY_FIELD] += f->empty_fields;
        for (size_t i = 0; i < f->nfields; i++) {
                if (f->fields[i].type == SLP_FIELD_N)
                        pos = f->fields[i].index;
                else if (f->fields[i].type == SLP_FIELD_D && pos++ >= TALLY_INBOUND)
                        y->c[TC_LIST_MISMATCH]++;
        }
}

static void tally_reject(struct tally *y, const struct slp_decode_result *r)
{
        switch (r->reason) {
        case SLP_REASON_NOISE:
                y->c[TC_NOISE_BYTES] += r->bytes;
                break;
        case SLP_REASON_RESYNC:
        case SLP_REASON_TRUNCATED:
                y->c[TC_RESYNC]++;
                break;
        case SLP_REASON_OVERLONG:
                y->c[TC_OVERLONG]++;
                break;
        case SLP_REASON_NO_CHECKSUM:
        case SLP_REASON_BAD_CHECKSUM_SYNTAX:
        case SLP_REASON_BAD_CHECKSUM:
                y->c[TC_BAD_CHECKSUM]++;
                break;
        case SLP_REASON_BAD_HEADER:
                y->c[TC_BAD_HEADER]++;
                break;
        case SLP_REASON_BAD_ADDRESS:
                y->c[TC_BAD_ADDRESS]++;
                break;
        default:
                y->c[TC_BAD_FIELD]++;
                break;
        }
}

/* Tallies buf, then writes it to the daemon. */
static void tally_send(struct it *t, struct tally *y, const void *buf, size_t len)
{
        const uint8_t *p = buf;
        size_t off = 0;

        y->c[TC_BYTES_IN] += len;
        while (off < len) {
                struct slp_decode_result r;

                off += slp_decoder_feed(&y->dec, p + off, len - off, &r);
                if (r.kind == SLP_RESULT_FRAME)
                        tally_frame(y, r.frame);
                else if (r.kind == SLP_RESULT_REJECT)
                        tally_reject(y, &r);
        }
        assert_int_equal(harness_write_all(t->master, buf, len, WAIT_MS), 0);
}

static void tally_frame_text(struct it *t, struct tally *y, const char *text)
{
        char buf[512];
        size_t n = wire_slp_raw(buf, sizeof(buf), text, 1);

        tally_send(t, y, buf, n);
}

/* A valid frame setting both inbound values to round-specific values, then waits for them. */
static void tally_round(struct it *t, struct tally *y, int round)
{
        char text[128], v0[16], v1[16];
        size_t before = y->frames;

        snprintf(v0, sizeof(v0), "r%d", round);
        snprintf(v1, sizeof(v1), "-%d.5", round);
        snprintf(text, sizeof(text), ":BA|N0|D%s|D%s", v0, v1);
        tally_frame_text(t, y, text);
        assert_int_equal(y->frames, before + 1);
        wait_value(t, "in0", v0);
        wait_value(t, "in1", v1);
}

/* Noise, bad checksums, an overlong frame, frames for another address and from an unknown peer,
 * unknown and empty fields, a D beyond the list, and 1 MiB of random bytes, each followed by a
 * valid frame: the daemon survives, applies every valid frame, and `slctl stats --json` shows
 * exactly the counts the real codec finds in what was sent. */
static void test_garbage_counters(void **state)
{
        static const char noise[] = "line noise \x01\x02\x7f\xff between frames";
        struct it *t = *state;
        struct tally *y = test_alloc(t, sizeof(*y));
        char buf[2048];
        char *json0 = test_alloc(t, STATS_MAX), *json1 = test_alloc(t, STATS_MAX);
        uint8_t *rnd = test_alloc(t, NOISE_BLOCK);
        uint64_t x = 0x9e3779b97f4a7c15u;
        size_t n, frames_before;
        int round = 0;

        assert_int_equal(slp_decoder_init(&y->dec, SLP_FRAME_DEFAULT), 0);
        plug(t);
        start(t, "sharedlink_garbage.yaml");
        wait_state(t, 0, "up");
        stats_json(t, json0, STATS_MAX);

        tally_round(t, y, ++round);
        tally_send(t, y, noise, sizeof(noise) - 1);
        tally_round(t, y, ++round);
        /* Bad checksum: a valid frame with its checksum's last digit changed. */
        n = wire_slp_raw(buf, sizeof(buf), ":BA|N0|Dbad|Dbad", 1);
        buf[n - 4] = buf[n - 4] == '0' ? '1' : '0';
        tally_send(t, y, buf, n);
        tally_frame_text(t, y, ":BA|N0|Dbad|Dbad|Cxy");         /* malformed checksum */
        tally_round(t, y, ++round);
        /* Overlong: longer than max_frame (1024); the rest of it is noise. */
        n = (size_t)snprintf(buf, sizeof(buf), "[:BA|N0|D");
        memset(buf + n, 'x', 1500);
        n += 1500;
        n += (size_t)snprintf(buf + n, sizeof(buf) - n, "|C00]\r\n");
        tally_send(t, y, buf, n);
        tally_round(t, y, ++round);
        /* Valid frames the daemon must ignore: for another node, from an unknown peer. */
        tally_frame_text(t, y, ":CA|N0|Dother|Dother");
        tally_frame_text(t, y, ":BD|N0|Dstranger|Dstranger");
        tally_round(t, y, ++round);
        /* Unknown and empty fields are skipped, the rest applies; a D beyond the list is
         * dropped. */
        tally_frame_text(t, y, ":BA|N0|Xfoo||Dunk0|Zbar|Dunk1|D2");
        wait_value(t, "in0", "unk0");
        wait_value(t, "in1", "unk1");
        tally_round(t, y, ++round);
        /* A bad header and a bad address, with good checksums. */
        tally_frame_text(t, y, "AB|N0|D1");
        tally_frame_text(t, y, ":BZ|N0|D1");
        tally_round(t, y, ++round);
        /* 1 MiB of random bytes (fixed seed: the same bytes every run). */
        for (size_t i = 0; i < NOISE_BLOCK; i++) {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                rnd[i] = (uint8_t)(x >> 24);
        }
        frames_before = y->frames;
        tally_send(t, y, rnd, NOISE_BLOCK);
        assert_int_equal(y->frames, frames_before);     /* no valid frame by chance */
        tally_round(t, y, ++round);
        tally_send(t, y, noise, sizeof(noise) - 1);
        tally_round(t, y, ++round);

        /* Alive, and the counters moved by exactly the tally. */
        assert_int_equal(kill(t->h.pid, 0), 0);
        stats_json(t, json1, STATS_MAX);
        for (int c = 0; c < TC_COUNT; c++) {
                uint64_t got = stat_of(json1, tally_name[c]) - stat_of(json0, tally_name[c]);

                if (got != y->c[c])
                        fail_msg("%s: daemon %llu, sent %llu", tally_name[c],
                                 (unsigned long long)got, (unsigned long long)y->c[c]);
        }
        print_message("sent %llu bytes: %llu frames, %llu noise bytes, %llu bad checksum, "
                      "%llu resync, %llu overlong, %llu bad header, %llu bad address, "
                      "%llu bad field\n", (unsigned long long)y->c[TC_BYTES_IN],
                      (unsigned long long)y->c[TC_FRAMES_IN],
                      (unsigned long long)y->c[TC_NOISE_BYTES],
                      (unsigned long long)y->c[TC_BAD_CHECKSUM],
                      (unsigned long long)y->c[TC_RESYNC], (unsigned long long)y->c[TC_OVERLONG],
                      (unsigned long long)y->c[TC_BAD_HEADER],
                      (unsigned long long)y->c[TC_BAD_ADDRESS],
                      (unsigned long long)y->c[TC_BAD_FIELD]);
        /* The tally is not trivially zero where the test meant to provoke something. */
        assert_true(y->c[TC_NOISE_BYTES] > NOISE_BLOCK / 4);
        assert_true(y->c[TC_BAD_CHECKSUM] >= 2);
        assert_true(y->c[TC_OVERLONG] >= 1);
        assert_int_equal(y->c[TC_NOT_FOR_US], 1);
        assert_int_equal(y->c[TC_UNKNOWN_PEER], 1);
        assert_int_equal(y->c[TC_LIST_MISMATCH], 1);
        assert_true(y->c[TC_UNKNOWN_FIELD] >= 2);
        assert_true(y->c[TC_EMPTY_FIELD] >= 1);
        assert_true(y->c[TC_BAD_HEADER] >= 1);
        assert_true(y->c[TC_BAD_ADDRESS] >= 1);
}

/* Waits (on the change word) until name's stale flag equals want. */
static void wait_stale(struct it *t, const char *name, bool want)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)WAIT_MS * 1000000u;
        uint32_t cursor = 0;

        while (harness_now_ns() < deadline) {
                if (!!(read_flags(t, name) & SL_FLAG_STALE) == want)
                        return;
                sl_wait(t->c, &cursor, 100);
        }
        fail_msg("%s never became %s", name, want ? "stale" : "fresh");
}

/* The `slctl list` line of name. */
static void list_line(struct it *t, const char *name, char *line, size_t size)
{
        char out[STATS_MAX];
        const char *p = out;

        slctl(t, out, sizeof(out), "list", NULL, NULL);
        for (;;) {
                size_t len = strcspn(p, "\n");

                if (strncmp(p, name, strlen(name)) == 0 && p[strlen(name)] == ' ') {
                        snprintf(line, size, "%.*s", (int)len, p);
                        return;
                }
                if (!p[len])
                        break;
                p += len + 1;
        }
        fail_msg("%s not in slctl list: %s", name, out);
}

/* Stale: the peer goes silent longer than stale_ms; its values turn stale (meta flag and
 * `slctl list`), and fresh again with its next frame. */
static void test_stale_and_fresh(void **state)
{
        struct it *t = *state;
        char line[LINE_MAX_T];

        plug(t);
        start(t, "sharedlink_stale.yaml");
        wait_state(t, 0, "up");
        send_frame(t->master, ":BA|N0|D7");
        wait_value(t, "in0", "7");
        wait_stale(t, "in0", false);

        /* Silence: nothing is sent until the flag is up. */
        wait_stale(t, "in0", true);
        list_line(t, "in0", line, sizeof(line));
        assert_non_null(strstr(line, "stale"));

        /* An empty D is "unchanged", not a fresh value: still stale. The Q in the same frame
         * is the event: once its answer is here, the whole frame has been applied. */
        send_frame(t->master, ":BA|N0|D|Qout0");
        {
                const struct slp_frame *f;

                do
                        f = next_frame(t);
                while (f->fields[0].type == SLP_FIELD_N);       /* the up list */
                assert_int_equal(f->fields[0].type, SLP_FIELD_R);
                assert_memory_equal(f->fields[0].value, "out0", 4);
        }
        assert_true(read_flags(t, "in0") & SL_FLAG_STALE);

        send_frame(t->master, ":BA|N0|D8");
        wait_value(t, "in0", "8");
        wait_stale(t, "in0", false);
        list_line(t, "in0", line, sizeof(line));
        assert_null(strstr(line, "stale"));
        assert_non_null(strstr(line, "valid"));
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_peer_on_pty, setup, teardown),
                cmocka_unit_test_setup_teardown(test_back_to_back, setup, teardown),
                cmocka_unit_test_setup_teardown(test_udp_loopback, setup, teardown),
                cmocka_unit_test_setup_teardown(test_spec_examples, setup, teardown),
                cmocka_unit_test_setup_teardown(test_periodic_split_compress_refresh, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_on_change_frame, setup, teardown),
                cmocka_unit_test_setup_teardown(test_garbage_counters, setup, teardown),
                cmocka_unit_test_setup_teardown(test_stale_and_fresh, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
