/*
 * libFuzzer target for the competitor CSV import (src/agility/agility_competitors.c) and the
 * results export (src/agility/agility_export.c).
 *
 * Any input either parses into competitors that keep every rule (numbers 1..999 and unique,
 * names terminated, not empty, without control characters) or fails with a "FILE:LINE: "
 * message; a parsed list exported (with and without results) parses again into the same
 * competitors. Any broken invariant is a __builtin_trap().
 */
#include <errno.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "agility/agility_competitors.h"
#include "agility/agility_export.h"
#include "fuzz_input.h"

#define LIST_MAX 32

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static struct agility_competitor list[LIST_MAX], back[LIST_MAX];
static char text[(LIST_MAX + 1) * AGILITY_EXPORT_LINE_MAX];

static bool text_ok(const char *s, size_t size, bool may_be_empty)
{
        size_t n = strnlen(s, size);

        if (n == size || (n == 0 && !may_be_empty))
                return false;
        for (size_t i = 0; i < n; i++)
                if ((unsigned char)s[i] < ' ' || s[i] == 0x7f)
                        return false;
        return true;
}

static void check_list(const struct agility_competitor *l, size_t n)
{
        CHECK(n >= 1 && n <= LIST_MAX);
        for (size_t i = 0; i < n; i++) {
                CHECK(l[i].number >= 1 && l[i].number <= CIRCE_COMPETITOR_MAX);
                for (size_t j = 0; j < i; j++)
                        CHECK(l[j].number != l[i].number);
                CHECK(text_ok(l[i].handler, sizeof(l[i].handler), false));
                CHECK(text_ok(l[i].dog, sizeof(l[i].dog), false));
                CHECK(text_ok(l[i].country, sizeof(l[i].country), true));
        }
}

/* Exports l (every other competitor with a made-up completed run) and parses it again. */
static void round_trip(const struct agility_competitor *l, size_t n)
{
        char err[AGILITY_CSV_ERROR_SIZE];
        size_t len = 0, m = 0;
        int r = agility_export_header(text, sizeof(text));

        CHECK(r > 0);
        len = (size_t)r;
        for (size_t i = 0; i < n; i++) {
                struct agility_result res = {
                        .competitor = l[i].number, .completed = i % 2 == 1, .finished = true,
                        .finish_ms = l[i].number * 997u, .faults = 5, .intermediates = 1,
                        .intermediate_ms = { 1234 }, .placement = (uint16_t)i,
                };

                r = agility_export_row(text + len, sizeof(text) - len, &l[i], &res);
                CHECK(r > 0);
                len += (size_t)r;
        }
        r = agility_competitors_parse("export.csv", text, len, back, LIST_MAX, &m, err,
                                      sizeof(err));
        CHECK(r == 0 && m == n);
        for (size_t i = 0; i < n; i++) {
                CHECK(back[i].number == l[i].number);
                CHECK(strcmp(back[i].handler, l[i].handler) == 0);
                CHECK(strcmp(back[i].dog, l[i].dog) == 0);
                CHECK(strcmp(back[i].country, l[i].country) == 0);
        }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        static const char prefix[] = "fuzz.csv:";
        char err[AGILITY_CSV_ERROR_SIZE];
        size_t n = 0;
        int r;

        memset(err, 'x', sizeof(err));
        r = agility_competitors_parse("fuzz.csv", (const char *)data, size, list, LIST_MAX, &n,
                                      err, sizeof(err));
        if (r == 0) {
                CHECK(err[0] == '\0');
                check_list(list, n);
                round_trip(list, n);
                return 0;
        }
        CHECK(r == -EINVAL || r == -ENOSPC);
        CHECK(strnlen(err, sizeof(err)) < sizeof(err));
        CHECK(strncmp(err, prefix, sizeof(prefix) - 1) == 0);
        return 0;
}
