/*
 * Integration-test harness (see harness.h). Plain POSIX; no cmocka here so that benchmarks and
 * stress programs can use it too.
 */
#define _GNU_SOURCE   /* pipe2 */
#include "common/harness.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#define HARNESS_POLL_SLICE_MS 20
#define HARNESS_ARGV_MAX 32

uint64_t harness_now_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

static int remaining_ms(uint64_t deadline_ns)
{
        uint64_t now = harness_now_ns();

        if (now >= deadline_ns)
                return 0;
        return (int)((deadline_ns - now + 999999) / 1000000);
}

const char *harness_daemon_path(void)
{
        static char path[HARNESS_PATH_MAX];
        const char *b = getenv("SHAREDLINK_BUILD");

        snprintf(path, sizeof(path), "%s/sharedlinkd", b ? b : "build/asan");
        return path;
}

const char *harness_slctl_path(void)
{
        static char path[HARNESS_PATH_MAX];
        const char *b = getenv("SHAREDLINK_BUILD");

        snprintf(path, sizeof(path), "%s/slctl", b ? b : "build/asan");
        return path;
}

int harness_init(struct harness *h, const char *tag)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };

        memset(h, 0, sizeof(*h));
        h->notify_fd = -1;
        snprintf(h->dir, sizeof(h->dir), "/tmp/sltest.XXXXXX");
        if (!mkdtemp(h->dir))
                return -errno;
        /* Other users (a privilege-dropped daemon or client) must reach files in here. */
        chmod(h->dir, 0755);
        snprintf(h->instance, sizeof(h->instance), "t%ld-%s", (long)getpid(), tag);
        snprintf(h->notify_path, sizeof(h->notify_path), "%s/notify.sock", h->dir);
        snprintf(h->log_path, sizeof(h->log_path), "%s/daemon.log", h->dir);

        h->notify_fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
        if (h->notify_fd < 0)
                return -errno;
        if (strlen(h->notify_path) >= sizeof(sa.sun_path))
                return -ENAMETOOLONG;
        strcpy(sa.sun_path, h->notify_path);
        if (bind(h->notify_fd, (struct sockaddr *)&sa, sizeof(sa)) < 0)
                return -errno;
        return 0;
}

static void remove_tree(const char *dir)
{
        DIR *d = opendir(dir);
        struct dirent *e;
        char p[HARNESS_PATH_MAX * 2];

        if (!d)
                return;
        while ((e = readdir(d))) {
                struct stat st;

                if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
                        continue;
                snprintf(p, sizeof(p), "%s/%s", dir, e->d_name);
                if (lstat(p, &st) == 0 && S_ISDIR(st.st_mode))
                        remove_tree(p);
                else
                        unlink(p);
        }
        closedir(d);
        rmdir(dir);
}

void harness_cleanup(struct harness *h)
{
        if (h->pid > 0 && harness_stop_daemon(h, SIGTERM, 5000) == -ETIMEDOUT)
                harness_stop_daemon(h, SIGKILL, 5000);
        if (h->notify_fd >= 0)
                close(h->notify_fd);
        h->notify_fd = -1;
        if (h->dir[0])
                remove_tree(h->dir);
        h->dir[0] = '\0';
}

int harness_write_file(struct harness *h, const char *name, const char *text, char *ret_path)
{
        char path[HARNESS_PATH_MAX];
        FILE *f;
        int r = 0;

        if ((size_t)snprintf(path, sizeof(path), "%s/%s", h->dir, name) >= sizeof(path))
                return -ENAMETOOLONG;
        f = fopen(path, "we");
        if (!f)
                return -errno;
        if (fputs(text, f) == EOF)
                r = -EIO;
        if (fclose(f) != 0 && r == 0)
                r = -errno;
        if (r == 0 && ret_path)
                strcpy(ret_path, path);
        return r;
}

int harness_start_config(struct harness *h, const char *name, const char *body, int timeout_ms,
                         char *why, size_t whysz)
{
        size_t size = strlen(body) + sizeof(h->instance) + sizeof(h->dir) + 64;
        char *text = malloc(size), path[HARNESS_PATH_MAX], tail[HARNESS_WHY_MAX] = "";
        struct stat sb;
        off_t since;
        int st = 0, r, fd;

        if (whysz)
                why[0] = '\0';
        if (!text)
                return -ENOMEM;
        snprintf(text, size, "instance: %s\nruntime_dir: %s\n%s", h->instance, h->dir, body);
        r = harness_write_file(h, name, text, path);
        free(text);
        if (r < 0) {
                if (whysz)
                        snprintf(why, whysz, "cannot write %s: %s", name, strerror(-r));
                return r;
        }
        /* The log is appended across starts: what this start wrote begins at its size now. */
        since = h->capture_log && stat(h->log_path, &sb) == 0 ? sb.st_size : 0;
        r = harness_start_daemon(h, path, timeout_ms, &st, NULL);
        if (r == 0)
                return 0;
        fd = h->capture_log ? open(h->log_path, O_RDONLY | O_CLOEXEC) : -1;
        if (fd >= 0) {
                ssize_t k = pread(fd, tail, sizeof(tail) - 1, since);

                tail[k > 0 ? (size_t)k : 0] = '\0';
                close(fd);
        }
        if (strstr(tail, "not available in this build"))
                return -ENOTSUP;
        if (whysz)
                snprintf(why, whysz, "%s (status %d)%s%s", strerror(-r), st,
                         h->capture_log ? "; log: " : "", tail);
        return r;
}

void harness_close_fd(int *fd)
{
        if (*fd >= 0)
                close(*fd);
        *fd = -1;
}

/* Reads every pending notify datagram; returns 1 once one contains needle. */
static int drain_notify(struct harness *h, const char *needle)
{
        char buf[HARNESS_NOTIFY_MAX];
        int found = 0;

        for (;;) {
                ssize_t n = recv(h->notify_fd, buf, sizeof(buf) - 1, 0);

                if (n < 0)
                        return found;
                buf[n] = '\0';
                snprintf(h->last_notify, sizeof(h->last_notify), "%s", buf);
                /* One datagram holds several newline-separated assignments. */
                for (char *line = strtok(buf, "\n"); line; line = strtok(NULL, "\n"))
                        if (!strcmp(line, needle) || strstr(line, needle) == line)
                                found = 1;
                if (found)
                        return 1;
        }
}

/* Polls the notify socket until needle arrives, the daemon exits, or the deadline passes. */
static int wait_notify_or_exit(struct harness *h, const char *needle, int timeout_ms,
                               int *ret_status)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)timeout_ms * 1000000u;

        for (;;) {
                struct pollfd p = { .fd = h->notify_fd, .events = POLLIN };
                int left = remaining_ms(deadline);
                int st;

                if (drain_notify(h, needle))
                        return 0;
                if (h->pid > 0 && waitpid(h->pid, &st, WNOHANG) == h->pid) {
                        h->pid = 0;
                        if (ret_status)
                                *ret_status = st;
                        return -ECHILD;
                }
                if (left == 0)
                        return -ETIMEDOUT;
                /* Short slices: a daemon that dies sends no datagram to wake us. */
                poll(&p, 1, left < HARNESS_POLL_SLICE_MS ? left : HARNESS_POLL_SLICE_MS);
        }
}

/* execv() takes char *const[] for historical reasons; it never writes through it. */
static void exec_argv(const char *const *argv)
{
        union { const char *const *c; char *const *m; } u = { .c = argv };

        execv(u.m[0], u.m);
        fprintf(stderr, "harness: exec %s: %s\n", argv[0], strerror(errno));
        _exit(127);
}

static void child_env(struct harness *h)
{
        setenv("NOTIFY_SOCKET", h->notify_path, 1);
        setenv("SHAREDLINK_RUNTIME_DIR", h->dir, 1);
        setenv("SHAREDLINK_INSTANCE", h->instance, 1);
}

int harness_start_daemon(struct harness *h, const char *config, int timeout_ms, int *ret_status,
                         const char *const *extra_args)
{
        const char *argv[HARNESS_ARGV_MAX];
        size_t n = 0;

        argv[n++] = harness_daemon_path();
        argv[n++] = "-c";
        argv[n++] = config;
        for (size_t i = 0; extra_args && extra_args[i] && n < HARNESS_ARGV_MAX - 1; i++)
                argv[n++] = extra_args[i];
        argv[n] = NULL;
        return harness_start_program(h, NULL, argv, timeout_ms, ret_status);
}

int harness_start_program(struct harness *h, const struct harness *env, const char *const *argv,
                          int timeout_ms, int *ret_status)
{
        pid_t pid;

        drain_notify(h, "\x01");   /* forget datagrams of an earlier daemon */
        pid = fork();
        if (pid < 0)
                return -errno;
        if (pid == 0) {
                /* A test that dies (timeout, crash) must not leave its daemon behind. */
                prctl(PR_SET_PDEATHSIG, SIGTERM);
                child_env(h);
                if (env) {
                        setenv("SHAREDLINK_RUNTIME_DIR", env->dir, 1);
                        setenv("SHAREDLINK_INSTANCE", env->instance, 1);
                }
                if (h->capture_log) {
                        int fd = open(h->log_path, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);

                        if (fd >= 0)
                                dup2(fd, STDERR_FILENO);
                }
                exec_argv(argv);
        }
        h->pid = pid;
        return wait_notify_or_exit(h, "READY=1", timeout_ms, ret_status);
}

int harness_start_refused(const struct harness *env, const char *tag, const char *const *argv,
                          int timeout_ms, int code, const char *needle, char *why, size_t whysz)
{
        struct harness h;
        int st = 0, r = harness_init(&h, tag);

        if (r < 0) {
                snprintf(why, whysz, "harness: %s", strerror(-r));
                return r;
        }
        h.capture_log = 1;
        r = harness_start_program(&h, env, argv, timeout_ms, &st);
        if (r == -ECHILD) {
                h.pid = 0;
                r = WIFEXITED(st) && WEXITSTATUS(st) == code &&
                    harness_log_contains(&h, needle) == 1 ? 0 : -EPROTO;
        } else {
                r = -EPROTO;
        }
        snprintf(why, whysz, "%s: %s (wait status 0x%x), wanted exit %d and \"%s\" in %s",
                 argv[0], h.pid > 0 ? "started" : "exited", (unsigned)st, code, needle,
                 h.log_path);
        if (r < 0)              /* keep the log to read */
                h.dir[0] = '\0';
        harness_cleanup(&h);
        return r;
}

int harness_wait_notify(struct harness *h, const char *needle, int timeout_ms)
{
        return wait_notify_or_exit(h, needle, timeout_ms, NULL);
}

int harness_stop_daemon(struct harness *h, int sig, int timeout_ms)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)timeout_ms * 1000000u;
        int st;

        if (h->pid <= 0)
                return -ECHILD;
        kill(h->pid, sig);
        for (;;) {
                pid_t r = waitpid(h->pid, &st, WNOHANG);

                if (r == h->pid) {
                        h->pid = 0;
                        return st;
                }
                if (r < 0) {
                        h->pid = 0;
                        return -errno;
                }
                if (remaining_ms(deadline) == 0)
                        return -ETIMEDOUT;
                poll(NULL, 0, 5);
        }
}

/* Appends what one read of fd gives to buf[*len..size-1); 0 at EOF or error, 1 otherwise. */
static int read_some(int fd, char *buf, size_t size, size_t *len)
{
        char tmp[512];
        ssize_t n = read(fd, tmp, sizeof(tmp));

        if (n < 0 && (errno == EINTR || errno == EAGAIN))
                return 1;
        if (n <= 0)
                return 0;
        if (buf && size > 0) {
                size_t take = (size_t)n < size - 1 - *len ? (size_t)n : size - 1 - *len;

                memcpy(buf + *len, tmp, take);
                *len += take;
        }
        return 1;
}

int harness_run_capture(struct harness *h, char *out, size_t size, char *err, size_t errsize,
                        int timeout_ms, const char *const *argv)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)timeout_ms * 1000000u;
        int opipe[2], epipe[2] = { -1, -1 }, st;
        size_t olen = 0, elen = 0;
        pid_t pid;

        if (pipe2(opipe, O_CLOEXEC) < 0)
                return -errno;
        if (err && pipe2(epipe, O_CLOEXEC) < 0) {
                close(opipe[0]);
                close(opipe[1]);
                return -errno;
        }
        pid = fork();
        if (pid < 0) {
                st = -errno;
                close(opipe[0]);
                close(opipe[1]);
                if (err) {
                        close(epipe[0]);
                        close(epipe[1]);
                }
                return st;
        }
        if (pid == 0) {
                child_env(h);
                dup2(opipe[1], STDOUT_FILENO);
                if (err)
                        dup2(epipe[1], STDERR_FILENO);
                exec_argv(argv);
        }
        close(opipe[1]);
        if (err)
                close(epipe[1]);
        while (opipe[0] >= 0 || epipe[0] >= 0) {
                struct pollfd p[2] = { { .fd = opipe[0], .events = POLLIN },
                                       { .fd = epipe[0], .events = POLLIN } };
                int left = remaining_ms(deadline);

                if (left == 0) {
                        kill(pid, SIGKILL);
                        waitpid(pid, &st, 0);
                        if (opipe[0] >= 0)
                                close(opipe[0]);
                        if (epipe[0] >= 0)
                                close(epipe[0]);
                        return -ETIMEDOUT;
                }
                if (poll(p, 2, left) <= 0)
                        continue;
                if (p[0].revents && !read_some(opipe[0], out, size, &olen)) {
                        close(opipe[0]);
                        opipe[0] = -1;
                }
                if (p[1].revents && !read_some(epipe[0], err, errsize, &elen)) {
                        close(epipe[0]);
                        epipe[0] = -1;
                }
        }
        if (out && size > 0)
                out[olen] = '\0';
        if (err && errsize > 0)
                err[elen] = '\0';
        if (waitpid(pid, &st, 0) < 0)
                return -errno;
        return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

int harness_run(struct harness *h, char *out, size_t size, int timeout_ms, const char *const *argv)
{
        return harness_run_capture(h, out, size, NULL, 0, timeout_ms, argv);
}

int harness_log_contains(struct harness *h, const char *needle)
{
        char buf[4096];
        size_t keep = strlen(needle), len = 0;
        int fd = open(h->log_path, O_RDONLY | O_CLOEXEC);
        ssize_t n;

        if (fd < 0)
                return -errno;
        if (keep >= sizeof(buf) / 2) {
                close(fd);
                return -EINVAL;
        }
        /* Scans in chunks, carrying the last strlen(needle) bytes over so a match that straddles
         * two chunks is still found. */
        while ((n = read(fd, buf + len, sizeof(buf) - 1 - len)) > 0) {
                len += (size_t)n;
                buf[len] = '\0';
                if (strstr(buf, needle)) {
                        close(fd);
                        return 1;
                }
                if (len > keep) {
                        memmove(buf, buf + len - keep, keep);
                        len = keep;
                }
        }
        close(fd);
        return 0;
}

int harness_wait_log(struct harness *h, const char *needle, int timeout_ms)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)timeout_ms * 1000000u;

        for (;;) {
                if (harness_log_contains(h, needle) == 1)
                        return 0;
                if (remaining_ms(deadline) == 0)
                        return -ETIMEDOUT;
                /* A file gives no readiness event: short slices, like wait_notify_or_exit. */
                poll(NULL, 0, HARNESS_POLL_SLICE_MS);
        }
}

int harness_connect_unix(const char *path)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        int fd;

        if (strlen(path) >= sizeof(sa.sun_path))
                return -ENAMETOOLONG;
        strcpy(sa.sun_path, path);
        fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (fd < 0)
                return -errno;
        if (connect(fd, (struct sockaddr *)&sa, sizeof(sa)) < 0) {
                int r = -errno;

                close(fd);
                return r;
        }
        return fd;
}

ssize_t harness_control_request(int fd, const char *line, char *reply, size_t size,
                                int timeout_ms)
{
        size_t len = 0, start;
        ssize_t n;
        int r;

        char *req;

        if (size == 0)
                return -EINVAL;
        /* One write for the line and its '\n': a daemon that answers the line (an overlong
         * one, say) and closes must not find half a request. */
        req = malloc(strlen(line) + 2);
        if (!req)
                return -ENOMEM;
        strcpy(req, line);
        strcat(req, "\n");
        r = harness_write_all(fd, req, strlen(req), timeout_ms);
        free(req);
        if (r < 0)
                return r;
        for (;;) {
                start = len;
                n = harness_read_until(fd, reply + len, size - len, '\n', timeout_ms);
                if (n < 0)
                        return n;
                len += (size_t)n;
                if (!strncmp(reply + start, "OK", 2) || !strncmp(reply + start, "ERR", 3))
                        return (ssize_t)len;
                if (len + 1 >= size)
                        return -ENOBUFS;
        }
}

int harness_openpty(int *ret_master, int *ret_slave, char *ret_slave_path)
{
        struct termios tio;
        int m, s;

        if (openpty(&m, &s, ret_slave_path, NULL, NULL) < 0)
                return -errno;
        /* Raw both ways: the tests speak exact bytes, no echo, no CR/LF translation. */
        if (tcgetattr(s, &tio) == 0) {
                cfmakeraw(&tio);
                tcsetattr(s, TCSANOW, &tio);
        }
        fcntl(m, F_SETFL, fcntl(m, F_GETFL) | O_NONBLOCK);
        fcntl(s, F_SETFL, fcntl(s, F_GETFL) | O_NONBLOCK);
        fcntl(m, F_SETFD, FD_CLOEXEC);
        fcntl(s, F_SETFD, FD_CLOEXEC);
        *ret_master = m;
        *ret_slave = s;
        return 0;
}

ssize_t harness_read_until(int fd, char *buf, size_t size, char delim, int timeout_ms)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)timeout_ms * 1000000u;
        size_t len = 0;

        if (size == 0)
                return -EINVAL;
        while (len < size - 1) {
                struct pollfd p = { .fd = fd, .events = POLLIN };
                int left = remaining_ms(deadline);
                ssize_t n;

                if (left == 0) {
                        buf[len] = '\0';
                        return -ETIMEDOUT;
                }
                if (poll(&p, 1, left) <= 0)
                        continue;
                n = read(fd, buf + len, 1);   /* one byte: never read past the delimiter */
                if (n < 0 && (errno == EAGAIN || errno == EINTR))
                        continue;
                if (n <= 0) {
                        buf[len] = '\0';
                        return -EIO;
                }
                if (buf[len++] == delim)
                        break;
        }
        buf[len] = '\0';
        return (ssize_t)len;
}

int harness_write_all(int fd, const void *buf, size_t len, int timeout_ms)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)timeout_ms * 1000000u;
        const char *p = buf;

        while (len > 0) {
                /* send() with MSG_NOSIGNAL on sockets: a peer that closed is -EPIPE, not a
                 * SIGPIPE that kills the test; write() for everything else (ptys). */
                ssize_t n = send(fd, p, len, MSG_NOSIGNAL);

                if (n < 0 && errno == ENOTSOCK)
                        n = write(fd, p, len);

                if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
                        struct pollfd pf = { .fd = fd, .events = POLLOUT };
                        int left = remaining_ms(deadline);

                        if (left == 0)
                                return -ETIMEDOUT;
                        poll(&pf, 1, left);
                        continue;
                }
                if (n < 0)
                        return -errno;
                p += n;
                len -= (size_t)n;
        }
        return 0;
}

size_t harness_circe_packet(const char *body, char *out)
{
        unsigned sum = 0x02;
        size_t n = 0;

        out[n++] = 0x02;
        for (const char *p = body; *p; p++) {
                out[n++] = *p;
                sum += (uint8_t)*p;
        }
        n += (size_t)sprintf(out + n, "%02X", sum & 0xFF);
        out[n++] = 0x03;
        out[n] = '\0';
        return n;
}

int harness_count_fds(pid_t pid)
{
        char path[64];
        DIR *d;
        struct dirent *e;
        int n = 0;

        snprintf(path, sizeof(path), "/proc/%ld/fd", (long)pid);
        d = opendir(path);
        if (!d)
                return -errno;
        while ((e = readdir(d)))
                if (e->d_name[0] != '.')
                        n++;
        closedir(d);
        return n;
}
