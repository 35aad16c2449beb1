/*
 * Wake thread: turns changes of a 32-bit futex word in shared memory into readability of an
 * eventfd, so the daemon's poll loop learns about client writes without polling the table.
 *
 * The thread blocks in futex_waitv on two words: the shared word it watches (clients bump it and
 * FUTEX_WAKE it after every write) and a private control word the daemon bumps to re-point it at
 * another word, or to stop it. Waiting on both matters: a client can truncate the object, after
 * which the daemon could not FUTEX_WAKE the shared word any more to stop the thread. The shared
 * word is client-controlled, so the thread only ever reads it under the SIGBUS guard, never waits
 * on it without the control word, and only signals the eventfd (it never touches the table).
 * With a waiter flag (shm_wake_watch_flagged) writers skip the FUTEX_WAKE while the thread is
 * awake; the flag is set, like the word is read, under the SIGBUS guard.
 * A third word, the doorbell (shm_wake_doorbell), lives in memory no client can write or truncate
 * (the daemon's .in): clients FUTEX_WAKE it without changing it when .out itself is unusable, and
 * every such wake-up signals the eventfd too, at most once per SHM_WAKE_DOORBELL_GAP_MS (anyone
 * who can read .in can ring it; a ring inside the gap is signalled when the gap ends, never lost).
 * On kernels without futex_waitv (before 5.16) it waits on the shared word alone with a timeout of
 * SHM_WAKE_FALLBACK_MS and rechecks the control word in between; the doorbell is not heard there.
 */
#ifndef SHM_WAKE_H
#define SHM_WAKE_H

#include <stdatomic.h>
#include <stdint.h>

#define SHM_WAKE_FALLBACK_MS    250
#define SHM_WAKE_DOORBELL_GAP_MS 100    /* shortest time between two doorbell signals */
#define SHM_WAKE_THREAD_NAME    "sl-wake"       /* the thread's name (comm, < 16 bytes) */

struct shm_wake;

/* Starts the thread (watching nothing) and its eventfd. 0 or -errno. */
int shm_wake_start(struct shm_wake **ret_wake);

/* The eventfd (non-blocking, close-on-exec): readable when the watched word changed. */
int shm_wake_fd(const struct shm_wake *w);

/* CLOCK_MONOTONIC (ns) when the thread last signalled the eventfd, 0 before the first time. */
uint64_t shm_wake_signal_ns(const struct shm_wake *w);

/* Drains the eventfd; returns 1 if it was signalled, 0 if not. */
int shm_wake_ack(struct shm_wake *w);

/*
 * Points the thread at another word (NULL: none). When this returns the thread no longer reads the
 * old word, so its mapping may be unmapped. The current value of the new word is the baseline:
 * only later changes signal the eventfd.
 */
void shm_wake_watch(struct shm_wake *w, _Atomic uint32_t *word);

/*
 * shm_wake_watch for a word whose writers honour a waiter flag (flag: one bit, e.g.
 * SHM_OUT_WAITING): before it sleeps the thread sets the flag with a CAS and sleeps only while
 * the word still holds that value; writers must add without touching the flag and FUTEX_WAKE
 * only when they cleared it. Writers that ignore the flag (add 1, always wake) still work.
 */
void shm_wake_watch_flagged(struct shm_wake *w, _Atomic uint32_t *word, uint32_t flag);

/*
 * Also sleeps on word (NULL: none), a doorbell: a wake-up on it signals the eventfd whether or not
 * anything changed (see above). Its value is never compared with anything.
 */
void shm_wake_doorbell(struct shm_wake *w, _Atomic uint32_t *word);

/* Stops and joins the thread, closes the eventfd, frees w. NULL-safe; returns NULL. */
struct shm_wake *shm_wake_stop(struct shm_wake *w);

#endif
