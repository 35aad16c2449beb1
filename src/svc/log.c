/*
 * Service logging (see log.h).
 */
#include "svc/log.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define LOG_ELLIPSIS            "..."
#define LOG_ESCAPE_LEN          4       /* "\xNN" */
#define LOG_PREFIX_LEN          3       /* "<N>" */
#define LOG_NSEC_PER_MSEC       1000000ull
#define LOG_NSEC_PER_SEC        1000000000ull

/* Process-wide by design (see log.h): written by log_init() before any thread starts. */
static int log_level = LOG_PRIO_INFO;
static int log_fd = STDERR_FILENO;
static int log_verbose;

void log_init(int verbosity, int fd)
{
        if (verbosity < 0)
                log_level = LOG_PRIO_WARNING;
        else if (verbosity >= LOG_VERBOSITY_DEBUG)
                log_level = LOG_PRIO_DEBUG;
        else
                log_level = LOG_PRIO_INFO;
        log_verbose = verbosity;
        log_fd = fd >= 0 ? fd : STDERR_FILENO;
}

int log_verbosity(void)
{
        return log_verbose;
}

static bool log_enabled(enum log_prio prio)
{
        return (int)prio <= log_level;
}

/* Copies `text` into line[pos..] escaping control bytes; returns the new position. Stops short
 * of `room` and marks the cut with an ellipsis. */
static size_t log_escape(char *line, size_t pos, size_t room, const char *text)
{
        static const char hex[] = "0123456789abcdef";
        size_t limit = room - sizeof(LOG_ELLIPSIS);     /* keeps space for "..." and NUL */

        for (const unsigned char *p = (const unsigned char *)text; *p; p++) {
                bool ctl = *p < 0x20 || *p == 0x7f;
                size_t need = ctl ? LOG_ESCAPE_LEN : 1;

                if (pos + need > limit) {
                        memcpy(line + pos, LOG_ELLIPSIS, sizeof(LOG_ELLIPSIS) - 1);
                        return pos + sizeof(LOG_ELLIPSIS) - 1;
                }
                if (ctl) {
                        line[pos++] = '\\';
                        line[pos++] = 'x';
                        line[pos++] = hex[*p >> 4];
                        line[pos++] = hex[*p & 0xf];
                } else {
                        line[pos++] = (char)*p;
                }
        }
        return pos;
}

/* Formats and writes one line; errnum > 0 appends ": strerror(errnum)". */
__attribute__((format(printf, 3, 0)))
static void log_vwrite(enum log_prio prio, int errnum, const char *fmt, va_list ap)
{
        char text[LOG_LINE_MAX];
        char line[LOG_LINE_MAX + 1];
        size_t pos, len;
        ssize_t n;

        vsnprintf(text, sizeof(text), fmt, ap);
        if (errnum > 0) {
                len = strlen(text);
                snprintf(text + len, sizeof(text) - len, ": %s", strerror(errnum));
        }
        pos = (size_t)snprintf(line, sizeof(line), "<%d>", (int)prio);
        pos = log_escape(line, pos, sizeof(line) - 1, text);
        line[pos++] = '\n';
        /* One write per line; a short write or EINTR loses the rest of one line, never more. */
        do {
                n = write(log_fd, line, pos);
        } while (n < 0 && errno == EINTR);
}

void log_msg(enum log_prio prio, const char *fmt, ...)
{
        va_list ap;

        if (!log_enabled(prio))
                return;
        va_start(ap, fmt);
        log_vwrite(prio, 0, fmt, ap);
        va_end(ap);
}

void log_debug(const char *fmt, ...)
{
        va_list ap;

        if (!log_enabled(LOG_PRIO_DEBUG))
                return;
        va_start(ap, fmt);
        log_vwrite(LOG_PRIO_DEBUG, 0, fmt, ap);
        va_end(ap);
}

void log_info(const char *fmt, ...)
{
        va_list ap;

        if (!log_enabled(LOG_PRIO_INFO))
                return;
        va_start(ap, fmt);
        log_vwrite(LOG_PRIO_INFO, 0, fmt, ap);
        va_end(ap);
}

void log_notice(const char *fmt, ...)
{
        va_list ap;

        if (!log_enabled(LOG_PRIO_NOTICE))
                return;
        va_start(ap, fmt);
        log_vwrite(LOG_PRIO_NOTICE, 0, fmt, ap);
        va_end(ap);
}

void log_warnx(const char *fmt, ...)
{
        va_list ap;

        va_start(ap, fmt);
        log_vwrite(LOG_PRIO_WARNING, 0, fmt, ap);
        va_end(ap);
}

void log_warn(const char *fmt, ...)
{
        int errnum = errno;
        va_list ap;

        va_start(ap, fmt);
        log_vwrite(LOG_PRIO_WARNING, errnum, fmt, ap);
        va_end(ap);
        errno = errnum;
}

void fatal(const char *fmt, ...)
{
        int errnum = errno;
        va_list ap;

        va_start(ap, fmt);
        log_vwrite(LOG_PRIO_CRIT, errnum, fmt, ap);
        va_end(ap);
        exit(EXIT_FAILURE);
}

void fatalx(const char *fmt, ...)
{
        va_list ap;

        va_start(ap, fmt);
        log_vwrite(LOG_PRIO_CRIT, 0, fmt, ap);
        va_end(ap);
        exit(EXIT_FAILURE);
}

/* ---------------------------------------------------------------------------------------------
 * Rate limiting */

void log_ratelimit_init(struct log_ratelimit *rl, const char *name, unsigned interval_ms,
                        unsigned burst)
{
        memset(rl, 0, sizeof(*rl));
        rl->name = name ? name : "log";
        rl->interval_ns = (uint64_t)interval_ms * LOG_NSEC_PER_MSEC;
        rl->burst = burst;
}

bool log_ratelimit_flush(struct log_ratelimit *rl)
{
        if (rl->suppressed == 0)
                return false;
        log_msg(LOG_PRIO_NOTICE, "%s: suppressed %llu messages", rl->name,
                (unsigned long long)rl->suppressed);
        rl->suppressed = 0;
        return true;
}

bool log_ratelimit_pass(struct log_ratelimit *rl, uint64_t now_ns)
{
        /* A window opens at the first message after the last one closed. A clock that went
         * backwards (a caller mixing clocks) also opens a new window. */
        if (!rl->window_open || now_ns < rl->window_start_ns ||
            now_ns - rl->window_start_ns >= rl->interval_ns) {
                rl->window_open = true;
                rl->window_start_ns = now_ns;
                rl->in_window = 0;
        }
        if (rl->in_window < rl->burst) {
                log_ratelimit_flush(rl);
                rl->in_window++;
                return true;
        }
        rl->suppressed++;
        rl->suppressed_total++;
        return false;
}

void log_ratelimited(struct log_ratelimit *rl, enum log_prio prio, const char *fmt, ...)
{
        struct timespec ts;
        va_list ap;

        /* A message the verbosity hides anyway neither uses the burst nor counts as suppressed. */
        if (!log_enabled(prio))
                return;
        clock_gettime(CLOCK_MONOTONIC, &ts);
        if (!log_ratelimit_pass(rl, (uint64_t)ts.tv_sec * LOG_NSEC_PER_SEC + (uint64_t)ts.tv_nsec))
                return;
        va_start(ap, fmt);
        log_vwrite(prio, 0, fmt, ap);
        va_end(ap);
}
