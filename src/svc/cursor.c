/*
 * The event cursor on disk (see cursor.h).
 */
#include "svc/cursor.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <libgen.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "svc/io.h"

#define CURSOR_MAGIC_FMT        "%s-cursor 1 "  /* owner; then epoch, cursor, seq */
#define CURSOR_OWNER_MAX        64
#define CURSOR_LINE_MAX         128
#define CURSOR_PATH_MAX         512
#define CURSOR_TMP_SUFFIX       ".tmp"

int cursor_load(const char *path, const char *owner, struct cursor *ret)
{
        char line[CURSOR_LINE_MAX], magic[CURSOR_OWNER_MAX + sizeof(CURSOR_MAGIC_FMT)], tail;
        struct cursor c;
        size_t mlen;
        ssize_t n;
        int fd;

        mlen = (size_t)snprintf(magic, sizeof(magic), CURSOR_MAGIC_FMT, owner);
        if (mlen >= sizeof(magic))
                return -ENAMETOOLONG;
        fd = open(path, O_RDONLY | O_CLOEXEC);

        if (fd < 0)
                return -errno;
        n = read(fd, line, sizeof(line) - 1);
        close(fd);
        if (n < 0)
                return -errno;
        line[n] = '\0';
        if (strlen(line) != (size_t)n || n == 0 || line[n - 1] != '\n')
                return -EBADMSG;
        if (strncmp(line, magic, mlen) != 0 ||
            sscanf(line + mlen, "%" SCNx64 " %" SCNu64 " %" SCNu64 "%c", &c.epoch, &c.cursor,
                   &c.seq, &tail) != 4 || tail != '\n')
                return -EBADMSG;
        *ret = c;
        return 0;
}

static int sync_dir(const char *path)
{
        char copy[CURSOR_PATH_MAX];
        int fd, r = 0;

        snprintf(copy, sizeof(copy), "%s", path);
        fd = open(dirname(copy), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (fd < 0)
                return -errno;
        if (fsync(fd) < 0)
                r = -errno;
        close(fd);
        return r;
}

int cursor_store(const char *path, const char *owner, const struct cursor *c, bool sync)
{
        char tmp[CURSOR_PATH_MAX], line[CURSOR_LINE_MAX], magic[CURSOR_OWNER_MAX +
                                                              sizeof(CURSOR_MAGIC_FMT)];
        int fd, r, n;

        if ((size_t)snprintf(tmp, sizeof(tmp), "%s" CURSOR_TMP_SUFFIX, path) >= sizeof(tmp))
                return -ENAMETOOLONG;
        if ((size_t)snprintf(magic, sizeof(magic), CURSOR_MAGIC_FMT, owner) >= sizeof(magic))
                return -ENAMETOOLONG;
        n = snprintf(line, sizeof(line), "%s%016" PRIx64 " %" PRIu64 " %" PRIu64 "\n", magic,
                     c->epoch, c->cursor, c->seq);
        if (n < 0 || (size_t)n >= sizeof(line))
                return -ENAMETOOLONG;
        fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (fd < 0)
                return -errno;
        r = io_write_all(fd, line, (size_t)n);
        if (r == 0 && sync && fsync(fd) < 0)
                r = -errno;
        if (close(fd) < 0 && r == 0)
                r = -errno;
        if (r == 0 && rename(tmp, path) < 0)
                r = -errno;
        if (r < 0) {
                unlink(tmp);
                return r;
        }
        return sync ? sync_dir(path) : 0;
}
