/*
 * slctl record: asks the daemon to stream what a link receives and sends ("record LINK" on the
 * control socket) and writes the lines to a file, one whole line per write(2), so that the file
 * holds only whole lines whenever the command stops. SIGINT and SIGTERM stop it cleanly: what
 * the daemon had already sent is still written (the lines stay RECORD_DRAIN_MS in flight at most:
 * a timer then ends the command), then the summary is printed and the exit is 0; a second signal
 * ends it at once. The handlers run only between two writes (the signals are blocked around
 * each). The format is docs/recording.md's; the lines are counted by its reader.
 */
#include "cli/cmd_record.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/time.h>
#include <unistd.h>

#include "cli/slctl.h"
#include "proto/recording.h"
#include "svc/io.h"

#define REPLY_SIZE              (SL_REPLY_LINE_MAX + 1)
#define RECORD_FILE_MODE        0644
#define RECORD_DURATION_MAX     (24L * 3600L * 365L)   /* seconds: --duration up to a year */
#define RECORD_MS_PER_S         1000L
#define RECORD_SUMMARY_MAX      512
#define RECORD_U64_DIGITS       24
/* After a stop signal, how long the lines the daemon already sent have to arrive: a local
 * socket hands them over in microseconds; this leaves room for a loaded machine. */
#define RECORD_DRAIN_MS         300
#define RECORD_US_PER_MS        1000L

/* What the signal handler reads: updated only while SIGINT and SIGTERM are blocked. */
static struct {
        int fd;                         /* -1 until the first line: an error leaves no file */
        const char *file;
        int open_error;
        uint64_t lines, chunks, bytes;
        long count;                     /* --count: stop after this many chunks (0: no limit) */
        int write_error;
        volatile sig_atomic_t stopping; /* a stop signal came: draining until the timer */
        struct rec_reader reader;       /* counts chunks, bytes and drops as replay will */
} rec;

/* Appends s to buf (async-signal-safe). */
static size_t put_str(char *buf, size_t len, size_t size, const char *s)
{
        while (*s && len + 1 < size)
                buf[len++] = *s++;
        buf[len] = '\0';
        return len;
}

static size_t put_u64(char *buf, size_t len, size_t size, uint64_t v)
{
        char digits[RECORD_U64_DIGITS];
        size_t n = 0;

        do {
                digits[n++] = (char)('0' + v % 10);
                v /= 10;
        } while (v);
        while (n > 0 && len + 1 < size)
                buf[len++] = digits[--n];
        buf[len] = '\0';
        return len;
}

/* "slctl: recorded N chunks (B bytes), D dropped, to FILE" on stderr (async-signal-safe). */
static void print_summary(void)
{
        char buf[RECORD_SUMMARY_MAX];
        size_t n = 0;

        n = put_str(buf, n, sizeof(buf), "slctl: recorded ");
        n = put_u64(buf, n, sizeof(buf), rec.chunks);
        n = put_str(buf, n, sizeof(buf), " chunks (");
        n = put_u64(buf, n, sizeof(buf), rec.bytes);
        n = put_str(buf, n, sizeof(buf), " bytes), ");
        n = put_u64(buf, n, sizeof(buf), rec.reader.dropped);
        n = put_str(buf, n, sizeof(buf), " dropped by the daemon, to ");
        n = put_str(buf, n, sizeof(buf), strcmp(rec.file, "-") ? rec.file : "standard output");
        n = put_str(buf, n, sizeof(buf), "\n");
        if (write(STDERR_FILENO, buf, n) < 0)
                return;                 /* nowhere to say it */
}

/* The drain after a stop signal is over (SIGALRM), or a second stop signal came. */
static void on_stop_now(int sig)
{
        (void)sig;
        print_summary();
        _exit(SLCTL_EXIT_OK);
}

/* A stop signal: the lines already on their way are still written, for RECORD_DRAIN_MS. */
static void on_stop_signal(int sig)
{
        struct itimerval drain = { .it_value = { .tv_usec = RECORD_DRAIN_MS * RECORD_US_PER_MS } };

        if (rec.stopping || setitimer(ITIMER_REAL, &drain, NULL) < 0)
                on_stop_now(sig);
        rec.stopping = 1;
}

static void block_stop_signals(int how)
{
        sigset_t set;

        sigemptyset(&set);
        sigaddset(&set, SIGINT);
        sigaddset(&set, SIGTERM);
        sigaddset(&set, SIGALRM);
        sigprocmask(how, &set, NULL);
}

static void catch_stop_signals(void)
{
        struct sigaction sa;

        memset(&sa, 0, sizeof(sa));
        sa.sa_handler = on_stop_signal;
        sigemptyset(&sa.sa_mask);
        sigaddset(&sa.sa_mask, SIGALRM);
        sigaction(SIGINT, &sa, NULL);
        sigaction(SIGTERM, &sa, NULL);
        sa.sa_handler = on_stop_now;
        sigaction(SIGALRM, &sa, NULL);
}

/* Counts a line with the format's own reader: a chunk, its bytes, and "# dropped N chunks".
 * A line it refuses is still written (the file says what the daemon sent) but not counted. */
static void count_line(const char *text, size_t len)
{
        rec.lines++;
        if (rec_reader_line(&rec.reader, text, len) == 1) {
                rec.chunks++;
                rec.bytes += rec.reader.len;
        }
}

static int open_output(void)
{
        if (strcmp(rec.file, "-") == 0) {
                rec.fd = STDOUT_FILENO;
                return 0;
        }
        rec.fd = open(rec.file, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC | O_NOCTTY,
                      RECORD_FILE_MODE);
        if (rec.fd < 0) {
                rec.open_error = errno;
                return -errno;
        }
        return 0;
}

/* sl_request's DATA callback: one line of the recording. */
static int on_line(const char *text, void *arg)
{
        size_t len = strlen(text);
        char *line = arg;
        int r;

        if (rec.fd < 0 && (r = open_output()) < 0)
                return r;
        memcpy(line, text, len);
        line[len++] = '\n';
        block_stop_signals(SIG_BLOCK);
        r = io_write_all(rec.fd, line, len);
        if (r == 0)
                count_line(text, len - 1);
        else
                rec.write_error = -r;
        block_stop_signals(SIG_UNBLOCK);
        if (r < 0)
                return r;
        if (rec.count > 0 && rec.chunks >= (uint64_t)rec.count)
                return -ECANCELED;      /* --count reached: not an error */
        return 0;
}

int cmd_record(struct slctl *s, int argc, char **argv)
{
        static const struct args_opt opts[] = { { "duration", 1 }, { "count", 1 }, { NULL, 0 } };
        char request[SL_REQUEST_LINE_MAX + 1], reply[REPLY_SIZE];
        char *line = NULL;
        long duration = 0;
        struct args a;
        int code, r;

        code = slctl_args(s, argc, argv, opts, &a);
        if (code >= 0)
                return code;
        if (a.npos != 2)
                return slctl_usage(s, "LINK and FILE expected");
        if (a.value[0] && (args_number(a.value[0], &duration) < 0 || duration == 0 ||
                           duration > RECORD_DURATION_MAX))
                return slctl_error(s, "bad --duration \"%s\": seconds, 1..%ld", a.value[0],
                                   RECORD_DURATION_MAX);
        if (a.value[1] && (args_number(a.value[1], &rec.count) < 0 || rec.count == 0))
                return slctl_error(s, "bad --count \"%s\": a number from 1 up", a.value[1]);
        if ((size_t)snprintf(request, sizeof(request), "record %s", a.pos[0]) >= sizeof(request))
                return slctl_error(s, "link name too long");
        code = slctl_open(s, 0);
        if (code >= 0)
                return code;
        line = malloc(REPLY_SIZE + 1);
        if (!line)
                return slctl_error(s, "out of memory");
        rec.fd = -1;
        rec.file = a.pos[1];
        rec_reader_init(&rec.reader);
        catch_stop_signals();
        r = sl_request(s->c, request, duration ? (int)(duration * RECORD_MS_PER_S) : -1, on_line,
                       line, reply, sizeof(reply));
        block_stop_signals(SIG_BLOCK);          /* from here on, a signal waits for the exit */
        if (rec.fd > STDOUT_FILENO && close(rec.fd) < 0 && r >= 0)
                rec.write_error = errno;
        free(line);
        if (rec.open_error)
                return slctl_error(s, "cannot write %s: %s", rec.file, strerror(rec.open_error));
        if (rec.write_error) {
                fflush(stdout);
                fprintf(stderr, "slctl: writing %s: %s\n", rec.file, strerror(rec.write_error));
                return SLCTL_EXIT_ERROR;
        }
        if (r == 0 || (r == -ETIMEDOUT && duration && rec.lines > 0) ||
            (r == -ECANCELED && rec.count > 0)) {
                /* The daemon ended it (link stopped, daemon stopping), or our own limit. */
                if (r == 0)
                        fprintf(stderr, "slctl: the daemon ended the recording: %s\n", reply);
                print_summary();
                return SLCTL_EXIT_OK;
        }
        fflush(stdout);
        fprintf(stderr, "slctl: %s\n", reply[0] ? reply : sl_strerror(r));
        return r == -ECONNREFUSED ? SLCTL_EXIT_NOT_RUNNING : SLCTL_EXIT_ERROR;
}
