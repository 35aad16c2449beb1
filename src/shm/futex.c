/*
 * Futex wrappers (see futex.h). glibc has no wrapper for futex(2) or futex_waitv(2).
 */
#include "shm/futex.h"

#include <errno.h>
#include <limits.h>
#include <linux/futex.h>
#include <stdint.h>
#include <string.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#define MS_PER_S        1000
#define NS_PER_MS       1000000L
#define NS_PER_S        1000000000ull

/* The futex syscalls take a mutable pointer even for waiting; go through an integer. */
static uint32_t *futex_addr(const _Atomic uint32_t *word)
{
        return (uint32_t *)(uintptr_t)word;
}

static int futex_call(const _Atomic uint32_t *word, int op, uint32_t val, int timeout_ms)
{
        struct timespec ts, *tsp = NULL;
        long r;

        if (timeout_ms >= 0) {
                ts.tv_sec = timeout_ms / MS_PER_S;
                ts.tv_nsec = (long)(timeout_ms % MS_PER_S) * NS_PER_MS;
                tsp = &ts;      /* FUTEX_WAIT takes a relative timeout */
        }
        r = syscall(SYS_futex, futex_addr(word), op, val, tsp, NULL, 0);
        if (r < 0)
                return -errno;
        return (int)r;
}

int shm_futex_wait(const _Atomic uint32_t *word, uint32_t expected, int timeout_ms)
{
        int r = futex_call(word, FUTEX_WAIT, expected, timeout_ms);

        return r > 0 ? 0 : r;
}

int shm_futex_wake(_Atomic uint32_t *word, int n)
{
        return futex_call(word, FUTEX_WAKE, (uint32_t)n, -1);
}

int shm_futex_wait_private(const _Atomic uint32_t *word, uint32_t expected, int timeout_ms)
{
        int r = futex_call(word, FUTEX_WAIT_PRIVATE, expected, timeout_ms);

        return r > 0 ? 0 : r;
}

int shm_futex_wake_private(_Atomic uint32_t *word, int n)
{
        return futex_call(word, FUTEX_WAKE_PRIVATE, (uint32_t)n, -1);
}

int shm_futex_wait_any(const struct shm_futex_want *want, unsigned n, uint64_t deadline_ns)
{
#ifdef SYS_futex_waitv
        struct futex_waitv w[SHM_FUTEX_WANT_MAX];
        struct timespec ts, *tsp = NULL;
        long r;

        if (n == 0 || n > SHM_FUTEX_WANT_MAX)
                return -EINVAL;
        memset(w, 0, sizeof(w));
        for (unsigned i = 0; i < n; i++) {
                w[i].val = want[i].expected;
                w[i].uaddr = (uint64_t)(uintptr_t)want[i].word;
                w[i].flags = FUTEX_32 | (want[i].private_word ? FUTEX_PRIVATE_FLAG : 0u);
        }
        if (deadline_ns) {
                /* futex_waitv takes an absolute time on the clock it is given */
                ts.tv_sec = (time_t)(deadline_ns / NS_PER_S);
                ts.tv_nsec = (long)(deadline_ns % NS_PER_S);
                tsp = &ts;
        }
        r = syscall(SYS_futex_waitv, w, n, 0u, tsp, CLOCK_MONOTONIC);
        if (r < 0)
                return -errno;
        return (int)r;
#else
        (void)want; (void)n; (void)deadline_ns;
        return -ENOSYS;
#endif
}
