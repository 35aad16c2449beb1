/*
 * The command line, start and main loop of every daemon (sharedlinkd, sharedlink-mqtt, the next
 * ones), so that each keeps one documented interface:
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
 *
 * Then, with its configuration read, the daemon makes its service (service_new) and runs it;
 * a main() is, in this fixed order with teardown in exact reverse (STYLE.md):
 *
 *      r = service_args(&desc, argc, argv, &args);     // -n, -V, -h and usage end here
 *      if (r != SERVICE_CONTINUE)
 *              return r;
 *      service_start(&args);                           // logger, SIGPIPE
 *      ... read args.config; on error log it and return SERVICE_EXIT_FAILURE ...
 *      service_new(&desc, &ops, ctx, &svc);            // loop, notify, signals, watchdog
 *      ... the daemon's own start on service_loop(svc); it sends service_ready() ...
 *      code = service_run(svc);                        // blocks until a stop
 *      ... the daemon's own teardown ...
 *      service_free(svc);                              // "stopped" after a clean stop
 *      return code;
 *
 * What the service routes, on its loop (svc/evloop.h), to the daemon's service_ops:
 *   SIGTERM, SIGINT  "SIGNAME: stopping[note]" at notice, STOPPING=1, and the loop ends with
 *                    exit 0 at once, or, when ops->stop asks to drain, once the daemon calls
 *                    service_exit(). A second stop signal while draining is ignored.
 *   SIGHUP           RELOADING=1, then ops->reload (which sends service_ready() when done);
 *                    without one, "SIGHUP: NAME has no reload; ..." at notice and nothing else.
 *   WATCHDOG_USEC    WATCHDOG=1 from a timer on the loop at half the period (so that a stuck
 *                    loop stops the pings and the service manager notices), logged once at info.
 * The signals are blocked from service_new() on: start threads after it, so that they inherit
 * the mask and the signals reach the loop.
 *
 * Exit status: SERVICE_EXIT_OK after a clean stop or a good -n check, SERVICE_EXIT_FAILURE on a
 * bad configuration, a failed start or a fatal error in the loop, SERVICE_EXIT_USAGE,
 * SERVICE_EXIT_HELD when another copy holds the daemon's lock (svc/lockfile.h).
 */
#ifndef SHAREDLINK_SVC_SERVICE_H
#define SHAREDLINK_SVC_SERVICE_H

#include <stdbool.h>
#include <stddef.h>

#include "svc/evloop.h"
#include "svc/notify.h"

#define SERVICE_EXIT_OK         0
#define SERVICE_EXIT_FAILURE    1       /* a bad configuration or a failed start */
#define SERVICE_EXIT_USAGE      2
/* Another copy already serves what this one would (svc/lockfile.h): the units do not restart on
 * it (RestartPreventExitStatus=), since a restart meets the same holder. */
#define SERVICE_EXIT_HELD       3
#define SERVICE_CONTINUE        (-1)    /* service_args(): run the daemon */
#define SERVICE_STOP_NOW        0       /* service_ops.stop: the loop ends after this round */
#define SERVICE_STOP_DRAIN      1       /* ... the daemon calls service_exit() when drained */
#define SERVICE_NOTE_MAX        128     /* bytes of a stop note in the log line */

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

/* What the daemon does on a stop or a reload; members may be NULL (see above). */
struct service_ops {
        /* SIGTERM/SIGINT: starts the stop; may write a note for the log line (" (3 events to be
         * acknowledged)"). SERVICE_STOP_NOW or SERVICE_STOP_DRAIN. NULL: stop now. */
        int (*stop)(void *arg, char *note, size_t note_size);
        /* SIGHUP, after RELOADING=1: reads the configuration again, then service_ready(). */
        void (*reload)(void *arg);
};

struct service;

/* Parses the command line. SERVICE_CONTINUE with *ret filled: start the daemon; otherwise the
 * exit status (-V, -h, a usage error, or -n's check). */
int service_args(const struct service_desc *d, int argc, char **argv, struct service_args *ret);

/* The logger at args->verbose, SIGPIPE ignored. */
void service_start(const struct service_args *args);

/* "configuration OK" on stdout, exit status 0: what -n prints for a good file. */
int service_check_ok(void);

/* The loop, the service manager's notifier, the signal routing and the watchdog timer for
 * the daemon d->name; ops and arg are kept. 0 or -errno (logged). */
int service_new(const struct service_desc *d, const struct service_ops *ops, void *arg,
                struct service **ret_service);

/* Cancels the watchdog, frees the notifier, the loop (which unblocks the signals), and logs
 * "stopped" after a clean stop. NULL ok; returns NULL. */
struct service *service_free(struct service *s);

/* The loop every part of the daemon runs on. */
struct evloop *service_loop(struct service *s);

/* The service manager's notifier (RELOADING=1, raw assignments). */
struct notify *service_notify(struct service *s);

/* Runs the loop until a stop or service_exit(); the exit status (a loop that failed for good is
 * logged and gives SERVICE_EXIT_FAILURE). */
int service_run(struct service *s);

/* Ends the loop after this round with exit status code: a drained stop (SERVICE_EXIT_OK) or a
 * fatal error (SERVICE_EXIT_FAILURE). */
void service_exit(struct service *s, int code);

/* Whether a stop signal arrived (the daemon drains: no new work). */
bool service_stopping(const struct service *s);

/* READY=1 with STATUS=<text> (NULL: none) in one message, at start and after a reload.
 * 1 when text differs from the last status sent, else 0. */
int service_ready(struct service *s, const char *text);

/* STATUS=<text> when it differs from the last one sent (states, not counts: every change is a
 * datagram to the service manager, dropped when its queue is full). 1 sent, 0 unchanged. */
int service_status(struct service *s, const char *text);

#endif
