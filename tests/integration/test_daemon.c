/*
 * sharedlinkd life cycle, end to end: the real daemon (build/asan) started by the harness on
 * temporary configs, pty links, a test NOTIFY_SOCKET and its control socket.
 *
 * Covered: -n on good and bad configs (positions, exit codes), usage; READY=1 with STATUS=;
 * SIGTERM/SIGINT clean stop (socket, shm objects, pty links removed); the control socket (ping,
 * stats, pipelining, unknown request, empty and binary lines, overlong line, unknown link,
 * protocol mismatch, half-closed client, connection limit, stale and foreign sockets,
 * permissions); runtime_dir creation; SIGHUP reload (changed link reopened, unchanged one
 * untouched, tables kept or recreated, recreated when the socket moves, bad config kept out); no
 * fd leak across reloads; a missing device recovering; no idle wakeups; WATCHDOG=1; a truncated
 * or scribbled outbound table recreated with no writer left to wake the daemon.
 */
#define _GNU_SOURCE     /* setgroups */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <errno.h>
#include <fcntl.h>
#include <grp.h>
#include <inttypes.h>
#include <poll.h>
#include <pwd.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <sharedlink.h>

#include "common/harness.h"
#include "common/shmtest.h"
#include "shm/slot.h"
#include "daemon/control.h"
#include "daemon/recorder.h"

#define T_START_MS      15000   /* READY=1 after start or reload (ASan build) */
#define T_REPLY_MS      5000    /* one control reply */
#define T_STOP_MS       10000
#define T_RECOVER_MS    20000   /* a link reopening: backoff up to 5 s, then a heartbeat */
#define T_HANGUP_MS     5000
#define T_RUN_MS        10000   /* a short program (-n, -V) */
#define T_WATCHDOG_USEC "400000"        /* WATCHDOG=1 every 200 ms */
#define T_QUIET_PINGS   5       /* watchdog pings that make a quiet interval */
#define CONFIG_MAX      8192
#define LINK_MAX        1024
#define REPLY_MAX       8192
#define CLIENTS_MAX     64      /* CONTROL_CLIENTS_MAX */
#define LINE_MAX_BYTES  1024    /* CTLP_LINE_MAX */
#define PATH_BUF        1024    /* any path built from the harness dir */
#define NOBODY_ID       65534
#define USERS           4       /* uids holding connections: enough to fill what users may */
#define USER_CONNECTIONS (CONTROL_CLIENTS_PER_UID + 4)  /* each tries this many */

/* ---------------------------------------------------------------------------------------------
 * Config text */

/* One SharedLink pty link (the daemon creates the pty and symlinks its slave at DIR/NAME.tty),
 * with one peer and one list each way; variable names are prefixed with the link name. */
static void sl_link(char *buf, size_t size, const char *dir, const char *name,
                    const char *transport, const char *dev, char addr, char peer,
                    unsigned period_ms, const char *extra_out)
{
        snprintf(buf, size,
                 "  - name: %s\n"
                 "    protocol: sharedlink\n"
                 "    transport: %s\n"
                 "    device: %s/%s\n"
                 "    address: %c\n"
                 "    peers:\n"
                 "      - address: %c\n"
                 "        period_ms: %u\n"
                 "        refresh_ms: 3600000\n"
                 "        stale_ms: 0\n"
                 "        outbound: [%s.out1, %s.out2%s]\n"
                 "        inbound: [%s.in1]\n",
                 name, transport, dir, dev, addr, peer, period_ms, name, name,
                 extra_out ? extra_out : "", name);
}

/* Writes "instance: <h->instance>" + top + "links:" + links into DIR/file. */
static void write_config(struct harness *h, const char *file, const char *top,
                         const char *links, char *ret_path)
{
        char text[CONFIG_MAX];

        snprintf(text, sizeof(text), "instance: %s\n%slinks:\n%s", h->instance, top ? top : "",
                 links);
        assert_int_equal(harness_write_file(h, file, text, ret_path), 0);
}

/* Two pty links p1 and p2 (A->B each), the usual test instance. */
static void two_links(struct harness *h, char *links, size_t size, unsigned p2_period,
                      const char *p2_extra)
{
        char a[LINK_MAX], b[LINK_MAX];

        sl_link(a, sizeof(a), h->dir, "p1", "pty", "p1.tty", 'A', 'B', 0, NULL);
        sl_link(b, sizeof(b), h->dir, "p2", "pty", "p2.tty", 'A', 'B', p2_period, p2_extra);
        snprintf(links, size, "%s%s", a, b);
}

static void socket_path(const struct harness *h, char *buf, size_t size)
{
        snprintf(buf, size, "%s/%s.sock", h->dir, h->instance);
}

static void shm_path(const struct harness *h, const char *suffix, char *buf, size_t size)
{
        snprintf(buf, size, "/dev/shm/sharedlink.%s.%s", h->instance, suffix);
}

static int path_exists(const char *path)
{
        struct stat st;

        return lstat(path, &st) == 0;
}

/* ---------------------------------------------------------------------------------------------
 * Fixtures */

static int setup(void **state)
{
        struct harness *h = calloc(1, sizeof(*h));

        if (!h || harness_init(h, "d") < 0)
                return -1;
        h->capture_log = 1;
        *state = h;
        return 0;
}

static int teardown(void **state)
{
        struct harness *h = *state;

        harness_cleanup(h);
        free(h);
        return 0;
}

/* Prints the captured daemon log (for a failure's context). */
static void print_log(struct harness *h)
{
        char buf[4096];
        FILE *f = fopen(h->log_path, "re");
        size_t n;

        if (!f)
                return;
        while ((n = fread(buf, 1, sizeof(buf) - 1, f)) > 0) {
                buf[n] = '\0';
                print_message("%s", buf);
        }
        fclose(f);
}

static void start_ok(struct harness *h, const char *config)
{
        int st = 0, r = harness_start_daemon(h, config, T_START_MS, &st, NULL);

        if (r < 0) {
                print_log(h);
                fail_msg("daemon did not become ready: %s (status 0x%x)", strerror(-r), st);
        }
}

static void stop_ok(struct harness *h, int sig)
{
        int st = harness_stop_daemon(h, sig, T_STOP_MS);

        assert_true(st >= 0);
        assert_true(WIFEXITED(st));
        assert_int_equal(WEXITSTATUS(st), 0);
}

static void reload_ok(struct harness *h)
{
        assert_int_equal(kill(h->pid, SIGHUP), 0);
        assert_int_equal(harness_wait_notify(h, "RELOADING=1", T_START_MS), 0);
        assert_int_equal(harness_wait_notify(h, "READY=1", T_START_MS), 0);
}

/* One request on a fresh connection. */
static void request(struct harness *h, const char *line, char *reply, size_t size)
{
        char path[PATH_BUF];
        int fd;

        socket_path(h, path, sizeof(path));
        fd = harness_connect_unix(path);
        assert_true(fd >= 0);
        assert_true(harness_control_request(fd, line, reply, size, T_REPLY_MS) > 0);
        close(fd);
}

static uint64_t ping_epoch(struct harness *h)
{
        char reply[REPLY_MAX];
        long pid;
        uint64_t epoch;

        request(h, "ping", reply, sizeof(reply));
        assert_int_equal(sscanf(reply, "OK %ld %" SCNu64, &pid, &epoch), 2);
        assert_int_equal(pid, h->pid);
        assert_true(epoch != 0);
        return epoch;
}

/* The value of "key=N" in a stats reply. */
static uint64_t stat_value(const char *reply, const char *key)
{
        char needle[64];
        const char *p;

        snprintf(needle, sizeof(needle), " %s=", key);
        p = strstr(reply, needle);
        assert_non_null(p);
        return strtoull(p + strlen(needle), NULL, 10);
}

/* ---------------------------------------------------------------------------------------------
 * -n, -V, usage */

static int run_daemon(struct harness *h, const char *a1, const char *a2, const char *a3,
                      char *out, size_t osize, char *err, size_t esize)
{
        const char *argv[5] = { harness_daemon_path(), a1, a2, a3, NULL };

        return harness_run_capture(h, out, osize, err, esize, T_RUN_MS, argv);
}

static void test_check_ok(void **state)
{
        struct harness *h = *state;
        char links[2 * LINK_MAX], path[PATH_BUF], out[PATH_BUF], err[1024];

        two_links(h, links, sizeof(links), 100, NULL);
        write_config(h, "good.yaml", NULL, links, path);
        assert_int_equal(run_daemon(h, "-n", "-c", path, out, sizeof(out), err, sizeof(err)), 0);
        assert_string_equal(out, "configuration OK\n");
        assert_string_equal(err, "");
        /* -n creates nothing. */
        snprintf(out, sizeof(out), "%s/p1.tty", h->dir);
        assert_false(path_exists(out));
}

struct bad_case {
        const char *name;
        const char *text;       /* after "instance: X\n" */
        const char *where;      /* "LINE:COL" or NULL (no position) */
        const char *message;
};

static const struct bad_case bad_cases[] = {
        { "unknown top key", "bogus: 1\nlinks: []\n", "2:1", "unknown key \"bogus\" at top level" },
        { "wrong type",
          "links:\n  - name: a\n    protocol: sharedlink\n    transport: pty\n"
          "    device: /tmp/x.tty\n    address: A\n    baud: fast\n",
          "8:11", "baud: expected an integer, got \"fast\"" },
        { "out of range",
          "links:\n  - name: a\n    protocol: sharedlink\n    transport: pty\n"
          "    device: /tmp/x.tty\n    address: A\n    baud: 50\n",
          "8:11", "baud 50 out of range (1200..4000000)" },
        { "yaml syntax", "links: [\n", "3:1", "did not find expected node content" },
        { "missing group",
          "group: nosuchgroup-sl\nlinks:\n  - name: a\n    protocol: sharedlink\n"
          "    transport: pty\n    device: /tmp/x.tty\n    address: A\n    peers:\n"
          "      - address: B\n        outbound: [v1]\n",
          "2:8", "group \"nosuchgroup-sl\" does not exist: create it (groupadd --system "
          "nosuchgroup-sl; for \"sharedlink\", systemd-sysusers once make install has put its "
          "sysusers.d file in place), or leave out group:\n" },
        { "pronto4 max_frame over what the clients read",
          "links:\n  - name: a\n    protocol: sharedlink\n    transport: pty\n"
          "    device: /tmp/x.tty\n    address: A\n    peers:\n"
          "      - address: B\n        dialect: pronto4\n        max_frame: 2048\n"
          "        inbound: learn\n",
          "11:20", "max_frame 2048 is more than a pronto4 peer reads" },
};

static void test_check_bad(void **state)
{
        struct harness *h = *state;
        char path[PATH_BUF], text[CONFIG_MAX], out[256], err[2048], want[2048];

        for (size_t i = 0; i < sizeof(bad_cases) / sizeof(bad_cases[0]); i++) {
                const struct bad_case *c = &bad_cases[i];
                int rc;

                snprintf(text, sizeof(text), "instance: %s\n%s", h->instance, c->text);
                assert_int_equal(harness_write_file(h, "bad.yaml", text, path), 0);
                rc = run_daemon(h, "-n", "-c", path, out, sizeof(out), err, sizeof(err));
                if (c->where)
                        snprintf(want, sizeof(want), "%s:%s: %s", path, c->where, c->message);
                else
                        snprintf(want, sizeof(want), "%s: %s", path, c->message);
                if (rc != 1 || strncmp(err, want, strlen(want)) != 0 || out[0])
                        fail_msg("case \"%s\": exit %d, stderr \"%s\", wanted \"%s...\"", c->name,
                                 rc, err, want);
        }
        /* A file that is not there. */
        snprintf(path, sizeof(path), "%s/none.yaml", h->dir);
        assert_int_equal(run_daemon(h, "-n", "-c", path, out, sizeof(out), err, sizeof(err)), 1);
        snprintf(want, sizeof(want), "%s: No such file or directory\n", path);
        assert_string_equal(err, want);
}

static void test_usage_version(void **state)
{
        struct harness *h = *state;
        char out[256], err[1024];

        assert_int_equal(run_daemon(h, "-V", NULL, NULL, out, sizeof(out), err, sizeof(err)), 0);
        assert_memory_equal(out, "sharedlinkd ", strlen("sharedlinkd "));
        assert_int_equal(run_daemon(h, "-x", NULL, NULL, out, sizeof(out), err, sizeof(err)), 2);
        assert_non_null(strstr(err, "usage: sharedlinkd"));
        assert_int_equal(run_daemon(h, "-n", "extra", NULL, out, sizeof(out), err, sizeof(err)),
                         2);
}

/* ---------------------------------------------------------------------------------------------
 * Start, status, stop */

static void test_start_status_stop(void **state)
{
        struct harness *h = *state;
        char links[2 * LINK_MAX], path[PATH_BUF], in[PATH_BUF], out[PATH_BUF], tty[PATH_BUF];
        struct stat st;

        two_links(h, links, sizeof(links), 100, NULL);
        write_config(h, "a.yaml", NULL, links, path);
        start_ok(h, path);
        assert_non_null(strstr(h->last_notify, "STATUS=2 of 2 links up"));

        socket_path(h, path, sizeof(path));
        assert_int_equal(lstat(path, &st), 0);
        assert_true(S_ISSOCK(st.st_mode));
        assert_int_equal(st.st_mode & 07777, 0660);
        shm_path(h, "in", in, sizeof(in));
        shm_path(h, "out", out, sizeof(out));
        assert_true(path_exists(in));
        assert_true(path_exists(out));
        snprintf(tty, sizeof(tty), "%s/p1.tty", h->dir);
        assert_true(path_exists(tty));

        stop_ok(h, SIGTERM);
        assert_int_equal(harness_wait_notify(h, "STOPPING=1", T_REPLY_MS), 0);
        assert_false(path_exists(path));
        assert_false(path_exists(in));
        assert_false(path_exists(out));
        assert_false(path_exists(tty));
        assert_int_equal(harness_log_contains(h, "stopped"), 1);
}

static void test_sigint(void **state)
{
        struct harness *h = *state;
        char links[2 * LINK_MAX], path[PATH_BUF];

        two_links(h, links, sizeof(links), 100, NULL);
        write_config(h, "a.yaml", NULL, links, path);
        start_ok(h, path);
        stop_ok(h, SIGINT);
        socket_path(h, path, sizeof(path));
        assert_false(path_exists(path));
}

/* runtime_dir from the file wins over $SHAREDLINK_RUNTIME_DIR and is made 0755 when missing. */
static void test_runtime_dir(void **state)
{
        struct harness *h = *state;
        char links[2 * LINK_MAX], top[PATH_BUF + 32], path[PATH_BUF + 128], dir[PATH_BUF];
        struct stat st;
        mode_t old;

        snprintf(dir, sizeof(dir), "%s/run/a", h->dir);
        snprintf(top, sizeof(top), "runtime_dir: %s\n", dir);
        two_links(h, links, sizeof(links), 100, NULL);
        write_config(h, "a.yaml", top, links, path);
        old = umask(077);               /* inherited: the daemon must not depend on it */
        start_ok(h, path);
        umask(old);
        assert_int_equal(stat(dir, &st), 0);
        assert_int_equal(st.st_mode & 07777, 0755);
        snprintf(path, sizeof(path), "%s/%s.sock", dir, h->instance);
        assert_int_equal(lstat(path, &st), 0);
        assert_int_equal(st.st_mode & 07777, 0660);
        socket_path(h, path, sizeof(path));
        assert_false(path_exists(path));
        stop_ok(h, SIGTERM);
}

/* ---------------------------------------------------------------------------------------------
 * Control socket */

static void start_two(struct harness *h)
{
        char links[2 * LINK_MAX], path[PATH_BUF];

        two_links(h, links, sizeof(links), 100, NULL);
        write_config(h, "a.yaml", NULL, links, path);
        start_ok(h, path);
}

struct reply_case {
        const char *request;
        const char *reply;      /* expected prefix */
};

static const struct reply_case reply_cases[] = {
        { "stats", "DATA loop wakeups=" },
        { "frobnicate now", "ERR 22 unknown request \"frobnicate\"" },
        { "", "ERR 22 empty request" },
        { "   ", "ERR 22 empty request" },
        { "ping extra", "ERR 22 usage: ping" },
        { "query", "ERR 22 usage: query LINK" },
        { "query nosuch B name", "ERR 2 no link named \"nosuch\"" },
        { "circe nosuch alert 123456", "ERR 2 no link named \"nosuch\"" },
        { "circe p1 alert 123456", "ERR 95 link p1 speaks sharedlink: circe is for circe links" },
        { "ping\x01", "ERR 22 request contains a byte outside printable ASCII" },
        { "ping\r", "OK " },    /* CRLF line ends are taken */
        /* Routed to the SharedLink engine of p1, whose peer B (nobody) never answers. */
        { "query p1 B p1.in1 200", "ERR 110 " },
};

static void test_control_requests(void **state)
{
        struct harness *h = *state;
        char reply[REPLY_MAX];

        start_two(h);
        ping_epoch(h);
        for (size_t i = 0; i < sizeof(reply_cases) / sizeof(reply_cases[0]); i++) {
                request(h, reply_cases[i].request, reply, sizeof(reply));
                if (strncmp(reply, reply_cases[i].reply, strlen(reply_cases[i].reply)) != 0)
                        fail_msg("request \"%s\": reply \"%s\", wanted \"%s...\"",
                                 reply_cases[i].request, reply, reply_cases[i].reply);
        }
        stop_ok(h, SIGTERM);
}

/* Several requests in one write are answered in order; a client that shuts its sending side
 * still gets every answer, then the daemon closes. */
static void test_control_pipeline(void **state)
{
        struct harness *h = *state;
        char path[PATH_BUF], buf[REPLY_MAX];
        const char *batch = "ping\nbogus\nquery nosuch B x\nping";     /* last without '\n' */
        int fd;

        start_two(h);
        socket_path(h, path, sizeof(path));
        fd = harness_connect_unix(path);
        assert_true(fd >= 0);
        assert_int_equal(harness_write_all(fd, batch, strlen(batch), T_REPLY_MS), 0);
        assert_int_equal(shutdown(fd, SHUT_WR), 0);
        assert_true(harness_read_until(fd, buf, sizeof(buf), '\n', T_REPLY_MS) > 0);
        assert_memory_equal(buf, "OK ", 3);
        assert_true(harness_read_until(fd, buf, sizeof(buf), '\n', T_REPLY_MS) > 0);
        assert_memory_equal(buf, "ERR 22 ", 7);
        assert_true(harness_read_until(fd, buf, sizeof(buf), '\n', T_REPLY_MS) > 0);
        assert_memory_equal(buf, "ERR 2 ", 6);
        assert_true(harness_read_until(fd, buf, sizeof(buf), '\n', T_REPLY_MS) > 0);
        assert_memory_equal(buf, "OK ", 3);
        assert_int_equal(harness_read_until(fd, buf, sizeof(buf), '\n', T_REPLY_MS), -EIO);
        close(fd);
        stop_ok(h, SIGTERM);
}

/* A line over CTLP_LINE_MAX is answered ERR 90 and the connection closed; the daemon goes on. */
static void test_control_overlong(void **state)
{
        struct harness *h = *state;
        char path[PATH_BUF], line[LINE_MAX_BYTES + 64], buf[REPLY_MAX];
        int fd;

        start_two(h);
        socket_path(h, path, sizeof(path));
        fd = harness_connect_unix(path);
        assert_true(fd >= 0);
        /* Exactly the limit (1023 bytes + '\n') is still a line: an unknown request. */
        memset(line, 'a', LINE_MAX_BYTES - 1);
        line[LINE_MAX_BYTES - 1] = '\0';
        assert_true(harness_control_request(fd, line, buf, sizeof(buf), T_REPLY_MS) > 0);
        assert_memory_equal(buf, "ERR 22 unknown request", 22);
        /* One more byte is too long. */
        memset(line, 'a', LINE_MAX_BYTES);
        line[LINE_MAX_BYTES] = '\0';
        assert_true(harness_control_request(fd, line, buf, sizeof(buf), T_REPLY_MS) > 0);
        assert_string_equal(buf, "ERR 90 request line too long\n");
        assert_int_equal(harness_read_until(fd, buf, sizeof(buf), '\n', T_REPLY_MS), -EIO);
        close(fd);
        request(h, "stats", buf, sizeof(buf));
        assert_int_equal(stat_value(buf, "overlong"), 1);
        ping_epoch(h);
        stop_ok(h, SIGTERM);
}

/* CONTROL_CLIENTS_MAX connections at once; one more is refused with a line; a slot freed is
 * taken again. */
static void test_control_clients_max(void **state)
{
        struct harness *h = *state;
        char path[PATH_BUF], buf[REPLY_MAX];
        int fds[CLIENTS_MAX], fd;

        start_two(h);
        socket_path(h, path, sizeof(path));
        for (int i = 0; i < CLIENTS_MAX; i++) {
                fds[i] = harness_connect_unix(path);
                assert_true(fds[i] >= 0);
                /* An answer proves the daemon accepted this one before the next. */
                assert_true(harness_control_request(fds[i], "ping", buf, sizeof(buf),
                                                    T_REPLY_MS) > 0);
        }
        fd = harness_connect_unix(path);
        assert_true(fd >= 0);
        assert_true(harness_read_until(fd, buf, sizeof(buf), '\n', T_REPLY_MS) > 0);
        assert_string_equal(buf, "ERR 87 too many control connections\n");
        assert_int_equal(harness_read_until(fd, buf, sizeof(buf), '\n', T_REPLY_MS), -EIO);
        close(fd);
        /* Freeing one slot: the daemon notices the close, then takes a new client. */
        close(fds[0]);
        fds[0] = -1;
        assert_true(harness_control_request(fds[1], "stats", buf, sizeof(buf), T_REPLY_MS) > 0);
        assert_int_equal(stat_value(buf, "refused_full"), 1);
        fd = harness_connect_unix(path);
        assert_true(fd >= 0);
        assert_true(harness_control_request(fd, "ping", buf, sizeof(buf), T_REPLY_MS) > 0);
        assert_memory_equal(buf, "OK ", 3);
        close(fd);
        for (int i = 1; i < CLIENTS_MAX; i++)
                close(fds[i]);
        stop_ok(h, SIGTERM);
}

/* In a child: become uid/gid with the given supplementary groups, connect, ping. Exit codes:
 * 0 OK, 1 ERR 13 then closed, 2 connect EACCES, 3+ anything else. */
static int ping_as(const char *path, uid_t uid, gid_t gid, const gid_t *groups, size_t ngroups)
{
        pid_t pid = fork();
        int st;

        assert_true(pid >= 0);
        if (pid == 0) {
                char buf[REPLY_MAX];
                int fd;

                if (setgroups(ngroups, groups) < 0 || setgid(gid) < 0 || setuid(uid) < 0)
                        _exit(10);
                fd = harness_connect_unix(path);
                if (fd == -EACCES)
                        _exit(2);
                if (fd < 0)
                        _exit(11);
                if (harness_control_request(fd, "ping", buf, sizeof(buf), T_REPLY_MS) < 0)
                        _exit(12);
                if (!strncmp(buf, "OK ", 3))
                        _exit(0);
                if (strcmp(buf, "ERR 13 permission denied\n") != 0)
                        _exit(13);
                _exit(harness_read_until(fd, buf, sizeof(buf), '\n', T_REPLY_MS) == -EIO ? 1 : 14);
        }
        assert_int_equal(waitpid(pid, &st, 0), pid);
        assert_true(WIFEXITED(st));
        return WEXITSTATUS(st);
}

static void test_control_permissions(void **state)
{
        struct harness *h = *state;
        char links[2 * LINK_MAX], top[128], path[PATH_BUF], buf[REPLY_MAX];
        struct group *gr = getgrgid(0);
        gid_t root_group = 0;

        if (geteuid() != 0) {
                print_message("not root: cannot play another user\n");
                skip();
        }
        assert_non_null(gr);
        snprintf(top, sizeof(top), "group: %s\n", gr->gr_name);
        two_links(h, links, sizeof(links), 100, NULL);
        write_config(h, "a.yaml", top, links, path);
        start_ok(h, path);
        socket_path(h, path, sizeof(path));

        /* The file mode keeps strangers out before the daemon sees them... */
        assert_int_equal(ping_as(path, NOBODY_ID, NOBODY_ID, NULL, 0), 2);
        /* ...and behind it the peer credentials do: with the mode opened up, ERR 13. */
        assert_int_equal(chmod(path, 0666), 0);
        assert_int_equal(ping_as(path, NOBODY_ID, NOBODY_ID, NULL, 0), 1);
        /* A member of the group through a supplementary group is served. */
        assert_int_equal(ping_as(path, NOBODY_ID, NOBODY_ID, &root_group, 1), 0);
        /* So is one whose primary group it is. */
        assert_int_equal(ping_as(path, NOBODY_ID, root_group, NULL, 0), 0);
        request(h, "stats", buf, sizeof(buf));
        assert_int_equal(stat_value(buf, "denied"), 1);
        stop_ok(h, SIGTERM);
}

/* The "key=N" counter of a fresh stats request. */
static uint64_t stat_now(struct harness *h, const char *key)
{
        char reply[REPLY_MAX];

        request(h, "stats", reply, sizeof(reply));
        return stat_value(reply, key);
}

/* Reads a recorder's header up to its last line ("# time: ..."): the recorder runs. */
static void read_record_header(int fd)
{
        char line[REPLY_MAX];

        do
                assert_true(harness_read_until(fd, line, sizeof(line), '\n', T_REPLY_MS) > 0);
        while (strncmp(line, "DATA # time:", 12) != 0);
}

/* `record LINK`, shutdown(SHUT_WR), close() (socat when its input ends) on a link that carries
 * nothing: the client and its recorder are gone from the very next request's stats, with no
 * other traffic. They were kept until a restart, and RECORDER_PER_LINK_MAX such clients filled
 * the link's recorders for good, so this goes one past that. No waiting: the daemon sees the
 * EOF (then the hangup) before the next connection's request, whose data came later and whose fd
 * is polled after this one's. */
static void test_control_half_closed_recorder(void **state)
{
        struct harness *h = *state;
        char path[PATH_BUF];
        int fd;

        start_two(h);
        socket_path(h, path, sizeof(path));
        for (unsigned i = 0; i <= RECORDER_PER_LINK_MAX; i++) {
                fd = harness_connect_unix(path);
                assert_true(fd >= 0);
                assert_int_equal(harness_write_all(fd, "record p1\n", 10, T_REPLY_MS), 0);
                read_record_header(fd);
                assert_int_equal(shutdown(fd, SHUT_WR), 0);
                /* Half-closed: still reading, so still served (this stats client is the 2nd). */
                assert_int_equal(stat_now(h, "clients"), 2);
                assert_int_equal(stat_now(h, "recorders"), 1);
                close(fd);
                assert_int_equal(stat_now(h, "clients"), 1);
                assert_int_equal(stat_now(h, "recorders"), 0);
        }
        assert_int_equal(stat_now(h, "started"), RECORDER_PER_LINK_MAX + 1);
        stop_ok(h, SIGTERM);
}

/* What a child holding control connections as another user saw. */
enum held_count { HELD_SERVED, HELD_USER, HELD_RESERVED, HELD_COUNTS };

struct holder {
        pid_t pid;
        unsigned got[HELD_COUNTS];
};

/* In a child as uid, in the daemon's group through a supplementary group: n connections, each
 * pinged; the served ones are kept open until the parent kills the child. Reports the counts
 * through a pipe, or exits 3+ on anything unexpected. */
static void hold_as(struct holder *hd, const char *path, uid_t uid, unsigned n)
{
        const gid_t member = 0;         /* the daemon's group in these tests: root's */
        pid_t parent = getpid();
        int report[2];
        ssize_t got;

        assert_int_equal(pipe2(report, O_CLOEXEC), 0);
        hd->pid = fork();
        assert_true(hd->pid >= 0);
        if (hd->pid == 0) {
                unsigned counts[HELD_COUNTS] = { 0 };
                char buf[REPLY_MAX];

                close(report[0]);
                if (setgroups(1, &member) < 0 || setgid(uid) < 0 || setuid(uid) < 0)
                        _exit(3);
                /* Dies with the test, also one that fails before it kills us (set after
                 * setuid, which clears it). */
                if (prctl(PR_SET_PDEATHSIG, SIGKILL) < 0 || getppid() != parent)
                        _exit(9);
                for (unsigned i = 0; i < n; i++) {
                        int fd = harness_connect_unix(path);

                        if (fd < 0)
                                _exit(4);
                        /* A refused one may be closed before the ping goes (EPIPE): its
                         * refusal line is read all the same. */
                        (void)!send(fd, "ping\n", 5, MSG_NOSIGNAL);
                        if (harness_read_until(fd, buf, sizeof(buf), '\n', T_REPLY_MS) <= 0)
                                _exit(8);
                        if (!strncmp(buf, "OK ", 3)) {
                                counts[HELD_SERVED]++;
                                continue;       /* held open */
                        }
                        if (strncmp(buf, "ERR 87 ", 7) != 0)
                                _exit(5);
                        if (strstr(buf, "from this user"))
                                counts[HELD_USER]++;
                        else if (strstr(buf, "kept for root"))
                                counts[HELD_RESERVED]++;
                        else
                                _exit(6);
                        close(fd);
                }
                if (write(report[1], counts, sizeof(counts)) != (ssize_t)sizeof(counts))
                        _exit(7);
                close(report[1]);
                for (;;)
                        pause();
        }
        close(report[1]);
        got = read(report[0], hd->got, sizeof(hd->got));
        close(report[0]);
        if (got != (ssize_t)sizeof(hd->got)) {
                int st = 0;

                waitpid(hd->pid, &st, 0);
                fail_msg("the child as uid %ld reported nothing: wait status 0x%x", (long)uid, st);
        }
}

static void release_holder(struct holder *hd)
{
        int st;

        assert_int_equal(kill(hd->pid, SIGKILL), 0);
        assert_int_equal(waitpid(hd->pid, &st, 0), hd->pid);
}

/* Group members under other uids try to fill the control socket with idle connections: each uid
 * gets CONTROL_CLIENTS_PER_UID, and together they never get the last CONTROL_CLIENTS_RESERVED
 * slots, so root's requests are still served (they were refused "too many control
 * connections"). Each refusal says why, and is counted. */
static void test_control_held_by_users(void **state)
{
        struct harness *h = *state;
        char links[2 * LINK_MAX], top[128], path[PATH_BUF], buf[REPLY_MAX];
        struct holder hd[USERS];
        const unsigned open_slots = CONTROL_CLIENTS_MAX - CONTROL_CLIENTS_RESERVED;
        unsigned served = 0, refused_user = 0, refused_reserved = 0;
        int fds[CONTROL_CLIENTS_RESERVED];

        if (geteuid() != 0) {
                print_message("not root: cannot play another user\n");
                skip();
        }
        snprintf(top, sizeof(top), "group: %s\n", getgrgid(0)->gr_name);
        two_links(h, links, sizeof(links), 100, NULL);
        write_config(h, "a.yaml", top, links, path);
        start_ok(h, path);
        socket_path(h, path, sizeof(path));

        for (unsigned u = 0; u < USERS; u++) {
                unsigned want = open_slots - served < CONTROL_CLIENTS_PER_UID ?
                                open_slots - served : CONTROL_CLIENTS_PER_UID;

                hold_as(&hd[u], path, NOBODY_ID - u, USER_CONNECTIONS);
                assert_int_equal(hd[u].got[HELD_SERVED], want);
                served += want;
                /* Over its own bound, or (the last one) over what is left to users. */
                if (want == CONTROL_CLIENTS_PER_UID)
                        refused_user += hd[u].got[HELD_USER];
                else
                        refused_reserved += hd[u].got[HELD_RESERVED];
                assert_int_equal(hd[u].got[HELD_USER] + hd[u].got[HELD_RESERVED],
                                 USER_CONNECTIONS - want);
        }
        assert_int_equal(served, open_slots);

        /* Root is served, in every slot that is left. */
        for (unsigned i = 0; i < CONTROL_CLIENTS_RESERVED; i++) {
                fds[i] = harness_connect_unix(path);
                assert_true(fds[i] >= 0);
                assert_true(harness_control_request(fds[i], "ping", buf, sizeof(buf),
                                                    T_REPLY_MS) > 0);
                assert_memory_equal(buf, "OK ", 3);
        }
        assert_true(harness_control_request(fds[0], "stats", buf, sizeof(buf), T_REPLY_MS) > 0);
        assert_int_equal(stat_value(buf, "refused_user"), refused_user);
        assert_int_equal(stat_value(buf, "refused_reserved"), refused_reserved);
        assert_true(refused_user > 0 && refused_reserved > 0);
        for (unsigned i = 0; i < CONTROL_CLIENTS_RESERVED; i++)
                close(fds[i]);
        for (unsigned u = 0; u < USERS; u++)
                release_holder(&hd[u]);
        stop_ok(h, SIGTERM);
}

/* A socket left by a dead daemon is replaced; one somebody listens on is not (exit 1, and the
 * listener keeps it). */
static void test_control_stale_and_live(void **state)
{
        struct harness *h = *state;
        char links[2 * LINK_MAX], config[PATH_BUF], path[PATH_BUF];
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        struct stat st;
        int fd, status = 0;

        two_links(h, links, sizeof(links), 100, NULL);
        write_config(h, "a.yaml", NULL, links, config);
        socket_path(h, path, sizeof(path));
        strcpy(sa.sun_path, path);

        /* Stale: bound, never listened, closed: connect() is refused. */
        fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        assert_int_equal(bind(fd, (struct sockaddr *)&sa, sizeof(sa)), 0);
        close(fd);
        start_ok(h, config);
        ping_epoch(h);
        stop_ok(h, SIGTERM);

        /* Live: somebody listens there. */
        fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        assert_int_equal(bind(fd, (struct sockaddr *)&sa, sizeof(sa)), 0);
        assert_int_equal(listen(fd, 4), 0);
        assert_int_equal(harness_start_daemon(h, config, T_START_MS, &status, NULL), -ECHILD);
        assert_true(WIFEXITED(status));
        assert_int_equal(WEXITSTATUS(status), 1);
        assert_int_equal(harness_log_contains(h, "another daemon answers on it"), 1);
        assert_int_equal(lstat(path, &st), 0);
        close(fd);
        /* Its tables went away with it. */
        shm_path(h, "in", path, sizeof(path));
        assert_false(path_exists(path));
}

/* A second daemon for a running instance refuses to start; the first one is not disturbed. */
static void test_second_daemon(void **state)
{
        struct harness *h = *state, h2;
        char links[2 * LINK_MAX], config[PATH_BUF], text[CONFIG_MAX];
        uint64_t epoch;
        int status = 0;

        start_two(h);
        epoch = ping_epoch(h);
        /* Same instance, other pty paths (so the config itself is fine). */
        assert_int_equal(harness_init(&h2, "d2"), 0);
        h2.capture_log = 1;
        two_links(&h2, links, sizeof(links), 100, NULL);
        snprintf(text, sizeof(text), "instance: %s\nlinks:\n%s", h->instance, links);
        assert_int_equal(harness_write_file(&h2, "b.yaml", text, config), 0);
        assert_int_equal(harness_start_daemon(&h2, config, T_START_MS, &status, NULL), -ECHILD);
        assert_true(WIFEXITED(status));
        assert_int_equal(WEXITSTATUS(status), 1);
        assert_int_equal(harness_log_contains(&h2, "another sharedlinkd runs this instance"), 1);
        harness_cleanup(&h2);
        assert_true(ping_epoch(h) == epoch);
        stop_ok(h, SIGTERM);
}

/* A group that does not exist fails a real start as it fails -n: exit 1, and the log says how
 * to create it (the reference configuration names "sharedlink", which make install's sysusers.d
 * file makes). */
static void test_missing_group_start(void **state)
{
        struct harness *h = *state;
        char links[2 * LINK_MAX], path[PATH_BUF];
        int status = 0;

        two_links(h, links, sizeof(links), 100, NULL);
        write_config(h, "a.yaml", "group: nosuchgroup-sl\n", links, path);
        assert_int_equal(harness_start_daemon(h, path, T_START_MS, &status, NULL), -ECHILD);
        assert_true(WIFEXITED(status));
        assert_int_equal(WEXITSTATUS(status), 1);
        assert_int_equal(harness_log_contains(h, "group \"nosuchgroup-sl\" does not exist: "
                                              "create it (groupadd --system nosuchgroup-sl"), 1);
}

static int orphan_answered(struct harness *h)
{
        char reply[REPLY_MAX];

        request(h, "stats", reply, sizeof(reply));
        return stat_value(reply, "orphaned") >= 1 && stat_value(reply, "orphan_answers") >= 1;
}

/* A client sends a query that the engine answers only later and leaves at once: the query is
 * still carried out, its answer goes nowhere, the daemon carries on. */
static void test_request_outlives_client(void **state)
{
        struct harness *h = *state;
        char path[PATH_BUF];
        const char *q = "query p1 B p1.in1 300\n";
        uint64_t deadline;
        int fd;

        start_two(h);
        socket_path(h, path, sizeof(path));
        fd = harness_connect_unix(path);
        assert_true(fd >= 0);
        assert_int_equal(harness_write_all(fd, q, strlen(q), T_REPLY_MS), 0);
        close(fd);
        /* The answer (ERR ETIMEDOUT after 300 ms) has no event of its own to wait on: look at
         * the counters in short slices until it was given. */
        deadline = harness_now_ns() + (uint64_t)T_REPLY_MS * 1000000u;
        while (!orphan_answered(h)) {
                assert_true(harness_now_ns() < deadline);
                poll(NULL, 0, 50);
        }
        ping_epoch(h);
        stop_ok(h, SIGTERM);
}

/* ---------------------------------------------------------------------------------------------
 * Reload */

struct held {
        int fd;                         /* our end of a link's pty slave */
        char target[256];               /* where its symlink pointed */
};

static void hold_pty(struct harness *h, const char *name, struct held *ret)
{
        char link[PATH_BUF];
        ssize_t n;

        snprintf(link, sizeof(link), "%s/%s", h->dir, name);
        n = readlink(link, ret->target, sizeof(ret->target) - 1);
        assert_true(n > 0);
        ret->target[n] = '\0';
        ret->fd = open(link, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
        assert_true(ret->fd >= 0);
}

/* start_two(), then the epoch of its tables, and both ptys held. */
static uint64_t start_two_held(struct harness *h, struct held *p1, struct held *p2)
{
        uint64_t epoch;

        start_two(h);
        epoch = ping_epoch(h);
        hold_pty(h, "p1.tty", p1);
        hold_pty(h, "p2.tty", p2);
        return epoch;
}

static void stop_two_held(struct harness *h, struct held *p1, struct held *p2)
{
        close(p1->fd);
        close(p2->fd);
        stop_ok(h, SIGTERM);
}

/* Rewrites a.yaml as two_links(period_ms, extra) under head (may be NULL) and reloads. */
static void reload_two(struct harness *h, const char *head, unsigned period_ms, const char *extra)
{
        char links[2 * LINK_MAX], path[PATH_BUF];

        two_links(h, links, sizeof(links), period_ms, extra);
        write_config(h, "a.yaml", head, links, path);
        reload_ok(h);
}

/* Waits for the daemon's end of a held pty to go away (the link was reopened): 1, or 0. */
static int hung_up(const struct held *p, int timeout_ms)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)timeout_ms * 1000000u;

        for (;;) {
                struct pollfd pf = { .fd = p->fd, .events = 0 };
                uint64_t now = harness_now_ns();
                int left = now >= deadline ? 0 : (int)((deadline - now) / 1000000u);

                if (poll(&pf, 1, left) > 0 && (pf.revents & POLLHUP))
                        return 1;
                if (left == 0)
                        return 0;
        }
}

static void pty_target(struct harness *h, const char *name, char *buf, size_t size)
{
        char link[PATH_BUF];
        ssize_t n;

        snprintf(link, sizeof(link), "%s/%s", h->dir, name);
        n = readlink(link, buf, size - 1);
        assert_true(n > 0);
        buf[n] = '\0';
}

/* Only p2's settings change: tables and p1 untouched, p2 reopened. */
static void test_reload_settings(void **state)
{
        struct harness *h = *state;
        char target[256];
        struct held p1, p2;
        uint64_t epoch;

        epoch = start_two_held(h, &p1, &p2);

        reload_two(h, NULL, 250, NULL);          /* p2: period 100 -> 250 */
        assert_true(hung_up(&p2, T_HANGUP_MS));
        pty_target(h, "p2.tty", target, sizeof(target));
        assert_string_not_equal(target, p2.target);
        assert_false(hung_up(&p1, 0));
        pty_target(h, "p1.tty", target, sizeof(target));
        assert_string_equal(target, p1.target);
        assert_true(ping_epoch(h) == epoch);
        assert_int_equal(harness_log_contains(h, "tables kept"), 1);
        assert_int_equal(harness_log_contains(h, "1 of 2 links restarted"), 1);

        /* The same file again: nothing restarts. */
        reload_ok(h);
        assert_int_equal(harness_wait_log(h, "0 of 2 links restarted", T_REPLY_MS), 0);
        stop_two_held(h, &p1, &p2);
}

/*
 * The socket moves (runtime_dir now in the file): the tables publish the path (layout 1.2), so
 * they are recreated, and a client that was never told any directory follows the socket.
 */
static void test_reload_socket_moves(void **state)
{
        struct harness *h = *state;
        char moved[PATH_BUF], head[PATH_BUF + 32], path[2 * PATH_BUF], reply[REPLY_MAX];
        struct sl_client *c = NULL;
        uint64_t epoch, now;
        long pid;

        start_two(h);
        epoch = ping_epoch(h);
        unsetenv("SHAREDLINK_RUNTIME_DIR");     /* of this process: the daemon's is h->dir */
        assert_int_equal(sl_open(h->instance, &c), 0);
        assert_int_equal(sl_request(c, "ping", 0, NULL, NULL, reply, sizeof(reply)), 0);

        snprintf(moved, sizeof(moved), "%s/moved", h->dir);
        snprintf(head, sizeof(head), "runtime_dir: %s\n", moved);
        reload_two(h, head, 100, NULL);
        assert_int_equal(harness_log_contains(h, "tables recreated"), 1);
        socket_path(h, path, sizeof(path));
        assert_false(path_exists(path));
        snprintf(path, sizeof(path), "%s/%s.sock", moved, h->instance);
        assert_true(path_exists(path));
        assert_int_equal(sl_request(c, "ping", 0, NULL, NULL, reply, sizeof(reply)), 0);
        assert_int_equal(sscanf(reply, "%ld %" SCNu64, &pid, &now), 2);
        assert_int_equal(pid, h->pid);
        assert_true(now != epoch);
        sl_close(c);
        stop_ok(h, SIGTERM);
}

/* A variable list changes: new tables (new epoch), every link restarted. */
static void test_reload_variables(void **state)
{
        struct harness *h = *state;
        struct held p1, p2;
        uint64_t epoch;

        epoch = start_two_held(h, &p1, &p2);
        reload_two(h, NULL, 100, ", p2.out3");
        assert_true(hung_up(&p1, T_HANGUP_MS));
        assert_true(hung_up(&p2, T_HANGUP_MS));
        assert_true(ping_epoch(h) != epoch);
        assert_int_equal(harness_log_contains(h, "tables recreated"), 1);
        stop_two_held(h, &p1, &p2);
}

/* A bad new config (syntax, a group that does not exist) keeps the old one running untouched. */
static void test_reload_bad(void **state)
{
        struct harness *h = *state;
        char path[PATH_BUF];
        struct held p1, p2;
        uint64_t epoch;

        epoch = start_two_held(h, &p1, &p2);

        assert_int_equal(harness_write_file(h, "a.yaml", "links: [\n", path), 0);
        reload_ok(h);
        assert_int_equal(harness_log_contains(h, "keeping the running configuration"), 1);
        assert_non_null(strstr(h->last_notify, "STATUS=2 of 2 links up"));

        reload_two(h, "group: nosuchgroup-sl\n", 250, NULL);
        assert_int_equal(harness_log_contains(h, "group \"nosuchgroup-sl\" does not exist"), 1);

        assert_false(hung_up(&p1, 0));
        assert_false(hung_up(&p2, 0));
        assert_true(ping_epoch(h) == epoch);
        stop_two_held(h, &p1, &p2);
}

/* Every kind of reload, several times: the daemon's fd count comes back to where it was. */
static void test_reload_no_fd_leak(void **state)
{
        struct harness *h = *state;
        char path[PATH_BUF], reply[REPLY_MAX];
        int before, after, fd;

        start_two(h);
        /* One connection for both counts: a connection closed just before a count may or may
         * not have been reaped by the daemon yet, which would make the count off by one. */
        socket_path(h, path, sizeof(path));
        fd = harness_connect_unix(path);
        assert_true(fd >= 0);
        assert_true(harness_control_request(fd, "ping", reply, sizeof(reply), T_REPLY_MS) > 0);
        before = harness_count_fds(h->pid);
        assert_true(before > 0);
        for (int round = 0; round < 3; round++) {
                reload_two(h, NULL, 200 + (unsigned)round, NULL);       /* one link */
                reload_two(h, NULL, 100, round % 2 ? ", p2.out3" : NULL);       /* tables */
                assert_int_equal(harness_write_file(h, "a.yaml", "links: [\n", path), 0);
                reload_ok(h);                                   /* refused */
        }
        reload_two(h, NULL, 100, NULL);
        assert_true(harness_control_request(fd, "ping", reply, sizeof(reply), T_REPLY_MS) > 0);
        after = harness_count_fds(h->pid);
        assert_int_equal(after, before);
        close(fd);
        stop_ok(h, SIGTERM);
}

/* ---------------------------------------------------------------------------------------------
 * Links that fail, idleness, watchdog */

/* A serial device that is not there: the daemon starts anyway, says the link is down, and
 * brings it up once the device appears. */
static void test_missing_device(void **state)
{
        struct harness *h = *state;
        char links[LINK_MAX], path[PATH_BUF], slave[256], dev[PATH_BUF];
        int m, s;

        sl_link(links, sizeof(links), h->dir, "s1", "serial", "dev.tty", 'B', 'A', 100, NULL);
        write_config(h, "a.yaml", NULL, links, path);
        start_ok(h, path);
        assert_non_null(strstr(h->last_notify, "STATUS=0 of 1 links up; s1: "));

        assert_int_equal(harness_openpty(&m, &s, slave), 0);
        snprintf(dev, sizeof(dev), "%s/dev.tty", h->dir);
        assert_int_equal(symlink(slave, dev), 0);
        assert_int_equal(harness_wait_notify(h, "STATUS=1 of 1 links up", T_RECOVER_MS), 0);
        ping_epoch(h);
        stop_ok(h, SIGTERM);
        close(m);
        close(s);
}

/*
 * No busy waiting: with nothing on the links and no client, the loop wakes only for its timers.
 * The quiet interval is counted in watchdog pings (WATCHDOG=1 every 200 ms), not timed; one
 * control connection is kept open so that measuring adds exactly one fd event (the second
 * request).
 */
static void test_idle_wakeups(void **state)
{
        struct harness *h = *state;
        char links[2 * LINK_MAX], path[PATH_BUF], r1[REPLY_MAX], r2[REPLY_MAX];
        uint64_t fd_events, timers, wakeups;
        int fd;

        two_links(h, links, sizeof(links), 0, NULL);            /* period 0: no periodic send */
        write_config(h, "a.yaml", NULL, links, path);
        setenv("WATCHDOG_USEC", T_WATCHDOG_USEC, 1);
        start_ok(h, path);
        unsetenv("WATCHDOG_USEC");
        assert_int_equal(harness_log_contains(h, "WATCHDOG=1 every 200 ms"), 1);

        socket_path(h, path, sizeof(path));
        fd = harness_connect_unix(path);
        assert_true(fd >= 0);
        assert_true(harness_control_request(fd, "stats", r1, sizeof(r1), T_REPLY_MS) > 0);
        /* Forget the pings sent before the first measure: count only those after it. */
        assert_int_equal(harness_wait_notify(h, "\x01", 0), -ETIMEDOUT);
        for (int i = 0; i < T_QUIET_PINGS; i++)
                assert_int_equal(harness_wait_notify(h, "WATCHDOG=1", T_REPLY_MS), 0);
        assert_true(harness_control_request(fd, "stats", r2, sizeof(r2), T_REPLY_MS) > 0);
        close(fd);

        fd_events = stat_value(r2, "fd_events") - stat_value(r1, "fd_events");
        timers = stat_value(r2, "timer_fires") - stat_value(r1, "timer_fires");
        wakeups = stat_value(r2, "wakeups") - stat_value(r1, "wakeups");
        print_message("quiet interval: %" PRIu64 " wakeups, %" PRIu64 " timer fires, %" PRIu64
                      " fd events\n", wakeups, timers, fd_events);
        assert_int_equal(stat_value(r2, "idle_wakeups") - stat_value(r1, "idle_wakeups"), 0);
        assert_int_equal(fd_events, 1);
        assert_true(timers >= T_QUIET_PINGS);
        /* Watchdog every 200 ms and heartbeat every 1000 ms: about 1.2 fires per ping; a timer
         * gone wild would be thousands. */
        assert_true(timers <= 2 * T_QUIET_PINGS + 2);
        assert_true(wakeups <= timers + fd_events);
        stop_ok(h, SIGTERM);
}

/*
 * Writes value to name through a client opened now, waiting (sl_wait, an event) while .out is
 * unusable: the daemon must recreate it on its own, with no writer left to wake it through .out.
 */
static void write_through(struct harness *h, const char *name, const char *value)
{
        struct sl_client *c;
        uint32_t cursor = 0;
        int id, r, tries = 0;

        assert_int_equal(sl_open(h->instance, &c), 0);
        id = sl_find(c, name);
        assert_true(id >= 0);
        sl_wait(c, &cursor, 0);
        while ((r = sl_write(c, id, value)) != 0) {
                assert_int_equal(r, -EAGAIN);                   /* .out unusable for now */
                assert_true(++tries < 4);
                assert_int_equal(sl_wait(c, &cursor, T_RECOVER_MS), 1); /* recreated */
        }
        sl_close(c);
}

/* Truncated (issue: a 0-byte .out stayed for minutes), then scribbled over: recreated both times. */
static void test_out_truncated_recovers(void **state)
{
        struct harness *h = *state;
        char links[2 * LINK_MAX], path[PATH_BUF], name[PATH_BUF];
        unsigned char junk[4096];
        int fd;

        two_links(h, links, sizeof(links), 100, NULL);
        write_config(h, "a.yaml", NULL, links, path);
        start_ok(h, path);
        write_through(h, "p1.out1", "1");
        snprintf(name, sizeof(name), "/sharedlink.%s.out", h->instance);

        /* No client has .out mapped now; someone empties it. */
        fd = shm_open(name, O_RDWR, 0);
        assert_true(fd >= 0);
        assert_int_equal(ftruncate(fd, 0), 0);
        close(fd);
        write_through(h, "p1.out1", "2");

        /* Random bytes over it, size kept. */
        for (size_t i = 0; i < sizeof(junk); i++)
                junk[i] = (unsigned char)(i * 131u + 7u);
        fd = shm_open(name, O_RDWR, 0);
        assert_true(fd >= 0);
        assert_true(write(fd, junk, sizeof(junk)) > 0);
        close(fd);
        write_through(h, "p2.out2", "3");
        assert_int_equal(harness_log_contains(h, "truncated or overwritten by a client"), 1);
        stop_ok(h, SIGTERM);
}

/* A daemon with two links, p1.out1 written once through the library, and both tables mapped
 * as a raw writer sees them (.out writable): the two tests below write p1.out1 by hand. */
struct raw_out {
        struct shmtest_view in, out;
        uint32_t index;                 /* p1.out1's directory entry */
};

static void raw_out_start(struct harness *h, struct raw_out *r)
{
        char links[2 * LINK_MAX], path[PATH_BUF], name[PATH_BUF];
        uint32_t count;

        two_links(h, links, sizeof(links), 100, NULL);
        write_config(h, "a.yaml", NULL, links, path);
        start_ok(h, path);
        write_through(h, "p1.out1", "1");
        snprintf(name, sizeof(name), "/sharedlink.%s.in", h->instance);
        r->in = shmtest_view_open(name, 0);
        snprintf(name, sizeof(name), "/sharedlink.%s.out", h->instance);
        r->out = shmtest_view_open(name, 1);
        assert_non_null(r->in.base);
        assert_non_null(r->out.base);
        count = atomic_load(&shmtest_in_header(&r->in)->count);
        for (r->index = 0; r->index < count; r->index++)
                if (strcmp(shmtest_in_dir(&r->in)[r->index].name, "p1.out1") == 0)
                        break;
        assert_true(r->index < count);
}

/* Writes value into p1.out1's .out slot as a writer does (claim, store, publish), with no mark
 * and no step of the change word; returns the slot's lock word after. */
static uint64_t raw_out_write(struct raw_out *r, const char *value)
{
        struct shm_slot *slot = shmtest_out_slot(&r->out,
                                                 shmtest_in_dir(&r->in)[r->index].out_slot);
        uint64_t word;

        assert_int_equal(shm_slot_claim(slot, (uint32_t)getpid(), &word), 0);
        shm_slot_store(slot, value, (uint32_t)strlen(value), SHM_SLOT_VALID | SHM_SLOT_OUTBOUND,
                       1, 2);
        assert_int_equal(shm_slot_publish(slot, word), 0);
        return shm_slot_word(slot);
}

static void raw_out_stop(struct harness *h, struct raw_out *r)
{
        shmtest_view_close(&r->out);
        shmtest_view_close(&r->in);
        stop_ok(h, SIGTERM);
}

/*
 * A write whose touched mark (layout 1.6) was lost, as a writer killed between its publish and
 * its mark leaves it: no mark, no bump of the change word, nobody to wake the daemon. Its scan at
 * the next heartbeat still takes it: the .in mirror ends up holding it (waited on through the
 * change word the daemon bumps when it mirrors, a bounded number of times).
 */
static void test_out_lost_mark_heartbeat(void **state)
{
        struct harness *h = *state;
        struct raw_out r;
        struct sl_client *c;
        uint32_t cursor = 0;
        uint64_t word;
        int tries = 0;

        raw_out_start(h, &r);
        assert_int_equal(sl_open(h->instance, &c), 0);
        sl_wait(c, &cursor, 0);
        word = raw_out_write(&r, "2");
        while (atomic_load(&shmtest_in_slot(&r.in, r.index)->source) != word) {
                assert_true(++tries < 4);
                assert_int_equal(sl_wait(c, &cursor, T_RECOVER_MS), 1);
        }
        sl_close(c);
        raw_out_stop(h, &r);
}

/*
 * Waits (bounded) until the daemon's wake thread sleeps having seen every step of .out's change
 * word: it sets SHM_OUT_WAITING with a CAS on the value it compared, after signalling the loop
 * for any change, and a writer's step clears the flag (shm/wake.h). Nothing wakes a waiter when
 * the flag is set, so this yields in a loop, as shmtest_thread_wait_asleep does.
 */
static void wait_wake_thread_asleep(struct shm_out_header *oh)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)T_REPLY_MS * 1000000u;

        while (!(atomic_load(&oh->change) & SHM_OUT_WAITING)) {
                assert_true(harness_now_ns() < deadline);
                sched_yield();
        }
}

/* Marks .out slot slot_index in the touched map (layout 1.6), as sl_write does after its publish. */
static void raw_out_touch(struct raw_out *r, uint32_t slot_index)
{
        struct shm_out_header *oh = r->out.base;

        atomic_fetch_or_explicit((_Atomic uint64_t *)((char *)r->out.base + oh->touched_offset) +
                                         slot_index / SHM_TOUCHED_WORD_BITS,
                                 (uint64_t)1 << (slot_index % SHM_TOUCHED_WORD_BITS),
                                 memory_order_release);
}

#define QUIET_TRIES     8       /* rounds a heartbeat may spoil before the test gives up */

/*
 * A control request sees the writes finished before it was sent: a write marked in the touched
 * map (layout 1.6) but whose wake-up has not come (here: none at all, the change word is not
 * bumped) is in the .in mirror by the time a request is answered. Without the catch-up before
 * each request, only the next heartbeat (up to 1 s later) would take it, and a `slctl query`
 * right after `slctl set` could answer the old value on a busy machine.
 *
 * Nothing else may take the write, or the test could not fail: before it the daemon is made
 * quiet (the wake thread asleep with every change seen, then two requests, the second sent
 * after the first's answer, so the loop round that found the wake-up's eventfd readable with the
 * first is over: the wake-up raw_out_start's write left is taken), and a round whose window
 * (from before the quieting to after the answer) saw a heartbeat, whose full scan takes every
 * write, is not counted: the heartbeat stamp did not move, or the round is played again with
 * another value (a heartbeat comes once a second; a round takes milliseconds).
 */
static void test_request_sees_earlier_writes(void **state)
{
        struct harness *h = *state;
        char reply[REPLY_MAX], value[16];
        struct raw_out r;
        struct shm_out_header *oh;
        _Atomic uint64_t *heartbeat;
        uint32_t slot_index;
        uint64_t word, before;
        int round = 0;

        raw_out_start(h, &r);
        oh = r.out.base;
        assert_true(oh->touched_words > 0);
        assert_true(oh->touched_offset + (uint64_t)oh->touched_words * sizeof(uint64_t) <=
                    r.out.size);
        heartbeat = &shmtest_in_header(&r.in)->heartbeat_ns;
        slot_index = shmtest_in_dir(&r.in)[r.index].out_slot;
        do {
                assert_true(++round <= QUIET_TRIES);
                before = atomic_load(heartbeat);
                wait_wake_thread_asleep(oh);
                request(h, "ping", reply, sizeof(reply));
                request(h, "ping", reply, sizeof(reply));
                /* The write and its mark, as sl_write makes them, but no step of the change
                 * word: no wake-up comes. */
                snprintf(value, sizeof(value), "%d", round + 1);
                word = raw_out_write(&r, value);
                raw_out_touch(&r, slot_index);
                request(h, "ping", reply, sizeof(reply));
                assert_memory_equal(reply, "OK ", 3);
        } while (atomic_load(heartbeat) != before);
        assert_int_equal(atomic_load(&shmtest_in_slot(&r.in, r.index)->source), word);
        raw_out_stop(h, &r);
}

#define HELD_WAITS      64      /* table changes a takeover may come after (hang guard) */

/* The stopped writer: claims p1.out1's slot, stores its length and first value word, as
 * shm_slot_store does, and stops itself there; continued, it stores the rest and publishes.
 * Exits 0 when the publish says the slot was taken over (-ECANCELED), else 1. */
static int stopped_writer_main(void *arg)
{
        struct shm_slot *slot = arg;
        uint64_t word;

        /* Never left stopped behind a test that failed. */
        if (prctl(PR_SET_PDEATHSIG, SIGKILL) < 0)
                return 2;
        if (shm_slot_claim(slot, (uint32_t)getpid(), &word) < 0)
                return 2;
        atomic_store(&slot->length, 16u);
        shm_slot_store_word(slot, 0, 0x3939393939393939ull);
        raise(SIGSTOP);
        shm_slot_store_word(slot, 1, 0x3939393939393939ull);
        atomic_store(&slot->flags, SHM_SLOT_VALID | SHM_SLOT_OUTBOUND);
        return shm_slot_publish(slot, word) == -ECANCELED ? 0 : 1;
}

/* The daemon's out_taken_over counter (what slctl stats shows). */
static uint64_t taken_over(struct raw_out *r)
{
        return atomic_load(&shmtest_in_header(&r->in)->counters[SHM_COUNTER_OUT_TAKEN_OVER]);
}

/* Waits until the daemon's .in mirror of p1.out1 holds what its .out slot holds now. */
static void wait_mirrored(struct sl_client *c, uint32_t *cursor, struct raw_out *r,
                          const struct shm_slot *slot)
{
        int tries = 0;

        while (atomic_load(&shmtest_in_slot(&r->in, r->index)->source) != shm_slot_word(slot)) {
                assert_true(++tries < HELD_WAITS);
                assert_int_equal(sl_wait(c, cursor, T_RECOVER_MS), 1);
        }
}

/* Reads p1.out1 through c and checks it is value. */
static void expect_read(struct sl_client *c, int id, const char *value)
{
        char buf[SL_VALUE_SIZE];

        assert_int_equal(sl_read(c, id, buf, sizeof(buf), NULL), (int)strlen(value));
        assert_string_equal(buf, value);
}

/*
 * A writer stopped (SIGSTOP) in the middle of its write: kill() finds it alive, so the dead-writer
 * repair never came and every write of the variable failed (-EBUSY) for as long as it stayed
 * stopped. The daemon takes the slot over after its bound (out_taken_over, one log line naming
 * the pid): the next write goes through; the writer, continued, learns at its publish that its
 * write was abandoned (-ECANCELED), and nothing of it is read or sent. Waits on table changes
 * (the takeover bumps the change word), with the counter as the condition; about 2 s (two
 * heartbeats) of it.
 */
static void test_out_stopped_writer_taken_over(void **state)
{
        struct harness *h = *state;
        struct shm_slot *slot;
        struct sl_client *c;
        struct raw_out r;
        const char *kept;
        char needle[64];
        uint32_t cursor = 0;
        int id, status, tries = 0, r_write;
        pid_t pid;

        raw_out_start(h, &r);
        slot = shmtest_out_slot(&r.out, shmtest_in_dir(&r.in)[r.index].out_slot);
        assert_int_equal(sl_open(h->instance, &c), 0);
        id = sl_find(c, "p1.out1");
        assert_true(id >= 0);
        sl_wait(c, &cursor, 0);
        wait_mirrored(c, &cursor, &r, slot);                    /* "1" taken by the daemon */
        pid = shmtest_fork(stopped_writer_main, slot);
        assert_true(pid > 0);
        assert_int_equal(waitpid(pid, &status, WUNTRACED), pid);        /* stopped mid-write */
        assert_true(WIFSTOPPED(status));
        /* Held by a live writer: refused, unless the takeover came first (a busy machine). */
        r_write = sl_write(c, id, "late");
        assert_true(r_write == -EBUSY || r_write == 0);
        kept = r_write == 0 ? "late" : "1";
        while (taken_over(&r) == 0) {
                assert_true(++tries < HELD_WAITS);
                /* The takeover bumps the change word (the mirror now points at it). */
                assert_int_equal(sl_wait(c, &cursor, T_RECOVER_MS), 1);
        }
        assert_int_equal(taken_over(&r), 1);
        snprintf(needle, sizeof(needle), "pid %ld held its slot", (long)pid);
        assert_int_equal(harness_log_contains(h, needle), 1);
        expect_read(c, id, kept);                       /* the last accepted value */
        /* Other writers get through again while it is still stopped. */
        assert_int_equal(sl_write(c, id, "2"), 0);
        wait_mirrored(c, &cursor, &r, slot);
        /* Continued: its late stores land in "2"'s slot past its length, and its publish fails. */
        assert_int_equal(kill(pid, SIGCONT), 0);
        assert_int_equal(shmtest_wait(pid), 0);
        expect_read(c, id, "2");
        assert_int_equal(taken_over(&r), 1);
        sl_close(c);
        raw_out_stop(h, &r);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_check_ok, setup, teardown),
                cmocka_unit_test_setup_teardown(test_check_bad, setup, teardown),
                cmocka_unit_test_setup_teardown(test_usage_version, setup, teardown),
                cmocka_unit_test_setup_teardown(test_start_status_stop, setup, teardown),
                cmocka_unit_test_setup_teardown(test_sigint, setup, teardown),
                cmocka_unit_test_setup_teardown(test_runtime_dir, setup, teardown),
                cmocka_unit_test_setup_teardown(test_control_requests, setup, teardown),
                cmocka_unit_test_setup_teardown(test_control_pipeline, setup, teardown),
                cmocka_unit_test_setup_teardown(test_control_overlong, setup, teardown),
                cmocka_unit_test_setup_teardown(test_control_clients_max, setup, teardown),
                cmocka_unit_test_setup_teardown(test_control_permissions, setup, teardown),
                cmocka_unit_test_setup_teardown(test_control_half_closed_recorder, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_control_held_by_users, setup, teardown),
                cmocka_unit_test_setup_teardown(test_control_stale_and_live, setup, teardown),
                cmocka_unit_test_setup_teardown(test_second_daemon, setup, teardown),
                cmocka_unit_test_setup_teardown(test_missing_group_start, setup, teardown),
                cmocka_unit_test_setup_teardown(test_request_outlives_client, setup, teardown),
                cmocka_unit_test_setup_teardown(test_reload_settings, setup, teardown),
                cmocka_unit_test_setup_teardown(test_reload_variables, setup, teardown),
                cmocka_unit_test_setup_teardown(test_reload_socket_moves, setup, teardown),
                cmocka_unit_test_setup_teardown(test_reload_bad, setup, teardown),
                cmocka_unit_test_setup_teardown(test_reload_no_fd_leak, setup, teardown),
                cmocka_unit_test_setup_teardown(test_missing_device, setup, teardown),
                cmocka_unit_test_setup_teardown(test_idle_wakeups, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_truncated_recovers, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_lost_mark_heartbeat, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_stopped_writer_taken_over, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_request_sees_earlier_writes, setup,
                                                teardown),
        };

        signal(SIGPIPE, SIG_IGN);       /* a daemon that hangs up is an error code, not death */
        /* TEST_FILTER=test_reload_* runs a subset (debugging). */
        if (getenv("TEST_FILTER"))
                cmocka_set_test_filter(getenv("TEST_FILTER"));
        return cmocka_run_group_tests(tests, NULL, NULL);
}
