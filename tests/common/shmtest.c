/*
 * Helpers for shared-memory tests (see shmtest.h).
 */
#define _GNU_SOURCE     /* setgroups */
#include "common/shmtest.h"

#include <errno.h>
#include <fcntl.h>
#include <grp.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#define SHMTEST_SIGNAL_BASE     128

void shmtest_instance(char *buf, size_t size, const char *tag)
{
        static unsigned counter;

        snprintf(buf, size, "t%d-%s-%u", (int)getpid(), tag, counter++);
}

void shmtest_unlink(const char *instance)
{
        char name[128];

        snprintf(name, sizeof(name), "/sharedlink.%s.in", instance);
        shm_unlink(name);
        snprintf(name, sizeof(name), "/sharedlink.%s.out", instance);
        shm_unlink(name);
}

pid_t shmtest_fork(int (*fn)(void *arg), void *arg)
{
        pid_t pid;

        fflush(NULL);
        pid = fork();
        if (pid == 0)
                _exit(fn(arg) & 0xff);
        return pid;
}

int shmtest_wait(pid_t pid)
{
        int status;

        while (waitpid(pid, &status, 0) < 0)
                if (errno != EINTR)
                        return -1;
        if (WIFEXITED(status))
                return WEXITSTATUS(status);
        if (WIFSIGNALED(status))
                return SHMTEST_SIGNAL_BASE + WTERMSIG(status);
        return -1;
}

struct as_user {
        uid_t uid;
        gid_t gid;
        size_t ngroups;
        const gid_t *groups;
        int (*fn)(void *arg);
        void *arg;
};

static int as_user_child(void *arg)
{
        struct as_user *u = arg;

        /* Order matters: groups and gid while still root, the uid last. */
        if (setgroups(u->ngroups, u->groups) < 0 || setgid(u->gid) < 0 || setuid(u->uid) < 0)
                return 99;
        return u->fn(u->arg);
}

int shmtest_as_user(uid_t uid, gid_t gid, size_t ngroups, const gid_t *groups,
                    int (*fn)(void *arg), void *arg)
{
        struct as_user u = { uid, gid, ngroups, groups, fn, arg };

        return shmtest_wait(shmtest_fork(as_user_child, &u));
}

long shmtest_object_size(const char *name)
{
        struct stat st;
        int fd = shm_open(name, O_RDONLY, 0);
        long r;

        if (fd < 0)
                return -errno;
        r = fstat(fd, &st) < 0 ? -errno : (long)st.st_size;
        close(fd);
        return r;
}

int shmtest_object_mode(const char *name, unsigned *ret_mode, gid_t *ret_gid)
{
        struct stat st;
        int fd = shm_open(name, O_RDONLY, 0);
        int r;

        if (fd < 0)
                return -errno;
        r = fstat(fd, &st) < 0 ? -errno : 0;
        close(fd);
        if (r == 0) {
                *ret_mode = st.st_mode & 07777;
                *ret_gid = st.st_gid;
        }
        return r;
}
