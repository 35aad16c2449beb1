/*
 * ros2/ros2_typehash: lookups by ROS and by DDS name, the USER_DATA text, and names that are none
 * of ours. The hash values themselves are recomputed from the .msg definitions and held to ROS's
 * published values by tests/ros2peer/test_typehash.py.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "ros2/ros2_typehash.h"

#define KNOWN_TYPES     10      /* the ROS types of ros2_typehash.c */

static void test_lookup_by_either_name(void **state)
{
        (void)state;
        assert_string_equal(ros2_typehash_get("std_msgs/msg/Int64"), ROS2_TYPEHASH_INT64);
        assert_string_equal(ros2_typehash_get("std_msgs::msg::dds_::Int64_"), ROS2_TYPEHASH_INT64);
        assert_string_equal(ros2_typehash_get("std_msgs::msg::dds_::Float64_"),
                            ROS2_TYPEHASH_FLOAT64);
        assert_string_equal(ros2_typehash_get("std_msgs/msg/String"), ROS2_TYPEHASH_STRING);
        assert_string_equal(ros2_typehash_get("diagnostic_msgs::msg::dds_::DiagnosticArray_"),
                            ROS2_TYPEHASH_DIAGNOSTIC_ARRAY);
        assert_string_equal(ros2_typehash_get("sensor_msgs/msg/NavSatFix"),
                            ROS2_TYPEHASH_NAVSATFIX);
        assert_string_equal(ros2_typehash_find("sensor_msgs/msg/NavSatFix")->dds_name,
                            "sensor_msgs::msg::dds_::NavSatFix_");
}

static void test_user_data_text(void **state)
{
        (void)state;
        assert_string_equal(ros2_typehash_user_data("std_msgs/msg/Int64"),
                            "typehash=RIHS01_8cd1048c2f186b6bd9a92472dc1ce51723c0833a221e2b7aecfff"
                            "111774f4b49;");
        assert_string_equal(ros2_typehash_user_data("std_msgs::msg::dds_::String_"),
                            "typehash=" ROS2_TYPEHASH_STRING ";");
}

static void test_unknown_names(void **state)
{
        (void)state;
        assert_null(ros2_typehash_get(NULL));
        assert_null(ros2_typehash_get(""));
        assert_null(ros2_typehash_get("std_msgs/msg/Int32"));
        assert_null(ros2_typehash_get("std_msgs::msg::dds_::Int64"));     /* no trailing _ */
        assert_null(ros2_typehash_get("std_msgs/Int64"));                 /* ROS 1 spelling */
        assert_null(ros2_typehash_user_data("std_msgs::msg::Int64_"));
        assert_null(ros2_typehash_find("int64"));
}

static void test_every_entry_well_formed(void **state)
{
        size_t n = 0;

        (void)state;
        for (const struct ros2_typehash *t; (t = ros2_typehash_at(n)) != NULL; n++) {
                assert_int_equal(strlen(t->hash), ROS2_TYPEHASH_LEN);
                assert_memory_equal(t->hash, ROS2_TYPEHASH_PREFIX, strlen(ROS2_TYPEHASH_PREFIX));
                assert_int_equal(strspn(t->hash + strlen(ROS2_TYPEHASH_PREFIX), "0123456789abcdef"),
                                 ROS2_TYPEHASH_HEX_LEN);
                assert_ptr_equal(ros2_typehash_find(t->ros_name), t);
                assert_ptr_equal(ros2_typehash_find(t->dds_name), t);
        }
        assert_int_equal(n, KNOWN_TYPES);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_lookup_by_either_name),
                cmocka_unit_test(test_user_data_text),
                cmocka_unit_test(test_unknown_names),
                cmocka_unit_test(test_every_entry_well_formed),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
