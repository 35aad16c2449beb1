/*
 * sharedlink-ros2's configuration (src/ros2/ros2_config.c): defaults, every key, the errors
 * with FILE:LINE:COL (unknown keys, bad namespaces, navsatfix entries), the default namespace
 * from the instance, and the domain from $ROS_DOMAIN_ID.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "ros2/ros2_config.h"

static int parse(const char *text, struct ros2_config *c, char *err)
{
        return ros2_config_parse("t.yaml", text, strlen(text), c, err, ROS2_ERROR_MAX);
}

static void test_defaults_and_keys(void **state)
{
        struct ros2_config c;
        char err[ROS2_ERROR_MAX], inst[ROS2_INSTANCE_MAX], ns[ROS2_NAMESPACE_MAX];
        unsigned d;

        (void)state;
        assert_int_equal(parse("", &c, err), 0);
        assert_int_equal(c.publish.count, 1);
        assert_string_equal(c.publish.glob[0], "*");
        assert_int_equal(c.writable.count, 0);
        assert_false(c.domain_set);
        assert_int_equal(c.wait_spin_us, 0);    /* the default sleeps at once */
        unsetenv("SHAREDLINK_INSTANCE");
        assert_int_equal(ros2_config_names(&c, inst, ns), 0);
        assert_string_equal(inst, "default");
        assert_string_equal(ns, "/sharedlink/default");
        assert_int_equal(parse("instance: car-1\nnamespace: /vehicle\npublish: [\"pronto.*\"]\n"
                               "writable: [\"Cmd*\"]\ndomain_id: 42\n"
                               "cyclonedds_uri: file:///etc/cyclone.xml\n"
                               "navsatfix:\n  - {topic: gps/fix, latitude: Lat, longitude: Lon,\n"
                               "     altitude: Alt, frame_id: gps}\n"
                               "wait_spin_us: 10000\n", &c, err), 0);
        assert_int_equal(c.wait_spin_us, SL_WAIT_SPIN_MAX_US);
        assert_string_equal(c.instance, "car-1");
        assert_string_equal(c.ns, "/vehicle");
        assert_string_equal(c.writable.glob[0], "Cmd*");
        assert_true(c.domain_set);
        assert_int_equal(ros2_config_domain(&c, &d), 0);
        assert_int_equal(d, 42);
        assert_int_equal(c.n_navsatfix, 1);
        assert_string_equal(c.navsatfix[0].altitude, "Alt");
        assert_int_equal(c.navsatfix[0].line, 8);
        assert_int_equal(c.navsatfix[0].column, 5);
        assert_int_equal(c.publish_line, 3);
        /* The default namespace maps the instance as a variable name. */
        assert_int_equal(parse("instance: car-1\n", &c, err), 0);
        assert_int_equal(ros2_config_names(&c, inst, ns), 0);
        assert_string_equal(ns, "/sharedlink/car_1");
}

static void test_domain_env(void **state)
{
        struct ros2_config c;
        char err[ROS2_ERROR_MAX];
        unsigned d = 99;

        (void)state;
        assert_int_equal(parse("", &c, err), 0);
        unsetenv("ROS_DOMAIN_ID");
        assert_int_equal(ros2_config_domain(&c, &d), 0);
        assert_int_equal(d, 0);
        setenv("ROS_DOMAIN_ID", "17", 1);
        assert_int_equal(ros2_config_domain(&c, &d), 0);
        assert_int_equal(d, 17);
        setenv("ROS_DOMAIN_ID", "233", 1);
        assert_int_equal(ros2_config_domain(&c, &d), -EINVAL);
        setenv("ROS_DOMAIN_ID", "x", 1);
        assert_int_equal(ros2_config_domain(&c, &d), -EINVAL);
        unsetenv("ROS_DOMAIN_ID");
}

struct bad_case {
        const char *text, *message;
};

static const struct bad_case bad[] = {
        { "foo: 1\n", "t.yaml:1:1: unknown key" },
        { "namespace: vehicle\n", "t.yaml:1:12: namespace: \"vehicle\": not a ROS namespace" },
        { "namespace: /a/1b\n", "not a ROS namespace" },
        { "domain_id: 233\n", "t.yaml:1:12: domain_id 233 out of range (0..232)" },
        { "publish: [\"a/b\"]\n", "'+', '#' and '/' are not allowed" },
        { "wait_spin_us: 10001\n", "t.yaml:1:15: wait_spin_us 10001 out of range (0..10000)" },
        { "wait_spin_us: -1\n", "t.yaml:1:15: wait_spin_us" },
        { "navsatfix:\n  - {topic: fix, latitude: a}\n",
          "t.yaml:2:5: navsatfix: needs topic, latitude and longitude" },
        { "navsatfix:\n  - {topic: fix, latitude: a, longitude: a}\n",
          "three different variables" },
        { "navsatfix:\n  - {topic: 1fix, latitude: a, longitude: b}\n", "not a ROS topic name" },
        { "navsatfix:\n  - {topic: fix, latitude: a/b, longitude: b}\n",
          "navsatfix: latitude: \"a/b\": not a variable name" },
        { "navsatfix:\n  - {topic: fix, latitude: a, longitude: b, speed: c}\n",
          "t.yaml:2:45: unknown key \"speed\" in navsatfix" },
        { "navsatfix:\n  - {topic: fix, latitude: a, longitude: b}\n"
          "  - {topic: fix, latitude: c, longitude: d}\n", "t.yaml:3:5: navsatfix: topic" },
        { "navsatfix:\n  - {topic: fix, latitude: a, longitude: b, frame_id: \"a b\"}\n",
          "frame_id" },
};

static void test_errors(void **state)
{
        struct ros2_config c;
        char err[ROS2_ERROR_MAX];

        (void)state;
        for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
                assert_int_equal(parse(bad[i].text, &c, err), -EINVAL);
                if (!strstr(err, bad[i].message))
                        fail_msg("case %zu: \"%s\" lacks \"%s\"", i, err, bad[i].message);
        }
}

/* The commented reference that make install puts in /etc parses, and says what an empty file
 * says. */
static void test_example(void **state)
{
        struct ros2_config c, d;
        char err[ROS2_ERROR_MAX];

        (void)state;
        if (ros2_config_load("conf/sharedlink-ros2.yaml", &c, err, sizeof(err)) < 0)
                fail_msg("%s", err);
        ros2_config_defaults(&d);
        assert_int_equal(c.publish.count, d.publish.count);
        assert_int_equal(c.writable.count, 0);
        assert_false(c.domain_set);
        assert_int_equal(c.n_navsatfix, 0);
        assert_int_equal(c.wait_spin_us, d.wait_spin_us);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_defaults_and_keys),
                cmocka_unit_test(test_domain_env),
                cmocka_unit_test(test_errors),
                cmocka_unit_test(test_example),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
