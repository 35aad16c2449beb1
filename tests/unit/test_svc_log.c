/*
 * log: priority prefixes, verbosity, errno text, escaping, truncation, rate limiting.
 * Lines are captured through a pipe given to log_init().
 */
#define _GNU_SOURCE     /* pipe2 */
#include <errno.h>
#include <fcntl.h>
#include <setjmp.h>
#include <stdbool.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "svc/log.h"

#define CAPTURE_MAX     (64 * 1024)
#define MS              1000000ull      /* ns */

struct capture {
        int rfd, wfd;
        char buf[CAPTURE_MAX];
};

static int setup(void **state)
{
        static struct capture c;
        int p[2];

        if (pipe2(p, O_CLOEXEC | O_NONBLOCK) < 0)
                return -1;
        c.rfd = p[0];
        c.wfd = p[1];
        log_init(0, c.wfd);
        *state = &c;
        return 0;
}

static int teardown(void **state)
{
        struct capture *c = *state;

        log_init(0, -1);
        close(c->rfd);
        close(c->wfd);
        return 0;
}

/* Everything logged since the last call, NUL-terminated. */
static const char *drain(struct capture *c)
{
        ssize_t n = read(c->rfd, c->buf, sizeof(c->buf) - 1);

        c->buf[n > 0 ? n : 0] = '\0';
        return c->buf;
}

static unsigned count_lines(const char *s)
{
        unsigned n = 0;

        for (; *s; s++)
                n += *s == '\n';
        return n;
}

static void test_prefixes(void **state)
{
        struct capture *c = *state;
        static const struct {
                int verbosity;
                bool debug, info;       /* which of the optional lines appear */
        } table[] = {
                { -5, false, false },
                { -1, false, false },
                { 0, false, true },
                { 1, true, true },
                { 9, true, true },
        };

        for (size_t i = 0; i < sizeof(table) / sizeof(table[0]); i++) {
                char expect[256];

                snprintf(expect, sizeof(expect), "%s%s<4>w 1: %s\n<4>wx 2\n",
                         table[i].debug ? "<7>d 5\n" : "",
                         table[i].info ? "<6>i 3\n<5>n 4\n" : "", strerror(ENOENT));
                log_init(table[i].verbosity, c->wfd);
                log_debug("d %d", 5);
                log_info("i %d", 3);
                log_notice("n %d", 4);
                errno = ENOENT;
                log_warn("w %d", 1);
                assert_int_equal(errno, ENOENT);        /* log_warn keeps errno */
                log_warnx("wx %d", 2);
                assert_string_equal(drain(c), expect);
                assert_int_equal(log_verbosity(), table[i].verbosity);
        }
        log_init(0, c->wfd);
        log_msg(LOG_PRIO_ERR, "e");
        log_msg(LOG_PRIO_DEBUG, "hidden");
        assert_string_equal(drain(c), "<3>e\n");
}

static void test_escape_and_truncate(void **state)
{
        struct capture *c = *state;
        char big[3 * LOG_LINE_MAX];
        const char *out;

        log_info("frame [%s] end", "a\nb\r\x7f");
        assert_string_equal(drain(c), "<6>frame [a\\x0ab\\x0d\\x7f] end\n");

        memset(big, 'x', sizeof(big) - 1);
        big[sizeof(big) - 1] = '\0';
        log_info("%s", big);
        out = drain(c);
        assert_int_equal(count_lines(out), 1);
        assert_true(strlen(out) <= LOG_LINE_MAX);
        assert_non_null(strstr(out, "...\n"));
        assert_memory_equal(out, "<6>xxx", 6);
}

static void test_ratelimit_counts(void **state)
{
        struct capture *c = *state;
        struct log_ratelimit rl;
        unsigned passed = 0;
        const char *out;

        log_ratelimit_init(&rl, "vehicle", 1000, 3);
        /* 10 messages in the first window: 3 pass, 7 suppressed. */
        for (int i = 0; i < 10; i++)
                passed += log_ratelimit_pass(&rl, 5 * MS + (uint64_t)i * MS);
        assert_int_equal(passed, 3);
        assert_int_equal(rl.suppressed, 7);
        assert_string_equal(drain(c), "");

        /* Still inside the window (999 ms after its start): suppressed. */
        assert_false(log_ratelimit_pass(&rl, 1004 * MS));
        assert_int_equal(rl.suppressed, 8);

        /* Next window: the summary comes first, then the message may pass. */
        assert_true(log_ratelimit_pass(&rl, 1005 * MS));
        out = drain(c);
        assert_string_equal(out, "<5>vehicle: suppressed 8 messages\n");
        assert_int_equal(rl.suppressed, 0);
        assert_int_equal(rl.suppressed_total, 8);

        /* Two more pass, the third is suppressed; flush reports it without a new window. */
        assert_true(log_ratelimit_pass(&rl, 1006 * MS));
        assert_true(log_ratelimit_pass(&rl, 1007 * MS));
        assert_false(log_ratelimit_pass(&rl, 1008 * MS));
        assert_true(log_ratelimit_flush(&rl));
        assert_false(log_ratelimit_flush(&rl));
        assert_string_equal(drain(c), "<5>vehicle: suppressed 1 messages\n");
        assert_int_equal(rl.suppressed_total, 9);
}

static void test_ratelimit_zero_burst_and_backwards_clock(void **state)
{
        struct capture *c = *state;
        struct log_ratelimit rl;

        log_ratelimit_init(&rl, "x", 1000, 0);
        assert_false(log_ratelimit_pass(&rl, 10 * MS));
        assert_false(log_ratelimit_pass(&rl, 5000 * MS));
        assert_int_equal(rl.suppressed, 2);

        log_ratelimit_init(&rl, "y", 1000, 1);
        assert_true(log_ratelimit_pass(&rl, 5000 * MS));
        assert_false(log_ratelimit_pass(&rl, 5001 * MS));
        /* Time going backwards opens a new window rather than suppressing forever. */
        assert_true(log_ratelimit_pass(&rl, 10 * MS));
        assert_string_equal(drain(c), "<5>y: suppressed 1 messages\n");
}

static void test_ratelimited_wrapper(void **state)
{
        struct capture *c = *state;
        struct log_ratelimit rl;
        const char *out;

        /* A window far longer than this test: exactly `burst` lines get out. */
        log_ratelimit_init(&rl, "link", 3600 * 1000, 2);
        for (int i = 0; i < 5; i++)
                log_ratelimited(&rl, LOG_PRIO_WARNING, "bad checksum %d", i);
        out = drain(c);
        assert_string_equal(out, "<4>bad checksum 0\n<4>bad checksum 1\n");
        assert_int_equal(rl.suppressed, 3);

        /* Debug messages hidden by the verbosity are not counted as suppressed. */
        log_ratelimited(&rl, LOG_PRIO_DEBUG, "noise");
        assert_int_equal(rl.suppressed, 3);
        assert_string_equal(drain(c), "");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_prefixes, setup, teardown),
                cmocka_unit_test_setup_teardown(test_escape_and_truncate, setup, teardown),
                cmocka_unit_test_setup_teardown(test_ratelimit_counts, setup, teardown),
                cmocka_unit_test_setup_teardown(test_ratelimit_zero_burst_and_backwards_clock,
                                                setup, teardown),
                cmocka_unit_test_setup_teardown(test_ratelimited_wrapper, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
