/*
 * sharedlink-ros2's names (src/ros2/ros2_names.c): the mapping of variable names to ROS names
 * (docs/ros2.md §1) case by case, the validity of ROS names as rmw checks them, the bridge's
 * reserved names, and the collision finder.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "ros2/ros2_names.h"

struct map_case {
        const char *var, *rel;          /* rel NULL: refused */
};

static const struct map_case map_cases[] = {
        { "pronto.A.AutoGpsLat", "pronto/A/AutoGpsLat" },
        { "AutoGpsLat", "AutoGpsLat" },
        { "gate-1.2nd", "gate_1/_2nd" },
        { "a..b", "a/_/b" },
        { ".a", "_/a" },
        { "a.", "a/_" },
        { "9", "_9" },
        { "_x", "_x" },
        { "a/b", NULL },
        { "a b", NULL },
        { "", NULL },
        { "a23456789012345678901234567890123456789012345678", NULL },       /* 48 bytes */
};

static void test_map(void **state)
{
        char out[ROS2_REL_SIZE];

        (void)state;
        for (size_t i = 0; i < sizeof(map_cases) / sizeof(map_cases[0]); i++) {
                const struct map_case *c = &map_cases[i];
                int r = ros2_names_map(c->var, out, sizeof(out));

                if (!c->rel) {
                        assert_int_equal(r, -EINVAL);
                        continue;
                }
                assert_int_equal(r, 0);
                assert_string_equal(out, c->rel);
                assert_true(ros2_names_valid_relative(out));
        }
        /* The worst case fits: 47 bytes of dots and digits. */
        assert_int_equal(ros2_names_map("1.1.1.1.1.1.1.1.1.1.1.1.1.1.1.1.1.1.1.1.1.1.1.1", out,
                                        sizeof(out)), 0);
        assert_true(ros2_names_valid_relative(out));
        assert_int_equal(ros2_names_map("a", out, 8), -EINVAL);         /* buffer too small */
}

static void test_valid(void **state)
{
        (void)state;
        assert_true(ros2_names_valid("/sharedlink/vehicle", true));
        assert_true(ros2_names_valid("/", true));
        assert_false(ros2_names_valid("/", false));
        assert_false(ros2_names_valid("sharedlink", true));
        assert_false(ros2_names_valid("/a//b", true));
        assert_false(ros2_names_valid("/a/", true));
        assert_false(ros2_names_valid("/a/1b", true));
        assert_false(ros2_names_valid("/a-b", true));
        assert_true(ros2_names_valid_relative("gps/fix"));
        assert_false(ros2_names_valid_relative("/gps"));
        assert_false(ros2_names_valid_relative("gps/"));
        assert_false(ros2_names_valid_relative(""));
}

static void test_join(void **state)
{
        char out[ROS2_NAME_SIZE], dds[ROS2_DDS_NAME_SIZE], big[ROS2_NAME_SIZE + 8];

        (void)state;
        assert_int_equal(ros2_names_join(out, sizeof(out), "/vehicle", "pronto/A/Lat", NULL), 0);
        assert_string_equal(out, "/vehicle/pronto/A/Lat");
        assert_int_equal(ros2_names_join(out, sizeof(out), "/", "a", NULL), 0);
        assert_string_equal(out, "/a");
        assert_int_equal(ros2_names_join(out, sizeof(out), "/v", "set", "a/b"), 0);
        assert_string_equal(out, "/v/set/a/b");
        assert_int_equal(ros2_names_join(out, sizeof(out), "/v", "/gps/fix", NULL), 0);
        assert_string_equal(out, "/gps/fix");
        assert_int_equal(ros2_names_dds(dds, sizeof(dds), "/v/a"), 0);
        assert_string_equal(dds, "rt/v/a");
        /* Over 247 bytes: refused. */
        memset(big, 'a', sizeof(big) - 1);
        big[0] = '/';
        big[sizeof(big) - 1] = '\0';
        assert_int_equal(ros2_names_join(out, sizeof(out), "/", big + 1, NULL), -ENAMETOOLONG);
}

static void test_reserved_and_duplicates(void **state)
{
        struct ros2_names_ref refs[] = {
                { "/v/a_b", 0 }, { "/v/c", 1 }, { "/v/a_b", 2 }, { "/v/events", 3 },
                { "/v/events", 4 }, { "/v/d", 5 },
        };
        bool dup[6] = { false };

        (void)state;
        assert_true(ros2_names_reserved("events"));
        assert_true(ros2_names_reserved("set_errors"));
        assert_true(ros2_names_reserved("set/x"));
        assert_false(ros2_names_reserved("set"));
        assert_false(ros2_names_reserved("settings/x"));
        ros2_names_duplicates(refs, 6, dup);
        assert_true(dup[0] && dup[2] && dup[3] && dup[4]);
        assert_false(dup[1] || dup[5]);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_map),
                cmocka_unit_test(test_valid),
                cmocka_unit_test(test_join),
                cmocka_unit_test(test_reserved_and_duplicates),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
