/*
 * sharedlink-agility results export (src/agility/agility_export.c): the reference's columns,
 * its time format ("27.000", "27.040~"), True/False, empty cells for what did not happen,
 * quoting, a buffer too small, and that an exported list imports again
 * (agility_competitors_parse) with the same competitors.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "agility/agility_competitors.h"
#include "agility/agility_export.h"

static const struct agility_competitor comps[] = {
        { .number = 12, .handler = "Anna Berg", .dog = "Rex", .country = "NL" },
        { .number = 3, .handler = "Smith, John", .dog = "The \"Dog\"", .country = "" },
        { .number = 7, .handler = " Eva", .dog = "Bo", .country = "SE" },
};

static void test_time(void **state)
{
        char t[AGILITY_EXPORT_TIME_MAX];

        (void)state;
        assert_int_equal(agility_export_time(t, sizeof(t), 27000, AGILITY_PRECISION_HIGH), 6);
        assert_string_equal(t, "27.000");
        agility_export_time(t, sizeof(t), 27040, AGILITY_PRECISION_LOW);
        assert_string_equal(t, "27.040~");
        agility_export_time(t, sizeof(t), 5, AGILITY_PRECISION_HIGH);
        assert_string_equal(t, "0.005");
        agility_export_time(t, sizeof(t), UINT32_MAX, AGILITY_PRECISION_LOW);
        assert_string_equal(t, "4294967.295~");
        assert_int_equal(agility_export_time(t, 6, 27000, AGILITY_PRECISION_HIGH), -ENOBUFS);
}

static void test_rows(void **state)
{
        struct agility_result done = {
                .competitor = 12, .completed = true, .finished = true, .faults = 5,
                .refusals = 0, .intermediates = 2, .intermediate_ms = { 10250, 20500 },
                .intermediate_precision = { AGILITY_PRECISION_HIGH, AGILITY_PRECISION_LOW },
                .finish_ms = 27000, .finish_precision = AGILITY_PRECISION_HIGH, .placement = 2,
        };
        struct agility_result elim = { .competitor = 3, .completed = true, .eliminated = true,
                                       .refusals = 15 };
        struct agility_result none = { .competitor = 7 };
        char line[AGILITY_EXPORT_LINE_MAX];

        (void)state;
        assert_true(agility_export_header(line, sizeof(line)) > 0);
        assert_string_equal(line, "CompetitorNumber,HandlerName,DogName,CountryCode,"
                            "IntermediateTime1,IntermediateTime2,IntermediateTime3,FinishTime,"
                            "FaultCount,RefusalCount,IsEliminated,Placement\r\n");
        assert_true(agility_export_row(line, sizeof(line), &comps[0], &done) > 0);
        assert_string_equal(line, "12,Anna Berg,Rex,NL,10.250,20.500~,,27.000,5,0,False,2\r\n");
        assert_true(agility_export_row(line, sizeof(line), &comps[1], &elim) > 0);
        assert_string_equal(line, "3,\"Smith, John\",\"The \"\"Dog\"\"\",,,,,,0,15,True,\r\n");
        assert_true(agility_export_row(line, sizeof(line), &comps[2], &none) > 0);
        assert_string_equal(line, "7,\" Eva\",Bo,SE,,,,,,,,\r\n");
        assert_int_equal(agility_export_row(line, 20, &comps[0], &done), -ENOBUFS);
        assert_true(strlen(line) < 20);
        assert_int_equal(agility_export_header(line, 10), -ENOBUFS);
        assert_int_equal(agility_export_header(line, 0), -ENOBUFS);
}

/* What we export, we (and the reference) import. */
static void test_round_trip(void **state)
{
        struct agility_result none = { 0 };
        struct agility_competitor back[4];
        char text[4 * AGILITY_EXPORT_LINE_MAX], err[AGILITY_CSV_ERROR_SIZE];
        size_t len = 0, n = 0;
        int r;

        (void)state;
        r = agility_export_header(text, sizeof(text));
        assert_true(r > 0);
        len = (size_t)r;
        for (size_t i = 0; i < 3; i++) {
                r = agility_export_row(text + len, sizeof(text) - len, &comps[i], &none);
                assert_true(r > 0);
                len += (size_t)r;
        }
        assert_int_equal(agility_competitors_parse("export.csv", text, len, back, 4, &n, err,
                                                   sizeof(err)), 0);
        assert_int_equal(n, 3);
        for (size_t i = 0; i < 3; i++) {
                assert_int_equal(back[i].number, comps[i].number);
                assert_string_equal(back[i].handler, comps[i].handler);
                assert_string_equal(back[i].dog, comps[i].dog);
                assert_string_equal(back[i].country, comps[i].country);
        }
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_time),
                cmocka_unit_test(test_rows),
                cmocka_unit_test(test_round_trip),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
