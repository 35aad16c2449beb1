/*
 * The event cursor on disk (see bridge_cursor.h).
 */
#include "mqtt/bridge_cursor.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <libgen.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "svc/io.h"

#define CURSOR_MAGIC            "sharedlink-mqtt-cursor 1"
#define CURSOR_LINE_MAX         128
#define CURSOR_PATH_MAX         512
#define CURSOR_TMP_SUFFIX       ".tmp"

int bridge_cursor_load(const char *path, struct bridge_cursor *ret)
{
        char line[CURSOR_LINE_MAX], magic[CURSOR_LINE_MAX], tail;
        struct bridge_cursor c;
        unsigned version;
        ssize_t n;
        int fd = open(path, O_RDONLY | O_CLOEXEC);

        if (fd < 0)
                return -errno;
        n = read(fd, line, sizeof(line) - 1);
        close(fd);
        if (n < 0)
                return -errno;
        line[n] = '\0';
        if (strlen(line) != (size_t)n || n == 0 || line[n - 1] != '\n')
                return -EBADMSG;
        if (sscanf(line, "%22s %u %" SCNx64 " %" SCNu64 " %" SCNu64 "%c", magic, &version,
                   &c.epoch, &c.cursor, &c.seq, &tail) != 6 || tail != '\n' ||
            strncmp(line, CURSOR_MAGIC " ", strlen(CURSOR_MAGIC) + 1) != 0)
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

int bridge_cursor_store(const char *path, const struct bridge_cursor *c, bool sync)
{
        char tmp[CURSOR_PATH_MAX], line[CURSOR_LINE_MAX];
        int fd, r, n;

        if ((size_t)snprintf(tmp, sizeof(tmp), "%s" CURSOR_TMP_SUFFIX, path) >= sizeof(tmp))
                return -ENAMETOOLONG;
        n = snprintf(line, sizeof(line), CURSOR_MAGIC " %016" PRIx64 " %" PRIu64 " %" PRIu64 "\n",
                     c->epoch, c->cursor, c->seq);
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
