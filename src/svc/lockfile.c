/*
 * One holder at a time (see lockfile.h).
 */
#include "svc/lockfile.h"

#include <errno.h>
#include <fcntl.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <sharedlink.h>

#include "svc/io.h"
#include "svc/log.h"

#define FNV_OFFSET      UINT64_C(0xcbf29ce484222325)    /* FNV-1a, 64 bits */
#define FNV_PRIME       UINT64_C(0x100000001b3)

void lockfile_init(struct lockfile *l)
{
        l->fd = -1;
        l->path[0] = '\0';
}

static int name_kept(unsigned char c)
{
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
               c == '_' || c == '-';
}

/* Appends part to name (len bytes so far), each byte that name_kept refuses as %XX when escape,
 * within size (NUL-terminated); returns the length the whole would have, so that a cut is seen. */
static size_t name_add(char *name, size_t size, size_t len, const char *part, bool escape)
{
        static const char hex[] = "0123456789ABCDEF";

        for (const unsigned char *p = (const unsigned char *)part; *p; p++) {
                char esc[3] = { '%', hex[*p >> 4], hex[*p & 0xf] };
                bool as_is = !escape || name_kept(*p);

                for (size_t i = 0; i < (as_is ? 1u : sizeof(esc)); i++, len++)
                        if (len + 1 < size)
                                name[len] = as_is ? (char)*p : esc[i];
        }
        name[len + 1 < size ? len : size - 1] = '\0';
        return len;
}

int lockfile_name(struct lockfile *l, const char *dir, const char *const *parts, size_t n_parts)
{
        /* Room for the whole escaped name, to hash it when it is cut. */
        char name[LOCKFILE_PATH_MAX];
        size_t len = 0, keep = LOCKFILE_NAME_MAX - strlen(LOCKFILE_SUFFIX);
        uint64_t hash = FNV_OFFSET;
        int n;

        name[0] = '\0';
        for (size_t i = 0; i < n_parts; i++) {
                if (i)
                        len = name_add(name, sizeof(name), len, ".", false);
                len = name_add(name, sizeof(name), len, parts[i], true);
        }
        if (len >= sizeof(name))
                return -ENAMETOOLONG;
        if (len > keep) {
                for (size_t i = 0; i < len; i++)
                        hash = (hash ^ (unsigned char)name[i]) * FNV_PRIME;
                snprintf(name + keep - LOCKFILE_HASH_LEN - 1, LOCKFILE_HASH_LEN + 2, "~%0*llx",
                         LOCKFILE_HASH_LEN, (unsigned long long)hash);
        }
        n = snprintf(l->path, sizeof(l->path), "%s/%s%s", dir, name, LOCKFILE_SUFFIX);
        if (n < 0 || (size_t)n >= sizeof(l->path)) {
                l->path[0] = '\0';
                return -ENAMETOOLONG;
        }
        return 0;
}

/* Opens the file, making it (and its directory) when missing: read access is all a lock needs. */
static int lockfile_open(const char *path)
{
        char dir[LOCKFILE_PATH_MAX];
        char *slash;
        int fd, r;

        for (int tries = 0; tries < 2; tries++) {
                /* Made here: LOCKFILE_MODE whatever the umask (see lockfile.h). */
                fd = open(path, O_RDONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC,
                          LOCKFILE_MODE);
                if (fd >= 0) {
                        if (fchmod(fd, LOCKFILE_MODE) < 0) {
                                r = -errno;
                                close(fd);
                                return r;
                        }
                        return fd;
                }
                /* There already (without O_CREAT, which a sticky directory may refuse on a
                 * file of another user); gone again by now only if someone removed it. */
                if (errno == EEXIST) {
                        fd = open(path, O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
                        if (fd >= 0 || errno != ENOENT)
                                return fd >= 0 ? fd : -errno;
                        continue;
                }
                if (errno != ENOENT || tries > 0)
                        return -errno;
                snprintf(dir, sizeof(dir), "%s", path);
                slash = strrchr(dir, '/');
                if (!slash || slash == dir)
                        return -ENOENT;
                *slash = '\0';
                r = io_mkdir_parents(dir, LOCKFILE_DIR_MODE);
                if (r < 0)
                        return r;
        }
        return -ENOENT;
}

/* The pid of a process that holds a POSIX lock on fd's file, 0 when none or unknown. */
static pid_t lockfile_holder(int fd)
{
        struct flock fl = { .l_type = F_WRLCK, .l_whence = SEEK_SET, .l_start = 0, .l_len = 0 };

        if (fcntl(fd, F_GETLK, &fl) < 0 || fl.l_type == F_UNLCK || fl.l_pid < 0)
                return 0;
        return fl.l_pid;
}

int lockfile_take(struct lockfile *l, pid_t *ret_holder)
{
        struct flock fl = { .l_type = F_RDLCK, .l_whence = SEEK_SET, .l_start = 0, .l_len = 0 };
        int fd, r;

        if (l->fd >= 0)
                return 0;
        if (!l->path[0])
                return -EINVAL;
        fd = lockfile_open(l->path);
        if (fd < 0)
                return fd;
        if (flock(fd, LOCK_EX | LOCK_NB) < 0) {
                r = errno == EWOULDBLOCK ? -EBUSY : -errno;
                if (r == -EBUSY && ret_holder)
                        *ret_holder = lockfile_holder(fd);
                close(fd);
                return r;
        }
        /* Only to be found (lockfile_holder): the flock is the lock. A failure here costs the
         * next one's message the pid, nothing else. POSIX locks end at the first close() of any
         * fd of the file by this process: nothing but this module opens it. */
        (void)fcntl(fd, F_SETLK, &fl);
        l->fd = fd;
        return 0;
}

int lockfile_take_service(struct lockfile *l, const char *program, const char *what,
                          const char *const *parts, size_t n_parts)
{
        const char *dir = getenv(LOCKFILE_DIR_ENV);
        pid_t holder = 0;
        int r;

        if (!dir || dir[0] != '/')
                dir = SL_RUNTIME_DIR_DEFAULT;
        r = lockfile_name(l, dir, parts, n_parts);
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "lock file in %s: %s", dir, strerror(-r));
                return r;
        }
        r = lockfile_take(l, &holder);
        if (r == -EBUSY && holder > 0)
                log_msg(LOG_PRIO_ERR, "another %s (pid %ld) already %s (lock %s): not starting "
                        "a second one", program, (long)holder, what, l->path);
        else if (r == -EBUSY)
                log_msg(LOG_PRIO_ERR, "another %s already %s (lock %s, its pid unknown: starting, "
                        "stopping or in another pid namespace): not starting a second one",
                        program, what, l->path);
        else if (r < 0)
                log_msg(LOG_PRIO_ERR, "lock %s: %s", l->path, strerror(-r));
        return r;
}

void lockfile_release(struct lockfile *l)
{
        if (l->fd >= 0)
                close(l->fd);
        l->fd = -1;
}
