/*
 * svc/lockfile: names (escaped parts, a long name cut and hashed), one holder at a time across
 * processes with the holder's pid told, a holder killed with SIGKILL leaving the lock to the next
 * at once, the file and its directory made whatever the umask, and, when run as root, a file
 * made by root serving an unprivileged user (who may not make one in root's directory).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <grp.h>
#include <pwd.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "svc/lockfile.h"

#define UNPRIVILEGED_USER       "nobody"
#define CHILD_HELD              'h'     /* the child says it holds the lock */
#define CHILD_OK                0       /* the child's exit status when its checks held */

struct fx {
        char dir[64];
};

static int setup(void **state)
{
        struct fx *f = calloc(1, sizeof(*f));

        if (!f)
                return -1;
        snprintf(f->dir, sizeof(f->dir), "/tmp/test_svc_lockfile.XXXXXX");
        if (!mkdtemp(f->dir) || chmod(f->dir, 0755) < 0)      /* others may look in */
                return -1;
        *state = f;
        return 0;
}

static int teardown(void **state)
{
        struct fx *f = *state;
        char cmd[128];

        snprintf(cmd, sizeof(cmd), "rm -rf '%s'", f->dir);
        if (system(cmd) != 0)
                return -1;
        free(f);
        return 0;
}

static void name_of(struct lockfile *l, const char *dir, const char *a, const char *b,
                    const char *c)
{
        const char *parts[] = { a, b, c };

        lockfile_init(l);
        assert_int_equal(lockfile_name(l, dir, parts, 3), 0);
}

/* Bytes other than letters, digits, _ and - are escaped, so that "a.b" and "a%2Eb" or
 * "x/y" cannot meet; a name too long for a file keeps its start and ends in a hash. */
static void test_names(void **state)
{
        struct lockfile l, m;
        char long_a[300], long_b[300];
        const char *base;

        (void)state;
        name_of(&l, "/run/sharedlink", "vehicle", "mqtt", "fleet/car.1");
        assert_string_equal(l.path, "/run/sharedlink/vehicle.mqtt.fleet%2Fcar%2E1.lock");
        name_of(&l, "/d", "i", "ros2", "/sharedlink/i");
        assert_string_equal(l.path, "/d/i.ros2.%2Fsharedlink%2Fi.lock");
        name_of(&l, "/d", "a.b", "c", "d");
        name_of(&m, "/d", "a", "b", "c.d");
        assert_string_not_equal(l.path, m.path);

        memset(long_a, 'x', sizeof(long_a) - 1);
        long_a[sizeof(long_a) - 1] = '\0';
        memcpy(long_b, long_a, sizeof(long_b));
        long_b[sizeof(long_b) - 2] = 'y';               /* differs only past the cut */
        name_of(&l, "/d", "i", "mqtt", long_a);
        name_of(&m, "/d", "i", "mqtt", long_b);
        base = strrchr(l.path, '/') + 1;
        assert_int_equal(strlen(base), LOCKFILE_NAME_MAX);
        assert_memory_equal(base, "i.mqtt.xxx", 10);
        assert_string_not_equal(l.path, m.path);
        name_of(&m, "/d", "i", "mqtt", long_a);         /* the same name: the same file */
        assert_string_equal(l.path, m.path);

        memset(long_a, '/', sizeof(long_a) - 1);        /* escaped: three times as long */
        name_of(&l, "/d", "i", "mqtt", long_a);
        assert_int_equal(strlen(strrchr(l.path, '/') + 1), LOCKFILE_NAME_MAX);
}

/* Forks a child that takes l, tells the parent over a pipe once it holds it, and exits when the
 * parent closes the other pipe (*wr_back); returns its pid, the first pipe's read end in *rd. */
static pid_t child_holding(struct lockfile *l, int *rd, int *wr_back)
{
        int up[2], down[2];
        pid_t pid;
        char c = CHILD_HELD;

        assert_int_equal(pipe2(up, O_CLOEXEC), 0);
        assert_int_equal(pipe2(down, O_CLOEXEC), 0);
        pid = fork();
        assert_true(pid >= 0);
        if (pid == 0) {
                close(up[0]);
                close(down[1]);
                if (lockfile_take(l, NULL) != 0 || write(up[1], &c, 1) != 1)
                        _exit(1);
                (void)read(down[0], &c, 1);             /* until the parent lets go */
                _exit(CHILD_OK);
        }
        close(up[1]);
        close(down[0]);
        assert_int_equal(read(up[0], &c, 1), 1);
        assert_int_equal(c, CHILD_HELD);
        *rd = up[0];
        *wr_back = down[1];
        return pid;
}

/* One holder at a time; the one refused learns the holder's pid; a holder killed with SIGKILL
 * (no cleanup of any kind) leaves the lock to the next at once; a release too. */
static void test_one_holder(void **state)
{
        struct fx *f = *state;
        struct lockfile l, mine;
        int rd, wr, st;
        pid_t pid, holder = -1;

        name_of(&l, f->dir, "inst", "mqtt", "sharedlink/inst");
        mine = l;
        pid = child_holding(&l, &rd, &wr);
        assert_int_equal(lockfile_take(&mine, &holder), -EBUSY);
        assert_int_equal(holder, pid);
        assert_int_equal(mine.fd, -1);

        assert_int_equal(kill(pid, SIGKILL), 0);
        assert_int_equal(waitpid(pid, &st, 0), pid);
        assert_true(WIFSIGNALED(st));
        close(rd);
        close(wr);
        assert_int_equal(lockfile_take(&mine, &holder), 0);
        assert_true(mine.fd >= 0);
        assert_int_equal(lockfile_take(&mine, &holder), 0);    /* held already: no change */

        /* Now the parent holds it: a child is refused, then takes it after the release. */
        pid = fork();
        assert_true(pid >= 0);
        if (pid == 0) {
                struct lockfile c = l;
                pid_t h = 0;

                _exit(lockfile_take(&c, &h) == -EBUSY && h == getppid() ? CHILD_OK : 1);
        }
        assert_int_equal(waitpid(pid, &st, 0), pid);
        assert_true(WIFEXITED(st) && WEXITSTATUS(st) == CHILD_OK);
        lockfile_release(&mine);
        assert_int_equal(mine.fd, -1);
        lockfile_release(&mine);                                /* twice: nothing */
        pid = child_holding(&l, &rd, &wr);
        close(wr);                                              /* it ends, releasing */
        assert_int_equal(waitpid(pid, &st, 0), pid);
        assert_true(WIFEXITED(st) && WEXITSTATUS(st) == CHILD_OK);
        close(rd);
        assert_int_equal(lockfile_take(&mine, NULL), 0);
        lockfile_release(&mine);
}

/* The file is made 0644 and missing directories 0755, whatever the umask; never removed. */
static void test_made_whatever_the_umask(void **state)
{
        struct fx *f = *state;
        char dir[128];
        struct lockfile l;
        struct stat st;
        mode_t old = umask(077);

        snprintf(dir, sizeof(dir), "%s/run/sub", f->dir);
        name_of(&l, dir, "inst", "ros2", "0");
        assert_int_equal(lockfile_take(&l, NULL), 0);
        umask(old);
        assert_int_equal(stat(l.path, &st), 0);
        assert_int_equal(st.st_mode & 07777, LOCKFILE_MODE);
        assert_int_equal(stat(dir, &st), 0);
        assert_int_equal(st.st_mode & 07777, LOCKFILE_DIR_MODE);
        lockfile_release(&l);
        assert_int_equal(stat(l.path, &st), 0);                 /* left for the next */
}

/* In a child: drops to pw's user for good (groups included); exits 2 when it cannot. */
static void become(const struct passwd *pw)
{
        if (setgroups(0, NULL) < 0 || setresgid(pw->pw_gid, pw->pw_gid, pw->pw_gid) < 0 ||
            setresuid(pw->pw_uid, pw->pw_uid, pw->pw_uid) < 0)
                _exit(2);
}

static void wait_child_ok(pid_t pid)
{
        int st;

        assert_int_equal(waitpid(pid, &st, 0), pid);
        assert_true(WIFEXITED(st));
        assert_int_equal(WEXITSTATUS(st), CHILD_OK);
}

/*
 * Run as root: root's daemon made the file (run by hand) and holds it; the service's user
 * (here nobody), who cannot write the file nor make one in root's directory, is refused with
 * root's pid, and takes the lock once root let go. A name nobody may make is -EACCES.
 */
static void test_other_user(void **state)
{
        struct fx *f = *state;
        struct passwd *pw = getpwnam(UNPRIVILEGED_USER);
        struct lockfile l, c, other;
        pid_t pid, parent = getpid(), h = 0;

        if (geteuid() != 0 || !pw) {
                print_message("not root, or no user " UNPRIVILEGED_USER ": skipped\n");
                skip();
        }
        name_of(&l, f->dir, "inst", "agility", "agility");
        name_of(&other, f->dir, "inst", "agility", "other");
        c = l;                                  /* the child's: not held */
        assert_int_equal(lockfile_take(&l, NULL), 0);
        pid = fork();
        assert_true(pid >= 0);
        if (pid == 0) {
                become(pw);
                _exit(lockfile_take(&c, &h) == -EBUSY && h == parent &&
                      lockfile_take(&other, NULL) == -EACCES ? CHILD_OK : 1);
        }
        wait_child_ok(pid);
        lockfile_release(&l);
        pid = fork();
        assert_true(pid >= 0);
        if (pid == 0) {
                become(pw);
                _exit(lockfile_take(&c, NULL) == 0 ? CHILD_OK : 1);
        }
        wait_child_ok(pid);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_names),
                cmocka_unit_test_setup_teardown(test_one_holder, setup, teardown),
                cmocka_unit_test_setup_teardown(test_made_whatever_the_umask, setup, teardown),
                cmocka_unit_test_setup_teardown(test_other_user, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
