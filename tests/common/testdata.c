/*
 * Test data files (see testdata.h).
 */
#include "common/testdata.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TESTDATA_FILE_MAX (64 * 1024)   /* larger than any configuration a test needs */

/* The first key of subst that text starts with, or -1 (an empty key never matches: it would
 * never advance). */
static int key_at(const char *text, const char *const *subst)
{
        for (int k = 0; subst && subst[k] && subst[k + 1]; k += 2)
                if (subst[k][0] && strncmp(text, subst[k], strlen(subst[k])) == 0)
                        return k;
        return -1;
}

ssize_t testdata_subst(const char *text, const char *const *subst, char *out, size_t size)
{
        size_t o = 0;

        while (*text) {
                int k = key_at(text, subst);
                const char *piece = k >= 0 ? subst[k + 1] : text;
                size_t len = k >= 0 ? strlen(piece) : 1;

                if (o + len >= size)
                        return -ENOBUFS;
                memcpy(out + o, piece, len);
                o += len;
                text += k >= 0 ? strlen(subst[k]) : 1;
        }
        if (o >= size)
                return -ENOBUFS;
        out[o] = '\0';
        return (ssize_t)o;
}

ssize_t testdata_load(const char *name, const char *const *subst, char *out, size_t size)
{
        const char *dir = getenv(TESTDATA_DIR_ENV);
        char path[PATH_MAX], *text;
        ssize_t r;
        size_t n;
        FILE *f;
        int e;

        snprintf(path, sizeof(path), "%s/%s", dir && *dir ? dir : TESTDATA_DIR_DEFAULT, name);
        f = fopen(path, "re");
        if (!f) {
                e = errno;
                fprintf(stderr, "testdata: %s: %s\n", path, strerror(e));
                return -e;
        }
        text = malloc(TESTDATA_FILE_MAX + 1);
        n = text ? fread(text, 1, TESTDATA_FILE_MAX + 1, f) : 0;
        e = !text ? ENOMEM : ferror(f) ? EIO : n > TESTDATA_FILE_MAX ? EFBIG : 0;
        fclose(f);
        if (e) {
                fprintf(stderr, "testdata: %s: %s\n", path, strerror(e));
                free(text);
                return -e;
        }
        text[n] = '\0';
        r = testdata_subst(text, subst, out, size);
        free(text);
        return r;
}
