/*
 * Helpers for shared-memory tests (see shmtest.h).
 */
#define _GNU_SOURCE     /* setgroups */
#include "common/shmtest.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <grp.h>
#include <inttypes.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
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

const struct shm_link_def shmtest_links[SHMTEST_NLINKS] = {
        { "vehicle", "sharedlink" },
        { "agility", "circe" },
};

void shmtest_table_init(struct shmtest_table *f, const char *tag)
{
        memset(f, 0, sizeof(*f));
        shmtest_instance(f->instance, sizeof(f->instance), tag);
        shm_layout_object_name(f->instance, "in", f->in_name, sizeof(f->in_name));
        shm_layout_object_name(f->instance, "out", f->out_name, sizeof(f->out_name));
}

void shmtest_table_config(struct shmtest_table *f, const struct shm_var *vars, uint32_t nvars,
                          uint32_t adhoc)
{
        memset(&f->cfg, 0, sizeof(f->cfg));
        f->cfg.instance = f->instance;
        f->cfg.vars = vars;
        f->cfg.nvars = nvars;
        f->cfg.links = shmtest_links;
        f->cfg.nlinks = SHMTEST_NLINKS;
        f->cfg.adhoc_capacity = adhoc;
        f->cfg.event_capacity = SHMTEST_EVENTS;
}

int shmtest_table_create(struct shmtest_table *f)
{
        return shm_table_create(&f->cfg, &f->t);
}

void shmtest_table_destroy(struct shmtest_table *f)
{
        f->t = shm_table_destroy(f->t);
        shmtest_unlink(f->instance);
}

int shmtest_table_strings(const char *instance, const char *prefix, unsigned direction,
                          unsigned n, struct shm_table **ret)
{
        return shmtest_table_strings_beat(instance, prefix, direction, n, 0, ret);
}

int shmtest_table_strings_beat(const char *instance, const char *prefix, unsigned direction,
                               unsigned n, uint32_t heartbeat_ms, struct shm_table **ret)
{
        char names[SHMTEST_STRINGS_MAX][SHM_NAME_SIZE];   /* copied by shm_table_create */
        struct shm_var vars[SHMTEST_STRINGS_MAX];
        struct shm_table_config cfg;

        if (n > SHMTEST_STRINGS_MAX)
                return -EINVAL;
        for (unsigned i = 0; i < n; i++) {
                snprintf(names[i], sizeof(names[i]), "%s%u", prefix, i);
                vars[i] = (struct shm_var){ names[i], direction, SHM_TYPE_STRING, SHM_LINK_NONE,
                                            NULL, SHM_POSITION_NONE };
        }
        memset(&cfg, 0, sizeof(cfg));
        cfg.instance = instance;
        cfg.vars = vars;
        cfg.nvars = n;
        cfg.heartbeat_interval_ms = heartbeat_ms;
        return shm_table_create(&cfg, ret);
}

struct shmtest_view shmtest_view_open(const char *name, bool writable)
{
        struct shmtest_view v = { NULL, 0 };
        struct stat st;
        int fd = shm_open(name, writable ? O_RDWR : O_RDONLY, 0);

        if (fd < 0)
                return v;
        if (fstat(fd, &st) == 0 && st.st_size > 0) {
                v.base = mmap(NULL, (size_t)st.st_size, PROT_READ | (writable ? PROT_WRITE : 0),
                              MAP_SHARED, fd, 0);
                v.size = (size_t)st.st_size;
                if (v.base == MAP_FAILED)
                        v.base = NULL;
        }
        close(fd);
        return v;
}

void shmtest_view_close(struct shmtest_view *v)
{
        if (v->base)
                munmap(v->base, v->size);
        v->base = NULL;
}

struct shm_in_header *shmtest_in_header(const struct shmtest_view *v)
{
        return v->base;
}

struct shm_dir_entry *shmtest_in_dir(const struct shmtest_view *v)
{
        return (struct shm_dir_entry *)((char *)v->base + shmtest_in_header(v)->dir_offset);
}

struct shm_slot *shmtest_in_slot(const struct shmtest_view *v, unsigned id)
{
        return (struct shm_slot *)((char *)v->base + shmtest_in_header(v)->slots_offset) + id;
}

struct shm_link *shmtest_in_link(const struct shmtest_view *v, unsigned link)
{
        return (struct shm_link *)((char *)v->base + shmtest_in_header(v)->links_offset) + link;
}

struct shm_slot *shmtest_out_slot(const struct shmtest_view *v, unsigned slot)
{
        return (struct shm_slot *)((char *)v->base + sizeof(struct shm_out_header)) + slot;
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

size_t shmtest_value_make(unsigned writer, uint64_t n, char *buf)
{
        size_t len = (size_t)snprintf(buf, SHM_VALUE_SIZE, "w%un%" PRIu64 ":", writer, n);
        size_t target = 24 + (size_t)(n % 36);
        unsigned sum = 0;

        while (len < target) {
                buf[len] = (char)('a' + (n + len) % 26);
                len++;
        }
        for (size_t i = 0; i < len; i++)
                sum += (unsigned char)buf[i];
        snprintf(buf + len, SHM_VALUE_SIZE - len, "%02X", sum & 0xffu);
        return len + 2;
}

int shmtest_value_ok(const char *v, size_t len)
{
        char expect[SHM_VALUE_SIZE];
        unsigned writer;
        uint64_t n;

        if (len >= SHM_VALUE_SIZE || sscanf(v, "w%un%" SCNu64 ":", &writer, &n) != 2)
                return 0;
        return shmtest_value_make(writer, n, expect) == len && memcmp(expect, v, len) == 0;
}

int shmtest_thread_state(const char *comm)
{
        DIR *d = opendir("/proc/self/task");
        struct dirent *e;
        int state = -1;

        if (!d)
                return -1;
        while (state < 0 && (e = readdir(d))) {
                char path[300], buf[512], *p;
                size_t n;
                FILE *f;

                if (e->d_name[0] == '.')
                        continue;
                snprintf(path, sizeof(path), "/proc/self/task/%s/stat", e->d_name);
                f = fopen(path, "r");
                if (!f)
                        continue;       /* exited meanwhile */
                n = fread(buf, 1, sizeof(buf) - 1u, f);
                fclose(f);
                buf[n] = '\0';
                /* "tid (comm) S ...": comm may hold anything, so the last ')' ends it. */
                p = strrchr(buf, ')');
                if (!p || p[1] != ' ' || !strchr(buf, '('))
                        continue;
                *p = '\0';
                if (strcmp(strchr(buf, '(') + 1, comm) == 0)
                        state = (unsigned char)p[2];
        }
        closedir(d);
        return state;
}

int shmtest_thread_wait_asleep(const char *comm, int limit_ms)
{
        struct timespec start, now;

        clock_gettime(CLOCK_MONOTONIC, &start);
        while (shmtest_thread_state(comm) != 'S') {
                clock_gettime(CLOCK_MONOTONIC, &now);
                if ((now.tv_sec - start.tv_sec) * 1000L +
                    (now.tv_nsec - start.tv_nsec) / 1000000L > limit_ms)
                        return -1;
                sched_yield();
        }
        return 0;
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
