/*
 * The command line, start and main loop of every daemon (see service.h).
 */
#include "svc/service.h"

#include <errno.h>
#include <inttypes.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "svc/log.h"

#define NOTIFY_FAILED_TELL_EVERY        100     /* undelivered notifications between warnings */

struct service {
        const struct service_desc *desc;
        const struct service_ops *ops;
        void *arg;
        struct evloop *loop;
        struct notify *notify;
        struct evloop_timer watchdog;
        bool stopping;
        bool clean;                     /* service_run() ended with SERVICE_EXIT_OK */
        char status[NOTIFY_STATUS_MAX]; /* the last STATUS= text sent */
        uint64_t notify_failed_told;    /* notify_failed() when we last said so */
};

/* Says once, then once per NOTIFY_FAILED_TELL_EVERY more, that the service manager is not
 * taking our messages (its queue full, or its socket gone): the loop never waits for it. */
static void service_notify_check(struct service *s)
{
        uint64_t failed = notify_failed(s->notify);

        if (failed == s->notify_failed_told ||
            (s->notify_failed_told && failed - s->notify_failed_told < NOTIFY_FAILED_TELL_EVERY))
                return;
        log_warnx("service manager: %" PRIu64 " notification(s) not delivered (its socket "
                    "is full or gone); STATUS= and WATCHDOG=1 are dropped, not waited for",
                    failed);
        s->notify_failed_told = failed;
}

static void usage(const struct service_desc *d, FILE *f)
{
        fprintf(f, "usage: %s [-c FILE] [-n] [-v] [-V]\n"
                   "  -c FILE  configuration (default %s)\n"
                   "  -n       check the configuration, print \"configuration OK\" and exit\n"
                   "  -v       more detail in the log (debug)\n"
                   "  -V       print the version and exit\n", d->name, d->config_default);
}

int service_args(const struct service_desc *d, int argc, char **argv, struct service_args *ret)
{
        struct service_args a = { .config = d->config_default };
        bool check = false;
        int opt;

        while ((opt = getopt(argc, argv, "c:nvVh")) != -1) {
                switch (opt) {
                case 'c':
                        a.config = optarg;
                        break;
                case 'n':
                        check = true;
                        break;
                case 'v':
                        a.verbose++;
                        break;
                case 'V':
                        printf("%s %s\n", d->name, d->version);
                        return SERVICE_EXIT_OK;
                case 'h':
                        usage(d, stdout);
                        return SERVICE_EXIT_OK;
                default:
                        usage(d, stderr);
                        return SERVICE_EXIT_USAGE;
                }
        }
        if (optind != argc) {
                usage(d, stderr);
                return SERVICE_EXIT_USAGE;
        }
        if (check)
                return d->check(a.config);
        *ret = a;
        return SERVICE_CONTINUE;
}

void service_start(const struct service_args *args)
{
        log_init(args->verbose, -1);
        /* Writes to a peer that left return EPIPE instead of killing the daemon. */
        signal(SIGPIPE, SIG_IGN);
}

int service_check_ok(void)
{
        printf("configuration OK\n");
        return SERVICE_EXIT_OK;
}

static void service_on_stop(struct evloop *loop, int signo, void *arg)
{
        struct service *s = arg;
        char note[SERVICE_NOTE_MAX] = "";
        int how = SERVICE_STOP_NOW;

        (void)loop;
        if (s->stopping)
                return;
        s->stopping = true;
        if (s->ops->stop)
                how = s->ops->stop(s->arg, note, sizeof(note));
        log_notice("%s: stopping%s", strsignal(signo), note);
        notify_stopping(s->notify);
        if (how == SERVICE_STOP_NOW)
                service_exit(s, SERVICE_EXIT_OK);
}

static void service_on_reload(struct evloop *loop, int signo, void *arg)
{
        struct service *s = arg;

        (void)loop;
        if (!s->ops->reload) {
                log_notice("%s: %s has no reload; restart it to read the configuration again",
                           strsignal(signo), s->desc->name);
                return;
        }
        notify_reloading(s->notify);
        s->ops->reload(s->arg);
}

/* From the loop, so that a stuck loop stops the pings and the service manager notices. */
static void service_on_watchdog(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        struct service *s = arg;

        (void)loop;
        (void)t;
        notify_watchdog(s->notify);
        service_notify_check(s);
}

static int service_watchdog_start(struct service *s)
{
        uint64_t ms = notify_watchdog_interval_ms(s->notify);
        int r;

        evloop_timer_init(&s->watchdog, s->loop, service_on_watchdog, s);
        if (ms == 0)
                return 0;
        r = evloop_timer_arm(&s->watchdog, ms, ms);
        if (r < 0)
                return r;
        log_info("watchdog: WATCHDOG=1 every %" PRIu64 " ms", ms);
        return 0;
}

int service_new(const struct service_desc *d, const struct service_ops *ops, void *arg,
                struct service **ret_service)
{
        static const struct service_ops none;
        struct service *s = calloc(1, sizeof(*s));
        int r;

        if (!s) {
                log_msg(LOG_PRIO_ERR, "%s", strerror(ENOMEM));
                return -ENOMEM;
        }
        s->desc = d;
        s->ops = ops ? ops : &none;
        s->arg = arg;
        r = evloop_new(&s->loop);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "event loop: %s", strerror(-r));
                goto fail;
        }
        r = notify_new(&s->notify);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "service manager: %s", strerror(-r));
                goto fail;
        }
        /* Blocked from here on: threads the daemon starts later inherit the mask. */
        if ((r = evloop_add_signal(s->loop, SIGTERM, service_on_stop, s)) < 0 ||
            (r = evloop_add_signal(s->loop, SIGINT, service_on_stop, s)) < 0 ||
            (r = evloop_add_signal(s->loop, SIGHUP, service_on_reload, s)) < 0) {
                log_msg(LOG_PRIO_ERR, "signals: %s", strerror(-r));
                goto fail;
        }
        r = service_watchdog_start(s);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "watchdog: %s", strerror(-r));
                goto fail;
        }
        *ret_service = s;
        return 0;

fail:
        service_free(s);
        return r;
}

struct service *service_free(struct service *s)
{
        if (!s)
                return NULL;
        if (s->loop)
                evloop_timer_cancel(&s->watchdog);
        s->notify = notify_free(s->notify);
        s->loop = evloop_free(s->loop);
        if (s->clean)
                log_notice("stopped");
        free(s);
        return NULL;
}

struct evloop *service_loop(struct service *s)
{
        return s->loop;
}

struct notify *service_notify(struct service *s)
{
        return s->notify;
}

int service_run(struct service *s)
{
        int r = evloop_run(s->loop);

        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "event loop: %s", strerror(-r));
                return SERVICE_EXIT_FAILURE;
        }
        s->clean = r == SERVICE_EXIT_OK;
        return r;
}

void service_exit(struct service *s, int code)
{
        evloop_exit(s->loop, code);
}

bool service_stopping(const struct service *s)
{
        return s->stopping;
}

/* Remembers text as the last status; whether it changed. */
static bool service_status_set(struct service *s, const char *text)
{
        if (strncmp(text, s->status, sizeof(s->status) - 1) == 0)
                return false;
        snprintf(s->status, sizeof(s->status), "%s", text);
        return true;
}

int service_ready(struct service *s, const char *text)
{
        char msg[NOTIFY_MESSAGE_MAX];
        bool changed;

        if (!text) {
                notify_ready(s->notify);
                return 0;
        }
        changed = service_status_set(s, text);
        snprintf(msg, sizeof(msg), "READY=1\nSTATUS=%s", s->status);
        /* One line of status: a newline would start another assignment. */
        for (char *p = msg + strlen("READY=1\n"); *p; p++)
                if (*p == '\n' || *p == '\r')
                        *p = ' ';
        notify_send(s->notify, msg);
        service_notify_check(s);
        return changed;
}

int service_status(struct service *s, const char *text)
{
        if (!service_status_set(s, text))
                return 0;
        notify_status(s->notify, "%s", s->status);
        service_notify_check(s);
        return 1;
}
