/*
 * Unit tests for the scoreboard's documents (src/agility/agilityd_http.c): /api/state with the
 * nulls of item 9 (elapsed_ms and precision until the finish, running_ms only while the run is
 * on, moving with the clock), /api/results in ranking order with names escaped as JSON, the CSV
 * export, a buffer too small, and the page with an update inside it that no name can break out
 * of.
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

#include "agility/agilityd_http.h"

#define DOC_MAX         8192

static struct agilityd_config cfg;     /* 200 KB: not on the stack */
static struct agility_result results[3];
static struct agility_run run;

static int setup(void **state)
{
        static const struct agility_competitor list[] = {
                { 1, "Anna \"Nan\" Smith", "R\xc3\xa9x", "NL" },
                { 2, "Bert", "Fly", "BE" },
                { 3, "Cora", "Zip", "" },
        };

        (void)state;
        memset(&cfg, 0, sizeof(cfg));
        memset(results, 0, sizeof(results));
        snprintf(cfg.class_name, sizeof(cfg.class_name), "Jumping A");
        cfg.cls = (struct agility_class){ .standard_course_time_ms = 30000, .start = 0xE1E1E1,
                                          .finish = 0xE2E2E2 };
        memcpy(cfg.competitors, list, sizeof(list));
        cfg.competitor_count = 3;
        /* 2: finished over the standard time (penalty 2 s); 1: clean; 3: no run. */
        results[0] = (struct agility_result){ .completed = true, .finished = true,
                                              .finish_ms = 27000 };
        results[1] = (struct agility_result){ .completed = true, .finished = true,
                                              .finish_ms = 32000, .faults = 5,
                                              .finish_precision = AGILITY_PRECISION_LOW };
        return agility_run_init(&run, &cfg.cls, cfg.competitors, 3, results, 2);
}

static void test_state(void **state)
{
        struct agility_run_view v = { .state = AGILITY_START_PASSED, .current = 3, .next = 0,
                                      .faults = 5, .started = true, .elapsed_ms = 1000 };
        char buf[DOC_MAX];

        (void)state;
        assert_true(agilityd_json_state(buf, sizeof(buf), &cfg, &v, 5000, 5250) > 0);
        assert_non_null(strstr(buf, "{\"class\":\"Jumping A\",\"state\":\"StartPassed\","
                                    "\"current\":3,\"next\":null,"));
        assert_non_null(strstr(buf, "\"current_competitor\":{\"number\":3,\"handler\":\"Cora\","
                                    "\"dog\":\"Zip\",\"country\":\"\"},"
                                    "\"next_competitor\":null,"));
        assert_non_null(strstr(buf, "\"faults\":5,\"refusals\":0,\"eliminated\":false,"
                                    "\"started\":true,\"finished\":false,\"elapsed_ms\":null,"
                                    "\"precision\":null,\"running_ms\":1250,"
                                    "\"intermediate_ms\":[],"));

        v = (struct agility_run_view){ .state = AGILITY_FINISH_PASSED, .current = 1,
                                       .started = true, .finished = true, .elapsed_ms = 27000,
                                       .intermediates = 2, .intermediate_ms = { 9000, 18000 } };
        assert_true(agilityd_json_state(buf, sizeof(buf), &cfg, &v, 5000, 9000) > 0);
        assert_non_null(strstr(buf, "\"elapsed_ms\":27000,\"precision\":\"high\","
                                    "\"running_ms\":null,\"intermediate_ms\":[9000,18000],"));
        assert_non_null(strstr(buf, "\"handler\":\"Anna \\\"Nan\\\" Smith\",\"dog\":\"R\xc3\xa9x\""));
        assert_int_equal(agilityd_json_state(buf, 64, &cfg, &v, 0, 0), -ENOBUFS);
}

static void test_results(void **state)
{
        char buf[DOC_MAX];
        int n;

        (void)state;
        n = agilityd_json_results(buf, sizeof(buf), &cfg, &run);
        assert_int_equal(n, (int)strlen(buf));
        assert_string_equal(buf,
                "[{\"competitor\":1,\"handler\":\"Anna \\\"Nan\\\" Smith\",\"dog\":\"R\xc3\xa9x\","
                "\"country\":\"NL\",\"intermediate_ms\":[],\"finish_ms\":27000,"
                "\"precision\":\"high\",\"faults\":0,\"refusals\":0,\"eliminated\":false,"
                "\"penalty\":0,\"placement\":1},"
                "{\"competitor\":2,\"handler\":\"Bert\",\"dog\":\"Fly\",\"country\":\"BE\","
                "\"intermediate_ms\":[],\"finish_ms\":32000,\"precision\":\"low\",\"faults\":5,"
                "\"refusals\":0,\"eliminated\":false,\"penalty\":7000,\"placement\":2}]");
        assert_int_equal(agilityd_json_results(buf, 100, &cfg, &run), -ENOBUFS);
}

static void test_csv(void **state)
{
        char buf[DOC_MAX];

        (void)state;
        assert_true(agilityd_csv_results(buf, sizeof(buf), &run) > 0);
        assert_string_equal(buf,
                "CompetitorNumber,HandlerName,DogName,CountryCode,IntermediateTime1,"
                "IntermediateTime2,IntermediateTime3,FinishTime,FaultCount,RefusalCount,"
                "IsEliminated,Placement\r\n"
                "1,\"Anna \"\"Nan\"\" Smith\",R\xc3\xa9x,NL,,,,27.000,0,0,False,1\r\n"
                "2,Bert,Fly,BE,,,,32.000~,5,0,False,2\r\n"
                "3,Cora,Zip,,,,,,,,,\r\n");
        assert_int_equal(agilityd_csv_results(buf, 200, &run), -ENOBUFS);
}

/* The update goes into the page's <script type="application/json">: a "</script>" in a name
 * must not end that element, and the JSON must read back the same (\u003c is '<'). */
static void test_page(void **state)
{
        static const char doc[] = "{\"state\":{\"class\":\"A </script><b>x\"},\"results\":[]}";
        static const char inside[] = "{\"state\":{\"class\":\"A \\u003c/script>\\u003cb>x\"},"
                                     "\"results\":[]}</script>";
        size_t len = 0;
        char *page = agilityd_page(doc, sizeof(doc) - 1, &len);
        const char *json;

        (void)state;
        assert_non_null(page);
        assert_int_equal(strlen(page), len);
        json = strstr(page, "<script type=\"application/json\" id=\"initial\">");
        assert_non_null(json);
        json = strchr(json, '>') + 1;
        assert_memory_equal(json, inside, sizeof(inside) - 1);
        /* Before it, no script; after it, the page's own, and the end of the page. */
        assert_null(strstr(json + sizeof(inside) - 1, "</script><b>"));
        assert_non_null(strstr(json, "new EventSource('/events')"));
        assert_non_null(strstr(json, "</html>\n"));
        free(page);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup(test_state, setup),
                cmocka_unit_test_setup(test_results, setup),
                cmocka_unit_test_setup(test_csv, setup),
                cmocka_unit_test(test_page),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
