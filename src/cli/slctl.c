/*
 * slctl: what every command shares (messages, option parsing, opening the instance, reads).
 * main.c holds the command table, the help texts and the dispatch.
 */
#include "cli/slctl.h"

#include <errno.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define SLCTL_ERR_SIZE          256

int slctl_error(struct slctl *s, const char *fmt, ...)
{
        va_list ap;

        (void)s;
        fflush(stdout);
        fputs("slctl: ", stderr);
        va_start(ap, fmt);
        vfprintf(stderr, fmt, ap);
        va_end(ap);
        fputc('\n', stderr);
        return SLCTL_EXIT_ERROR;
}

int slctl_usage(struct slctl *s, const char *fmt, ...)
{
        const char *cmd = s ? s->command : NULL;
        va_list ap;

        fflush(stdout);
        fprintf(stderr, "slctl%s%s: ", cmd ? " " : "", cmd ? cmd : "");
        va_start(ap, fmt);
        vfprintf(stderr, fmt, ap);
        va_end(ap);
        fprintf(stderr, "\nTry 'slctl %s%s--help'.\n", cmd ? cmd : "", cmd ? " " : "");
        return SLCTL_EXIT_USAGE;
}

int slctl_not_running(struct slctl *s, const char *why)
{
        fflush(stdout);
        fprintf(stderr, "slctl: sharedlinkd (instance \"%s\") is not running: %s\n", s->instance,
                why);
        return SLCTL_EXIT_NOT_RUNNING;
}

int slctl_print_help(struct slctl *s)
{
        if (s->help)
                fputs(s->help, stdout);
        return SLCTL_EXIT_OK;
}

int slctl_args(struct slctl *s, int argc, char **argv, const struct args_opt *opts,
               struct args *ret)
{
        char err[SLCTL_ERR_SIZE];

        if (args_parse(argc - 1, argv + 1, opts, ret, err, sizeof(err)) < 0)
                return slctl_usage(s, "%s", err);
        if (ret->help)
                return slctl_print_help(s);
        return -1;
}

int slctl_open(struct slctl *s, int allow_dead)
{
        int r = sl_open(s->instance, &s->c);

        if (r == -ENOENT)
                return slctl_not_running(s, "its shared memory does not exist");
        if (r == -EINVAL)
                return slctl_error(s, "bad instance name \"%s\" (letters, digits, '_', '-', '.')",
                                   s->instance);
        /* The tables themselves are closed to this user: reads are refused, not only writes. */
        if (r == -EACCES)
                return slctl_error(s, "cannot read instance \"%s\": permission denied (its "
                                   "daemon has a group, which this user is not in: reading, "
                                   "writing and commands all need it)", s->instance);
        if (r < 0)
                return slctl_error(s, "cannot open instance \"%s\": %s", s->instance,
                                   sl_strerror(r));
        if (!allow_dead && sl_daemon_alive(s->c) == 0)
                return slctl_not_running(s, "its tables are left over from a daemon that is gone");
        return -1;
}

int slctl_count_timeout(struct slctl *s, const char *count_text, const char *timeout_text,
                        long *count, long *timeout_ms)
{
        *count = 0;
        *timeout_ms = -1;
        if (count_text && (args_number(count_text, count) < 0 || *count == 0))
                return slctl_error(s, "bad --count \"%s\": a number from 1 up", count_text);
        if (timeout_text && args_number(timeout_text, timeout_ms) < 0)
                return slctl_error(s, "bad --timeout \"%s\": milliseconds expected (at most "
                                   "%d digits)", timeout_text, ARGS_DIGITS_MAX);
        return -1;
}

void slctl_interruptible(void)
{
        struct sigaction sa;

        memset(&sa, 0, sizeof(sa));
        sa.sa_handler = SIG_DFL;
        sigemptyset(&sa.sa_mask);
        sigaction(SIGINT, &sa, NULL);
}

int slctl_write(struct slctl *s, int id, const char *value)
{
        long nap_ms = 1, waited_ms = 0;
        int r = sl_write(s->c, id, value);

        while (r == -EAGAIN && waited_ms < SLCTL_WRITE_BUSY_MS) {
                struct timespec ts = { nap_ms / 1000, (nap_ms % 1000) * 1000000L };

                nanosleep(&ts, NULL);
                waited_ms += nap_ms;
                nap_ms = nap_ms * 2 < 100 ? nap_ms * 2 : 100;
                r = sl_write(s->c, id, value);
        }
        return r;
}

int slctl_read(struct slctl *s, int id, char *buf, size_t size, struct sl_meta *meta)
{
        int r = -EAGAIN;

        for (int i = 0; i < SLCTL_READ_TRIES && r == -EAGAIN; i++)
                r = sl_read(s->c, id, buf, size, meta);
        return r;
}

void slctl_format_age(char *buf, size_t size, uint64_t age_ns, int known)
{
        if (!known)
                snprintf(buf, size, "-");
        else
                snprintf(buf, size, "%.3fs", (double)age_ns / 1e9);
}
