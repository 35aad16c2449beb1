/*
 * The sharedlinkd instance: one configuration in force, its shm tables, its control socket and
 * its links, on one event loop (DESIGN.md §2.2).
 *
 * Start, in this order (teardown in exact reverse):
 *   config -> shm tables (every link's declared variables, group from the config)
 *          -> control socket <runtime_dir>/<instance>.sock (runtime_dir made 0755 if missing)
 *          -> links (ops->create for each; one that cannot start is reported, never fatal)
 *          -> outbound wake fd on the loop -> heartbeat timer -> STATUS, READY=1 (the service
 *          has the loop, the signals and the watchdog: svc/service.h)
 *
 * runtime_dir: the config's when the file sets it; otherwise $SHAREDLINK_RUNTIME_DIR when set
 * (absolute), else the default /run/sharedlink. Tests and unprivileged runs use the variable.
 *
 * Reload (SIGHUP, daemon_reload; the service sent RELOADING=1): the file is read and checked
 * as at start; a bad one keeps the running configuration untouched (an error is logged). Then:
 *   - the tables are kept when the variables every link declares (names, directions, types,
 *     peers, positions), the link names and protocols, the instance and the group are all
 *     unchanged: only the links whose settings changed (config_link_equal) are stopped and
 *     started again; the others keep running untouched, with their channel and counters;
 *   - otherwise (a variable list changed, a link was added, removed, renamed or moved, the
 *     instance or group changed) every link is stopped, both tables are recreated with a new
 *     epoch (clients notice it and remap transparently; ad hoc variables are declared again by
 *     the engines as they meet them), and every link starts again;
 *   - the control socket is recreated only when its path or group changed.
 * Then STATUS and READY=1 again.
 */
#ifndef SHAREDLINK_DAEMON_DAEMON_H
#define SHAREDLINK_DAEMON_DAEMON_H

#include <stddef.h>

#include "daemon/config.h"
#include "daemon/daemon_plan.h"        /* DAEMON_ERROR_MAX */
#include "svc/service.h"

struct daemon;

/*
 * Checks what the parser cannot: an engine for every link's protocol in this build, the group
 * exists, every link's declaration works, the socket path fits, every replay link's recording
 * reads ("FILE:LINE: message" for a broken line). 0, or -errno with a one-line message in err
 * that starts with where, as the parser's do: "PATH:LINE:COL: group \"x\" does not exist",
 * "PATH: link x: protocol circe not available in this build".
 */
#define DAEMON_WHERE_MAX        (CONFIG_PATH_MAX + 24)  /* "<path>:<line>:<col>" + NUL */

int daemon_check_config(const struct config *config, const char *path, char *err,
                        size_t errsz);

/*
 * Starts an instance on the service's loop from config (taken over: freed on failure too);
 * config_path is read again by daemon_reload(). Sends STATUS= and READY=1 through the service.
 * 0 or -errno (logged). It starts a thread (the outbound wake): the service blocked the signals.
 */
int daemon_new(struct service *svc, const char *config_path, struct config *config,
               struct daemon **ret_daemon);

/* Reloads the configuration file (see above). Never stops the daemon for a bad file; returns 0,
 * or -errno when the new configuration was refused or could not be applied. */
int daemon_reload(struct daemon *d);

/* Stops every link, removes the socket and unlinks the tables, in reverse start order. NULL ok;
 * returns NULL. */
struct daemon *daemon_free(struct daemon *d);

#endif
