/*
 * sharedlinkd: command line, then init in a fixed order (log, config, loop, notify, signals,
 * instance), run, teardown in exact reverse. See daemon.h for what the instance does.
 *
 *   sharedlinkd [-c FILE] [-n] [-v] [-V]
 *
 * Always in the foreground, logging to stderr with <N> priority prefixes (journald). Exit
 * status: 0 after a clean stop (SIGTERM, SIGINT) or a good -n check, 1 on a bad configuration or
 * a failed start, 2 on a usage error.
 */
#include <signal.h>
#include <stdio.h>
#include <string.h>

#include "daemon/config.h"
#include "daemon/daemon.h"
#include "daemon/evloop.h"
#include "svc/log.h"
#include "svc/notify.h"
#include "svc/service.h"

#define MAIN_CONFIG_DEFAULT     "/etc/sharedlink/sharedlinkd.yaml"

struct main_ctx {
        struct daemon *daemon;
        struct notify *notify;
};

static void on_stop(struct evloop *loop, int signo, void *arg)
{
        struct main_ctx *ctx = arg;

        log_notice("%s: stopping", strsignal(signo));
        notify_stopping(ctx->notify);
        evloop_exit(loop, 0);
}

static void on_reload(struct evloop *loop, int signo, void *arg)
{
        struct main_ctx *ctx = arg;

        (void)loop;
        (void)signo;
        daemon_reload(ctx->daemon);
}

/* -n: what the parser and daemon_check_config() say; nothing is created. */
static int check_only(const char *path)
{
        char err[DAEMON_ERROR_MAX];
        struct config_error cerr;
        struct config *config;
        int r;

        r = config_load_file(path, &config, &cerr);
        if (r < 0) {
                fprintf(stderr, "%s\n", cerr.message);
                return 1;
        }
        r = daemon_check_config(config, err, sizeof(err));
        config_free(config);
        if (r < 0) {
                fprintf(stderr, "%s: %s\n", path, err);
                return 1;
        }
        return service_check_ok();
}

int main(int argc, char **argv)
{
        static const struct service_desc desc = {
                .name = "sharedlinkd", .version = SHAREDLINK_VERSION,
                .config_default = MAIN_CONFIG_DEFAULT, .check = check_only,
        };
        struct service_args args;
        struct main_ctx ctx = { 0 };
        struct config_error cerr;
        struct config *config;
        struct evloop *loop = NULL;
        const char *path;
        int r, code = 1;

        r = service_args(&desc, argc, argv, &args);
        if (r != SERVICE_CONTINUE)
                return r;
        path = args.config;
        service_start(&args);
        r = config_load_file(path, &config, &cerr);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "%s", cerr.message);
                return 1;
        }
        log_notice("sharedlinkd %s starting, configuration %s", SHAREDLINK_VERSION, path);

        r = evloop_new(&loop);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "event loop: %s", strerror(-r));
                config_free(config);
                return 1;
        }
        r = notify_new(&ctx.notify);
        if (r < 0) {
                config_free(config);
                goto out_loop;
        }
        /* Signals before daemon_new(): it starts a thread, which must inherit the blocked mask. */
        if ((r = evloop_add_signal(loop, SIGTERM, on_stop, &ctx)) < 0 ||
            (r = evloop_add_signal(loop, SIGINT, on_stop, &ctx)) < 0 ||
            (r = evloop_add_signal(loop, SIGHUP, on_reload, &ctx)) < 0) {
                log_msg(LOG_PRIO_ERR, "signals: %s", strerror(-r));
                config_free(config);
                goto out_notify;
        }
        r = daemon_new(loop, ctx.notify, path, config, &ctx.daemon);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "start failed: %s", strerror(-r));
                goto out_notify;
        }
        r = evloop_run(loop);
        if (r < 0)
                log_msg(LOG_PRIO_ERR, "event loop: %s", strerror(-r));
        code = r == 0 ? 0 : 1;
        ctx.daemon = daemon_free(ctx.daemon);
        if (code == 0)
                log_notice("stopped");
out_notify:
        ctx.notify = notify_free(ctx.notify);
out_loop:
        loop = evloop_free(loop);
        return code;
}
