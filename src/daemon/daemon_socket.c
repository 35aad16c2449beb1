/*
 * The runtime directory and the control socket (daemon_socket.h).
 */
#include "daemon/daemon_socket.h"

#include <errno.h>
#include <string.h>

#include "svc/io.h"
#include "svc/log.h"

int daemon_socket_open(struct evloop *loop, const struct daemon_plan *plan, control_request_fn fn,
                       void *arg, struct control **ret_control)
{
        int r = io_mkdir_parents(plan->runtime_dir, DAEMON_RUNTIME_DIR_MODE);

        if (r < 0) {
                log_warnx("runtime directory %s: %s", plan->runtime_dir, strerror(-r));
                return r;
        }
        r = control_new(loop, plan->socket_path, plan->gid, plan->has_group, fn, arg,
                        ret_control);
        if (r < 0) {
                log_warnx("control socket %s: %s%s", plan->socket_path, strerror(-r),
                          r == -EADDRINUSE ? " (another daemon answers on it)" : "");
                return r;
        }
        log_info("control socket %s", plan->socket_path);
        return 0;
}
