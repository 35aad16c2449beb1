/*
 * Options of one slctl command (args.h).
 */
#include "cli/args.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

/* "-5", "-0.25": a value, not an option. */
static int is_negative_number(const char *word)
{
        return word[0] == '-' && ((word[1] >= '0' && word[1] <= '9') ||
                                  (word[1] == '.' && word[2] >= '0' && word[2] <= '9'));
}

/* Index of the option called name[0..len) in opts, or -1. */
static int find_opt(const struct args_opt *opts, const char *name, size_t len)
{
        for (int i = 0; opts && opts[i].name && i < ARGS_OPTS_MAX; i++)
                if (strlen(opts[i].name) == len && strncmp(opts[i].name, name, len) == 0)
                        return i;
        return -1;
}

int args_parse(int argc, char **argv, const struct args_opt *opts, struct args *ret, char *err,
               size_t errsz)
{
        struct args a;
        int options_done = 0;

        memset(&a, 0, sizeof(a));
        for (int i = 0; i < argc; i++) {
                char *w = argv[i];
                const char *eq;
                size_t len;
                int k;

                if (options_done || w[0] != '-' || w[1] == '\0' || is_negative_number(w)) {
                        if (a.npos == ARGS_POS_MAX) {
                                snprintf(err, errsz, "too many arguments");
                                return -EINVAL;
                        }
                        a.pos[a.npos++] = w;
                        continue;
                }
                if (strcmp(w, "--") == 0) {
                        options_done = 1;
                        continue;
                }
                if (strcmp(w, "-h") == 0 || strcmp(w, "--help") == 0) {
                        a.help = 1;
                        continue;
                }
                if (w[1] != '-') {
                        snprintf(err, errsz, "unknown option %s", w);
                        return -EINVAL;
                }
                eq = strchr(w + 2, '=');
                len = eq ? (size_t)(eq - (w + 2)) : strlen(w + 2);
                k = find_opt(opts, w + 2, len);
                if (k < 0) {
                        snprintf(err, errsz, "unknown option --%.*s", (int)len, w + 2);
                        return -EINVAL;
                }
                if (a.given[k]) {
                        snprintf(err, errsz, "--%s given twice", opts[k].name);
                        return -EINVAL;
                }
                a.given[k] = 1;
                if (!opts[k].has_value) {
                        if (eq) {
                                snprintf(err, errsz, "--%s takes no value", opts[k].name);
                                return -EINVAL;
                        }
                        continue;
                }
                if (eq) {
                        a.value[k] = eq + 1;
                } else if (i + 1 < argc) {
                        a.value[k] = argv[++i];
                } else {
                        snprintf(err, errsz, "--%s needs a value", opts[k].name);
                        return -EINVAL;
                }
        }
        *ret = a;
        return 0;
}

int args_number(const char *text, long *ret)
{
        size_t len = strlen(text);
        long v = 0;

        if (len == 0 || strspn(text, "0123456789") != len)
                return -EINVAL;
        if (len > ARGS_DIGITS_MAX)
                return -ERANGE;
        for (size_t i = 0; i < len; i++)
                v = v * 10 + (text[i] - '0');
        *ret = v;
        return 0;
}
