/*
 * The instance's state, shared by the files that serve it and nothing outside them:
 *
 * daemon.c             start, stop and reload: the order of everything below (daemon.h)
 * daemon_out.c         outbound routing: client writes -> the engine of the variable's link
 * daemon_status.c      STATUS=, the heartbeat (shm, engines, recorders), the watchdog
 * daemon_request.c     control requests the core answers, and routing to the engines
 *
 * They build on modules that know nothing of struct daemon: daemon_config.h (reference-counted
 * configurations), daemon_plan.h (config -> plan), daemon_tables.h (the shm tables),
 * daemon_socket.h (runtime directory, control socket), daemon_link.h (one link's lifecycle).
 */
#ifndef SHAREDLINK_DAEMON_DAEMON_INTERNAL_H
#define SHAREDLINK_DAEMON_DAEMON_INTERNAL_H

#include <stdint.h>

#include "daemon/config.h"
#include "daemon/daemon_config.h"
#include "daemon/daemon_link.h"
#include "daemon/daemon_plan.h"
#include "daemon/evloop.h"
#include "daemon/recorder.h"
#include "daemon/stages.h"
#include "svc/log.h"
#include "svc/notify.h"

struct control;
struct shm_table;

struct daemon {
        struct evloop *loop;
        struct notify *notify;
        char *config_path;
        struct daemon_config *dc;       /* in force */
        struct daemon_plan plan;        /* of dc */
        struct shm_table *table;
        struct control *control;
        struct daemon_link *links[CONFIG_LINKS_MAX];
        unsigned n_links;
        int wake_fd;                    /* -1 when not on the loop */
        /* The outbound path timed in here, reported by `stats`: client write -> wake thread
         * signals -> poll loop runs -> frame handed to the link. While a scan answers a wake-up,
         * wake_stamps holds its signal and poll stamps (else 0: nothing is recorded). */
        struct stages out_stages;
        uint64_t wake_stamps[2];
        struct evloop_timer heartbeat;
        struct evloop_timer watchdog;
        struct log_ratelimit out_rl;    /* outbound object trouble */
        struct recorder_stats rec_stats;        /* every link's recorders */
        char status[NOTIFY_STATUS_MAX];
};

#endif
