/*
 * svc/evjson: the event JSON both bridges publish (moved from the MQTT bridge's formats, with
 * its tests): the fields of an event, the split of its text into key=value fields with escaping,
 * a notice, and overflow.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "svc/evjson.h"

static void test_event(void **state)
{
        struct sl_event ev = { .size = sizeof(ev), .seq = 17, .real_ns = 5,
                               .type_name = "action", .link_name = "agility",
                               .text = "device=E1E1E1 sensor_time=5000" };
        char buf[EVJSON_MAX];

        (void)state;
        assert_true(evjson_event(buf, sizeof(buf), 0xabcdefull, &ev) > 0);
        assert_string_equal(buf, "{\"epoch\":\"0000000000abcdef\",\"seq\":17,\"time_ns\":5,"
                            "\"link\":\"agility\",\"type\":\"action\","
                            "\"text\":\"device=E1E1E1 sensor_time=5000\",\"fields\":"
                            "{\"device\":\"E1E1E1\",\"sensor_time\":\"5000\"},"
                            "\"truncated\":false}");
        snprintf(ev.text, sizeof(ev.text), "a=\"q\\\" flag  b=\x01");
        ev.flags = SL_EVENT_TRUNCATED;
        assert_true(evjson_event(buf, sizeof(buf), 1, &ev) > 0);
        assert_non_null(strstr(buf, "\"fields\":{\"a\":\"\\\"q\\\\\\\"\",\"flag\":\"\","
                                    "\"b\":\"\\u0001\"}"));
        assert_non_null(strstr(buf, "\"truncated\":true}"));
}

static void test_notice(void **state)
{
        char buf[EVJSON_MAX], tiny[16];

        (void)state;
        assert_true(evjson_notice(buf, sizeof(buf), EVJSON_OVERRUN, 1, 30, 12) > 0);
        assert_string_equal(buf, "{\"epoch\":\"0000000000000001\",\"seq\":30,\"link\":\"\","
                            "\"type\":\"overrun\",\"lost\":12}");
        assert_int_equal(evjson_notice(tiny, sizeof(tiny), EVJSON_RESTARTED, 1, 2, 0), -ENOBUFS);
        assert_non_null(memchr(tiny, '\0', sizeof(tiny)));
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_event),
                cmocka_unit_test(test_notice),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
