/*
 * The command line and start of every daemon (see service.h).
 */
#include "svc/service.h"

#include <signal.h>
#include <stdio.h>
#include <unistd.h>

#include "svc/log.h"

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
