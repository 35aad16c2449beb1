/*
 * Unit tests for sharedlink-mqtt's wire formats (src/mqtt/bridge_format.c): topics, set/ topic
 * parsing, the checks of set/ payloads (size, UTF-8), the JSON of meta and errors (escaping,
 * overflow). Its cursor file is the toolkit's (tests/unit/test_cursor.c).
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "mqtt/bridge_format.h"

#define BASE "sharedlink/car1"

static void test_topics(void **state)
{
        char t[BRIDGE_TOPIC_MAX], small[12];

        (void)state;
        assert_int_equal(bridge_format_topic(t, sizeof(t), BASE, "a.Lat", NULL), 0);
        assert_string_equal(t, BASE "/a.Lat");
        assert_int_equal(bridge_format_topic(t, sizeof(t), BASE, "a.Lat", "meta"), 0);
        assert_string_equal(t, BASE "/a.Lat/meta");
        assert_int_equal(bridge_format_topic(small, sizeof(small), BASE, "x", NULL),
                         -ENAMETOOLONG);
        assert_true(bridge_format_name_ok("agility.device.E1E1E1.online"));
        assert_false(bridge_format_name_ok(""));
        assert_false(bridge_format_name_ok("a/b"));
        assert_false(bridge_format_name_ok("a+"));
        assert_false(bridge_format_name_ok("#"));
        assert_false(bridge_format_name_ok("a b"));
        assert_false(bridge_format_name_ok("a:b"));            /* no name the tables can hold */
        assert_false(bridge_format_name_ok("a\"b"));
        assert_false(bridge_format_name_ok("status"));          /* our own topics */
        assert_false(bridge_format_name_ok("events"));
        assert_false(bridge_format_name_ok("set"));
        assert_true(bridge_format_name_ok("statusx"));
        assert_false(bridge_format_name_ok("\xc3\xa9"));
}

static void test_set_topics(void **state)
{
        char name[SL_NAME_SIZE];
        char longname[BRIDGE_TOPIC_MAX];

        (void)state;
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/a.Lat", name), 1);
        assert_string_equal(name, "a.Lat");
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/a.Lat/error", name), 0);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/a.Lat/x", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set//error", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/a.Lat", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, "sharedlink/car2/set/a", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/status", name), -EINVAL);
        /* A broker never delivers these (MQTT forbids wildcards and non-UTF-8 in a published
         * topic, and mosquitto drops the client that tries), but one that did gets no write. */
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/a+", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/+", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/#", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/a#", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/+/error", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/a.\xff", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/\xc0\xae", name), -EINVAL);
        assert_int_equal(bridge_format_set_topic(BASE, BASE "/set/a\x01", name), -EINVAL);
        snprintf(longname, sizeof(longname), BASE "/set/%0*d", SL_NAME_SIZE, 0);
        assert_int_equal(bridge_format_set_topic(BASE, longname, name), -EINVAL);
        snprintf(longname, sizeof(longname), BASE "/set/%0*d", SL_NAME_SIZE - 1, 0);
        assert_int_equal(bridge_format_set_topic(BASE, longname, name), 1);
}

static void test_values(void **state)
{
        char v[80];

        (void)state;
        memset(v, '1', sizeof(v));
        assert_int_equal(bridge_format_check_value("", 0), BRIDGE_REFUSE_NONE);
        assert_int_equal(bridge_format_check_value(v, 63), BRIDGE_REFUSE_NONE);
        assert_int_equal(bridge_format_check_value(v, 64), BRIDGE_REFUSE_TOO_LONG);
        assert_int_equal(bridge_format_check_value("\xc3\xa9", 2), BRIDGE_REFUSE_NONE);
        assert_int_equal(bridge_format_check_value("\xf0\x9f\x98\x80", 4), BRIDGE_REFUSE_NONE);
        assert_int_equal(bridge_format_check_value("\xff", 1), BRIDGE_REFUSE_NOT_UTF8);
        assert_int_equal(bridge_format_check_value("\xc3", 1), BRIDGE_REFUSE_NOT_UTF8);
        assert_int_equal(bridge_format_check_value("\xc0\xaf", 2), BRIDGE_REFUSE_NOT_UTF8);
        assert_int_equal(bridge_format_check_value("\xe0\x80\xaf", 3), BRIDGE_REFUSE_NOT_UTF8);
        assert_int_equal(bridge_format_check_value("\xed\xa0\x80", 3), BRIDGE_REFUSE_NOT_UTF8);
        assert_int_equal(bridge_format_check_value("\xf4\x90\x80\x80", 4),
                         BRIDGE_REFUSE_NOT_UTF8);
        assert_int_equal(bridge_format_check_value("a\0b", 3), BRIDGE_REFUSE_BAD_VALUE);
        assert_string_equal(bridge_format_refusal(BRIDGE_REFUSE_INBOUND),
                            "an inbound variable is read only");
        assert_string_equal(bridge_format_refusal(BRIDGE_REFUSE_COUNT), "refused");
}

static void test_json(void **state)
{
        struct sl_var_info info = { .size = sizeof(info), .name = "b.Lat", .peer = "A",
                                    .direction = SL_DIR_IN, .type = SL_VAR_DOUBLE, .link = 1 };
        struct sl_meta meta = { .size = sizeof(meta), .age_ns = 2500000, .sequence = 7,
                                .real_ns = 11, .flags = SL_FLAG_VALID | SL_FLAG_STALE };
        char buf[BRIDGE_JSON_MAX], tiny[16];

        (void)state;
        assert_true(bridge_format_meta(buf, sizeof(buf), &info, &meta, "node_b") > 0);
        assert_string_equal(buf, "{\"valid\":true,\"stale\":true,\"age_ms\":2,\"seq\":7,"
                            "\"time_ns\":11,\"direction\":\"in\",\"type\":\"double\","
                            "\"link\":\"node_b\",\"peer\":\"A\",\"repaired\":false}");
        assert_true(bridge_format_error(buf, sizeof(buf), "b.Lat", BRIDGE_REFUSE_INBOUND, 0,
                                        NULL) > 0);
        assert_string_equal(buf, "{\"name\":\"b.Lat\",\"code\":\"inbound\",\"error\":\"an "
                            "inbound variable is read only\"}");
        assert_true(bridge_format_error(buf, sizeof(buf), "a", BRIDGE_REFUSE_FAILED,
                                        -ENOTCONN, NULL) > 0);
        assert_non_null(strstr(buf, "\"detail\":"));
        /* A reason given is the detail (the library's word on a refused value). */
        assert_true(bridge_format_error(buf, sizeof(buf), "a", BRIDGE_REFUSE_BAD_VALUE, -EINVAL,
                                        "\"x\" is not a long") > 0);
        assert_non_null(strstr(buf, "\"detail\":\"\\\"x\\\" is not a long\""));
        /* Overflow is reported, and what was written stays NUL-terminated. */
        assert_int_equal(bridge_format_meta(tiny, sizeof(tiny), &info, &meta, "x"), -ENOBUFS);
        assert_true(strlen(tiny) < sizeof(tiny));
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_topics),
                cmocka_unit_test(test_set_topics),
                cmocka_unit_test(test_values),
                cmocka_unit_test(test_json),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
