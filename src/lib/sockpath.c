/*
 * Where the control socket is (sockpath.h).
 */
#include "lib/sockpath.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#include <sharedlink.h>

#include "shm/layout.h"

#define SOCKPATH_ENV            "SHAREDLINK_RUNTIME_DIR"
#define SOCKPATH_SUFFIX         ".sock"

static int store(struct sockpath *sp, const char *instance, const char *dir)
{
        size_t need = strlen(dir) + 1u + strlen(instance) + sizeof(SOCKPATH_SUFFIX);

        if (need > sizeof(((struct sockaddr_un *)0)->sun_path) || strlen(dir) >= sizeof(sp->dir)) {
                sp->dir[0] = '\0';
                sp->error = -ENAMETOOLONG;
                return -ENAMETOOLONG;
        }
        strcpy(sp->dir, dir);
        sp->error = 0;
        return 0;
}

int sockpath_set(struct sockpath *sp, const char *instance, const char *dir)
{
        sp->chosen = 1;
        return store(sp, instance, dir);
}

int sockpath_default(struct sockpath *sp, const char *instance)
{
        const char *env = getenv(SOCKPATH_ENV);

        sp->chosen = env && *env;
        return store(sp, instance, sp->chosen ? env : SL_RUNTIME_DIR_DEFAULT);
}

int sockpath_published(const struct shm_in_header *h, const char *instance, char *buf,
                       size_t size)
{
        char path[SHM_SOCKET_PATH_SIZE];
        char want[SHM_INSTANCE_MAX + sizeof(SOCKPATH_SUFFIX) + 1];        /* "/NAME.sock" */
        size_t len, tail;

        if ((h->layout_version & 0xffffu) < SHM_LAYOUT_MINOR_SOCKET || !h->control_socket[0])
                return -ENOENT;         /* an older daemon: reserved bytes, not a path */
        /* One copy, checked and used: the object is not ours, its bytes may change meanwhile. */
        memcpy(path, h->control_socket, sizeof(path));
        len = strnlen(path, sizeof(path));
        tail = (size_t)snprintf(want, sizeof(want), "/%s%s", instance, SOCKPATH_SUFFIX);
        if (len == sizeof(path) || len >= size || path[0] != '/' || len <= tail ||
            strcmp(path + len - tail, want) != 0)
                return -EINVAL;
        for (size_t i = 0; i < len; i++)        /* ASCII controls: no path of ours has them */
                if ((unsigned char)path[i] < 0x20 || path[i] == 0x7f)
                        return -EINVAL;
        memcpy(buf, path, len + 1);
        return 0;
}

int sockpath_address(const struct sockpath *sp, const struct shm_in_header *h,
                     const char *instance, struct sockaddr_un *ret_sa)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        int n;

        _Static_assert(sizeof(sa.sun_path) >= SHM_SOCKET_PATH_SIZE, "published socket path");
        if (!sp->chosen && h &&
            sockpath_published(h, instance, sa.sun_path, sizeof(sa.sun_path)) == 0) {
                *ret_sa = sa;
                return 0;
        }
        if (sp->error < 0)
                return sp->error;
        n = snprintf(sa.sun_path, sizeof(sa.sun_path), "%s/%s%s", sp->dir, instance,
                     SOCKPATH_SUFFIX);
        if (n < 0 || (size_t)n >= sizeof(sa.sun_path))
                return -ENAMETOOLONG;   /* not reached: store() checked it */
        *ret_sa = sa;
        return 0;
}
