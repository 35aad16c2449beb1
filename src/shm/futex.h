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

/*
 * Waits until either the shared word differs from shared_expected or the private word differs from
 * private_expected, or one of them is woken (futex_waitv, Linux 5.16). Returns 0 when woken,
 * -EAGAIN when a word differs already, -EFAULT when the shared word is not mapped (e.g. a client
 * truncated the object), -ENOSYS on older kernels (the caller falls back), -EINTR.
 */
int shm_futex_wait2(const _Atomic uint32_t *shared_word, uint32_t shared_expected,
                    const _Atomic uint32_t *private_word, uint32_t private_expected);

#endif
