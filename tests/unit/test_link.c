/*
 * link.c's pure helpers: the core's wait=MS parsing (link_command_wait, link_parse_ms) and the
 * command-word routing (link_protocol_for_command). The wait queue (link_waitq_*) works on real
 * control requests: test_link_sharedlink.c and test_link_circe.c drive it through both engines.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "daemon/link.h"

#define WORDS_MAX       8

static int split(char *line, char **argv)
{
        int n = 0;

        for (char *w = strtok(line, " "); w && n < WORDS_MAX; w = strtok(NULL, " "))
                argv[n++] = w;
        return n;
}

struct wait_case {
        const char *line;
        int result;             /* 0 or -EINVAL */
        int argc;               /* words left */
        unsigned wait_ms;
};

static const struct wait_case wait_cases[] = {
        { "query veh A X", 0, 4, 0 },
        { "query veh A X 100 wait=250", 0, 5, 250 },
        { "circe a sync-clocks wait=0", 0, 3, 0 },
        { "circe a alert E1E1E1 wait=60000", 0, 4, 60000 },
        { "circe a wait=5", 0, 2, 5 },
        /* WORD LINK are never a wait: the engine reports what is missing. */
        { "query wait=5", 0, 2, 0 },
        /* Only the last word. */
        { "circe a emulate action E1E1E1 wait=5 keys=1", 0, 7, 0 },
        { "query veh A X wait=60001", -EINVAL, 5, 0 },
        { "query veh A X wait=", -EINVAL, 5, 0 },
        { "query veh A X wait=-5", -EINVAL, 5, 0 },
        { "query veh A X wait=12ms", -EINVAL, 5, 0 },
        { "query veh A X wait=99999999999999999999", -EINVAL, 5, 0 },
};

static void test_command_wait(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(wait_cases) / sizeof(wait_cases[0]); i++) {
                const struct wait_case *k = &wait_cases[i];
                char buf[128], err[128] = "", *argv[WORDS_MAX];
                unsigned wait_ms = 12345;
                int argc, r;

                snprintf(buf, sizeof(buf), "%s", k->line);
                argc = split(buf, argv);
                r = link_command_wait(&argc, argv, &wait_ms, err, sizeof(err));
                if (r != k->result || argc != k->argc)
                        fail_msg("\"%s\": %d, %d words (want %d, %d)", k->line, r, argc,
                                 k->result, k->argc);
                if (r == 0) {
                        assert_int_equal(wait_ms, k->wait_ms);
                } else {
                        /* Nothing written on failure but the reason. */
                        assert_int_equal(wait_ms, 12345);
                        assert_non_null(strstr(err, "bad wait \""));
                        assert_non_null(strstr(err, "0..60000"));
                }
        }
}

static void test_parse_ms(void **state)
{
        unsigned v = 7;

        (void)state;
        assert_int_equal(link_parse_ms("1", 1, 10, &v), 0);
        assert_int_equal(v, 1);
        assert_int_equal(link_parse_ms("10", 1, 10, &v), 0);
        assert_int_equal(v, 10);
        assert_int_equal(link_parse_ms("0", 1, 10, &v), -EINVAL);
        assert_int_equal(link_parse_ms("11", 1, 10, &v), -EINVAL);
        assert_int_equal(link_parse_ms("", 0, 10, &v), -EINVAL);
        assert_int_equal(link_parse_ms("+1", 0, 10, &v), -EINVAL);
        assert_int_equal(link_parse_ms("1 ", 0, 10, &v), -EINVAL);
        assert_int_equal(v, 10);
}

static void test_command_words(void **state)
{
        enum config_protocol p = CONFIG_PROTOCOL_CIRCE;

        (void)state;
        assert_int_equal(link_protocol_for_command("query", &p), 0);
        assert_int_equal(p, CONFIG_PROTOCOL_SHAREDLINK);
        assert_string_equal(link_ops_for(p)->command_word, "query");
        assert_int_equal(link_protocol_for_command("circe", &p), 0);
        assert_int_equal(p, CONFIG_PROTOCOL_CIRCE);
        assert_string_equal(link_ops_for(p)->command_word, "circe");
        assert_int_equal(link_protocol_for_command("ping", &p), -ENOENT);
        assert_int_equal(link_protocol_for_command("", &p), -ENOENT);
        assert_int_equal(p, CONFIG_PROTOCOL_CIRCE);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_command_wait),
                cmocka_unit_test(test_parse_ms),
                cmocka_unit_test(test_command_words),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
