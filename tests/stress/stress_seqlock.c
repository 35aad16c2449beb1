/*
 * Seqlock stress: one writer keeps updating inbound values that carry their own check (the value
 * is derived from a counter k written inside it, the time stamps are k too), while readers read
 * through the library as fast as they can. Any torn read (value not matching its own counter,
 * value not matching its time stamps, a counter going backwards) is counted and fails the test.
 *
 * Phase 1: writer and readers are separate processes over the real shm objects.
 * Phase 2: the same with threads in one process (what ThreadSanitizer can see), readers sharing
 *          one client handle and using another.
 * Phase 3: outbound values: writer processes write them with sl_write (several writers, the
 *          same slots), reader processes read them back through the library: no torn value;
 *          the reads that still ended in -EAGAIN (a writer off its CPU mid-write for longer
 *          than the library's backoff) are counted.
 * Bounded by work, not by seconds: each reader reads until it has made READS_MIN reads and seen
 * the values move CHANGES_MIN times (so it raced with the writer however slowly either ran);
 * the writers write until the readers are done. Each phase prints its counts.
 */
#include <errno.h>
#include <inttypes.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <sharedlink.h>

#include "common/shmtest.h"
#include "shm/seqlock.h"
#include "shm/table.h"

#define NVALUES                 8
#define READER_PROCESSES        3
#define READER_THREADS          3
#if defined(SHM_SEQLOCK_TSAN)
#define READS_MIN               50000u  /* per reader: ThreadSanitizer is ~10x slower */
#else
#define READS_MIN               200000u /* per reader */
#endif
#define CHANGES_MIN             1000u   /* newer values seen, per reader */
#define OUT_WRITERS             2
#define COUNTER_DIGITS          20

struct stats {
        _Atomic uint64_t reads;
        _Atomic uint64_t torn;
        _Atomic uint64_t eagain;
        _Atomic uint64_t changes;       /* reads that saw a newer counter than the last one */
        _Atomic uint64_t writes;
};

struct shared {
        _Atomic int stop;
        struct stats s;
};

/* The value for counter k: 20 digits, '-', then k-derived filler; 21..63 bytes long. */
static size_t make_value(uint64_t k, char *buf)
{
        size_t len = 21 + (size_t)(k % 43);

        snprintf(buf, SL_VALUE_SIZE, "%0*" PRIu64 "-", COUNTER_DIGITS, k);
        for (size_t i = COUNTER_DIGITS + 1; i < len; i++)
                buf[i] = (char)('A' + (k * 7 + i) % 26);
        buf[len] = '\0';
        return len;
}

/* Checks one read (and its time stamps, with m); returns the counter, or UINT64_MAX when the read
 * is inconsistent. */
static uint64_t check_value(int id, const char *v, int len, const struct sl_meta *m)
{
        char expect[SL_VALUE_SIZE];
        uint64_t k;
        char *end;

        if (len < COUNTER_DIGITS + 1)
                return UINT64_MAX;
        k = strtoull(v, &end, 10);
        if (end != v + COUNTER_DIGITS || (int)(k % NVALUES) != id)
                return UINT64_MAX;
        if ((int)make_value(k, expect) != len || strcmp(expect, v) != 0)
                return UINT64_MAX;
        if (m && (m->mono_ns != k || m->real_ns != 3 * k || !(m->flags & SL_FLAG_VALID)))
                return UINT64_MAX;
        return k;
}

static void writer_loop(struct shm_table *t, const _Atomic int *stop, struct stats *s)
{
        char value[SL_VALUE_SIZE];

        for (uint64_t k = NVALUES; !atomic_load_explicit(stop, memory_order_relaxed); k++) {
                size_t len = make_value(k, value);

                /* Time stamps = k: a reader checks they belong to the value it got. */
                shm_table_begin_at(t, k, 3 * k);
                shm_table_set(t, (uint32_t)(k % NVALUES), value, len);
                shm_table_commit(t);
                atomic_fetch_add_explicit(&s->writes, 1, memory_order_relaxed);
        }
}

/* Reads until READS_MIN reads saw CHANGES_MIN changes; every value is checked, and (one writer,
 * monotonic) counters never go backwards. */
static void reader_loop(struct sl_client *c, int monotonic, struct stats *s)
{
        struct sl_meta meta = { .size = sizeof(meta) };
        uint64_t last[NVALUES] = { 0 };
        uint64_t reads = 0, torn = 0, eagain = 0, changes = 0;
        char buf[SL_VALUE_SIZE];

        while (reads < READS_MIN || changes < CHANGES_MIN) {
                for (int round = 0; round < 256; round++) {
                        int id = (int)(reads % NVALUES);
                        int len = sl_read(c, id, buf, sizeof(buf), &meta);
                        uint64_t k;

                        reads++;
                        if (len == -EAGAIN) {
                                eagain++;
                                continue;
                        }
                        if (len == 0 && !(meta.flags & SL_FLAG_VALID))
                                continue;       /* not written yet */
                        k = len < 0 ? UINT64_MAX : check_value(id, buf, len, monotonic ? &meta :
                                                                NULL);
                        if (k == UINT64_MAX || (monotonic && k < last[id])) {
                                torn++;
                                continue;
                        }
                        if (k != last[id])
                                changes++;
                        last[id] = k;
                }
        }
        atomic_fetch_add(&s->reads, reads);
        atomic_fetch_add(&s->torn, torn);
        atomic_fetch_add(&s->eagain, eagain);
        atomic_fetch_add(&s->changes, changes);
}

/* ---- phase 1: processes ---------------------------------------------------------------------- */

struct proc_arg {
        struct shared *sh;
        struct shm_table *t;
        const char *instance;
        unsigned writer;                /* phase 3: which writer this is */
};

static int writer_process(void *arg)
{
        struct proc_arg *a = arg;

        writer_loop(a->t, &a->sh->stop, &a->sh->s);
        return 0;
}

static int reader_process(void *arg)
{
        struct proc_arg *a = arg;
        struct sl_client *c;

        if (sl_open(a->instance, &c) < 0)
                return 1;
        reader_loop(c, a->t != NULL, &a->sh->s);
        sl_close(c);
        return 0;
}

static int phase_processes(const char *instance, struct stats *ret)
{
        struct shared *sh = mmap(NULL, sizeof(*sh), PROT_READ | PROT_WRITE,
                                 MAP_SHARED | MAP_ANONYMOUS, -1, 0);
        struct proc_arg a;
        pid_t writer, readers[READER_PROCESSES];
        int bad = 0;

        if (sh == MAP_FAILED)
                return -1;
        memset(sh, 0, sizeof(*sh));
        a.sh = sh;
        a.instance = instance;
        if (shmtest_table_strings(instance, "v", SHM_DIR_IN, NVALUES, &a.t) < 0)
                return -1;
        writer = shmtest_fork(writer_process, &a);
        for (int i = 0; i < READER_PROCESSES; i++)
                readers[i] = shmtest_fork(reader_process, &a);
        for (int i = 0; i < READER_PROCESSES; i++)
                bad |= shmtest_wait(readers[i]) != 0;
        atomic_store(&sh->stop, 1);
        bad |= shmtest_wait(writer) != 0;
        shm_table_destroy(a.t);
        memcpy(ret, &sh->s, sizeof(*ret));
        munmap(sh, sizeof(*sh));
        return bad ? -1 : 0;
}

/* ---- phase 2: threads --------------------------------------------------------------------------- */

struct thread_arg {
        struct shared *sh;
        struct shm_table *t;
        struct sl_client *c;
};

static void *writer_thread(void *arg)
{
        struct thread_arg *a = arg;

        writer_loop(a->t, &a->sh->stop, &a->sh->s);
        return NULL;
}

static void *reader_thread(void *arg)
{
        struct thread_arg *a = arg;

        reader_loop(a->c, 1, &a->sh->s);
        return NULL;
}

static int phase_threads(const char *instance, struct stats *ret)
{
        struct shared sh;
        struct thread_arg w, r[READER_THREADS];
        struct sl_client *shared_client, *own_client;
        pthread_t wt, rt[READER_THREADS];

        memset(&sh, 0, sizeof(sh));
        memset(&w, 0, sizeof(w));
        w.sh = &sh;
        if (shmtest_table_strings(instance, "v", SHM_DIR_IN, NVALUES, &w.t) < 0)
                return -1;
        if (sl_open(instance, &shared_client) < 0 || sl_open(instance, &own_client) < 0)
                return -1;
        pthread_create(&wt, NULL, writer_thread, &w);
        for (int i = 0; i < READER_THREADS; i++) {
                r[i] = w;
                /* Two threads share one handle (thread-safe readers), one has its own. */
                r[i].c = i == 0 ? own_client : shared_client;
                pthread_create(&rt[i], NULL, reader_thread, &r[i]);
        }
        for (int i = 0; i < READER_THREADS; i++)
                pthread_join(rt[i], NULL);
        atomic_store(&sh.stop, 1);
        pthread_join(wt, NULL);
        sl_close(shared_client);
        sl_close(own_client);
        shm_table_destroy(w.t);
        memcpy(ret, &sh.s, sizeof(*ret));
        return 0;
}

/* ---- phase 3: outbound values, several writers ---------------------------------------------- */

static int out_writer_process(void *arg)
{
        struct proc_arg *a = arg;
        char value[SL_VALUE_SIZE];
        struct sl_client *c;

        if (sl_open(a->instance, &c) < 0)
                return 1;
        /* Counter k of writer w: k = n * OUT_WRITERS + w, for variable k % NVALUES. */
        for (uint64_t k = NVALUES + a->writer; !atomic_load_explicit(&a->sh->stop,
                                                                    memory_order_relaxed);
             k += OUT_WRITERS) {
                make_value(k, value);
                if (sl_write(c, (int)(k % NVALUES), value) == 0)
                        atomic_fetch_add_explicit(&a->sh->s.writes, 1, memory_order_relaxed);
        }
        sl_close(c);
        return 0;
}

static int phase_outbound(const char *instance, struct stats *ret)
{
        struct shared *sh = mmap(NULL, sizeof(*sh), PROT_READ | PROT_WRITE,
                                 MAP_SHARED | MAP_ANONYMOUS, -1, 0);
        struct proc_arg a[OUT_WRITERS], r;
        struct shm_table *t;
        pid_t writers[OUT_WRITERS], readers[READER_PROCESSES];
        int bad = 0;

        if (sh == MAP_FAILED)
                return -1;
        memset(sh, 0, sizeof(*sh));
        if (shmtest_table_strings(instance, "o", SHM_DIR_OUT, NVALUES, &t) < 0)
                return -1;
        r = (struct proc_arg){ sh, NULL, instance, 0 };         /* t NULL: no time stamp check */
        for (int i = 0; i < OUT_WRITERS; i++) {
                a[i] = (struct proc_arg){ sh, NULL, instance, (unsigned)i };
                writers[i] = shmtest_fork(out_writer_process, &a[i]);
        }
        for (int i = 0; i < READER_PROCESSES; i++)
                readers[i] = shmtest_fork(reader_process, &r);
        for (int i = 0; i < READER_PROCESSES; i++)
                bad |= shmtest_wait(readers[i]) != 0;
        atomic_store(&sh->stop, 1);
        for (int i = 0; i < OUT_WRITERS; i++)
                bad |= shmtest_wait(writers[i]) != 0;
        shm_table_destroy(t);
        memcpy(ret, &sh->s, sizeof(*ret));
        munmap(sh, sizeof(*sh));
        return bad ? -1 : 0;
}

static int report(const char *phase, int r, const struct stats *s)
{
        uint64_t reads = atomic_load(&s->reads), torn = atomic_load(&s->torn);
        uint64_t writes = atomic_load(&s->writes), changes = atomic_load(&s->changes);

        printf("stress_seqlock %s: reads=%" PRIu64 " torn=%" PRIu64 " eagain=%" PRIu64
               " changes_seen=%" PRIu64 " writes=%" PRIu64 "\n", phase, reads, torn,
               atomic_load(&s->eagain), changes, writes);
        /* Fails on any torn read; the readers' bounds make sure they raced with the writers.
         * eagain is a figure, not a verdict: a read ends in -EAGAIN only when a writer stayed
         * off its CPU mid-write through the library's backoff (SL_READ_BUSY_MS), which is the
         * scheduler's doing (without the backoff it was 2-5% of the outbound reads on a 2-vCPU
         * VM, with it none in the ASan build; test_lib checks the backoff itself). */
        return r == 0 && torn == 0 && reads > 0 && writes > 0 && changes > NVALUES ? 0 : 1;
}

int main(void)
{
        static const struct {
                const char *name;
                int (*run)(const char *instance, struct stats *ret);
        } phases[] = {
                { "processes", phase_processes },
                { "threads", phase_threads },
                { "outbound", phase_outbound },
        };
        char instance[64];
        struct stats s;
        int failed = 0;

        for (size_t i = 0; i < sizeof(phases) / sizeof(phases[0]); i++) {
                int r;

                shmtest_instance(instance, sizeof(instance), "stress");
                r = phases[i].run(instance, &s);
                failed |= report(phases[i].name, r, &s);
                shmtest_unlink(instance);
        }
        printf("stress_seqlock: %s\n", failed ? "FAILED" : "ok, zero torn reads");
        return failed;
}
