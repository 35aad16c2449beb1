/*
 * sharedlinkd: command line, then init in a fixed order (log, config, service: loop, notify,
 * signals, watchdog; instance), run, teardown in exact reverse. See daemon.h for what the
 * instance does, svc/service.h for the signals and the exit status.
 *
 *   sharedlinkd [-c FILE] [-n] [-v] [-V]
 *
 * Always in the foreground, logging to stderr with <N> priority prefixes (journald). Exit
 * status: 0 after a clean stop (SIGTERM, SIGINT) or a good -n check, 1 on a bad configuration or
 * a failed start, 2 on a usage error.
 */
#include <stdio.h>
#include <string.h>

#include "daemon/config.h"
#include "daemon/daemon.h"
#include "svc/log.h"
#include "svc/service.h"

#define MAIN_CONFIG_DEFAULT     "/etc/sharedlink/sharedlinkd.yaml"

static void on_reload(void *arg)
{
        struct daemon **daemon = arg;

        daemon_reload(*daemon);
}

/* -n: what the parser and daemon_check_config() say; nothing is created. */
static int check_only(const char *path)
{
        char err[DAEMON_WHERE_MAX + DAEMON_ERROR_MAX];
        struct config_error cerr;
        struct config *config;
        int r;

        r = config_load_file(path, &config, &cerr);
        if (r < 0) {
                fprintf(stderr, "%s\n", cerr.message);
                return SERVICE_EXIT_FAILURE;
        }
        r = daemon_check_config(config, path, err, sizeof(err));
        config_free(config);
        if (r < 0) {
                fprintf(stderr, "%s\n", err);
                return SERVICE_EXIT_FAILURE;
        }
        return service_check_ok();
}

int main(int argc, char **argv)
{
        static const struct service_desc desc = {
                .name = "sharedlinkd", .version = SHAREDLINK_VERSION,
                .config_default = MAIN_CONFIG_DEFAULT, .check = check_only,
        };
        static const struct service_ops ops = { .reload = on_reload };
        struct service_args args;
        struct config_error cerr;
        struct config *config;
        struct daemon *daemon = NULL;
        struct service *svc;
        int r;

        r = service_args(&desc, argc, argv, &args);
        if (r != SERVICE_CONTINUE)
                return r;
        service_start(&args);
        r = config_load_file(args.config, &config, &cerr);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "%s", cerr.message);
                return SERVICE_EXIT_FAILURE;
        }
        log_notice("sharedlinkd %s starting, configuration %s", SHAREDLINK_VERSION, args.config);
        if (service_new(&desc, &ops, &daemon, &svc) < 0) {
                config_free(config);
                return SERVICE_EXIT_FAILURE;
        }
        r = daemon_new(svc, args.config, config, &daemon);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "start failed: %s", strerror(-r));
                service_free(svc);
                return SERVICE_EXIT_FAILURE;
        }
        r = service_run(svc);
        daemon = daemon_free(daemon);
        service_free(svc);
        return r;
}
