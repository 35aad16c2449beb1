/*
 * svc/service: the command line every daemon documents ([-c FILE] [-n] [-v] [-V], -h; exit 2 on
 * a usage error) and -n's check; the skeleton's routing, in process: SIGTERM/SIGINT stop (now,
 * or drained with a note; a second signal ignored), SIGHUP to the reload after RELOADING=1 or
 * to a log line, the watchdog timer, READY=1/STATUS= (sent when changed), exit statuses and
 * "stopped". The signals are raised to the process itself and read by the loop (blocked).
 */
#include <poll.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cmocka.h>

#include "svc/log.h"
#include "svc/service.h"

#define NOTE            " (2 events to be acknowledged)"
#define DGRAM_MAX       1024
#define LOG_MAX         8192

#define CHECK_BAD       "/bad.yaml"
#define ARGS_MAX        8
#define ARG_SIZE        32

static const char *checked;

static int check(const char *path)
{
        checked = path;
        return strcmp(path, CHECK_BAD) == 0 ? SERVICE_EXIT_FAILURE : service_check_ok();
}

static const struct service_desc desc = {
        .name = "testd", .version = "9.9", .config_default = "/etc/testd.yaml", .check = check,
};

/* ARGV (NULL-terminated, without argv[0]) through service_args(). */
static int run(struct service_args *a, const char *const *argv)
{
        static char text[ARGS_MAX][ARG_SIZE];
        char *args[ARGS_MAX + 1];
        int argc = 0;

        for (const char *arg = "testd"; arg && argc < ARGS_MAX; arg = *argv++) {
                snprintf(text[argc], sizeof(text[argc]), "%s", arg);
                args[argc] = text[argc];
                argc++;
        }
        args[argc] = NULL;
        optind = 0;     /* glibc: start getopt afresh */
        checked = NULL;
        *a = (struct service_args){ 0 };
        return service_args(&desc, argc, args, a);
}

static void test_run(void **state)
{
        struct service_args a;

        (void)state;
        assert_int_equal(run(&a, (const char *const[]){ NULL }), SERVICE_CONTINUE);
        assert_string_equal(a.config, "/etc/testd.yaml");
        assert_int_equal(a.verbose, 0);
        assert_int_equal(run(&a, (const char *const[]){ "-c", "/x.yaml", "-v", "-v", NULL }),
                         SERVICE_CONTINUE);
        assert_string_equal(a.config, "/x.yaml");
        assert_int_equal(a.verbose, 2);
        assert_int_equal(run(&a, (const char *const[]){ "-vc/y.yaml", NULL }), SERVICE_CONTINUE);
        assert_string_equal(a.config, "/y.yaml");
        assert_int_equal(a.verbose, 1);
}

static void test_exits(void **state)
{
        struct service_args a;

        (void)state;
        assert_int_equal(run(&a, (const char *const[]){ "-V", NULL }), SERVICE_EXIT_OK);
        assert_int_equal(run(&a, (const char *const[]){ "-h", NULL }), SERVICE_EXIT_OK);
        assert_int_equal(run(&a, (const char *const[]){ "-x", NULL }), SERVICE_EXIT_USAGE);
        assert_int_equal(run(&a, (const char *const[]){ "-c", NULL }), SERVICE_EXIT_USAGE);
        assert_int_equal(run(&a, (const char *const[]){ "extra", NULL }), SERVICE_EXIT_USAGE);
        assert_null(checked);
        /* -n checks the file -c names (after all options), and its answer is the status. */
        assert_int_equal(run(&a, (const char *const[]){ "-n", NULL }), SERVICE_EXIT_OK);
        assert_string_equal(checked, "/etc/testd.yaml");
        assert_int_equal(run(&a, (const char *const[]){ "-n", "-c", CHECK_BAD, NULL }),
                         SERVICE_EXIT_FAILURE);
        assert_string_equal(checked, CHECK_BAD);
        /* A usage error wins over -n. */
        assert_int_equal(run(&a, (const char *const[]){ "-n", "extra", NULL }),
                         SERVICE_EXIT_USAGE);
        assert_null(checked);
}

/* ---- the skeleton --------------------------------------------------------------------------- */

/* The service manager (an abstract datagram socket as NOTIFY_SOCKET) and the log (a file). */
struct fixture {
        int notify_fd;
        FILE *log;
        unsigned stops, reloads;
        int stop_answer;
        struct service *svc;
};

static int setup(void **state)
{
        static struct fixture f;
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        char name[sizeof(sa.sun_path)];

        f = (struct fixture){ .stop_answer = SERVICE_STOP_NOW };
        snprintf(name, sizeof(name), "@sharedlink-test-service-%ld", (long)getpid());
        memcpy(sa.sun_path, name, strlen(name));
        sa.sun_path[0] = '\0';
        f.notify_fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
        assert_true(f.notify_fd >= 0);
        assert_int_equal(bind(f.notify_fd, (struct sockaddr *)&sa,
                              (socklen_t)(offsetof(struct sockaddr_un, sun_path) + strlen(name))),
                         0);
        setenv("NOTIFY_SOCKET", name, 1);
        f.log = tmpfile();
        assert_non_null(f.log);
        log_init(0, fileno(f.log));
        *state = &f;
        return 0;
}

static int teardown(void **state)
{
        struct fixture *f = *state;

        f->svc = service_free(f->svc);
        log_init(0, -1);
        fclose(f->log);
        close(f->notify_fd);
        unsetenv("NOTIFY_SOCKET");
        unsetenv("WATCHDOG_USEC");
        return 0;
}

/* The next datagram sent ("" when none is waiting: everything is sent before the call returns). */
static const char *notified(struct fixture *f)
{
        static char buf[DGRAM_MAX];
        ssize_t n = recv(f->notify_fd, buf, sizeof(buf) - 1, 0);

        buf[n > 0 ? n : 0] = '\0';
        return buf;
}

/* Whether the log holds text. */
static bool logged(struct fixture *f, const char *text)
{
        static char buf[LOG_MAX];
        size_t n;

        fflush(f->log);
        rewind(f->log);
        n = fread(buf, 1, sizeof(buf) - 1, f->log);
        buf[n] = '\0';
        fseek(f->log, 0, SEEK_END);
        return strstr(buf, text) != NULL;
}

static int on_stop(void *arg, char *note, size_t note_size)
{
        struct fixture *f = arg;

        f->stops++;
        snprintf(note, note_size, "%s", NOTE);
        return f->stop_answer;
}

static void on_reload(void *arg)
{
        struct fixture *f = arg;

        f->reloads++;
        /* RELOADING=1 went out before the reload started. */
        assert_int_equal(strncmp(notified(f), "RELOADING=1\nMONOTONIC_USEC=",
                                 strlen("RELOADING=1\nMONOTONIC_USEC=")), 0);
}

static const struct service_ops full_ops = { .stop = on_stop, .reload = on_reload };

/* One round of the loop after raising signo to ourselves (pending: it is blocked). */
static void deliver(struct fixture *f, int signo)
{
        assert_int_equal(raise(signo), 0);
        assert_int_equal(evloop_run_once(service_loop(f->svc)), 0);
}

static void test_reload_then_stop(void **state)
{
        struct fixture *f = *state;
        static const struct service_ops reload_only = { .reload = on_reload };

        assert_int_equal(service_new(&desc, &reload_only, f, &f->svc), 0);
        deliver(f, SIGHUP);
        assert_int_equal(f->reloads, 1);
        assert_false(service_stopping(f->svc));
        deliver(f, SIGHUP);
        assert_int_equal(f->reloads, 2);
        /* No stop callback: SIGTERM ends the loop at once, with exit status 0. */
        assert_int_equal(raise(SIGTERM), 0);
        assert_int_equal(service_run(f->svc), SERVICE_EXIT_OK);
        assert_true(service_stopping(f->svc));
        assert_string_equal(notified(f), "STOPPING=1");
        assert_true(logged(f, "Terminated: stopping\n"));
        assert_false(logged(f, "stopped"));
        f->svc = service_free(f->svc);
        assert_true(logged(f, "stopped"));
}

static void test_stop_drains(void **state)
{
        struct fixture *f = *state;

        f->stop_answer = SERVICE_STOP_DRAIN;
        assert_int_equal(service_new(&desc, &full_ops, f, &f->svc), 0);
        deliver(f, SIGINT);
        assert_int_equal(f->stops, 1);
        assert_true(service_stopping(f->svc));
        assert_true(logged(f, "Interrupt: stopping" NOTE));
        assert_string_equal(notified(f), "STOPPING=1");
        /* Draining: the loop goes on, and a second stop signal changes nothing. */
        assert_false(evloop_exiting(service_loop(f->svc)));
        deliver(f, SIGTERM);
        assert_int_equal(f->stops, 1);
        assert_string_equal(notified(f), "");
        assert_false(evloop_exiting(service_loop(f->svc)));
        /* The daemon says when it is drained. */
        service_exit(f->svc, SERVICE_EXIT_OK);
        assert_int_equal(service_run(f->svc), SERVICE_EXIT_OK);
        f->svc = service_free(f->svc);
        assert_true(logged(f, "stopped"));
}

static void test_no_reload(void **state)
{
        struct fixture *f = *state;

        assert_int_equal(service_new(&desc, NULL, f, &f->svc), 0);
        deliver(f, SIGHUP);
        assert_true(logged(f, "Hangup: testd has no reload"));
        assert_string_equal(notified(f), "");           /* no RELOADING=1 */
        assert_false(service_stopping(f->svc));
        /* A failure ends the loop with its status, and no "stopped". */
        service_exit(f->svc, SERVICE_EXIT_FAILURE);
        assert_int_equal(service_run(f->svc), SERVICE_EXIT_FAILURE);
        f->svc = service_free(f->svc);
        assert_false(logged(f, "stopped"));
}

static void test_watchdog(void **state)
{
        struct fixture *f = *state;
        struct pollfd p = { .fd = f->notify_fd, .events = POLLIN };

        setenv("WATCHDOG_USEC", "2000", 1);             /* WATCHDOG=1 every 1 ms */
        assert_int_equal(service_new(&desc, NULL, f, &f->svc), 0);
        assert_true(logged(f, "watchdog: WATCHDOG=1 every 1 ms"));
        /* Nothing else is on the loop: the round that returns is the watchdog timer's. */
        assert_int_equal(evloop_run_once(service_loop(f->svc)), 0);
        assert_int_equal(poll(&p, 1, 0), 1);
        assert_string_equal(notified(f), "WATCHDOG=1");
}

static void test_no_watchdog(void **state)
{
        struct fixture *f = *state;

        assert_int_equal(service_new(&desc, NULL, f, &f->svc), 0);
        assert_false(logged(f, "watchdog"));
        assert_int_equal(evloop_next_timeout_ms(service_loop(f->svc)), -1);
}

static void test_ready_status(void **state)
{
        struct fixture *f = *state;

        assert_int_equal(service_new(&desc, NULL, f, &f->svc), 0);
        assert_int_equal(service_ready(f->svc, "1 of 2 links up"), 1);
        assert_string_equal(notified(f), "READY=1\nSTATUS=1 of 2 links up");
        assert_int_equal(service_status(f->svc, "1 of 2 links up"), 0);
        assert_string_equal(notified(f), "");
        assert_int_equal(service_status(f->svc, "2 of 2\nlinks up"), 1);
        assert_string_equal(notified(f), "STATUS=2 of 2 links up");
        /* READY=1 always goes out (after a reload), the status with it. */
        assert_int_equal(service_ready(f->svc, "2 of 2\nlinks up"), 0);
        assert_string_equal(notified(f), "READY=1\nSTATUS=2 of 2 links up");
        assert_int_equal(service_ready(f->svc, NULL), 0);
        assert_string_equal(notified(f), "READY=1");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_run),
                cmocka_unit_test(test_exits),
                cmocka_unit_test_setup_teardown(test_reload_then_stop, setup, teardown),
                cmocka_unit_test_setup_teardown(test_stop_drains, setup, teardown),
                cmocka_unit_test_setup_teardown(test_no_reload, setup, teardown),
                cmocka_unit_test_setup_teardown(test_watchdog, setup, teardown),
                cmocka_unit_test_setup_teardown(test_no_watchdog, setup, teardown),
                cmocka_unit_test_setup_teardown(test_ready_status, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
