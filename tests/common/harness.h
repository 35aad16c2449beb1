/*
 * Integration-test harness: start the real sharedlinkd in a private temporary directory, wait for
 * its READY=1 on a test NOTIFY_SOCKET (an event, not a sleep), talk to it over pty pairs, stop it.
 *
 * Every wait has a timeout in milliseconds and returns -ETIMEDOUT when it passes, so a broken
 * daemon fails a test instead of hanging it.
 */
#pragma once

#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#define HARNESS_PATH_MAX 256
#define HARNESS_NOTIFY_MAX 1024

struct harness {
        char dir[HARNESS_PATH_MAX];        /* private temp dir: configs, sockets, pty links */
        char instance[64];                 /* unique per test process */
        char notify_path[HARNESS_PATH_MAX + 32];
        int notify_fd;                     /* our NOTIFY_SOCKET end, -1 when closed */
        pid_t pid;                         /* daemon pid, 0 when not running */
        char last_notify[HARNESS_NOTIFY_MAX];
        int capture_log;                   /* set before starting: daemon stderr -> log_path */
        char log_path[HARNESS_PATH_MAX + 32];
};

/* Makes the temp dir and a unique instance name ("t<pid>_<tag>"); 0 or -errno. */
int harness_init(struct harness *h, const char *tag);

/* Stops a running daemon (SIGKILL if it ignores SIGTERM) and removes the temp dir. */
void harness_cleanup(struct harness *h);

/* Writes `text` to <dir>/<name>; the path goes to ret_path (HARNESS_PATH_MAX). 0 or -errno. */
int harness_write_file(struct harness *h, const char *name, const char *text, char *ret_path);

/* Path of the daemon under test: $SHAREDLINK_BUILD/sharedlinkd (set by `make check`). */
const char *harness_daemon_path(void);

/* Path of slctl under test. */
const char *harness_slctl_path(void);

/* Starts `sharedlinkd -c config extra_args...` (NULL-terminated list) with NOTIFY_SOCKET set and
 * SHAREDLINK_RUNTIME_DIR=dir; returns 0 once READY=1 arrived, -ECHILD if the daemon exited first
 * (ret_status gets its wait status when non-NULL), -ETIMEDOUT. */
int harness_start_daemon(struct harness *h, const char *config, int timeout_ms, int *ret_status,
                         const char *const *extra_args);

/* Starts another daemon of the house, argv (NULL-terminated, argv[0] the path), the way
 * harness_start_daemon() starts sharedlinkd: h's NOTIFY_SOCKET and capture_log; the instance
 * and runtime directory of env (the harness running sharedlinkd; NULL: h's). */
int harness_start_program(struct harness *h, const struct harness *env, const char *const *argv,
                          int timeout_ms, int *ret_status);

/* Starts argv as harness_start_program() does, in a harness of its own (tag; removed after) with
 * env's instance and runtime directory, for a start that must be refused: 0 when the program
 * exited with status code before READY=1 and its log holds needle; otherwise -EPROTO (or the
 * -errno of the harness), with what happened in why (whysz bytes). */
int harness_start_refused(const struct harness *env, const char *tag, const char *const *argv,
                          int timeout_ms, int code, const char *needle, char *why, size_t whysz);

/* The message harness_start_config() leaves: the outcome and what this start wrote to the log. */
#define HARNESS_WHY_MAX 2048

/* Writes "instance: <instance>\nruntime_dir: <dir>\n" and then body (e.g. a "links:" document)
 * to <dir>/<name> and starts the daemon on it as harness_start_daemon() does (no extra args).
 * 0 once READY=1 came; -ENOTSUP when the daemon refused a link whose engine this build lacks
 * ("not available in this build" in the captured log: the caller skips the test); else the
 * -errno of the write or the start, with why (whysz bytes, 0 for none) telling the wait status
 * and the head of the captured log. */
int harness_start_config(struct harness *h, const char *name, const char *body, int timeout_ms,
                         char *why, size_t whysz);

/* Closes *fd if it is open (>= 0) and sets it to -1: for teardowns. */
void harness_close_fd(int *fd);

/* Waits for a notify datagram containing `needle` (e.g. "RELOADING=1"); 0 or -ETIMEDOUT. */
int harness_wait_notify(struct harness *h, const char *needle, int timeout_ms);

/* Sends `sig` and waits for the daemon to exit; returns its wait status or -ETIMEDOUT. */
int harness_stop_daemon(struct harness *h, int sig, int timeout_ms);

/* Runs a program with args (NULL-terminated) and env SHAREDLINK_INSTANCE/RUNTIME_DIR of `h`,
 * capturing stdout into out (NUL-terminated, truncated to size); returns the exit code (>= 0),
 * or -errno / -ETIMEDOUT. */
int harness_run(struct harness *h, char *out, size_t size, int timeout_ms, const char *const *argv);

/* Like harness_run, also capturing stderr into err (NUL-terminated, truncated to errsize; err
 * may be NULL to leave stderr alone). */
int harness_run_capture(struct harness *h, char *out, size_t size, char *err, size_t errsize,
                        int timeout_ms, const char *const *argv);

/* Whether the captured daemon log (capture_log) contains needle: 1, 0, or -errno. */
int harness_log_contains(struct harness *h, const char *needle);

/* Waits until the captured daemon log contains needle; 0 or -ETIMEDOUT. */
int harness_wait_log(struct harness *h, const char *needle, int timeout_ms);

/* Connects to a Unix stream socket (a control socket); returns the fd (CLOEXEC) or -errno. */
int harness_connect_unix(const char *path);

/* Sends one request line (a '\n' is appended) on a control connection and reads the reply up to
 * and including its final "OK..." or "ERR..." line into reply (NUL-terminated, DATA lines
 * included). Returns the length, -EIO (connection closed first) or -ETIMEDOUT. */
ssize_t harness_control_request(int fd, const char *line, char *reply, size_t size,
                                int timeout_ms);

/* Opens a raw pty pair (master and slave non-blocking, CLOEXEC); 0 or -errno. */
int harness_openpty(int *ret_master, int *ret_slave, char *ret_slave_path);

/* Reads until `delim` has been read (included) or size-1 bytes; returns the length, or
 * -ETIMEDOUT / -EIO. buf is NUL-terminated. */
ssize_t harness_read_until(int fd, char *buf, size_t size, char delim, int timeout_ms);

/* Writes all of buf (retrying on EAGAIN with poll); 0 or -errno. */
int harness_write_all(int fd, const void *buf, size_t len, int timeout_ms);

/* Frames a CIRCE packet body ("OP<TAB>PID:VALUE<TAB>...") as STX body checksum ETX into out
 * (room for strlen(body) + 4 bytes + NUL); returns its length. */
size_t harness_circe_packet(const char *body, char *out);

/* Counts the open fds of a process (from /proc/PID/fd); -errno on error. */
int harness_count_fds(pid_t pid);

/* Monotonic time in ns. */
uint64_t harness_now_ns(void);
