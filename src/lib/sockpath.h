/*
 * Where a handle's control socket is: a runtime directory chosen by the program
 * (sl_set_runtime_dir), by $SHAREDLINK_RUNTIME_DIR, or the default, and the path the daemon
 * publishes in its tables (layout 1.2). State of its own, apart from the handle, so that opening
 * a handle (client.c) and sending a request (request.c) both use it and neither calls the other.
 */
#ifndef SL_SOCKPATH_H
#define SL_SOCKPATH_H

#include <stddef.h>
#include <sys/un.h>

struct shm_in_header;

#define SOCKPATH_DIR_SIZE       108     /* sizeof(sun_path): the socket path must fit it anyway */

struct sockpath {
        char dir[SOCKPATH_DIR_SIZE];    /* "": error says why */
        int error;
        int chosen;                     /* 1: set or from the environment, not the default, so
                                         * the path the header publishes does not apply */
};

/* dir as the runtime directory of instance's socket (chosen). 0 or -ENAMETOOLONG. */
int sockpath_set(struct sockpath *sp, const char *instance, const char *dir);

/* $SHAREDLINK_RUNTIME_DIR (chosen), else SL_RUNTIME_DIR_DEFAULT. 0 or -ENAMETOOLONG. */
int sockpath_default(struct sockpath *sp, const char *instance);

/*
 * The socket address of instance's daemon: a directory set or in the environment wins; else the
 * path header h publishes (h may be NULL); else the default directory. 0 or -ENAMETOOLONG.
 */
int sockpath_address(const struct sockpath *sp, const struct shm_in_header *h,
                     const char *instance, struct sockaddr_un *ret_sa);

/*
 * The control socket path that header h publishes (layout 1.2), checked as hostile input: a NUL
 * within the field, an absolute path naming "<instance>.sock", no control byte. Copies it into
 * buf (size >= SHM_SOCKET_PATH_SIZE) and returns 0; -ENOENT when h publishes none (an older
 * daemon), -EINVAL when the field is not such a path.
 */
int sockpath_published(const struct shm_in_header *h, const char *instance, char *buf,
                       size_t size);

#endif
