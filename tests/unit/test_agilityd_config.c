/*
 * Unit tests for sharedlink-agility's class file (src/agility/agilityd_config.c): the shipped
 * example parses into the class it describes, the combined gate gets its default delay, and
 * every rule that spans keys gives its exact "FILE:LINE:COL: message".
 *
 * Run from the source tree root (as `make check` does): the example is read from conf/.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "agility/agilityd_config.h"
#include "svc/io.h"

#define EXAMPLE_CONF    "conf/sharedlink-agility.yaml"
#define NAME            "a.yaml"

/* The keys every good file needs, then the test's own. */
#define BASE    "link: agility\n" \
                "class: {name: A, intermediates: 0}\n" \
                "competitors: /c.csv\n" \
                "database: /r.db\n"

static struct agilityd_config cfg;     /* 200 KB: not on the stack */

static void parse_ok(const char *yaml)
{
        char err[AGILITYD_ERROR_MAX];
        int r = agilityd_config_parse(NAME, yaml, strlen(yaml), &cfg, err, sizeof(err));

        if (r < 0)
                fail_msg("unexpected error %d: %s", r, err);
}

static void parse_fails(const char *yaml, const char *want)
{
        char err[AGILITYD_ERROR_MAX];
        int r = agilityd_config_parse(NAME, yaml, strlen(yaml), &cfg, err, sizeof(err));

        if (r >= 0)
                fail_msg("%s: accepted, wanted %s", yaml, want);
        if (strcmp(err, want) != 0)
                fail_msg("%s\n  got:    %s\n  wanted: %s", yaml, err, want);
}

static void test_example(void **state)
{
        char *text, err[AGILITYD_ERROR_MAX];
        size_t len;

        (void)state;
        assert_int_equal(io_read_file(EXAMPLE_CONF, AGILITYD_FILE_MAX, &text, &len), 0);
        if (agilityd_config_parse(EXAMPLE_CONF, text, len, &cfg, err, sizeof(err)) < 0)
                fail_msg("%s", err);
        free(text);
        assert_string_equal(cfg.link, "agility");
        assert_string_equal(cfg.class_name, "Jumping A");
        assert_int_equal(cfg.cls.standard_course_time_ms, 40000);
        assert_int_equal(cfg.cls.max_course_time_ms, 80000);
        assert_false(cfg.cls.combined);
        assert_int_equal(cfg.cls.start, 0xE1E1E1);
        assert_int_equal(cfg.cls.finish, 0xE2E2E2);
        assert_int_equal(cfg.cls.keypad_count, 1);
        assert_int_equal(cfg.cls.keypads[0], 0xAAAAAA);
        assert_int_equal(cfg.display_count, 1);
        assert_int_equal(cfg.displays[0], 0xD15D15);
        assert_string_equal(cfg.http_host, "127.0.0.1");
        assert_int_equal(cfg.http_port, 8431);
}

static void test_values(void **state)
{
        (void)state;
        parse_ok(BASE "gates: {start_finish: e1e1e1}\nhttp: \"[::1]:0\"\n");
        assert_true(cfg.cls.combined);
        assert_int_equal(cfg.cls.start, 0xE1E1E1);
        assert_int_equal(cfg.cls.min_delay_ms, 3000);   /* the reference's default */
        assert_string_equal(cfg.http_host, "::1");
        assert_int_equal(cfg.http_port, 0);
        parse_ok("link: agility\n"
                 "class: {name: A, intermediates: 2}\n"
                 "gates: {start: 000001, finish: 000002, intermediate: [000003, 000004]}\n"
                 "keypads: [000001, 00000A]\n"
                 "competitors: /c.csv\n"
                 "database: /r.db\n");
        assert_int_equal(cfg.cls.intermediates, 2);
        assert_int_equal(cfg.cls.intermediate[1], 4);
        assert_int_equal(cfg.cls.keypads[1], 10);       /* a keypad may also be a gate */
        assert_int_equal(cfg.http_port, AGILITYD_HTTP_PORT_DEFAULT);
}

static void test_errors(void **state)
{
        static const struct {
                const char *yaml, *want;
        } cases[] = {
                { "", "a.yaml: empty file: link, class, gates, competitors and database are "
                      "needed" },
                { BASE, "a.yaml:1:1: gates: missing (see sharedlink-agility(8))" },
                { BASE "gates: {start: E1E1E1}\n",
                  "a.yaml:5:8: gates: needs start and finish, or start_finish" },
                { BASE "gates: {start: E1E1E1, finish: E2E2E2, start_finish: E3E3E3}\n",
                  "a.yaml:5:8: gates: start_finish (one combined gate) excludes start and "
                  "finish" },
                { BASE "gates: {start: E1E1E1, finish: E2E2E2, min_delay_ms: 10}\n",
                  "a.yaml:5:8: gates: min_delay_ms is for a combined start_finish gate" },
                { BASE "gates: {start: E1E1E1, finish: E1E1E1}\n",
                  "a.yaml:1:1: gates: E1E1E1 is two gates" },
                { BASE "gates: {start: FFFFFF, finish: E1E1E1}\n",
                  "a.yaml:5:16: start: \"FFFFFF\" is not a device address (six hex digits, not "
                  "000000 or FFFFFF)" },
                { BASE "gates: {start: E1E1E, finish: E1E1E1}\n",
                  "a.yaml:5:16: start: \"E1E1E\" is not a device address (six hex digits, not "
                  "000000 or FFFFFF)" },
                { BASE "gates: {start: E1E1E1, finish: E2E2E2, intermediate: [E3E3E3]}\n",
                  "a.yaml:1:1: gates: intermediate lists 1 gates, class: intermediates is 0" },
                { BASE "gates: {start: E1E1E1, finish: E2E2E2}\nkeypads: [AAAAAA, AAAAAA]\n",
                  "a.yaml:6:19: keypads: \"AAAAAA\" is listed twice" },
                { BASE "gates: {start: E1E1E1, finish: E2E2E2}\ndisplays: [E2E2E2]\n",
                  "a.yaml:1:1: displays: E2E2E2 is a gate" },
                { BASE "gates: {start: E1E1E1, finish: E2E2E2}\nhttp: localhost:80\n",
                  "a.yaml:6:7: http: \"localhost:80\": the host must be a numeric IPv4 or IPv6 "
                  "address" },
                { BASE "gates: {start: E1E1E1, finish: E2E2E2}\nhttp: \"127.0.0.1:65536\"\n",
                  "a.yaml:6:7: http: \"127.0.0.1:65536\": the port must be 0..65535 (0: any free "
                  "port)" },
                { "link: a\nclass: {name: A, standard_course_time_ms: 50000, "
                  "max_course_time_ms: 40000}\n",
                  "a.yaml:2:8: class: max_course_time_ms (40000) is less than "
                  "standard_course_time_ms (50000)" },
                { "link: a\nclass: {intermediates: 4}\n",
                  "a.yaml:2:24: intermediates 4 out of range (0..3)" },
                { BASE "gates: {start: E1E1E1, finish: E2E2E2}\ndatabase: r.db\n",
                  "a.yaml:6:1: duplicate key \"database\" (first at 4:1)" },
        };

        (void)state;
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++)
                parse_fails(cases[i].yaml, cases[i].want);
}

static void test_address(void **state)
{
        char buf[8];
        uint32_t a;

        (void)state;
        assert_int_equal(agilityd_address_parse("d15d15", &a), 0);
        assert_int_equal(a, 0xD15D15);
        agilityd_address_format(a, buf);
        assert_string_equal(buf, "D15D15");
        assert_int_equal(agilityd_address_parse("000000", &a), -EINVAL);
        assert_int_equal(agilityd_address_parse("FFFFFF", &a), -EINVAL);
        assert_int_equal(agilityd_address_parse("FFFFFE", &a), 0);
        assert_int_equal(agilityd_address_parse("0x1234", &a), -EINVAL);
        assert_int_equal(agilityd_address_parse("1234567", &a), -EINVAL);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_example),
                cmocka_unit_test(test_values),
                cmocka_unit_test(test_errors),
                cmocka_unit_test(test_address),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
