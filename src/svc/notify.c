/*
 * Service manager notifications (see notify.h).
 */
#include "svc/notify.h"

#include <errno.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#if HAVE_LIBSYSTEMD
#include <systemd/sd-daemon.h>
#endif

#define NOTIFY_USEC_PER_SEC     1000000ull
#define NOTIFY_NSEC_PER_USEC    1000ull
#define NOTIFY_USEC_PER_MSEC    1000ull
#define NOTIFY_MSEC_PER_SEC     1000u

struct notify {
        bool enabled;
        char socket_path[sizeof(((struct sockaddr_un *)NULL)->sun_path) + 1];
        uint64_t watchdog_usec;
        uint64_t failed;                /* messages not sent (notify_failed) */
};

/* WATCHDOG_USEC, honoured only when WATCHDOG_PID is unset or ours (as sd_watchdog_enabled()). */
static uint64_t notify_read_watchdog(void)
{
#if HAVE_LIBSYSTEMD
        uint64_t usec = 0;

        return sd_watchdog_enabled(0, &usec) > 0 ? usec : 0;
#else
        const char *s = getenv("WATCHDOG_USEC"), *pid = getenv("WATCHDOG_PID");
        unsigned long long v;
        char *end;

        if (!s || !*s)
                return 0;
        if (pid && *pid) {
                errno = 0;
                v = strtoull(pid, &end, 10);
                if (errno || *end || v != (unsigned long long)getpid())
                        return 0;
        }
        errno = 0;
        v = strtoull(s, &end, 10);
        if (errno || *end || s[0] == '-')
                return 0;
        return v;
#endif
}

int notify_new(struct notify **ret_notify)
{
        struct notify *n = calloc(1, sizeof(*n));
        const char *path = getenv("NOTIFY_SOCKET");

        if (!n)
                return -ENOMEM;
        if (path && *path && strlen(path) < sizeof(n->socket_path)) {
                strcpy(n->socket_path, path);
                n->enabled = true;
        }
        n->watchdog_usec = n->enabled ? notify_read_watchdog() : 0;
        *ret_notify = n;
        return 0;
}

struct notify *notify_free(struct notify *n)
{
        free(n);
        return NULL;
}

bool notify_enabled(const struct notify *n)
{
        return n && n->enabled;
}

int notify_send_datagram(const char *path, const char *text, unsigned wait_ms)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        struct timeval tv = {
                .tv_sec = wait_ms / NOTIFY_MSEC_PER_SEC,
                .tv_usec = (wait_ms % NOTIFY_MSEC_PER_SEC) * NOTIFY_USEC_PER_MSEC,
        };
        size_t len = strlen(path);
        socklen_t salen;
        ssize_t r;
        int fd;

        if (len == 0 || len > sizeof(sa.sun_path))
                return -EINVAL;
        if (path[0] != '/' && path[0] != '@')
                return -EAFNOSUPPORT;
        memcpy(sa.sun_path, path, len);
        /* Abstract names start with a NUL and have an exact length, no terminator. */
        if (path[0] == '@')
                sa.sun_path[0] = '\0';
        salen = (socklen_t)(offsetof(struct sockaddr_un, sun_path) + len);
        fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        if (fd < 0)
                return -errno;
        /* A datagram to a receiver whose queue is full waits for room: bounded by wait_ms, or
         * not at all. */
        if (wait_ms && setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof(tv)) < 0) {
                r = -errno;
                close(fd);
                return (int)r;
        }
        do {
                r = sendto(fd, text, strlen(text),
                           MSG_NOSIGNAL | (wait_ms ? 0 : MSG_DONTWAIT),
                           (const struct sockaddr *)&sa, salen);
        } while (r < 0 && errno == EINTR);
        if (r < 0)
                r = errno == EWOULDBLOCK ? -EAGAIN : -errno;
        close(fd);
        return r < 0 ? (int)r : 1;
}

/* Every message goes through here, in both builds: sd_notify() would wait without bound for a
 * manager that does not read its socket, and the loop that sends must not. */
static int notify_send_wait(struct notify *n, const char *assignments, unsigned wait_ms)
{
        int r;

        if (!notify_enabled(n))
                return 0;
        r = notify_send_datagram(n->socket_path, assignments, wait_ms);
        if (r < 0)
                n->failed++;
        return r;
}

int notify_send(struct notify *n, const char *assignments)
{
        return notify_send_wait(n, assignments, NOTIFY_ONCE_WAIT_MS);
}

uint64_t notify_failed(const struct notify *n)
{
        return n ? n->failed : 0;
}

int notify_ready(struct notify *n)
{
        return notify_send(n, "READY=1");
}

int notify_status(struct notify *n, const char *fmt, ...)
{
        char msg[sizeof("STATUS=") + NOTIFY_STATUS_MAX];
        va_list ap;

        if (!notify_enabled(n))
                return 0;
        strcpy(msg, "STATUS=");
        va_start(ap, fmt);
        vsnprintf(msg + strlen("STATUS="), NOTIFY_STATUS_MAX, fmt, ap);
        va_end(ap);
        /* One line: a newline would start another assignment (e.g. a forged READY=1). */
        for (char *p = msg; *p; p++)
                if (*p == '\n' || *p == '\r')
                        *p = ' ';
        return notify_send_wait(n, msg, 0);
}

int notify_watchdog(struct notify *n)
{
        return notify_send_wait(n, "WATCHDOG=1", 0);
}

int notify_reloading(struct notify *n)
{
        char msg[NOTIFY_MESSAGE_MAX];
        struct timespec ts;

        if (!notify_enabled(n))
                return 0;
        /* MONOTONIC_USEC lets systemd (Type=notify-reload, v253+) match the reload request;
         * older versions ignore it. */
        clock_gettime(CLOCK_MONOTONIC, &ts);
        snprintf(msg, sizeof(msg), "RELOADING=1\nMONOTONIC_USEC=%llu",
                 (unsigned long long)ts.tv_sec * NOTIFY_USEC_PER_SEC +
                 (unsigned long long)ts.tv_nsec / NOTIFY_NSEC_PER_USEC);
        return notify_send(n, msg);
}

int notify_stopping(struct notify *n)
{
        return notify_send(n, "STOPPING=1");
}

uint64_t notify_watchdog_usec(const struct notify *n)
{
        return n ? n->watchdog_usec : 0;
}

uint64_t notify_watchdog_interval_ms(const struct notify *n)
{
        uint64_t usec = notify_watchdog_usec(n);

        if (usec == 0)
                return 0;
        usec /= 2;
        return usec < NOTIFY_USEC_PER_MSEC ? 1 : usec / NOTIFY_USEC_PER_MSEC;
}
