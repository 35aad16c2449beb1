/*
 * SIGBUS guard (see guard.h).
 */
#include "shm/guard.h"

#include <errno.h>
#include <pthread.h>
#include <setjmp.h>
#include <signal.h>
#include <stdatomic.h>
#include <stddef.h>
#include <string.h>

/*
 * The signal handler is process-wide, so the "which thread is inside a guarded call" state must be
 * reachable from it without arguments: a thread-local pointer to that thread's jump buffer.
 * This and the once-flag below are the only global state in src/shm; the library never uses them.
 */
static _Thread_local sigjmp_buf *volatile guard_jump;
static pthread_once_t guard_once = PTHREAD_ONCE_INIT;
static int guard_install_error;

static void guard_handler(int sig, siginfo_t *info, void *context)
{
        sigjmp_buf *jump = guard_jump;

        (void)info;
        (void)context;
        if (jump) {
                guard_jump = NULL;
                siglongjmp(*jump, 1);
        }
        /* Not ours: fall back to the default action; returning re-executes the fault. */
        signal(sig, SIG_DFL);
}

static void guard_install_once(void)
{
        struct sigaction sa;

        memset(&sa, 0, sizeof(sa));
        sa.sa_sigaction = guard_handler;
        /* SA_NODEFER: we leave the handler by siglongjmp on a buffer saved without the signal
         * mask, so SIGBUS must not be blocked while the handler runs, or it would stay blocked
         * and the next fault would kill the process. */
        sa.sa_flags = SA_SIGINFO | SA_NODEFER;
        sigemptyset(&sa.sa_mask);
        if (sigaction(SIGBUS, &sa, NULL) < 0)
                guard_install_error = -errno;
}

int shm_guard_install(void)
{
        int r = pthread_once(&guard_once, guard_install_once);

        if (r != 0)
                return -r;
        return guard_install_error;
}

int shm_guard_run(void (*fn)(void *arg), void *arg)
{
        sigjmp_buf jump;

        /* savemask 0: no sigprocmask syscall per scan; see SA_NODEFER above. */
        if (sigsetjmp(jump, 0) != 0)
                return -EFAULT;         /* guard_jump was cleared by the handler */
        guard_jump = &jump;
        /* The handler runs on this thread: a compiler barrier is all the ordering needed. */
        atomic_signal_fence(memory_order_seq_cst);
        fn(arg);
        guard_jump = NULL;
        return 0;
}
