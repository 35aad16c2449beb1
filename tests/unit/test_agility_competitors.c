/*
 * sharedlink-agility competitor import (src/agility/agility_competitors.c): the reference's
 * CSV (header with CompetitorNumber, HandlerName, DogName, CountryCode in any order, extra
 * columns ignored, separator detected, quoted cells, BOM, CRLF), and each rule it enforces with
 * its FILE:LINE message: duplicates, bad numbers, empty names, missing columns, bad quoting,
 * cell counts, an empty file, too many competitors.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "agility/agility_competitors.h"

#define CAP 8
#define HDR "CompetitorNumber,HandlerName,DogName,CountryCode\n"

static struct agility_competitor list[CAP];
static size_t count;
static char err[AGILITY_CSV_ERROR_SIZE];

static int parse(const char *text, size_t len)
{
        count = 0;
        memset(err, 'x', sizeof(err));
        return agility_competitors_parse("dogs.csv", text, len, list, CAP, &count, err,
                                         sizeof(err));
}

static int parse_str(const char *text)
{
        return parse(text, strlen(text));
}

static void test_good(void **state)
{
        (void)state;
        assert_int_equal(parse_str(HDR "12,Anna Berg,Rex,NL\n3,\"Smith, John\",\"The \"\"Dog\"\"\","
                                   "\n"), 0);
        assert_int_equal(count, 2);
        assert_int_equal(list[0].number, 12);
        assert_string_equal(list[0].handler, "Anna Berg");
        assert_string_equal(list[0].dog, "Rex");
        assert_string_equal(list[0].country, "NL");
        assert_int_equal(list[1].number, 3);
        assert_string_equal(list[1].handler, "Smith, John");
        assert_string_equal(list[1].dog, "The \"Dog\"");
        assert_string_equal(list[1].country, "");
        assert_string_equal(err, "");
}

static void test_dialects(void **state)
{
        static const char bom_crlf[] = "\xef\xbb\xbf" "competitornumber;DogName;CountryCode;"
                                       "HandlerName;FinishTime\r\n\r\n"
                                       " 007 ; Bo ; SE ;  Eva Lind ; 31.250\r\n";
        static const char tabs[] = "HandlerName\tCompetitorNumber\tDogName\tCountryCode\n"
                                   "Piet, Jr.\t999\tMax\tBE";

        (void)state;
        assert_int_equal(parse_str(bom_crlf), 0);
        assert_int_equal(count, 1);
        assert_int_equal(list[0].number, 7);
        assert_string_equal(list[0].handler, "Eva Lind");
        assert_string_equal(list[0].dog, "Bo");
        assert_string_equal(list[0].country, "SE");
        assert_int_equal(parse_str(tabs), 0);
        assert_int_equal(list[0].number, 999);
        assert_string_equal(list[0].handler, "Piet, Jr.");
}

struct bad_case {
        const char *text;
        int err;
        const char *msg;
};

static const struct bad_case bad[] = {
        { HDR "1,A,B,NL\n2,C,D,NL\n1,E,F,NL\n", -EINVAL,
          "dogs.csv:4: competitor number 1 is already on line 2" },
        { HDR "0,A,B,NL\n", -EINVAL, "dogs.csv:2: competitor number '0' is not a number 1..999" },
        { HDR "1000,A,B,NL\n", -EINVAL,
          "dogs.csv:2: competitor number '1000' is not a number 1..999" },
        { HDR "12a,A,B,NL\n", -EINVAL,
          "dogs.csv:2: competitor number '12a' is not a number 1..999" },
        { HDR "-1,A,B,NL\n", -EINVAL,
          "dogs.csv:2: competitor number '-1' is not a number 1..999" },
        { HDR "99999999999999999999,A,B,NL\n", -EINVAL,
          "dogs.csv:2: competitor number '99999999999999999999' is not a number 1..999" },
        { HDR ",A,B,NL\n", -EINVAL, "dogs.csv:2: competitor number '' is not a number 1..999" },
        { HDR "1,,B,NL\n", -EINVAL, "dogs.csv:2: handler name is empty" },
        { HDR "1,A,  ,NL\n", -EINVAL, "dogs.csv:2: dog name is empty" },
        { HDR "1,A,B,ABCDEFGH\n", -EINVAL, "dogs.csv:2: country code longer than 7 bytes" },
        { HDR "1,A,B\n", -EINVAL, "dogs.csv:2: 3 cells, but the header has 4" },
        { HDR "1,\"A,B,C\n", -EINVAL, "dogs.csv:2: a quote that does not close" },
        { HDR "1,\"A\"x,B,C\n", -EINVAL, "dogs.csv:2: text after a closing quote" },
        { HDR "1,A\"x,B,C\n", -EINVAL, "dogs.csv:2: a quote inside an unquoted cell" },
        { HDR "1,A\x01,B,C\n", -EINVAL, "dogs.csv:2: handler name holds a control character" },
        { "CompetitorNumber,HandlerName,DogName\n1,A,B\n", -EINVAL,
          "dogs.csv:1: no column CountryCode in the header" },
        { "CompetitorNumber,HandlerName,DogName,CountryCode,dogname\n", -EINVAL,
          "dogs.csv:1: column DogName appears twice" },
        { "", -EINVAL, "dogs.csv:1: no header line (CompetitorNumber, HandlerName, DogName, "
                       "CountryCode)" },
        { "\n\n", -EINVAL, "dogs.csv:2: no header line (CompetitorNumber, HandlerName, "
                           "DogName, CountryCode)" },
        { HDR, -EINVAL, "dogs.csv:1: no competitor after the header" },
        { HDR "1,A,B,C\n2,A,B,C\n3,A,B,C\n4,A,B,C\n5,A,B,C\n6,A,B,C\n7,A,B,C\n8,A,B,C\n"
              "9,A,B,C\n", -ENOSPC, "dogs.csv:10: more than 8 competitors" },
};

static void test_bad(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
                print_message("case %zu\n", i);
                assert_int_equal(parse_str(bad[i].text), bad[i].err);
                assert_string_equal(err, bad[i].msg);
        }
}

static void test_limits(void **state)
{
        char text[2 * AGILITY_CSV_LINE_MAX];
        char name[AGILITY_NAME_SIZE + 1];
        int n;

        (void)state;
        /* A NUL byte in the text. */
        assert_int_equal(parse(HDR "1,A\0,B,C\n", sizeof(HDR "1,A\0,B,C\n") - 1), -EINVAL);
        assert_string_equal(err, "dogs.csv:2: a NUL byte in the line");
        /* Names of 63 bytes fit, 64 do not. */
        memset(name, 'n', sizeof(name));
        name[AGILITY_NAME_SIZE - 1] = '\0';
        snprintf(text, sizeof(text), HDR "1,%s,B,C\n", name);
        assert_int_equal(parse_str(text), 0);
        assert_int_equal(strlen(list[0].handler), AGILITY_NAME_SIZE - 1);
        name[AGILITY_NAME_SIZE - 1] = 'n';
        name[AGILITY_NAME_SIZE] = '\0';
        snprintf(text, sizeof(text), HDR "1,A,%s,C\n", name);
        assert_int_equal(parse_str(text), -EINVAL);
        assert_string_equal(err, "dogs.csv:2: dog name longer than 63 bytes");
        /* A line longer than the limit. */
        n = snprintf(text, sizeof(text), HDR "1,A,B,%0*d\n", AGILITY_CSV_LINE_MAX, 0);
        assert_int_equal(parse(text, (size_t)n), -EINVAL);
        assert_string_equal(err, "dogs.csv:2: line longer than 1024 bytes");
        /* No room for an error message: still refused. */
        assert_int_equal(agility_competitors_parse("x", HDR, strlen(HDR), list, CAP, &count,
                                                   NULL, 0), -EINVAL);
        /* find */
        assert_int_equal(parse_str(HDR "5,A,B,C\n9,D,E,F\n"), 0);
        assert_ptr_equal(agility_competitors_find(list, count, 9), &list[1]);
        assert_null(agility_competitors_find(list, count, 6));
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_good),
                cmocka_unit_test(test_dialects),
                cmocka_unit_test(test_bad),
                cmocka_unit_test(test_limits),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
