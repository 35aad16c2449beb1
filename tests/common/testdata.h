/*
 * The files under tests/data/ (configurations a test would otherwise embed as long C strings),
 * found from wherever the test binary runs, with placeholders such as "@DIR@" replaced by the
 * test's own runtime paths. Plain C, no cmocka.
 */
#pragma once

#include <stddef.h>
#include <sys/types.h>

#define TESTDATA_DIR_ENV        "SHAREDLINK_TESTDATA"   /* set by tests/run-tests.sh */
#define TESTDATA_DIR_DEFAULT    "tests/data"            /* from the source root */

/* Copies text into out with every key of subst replaced by its value; subst is { key, value,
 * key, value, ..., NULL } (or NULL: no placeholders). Returns the length (out NUL-terminated)
 * or -ENOBUFS. */
ssize_t testdata_subst(const char *text, const char *const *subst, char *out, size_t size);

/* Reads <$SHAREDLINK_TESTDATA or tests/data>/name into out and substitutes as testdata_subst.
 * Returns the length or -errno (the path it tried goes to stderr). */
ssize_t testdata_load(const char *name, const char *const *subst, char *out, size_t size);
