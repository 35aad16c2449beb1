/*
 * tests/common/testdata: placeholders replaced everywhere and only where they stand, bounded
 * output, and the data files found (or a clear error) from where the tests run.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "common/testdata.h"

#define OUT_MAX 8192

static void test_subst(void **state)
{
        const char *const subst[] = { "@DIR@", "/tmp/x", "@P0@", "4000", "@P10@", "9", NULL };
        char out[64];

        (void)state;
        assert_int_equal(testdata_subst("device: @DIR@/tty0 at @DIR@", subst, out, sizeof(out)),
                         strlen("device: /tmp/x/tty0 at /tmp/x"));
        assert_string_equal(out, "device: /tmp/x/tty0 at /tmp/x");
        /* The first key that matches wins: list longer keys first where one prefixes another. */
        assert_true(testdata_subst("@P0@ @P10@ @P1@ @DIR", subst, out, sizeof(out)) > 0);
        assert_string_equal(out, "4000 9 @P1@ @DIR");
        /* An empty key is no key. */
        {
                const char *const empty[] = { "", "x", NULL };

                assert_int_equal(testdata_subst("ab", empty, out, sizeof(out)), 2);
                assert_string_equal(out, "ab");
        }
        /* No placeholders at all. */
        assert_int_equal(testdata_subst("a@b", NULL, out, sizeof(out)), 3);
        assert_string_equal(out, "a@b");
        assert_int_equal(testdata_subst("", subst, out, sizeof(out)), 0);
        assert_string_equal(out, "");
}

static void test_subst_bounds(void **state)
{
        const char *const subst[] = { "@D@", "0123456789", NULL };
        char out[12];

        (void)state;
        /* 11 bytes + NUL fit exactly; one more byte does not, whichever side makes it. */
        assert_int_equal(testdata_subst("@D@x", subst, out, sizeof(out)), 11);
        assert_string_equal(out, "0123456789x");
        assert_int_equal(testdata_subst("@D@xy", subst, out, sizeof(out)), -ENOBUFS);
        assert_int_equal(testdata_subst("xy@D@", subst, out, sizeof(out)), -ENOBUFS);
        assert_int_equal(testdata_subst("abcdefghijkl", NULL, out, sizeof(out)), -ENOBUFS);
}

/* A real data file, from the directory run-tests.sh names (or tests/data by hand). */
static void test_load(void **state)
{
        const char *const subst[] = { "@DEV@", "/dev/pts/99", "@DIR@", "/run/t", NULL };
        static char out[OUT_MAX];
        ssize_t n;

        (void)state;
        n = testdata_load("sharedlink_peer_on_pty.yaml", subst, out, sizeof(out));
        assert_true(n > 0);
        assert_int_equal(strlen(out), (size_t)n);
        assert_int_equal(strncmp(out, "links:\n", 7), 0);
        assert_non_null(strstr(out, "device: /dev/pts/99\n"));
        assert_null(strchr(out, '@'));
        /* too small for it */
        assert_int_equal(testdata_load("sharedlink_peer_on_pty.yaml", subst, out, 16), -ENOBUFS);
        assert_int_equal(testdata_load("no-such-file.yaml", NULL, out, sizeof(out)), -ENOENT);
}

/* SHAREDLINK_TESTDATA, when set, is where the files are looked for. */
static void test_load_dir(void **state)
{
        char *saved = getenv(TESTDATA_DIR_ENV) ? strdup(getenv(TESTDATA_DIR_ENV)) : NULL;
        static char out[OUT_MAX];

        (void)state;
        assert_int_equal(setenv(TESTDATA_DIR_ENV, "/nonexistent-testdata", 1), 0);
        assert_int_equal(testdata_load("sharedlink_peer_on_pty.yaml", NULL, out, sizeof(out)),
                         -ENOENT);
        if (saved) {
                assert_int_equal(setenv(TESTDATA_DIR_ENV, saved, 1), 0);
                free(saved);
        } else {
                assert_int_equal(unsetenv(TESTDATA_DIR_ENV), 0);
        }
        assert_true(testdata_load("sharedlink_peer_on_pty.yaml", NULL, out, sizeof(out)) > 0);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_subst),
                cmocka_unit_test(test_subst_bounds),
                cmocka_unit_test(test_load),
                cmocka_unit_test(test_load_dir),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
