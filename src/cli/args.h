/*
 * Command-line options of one slctl command: "--name", "--name=VALUE", "--name VALUE", "-h",
 * anything else positional. A word that starts with '-' is an option unless it is a negative
 * number ("set Throttle -0.5") or comes after "--". Pure: no output, the caller reports errors.
 */
#ifndef SLCTL_ARGS_H
#define SLCTL_ARGS_H

#include <stddef.h>

#define ARGS_OPTS_MAX           24      /* options one command knows */
#define ARGS_POS_MAX            64      /* positional words one command takes */
#define ARGS_DIGITS_MAX         9       /* decimal digits of a number option (fits an int) */

/* One option a command knows; a table of them ends with { NULL, 0 }. */
struct args_opt {
        const char *name;               /* long name without "--", e.g. "json" */
        int has_value;                  /* 1: takes a value */
};

struct args {
        int help;                       /* -h or --help was given */
        int given[ARGS_OPTS_MAX];       /* per option of the table: 1 when given */
        const char *value[ARGS_OPTS_MAX];       /* per option: its value (has_value ones) */
        int npos;
        char *pos[ARGS_POS_MAX];        /* positional words, in order */
};

/*
 * Parses argv[0..argc) (argv[0] is the first word after the command name) against opts into *ret.
 * Returns 0, or -EINVAL with the reason in err (unknown option, missing value, an option given
 * twice, a value for a flag, too many words).
 */
int args_parse(int argc, char **argv, const struct args_opt *opts, struct args *ret, char *err,
               size_t errsz);

/* Parses a non-negative decimal number (digits only); 0, -EINVAL (not one) or -ERANGE. */
int args_number(const char *text, long *ret);

#endif
