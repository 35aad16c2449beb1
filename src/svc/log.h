/*
 * Service logging, the one logger of every daemon (sharedlinkd, sharedlink-mqtt), OpenBSD style:
 * log_warn() appends strerror(errno), log_warnx() does not, fatal()/fatalx() log and exit(1)
 * (use them only before READY=1: afterwards a failing link or a bad input must never stop the
 * daemon).
 *
 * Every message is one line on the log fd (stderr by default) with an sd-daemon(3) priority
 * prefix, "<3>message\n", which journald turns into the syslog priority. One line is one
 * write(2), so lines from several threads never interleave. Control characters in a message
 * (wire bytes quoted in a diagnostic, say) are written as \xNN so that one message is always
 * one journal line; a message longer than LOG_LINE_MAX is cut and ends with "...".
 *
 * The logger is process-wide state (the verbosity and the fd): it stands for the one stderr a
 * process has, and fatal() must work from anywhere without a handle. Everything else in a
 * daemon takes an instance handle; rate limiters below are per instance (e.g. per link).
 */
#ifndef SHAREDLINK_SVC_LOG_H
#define SHAREDLINK_SVC_LOG_H

#include <stdbool.h>
#include <stdint.h>

/* Priorities, numerically those of syslog(3) and sd-daemon(3). */
enum log_prio {
        LOG_PRIO_CRIT = 2,
        LOG_PRIO_ERR = 3,
        LOG_PRIO_WARNING = 4,
        LOG_PRIO_NOTICE = 5,
        LOG_PRIO_INFO = 6,
        LOG_PRIO_DEBUG = 7,
};

#define LOG_LINE_MAX            1024    /* bytes per line, prefix and newline included */
#define LOG_VERBOSITY_DEBUG     1       /* verbosity that enables log_debug() */

/* Sets the verbosity (< 0: warnings and worse; 0: info and worse; >= 1: debug too) and the fd
 * lines go to (-1: stderr). Safe to call again, e.g. on reload or from a test. */
void log_init(int verbosity, int fd);

/* Current verbosity, as given to log_init(). */
int log_verbosity(void);

/* Writes one message at `prio` if the verbosity lets it through. */
void log_msg(enum log_prio prio, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Debug detail, shown with -v only. */
void log_debug(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* Normal operation worth a line (link up, config loaded). */
void log_info(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* A significant but normal event (reload, clean stop). */
void log_notice(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* A warning without errno. */
void log_warnx(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* A warning followed by ": strerror(errno)". */
void log_warn(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* Logs at LOG_PRIO_CRIT with ": strerror(errno)" and exits 1. */
void fatal(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));

/* Logs at LOG_PRIO_CRIT and exits 1. */
void fatalx(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));

/*
 * Rate limiter for repetitive diagnostics (wire errors on one link): at most `burst` messages
 * per `interval`; the rest are counted, and the first message let through after the window
 * (or log_ratelimit_flush()) is preceded by "<name>: suppressed K messages".
 * The caller owns the struct; `name` must outlive it.
 */
struct log_ratelimit {
        const char *name;               /* says whose messages were suppressed */
        uint64_t interval_ns;
        unsigned burst;
        bool window_open;               /* false until the first message */
        uint64_t window_start_ns;
        unsigned in_window;             /* messages let through in the current window */
        uint64_t suppressed;            /* not yet reported */
        uint64_t suppressed_total;      /* since init, for counters */
};

#define LOG_RATELIMIT_INTERVAL_MS       5000    /* default window of log_ratelimit_init() users */
#define LOG_RATELIMIT_BURST             10      /* default burst */

/* Initialises a limiter: `burst` messages per `interval_ms` (burst 0 suppresses everything). */
void log_ratelimit_init(struct log_ratelimit *rl, const char *name, unsigned interval_ms,
                        unsigned burst);

/* Core decision at monotonic time now_ns: true when a message may be written now (after the
 * "suppressed" summary, which it writes itself when due). */
bool log_ratelimit_pass(struct log_ratelimit *rl, uint64_t now_ns);

/* Writes the "suppressed" summary now if messages were suppressed (from a periodic timer, so a
 * burst that stopped is still reported); true if it wrote one. */
bool log_ratelimit_flush(struct log_ratelimit *rl);

/* log_msg() through the limiter, on the monotonic clock. */
void log_ratelimited(struct log_ratelimit *rl, enum log_prio prio, const char *fmt, ...)
        __attribute__((format(printf, 3, 4)));

#endif
