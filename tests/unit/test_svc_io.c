/*
 * svc/io: io_write_all() through a pipe whose writer is interrupted (short writes and EINTR),
 * on a full non-blocking pipe and a closed reader; io_read_file()'s bounds; io_mkdir_parents().
 */
#define _GNU_SOURCE     /* F_SETPIPE_SZ, pipe2 */
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>

#include "svc/io.h"

#define PIPE_SIZE       4096            /* the smallest pipe Linux makes */
#define TOTAL           (256 * 1024)    /* many pipefuls */
#define READ_CHUNK      1000            /* not a divisor of the pipe size */

static atomic_uint interrupts;

static void on_usr1(int signo)
{
        (void)signo;
        atomic_fetch_add(&interrupts, 1);
}

struct writer {
        int fd;
        const unsigned char *data;
        int result;
};

static void *writer_main(void *arg)
{
        struct writer *w = arg;

        w->result = io_write_all(w->fd, w->data, TOTAL);
        close(w->fd);   /* the reader sees the end, and a writer that stopped early fails */
        return NULL;
}

/*
 * The reader takes a little at a time and signals the writer after each read, with a handler
 * that does not restart: the writer's write(2) returns early with what it wrote so far, or
 * fails with EINTR, over and over. Every byte must still arrive once and in order.
 */
static void test_write_all_interrupted_pipe(void **state)
{
        struct sigaction sa = { .sa_handler = on_usr1 };        /* no SA_RESTART */
        unsigned char *data = malloc(TOTAL), *got = malloc(TOTAL);
        struct writer w;
        pthread_t th;
        size_t have = 0;
        int p[2];

        (void)state;
        assert_non_null(data);
        assert_non_null(got);
        for (size_t i = 0; i < TOTAL; i++)
                data[i] = (unsigned char)(i * 7 + i / 251);
        sigemptyset(&sa.sa_mask);
        assert_int_equal(sigaction(SIGUSR1, &sa, NULL), 0);
        assert_int_equal(pipe2(p, O_CLOEXEC), 0);
        fcntl(p[1], F_SETPIPE_SZ, PIPE_SIZE);   /* best effort: a bigger pipe tests less */
        w = (struct writer){ .fd = p[1], .data = data, .result = 1 };
        assert_int_equal(pthread_create(&th, NULL, writer_main, &w), 0);
        while (have < TOTAL) {
                ssize_t n = read(p[0], got + have, READ_CHUNK);

                if (n < 0 && errno == EINTR)
                        continue;
                if (n == 0)
                        fail_msg("end of data after %zu of %d bytes", have, TOTAL);
                assert_true(n > 0);
                have += (size_t)n;
                pthread_kill(th, SIGUSR1);
        }
        assert_int_equal(pthread_join(th, NULL), 0);
        assert_int_equal(w.result, 0);
        assert_memory_equal(got, data, TOTAL);
        assert_true(atomic_load(&interrupts) > 0);
        close(p[0]);
        free(data);
        free(got);
}

static void test_write_all_errors(void **state)
{
        char block[PIPE_SIZE] = { 0 };
        int p[2];

        (void)state;
        /* A full non-blocking pipe: -EAGAIN once what fits is in. */
        assert_int_equal(pipe2(p, O_CLOEXEC | O_NONBLOCK), 0);
        for (;;) {
                int r = io_write_all(p[1], block, sizeof(block));

                if (r < 0) {
                        assert_int_equal(r, -EAGAIN);
                        break;
                }
        }
        /* The reader gone: -EPIPE, with SIGPIPE ignored as every daemon does. */
        signal(SIGPIPE, SIG_IGN);
        close(p[0]);
        assert_int_equal(io_write_all(p[1], "x", 1), -EPIPE);
        close(p[1]);
        assert_int_equal(io_write_all(p[1], "x", 1), -EBADF);
        assert_int_equal(io_write_all(-1, "", 0), 0);   /* nothing to write: no call */
}

static void test_read_file(void **state)
{
        char path[] = "/tmp/test_svc_io.XXXXXX";
        char *text;
        size_t len;
        int fd = mkstemp(path);

        (void)state;
        assert_true(fd >= 0);
        assert_int_equal(io_write_all(fd, "0123456789", 10), 0);
        close(fd);
        assert_int_equal(io_read_file(path, 10, &text, &len), 0);
        assert_int_equal(len, 10);
        assert_string_equal(text, "0123456789");
        free(text);
        assert_int_equal(io_read_file(path, 9, &text, &len), -EFBIG);
        assert_int_equal(io_read_file("/dev/null", 9, &text, &len), 0);
        assert_int_equal(len, 0);
        assert_string_equal(text, "");
        free(text);
        unlink(path);
        assert_int_equal(io_read_file(path, 9, &text, &len), -ENOENT);
        assert_int_equal(io_read_file("/", 9, &text, &len), -EISDIR);
}

/* Every missing level is made with the mode asked, whatever the umask; what exists is kept; a
 * file in the way is -ENOTDIR. */
static void test_mkdir_parents(void **state)
{
        char dir[] = "/tmp/test_svc_io.XXXXXX", path[256], file[256];
        struct stat st;
        mode_t old = umask(077);
        int fd;

        (void)state;
        assert_non_null(mkdtemp(dir));
        snprintf(path, sizeof(path), "%s/a/b/c", dir);
        assert_int_equal(io_mkdir_parents(path, 0755), 0);
        assert_int_equal(stat(path, &st), 0);
        assert_int_equal(st.st_mode & 07777, 0755);
        snprintf(file, sizeof(file), "%s/a/b", dir);
        assert_int_equal(stat(file, &st), 0);
        assert_int_equal(st.st_mode & 07777, 0755);
        assert_int_equal(io_mkdir_parents(path, 0700), 0);     /* there: left as it is */
        assert_int_equal(stat(path, &st), 0);
        assert_int_equal(st.st_mode & 07777, 0755);
        snprintf(file, sizeof(file), "%s/f", dir);
        fd = open(file, O_WRONLY | O_CREAT | O_EXCL, 0600);
        assert_true(fd >= 0);
        close(fd);
        assert_int_equal(io_mkdir_parents(file, 0755), -ENOTDIR);
        snprintf(path, sizeof(path), "%s/f/g", dir);
        assert_int_equal(io_mkdir_parents(path, 0755), -ENOTDIR);
        umask(old);
        unlink(file);
        snprintf(path, sizeof(path), "%s/a/b/c", dir);
        rmdir(path);
        snprintf(path, sizeof(path), "%s/a/b", dir);
        rmdir(path);
        snprintf(path, sizeof(path), "%s/a", dir);
        rmdir(path);
        assert_int_equal(rmdir(dir), 0);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_write_all_interrupted_pipe),
                cmocka_unit_test(test_write_all_errors),
                cmocka_unit_test(test_read_file),
                cmocka_unit_test(test_mkdir_parents),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
