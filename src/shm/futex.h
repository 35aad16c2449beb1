/*
 * Futex wrappers for 32-bit words in shared memory.
 *
 * The shared forms deliberately omit FUTEX_PRIVATE_FLAG: a private futex is keyed by the process's
 * address space, so a FUTEX_WAIT_PRIVATE in one process is never woken by a FUTEX_WAKE in another
 * (measured: the waiter times out, the waker reports 0 woken). Waiting works on a PROT_READ mapping
 * (kernel commit 9ea71503a8ed), which is how clients map .in.
 */
#ifndef SHM_FUTEX_H
#define SHM_FUTEX_H

#include <stdatomic.h>
#include <stdint.h>

/*
 * Blocks while *word == expected, at most timeout_ms (< 0: no limit). Returns 0 when woken (or
 * spuriously), -EAGAIN when *word != expected already, -ETIMEDOUT, -EINTR or -EFAULT.
 * Always re-check the word after it returns.
 */
int shm_futex_wait(const _Atomic uint32_t *word, uint32_t expected, int timeout_ms);

/* Wakes up to n waiters of a shared-memory word (any process); returns the number woken or -errno. */
int shm_futex_wake(_Atomic uint32_t *word, int n);

/* Process-private forms, for words in ordinary memory. Same returns as above. */
int shm_futex_wait_private(const _Atomic uint32_t *word, uint32_t expected, int timeout_ms);

/* Wakes up to n waiters of a process-private word. */
int shm_futex_wake_private(_Atomic uint32_t *word, int n);

/* One word of shm_futex_wait_any. */
struct shm_futex_want {
        const _Atomic uint32_t *word;
        uint32_t expected;
        int private_word;               /* 1: a process-private word (ordinary memory) */
};

#define SHM_FUTEX_WANT_MAX      4u      /* words one shm_futex_wait_any waits on (kernel: 128) */

/*
 * Waits until one of the n words (n <= SHM_FUTEX_WANT_MAX) differs from its expected value or is
 * woken (futex_waitv, Linux 5.16), at most until deadline_ns (CLOCK_MONOTONIC; 0: no limit).
 * Returns the index of a word that was woken, -EAGAIN when a word differs already, -ETIMEDOUT,
 * -EFAULT when a shared word is not mapped (e.g. a client truncated its object), -EINVAL, -EINTR,
 * or -ENOSYS on older kernels (the caller falls back).
 */
int shm_futex_wait_any(const struct shm_futex_want *want, unsigned n, uint64_t deadline_ns);

#endif
