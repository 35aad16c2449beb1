/*
 * Wake thread (see wake.h).
 */
#include "shm/wake.h"

#include <errno.h>
#include <pthread.h>
#include <stdlib.h>
#include <sys/eventfd.h>
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
};

struct wake_load {
        const _Atomic uint32_t *word;
        uint32_t value;
};

static void wake_load_fn(void *arg)
{
        struct wake_load *l = arg;

        l->value = atomic_load_explicit(l->word, memory_order_acquire);
}

/* Reads the shared word under the SIGBUS guard: 0 or -EFAULT. */
static int wake_read(const _Atomic uint32_t *word, uint32_t *ret_value)
{
        struct wake_load l = { .word = word, .value = 0 };
        int r = shm_guard_install();

        if (r == 0)
                r = shm_guard_run(wake_load_fn, &l);

        if (r < 0)
                return r;
        *ret_value = l.value;
        return 0;
}

static void wake_signal(struct shm_wake *w)
{
        uint64_t one = 1;

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
                int readable, r;

                pthread_mutex_lock(&w->lock);
                word = w->word;
                readable = word && wake_read(word, &value) == 0;
                if (readable) {
                        if (w->baseline_set && value != w->baseline)
                                wake_signal(w);
                        w->baseline = value;
                        w->baseline_set = 1;
                }
                pthread_mutex_unlock(&w->lock);
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

void shm_wake_watch(struct shm_wake *w, _Atomic uint32_t *word)
{
        uint32_t value;

        pthread_mutex_lock(&w->lock);
        w->word = word;
        w->baseline_set = word && wake_read(word, &value) == 0;
        if (w->baseline_set)
                w->baseline = value;
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
