/*
 * Event loop on poll(2) (see evloop.h).
 *
 * fds: an array of registrations, in the order they were added. Removal during a round only
 * marks an entry dead; dead entries are swept after the round, so indexes stay stable while
 * the round walks the pollfd array (entry i was polled as pfds[i]). Entries appended during a
 * round sit past the polled range and wait for the next round.
 *
 * Timers: a binary min-heap on (deadline, seq) of pointers to the owners' timers; each timer
 * knows its heap index, so cancel and re-arm are O(log n) anywhere, also mid-dispatch.
 */
#include "svc/evloop.h"

#include <errno.h>
#include <limits.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/signalfd.h>
#include <time.h>
#include <unistd.h>

#define EVLOOP_NSEC_PER_MSEC    1000000ull
#define EVLOOP_NSEC_PER_SEC     1000000000ull
#define EVLOOP_INITIAL_CAP      16
#define EVLOOP_SIGINFO_BATCH    8       /* signalfd records read per read(2) */
#define EVLOOP_SIGNO_MAX        65      /* > SIGRTMAX on Linux */
#define EVLOOP_EVENTS_POLL      (POLLIN | POLLOUT | POLLPRI)
#define EVLOOP_EVENTS_ALLOWED   (EVLOOP_EVENTS_POLL | EVLOOP_HANGUP)
#define EVLOOP_EVENTS_ALWAYS    (POLLERR | POLLHUP | POLLNVAL)

struct evloop_io {
        int fd;
        unsigned events;
        evloop_fd_cb cb;
        void *arg;
        bool dead;
};

struct evloop_sig {
        evloop_signal_cb cb;
        void *arg;
        bool was_blocked;               /* blocked before we took it: stays blocked on release */
};

struct evloop {
        struct evloop_io *io;
        struct pollfd *pfds;
        size_t n_io, cap_io;
        size_t n_dead;

        struct evloop_timer **heap;
        size_t n_heap, cap_heap;
        uint64_t timer_seq;             /* next arming sequence number */

        int sigfd;                      /* -1 until the first signal is added */
        sigset_t sigmask;
        struct evloop_sig sigs[EVLOOP_SIGNO_MAX];

        uint64_t now_ns;
        bool running;                   /* inside evloop_run_once() */
        bool exit_requested;
        int exit_code;
        struct evloop_stats stats;
};

uint64_t evloop_clock_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * EVLOOP_NSEC_PER_SEC + (uint64_t)ts.tv_nsec;
}

int evloop_new(struct evloop **ret_loop)
{
        struct evloop *loop = calloc(1, sizeof(*loop));

        if (!loop)
                return -ENOMEM;
        loop->sigfd = -1;
        sigemptyset(&loop->sigmask);
        loop->now_ns = evloop_clock_ns();
        *ret_loop = loop;
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * fds */

static struct evloop_io *evloop_find_io(struct evloop *loop, int fd)
{
        for (size_t i = 0; i < loop->n_io; i++)
                if (!loop->io[i].dead && loop->io[i].fd == fd)
                        return &loop->io[i];
        return NULL;
}

static int evloop_grow_io(struct evloop *loop)
{
        size_t cap = loop->cap_io ? loop->cap_io * 2 : EVLOOP_INITIAL_CAP;
        struct evloop_io *io;
        struct pollfd *pfds;

        if (cap > EVLOOP_FDS_MAX)
                cap = EVLOOP_FDS_MAX;
        if (cap <= loop->cap_io)
                return -ENOSPC;
        io = realloc(loop->io, cap * sizeof(*io));
        if (!io)
                return -ENOMEM;
        loop->io = io;
        pfds = realloc(loop->pfds, cap * sizeof(*pfds));
        if (!pfds)
                return -ENOMEM;
        loop->pfds = pfds;
        loop->cap_io = cap;
        return 0;
}

int evloop_add_fd(struct evloop *loop, int fd, unsigned events, evloop_fd_cb cb, void *arg)
{
        int r;

        if (fd < 0 || !cb || (events & ~(unsigned)EVLOOP_EVENTS_ALLOWED))
                return -EINVAL;
        if (evloop_find_io(loop, fd))
                return -EEXIST;
        if (loop->n_io - loop->n_dead >= EVLOOP_FDS_MAX)
                return -ENOSPC;
        if (loop->n_io == loop->cap_io) {
                r = evloop_grow_io(loop);
                if (r < 0)
                        return r;
        }
        loop->io[loop->n_io++] = (struct evloop_io){
                .fd = fd, .events = events, .cb = cb, .arg = arg,
        };
        return 0;
}

int evloop_mod_fd(struct evloop *loop, int fd, unsigned events)
{
        struct evloop_io *io;

        if (events & ~(unsigned)EVLOOP_EVENTS_ALLOWED)
                return -EINVAL;
        io = evloop_find_io(loop, fd);
        if (!io)
                return -ENOENT;
        io->events = events;
        return 0;
}

int evloop_del_fd(struct evloop *loop, int fd)
{
        struct evloop_io *io = evloop_find_io(loop, fd);

        if (!io)
                return -ENOENT;
        io->dead = true;
        loop->n_dead++;
        return 0;
}

/* Drops dead entries, keeping the order; only between rounds. */
static void evloop_sweep_io(struct evloop *loop)
{
        size_t j = 0;

        if (loop->n_dead == 0)
                return;
        for (size_t i = 0; i < loop->n_io; i++)
                if (!loop->io[i].dead)
                        loop->io[j++] = loop->io[i];
        loop->n_io = j;
        loop->n_dead = 0;
}

/* Runs the callbacks of the first n_polled entries that poll() found ready. */
static unsigned evloop_dispatch_io(struct evloop *loop, size_t n_polled)
{
        unsigned ran = 0;

        for (size_t i = 0; i < n_polled; i++) {
                struct evloop_io *io = &loop->io[i];
                unsigned revents;

                if (io->dead || loop->pfds[i].revents == 0)
                        continue;
                /* Mask with the current events: an earlier callback of this round may have
                 * dropped POLLOUT, and must not get it anyway. */
                revents = (unsigned)loop->pfds[i].revents & (io->events | EVLOOP_EVENTS_ALWAYS);
                if (revents == 0)
                        continue;
                io->cb(loop, io->fd, revents, io->arg);
                ran++;
                loop->stats.fd_events++;
                /* io may have moved (an add grew the array): index again. */
                io = &loop->io[i];
                if ((revents & POLLNVAL) && !io->dead) {
                        io->dead = true;
                        loop->n_dead++;
                        loop->stats.nval_drops++;
                }
        }
        return ran;
}

/* ---------------------------------------------------------------------------------------------
 * Timers */

static bool evloop_timer_before(const struct evloop_timer *a, const struct evloop_timer *b)
{
        if (a->deadline_ns != b->deadline_ns)
                return a->deadline_ns < b->deadline_ns;
        return a->seq < b->seq;
}

static void evloop_heap_set(struct evloop *loop, size_t i, struct evloop_timer *t)
{
        loop->heap[i] = t;
        t->heap_index = i;
}

static void evloop_heap_up(struct evloop *loop, size_t i)
{
        struct evloop_timer *t = loop->heap[i];

        while (i > 0) {
                size_t parent = (i - 1) / 2;

                if (!evloop_timer_before(t, loop->heap[parent]))
                        break;
                evloop_heap_set(loop, i, loop->heap[parent]);
                i = parent;
        }
        evloop_heap_set(loop, i, t);
}

static void evloop_heap_down(struct evloop *loop, size_t i)
{
        struct evloop_timer *t = loop->heap[i];

        for (;;) {
                size_t child = 2 * i + 1;

                if (child >= loop->n_heap)
                        break;
                if (child + 1 < loop->n_heap &&
                    evloop_timer_before(loop->heap[child + 1], loop->heap[child]))
                        child++;
                if (!evloop_timer_before(loop->heap[child], t))
                        break;
                evloop_heap_set(loop, i, loop->heap[child]);
                i = child;
        }
        evloop_heap_set(loop, i, t);
}

static void evloop_heap_remove(struct evloop *loop, struct evloop_timer *t)
{
        size_t i = t->heap_index;
        struct evloop_timer *last = loop->heap[--loop->n_heap];

        t->heap_index = EVLOOP_TIMER_IDLE;
        if (last == t)
                return;
        evloop_heap_set(loop, i, last);
        evloop_heap_up(loop, i);
        evloop_heap_down(loop, last->heap_index);
}

static int evloop_heap_insert(struct evloop *loop, struct evloop_timer *t)
{
        if (loop->n_heap == loop->cap_heap) {
                size_t cap = loop->cap_heap ? loop->cap_heap * 2 : EVLOOP_INITIAL_CAP;
                struct evloop_timer **heap;

                if (cap > EVLOOP_TIMERS_MAX)
                        cap = EVLOOP_TIMERS_MAX;
                if (cap <= loop->cap_heap)
                        return -ENOSPC;
                heap = realloc(loop->heap, cap * sizeof(*heap));
                if (!heap)
                        return -ENOMEM;
                loop->heap = heap;
                loop->cap_heap = cap;
        }
        t->seq = loop->timer_seq++;
        evloop_heap_set(loop, loop->n_heap++, t);
        evloop_heap_up(loop, t->heap_index);
        return 0;
}

void evloop_timer_init(struct evloop_timer *timer, struct evloop *loop, evloop_timer_cb cb,
                       void *arg)
{
        *timer = (struct evloop_timer){
                .loop = loop, .cb = cb, .arg = arg, .heap_index = EVLOOP_TIMER_IDLE,
        };
}

bool evloop_timer_armed(const struct evloop_timer *timer)
{
        return timer && timer->heap_index != EVLOOP_TIMER_IDLE;
}

void evloop_timer_cancel(struct evloop_timer *timer)
{
        if (evloop_timer_armed(timer))
                evloop_heap_remove(timer->loop, timer);
}

int evloop_timer_arm(struct evloop_timer *timer, uint64_t delay_ms, uint64_t interval_ms)
{
        /* Beyond this a deadline in ns would overflow; nobody needs timers of 500 years. */
        const uint64_t max_ms = UINT64_MAX / EVLOOP_NSEC_PER_MSEC / 4;

        if (!timer->loop || !timer->cb || delay_ms > max_ms || interval_ms > max_ms)
                return -EINVAL;
        evloop_timer_cancel(timer);
        /* A fresh clock, not the cached one: arming after a long callback must not fire early. */
        timer->deadline_ns = evloop_clock_ns() + delay_ms * EVLOOP_NSEC_PER_MSEC;
        timer->interval_ns = interval_ms * EVLOOP_NSEC_PER_MSEC;
        return evloop_heap_insert(timer->loop, timer);
}

/* Fires the timers due at loop->now_ns that were armed before this round began. */
static unsigned evloop_dispatch_timers(struct evloop *loop)
{
        uint64_t seq_limit = loop->timer_seq;
        unsigned ran = 0;

        while (loop->n_heap > 0) {
                struct evloop_timer *t = loop->heap[0];

                if (t->deadline_ns > loop->now_ns)
                        break;
                /* Armed during this round: waits for the next one (poll timeout 0), so a
                 * callback re-arming with delay 0 cannot trap us here. The fresh clock used by
                 * evloop_timer_arm() is normally past now_ns already; this makes it certain
                 * when the clock has not ticked in between. */
                if (t->seq >= seq_limit)
                        break;
                evloop_heap_remove(loop, t);
                if (t->interval_ns > 0) {
                        /* Re-insert before the callback, which may cancel, re-arm or free it:
                         * after the call we touch nothing of t. */
                        t->deadline_ns += t->interval_ns;
                        if (t->deadline_ns <= loop->now_ns)
                                t->deadline_ns = loop->now_ns + t->interval_ns;
                        /* Cannot fail: the slot was just freed. */
                        evloop_heap_insert(loop, t);
                }
                loop->stats.timer_fires++;
                ran++;
                t->cb(loop, t, t->arg);
        }
        return ran;
}

int evloop_next_timeout_ms(const struct evloop *loop)
{
        uint64_t now, left;

        if (loop->n_heap == 0)
                return -1;
        now = evloop_clock_ns();
        if (loop->heap[0]->deadline_ns <= now)
                return 0;
        /* Round up: waking a fraction of a millisecond early would be a wasted wakeup. */
        left = (loop->heap[0]->deadline_ns - now + EVLOOP_NSEC_PER_MSEC - 1) / EVLOOP_NSEC_PER_MSEC;
        return left > INT_MAX ? INT_MAX : (int)left;
}

/* ---------------------------------------------------------------------------------------------
 * Signals */

static void evloop_on_signalfd(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct signalfd_siginfo si[EVLOOP_SIGINFO_BATCH];

        (void)revents;
        (void)arg;
        for (;;) {
                ssize_t n = read(fd, si, sizeof(si));

                if (n < 0 && errno == EINTR)
                        continue;
                if (n <= 0)
                        return;
                for (size_t i = 0; i < (size_t)n / sizeof(si[0]); i++) {
                        uint32_t signo = si[i].ssi_signo;

                        /* Look the callback up each time: an earlier one may have removed it. */
                        if (signo >= EVLOOP_SIGNO_MAX || !loop->sigs[signo].cb)
                                continue;
                        loop->stats.signals++;
                        loop->sigs[signo].cb(loop, (int)signo, loop->sigs[signo].arg);
                }
        }
}

static int evloop_update_signalfd(struct evloop *loop)
{
        int fd = signalfd(loop->sigfd, &loop->sigmask, SFD_NONBLOCK | SFD_CLOEXEC);
        int r;

        if (fd < 0)
                return -errno;
        if (loop->sigfd < 0) {
                r = evloop_add_fd(loop, fd, POLLIN, evloop_on_signalfd, NULL);
                if (r < 0) {
                        close(fd);
                        return r;
                }
                loop->sigfd = fd;
        }
        return 0;
}

/* Consumes pending deliveries of signo, so that unblocking it cannot run its default action. */
static void evloop_discard_signal(int signo)
{
        const struct timespec zero = { 0, 0 };
        sigset_t set;

        sigemptyset(&set);
        sigaddset(&set, signo);
        while (sigtimedwait(&set, NULL, &zero) == signo)
                ;
}

int evloop_add_signal(struct evloop *loop, int signo, evloop_signal_cb cb, void *arg)
{
        sigset_t one, old;
        int r;

        if (signo <= 0 || signo >= EVLOOP_SIGNO_MAX || !cb || signo == SIGKILL || signo == SIGSTOP)
                return -EINVAL;
        if (loop->sigs[signo].cb)
                return -EEXIST;
        sigemptyset(&one);
        sigaddset(&one, signo);
        r = pthread_sigmask(SIG_BLOCK, &one, &old);
        if (r != 0)
                return -r;
        sigaddset(&loop->sigmask, signo);
        r = evloop_update_signalfd(loop);
        if (r < 0) {
                sigdelset(&loop->sigmask, signo);
                if (!sigismember(&old, signo))
                        pthread_sigmask(SIG_UNBLOCK, &one, NULL);
                return r;
        }
        loop->sigs[signo] = (struct evloop_sig){
                .cb = cb, .arg = arg, .was_blocked = sigismember(&old, signo) == 1,
        };
        return 0;
}

static void evloop_release_signal(struct evloop *loop, int signo)
{
        sigset_t one;

        sigdelset(&loop->sigmask, signo);
        if (!loop->sigs[signo].was_blocked) {
                evloop_discard_signal(signo);
                sigemptyset(&one);
                sigaddset(&one, signo);
                pthread_sigmask(SIG_UNBLOCK, &one, NULL);
        }
        loop->sigs[signo] = (struct evloop_sig){ 0 };
}

int evloop_del_signal(struct evloop *loop, int signo)
{
        if (signo <= 0 || signo >= EVLOOP_SIGNO_MAX || !loop->sigs[signo].cb)
                return -ENOENT;
        evloop_release_signal(loop, signo);
        /* The signalfd keeps its other signals; an empty mask just never fires. */
        if (loop->sigfd >= 0 && signalfd(loop->sigfd, &loop->sigmask, 0) < 0)
                return -errno;
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Running */

int evloop_run_once(struct evloop *loop)
{
        size_t n_polled;
        unsigned ran;
        int n, timeout;

        if (loop->running)
                return -EBUSY;
        evloop_sweep_io(loop);
        n_polled = loop->n_io;
        for (size_t i = 0; i < n_polled; i++) {
                /* A negative fd makes poll() skip the entry: events 0 means "not now". With
                 * EVLOOP_HANGUP alone it is polled with events 0, which poll() still answers
                 * with POLLHUP/POLLERR. */
                loop->pfds[i].fd = loop->io[i].events ? loop->io[i].fd : -1;
                loop->pfds[i].events = (short)(loop->io[i].events & EVLOOP_EVENTS_POLL);
                loop->pfds[i].revents = 0;
        }
        timeout = evloop_next_timeout_ms(loop);
        n = poll(loop->pfds, n_polled, timeout);
        loop->stats.wakeups++;
        loop->now_ns = evloop_clock_ns();
        if (n < 0) {
                loop->stats.idle_wakeups++;
                return errno == EINTR ? 0 : -errno;
        }
        loop->running = true;
        ran = n > 0 ? evloop_dispatch_io(loop, n_polled) : 0;
        ran += evloop_dispatch_timers(loop);
        loop->running = false;
        if (ran == 0)
                loop->stats.idle_wakeups++;
        evloop_sweep_io(loop);
        return 0;
}

int evloop_run(struct evloop *loop)
{
        if (loop->running)
                return -EBUSY;
        while (!loop->exit_requested) {
                int r = evloop_run_once(loop);

                if (r < 0)
                        return r;
        }
        loop->exit_requested = false;
        return loop->exit_code;
}

void evloop_exit(struct evloop *loop, int code)
{
        loop->exit_requested = true;
        loop->exit_code = code;
}

bool evloop_exiting(const struct evloop *loop)
{
        return loop->exit_requested;
}

uint64_t evloop_now_ns(const struct evloop *loop)
{
        return loop->now_ns;
}

void evloop_get_stats(const struct evloop *loop, struct evloop_stats *ret_stats)
{
        *ret_stats = loop->stats;
}

struct evloop *evloop_free(struct evloop *loop)
{
        if (!loop)
                return NULL;
        for (int signo = 1; signo < EVLOOP_SIGNO_MAX; signo++)
                if (loop->sigs[signo].cb)
                        evloop_release_signal(loop, signo);
        if (loop->sigfd >= 0)
                close(loop->sigfd);
        for (size_t i = 0; i < loop->n_heap; i++)
                loop->heap[i]->heap_index = EVLOOP_TIMER_IDLE;
        free(loop->heap);
        free(loop->io);
        free(loop->pfds);
        free(loop);
        return NULL;
}
