/*
 * Handle-lock stress: reader threads share one client handle and read through it as fast as they
 * can while the "daemon" (a thread of this process, with the real table module) keeps forcing the
 * handle to refresh under its write lock: new ad hoc names (the id arrays grow and move), a
 * recreated .out (the old mapping is unmapped), and whole restarts (a new .in; the old one is
 * unmapped once the last reader is out). A reader inside the handle during any of that would read
 * freed or unmapped memory: AddressSanitizer (make check) or ThreadSanitizer (the tsan build)
 * reports it, or the process faults. Every value read is also checked for its form. (The reader
 * slots are not built under ThreadSanitizer, which does not model membarrier: there every reader
 * goes through the shared count.)
 *
 * Bounded by work, not by seconds: the daemon restarts RESTARTS times, and before each of its
 * steps (a name added, .out recreated, a restart) it waits until the readers finished another
 * batch of reads, so readers are inside the handle between every two refreshes however busy the
 * machine is (a 2 s run once made no refresh at all under ThreadSanitizer on a loaded machine).
 */
#include <errno.h>
#include <inttypes.h>
#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sharedlink.h>

#include "common/shmtest.h"
#include "lib/client.h"
#include "shm/table.h"

/* More readers than a handle has reader slots: some enter through their own slot (a plain
 * store, the writer's membarrier), the others, whose slot is taken, through the shared count. */
#define READERS                 ((int)CLIENT_READER_SLOTS + 4)
#define ADHOC                   64      /* names one table run adds before it restarts */
#define RESTARTS                6       /* table runs after the first */
#define BATCH                   64      /* reads of one reader between two progress marks */
#define VALUE_PREFIX            "value-"

enum { IN, OUT, NVARS };

struct shared {
        const char *instance;
        struct sl_client *c;
        _Atomic int done;               /* the daemon loop is over: readers stop */
        _Atomic uint64_t batches;       /* reader batches finished: the daemon's pace */
        _Atomic uint64_t reads;
        _Atomic uint64_t good;          /* reads that returned a well-formed value */
        _Atomic uint64_t bad;           /* reads that returned something else */
        _Atomic uint64_t refreshes;     /* names added + .out recreated + restarts */
        _Atomic uint64_t restarts;
};

/* Waits until the readers finished a batch after the one seen last (*seen). */
static void wait_readers(struct shared *sh, uint64_t *seen)
{
        uint64_t now;

        while ((now = atomic_load(&sh->batches)) == *seen)
                sched_yield();
        *seen = now;
}

static int create_table(const char *instance, uint64_t run, struct shm_table **ret)
{
        static const struct shm_var vars[NVARS] = {
                [IN] = { "In", SHM_DIR_IN, SHM_TYPE_STRING, SHM_LINK_NONE, NULL,
                         SHM_POSITION_NONE },
                [OUT] = { "Out", SHM_DIR_OUT, SHM_TYPE_STRING, SHM_LINK_NONE, NULL,
                          SHM_POSITION_NONE },
        };
        struct shm_table_config cfg = {
                .instance = instance, .vars = vars, .nvars = NVARS, .adhoc_capacity = ADHOC,
        };
        char value[SL_VALUE_SIZE];
        int r = shm_table_create(&cfg, ret);

        if (r < 0)
                return r;
        snprintf(value, sizeof(value), VALUE_PREFIX "%" PRIu64, run);
        return shm_table_set_str(*ret, IN, value);
}

/* The daemon's side: add names, recreate .out, restart, RESTARTS times, in step with readers. */
static int daemon_loop(struct shared *sh)
{
        struct shm_table *t;
        uint64_t run = 0, seen = 0;
        char name[SL_NAME_SIZE];

        if (create_table(sh->instance, run, &t) < 0)
                return -1;
        while (run < RESTARTS) {
                struct shm_var v = { name, SHM_DIR_IN, SHM_TYPE_STRING, SHM_LINK_NONE, NULL,
                                     SHM_POSITION_NONE };
                uint64_t n = atomic_fetch_add(&sh->refreshes, 1);
                int id;

                wait_readers(sh, &seen);

                snprintf(name, sizeof(name), "adhoc.%" PRIu64, n);
                id = shm_table_add(t, &v);
                if (id >= 0) {
                        shm_table_set_str(t, (uint32_t)id, VALUE_PREFIX "adhoc");
                        if (n % 8 == 0 && shm_table_out_recreate(t) < 0)
                                return -1;
                        continue;
                }
                if (id != -ENOSPC)
                        return -1;
                /* Ad hoc room used up: restart, as a new daemon would. */
                shm_table_destroy(t);
                run++;
                atomic_fetch_add(&sh->restarts, 1);
                if (create_table(sh->instance, run, &t) < 0)
                        return -1;
        }
        shm_table_destroy(t);
        return 0;
}

static void check(struct shared *sh, int r, const char *buf)
{
        if (r > 0 && strncmp(buf, VALUE_PREFIX, strlen(VALUE_PREFIX)) == 0)
                atomic_fetch_add_explicit(&sh->good, 1, memory_order_relaxed);
        else if (r > 0)         /* 0: not set yet in a table just made */
                atomic_fetch_add_explicit(&sh->bad, 1, memory_order_relaxed);
}

static void *reader_main(void *arg)
{
        struct shared *sh = arg;
        struct sl_meta meta = { .size = sizeof(meta) };
        char buf[SL_VALUE_SIZE], small[8], name[SL_NAME_SIZE];
        uint64_t reads = 0;

        while (!atomic_load(&sh->done)) {
                for (int i = 0; i < BATCH; i++, reads++) {
                        int count = sl_count(sh->c), r;

                        /* Both read paths (straight into buf, and through a copy) ... */
                        r = sl_read(sh->c, IN, buf, sizeof(buf), &meta);
                        check(sh, r, buf);
                        r = sl_read(sh->c, IN, small, sizeof(small), NULL);
                        if (r > 0 && strncmp(small, VALUE_PREFIX, 6) != 0)
                                atomic_fetch_add_explicit(&sh->bad, 1, memory_order_relaxed);
                        /* ... the .out slot, the id arrays, the name hash, the newest name. */
                        sl_read(sh->c, OUT, buf, sizeof(buf), NULL);
                        sl_write(sh->c, OUT, VALUE_PREFIX "out");
                        if (count > NVARS) {
                                r = sl_read(sh->c, count - 1, buf, sizeof(buf), NULL);
                                check(sh, r, buf);
                        }
                        snprintf(name, sizeof(name), "adhoc.%d", (int)(reads % ADHOC));
                        sl_find(sh->c, name);
                }
                atomic_fetch_add(&sh->batches, 1);
        }
        atomic_fetch_add(&sh->reads, reads);
        return NULL;
}

int main(void)
{
        struct shared sh;
        struct shm_table *t;
        pthread_t readers[READERS];
        char instance[64];
        int r, ok;

        memset(&sh, 0, sizeof(sh));
        shmtest_instance(instance, sizeof(instance), "handle");
        sh.instance = instance;
        /* A first table, so that the handle can open; the daemon loop then takes over. */
        if (create_table(instance, 0, &t) < 0 || sl_open(instance, &sh.c) < 0) {
                fprintf(stderr, "stress_handle: cannot create the tables\n");
                return 1;
        }
        shm_table_destroy(t);
        for (int i = 0; i < READERS; i++)
                pthread_create(&readers[i], NULL, reader_main, &sh);
        r = daemon_loop(&sh);
        atomic_store(&sh.done, 1);
        for (int i = 0; i < READERS; i++)
                pthread_join(readers[i], NULL);
        sl_close(sh.c);
        shmtest_unlink(instance);
        /* It proved something only if readers read while the handle was refreshed many times. */
        ok = r == 0 && atomic_load(&sh.bad) == 0 && atomic_load(&sh.good) > 0 &&
             atomic_load(&sh.restarts) == RESTARTS && atomic_load(&sh.refreshes) > ADHOC;
        printf("stress_handle: reads=%" PRIu64 " good=%" PRIu64 " bad=%" PRIu64
               " refreshes=%" PRIu64 " restarts=%" PRIu64 "\n", atomic_load(&sh.reads),
               atomic_load(&sh.good), atomic_load(&sh.bad), atomic_load(&sh.refreshes),
               atomic_load(&sh.restarts));
        printf("stress_handle: %s\n", ok ? "ok, no reader inside a refresh" : "FAILED");
        return ok ? 0 : 1;
}
