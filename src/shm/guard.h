/*
 * SIGBUS guard for reading memory that someone else can truncate (the .out object: any client in
 * the group can ftruncate it, and touching a page of a shared mapping beyond the end of the file
 * raises SIGBUS).
 *
 * Choice: the daemon checks the object's size with fstat before each scan (cheap, catches the
 * common case and lets it recreate the object) AND runs the copy-out under this guard, because a
 * client can truncate between the fstat and the copy. The guard installs one process-wide SIGBUS
 * handler (SA_NODEFER, so the signal is not left blocked after the jump); a thread arms it with a
 * thread-local jump buffer around the guarded call. A SIGBUS outside a guarded call restores the
 * handler that was there before (the default action, or a sanitizer's) and returns, so the
 * faulting instruction raises it again and the process dies as it would have without the guard. Daemon side only: the library never installs handlers.
 */
#ifndef SHM_GUARD_H
#define SHM_GUARD_H

/* Installs the SIGBUS handler unless it is installed already (thread-safe). 0 or -errno. */
int shm_guard_install(void);

/*
 * Runs fn(arg) with the guard armed in this thread. Returns 0, or -EFAULT when fn touched memory
 * that raised SIGBUS (fn was abandoned at that point: keep its state in *arg, write nothing to
 * ordinary memory that must stay consistent, and never call out of fn to code that could be cut
 * in half). Guarded calls do not nest. shm_guard_install must have been called.
 */
int shm_guard_run(void (*fn)(void *arg), void *arg);

#endif
