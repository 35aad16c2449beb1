/*
 * Futex wrappers (see futex.h). glibc has no wrapper for futex(2) or futex_waitv(2).
 */
#include "shm/futex.h"

#include <errno.h>
#include <limits.h>
#include <linux/futex.h>
#include <stdint.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#define MS_PER_S        1000
#define NS_PER_MS       1000000L

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

int shm_futex_wait2(const _Atomic uint32_t *shared_word, uint32_t shared_expected,
                    const _Atomic uint32_t *private_word, uint32_t private_expected)
{
#ifdef SYS_futex_waitv
        struct futex_waitv w[2] = {
                { .val = shared_expected, .uaddr = (uint64_t)(uintptr_t)shared_word,
                  .flags = FUTEX_32 },
                { .val = private_expected, .uaddr = (uint64_t)(uintptr_t)private_word,
                  .flags = FUTEX_32 | FUTEX_PRIVATE_FLAG },
        };
        long r = syscall(SYS_futex_waitv, w, 2u, 0u, NULL, CLOCK_MONOTONIC);

        if (r < 0)
                return -errno;
        return 0;
#else
        (void)shared_word; (void)shared_expected; (void)private_word; (void)private_expected;
        return -ENOSYS;
#endif
}
