/*
 * The runtime directory and the control socket (daemon_socket.h).
 */
#include "daemon/daemon_socket.h"

#include <errno.h>
#include <string.h>
#include <sys/stat.h>

#include "svc/log.h"

/* mkdir -p with mode for the directories it creates (not subject to the umask). */
static int mkdir_parents(const char *path, mode_t mode)
{
        char buf[CONFIG_PATH_MAX];
        struct stat st;

        if (strlen(path) >= sizeof(buf))
                return -ENAMETOOLONG;
        strcpy(buf, path);
        for (char *p = buf + 1;; p++) {
                char c = *p;

                if (c != '/' && c != '\0')
                        continue;
                *p = '\0';
                if (mkdir(buf, mode) == 0) {
                        if (chmod(buf, mode) < 0)
                                return -errno;
                } else if (errno != EEXIST) {
                        return -errno;
                }
                *p = c;
                if (!c)
                        break;
        }
        if (stat(path, &st) < 0)
                return -errno;
        return S_ISDIR(st.st_mode) ? 0 : -ENOTDIR;
}

int daemon_socket_open(struct evloop *loop, const struct daemon_plan *plan, control_request_fn fn,
                       void *arg, struct control **ret_control)
{
        int r = mkdir_parents(plan->runtime_dir, DAEMON_RUNTIME_DIR_MODE);

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
