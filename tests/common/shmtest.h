/*
 * Helpers for tests of the shared-memory tables: unique instance names, cleanup, child processes
 * (real processes, exit status as the result), and running code as another user.
 */
#ifndef TESTS_SHMTEST_H
#define TESTS_SHMTEST_H

#include <stddef.h>
#include <sys/types.h>

#define SHMTEST_NOBODY          65534   /* uid/gid of nobody/nogroup on Debian */
#define SHMTEST_GROUP           54321   /* a group nobody is not in (need not exist) */

/* Writes an instance name unique to this process and call: "t<pid>-<tag>-<n>". */
void shmtest_instance(char *buf, size_t size, const char *tag);

/* Removes both shm objects of an instance (whatever state they are in). */
void shmtest_unlink(const char *instance);

/* Forks; the child runs fn(arg) and exits with its return value (0..255). Returns the pid. */
pid_t shmtest_fork(int (*fn)(void *arg), void *arg);

/* Waits for a child; returns its exit status, or 128 + signal number. */
int shmtest_wait(pid_t pid);

/*
 * Runs fn(arg) in a child as uid/gid with the given supplementary groups (ngroups may be 0) and
 * returns its exit status. Needs root.
 */
int shmtest_as_user(uid_t uid, gid_t gid, size_t ngroups, const gid_t *groups,
                    int (*fn)(void *arg), void *arg);

/* Size of the shm object called name ("/sharedlink.x.in"), or -errno. */
long shmtest_object_size(const char *name);

/* Mode bits (& 07777) and group of an shm object; 0 or -errno. */
int shmtest_object_mode(const char *name, unsigned *ret_mode, gid_t *ret_gid);

#endif
