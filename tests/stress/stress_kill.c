/*
 * Kill stress: a client writing outbound values is killed with SIGKILL at a random point of its
 * writes, again and again. After each kill the daemon side scans .out: a slot the dead writer left
 * odd must be repaired at once (none stays wedged: every lock word is even after the scan, and the
 * next writer gets every slot), and no half-written value is ever accepted by the daemon or read
 * as valid by a reader process that reads all the time through the library.
 *
 * Writers alternate between the library (sl_write) and a deliberately slow raw writer that stores
 * the value word by word, yielding in between, so that many kills land inside a write.
 * Runs KILL_ITERATIONS kills (default 1000, 300 under ThreadSanitizer), however long that takes: bounded by work, not by
 * seconds, so a busy machine makes it slower, never weaker (each kill waits for its writer's
 * progress on the .out change word, an event).
 */
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <sched.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include <sharedlink.h>

#include "common/shmtest.h"
#include "shm/futex.h"
#include "shm/seqlock.h"
#include "shm/slot.h"
#include "shm/table.h"

#define NVARS                   4
#if defined(SHM_SEQLOCK_TSAN)
#define DEFAULT_ITERATIONS      300     /* ThreadSanitizer: each kill costs ~10x */
#else
#define DEFAULT_ITERATIONS      1000
#endif
#define WAIT_LIMIT_MS           10000

struct shared {
        _Atomic int stop;
        _Atomic uint64_t reads;
        _Atomic uint64_t valid_reads;
        _Atomic uint64_t torn;
};

/* ---- the writer that gets killed --------------------------------------------------------------- */

struct writer_arg {
        const char *instance;
        unsigned index;
        int slow;
};

static int writer_main(void *arg)
{
        struct writer_arg *w = arg;
        char value[SL_VALUE_SIZE], name[SHM_OBJECT_NAME_SIZE];
        struct shmtest_view v = { NULL, 0 };
        struct sl_client *c;
        struct shm_out_header *h = NULL;
        struct shm_slot *slots = NULL;

        if (sl_open(w->instance, &c) < 0)
                return 1;
        if (w->slow) {
                /* a rogue's own mapping of .out, as any client could make it */
                shm_layout_object_name(w->instance, "out", name, sizeof(name));
                v = shmtest_view_open(name, true);
                if (!v.base)
                        return 2;
                h = v.base;
                slots = shmtest_out_slot(&v, 0);
        }
        for (uint64_t n = 0;; n++) {
                unsigned id = (unsigned)((n * 7 + w->index) % NVARS);
                size_t len = shmtest_value_make(w->index, n, value);
                uint64_t word, words[SHM_VALUE_WORDS];

                if (!w->slow) {
                        if (sl_write(c, (int)id, value) < 0)
                                return 4;
                        continue;
                }
                /* By hand, slowly: the odd window spans several yields. */
                if (shm_slot_claim(&slots[id], (uint32_t)getpid(), &word) < 0)
                        return 5;
                memset(words, 0, sizeof(words));
                memcpy(words, value, len);
                atomic_store_explicit(&slots[id].length, (uint32_t)len, memory_order_relaxed);
                for (unsigned i = 0; i < SHM_VALUE_WORDS; i++) {
                        shm_slot_store_word(&slots[id], i, words[i]);
                        sched_yield();
                }
                atomic_store_explicit(&slots[id].flags, SHM_SLOT_VALID | SHM_SLOT_OUTBOUND,
                                      memory_order_relaxed);
                if (shm_slot_publish(&slots[id], word) < 0)
                        return 6;
                /* As sl_write does (layout 1.6): mark, then the step wait_progress counts. */
                atomic_fetch_or((_Atomic uint64_t *)(void *)((char *)h + h->touched_offset),
                                UINT64_C(1) << id);
                atomic_fetch_add(&h->change, SHM_OUT_CHANGE_TOUCHED);
                shm_futex_wake(&h->change, 1);
        }
}

/* ---- a reader that never stops reading --------------------------------------------------------- */

struct reader_arg {
        const char *instance;
        struct shared *sh;
};

static int reader_main(void *arg)
{
        struct reader_arg *r = arg;
        struct sl_meta meta = { .size = sizeof(meta) };
        uint64_t reads = 0, valid = 0, torn = 0;
        char buf[SL_VALUE_SIZE];
        struct sl_client *c;

        if (sl_open(r->instance, &c) < 0)
                return 1;
        while (!atomic_load_explicit(&r->sh->stop, memory_order_relaxed)) {
                int len = sl_read(c, (int)(reads % NVARS), buf, sizeof(buf), &meta);

                reads++;
                if (len < 0 || !(meta.flags & SL_FLAG_VALID))
                        continue;       /* busy, or no valid value: nothing handed out */
                valid++;
                if (!shmtest_value_ok(buf, (size_t)len))
                        torn++;
        }
        atomic_fetch_add(&r->sh->reads, reads);
        atomic_fetch_add(&r->sh->valid_reads, valid);
        atomic_fetch_add(&r->sh->torn, torn);
        sl_close(c);
        return 0;
}

/* ---- the daemon side ------------------------------------------------------------------------------ */

struct scan_stats {
        uint64_t accepted;
        uint64_t repaired;
        uint64_t bad;           /* an accepted value that is not a complete value: must stay 0 */
        uint64_t invalid;       /* writers only write valid values: must stay 0 */
};

static void on_change(void *userdata, const struct shm_out_change *ch)
{
        struct scan_stats *s = userdata;

        switch (ch->status) {
        case SHM_OUT_CHANGED:
                s->accepted++;
                if (!shmtest_value_ok(ch->value, ch->length))
                        s->bad++;
                break;
        case SHM_OUT_REPAIRED:
                s->repaired++;
                break;
        case SHM_OUT_INVALID:
                s->invalid++;
                break;
        }
}

/* Waits (on the futex, not a clock) until writers bumped the .out change word `steps` times. */
/*
 * Waits for `steps` more writes. Writers wake a sleeper only when it set SHM_OUT_WAITING (layout
 * 1.1), so this waiter sets it before each sleep as the daemon's wake thread does.
 */
static int wait_progress(struct shm_out_header *h, unsigned steps)
{
        uint32_t start = atomic_load(&h->change) & ~SHM_OUT_WAITING, seen;

        /* Every writer adds SHM_OUT_CHANGE_TOUCHED (layout 1.6): whole steps of the high half. */
        while ((((seen = atomic_load(&h->change)) & ~SHM_OUT_WAITING) - start) /
               SHM_OUT_CHANGE_TOUCHED < steps) {
                if (!(seen & SHM_OUT_WAITING) &&
                    !atomic_compare_exchange_strong(&h->change, &seen, seen | SHM_OUT_WAITING))
                        continue;       /* a write came in between: count it */
                if (shm_futex_wait(&h->change, seen | SHM_OUT_WAITING, WAIT_LIMIT_MS) ==
                    -ETIMEDOUT)
                        return -1;
        }
        return 0;
}

static int all_even(const struct shm_slot *slots)
{
        for (unsigned i = 0; i < NVARS; i++)
                if (shm_seqlock_odd(shm_slot_word(&slots[i])))
                        return 0;
        return 1;
}

static unsigned env_unsigned(const char *name, unsigned def)
{
        const char *v = getenv(name);
        unsigned long n = v ? strtoul(v, NULL, 10) : 0;

        return n ? (unsigned)n : def;
}

int main(void)
{
        unsigned iterations = env_unsigned("KILL_ITERATIONS", DEFAULT_ITERATIONS);
        struct shared *sh = mmap(NULL, sizeof(*sh), PROT_READ | PROT_WRITE,
                                 MAP_SHARED | MAP_ANONYMOUS, -1, 0);
        char instance[64], name[SHM_OBJECT_NAME_SIZE];
        struct scan_stats st = { 0, 0, 0, 0 };
        struct reader_arg ra;
        struct shm_table *t;
        struct shmtest_view view;
        struct shm_out_header *h;
        unsigned kills = 0, wedged = 0, stuck = 0, final_fail = 0;
        struct sl_client *c;
        pid_t reader;
        int failed;

        srand((unsigned)getpid());
        shmtest_instance(instance, sizeof(instance), "kill");
        if (sh == MAP_FAILED || shmtest_table_strings(instance, "o", SHM_DIR_OUT, NVARS, &t) < 0)
                return 2;
        memset(sh, 0, sizeof(*sh));
        shm_layout_object_name(instance, "out", name, sizeof(name));
        view = shmtest_view_open(name, true);   /* read-write: wait_progress sets the flag */
        if (!view.base)
                return 2;
        h = view.base;
        ra = (struct reader_arg){ instance, sh };
        reader = shmtest_fork(reader_main, &ra);

        for (; kills < iterations; kills++) {
                struct writer_arg w = { instance, kills, (int)(kills & 1u) };
                pid_t pid = shmtest_fork(writer_main, &w);

                /* Let it get going for a random number of writes, then kill it mid-stride
                 * (fewer for the slow writer: each of its writes yields the CPU eight times). */
                if (wait_progress(h, 1u + (unsigned)rand() % (w.slow ? 6u : 40u)) < 0)
                        stuck++;
                kill(pid, SIGKILL);
                if (shmtest_wait(pid) != 128 + SIGKILL)
                        stuck++;
                shm_table_out_scan(t, on_change, &st);
                if (!all_even((const struct shm_slot *)(h + 1)))
                        wedged++;
        }

        /* Every slot still takes a write (nothing wedged), and the daemon accepts it. */
        if (sl_open(instance, &c) == 0) {
                for (int i = 0; i < NVARS; i++) {
                        char v[SL_VALUE_SIZE];

                        shmtest_value_make(9999, (uint64_t)i, v);
                        final_fail += sl_write(c, i, v) != 0;
                }
                sl_close(c);
        } else {
                final_fail = NVARS;
        }
        uint64_t before = st.accepted;
        shm_table_out_scan(t, on_change, &st);
        final_fail += st.accepted - before != NVARS;

        atomic_store(&sh->stop, 1);
        failed = shmtest_wait(reader) != 0;
        failed |= st.bad || st.invalid || wedged || stuck || final_fail || atomic_load(&sh->torn);
        /* A run in which no kill landed inside a write proved nothing about repair. */
        failed |= st.repaired == 0 || atomic_load(&sh->valid_reads) == 0;
        printf("stress_kill: kills=%u repaired=%" PRIu64 " accepted=%" PRIu64 " bad=%" PRIu64
               " invalid=%" PRIu64 " wedged=%u stuck=%u final_write_failures=%u\n",
               kills, st.repaired, st.accepted, st.bad, st.invalid, wedged, stuck, final_fail);
        printf("stress_kill: reader reads=%" PRIu64 " valid=%" PRIu64 " torn=%" PRIu64 "\n",
               atomic_load(&sh->reads), atomic_load(&sh->valid_reads), atomic_load(&sh->torn));
        printf("stress_kill: %s\n", failed ? "FAILED" : "ok, nothing wedged, nothing half-written");
        shmtest_view_close(&view);
        shm_table_destroy(t);
        shmtest_unlink(instance);
        return failed;
}
