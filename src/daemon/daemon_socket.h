/*
 * The instance's control socket <runtime_dir>/<instance>.sock (control.h), opened from a plan:
 * the runtime directory is made (DAEMON_RUNTIME_DIR_MODE, parents too) when missing.
 */
#ifndef SHAREDLINK_DAEMON_DAEMON_SOCKET_H
#define SHAREDLINK_DAEMON_DAEMON_SOCKET_H

#include "daemon/control.h"
#include "daemon/daemon_plan.h"
#include "daemon/evloop.h"

#define DAEMON_RUNTIME_DIR_MODE 0755

/* Makes plan's runtime directory and serves plan's socket path (group, if any) on loop, every
 * request to fn with arg. 0 or -errno (logged; -EADDRINUSE: another daemon answers on it). */
int daemon_socket_open(struct evloop *loop, const struct daemon_plan *plan, control_request_fn fn,
                       void *arg, struct control **ret_control);

#endif
