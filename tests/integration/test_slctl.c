/*
 * Integration tests of slctl (build/asan/slctl, run as a process): list, get, set, watch, events
 * and stats against real tables, usage errors (exit 2), bad input (exit 1), no daemon (exit 3),
 * and JSON that parses.
 *
 * Most tables are made by this test process with the daemon's own table module (src/shm/table.h),
 * so the test plays the daemon's side of the shared memory: it publishes values and events,
 * marks them stale, and reads what slctl wrote to .out with the daemon's outbound scan.
 *
 * The commands (circe, query) and the library's control-socket client run end to end against the
 * real sharedlinkd (started by the harness) with links joined back to back by a pty, as `make
 * demo` does: a CIRCE controller and the built-in mediator emulator; SharedLink nodes A and B.
 * Each is skipped when the build lacks that engine.
 */
#define _GNU_SOURCE     /* pipe2 */
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <poll.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <grp.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <cmocka.h>

#include <sharedlink.h>

#include "common/harness.h"
#include "common/slwait.h"
#include "cli/counters.h"
#include "common/testdata.h"
#include "common/shmtest.h"
#include "shm/table.h"

#define RUN_LIMIT_MS    20000   /* a hang guard for one slctl run, not a timing assertion */
#define LINE_LIMIT_MS   10000   /* the same for one line of a running watch/events */
#define OUT_SIZE        65536
#define ERR_SIZE        4096
#define ARGV_MAX        32
#define START_MS        15000   /* READY=1 from the ASan daemon */
#define WAIT_MS         10000   /* one awaited value or event */
#define CONFIG_MAX      4096

enum { LAT, LON, THROTTLE, STATE, QUOTE, NEVER, NVARS };

static const struct shm_var vars[NVARS] = {
        [LAT] = { "AutoGpsLat", SHM_DIR_IN, SHM_TYPE_DOUBLE, 0, "A", 0 },
        [LON] = { "AutoGpsLon", SHM_DIR_IN, SHM_TYPE_DOUBLE, 0, "A", 1 },
        [THROTTLE] = { "CmdThrottle", SHM_DIR_OUT, SHM_TYPE_DOUBLE, 0, "A", 0 },
        [STATE] = { "agility.state", SHM_DIR_IN, SHM_TYPE_STRING, 1, NULL, SHM_POSITION_NONE },
        /* JSON must escape what values may hold: quotes and backslashes (a name is letters,
         * digits, _ . -: slp_name_byte(), one rule for the config, the table and the codec). */
        [QUOTE] = { "Quote.Back-slash", SHM_DIR_IN, SHM_TYPE_STRING, SHM_LINK_NONE, NULL,
                    SHM_POSITION_NONE },
        [NEVER] = { "NeverSet", SHM_DIR_IN, SHM_TYPE_LONG, SHM_LINK_NONE, NULL, SHM_POSITION_NONE },
};

static const struct shm_link_def table_links[] = {
        { "vehicle", "sharedlink" },
        { "agility", "circe" },
};

struct fixture {
        struct harness h;
        struct shm_table *t;            /* the test's own tables, or NULL */
        struct sl_client *c;            /* a client of the real daemon's tables, or NULL */
        char out[OUT_SIZE];
        char err[ERR_SIZE];
        int ignore_sigint;              /* start slctl with SIGINT ignored (as `cmd &` in sh) */
        int no_runtime_env;             /* start slctl without SHAREDLINK_RUNTIME_DIR */
        uid_t run_uid;                  /* start slctl as this uid, in no group (0: as we are) */
        int table_group;                /* make_table: tables of a daemon with a group (root) */
};

static int make_table(struct fixture *f, uint32_t event_capacity, struct shm_table **ret)
{
        struct shm_table_config cfg = {
                .instance = f->h.instance, .vars = vars, .nvars = NVARS, .links = table_links,
                .nlinks = 2, .adhoc_capacity = 4, .event_capacity = event_capacity,
                .has_group = f->table_group, .gid = 0,
        };

        return shm_table_create(&cfg, ret);
}

static int setup_bare(void **state)
{
        struct fixture *f = calloc(1, sizeof(*f));

        *state = f;
        return f && harness_init(&f->h, "slctl") == 0 ? 0 : -1;
}

static int setup(void **state)
{
        struct fixture *f;

        if (setup_bare(state) < 0)
                return -1;
        f = *state;
        if (make_table(f, 16, &f->t) < 0)
                return -1;
        shm_table_begin(f->t);
        shm_table_set_str(f->t, LAT, "40.12345678");
        shm_table_set_str(f->t, LON, "-113.5");
        shm_table_set_str(f->t, STATE, "connected");
        shm_table_set_str(f->t, QUOTE, "say \"hi\" \\o/");
        shm_table_commit(f->t);
        shm_table_link_state(f->t, 0, 1, "up");
        shm_table_counter_add(f->t, 0, SHM_COUNTER_FRAMES_IN, 42);
        return 0;
}

static int teardown(void **state)
{
        struct fixture *f = *state;

        sl_close(f->c);
        shm_table_destroy(f->t);
        harness_cleanup(&f->h);
        free(f);
        return 0;
}

/* ---- running slctl ------------------------------------------------------------------------- */

struct proc {
        pid_t pid;
        int out;                        /* its stdout (non-blocking read end) */
        int err;                        /* its stderr */
};

/* Starts slctl with args (NULL-terminated) in the harness environment. */
static void proc_start(struct fixture *f, const char *const *args, struct proc *p)
{
        const char *argv[ARGV_MAX];
        int out[2], err[2];
        size_t n = 0;

        argv[n++] = harness_slctl_path();
        for (size_t i = 0; args[i] && n < ARGV_MAX - 1; i++)
                argv[n++] = args[i];
        argv[n] = NULL;
        assert_int_equal(pipe2(out, O_CLOEXEC), 0);
        assert_int_equal(pipe2(err, O_CLOEXEC), 0);
        p->pid = fork();
        assert_true(p->pid >= 0);
        if (p->pid == 0) {
                union { const char *const *c; char *const *m; } u = { .c = argv };

                setenv("SHAREDLINK_INSTANCE", f->h.instance, 1);
                if (f->no_runtime_env)
                        unsetenv("SHAREDLINK_RUNTIME_DIR");
                else
                        setenv("SHAREDLINK_RUNTIME_DIR", f->h.dir, 1);
                if (f->ignore_sigint)
                        signal(SIGINT, SIG_IGN);
                if (f->run_uid && (setgroups(0, NULL) < 0 || setgid(f->run_uid) < 0 ||
                                   setuid(f->run_uid) < 0))
                        _exit(126);
                dup2(out[1], STDOUT_FILENO);
                dup2(err[1], STDERR_FILENO);
                execv(u.m[0], u.m);
                _exit(127);
        }
        close(out[1]);
        close(err[1]);
        fcntl(out[0], F_SETFL, O_NONBLOCK);
        fcntl(err[0], F_SETFL, O_NONBLOCK);
        p->out = out[0];
        p->err = err[0];
}

/* Reads what is left on both pipes until EOF, waits for the exit; returns the exit code. */
static int proc_finish(struct proc *p, char *out, size_t out_size, char *err, size_t err_size)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)RUN_LIMIT_MS * 1000000u;
        size_t lens[2] = { strlen(out), strlen(err) };
        char *bufs[2] = { out, err };
        size_t sizes[2] = { out_size, err_size };
        int fds[2] = { p->out, p->err }, st;

        while (fds[0] >= 0 || fds[1] >= 0) {
                struct pollfd pf[2] = { { .fd = fds[0], .events = POLLIN },
                                        { .fd = fds[1], .events = POLLIN } };

                if (harness_now_ns() > deadline) {
                        kill(p->pid, SIGKILL);
                        fail_msg("slctl did not finish");
                }
                if (poll(pf, 2, 100) <= 0)
                        continue;
                for (int i = 0; i < 2; i++) {
                        ssize_t n;

                        if (fds[i] < 0 || !pf[i].revents)
                                continue;
                        n = read(fds[i], bufs[i] + lens[i], sizes[i] - 1 - lens[i]);
                        if (n > 0) {
                                lens[i] += (size_t)n;
                                bufs[i][lens[i]] = '\0';
                        } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
                                close(fds[i]);
                                fds[i] = -1;
                        }
                }
        }
        assert_int_equal(waitpid(p->pid, &st, 0), p->pid);
        return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

/* Runs slctl with args to its end; stdout in f->out, stderr in f->err; returns the exit code. */
static int run_argv(struct fixture *f, const char *const *args)
{
        struct proc p;

        f->out[0] = '\0';
        f->err[0] = '\0';
        proc_start(f, args, &p);
        return proc_finish(&p, f->out, sizeof(f->out), f->err, sizeof(f->err));
}

#define RUN(f, ...) run_argv((f), (const char *const[]){ __VA_ARGS__, NULL })

/* Reads one line of a running slctl's stdout into buf (newline included). */
static void proc_line(struct proc *p, char *buf, size_t size)
{
        ssize_t n = harness_read_until(p->out, buf, size, '\n', LINE_LIMIT_MS);

        if (n <= 0)
                fail_msg("no line from slctl (%zd), got \"%s\"", n, buf);
}

/* Number of lines in text. */
static int count_lines(const char *text)
{
        int n = 0;

        for (; *text; text++)
                n += *text == '\n';
        return n;
}

/* ---- a small strict JSON checker (RFC 8259 grammar; no python needed) ---------------------- */

struct json_in {
        const char *p;
        int depth;
};

static int json_value(struct json_in *j);

static void json_ws(struct json_in *j)
{
        while (*j->p == ' ' || *j->p == '\n' || *j->p == '\r' || *j->p == '\t')
                j->p++;
}

static int json_lit(struct json_in *j, const char *lit)
{
        size_t n = strlen(lit);

        if (strncmp(j->p, lit, n) != 0)
                return -1;
        j->p += n;
        return 0;
}

static int json_str(struct json_in *j)
{
        if (*j->p++ != '"')
                return -1;
        for (;;) {
                unsigned char ch = (unsigned char)*j->p++;

                if (ch == '"')
                        return 0;
                if (ch < 0x20)
                        return -1;      /* includes the end of the text */
                if (ch >= 0x80)
                        return -1;      /* slctl promises ASCII-only output */
                if (ch != '\\')
                        continue;
                ch = (unsigned char)*j->p++;
                if (ch == 'u') {
                        for (int i = 0; i < 4; i++, j->p++)
                                if (!strchr("0123456789abcdefABCDEF", *j->p) || !*j->p)
                                        return -1;
                } else if (!strchr("\"\\/bfnrt", ch) || !ch) {
                        return -1;
                }
        }
}

static int json_num(struct json_in *j)
{
        const char *start = j->p;

        if (*j->p == '-')
                j->p++;
        if (*j->p == '0')
                j->p++;
        else if (*j->p >= '1' && *j->p <= '9')
                while (*j->p >= '0' && *j->p <= '9')
                        j->p++;
        else
                return -1;
        if (*j->p == '.') {
                j->p++;
                if (!(*j->p >= '0' && *j->p <= '9'))
                        return -1;
                while (*j->p >= '0' && *j->p <= '9')
                        j->p++;
        }
        if (*j->p == 'e' || *j->p == 'E') {
                j->p++;
                if (*j->p == '+' || *j->p == '-')
                        j->p++;
                if (!(*j->p >= '0' && *j->p <= '9'))
                        return -1;
                while (*j->p >= '0' && *j->p <= '9')
                        j->p++;
        }
        return j->p > start ? 0 : -1;
}

static int json_list(struct json_in *j, char close, int members)
{
        j->p++;
        json_ws(j);
        if (*j->p == close) {
                j->p++;
                return 0;
        }
        for (;;) {
                json_ws(j);
                if (members) {
                        if (json_str(j) < 0)
                                return -1;
                        json_ws(j);
                        if (*j->p++ != ':')
                                return -1;
                }
                if (json_value(j) < 0)
                        return -1;
                json_ws(j);
                if (*j->p == close) {
                        j->p++;
                        return 0;
                }
                if (*j->p++ != ',')
                        return -1;
        }
}

static int json_value(struct json_in *j)
{
        int r;

        json_ws(j);
        if (++j->depth > 64)
                return -1;
        switch (*j->p) {
        case '{':
                r = json_list(j, '}', 1);
                break;
        case '[':
                r = json_list(j, ']', 0);
                break;
        case '"':
                r = json_str(j);
                break;
        case 't':
                r = json_lit(j, "true");
                break;
        case 'f':
                r = json_lit(j, "false");
                break;
        case 'n':
                r = json_lit(j, "null");
                break;
        default:
                r = json_num(j);
        }
        j->depth--;
        return r;
}

/* 0 when text is exactly one JSON value (with whitespace around). */
static int json_check(const char *text)
{
        struct json_in j = { .p = text };

        if (json_value(&j) < 0)
                return -1;
        json_ws(&j);
        return *j.p == '\0' ? 0 : -1;
}

/* A python3 on $PATH, for a second opinion on the JSON; NULL when there is none. */
static const char *python3_path(void)
{
        static char found[512];
        const char *path = getenv("PATH");
        char dirs[4096], *save = NULL;

        if (!path)
                return NULL;
        snprintf(dirs, sizeof(dirs), "%s", path);
        for (char *d = strtok_r(dirs, ":", &save); d; d = strtok_r(NULL, ":", &save)) {
                snprintf(found, sizeof(found), "%s/python3", d);
                if (access(found, X_OK) == 0)
                        return found;
        }
        return NULL;
}

/* Checks JSON with the checker above and, when there is one, python3 -m json.tool. */
static void assert_json(struct fixture *f, const char *text)
{
        const char *py = python3_path();
        char path[HARNESS_PATH_MAX];

        if (json_check(text) < 0)
                fail_msg("not JSON: %s", text);
        if (!py)
                return;
        assert_int_equal(harness_write_file(&f->h, "out.json", text, path), 0);
        {
                const char *const argv[] = { py, "-m", "json.tool", path, NULL };
                char out[OUT_SIZE];

                assert_int_equal(harness_run(&f->h, out, sizeof(out), RUN_LIMIT_MS, argv), 0);
        }
}

static void test_json_checker(void **state)
{
        static const char *const good[] = {
                "{}", "[]", "{\"a\":[1,-2.5e3,true,false,null,\"x\\\"\\u00ff\"]}", " 0 ",
        };
        static const char *const bad[] = {
                "", "{", "{\"a\"}", "[1,]", "{\"a\":1,}", "\"\x01\"", "01", "1.", "tru",
                "{} {}", "\"\\x\"", "\"\xc3\xa9\"", "[\"\\u00f\"]",
        };

        (void)state;
        for (size_t i = 0; i < sizeof(good) / sizeof(good[0]); i++)
                assert_int_equal(json_check(good[i]), 0);
        for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++)
                if (json_check(bad[i]) == 0)
                        fail_msg("accepted: %s", bad[i]);
}

/* ---- list, get ----------------------------------------------------------------------------- */

static void test_list(void **state)
{
        struct fixture *f = *state;

        assert_int_equal(RUN(f, "list"), 0);
        assert_int_equal(count_lines(f->out), 1 + NVARS);
        assert_non_null(strstr(f->out, "NAME"));
        assert_non_null(strstr(f->out, " 40.12345678\n"));
        assert_non_null(strstr(f->out, " say \"hi\" \\o/\n"));
        /* One row, field by field: name, direction, link, peer, type, age, flags, value. */
        {
                char name[64], dir[8], link[32], peer[16], type[16], age[32], flags[64], value[64];
                const char *row = strstr(f->out, "AutoGpsLon ");

                assert_non_null(row);
                assert_int_equal(sscanf(row, "%63s %7s %31s %15s %15s %31s %63s %63s", name, dir,
                                        link, peer, type, age, flags, value), 8);
                assert_string_equal(dir, "in");
                assert_string_equal(link, "vehicle");
                assert_string_equal(peer, "A");
                assert_string_equal(type, "double");
                assert_true(age[strlen(age) - 1] == 's');
                assert_string_equal(flags, "valid");
                assert_string_equal(value, "-113.5");
        }
        /* Never written: age and flags "-", no value. */
        {
                char name[64], dir[8], link[32], peer[16], type[16], age[32], flags[64];
                const char *row = strstr(f->out, "CmdThrottle ");

                assert_non_null(row);
                assert_int_equal(sscanf(row, "%63s %7s %31s %15s %15s %31s %63s", name, dir, link,
                                        peer, type, age, flags), 7);
                assert_string_equal(dir, "out");
                assert_string_equal(age, "-");
                assert_string_equal(flags, "-");
                assert_true(strncmp(strchr(row, '\n') - 2, " -", 2) == 0);  /* no value after */
        }

        assert_int_equal(RUN(f, "list", "--json"), 0);
        assert_json(f, f->out);
        assert_non_null(strstr(f->out, "\"name\":\"Quote.Back-slash\""));
        assert_non_null(strstr(f->out, "\"value\":\"say \\\"hi\\\" \\\\o/\""));
        assert_non_null(strstr(f->out, "\"name\":\"NeverSet\",\"direction\":\"in\",\"link\":null,"
                               "\"peer\":null,\"type\":\"long\",\"position\":null,\"value\":\"\","
                               "\"valid\":false"));
        assert_non_null(strstr(f->out, "\"name\":\"AutoGpsLat\",\"direction\":\"in\","
                               "\"link\":\"vehicle\",\"peer\":\"A\",\"type\":\"double\","
                               "\"position\":0,\"value\":\"40.12345678\",\"valid\":true,"
                               "\"stale\":false"));
}

static void test_get(void **state)
{
        struct fixture *f = *state;

        assert_int_equal(RUN(f, "get", "AutoGpsLon", "AutoGpsLat", "agility.state"), 0);
        assert_string_equal(f->out, "-113.5\n40.12345678\nconnected\n");
        /* Never set: an empty line; stale: its last value, unless --strict. */
        assert_int_equal(RUN(f, "get", "NeverSet", "AutoGpsLat"), 0);
        assert_string_equal(f->out, "\n40.12345678\n");
        assert_int_equal(shm_table_set_stale(f->t, LAT, 1), 0);
        shm_table_commit(f->t);
        assert_int_equal(RUN(f, "get", "AutoGpsLat"), 0);
        assert_string_equal(f->out, "40.12345678\n");
        assert_int_equal(RUN(f, "get", "--strict", "AutoGpsLon", "AutoGpsLat"), 1);
        assert_string_equal(f->out, "");
        assert_non_null(strstr(f->err, "AutoGpsLat"));
        assert_non_null(strstr(f->err, "stale"));
        assert_int_equal(RUN(f, "get", "--strict", "NeverSet"), 1);
        assert_string_equal(f->out, "");
        assert_int_equal(RUN(f, "get", "--strict", "AutoGpsLon"), 0);
        assert_string_equal(f->out, "-113.5\n");
        /* Unknown: nothing printed, the name in the message. */
        assert_int_equal(RUN(f, "get", "AutoGpsLon", "NoSuchThing"), 1);
        assert_string_equal(f->out, "");
        assert_non_null(strstr(f->err, "NoSuchThing"));
}

/* ---- set ----------------------------------------------------------------------------------- */

struct scanned {
        int n;
        struct shm_out_change last;
};

static void on_out(void *userdata, const struct shm_out_change *change)
{
        struct scanned *s = userdata;

        s->n++;
        s->last = *change;
}

static void test_set(void **state)
{
        struct fixture *f = *state;
        struct scanned s = { 0 };
        char long_value[80];

        assert_int_equal(RUN(f, "set", "CmdThrottle", "0.25"), 0);
        assert_string_equal(f->out, "");
        /* The daemon's side sees it, validated. */
        assert_int_equal(shm_table_out_scan(f->t, on_out, &s), 1);
        assert_int_equal(s.last.id, THROTTLE);
        assert_int_equal(s.last.status, SHM_OUT_CHANGED);
        assert_string_equal(s.last.value, "0.25");
        /* A negative number is a value, not an option; so is anything after --. */
        assert_int_equal(RUN(f, "set", "CmdThrottle", "-0.5"), 0);
        assert_int_equal(RUN(f, "get", "CmdThrottle"), 0);
        assert_string_equal(f->out, "-0.5\n");
        assert_int_equal(RUN(f, "set", "--", "CmdThrottle", "-2e-3"), 0);
        assert_int_equal(RUN(f, "get", "CmdThrottle"), 0);
        assert_string_equal(f->out, "-2e-3\n");
        /* Refusals, each explained. A value its type refuses (CmdThrottle is a double) is
         * refused before the table: it keeps the last value, the daemon hears nothing. */
        s.n = 0;
        assert_true(shm_table_out_scan(f->t, on_out, &s) >= 1);
        assert_int_equal(RUN(f, "set", "--", "CmdThrottle", "-x"), 1);
        assert_non_null(strstr(f->err, "\"-x\" is not a double"));
        assert_int_equal(RUN(f, "set", "CmdThrottle", "abc"), 1);
        assert_non_null(strstr(f->err, "CmdThrottle"));
        assert_non_null(strstr(f->err, "\"abc\" is not a double"));
        assert_int_equal(RUN(f, "get", "CmdThrottle"), 0);
        assert_string_equal(f->out, "-2e-3\n");
        s.n = 0;
        assert_int_equal(shm_table_out_scan(f->t, on_out, &s), 0);
        assert_int_equal(RUN(f, "set", "AutoGpsLat", "1"), 1);
        assert_non_null(strstr(f->err, "inbound"));
        assert_int_equal(RUN(f, "set", "CmdThrottle", "a|b"), 1);
        assert_non_null(strstr(f->err, "printable ASCII except | [ ]"));
        memset(long_value, '7', 64);
        long_value[64] = '\0';
        assert_int_equal(RUN(f, "set", "CmdThrottle", long_value), 1);
        assert_non_null(strstr(f->err, "63 bytes"));
        long_value[63] = '\0';
        assert_int_equal(RUN(f, "set", "CmdThrottle", long_value), 0);
        assert_int_equal(RUN(f, "set", "NoSuchThing", "1"), 1);
        assert_non_null(strstr(f->err, "NoSuchThing"));
        /* Nothing refused reached .out: the last change is the 63-byte value. */
        s.n = 0;
        assert_true(shm_table_out_scan(f->t, on_out, &s) >= 1);
        assert_string_equal(s.last.value, long_value);
}

/* ---- watch --------------------------------------------------------------------------------- */

static void test_watch(void **state)
{
        const char *const args[] = { "watch", "--count", "2", "--timeout", "60000", "AutoGpsLat",
                                     "AutoGpsLon", NULL };
        struct fixture *f = *state;
        char line[512], out[256] = "", err[256] = "";
        struct proc p;

        proc_start(f, args, &p);
        /* The current values first: once they are out, slctl is watching. */
        proc_line(&p, line, sizeof(line));
        assert_non_null(strstr(line, " AutoGpsLat 40.12345678\n"));
        assert_true(line[4] == '-' && line[10] == 'T');         /* 2025-11-23T04:36:12.345 */
        proc_line(&p, line, sizeof(line));
        assert_non_null(strstr(line, " AutoGpsLon -113.5\n"));

        /* The same value again (a periodic refresh) is not a change: the next line is 41.5. */
        shm_table_set_str(f->t, LAT, "40.12345678");
        shm_table_set_str(f->t, LAT, "41.5");
        proc_line(&p, line, sizeof(line));
        assert_non_null(strstr(line, " AutoGpsLat 41.5\n"));
        shm_table_set_stale(f->t, LON, 1);
        shm_table_commit(f->t);
        proc_line(&p, line, sizeof(line));
        assert_non_null(strstr(line, " AutoGpsLon -113.5 [stale]\n"));
        /* Two changes seen: it ends by itself. */
        assert_int_equal(proc_finish(&p, out, sizeof(out), err, sizeof(err)), 0);
        assert_string_equal(out, "");

        /* No change within the bound: with --count that is an error, without it is not. */
        assert_int_equal(RUN(f, "watch", "--count", "1", "--timeout", "50", "NeverSet"), 1);
        assert_int_equal(count_lines(f->out), 1);
        assert_non_null(strstr(f->out, " NeverSet [invalid]\n"));
        assert_int_equal(RUN(f, "watch", "--timeout", "0"), 0);
        assert_int_equal(count_lines(f->out), NVARS);
        assert_int_equal(RUN(f, "watch", "NoSuchThing"), 1);
        assert_int_equal(RUN(f, "watch", "--count", "0"), 1);
        assert_int_equal(RUN(f, "watch", "--timeout", "soon"), 1);
}

/* "Until interrupted", also when started the way `slctl watch &` is in a script. */
static void test_watch_interrupted(void **state)
{
        const char *const watch[] = { "watch", "AutoGpsLat", NULL };
        const char *const follow[] = { "events", "--follow", NULL };
        struct fixture *f = *state;
        char line[512], out[256] = "", err[256] = "";
        struct proc p;

        f->ignore_sigint = 1;
        proc_start(f, watch, &p);
        proc_line(&p, line, sizeof(line));
        assert_int_equal(kill(p.pid, SIGINT), 0);
        assert_int_equal(proc_finish(&p, out, sizeof(out), err, sizeof(err)), 128 + SIGINT);
        shm_table_event(f->t, SHM_EVENT_DAEMON, SHM_LINK_NONE, "started");
        proc_start(f, follow, &p);
        proc_line(&p, line, sizeof(line));
        assert_string_equal(line, "1 - daemon started\n");
        assert_int_equal(kill(p.pid, SIGINT), 0);
        assert_int_equal(proc_finish(&p, out, sizeof(out), err, sizeof(err)), 128 + SIGINT);
}

static void test_watch_new_names(void **state)
{
        const char *const args[] = { "watch", "--count", "1", "--timeout", "60000", NULL };
        const struct shm_var adhoc = { "AdHocName", SHM_DIR_IN, SHM_TYPE_STRING, 0, "A",
                                       SHM_POSITION_NONE };
        struct fixture *f = *state;
        char line[512], out[256] = "", err[256] = "";
        struct proc p;
        int id;

        proc_start(f, args, &p);
        for (int i = 0; i < NVARS; i++)
                proc_line(&p, line, sizeof(line));
        /* A name that appears while watching everything is a change too. */
        id = shm_table_add(f->t, &adhoc);
        assert_true(id >= 0);
        shm_table_set_str(f->t, (uint32_t)id, "hello world");
        proc_line(&p, line, sizeof(line));
        assert_non_null(strstr(line, " AdHocName "));
        assert_int_equal(proc_finish(&p, out, sizeof(out), err, sizeof(err)), 0);
}

/* ---- events -------------------------------------------------------------------------------- */

static void test_events_ring(void **state)
{
        struct fixture *f = *state;
        char expect[64];

        /* setup() made 0 events (link_state publishes no event); 20 in a ring of 16. */
        for (int i = 0; i < 20; i++)
                shm_table_eventf(f->t, SHM_EVENT_ACTION, 1, "device=E1E1E1 sensor_time=%d",
                                 i * 100);
        shm_table_event(f->t, SHM_EVENT_DAEMON, SHM_LINK_NONE, "");
        assert_int_equal(RUN(f, "events"), 0);
        assert_true(strncmp(f->out, "- - overrun lost=", 17) == 0);
        snprintf(expect, sizeof(expect), "\n20 agility action device=E1E1E1 sensor_time=1900\n");
        assert_non_null(strstr(f->out, expect));
        assert_non_null(strstr(f->out, "\n21 - daemon\n"));
        assert_int_equal(count_lines(f->out), 1 + 16);
        assert_int_equal(RUN(f, "events", "--count", "2"), 0);
        assert_int_equal(count_lines(f->out), 3);       /* the overrun line, then 2 events */
        assert_int_equal(RUN(f, "events", "--new"), 0);
        assert_string_equal(f->out, "");
        assert_int_equal(RUN(f, "events", "--timeout", "10"), 2);
}

static void test_events_follow(void **state)
{
        const char *const args[] = { "events", "--follow", "--count", "3", "--timeout", "60000",
                                     NULL };
        struct fixture *f = *state;
        char line[512], out[256] = "", err[256] = "";
        struct proc p;

        shm_table_event(f->t, SHM_EVENT_DEVICE_ONLINE, 1, "device=AAAAAA");
        proc_start(f, args, &p);
        proc_line(&p, line, sizeof(line));
        assert_string_equal(line, "1 agility device-online device=AAAAAA\n");
        /* Printed as they come. */
        shm_table_event(f->t, SHM_EVENT_ACTION, 1, "device=E1E1E1 sensor_time=5000");
        proc_line(&p, line, sizeof(line));
        assert_string_equal(line, "2 agility action device=E1E1E1 sensor_time=5000\n");
        shm_table_begin(f->t);
        shm_table_event(f->t, SHM_EVENT_DEVICE_OFFLINE, 1, "device=AAAAAA");
        shm_table_event(f->t, SHM_EVENT_ACTION, 1, "device=E1E1E1");
        shm_table_commit(f->t);
        proc_line(&p, line, sizeof(line));
        assert_string_equal(line, "3 agility device-offline device=AAAAAA\n");
        /* --count 3: the fourth is not printed. */
        assert_int_equal(proc_finish(&p, out, sizeof(out), err, sizeof(err)), 0);
        assert_string_equal(out, "");
        /* Following with nothing new until the bound: fine without --count. */
        assert_int_equal(RUN(f, "events", "--follow", "--new", "--timeout", "20"), 0);
        assert_string_equal(f->out, "");
        assert_int_equal(RUN(f, "events", "--follow", "--new", "--count", "1", "--timeout", "20"),
                         1);
}

/* ---- stats --------------------------------------------------------------------------------- */

static void test_stats(void **state)
{
        struct fixture *f = *state;
        char pid[64];

        assert_int_equal(RUN(f, "stats"), 0);
        snprintf(pid, sizeof(pid), "sharedlinkd pid %d, running", (int)getpid());
        assert_non_null(strstr(f->out, pid));
        assert_non_null(strstr(f->out, "link vehicle (sharedlink): up for "));
        assert_non_null(strstr(f->out, "link agility (circe): no state yet"));
        assert_non_null(strstr(f->out, "frames_in                    42"));
        assert_non_null(strstr(f->out, "out_recreated"));
        assert_int_equal(RUN(f, "stats", "--json"), 0);
        assert_json(f, f->out);
        assert_non_null(strstr(f->out, "\"name\":\"vehicle\",\"protocol\":\"sharedlink\","
                               "\"state\":1,\"state_name\":\"up\""));
        assert_non_null(strstr(f->out, "\"frames_in\":42,"));
        assert_non_null(strstr(f->out, "\"alive\":true"));
}

/* ---- usage, help, bad input ---------------------------------------------------------------- */

static void test_usage(void **state)
{
        static const char *const usage[][8] = {
                { "bogus" }, { "--bogus" }, { "-i" }, { "-i", "" },
                { "list", "extra" }, { "list", "--bogus" }, { "list", "--json=1" },
                { "list", "--json", "--json" }, { "get" }, { "set", "CmdThrottle" },
                { "set", "a", "b", "c" }, { "watch", "--count" }, { "events", "--timeout", "5" },
                { "events", "x" }, { "stats", "x" }, { "query", "vehicle", "A" },
                { "command" }, { "command", "vehicle" }, { "command", "--wait" },
                { "circe" }, { "circe", "agility" }, { "circe", "agility", "dance" },
                { "circe", "agility", "alert" }, { "circe", "agility", "alert", "A", "B" },
                { "circe", "agility", "network-setup", "AAAAAA", "--roles", "1" },
                { "circe", "agility", "network-setup", "AAAAAA", "--join", "--leave", "--roles",
                  "1" },
                { "circe", "agility", "network-setup", "AAAAAA", "--join" },
                { "circe", "agility", "device-setup" },
                { "circe", "agility", "sync-clocks", "--roles", "1" },
                { "circe", "agility", "visualize" },
                { "circe", "agility", "emulate", "press", "E1E1E1" },
                { "circe", "agility", "alert", "E1E1E1", "--keys", "1" },
                { "help", "bogus" },
        };
        struct fixture *f = *state;

        assert_int_equal(run_argv(f, (const char *const[]){ NULL }), 2);
        assert_non_null(strstr(f->err, "--help"));
        for (size_t i = 0; i < sizeof(usage) / sizeof(usage[0]); i++) {
                int code = run_argv(f, usage[i]);

                if (code != 2)
                        fail_msg("slctl %s %s %s: exit %d, not 2", usage[i][0],
                                 usage[i][1] ? usage[i][1] : "", usage[i][1] && usage[i][2] ?
                                 usage[i][2] : "", code);
                assert_string_equal(f->out, "");
                assert_true(f->err[0] != '\0');
        }
}

static void test_help(void **state)
{
        static const char *const commands[] = {
                "list", "get", "set", "watch", "events", "stats", "query", "ping", "command",
                "circe",
        };
        struct fixture *f = *state;

        assert_int_equal(RUN(f, "--help"), 0);
        for (size_t i = 0; i < sizeof(commands) / sizeof(commands[0]); i++)
                assert_non_null(strstr(f->out, commands[i]));
        assert_non_null(strstr(f->out, "Exit status"));
        assert_int_equal(RUN(f, "-h"), 0);
        assert_int_equal(RUN(f, "help"), 0);
        for (size_t i = 0; i < sizeof(commands) / sizeof(commands[0]); i++) {
                char want[64];

                snprintf(want, sizeof(want), "slctl [-i INSTANCE] %s", commands[i]);
                assert_int_equal(RUN(f, commands[i], "--help"), 0);
                assert_non_null(strstr(f->out, want));
                assert_int_equal(RUN(f, "help", commands[i]), 0);
                assert_non_null(strstr(f->out, want));
        }
        assert_int_equal(RUN(f, "--version"), 0);
        assert_true(strncmp(f->out, "slctl (sharedlink) ", 19) == 0);
}

/* Refused by the library before any connection: exit 1, although no daemon socket exists. */
static void test_bad_input(void **state)
{
        static const char *const bad[][10] = {
                { "query", "vehicle", "Z", "AutoGpsLat" },
                { "query", "vehicle", "A", "Bad|Name" },
                { "query", "--timeout", "0", "vehicle", "A", "X" },
                { "query", "--timeout", "60001", "vehicle", "A", "X" },
                { "query", "--wait", "60001", "vehicle", "A", "X" },
                { "circe", "agility", "alert", "FFFFFF" },
                { "circe", "agility", "alert", "E1E1E" },
                { "circe", "agility", "network-setup", "AAAAAA", "--join", "--roles", "128" },
                { "circe", "agility", "network-setup", "AAAAAA", "--join", "--roles", "x" },
                { "circe", "agility", "device-setup", "--assign", "123456", "--capabilities",
                  "200" },
                { "circe", "agility", "device-setup", "--assign", "123456", "--dest", "XYZ" },
                { "circe", "agility", "visualize", "D15D15" },
                { "circe", "agility", "visualize", "D15D15,", "--current", "1" },
                { "circe", "agility", "visualize", "D15D15", "--current", "1000" },
                { "circe", "agility", "visualize", "D15D15", "--primary", "1000000" },
                { "circe", "agility", "visualize", "D15D15", "--eliminated", "2" },
                { "circe", "agility", "visualize", "D15D15", "--faults", "-1" },
                { "circe", "arena", "emulate", "action", "E1E1E1", "--keys", "65536" },
                { "circe", "arena", "emulate", "action", "E1E1E1", "--sensor-time", "9999999999" },
                { "command", "vehicle", "Servo Pod", "x" },
                { "command", "vehicle", "Servo|Pod" },
                { "command", "vehicle", "ServoPod", "0,TELEOP|START" },
                { "command", "vehicle", "ServoPod", "0,TELEOP  START" },
                { "command", "vehicle", "ServoPod", "0,TELEOP ", "START" },
                { "command", "vehicle", "ServoPod", "[0]" },
                { "command", "vehicle", "ServoPod",
                  "0123456789012345678901234567890123456789", "012345678901234567890123" },
                { "command", "--wait", "60001", "vehicle", "ServoPod" },
        };
        struct fixture *f = *state;

        for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
                int code = run_argv(f, bad[i]);

                if (code != 1)
                        fail_msg("case %zu (%s %s ...): exit %d, not 1; %s", i, bad[i][0],
                                 bad[i][1], code, f->err);
                assert_string_equal(f->out, "");
                assert_true(f->err[0] != '\0');
        }
        /* Lower-case addresses are taken (upper-cased); well-formed commands then find no
         * daemon listening on the control socket. */
        assert_int_equal(RUN(f, "circe", "agility", "alert", "e1e1e1"), 3);
        assert_non_null(strstr(f->err, "not running"));
        assert_int_equal(RUN(f, "circe", "agility", "visualize", "d15d15,E1E1E1", "--current",
                             "7", "--start-timer", "--wait", "100"), 3);
        assert_int_equal(RUN(f, "query", "vehicle", "A", "AutoGpsLat"), 3);
        /* 63 bytes of text in two words is the most a command takes. */
        assert_int_equal(RUN(f, "command", "vehicle", "ServoPod",
                             "0123456789012345678901234567890123456789", "0123456789012345678901"),
                         3);
        assert_int_equal(RUN(f, "command", "vehicle", "MUI"), 3);
}

/* ---- no daemon ----------------------------------------------------------------------------- */

/* A user outside the group of a daemon that has one: the tables are 0640, so reading is refused
 * as well as writing, and slctl says so; it said only that writes and commands need the group. */
static void test_not_a_member(void **state)
{
        struct fixture *f = *state;

        if (geteuid() != 0) {
                print_message("not root: cannot play another user\n");
                skip();
        }
        f->table_group = 1;
        assert_int_equal(make_table(f, 16, &f->t), 0);
        f->run_uid = SHMTEST_NOBODY;
        assert_int_equal(RUN(f, "get", "AutoGpsLat"), 1);
        if (!strstr(f->err, "permission denied") ||
            !strstr(f->err, "reading, writing and commands all need it"))
                fail_msg("slctl get as a non-member said: %s", f->err);
        /* The library's own words, for every other caller: reads are named too. */
        assert_non_null(strstr(sl_strerror(-EACCES), "so do reads"));
        /* Root reads the same tables. */
        f->run_uid = 0;
        assert_int_equal(RUN(f, "list"), 0);
}

static void test_not_running(void **state)
{
        static const char *const cmds[][8] = {
                { "list" }, { "list", "--json" }, { "get", "AutoGpsLat" },
                { "set", "CmdThrottle", "1" }, { "watch" }, { "events" }, { "stats" },
                { "query", "vehicle", "A", "X" }, { "circe", "agility", "alert", "E1E1E1" },
                { "circe", "agility", "sync-clocks" }, { "command", "vehicle", "ServoPod", "x" },
        };
        struct fixture *f = *state;

        /* No tables at all. */
        for (size_t i = 0; i < sizeof(cmds) / sizeof(cmds[0]); i++) {
                int code = run_argv(f, cmds[i]);

                if (code != 3)
                        fail_msg("slctl %s: exit %d, not 3", cmds[i][0], code);
                assert_string_equal(f->out, "");
                assert_non_null(strstr(f->err, "not running"));
        }
}

/* Makes the tables and exits without removing them: a daemon that crashed. */
static int crashed_daemon(void *arg)
{
        struct fixture *f = arg;
        struct shm_table *t;

        return make_table(f, 16, &t) == 0 ? 0 : 1;
}

static void test_dead_daemon(void **state)
{
        struct fixture *f = *state;

        assert_int_equal(shmtest_wait(shmtest_fork(crashed_daemon, f)), 0);
        assert_int_equal(RUN(f, "get", "AutoGpsLat"), 3);
        assert_non_null(strstr(f->err, "not running"));
        assert_int_equal(RUN(f, "list"), 3);
        /* stats still shows what the dead daemon left, and says so. */
        assert_int_equal(RUN(f, "stats"), 3);
        assert_non_null(strstr(f->out, "not running"));
        assert_non_null(strstr(f->out, "link vehicle (sharedlink)"));
        assert_int_equal(RUN(f, "stats", "--json"), 3);
        assert_json(f, f->out);
        assert_non_null(strstr(f->out, "\"alive\":false"));
        shmtest_unlink(f->h.instance);
}


/* ---- against the real daemon: commands ----------------------------------------------------- */

/* Starts sharedlinkd on links (a "links:" document); skips the test when the build lacks an
 * engine. */
static void daemon_start(struct fixture *f, const char *links)
{
        char why[HARNESS_WHY_MAX];
        int r;

        f->h.capture_log = 1;
        r = harness_start_config(&f->h, "slctl.yaml", links, START_MS, why, sizeof(why));
        if (r == -ENOTSUP)
                skip();
        if (r < 0)
                fail_msg("sharedlinkd did not start: %s", why);
        assert_int_equal(sl_open(f->h.instance, &f->c), 0);
        /* The daemon runs with SHAREDLINK_RUNTIME_DIR set; this process does not have it. */
        assert_int_equal(sl_set_runtime_dir(f->c, f->h.dir), 0);
}

/* The `make demo` CIRCE pair: the emulator "arena" and the controller "agility" on its pty. */
static void links_circe(struct fixture *f, char *links, size_t size)
{
        const char *const subst[] = { "@DIR@", f->h.dir, NULL };

        assert_true(testdata_load("slctl_circe_pair.yaml", subst, links, size) > 0);
}

static void daemon_start_circe(struct fixture *f)
{
        char links[CONFIG_MAX];

        links_circe(f, links, sizeof(links));
        daemon_start(f, links);
}

/* Waits (sl_wait, not sleeping) until name reads want. */
static void wait_value(struct fixture *f, const char *name, const char *want)
{
        char last[SL_VALUE_SIZE];

        if (slwait_value(f->c, name, want, WAIT_MS, last, sizeof(last)) < 0)
                fail_msg("%s never became \"%s\" (last \"%s\")", name, want, last);
}

static void wait_circe_up(struct fixture *f)
{
        wait_value(f, "agility.state", "connected");
        wait_value(f, "agility.device.E1E1E1.online", "1");
        wait_value(f, "agility.device.AAAAAA.online", "1");
        wait_value(f, "agility.device.D15D15.online", "1");
}

/* The slctl commands, mapped onto the control requests, and what they do to the emulator. */
static void test_daemon_circe(void **state)
{
        struct fixture *f = *state;
        char want[64];

        daemon_start_circe(f);
        wait_circe_up(f);

        /* Lower-case addresses are taken; success prints nothing. */
        assert_int_equal(RUN(f, "circe", "agility", "alert", "e1e1e1"), 0);
        assert_string_equal(f->out, "");
        assert_int_equal(RUN(f, "circe", "agility", "network-setup", "E1E1E1", "--join",
                             "--roles", "2"), 0);
        wait_value(f, "arena.device.E1E1E1.membership", "1");
        wait_value(f, "agility.device.E1E1E1.roles", "2");
        assert_int_equal(RUN(f, "circe", "agility", "network-setup", "E1E1E1", "--leave",
                             "--roles", "0"), 0);
        wait_value(f, "arena.device.E1E1E1.membership", "0");

        assert_int_equal(RUN(f, "circe", "agility", "visualize", "D15D15", "--current", "12",
                             "--next", "13", "--start-timer", "--primary", "1234", "--secondary",
                             "5678", "--faults", "1", "--refusals", "2", "--eliminated", "1",
                             "--placement", "3"), 0);
        wait_value(f, "arena.device.D15D15.current_competitor", "12");
        assert_true(slwait_value_is(f->c, "arena.device.D15D15.next_competitor", "13"));
        assert_true(slwait_value_is(f->c, "arena.device.D15D15.primary_time", "1234"));
        /* The primary time stops the timer. */
        assert_true(slwait_value_is(f->c, "arena.device.D15D15.timer_running", "0"));
        assert_true(slwait_value_is(f->c, "arena.device.D15D15.secondary_time", "5678"));
        assert_true(slwait_value_is(f->c, "arena.device.D15D15.faults", "1"));
        assert_true(slwait_value_is(f->c, "arena.device.D15D15.refusals", "2"));
        assert_true(slwait_value_is(f->c, "arena.device.D15D15.eliminated", "1"));
        assert_true(slwait_value_is(f->c, "arena.device.D15D15.placement", "3"));

        /* A gate passage on the emulator is an action event of the controller. */
        assert_int_equal(RUN(f, "circe", "arena", "emulate", "action", "E1E1E1", "--keys",
                             "8192", "--sensor-time", "5000"), 0);
        wait_value(f, "agility.device.E1E1E1.sensor_time", "5000");
        assert_int_equal(RUN(f, "events"), 0);
        assert_non_null(strstr(f->out, " agility action device=E1E1E1 keys=8192 "
                               "sensor_time=5000\n"));
        assert_non_null(strstr(f->out, " agility device-online device=D15D15 "));
        assert_true(strncmp(f->out, "1 ", 2) == 0);     /* from the first, in order */

        /* Clock synchronisation: one line per device. */
        assert_int_equal(RUN(f, "circe", "agility", "sync-clocks"), 0);
        assert_int_equal(count_lines(f->out), 3);
        for (const char *const *a = (const char *const[]){ "E1E1E1", "AAAAAA", "D15D15", NULL };
             *a; a++) {
                snprintf(want, sizeof(want), "%s succeeded\n", *a);
                assert_non_null(strstr(f->out, want));
        }

        /* Device setup last: it gives the remote control a new address. */
        assert_int_equal(RUN(f, "circe", "agility", "device-setup", "--assign", "ABCDEF",
                             "--dest", "AAAAAA", "--capabilities", "31"), 0);
        wait_value(f, "agility.device.ABCDEF.online", "1");
}

/* What the daemon refuses: exit 1 with its message, never 3 (it is running). */
static void test_daemon_refusals(void **state)
{
        static const char *const refused[][8] = {
                { "circe", "nosuch", "alert", "E1E1E1" },               /* ERR ENOENT */
                { "circe", "arena", "alert", "E1E1E1" },                /* a mediator */
                { "circe", "agility", "emulate", "action", "E1E1E1" },  /* a controller */
                { "circe", "arena", "emulate", "action", "123456" },    /* no such device */
                { "query", "agility", "A", "AutoGpsLat" },              /* not SharedLink */
                { "query", "nosuch", "A", "AutoGpsLat" },
        };
        struct fixture *f = *state;

        daemon_start_circe(f);
        wait_circe_up(f);
        for (size_t i = 0; i < sizeof(refused) / sizeof(refused[0]); i++) {
                int code = run_argv(f, refused[i]);

                if (code != 1)
                        fail_msg("slctl %s %s %s: exit %d, not 1 (%s)", refused[i][0],
                                 refused[i][1], refused[i][2], code, f->err);
                assert_string_equal(f->out, "");
                assert_true(strncmp(f->err, "slctl: ", 7) == 0 && strlen(f->err) > 12);
        }
        assert_int_equal(RUN(f, "circe", "arena", "alert", "E1E1E1"), 1);
        assert_non_null(strstr(f->err, "mediator"));
        assert_int_equal(RUN(f, "circe", "arena", "emulate", "action", "123456"), 1);
        assert_non_null(strstr(f->err, "123456"));
}

/* A link that never comes up: ERR ENOTCONN at once, or after --wait. */
static void test_daemon_link_down(void **state)
{
        struct fixture *f = *state;
        char links[CONFIG_MAX];

        snprintf(links, sizeof(links),
                 "links:\n"
                 "  - name: agility\n"
                 "    protocol: circe\n"
                 "    role: controller\n"
                 "    transport: serial\n"
                 "    device: %s/nothing-here.tty\n", f->h.dir);
        daemon_start(f, links);
        assert_int_equal(RUN(f, "circe", "agility", "alert", "E1E1E1"), 1);
        assert_non_null(strstr(f->err, "not connected"));
        assert_int_equal(RUN(f, "circe", "agility", "alert", "E1E1E1", "--wait", "50"), 1);
        assert_int_equal(RUN(f, "circe", "agility", "sync-clocks", "--wait", "50"), 1);
}

/* Counts DATA lines; stops at the first when arg says so (the count is then negative). */
static int data_line(const char *text, void *arg)
{
        int *n = arg;

        assert_true(text[0] != '\0');
        if (*n < 0)
                return -ECANCELED;
        (*n)++;
        return 0;
}

/* Counts sync-clocks results: [0] timed out, [1] succeeded. */
static int sync_result(const char *addr, int succeeded, void *arg)
{
        int *results = arg;

        assert_int_equal(strlen(addr), 6);
        results[succeeded ? 1 : 0]++;
        return 0;
}

/* The library's side: sl_request with DATA lines, the typed calls, the daemon going away. */
static void test_daemon_library(void **state)
{
        struct fixture *f = *state;
        char reply[SL_REPLY_LINE_MAX + 1], want[64];
        struct sl_daemon_info d = { .size = sizeof(d) };
        int results[2] = { 0, 0 }, n;
        static const char *const dests[] = { "D15D15" };
        struct sl_circe_visualize v = {
                .size = sizeof(v), .dests = dests, .dest_count = 1, .has_current = 1,
                .current = 99,
        };

        daemon_start_circe(f);
        wait_circe_up(f);
        assert_int_equal(sl_daemon_info(f->c, &d), 0);
        assert_int_equal(sl_request(f->c, "ping", 0, NULL, NULL, reply, sizeof(reply)), 0);
        snprintf(want, sizeof(want), "%d ", (int)f->h.pid);
        assert_true(strncmp(reply, want, strlen(want)) == 0);
        /* The epoch the daemon says is the tables' epoch. */
        assert_int_equal(strtoull(reply + strlen(want), NULL, 10) == d.epoch ||
                         strtoull(reply + strlen(want), NULL, 16) == d.epoch, 1);

        /* DATA lines (the core's own stats request) go to the callback, which can stop them. */
        n = 0;
        assert_int_equal(sl_request(f->c, "stats", 0, data_line, &n, reply, sizeof(reply)), 0);
        assert_true(n >= 2);
        n = -1;
        assert_int_equal(sl_request(f->c, "stats", 0, data_line, &n, reply, sizeof(reply)),
                         -ECANCELED);
        assert_true(reply[0] != '\0');

        assert_int_equal(sl_circe_visualize(f->c, "agility", &v, reply, sizeof(reply)), 0);
        wait_value(f, "arena.device.D15D15.current_competitor", "99");
        assert_int_equal(sl_circe_sync_clocks(f->c, "agility", sync_result, results, reply,
                                              sizeof(reply)), 0);
        assert_int_equal(results[1], 3);        /* three devices succeeded */
        assert_int_equal(results[0], 0);
        /* The daemon's errno comes back as is, its message with it. */
        assert_int_equal(sl_circe_alert(f->c, "nosuch", "E1E1E1", reply, sizeof(reply)),
                         -ENOENT);
        assert_true(reply[0] != '\0');
        assert_int_equal(sl_circe_alert(f->c, "arena", "E1E1E1", reply, sizeof(reply)),
                         -EOPNOTSUPP);
        assert_true(sl_query(f->c, "agility", "A", "X", 0, reply, sizeof(reply)) < 0);
        /* A request the daemon does not know is an error from it, not from us. */
        assert_int_equal(sl_request(f->c, "dance", 0, NULL, NULL, reply, sizeof(reply)) < 0, 1);

        /* Stopped: nothing listens any more. */
        assert_int_equal(harness_stop_daemon(&f->h, SIGTERM, WAIT_MS), 0);
        assert_int_equal(sl_circe_alert(f->c, "agility", "E1E1E1", reply, sizeof(reply)),
                         -ECONNREFUSED);
        assert_int_equal(RUN(f, "circe", "agility", "alert", "E1E1E1"), 3);
        assert_non_null(strstr(f->err, "not running"));
        assert_int_equal(RUN(f, "list"), 3);
}


/* SharedLink nodes A and B of one daemon, back to back over a pty; B also knows a silent C. */
static void links_sharedlink(struct fixture *f, char *links, size_t size)
{
        const char *const subst[] = { "@DIR@", f->h.dir, NULL };

        assert_true(testdata_load("slctl_sharedlink_pair.yaml", subst, links, size) > 0);
}

static void daemon_start_sharedlink(struct fixture *f)
{
        char links[CONFIG_MAX];

        links_sharedlink(f, links, sizeof(links));
        daemon_start(f, links);
}

/* Both pairs in one daemon, as `make demo` runs them. */
static void daemon_start_both(struct fixture *f)
{
        char links[CONFIG_MAX], circe[CONFIG_MAX];
        const char *more;
        size_t n;


        links_sharedlink(f, links, sizeof(links));
        links_circe(f, circe, sizeof(circe));
        /* Both templates start "links:": the second one's entries join the first list. */
        more = strncmp(circe, "links:\n", 7) == 0 ? circe + 7 : circe;
        n = strlen(links);
        assert_true(n + strlen(more) < sizeof(links));
        memcpy(links + n, more, strlen(more) + 1);
        daemon_start(f, links);
}

/* ---- bash completion (completion/slctl.bash) ----------------------------------------------- */

#define COMPLETION_SCRIPT "completion/slctl.bash"     /* make check runs in the source tree */
#define WORDS_MAX 16
#define BASH_PATH "/bin/bash"     /* essential on Debian; the harness execs without PATH */

/* Completes the words (the last one is the word being completed) the way bash's programmable
 * completion would: sources the script, sets COMP_WORDS/COMP_CWORD, calls _slctl. Returns
 * COMPREPLY, one per line, sorted, in f->out; a completion never writes to the terminal. */
static void complete_argv(struct fixture *f, const char *const *words)
{
        static const char script[] =
                "set -u; source \"$1\" || exit 9; shift\n"
                "[ \"$(complete -p slctl)\" = 'complete -F _slctl slctl' ] || exit 8\n"
                "COMP_WORDS=(\"$@\"); COMP_CWORD=$(($# - 1)); COMP_LINE=\"$*\"\n"
                "_slctl || exit 7\n"
                "[ ${#COMPREPLY[@]} -eq 0 ] || printf '%s\\n' \"${COMPREPLY[@]}\" | sort\n";
        const char *argv[WORDS_MAX + 6] = { BASH_PATH, "-c", script, "bash", COMPLETION_SCRIPT,
                                            harness_slctl_path() };
        size_t n = 6;
        int r;

        for (size_t i = 0; words[i]; i++) {
                assert_true(n < WORDS_MAX + 5);
                argv[n++] = words[i];
        }
        argv[n] = NULL;
        r = harness_run_capture(&f->h, f->out, sizeof(f->out), f->err, sizeof(f->err),
                                RUN_LIMIT_MS, argv);
        if (r != 0 || f->err[0])
                fail_msg("completing: bash exit %d, output \"%s\", stderr \"%s\"", r, f->out,
                         f->err);
}

#define COMPLETE(f, ...) complete_argv((f), (const char *const[]){ __VA_ARGS__, NULL })

/* Commands, options and fixed values from the script; names, links, peers and devices from
 * the real daemon through slctl; -i INSTANCE passed along. */
static void test_completion(void **state)
{
        struct fixture *f = *state;
        char words[sizeof(f->h.dir) + sizeof(f->h.instance) + 16];

        daemon_start_both(f);
        wait_circe_up(f);
        COMPLETE(f, "");
        assert_string_equal(f->out, "circe\ncommand\nevents\nget\nhelp\nlist\nping\nquery\n"
                            "record\nset\nstats\nwatch\n");
        COMPLETE(f, "st");
        assert_string_equal(f->out, "stats\n");
        COMPLETE(f, "--v");
        assert_string_equal(f->out, "--version\n");
        COMPLETE(f, "help", "ci");
        assert_string_equal(f->out, "circe\n");
        COMPLETE(f, "stats", "--");
        assert_string_equal(f->out, "--all\n--help\n--json\n");
        COMPLETE(f, "events", "--f");
        assert_string_equal(f->out, "--follow\n");
        /* Variables: every one for get, the outbound ones for set, none for set's value. */
        COMPLETE(f, "get", "b.");
        assert_string_equal(f->out, "b.Cmd\nb.ForC\nb.Head\nb.Lat\n");
        COMPLETE(f, "watch", "--count", "3", "agility.device.E1E1E1.s");
        assert_string_equal(f->out, "agility.device.E1E1E1.sensor_time\n"
                            "agility.device.E1E1E1.signal\n");
        COMPLETE(f, "set", "");
        assert_string_equal(f->out, "a.Head\na.Lat\nb.Cmd\nb.ForC\n");
        COMPLETE(f, "set", "a.Lat", "");
        assert_string_equal(f->out, "");
        /* -i: the instance on the line is asked, not the default; and instances complete. */
        COMPLETE(f, "-i", "nosuchinstance", "get", "b.");
        assert_string_equal(f->out, "");
        snprintf(words, sizeof(words), "-i%s", f->h.instance);
        COMPLETE(f, words, "get", "b.L");
        assert_string_equal(f->out, "b.Lat\n");
        COMPLETE(f, "-i", f->h.instance);
        snprintf(words, sizeof(words), "%s\n", f->h.instance);
        assert_string_equal(f->out, words);
        /* Links by protocol, peers, CIRCE operations and device addresses. */
        COMPLETE(f, "query", "");
        assert_string_equal(f->out, "node_a\nnode_b\n");
        COMPLETE(f, "query", "--timeout", "100", "node_b", "");
        assert_string_equal(f->out, "A\nC\n");
        COMPLETE(f, "ping", "--wait", "100", "node_b", "");
        assert_string_equal(f->out, "A\nC\n");
        COMPLETE(f, "ping", "--");
        assert_string_equal(f->out, "--help\n--timeout\n--wait\n");
        COMPLETE(f, "command", "");
        assert_string_equal(f->out, "node_a\nnode_b\n");
        COMPLETE(f, "command", "--wait", "100", "node_a", "");
        assert_string_equal(f->out, "");
        COMPLETE(f, "command", "--");
        assert_string_equal(f->out, "--help\n--wait\n");
        COMPLETE(f, "circe", "");
        assert_string_equal(f->out, "agility\narena\n");
        COMPLETE(f, "circe", "agility", "");
        assert_string_equal(f->out, "alert\ndevice-setup\nemulate\nnetwork-setup\n"
                            "sync-clocks\nvisualize\n");
        COMPLETE(f, "circe", "agility", "alert", "");
        assert_string_equal(f->out, "AAAAAA\nD15D15\nE1E1E1\n");
        COMPLETE(f, "circe", "arena", "emulate", "");
        assert_string_equal(f->out, "action\n");
        COMPLETE(f, "circe", "arena", "emulate", "action", "E");
        assert_string_equal(f->out, "E1E1E1\n");
        COMPLETE(f, "circe", "agility", "sync-clocks", "");
        assert_string_equal(f->out, "");
        COMPLETE(f, "circe", "agility", "visualize", "D15D15", "--el");
        assert_string_equal(f->out, "--eliminated\n");
        COMPLETE(f, "circe", "agility", "visualize", "D15D15", "--eliminated", "");
        assert_string_equal(f->out, "0\n1\n");
        COMPLETE(f, "circe", "agility", "device-setup", "--assign", "123456", "--dest", "A");
        assert_string_equal(f->out, "AAAAAA\n");
        COMPLETE(f, "circe", "agility", "network-setup", "E1E1E1", "--r");
        assert_string_equal(f->out, "--roles\n");
        /* record: its options, any link, then the file (from the file system). */
        COMPLETE(f, "rec");
        assert_string_equal(f->out, "record\n");
        COMPLETE(f, "record", "--");
        assert_string_equal(f->out, "--count\n--duration\n--help\n");
        COMPLETE(f, "record", "");
        assert_string_equal(f->out, "agility\narena\nnode_a\nnode_b\n");
        COMPLETE(f, "record", "--duration", "5", "no");
        assert_string_equal(f->out, "node_a\nnode_b\n");
        COMPLETE(f, "record", "--count", "9", "");
        assert_string_equal(f->out, "agility\narena\nnode_a\nnode_b\n");
        assert_int_equal(harness_write_file(&f->h, "old.rec", "", NULL), 0);
        assert_int_equal(harness_write_file(&f->h, "old.txt", "", NULL), 0);
        snprintf(words, sizeof(words), "%s/old.r", f->h.dir);
        COMPLETE(f, "record", "node_a", words);
        snprintf(words, sizeof(words), "%s/old.rec\n", f->h.dir);
        assert_string_equal(f->out, words);
        snprintf(words, sizeof(words), "%s/old.", f->h.dir);
        COMPLETE(f, "record", "--duration", "60", "agility", words);
        assert_non_null(strstr(f->out, "old.rec\n"));
        assert_non_null(strstr(f->out, "old.txt\n"));
        COMPLETE(f, "record", "node_a", words, "");
        assert_string_equal(f->out, "");
}

/* With no daemon, the fixed words still complete, and slctl's complaints stay hidden. */
static void test_completion_no_daemon(void **state)
{
        struct fixture *f = *state;

        COMPLETE(f, "s");
        assert_string_equal(f->out, "set\nstats\n");
        COMPLETE(f, "co");
        assert_string_equal(f->out, "command\n");
        COMPLETE(f, "get", "");
        assert_string_equal(f->out, "");
        COMPLETE(f, "record", "");
        assert_string_equal(f->out, "");
        COMPLETE(f, "record", "--d");
        assert_string_equal(f->out, "--duration\n");
        COMPLETE(f, "circe", "x", "");
        assert_string_equal(f->out, "alert\ndevice-setup\nemulate\nnetwork-setup\n"
                            "sync-clocks\nvisualize\n");
}

/* ---- slctl stats: the counters that apply -------------------------------------------------- */

/* One section of `slctl stats` text: the daemon's (name "") or a link's, its counters in order. */
struct stats_section {
        char name[SL_LINK_NAME_SIZE];
        unsigned scope;
        unsigned n;
        char names[SL_COUNTERS_MAX][SL_NAME_SIZE];
        uint64_t values[SL_COUNTERS_MAX];
};

#define STATS_SECTIONS_MAX 8

/* Parses `slctl stats` text into sections; returns how many. */
static unsigned stats_parse(const char *text, struct stats_section *sec)
{
        unsigned count = 0;
        char line[512];

        for (const char *p = text; *p; ) {
                size_t len = strcspn(p, "\n");
                struct stats_section *cur = count ? &sec[count - 1] : NULL;
                char proto[SL_PROTOCOL_SIZE + 4];
                const char *w;
                int used;

                assert_true(len < sizeof(line));
                memcpy(line, p, len);
                line[len] = '\0';
                p += len + (p[len] == '\n');
                if (strncmp(line, "instance ", 9) == 0 || strncmp(line, "link ", 5) == 0) {
                        assert_true(count < STATS_SECTIONS_MAX);
                        cur = &sec[count++];
                        memset(cur, 0, sizeof(*cur));
                        cur->scope = COUNTERS_DAEMON;
                        if (line[0] == 'l') {
                                assert_int_equal(sscanf(line, "link %31s (%19[^)])", cur->name,
                                                        proto), 2);
                                cur->scope = counters_protocol_scope(proto);
                        }
                        continue;
                }
                if (strncmp(line, "  epoch ", 8) == 0)
                        continue;
                assert_non_null(cur);
                for (w = line; sscanf(w, " %47s %" SCNu64 "%n", cur->names[cur->n],
                                      &cur->values[cur->n], &used) == 2; w += used) {
                        assert_true(cur->n < SL_COUNTERS_MAX - 1);
                        cur->n++;
                }
        }
        return count;
}

/* A section shows exactly the counters of its scope (all: every one), non-zero first. */
static void stats_check_section(const struct stats_section *sec, int all)
{
        unsigned want = 0, zero_seen = 0;

        for (unsigned k = 0; k < counters_known(); k++)
                want += all || (counters_scope(counters_known_name(k)) & sec->scope) != 0;
        if (sec->n != want)
                fail_msg("stats%s: section \"%s\" shows %u counters, %u apply", all ? " --all" : "",
                         sec->name, sec->n, want);
        for (unsigned i = 0; i < sec->n; i++) {
                if (!all && !(counters_scope(sec->names[i]) & sec->scope))
                        fail_msg("stats: \"%s\" shows %s", sec->name, sec->names[i]);
                if (sec->values[i] == 0)
                        zero_seen = 1;
                else if (zero_seen)
                        fail_msg("stats: \"%s\": %s is non-zero after a zero counter",
                                 sec->name, sec->names[i]);
        }
}

/* The real daemon, both protocols with traffic, errors and queries: no counter moves outside
 * the scope slctl gives it (else stats would hide it), and stats shows exactly the counters
 * that apply, non-zero first; --all every counter; --json every counter, always. */
static void test_daemon_stats_scope(void **state)
{
        struct fixture *f = *state;
        struct stats_section *sec = calloc(STATS_SECTIONS_MAX, sizeof(*sec));
        struct sl_link_info *l = calloc(1, sizeof(*l));
        struct sl_daemon_info d = { .size = sizeof(d) };
        unsigned nsec, nonzero = 0;
        int links;

        assert_non_null(sec);
        assert_non_null(l);
        daemon_start_both(f);
        wait_circe_up(f);
        assert_int_equal(RUN(f, "set", "a.Lat", "40.5"), 0);
        wait_value(f, "b.Lat", "40.5");
        assert_int_equal(RUN(f, "query", "--wait", "10000", "node_b", "A", "a.Lat"), 0);
        assert_int_equal(RUN(f, "query", "--timeout", "100", "node_b", "C", "x"), 1);
        assert_int_equal(RUN(f, "set", "b.Cmd", "bad|value"), 1);
        assert_int_equal(RUN(f, "circe", "arena", "emulate", "action", "E1E1E1"), 0);

        links = sl_link_count(f->c);
        assert_int_equal(links, 4);
        for (int i = 0; i < links; i++) {
                int r = -EAGAIN;

                for (int t = 0; t < 64 && r == -EAGAIN; t++) {
                        memset(l, 0, sizeof(*l));
                        l->size = sizeof(*l);
                        r = sl_link_info(f->c, i, l);
                }
                assert_int_equal(r, 0);
                for (unsigned k = 0; k < l->counter_count; k++) {
                        if (!l->counters[k].value)
                                continue;
                        nonzero++;
                        if (!(counters_scope(l->counters[k].name) &
                              counters_protocol_scope(l->protocol)))
                                fail_msg("link %s (%s) moved %s, outside its scope", l->name,
                                         l->protocol, l->counters[k].name);
                }
        }
        assert_true(nonzero > 8);
        assert_int_equal(sl_daemon_info(f->c, &d), 0);
        for (unsigned k = 0; k < d.counter_count; k++)
                if (d.counters[k].value && !(counters_scope(d.counters[k].name) & COUNTERS_DAEMON))
                        fail_msg("the daemon moved %s, outside its scope", d.counters[k].name);

        assert_int_equal(RUN(f, "stats"), 0);
        nsec = stats_parse(f->out, sec);
        assert_int_equal(nsec, 5);
        for (unsigned i = 0; i < nsec; i++)
                stats_check_section(&sec[i], 0);
        assert_string_equal(sec[1].name, "node_a");
        assert_int_equal(sec[1].scope, COUNTERS_SHAREDLINK);
        assert_int_equal(sec[4].scope, COUNTERS_CIRCE);
        assert_true(sec[1].values[0] > 0);             /* node_a had frames: first is non-zero */
        assert_int_equal(RUN(f, "stats", "--all"), 0);
        assert_int_equal(stats_parse(f->out, sec), 5);
        for (unsigned i = 0; i < nsec; i++)
                stats_check_section(&sec[i], 1);
        assert_int_equal(RUN(f, "stats", "--json", "--all"), 0);
        assert_json(f, f->out);
        assert_int_equal(RUN(f, "stats", "--json"), 0);
        assert_json(f, f->out);
        /* Every counter in every section, also the other protocol's: a SharedLink-only one
         * in the daemon's and the 4 links' objects. */
        nsec = 0;
        for (const char *p = f->out; (p = strstr(p, "\"not_for_us\":")) != NULL; p++)
                nsec++;
        assert_int_equal(nsec, 5);
        free(sec);
        free(l);
}

/* slctl query: the peer's answer, through the daemon and the wire. */
static void test_daemon_query(void **state)
{
        struct fixture *f = *state;
        char reply[SL_VALUE_SIZE];

        daemon_start_sharedlink(f);
        assert_int_equal(RUN(f, "set", "a.Lat", "40.5"), 0);
        assert_int_equal(RUN(f, "set", "a.Head", "north by east"), 0);
        /* --wait: the link may still be coming up. */
        assert_int_equal(RUN(f, "query", "--wait", "10000", "node_b", "A", "a.Lat"), 0);
        assert_string_equal(f->out, "40.5\n");
        assert_int_equal(RUN(f, "query", "--wait", "10000", "--timeout", "5000", "node_b", "A",
                             "a.Head"), 0);
        assert_string_equal(f->out, "north by east\n");
        /* A name the peer does not know: an empty answer. */
        assert_int_equal(RUN(f, "query", "--wait", "10000", "node_b", "A", "NoSuchName"), 0);
        assert_string_equal(f->out, "\n");
        /* A peer that never answers; one the link does not have. */
        assert_int_equal(RUN(f, "query", "--timeout", "100", "node_b", "C", "x"), 1);
        assert_true(f->err[0] != '\0');
        assert_int_equal(RUN(f, "query", "node_b", "D", "x"), 1);
        assert_int_equal(RUN(f, "circe", "node_b", "alert", "E1E1E1"), 1);     /* not CIRCE */

        /* The library: the value's length, or -ENOBUFS when it does not fit. */
        assert_int_equal(sl_set_command_wait(f->c, 10000), 0);
        assert_int_equal(sl_query(f->c, "node_b", "A", "a.Lat", 0, reply, sizeof(reply)), 4);
        assert_string_equal(reply, "40.5");
        assert_int_equal(sl_query(f->c, "node_b", "A", "a.Lat", 0, reply, 4), -ENOBUFS);
        assert_int_equal(sl_query(f->c, "node_b", "C", "x", 100, reply, sizeof(reply)),
                         -ETIMEDOUT);
}

/* slctl ping and sl_ping: P0 over the pty to the other node, its G0 back; the peer that never
 * answers, one the link lacks, a bad timeout, a link that does not exist. */
static void test_daemon_ping(void **state)
{
        struct fixture *f = *state;
        char reply[SL_REPLY_LINE_MAX + 1];
        uint64_t rtt_ns = 0;

        daemon_start_sharedlink(f);
        assert_int_equal(RUN(f, "ping", "--wait", "10000", "node_b", "A"), 0);
        assert_int_equal(strncmp(f->out, "G0 from A on node_b: time=", 26), 0);
        assert_non_null(strstr(f->out, " ms\n"));
        assert_int_equal(RUN(f, "ping", "--timeout", "100", "node_b", "C"), 1);
        assert_non_null(strstr(f->err, "no pong from peer C within 100 ms"));
        assert_int_equal(RUN(f, "ping", "node_b", "D"), 1);
        assert_non_null(strstr(f->err, "D is not a peer of link node_b"));
        assert_int_equal(RUN(f, "ping", "--timeout", "0", "node_b", "A"), 1);
        assert_int_equal(RUN(f, "ping", "node_b"), 2);

        assert_int_equal(sl_set_command_wait(f->c, 10000), 0);
        assert_int_equal(sl_ping(f->c, "node_a", "B", 5000, &rtt_ns, reply, sizeof(reply)), 0);
        assert_true(rtt_ns > 0);
        assert_int_equal(sl_ping(f->c, "node_b", "A", 0, NULL, NULL, 0), 0);
        assert_int_equal(sl_ping(f->c, "node_b", "C", 100, &rtt_ns, reply, sizeof(reply)),
                         -ETIMEDOUT);
        assert_non_null(strstr(reply, "no pong"));
        assert_int_equal(sl_ping(f->c, "node_b", "Z", 0, NULL, reply, sizeof(reply)), -EINVAL);
        assert_int_equal(sl_ping(f->c, "node_b", "A", 60001, NULL, reply, sizeof(reply)),
                         -EINVAL);
        assert_int_equal(sl_ping(f->c, "nolink", "A", 0, NULL, reply, sizeof(reply)), -ENOENT);
}

/*
 * An operation for the other protocol's links: EOPNOTSUPP, not EINVAL, on the control socket
 * (ERR 95), from the library and from slctl, each saying which protocol the link speaks.
 */
static void test_daemon_wrong_protocol(void **state)
{
        static const char *const lines[][2] = {
                { "query agility A a.Lat", "link agility speaks circe: query is for sharedlink" },
                { "command agility ServoPod 0,Stop",
                  "link agility speaks circe: command is for sharedlink" },
                { "circe node_b alert E1E1E1",
                  "link node_b speaks sharedlink: circe is for circe" },
        };
        struct fixture *f = *state;
        char sock[2 * HARNESS_PATH_MAX], reply[SL_REPLY_LINE_MAX + 1], want[SL_REPLY_LINE_MAX];
        int fd;

        daemon_start_both(f);
        snprintf(sock, sizeof(sock), "%s/%s.sock", f->h.dir, f->h.instance);
        fd = harness_connect_unix(sock);
        assert_true(fd >= 0);
        for (size_t i = 0; i < sizeof(lines) / sizeof(lines[0]); i++) {
                assert_true(harness_control_request(fd, lines[i][0], reply, sizeof(reply),
                                                    WAIT_MS) > 0);
                snprintf(want, sizeof(want), "ERR %d %s links (operation not supported on this "
                         "link's protocol)\n", EOPNOTSUPP, lines[i][1]);
                assert_string_equal(reply, want);
        }
        close(fd);

        assert_int_equal(sl_query(f->c, "agility", "A", "a.Lat", 0, reply, sizeof(reply)),
                         -EOPNOTSUPP);
        assert_non_null(strstr(reply, "speaks circe"));
        assert_int_equal(sl_command(f->c, "agility", "ServoPod", "0,Stop"), -EOPNOTSUPP);
        assert_int_equal(sl_circe_alert(f->c, "node_b", "E1E1E1", reply, sizeof(reply)),
                         -EOPNOTSUPP);
        assert_non_null(strstr(reply, "speaks sharedlink"));
        assert_non_null(strstr(sl_strerror(-EOPNOTSUPP), "not supported"));

        assert_int_equal(RUN(f, "query", "agility", "A", "a.Lat"), 1);
        assert_non_null(strstr(f->err, "slctl: link agility speaks circe: query is for "
                               "sharedlink links (operation not supported"));
        assert_int_equal(RUN(f, "command", "agility", "ServoPod", "0,Stop"), 1);
        assert_non_null(strstr(f->err, "slctl: link agility speaks circe: command is for "
                               "sharedlink links (operation not supported"));
        assert_int_equal(RUN(f, "circe", "node_b", "alert", "E1E1E1"), 1);
        assert_non_null(strstr(f->err, "slctl: link node_b speaks sharedlink: circe is for "
                               "circe links (operation not supported"));
        /* A SharedLink link without a pronto4 peer is still told apart. */
        assert_int_equal(RUN(f, "command", "node_b", "ServoPod", "0,Stop"), 1);
        assert_non_null(strstr(f->err, "link node_b has no pronto4 peer"));
}

/*
 * Layout 1.2: the daemon publishes its control socket in the tables, so slctl and the library
 * find a socket in a temporary runtime directory with no SHAREDLINK_RUNTIME_DIR at all.
 */
static void test_daemon_published_socket(void **state)
{
        struct fixture *f = *state;
        struct sl_client *c = NULL;
        char reply[SL_VALUE_SIZE], want[64];

        unsetenv("SHAREDLINK_RUNTIME_DIR");     /* of this process, in case a user set it */
        daemon_start_sharedlink(f);
        f->no_runtime_env = 1;
        assert_int_equal(RUN(f, "set", "a.Lat", "40.5"), 0);
        assert_int_equal(RUN(f, "query", "--wait", "10000", "node_b", "A", "a.Lat"), 0);
        assert_string_equal(f->out, "40.5\n");
        assert_int_equal(RUN(f, "stats"), 0);
        snprintf(want, sizeof(want), "sharedlinkd pid %d, running", (int)f->h.pid);
        assert_non_null(strstr(f->out, want));
        /* A handle that was never told the directory: the published path. */
        assert_int_equal(sl_open(f->h.instance, &c), 0);
        assert_int_equal(sl_set_command_wait(c, 10000), 0);
        assert_int_equal(sl_query(c, "node_b", "A", "a.Lat", 0, reply, sizeof(reply)), 4);
        assert_string_equal(reply, "40.5");
        /* The environment still wins over it: a directory nobody listens in is refused. */
        assert_int_equal(setenv("SHAREDLINK_RUNTIME_DIR", "/nonexistent/sharedlink", 1), 0);
        assert_int_equal(sl_set_runtime_dir(c, NULL), 0);
        unsetenv("SHAREDLINK_RUNTIME_DIR");
        assert_int_equal(sl_query(c, "node_b", "A", "a.Lat", 0, reply, sizeof(reply)),
                         -ECONNREFUSED);
        sl_close(c);
}

/* The table commands on the real daemon's tables. */
static void test_daemon_tables(void **state)
{
        struct fixture *f = *state;

        daemon_start_circe(f);
        wait_circe_up(f);
        assert_int_equal(RUN(f, "get", "agility.state", "agility.mediator.version"), 0);
        assert_string_equal(f->out, "connected\n0.2.3\n");
        assert_int_equal(RUN(f, "list", "--json"), 0);
        assert_json(f, f->out);
        assert_non_null(strstr(f->out, "\"name\":\"agility.device.E1E1E1.battery\""));
        assert_int_equal(RUN(f, "stats", "--json"), 0);
        assert_json(f, f->out);
        assert_non_null(strstr(f->out, "\"name\":\"agility\",\"protocol\":\"circe\""));
        assert_int_equal(RUN(f, "stats"), 0);
        assert_non_null(strstr(f->out, "link agility (circe): connected for "));
        assert_int_equal(RUN(f, "events", "--count", "1"), 0);
        assert_int_equal(count_lines(f->out), 1);
        /* Inbound variables are the daemon's. */
        assert_int_equal(RUN(f, "set", "agility.state", "x"), 1);
}

/* 1 when process pid sleeps in nanosleep/clock_nanosleep (its /proc syscall line); -1 gone. */
static int proc_napping(pid_t pid)
{
        char path[64], line[128] = "";
        long nr = -1;
        FILE *fp;

        snprintf(path, sizeof(path), "/proc/%d/syscall", (int)pid);
        fp = fopen(path, "re");
        if (!fp)
                return -1;
        if (fgets(line, sizeof(line), fp))
                nr = strtol(line, NULL, 10);
        fclose(fp);
        return nr == SYS_nanosleep || nr == SYS_clock_nanosleep;
}

/*
 * A member truncates .out (issue 19.3) while the daemon cannot answer at once (stopped here, so
 * the first write surely finds the table unusable): `slctl set` rings the daemon, waits instead
 * of failing with "try again", and goes through once the daemon has recreated the table.
 */
static void test_daemon_out_truncated(void **state)
{
        struct fixture *f = *state;
        char path[sizeof(f->h.instance) + 32];
        struct proc p;
        int fd, code;

        daemon_start_sharedlink(f);
        assert_int_equal(RUN(f, "set", "a.Lat", "40.5"), 0);
        snprintf(path, sizeof(path), "/dev/shm/sharedlink.%s.out", f->h.instance);
        assert_int_equal(kill(f->h.pid, SIGSTOP), 0);
        fd = open(path, O_WRONLY | O_TRUNC | O_CLOEXEC);
        assert_true(fd >= 0);
        close(fd);
        f->out[0] = f->err[0] = '\0';
        proc_start(f, (const char *const[]){ "set", "a.Lat", "41.5", NULL }, &p);
        /* Until slctl has found the table unusable and waits (or, without the wait, has ended). */
        for (int i = 0; i < 5000 && proc_napping(p.pid) == 0; i++)
                nanosleep(&(struct timespec){ 0, 1000000 }, NULL);
        assert_int_equal(kill(f->h.pid, SIGCONT), 0);
        code = proc_finish(&p, f->out, sizeof(f->out), f->err, sizeof(f->err));
        if (code != 0)
                fail_msg("slctl set after a truncated .out: exit %d: %s", code, f->err);
        wait_value(f, "b.Lat", "41.5");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_json_checker),
                cmocka_unit_test_setup_teardown(test_list, setup, teardown),
                cmocka_unit_test_setup_teardown(test_get, setup, teardown),
                cmocka_unit_test_setup_teardown(test_set, setup, teardown),
                cmocka_unit_test_setup_teardown(test_watch, setup, teardown),
                cmocka_unit_test_setup_teardown(test_watch_interrupted, setup, teardown),
                cmocka_unit_test_setup_teardown(test_watch_new_names, setup, teardown),
                cmocka_unit_test_setup_teardown(test_events_ring, setup, teardown),
                cmocka_unit_test_setup_teardown(test_events_follow, setup, teardown),
                cmocka_unit_test_setup_teardown(test_stats, setup, teardown),
                cmocka_unit_test_setup_teardown(test_usage, setup, teardown),
                cmocka_unit_test_setup_teardown(test_help, setup, teardown),
                cmocka_unit_test_setup_teardown(test_bad_input, setup, teardown),
                cmocka_unit_test_setup_teardown(test_not_a_member, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_not_running, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_dead_daemon, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_daemon_circe, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_daemon_refusals, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_daemon_link_down, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_daemon_library, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_daemon_tables, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_daemon_out_truncated, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_daemon_query, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_daemon_ping, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_daemon_wrong_protocol, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_daemon_published_socket, setup_bare,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_daemon_stats_scope, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_completion, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_completion_no_daemon, setup_bare, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
