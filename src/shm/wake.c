/*
 * Wake thread (see wake.h).
 */
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

static void wake_signal(struct shm_wake *w)
{
        struct timespec ts;
        uint64_t one = 1;

        /* One clock read per wake-up (not per write): tells how long the wake-up took. */
        clock_gettime(CLOCK_MONOTONIC, &ts);
        atomic_store_explicit(&w->signal_ns, (uint64_t)ts.tv_sec * 1000000000ull +
                              (uint64_t)ts.tv_nsec, memory_order_relaxed);
        /* EAGAIN (counter saturated) is fine: the fd is readable either way. */
        if (write(w->efd, &one, sizeof(one)) < 0 && errno != EAGAIN)
                return;
}

static void *wake_main(void *arg)
{
        struct shm_wake *w = arg;

        while (!atomic_load_explicit(&w->stop, memory_order_acquire)) {
                uint32_t control = atomic_load_explicit(&w->control, memory_order_acquire);
                _Atomic uint32_t *word;
                uint32_t value = 0;
                int readable, armed = 1, r;

                pthread_mutex_lock(&w->lock);
                word = w->word;
                readable = word && wake_read(word, &value) == 0;
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

                if (!readable) {
                        /* Nothing to watch, or the object is truncated: wait for watch()/stop. */
                        shm_futex_wait_private(&w->control, control, -1);
                        continue;
                }
                /* A concurrent watch() bumps control before we block: waitv returns -EAGAIN. If
                 * the shared word was unmapped meanwhile, waitv fails with -EFAULT and we loop. */
                r = shm_futex_wait2(word, value, &w->control, control);
                if (r == -ENOSYS) {
                        if (atomic_load_explicit(&w->control, memory_order_acquire) == control)
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
