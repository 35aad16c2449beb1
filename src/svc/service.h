/*
 * The command line and start of every daemon (sharedlinkd, sharedlink-mqtt, the next ones), so
 * that each keeps one documented interface:
 *
 *   NAME [-c FILE] [-n] [-v] [-V]
 *
 *   -c FILE  configuration (default: the daemon's)
 *   -n       check the configuration, print "configuration OK" and exit 0, or print
 *            "FILE:LINE:COL: message" and exit 1
 *   -v       more detail in the log (debug); -h prints the usage and exits 0
 *   -V       print "NAME VERSION" and exit 0
 *
 * A usage error exits 2. Past the command line, service_start() makes the process a daemon of
 * this house: the logger at the chosen verbosity on stderr (journald priorities, svc/log.h) and
 * SIGPIPE ignored, so that a write to a peer that left returns EPIPE instead of killing it.
 * The daemon then adds SIGTERM/SIGINT (stop: STOPPING=1, exit 0) and SIGHUP (its reload, or
 * nothing) to its own loop, and tells the service manager through svc/notify.h.
 */
#ifndef SHAREDLINK_SVC_SERVICE_H
#define SHAREDLINK_SVC_SERVICE_H

#include <stdbool.h>

#define SERVICE_EXIT_OK         0
#define SERVICE_EXIT_FAILURE    1       /* a bad configuration or a failed start */
#define SERVICE_EXIT_USAGE      2
#define SERVICE_CONTINUE        (-1)    /* service_args(): run the daemon */

struct service_desc {
        const char *name;               /* in the usage and -V: "sharedlinkd" */
        const char *version;
        const char *config_default;     /* -c's default */
        /* -n: checks the file PATH; prints "configuration OK" or the error itself and returns
         * the exit status. */
        int (*check)(const char *path);
};

struct service_args {
        const char *config;             /* -c, or the default */
        int verbose;                    /* how many -v */
};

/* Parses the command line. SERVICE_CONTINUE with *ret filled: start the daemon; otherwise the
 * exit status (-V, -h, a usage error, or -n's check). */
int service_args(const struct service_desc *d, int argc, char **argv, struct service_args *ret);

/* The logger at args->verbose, SIGPIPE ignored. */
void service_start(const struct service_args *args);

/* "configuration OK" on stdout, exit status 0: what -n prints for a good file. */
int service_check_ok(void);

#endif
