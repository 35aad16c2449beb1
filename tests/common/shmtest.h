/*
 * Helpers for tests of the shared-memory tables: unique instance names, cleanup, a table fixture,
 * direct views of the objects as a client (or a rogue) maps them, child processes (real
 * processes, exit status as the result), and running code as another user.
 */
#ifndef TESTS_SHMTEST_H
#define TESTS_SHMTEST_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "shm/layout.h"
#include "shm/table.h"

#define SHMTEST_NOBODY          65534   /* uid/gid of nobody/nogroup on Debian */
#define SHMTEST_GROUP           54321   /* a group nobody is not in (need not exist) */
#define SHMTEST_INSTANCE_SIZE   64
#define SHMTEST_NLINKS          2
#define SHMTEST_EVENTS          16      /* event ring of the fixture's tables */
#define SHMTEST_STRINGS_MAX     64      /* variables of shmtest_table_strings() */

/* The links of the fixture's tables: 0 "vehicle" (sharedlink), 1 "agility" (circe). */
extern const struct shm_link_def shmtest_links[SHMTEST_NLINKS];

/* One table under a unique instance name, and the names of its two objects. */
struct shmtest_table {
        char instance[SHMTEST_INSTANCE_SIZE];
        char in_name[SHM_OBJECT_NAME_SIZE];
        char out_name[SHM_OBJECT_NAME_SIZE];
        struct shm_table_config cfg;
        struct shm_table *t;            /* NULL until created */
};

/* A direct mapping of a whole object. */
struct shmtest_view {
        void *base;                     /* NULL when the object could not be mapped */
        size_t size;
};

/* Writes an instance name unique to this process and call: "t<pid>-<tag>-<n>". */
void shmtest_instance(char *buf, size_t size, const char *tag);

/* Removes both shm objects of an instance (whatever state they are in). */
void shmtest_unlink(const char *instance);

/* A fresh instance name from tag (shmtest_instance), the object names, no table yet. */
void shmtest_table_init(struct shmtest_table *f, const char *tag);

/* Resets f->cfg to the fixture's table: vars (copied by shm_table_create, so they need only
 * outlive it), shmtest_links, adhoc ad hoc names, SHMTEST_EVENTS events. */
void shmtest_table_config(struct shmtest_table *f, const struct shm_var *vars, uint32_t nvars,
                          uint32_t adhoc);

/* Creates the table of f->cfg into f->t; 0 or -errno. */
int shmtest_table_create(struct shmtest_table *f);

/* Destroys f->t (if any) and removes both objects, whatever a test left them as. */
void shmtest_table_destroy(struct shmtest_table *f);

/* Creates a table of n string variables <prefix>0 .. <prefix>n-1, all of one direction, no
 * links (what the stress tests hammer); 0 or -errno (-EINVAL above SHMTEST_STRINGS_MAX). */
int shmtest_table_strings(const char *instance, const char *prefix, unsigned direction,
                          unsigned n, struct shm_table **ret);

/* shmtest_table_strings of a table whose daemon says it calls shm_table_out_scan every
 * heartbeat_ms (shm_table_config.heartbeat_interval_ms: what bounds a held slot's takeover). */
int shmtest_table_strings_beat(const char *instance, const char *prefix, unsigned direction,
                               unsigned n, uint32_t heartbeat_ms, struct shm_table **ret);

/* Maps the object called name whole (read-only, or read-write); base is NULL when it cannot. */
struct shmtest_view shmtest_view_open(const char *name, bool writable);

/* Unmaps a view (a NULL base is fine). */
void shmtest_view_close(struct shmtest_view *v);

/* Parts of a .in view, where its header says they are (a rogue header is taken as it is). */
struct shm_in_header *shmtest_in_header(const struct shmtest_view *v);
struct shm_dir_entry *shmtest_in_dir(const struct shmtest_view *v);
struct shm_slot *shmtest_in_slot(const struct shmtest_view *v, unsigned id);
struct shm_link *shmtest_in_link(const struct shmtest_view *v, unsigned link);

/* Slot `slot` of a .out view (the slots follow the header). */
struct shm_slot *shmtest_out_slot(const struct shmtest_view *v, unsigned slot);

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

/*
 * Self-checking values for the stress tests: "w<writer>n<n>:", filler, then two hex digits of the
 * byte sum of what precedes (26..63 bytes, wire charset). Writes the value for (writer, n) into
 * buf (SL_VALUE_SIZE bytes) and returns its length.
 */
size_t shmtest_value_make(unsigned writer, uint64_t n, char *buf);

/* 1 when v[0..len) is exactly a value shmtest_value_make can produce, else 0. */
int shmtest_value_ok(const char *v, size_t len);

/*
 * State letter (proc(5): 'R' running, 'S' sleeping, ...) of the thread of this process named comm
 * (pthread_setname_np), or -1 when there is none: how a test learns that a thread is asleep.
 */
int shmtest_thread_state(const char *comm);

/* Waits until the thread named comm sleeps ('S'), at most limit_ms (a hang guard); 0 or -1. */
int shmtest_thread_wait_asleep(const char *comm, int limit_ms);

/* Mode bits (& 07777) and group of an shm object; 0 or -errno. */
int shmtest_object_mode(const char *name, unsigned *ret_mode, gid_t *ret_gid);

#endif
