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
 * reachable from it without arguments: a thread-local pointer to that thread's jump buffer; and
 * the handler that was installed before ours, to hand unguarded faults back to. These are the only
 * global state in src/shm; the library never uses them.
 */
static _Thread_local sigjmp_buf *volatile guard_jump;
static pthread_mutex_t guard_lock = PTHREAD_MUTEX_INITIALIZER;
static struct sigaction guard_previous;

static void guard_handler(int sig, siginfo_t *info, void *context)
{
        sigjmp_buf *jump = guard_jump;

        (void)info;
        (void)context;
        if (jump) {
                guard_jump = NULL;
                siglongjmp(*jump, 1);
        }
        /* Not ours: put the previous handler back (the default action, or a sanitizer's) and
         * return; the faulting instruction runs again and faults into it. */
        sigaction(sig, &guard_previous, NULL);
}

static int guard_installed(void)
{
        struct sigaction cur;

        return sigaction(SIGBUS, NULL, &cur) == 0 && (cur.sa_flags & SA_SIGINFO) &&
               cur.sa_sigaction == guard_handler;
}

int shm_guard_install(void)
{
        struct sigaction sa;
        int r = 0;

        pthread_mutex_lock(&guard_lock);
        /* Checked every time, not once: someone (a test framework) may have replaced it. */
        if (!guard_installed()) {
                memset(&sa, 0, sizeof(sa));
                sa.sa_sigaction = guard_handler;
                /* SA_NODEFER: we leave the handler by siglongjmp on a buffer saved without the
                 * signal mask, so SIGBUS must not be blocked while the handler runs, or it would
                 * stay blocked and the next fault would kill the process. */
                sa.sa_flags = SA_SIGINFO | SA_NODEFER;
                sigemptyset(&sa.sa_mask);
                if (sigaction(SIGBUS, &sa, &guard_previous) < 0)
                        r = -errno;
        }
        pthread_mutex_unlock(&guard_lock);
        return r;
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
