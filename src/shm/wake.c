/*
 * Wake thread (see wake.h).
 */
#define _GNU_SOURCE     /* pthread_setname_np */
#include "shm/wake.h"

#include <errno.h>
#include <pthread.h>
#include <stdlib.h>
#include <sys/eventfd.h>
#include <time.h>
#include <unistd.h>

#include "shm/futex.h"
#include "shm/guard.h"

struct shm_wake {
        pthread_t thread;
        int efd;
        /* Private futex word: bumped (and woken) on every watch() and on stop. */
        _Atomic uint32_t control;
        _Atomic int stop;
        /* Guards `word` and `baseline`: the thread holds it while it reads the shared word, so
         * watch() returning means the old word is no longer touched. */
        pthread_mutex_t lock;
        _Atomic uint32_t *word;
        uint32_t baseline;
        int baseline_set;
        uint32_t flag;                  /* waiter flag bit of `word`, 0 for none */
        _Atomic uint32_t *doorbell;     /* under `lock`; NULL: none */
        _Atomic uint64_t signal_ns;     /* CLOCK_MONOTONIC of the last eventfd signal */
};

struct wake_load {
        _Atomic uint32_t *word;
        uint32_t value;
        uint32_t flag;                  /* arm: set this bit if value is still there */
        int armed;
};

static void wake_load_fn(void *arg)
{
        struct wake_load *l = arg;

        l->value = atomic_load_explicit(l->word, memory_order_acquire);
}

/* A CAS, so that a writer's add between our load and the store is never lost: it either comes
 * first (the CAS fails, and the change is seen) or sees the flag (and wakes us). */
static void wake_arm_fn(void *arg)
{
        struct wake_load *l = arg;
        uint32_t expected = l->value;

        l->armed = (expected & l->flag) != 0 ||
                   atomic_compare_exchange_strong_explicit(l->word, &expected,
                                                           expected | l->flag,
                                                           memory_order_acq_rel,
                                                           memory_order_acquire);
        l->value = expected | l->flag;
}

static int wake_guarded(void (*fn)(void *), struct wake_load *l)
{
        int r = shm_guard_install();

        if (r == 0)
                r = shm_guard_run(fn, l);
        return r;
}

/* Reads the shared word under the SIGBUS guard: 0 or -EFAULT. */
static int wake_read(_Atomic uint32_t *word, uint32_t *ret_value)
{
        struct wake_load l = { .word = word, .value = 0 };
        int r = wake_guarded(wake_load_fn, &l);

        if (r < 0)
                return r;
        *ret_value = l.value;
        return 0;
}

/*
 * Sets the waiter flag on *value (under the guard). Returns 1 with the value to sleep on in
 * *value, 0 when the word changed meanwhile (look again), or -EFAULT.
 */
static int wake_arm(_Atomic uint32_t *word, uint32_t flag, uint32_t *value)
{
        struct wake_load l = { .word = word, .value = *value, .flag = flag };
        int r = wake_guarded(wake_arm_fn, &l);

        if (r < 0)
                return r;
        *value = l.value;
        return l.armed;
}

#define WAKE_NS_PER_MS  1000000ull

static uint64_t wake_now(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

static void wake_signal(struct shm_wake *w)
{
        uint64_t one = 1;

        /* One clock read per wake-up (not per write): tells how long the wake-up took. */
        atomic_store_explicit(&w->signal_ns, wake_now(), memory_order_relaxed);
        /* EAGAIN (counter saturated) is fine: the fd is readable either way. */
        if (write(w->efd, &one, sizeof(one)) < 0 && errno != EAGAIN)
                return;
}

/* Doorbell pacing: at most one signal per SHM_WAKE_DOORBELL_GAP_MS, none lost. */
struct wake_bell {
        uint64_t quiet_until;           /* no doorbell signal before this (CLOCK_MONOTONIC) */
        int pending;                    /* rung inside the gap: signal once it ends */
};

static void wake_bell_ring(struct shm_wake *w, struct wake_bell *b, uint64_t now)
{
        if (now < b->quiet_until) {
                b->pending = 1;
                return;
        }
        wake_signal(w);
        b->pending = 0;
        b->quiet_until = now + SHM_WAKE_DOORBELL_GAP_MS * WAKE_NS_PER_MS;
}

static void *wake_main(void *arg)
{
        struct shm_wake *w = arg;
        struct wake_bell bell = { 0, 0 };

        while (!atomic_load_explicit(&w->stop, memory_order_acquire)) {
                uint32_t control = atomic_load_explicit(&w->control, memory_order_acquire);
                struct shm_futex_want want[3];
                _Atomic uint32_t *word, *doorbell;
                unsigned n = 0, bell_index = SHM_FUTEX_WANT_MAX;
                uint32_t value = 0;
                int readable, armed = 1, r;

                pthread_mutex_lock(&w->lock);
                word = w->word;
                doorbell = w->doorbell;
                readable = word && wake_read(word, &value) == 0;
                if (word && !readable && w->baseline_set) {
                        /* It was readable: the object was truncated under us. A client that
                         * then rang the doorbell while we were awake rang in vain (a wake-up
                         * reaches sleepers only), so this counts as the change it reports. */
                        w->baseline_set = 0;
                        wake_signal(w);
                }
                if (readable) {
                        if (w->baseline_set && value != w->baseline)
                                wake_signal(w);
                        w->baseline = value;
                        w->baseline_set = 1;
                        /* Still under the lock: watch() may unmap the word once we let go. The
                         * armed value (flag set) is the new baseline: the flag bit is also a bit
                         * of the count for a 1.0 client, which adds 1, so changes are compared
                         * on the whole word, never with the flag masked out. */
                        if (w->flag) {
                                armed = wake_arm(word, w->flag, &value);
                                if (armed > 0)
                                        w->baseline = value;
                        }
                }
                pthread_mutex_unlock(&w->lock);
                if (armed <= 0)
                        continue;       /* changed while arming (or gone): look again */
                if (atomic_load_explicit(&w->stop, memory_order_acquire))
                        break;
                if (bell.pending)
                        wake_bell_ring(w, &bell, wake_now());

                /* A concurrent watch() bumps control before we block: the wait returns -EAGAIN.
                 * If the shared word was unmapped meanwhile, it fails with -EFAULT and we loop,
                 * to find it unreadable and wait without it. A truncated .out leaves the control
                 * word and the doorbell (in memory no client can truncate). */
                want[n++] = (struct shm_futex_want){ &w->control, control, 1 };
                if (readable)
                        want[n++] = (struct shm_futex_want){ word, value, 0 };
                if (doorbell && !bell.pending) {
                        bell_index = n;
                        want[n++] = (struct shm_futex_want){
                                doorbell, atomic_load_explicit(doorbell, memory_order_relaxed), 0 };
                }
                r = shm_futex_wait_any(want, n, bell.pending ? bell.quiet_until : 0);
                if (r >= 0 && (unsigned)r == bell_index) {
                        wake_bell_ring(w, &bell, wake_now());
                } else if (r == -ENOSYS) {
                        if (!readable)  /* nothing to watch, or the object is truncated */
                                shm_futex_wait_private(&w->control, control, -1);
                        else if (atomic_load_explicit(&w->control, memory_order_acquire) ==
                                 control)
                                shm_futex_wait(word, value, SHM_WAKE_FALLBACK_MS);
                }
        }
        return NULL;
}

int shm_wake_start(struct shm_wake **ret_wake)
{
        struct shm_wake *w = calloc(1, sizeof(*w));
        int r;

        if (!w)
                return -ENOMEM;
        w->efd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
        if (w->efd < 0) {
                r = -errno;
                free(w);
                return r;
        }
        pthread_mutex_init(&w->lock, NULL);
        r = pthread_create(&w->thread, NULL, wake_main, w);
        if (r != 0) {
                pthread_mutex_destroy(&w->lock);
                close(w->efd);
                free(w);
                return -r;
        }
        /* Named for ps/top and debuggers (and for tests that wait until it sleeps). */
        pthread_setname_np(w->thread, SHM_WAKE_THREAD_NAME);
        *ret_wake = w;
        return 0;
}

int shm_wake_fd(const struct shm_wake *w)
{
        return w->efd;
}

uint64_t shm_wake_signal_ns(const struct shm_wake *w)
{
        return atomic_load_explicit(&w->signal_ns, memory_order_relaxed);
}

int shm_wake_ack(struct shm_wake *w)
{
        uint64_t v;

        return read(w->efd, &v, sizeof(v)) == (ssize_t)sizeof(v) ? 1 : 0;
}

static void wake_kick(struct shm_wake *w)
{
        atomic_fetch_add_explicit(&w->control, 1u, memory_order_release);
        shm_futex_wake_private(&w->control, 1);
}

static void wake_watch(struct shm_wake *w, _Atomic uint32_t *word, uint32_t flag)
{
        uint32_t value;

        pthread_mutex_lock(&w->lock);
        w->word = word;
        w->flag = flag;
        w->baseline_set = word && wake_read(word, &value) == 0;
        if (w->baseline_set)
                w->baseline = value;
        pthread_mutex_unlock(&w->lock);
        wake_kick(w);
}

void shm_wake_watch(struct shm_wake *w, _Atomic uint32_t *word)
{
        wake_watch(w, word, 0);
}

void shm_wake_watch_flagged(struct shm_wake *w, _Atomic uint32_t *word, uint32_t flag)
{
        wake_watch(w, word, flag);
}

void shm_wake_doorbell(struct shm_wake *w, _Atomic uint32_t *word)
{
        pthread_mutex_lock(&w->lock);
        w->doorbell = word;
        pthread_mutex_unlock(&w->lock);
        wake_kick(w);
}

struct shm_wake *shm_wake_stop(struct shm_wake *w)
{
        if (!w)
                return NULL;
        atomic_store_explicit(&w->stop, 1, memory_order_release);
        wake_kick(w);
        pthread_join(w->thread, NULL);
        pthread_mutex_destroy(&w->lock);
        close(w->efd);
        free(w);
        return NULL;
}
