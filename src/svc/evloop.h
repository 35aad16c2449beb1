/*
 * Event loop on poll(2): file descriptors, monotonic timers and signals (through signalfd),
 * one instance per loop, single-threaded.
 *
 *      struct evloop *loop;
 *      struct evloop_timer tick;
 *
 *      evloop_new(&loop);
 *      evloop_add_signal(loop, SIGTERM, on_term, ctx);       // on_term calls evloop_exit()
 *      evloop_add_fd(loop, fd, POLLIN, on_readable, ctx);
 *      evloop_timer_init(&tick, loop, on_tick, ctx);
 *      evloop_timer_arm(&tick, 100, 100);                     // every 100 ms
 *      code = evloop_run(loop);
 *      evloop_free(loop);
 *
 * Rules that the users can rely on:
 * - No busy waiting: with no armed timer, poll() waits forever; with one, it waits until the
 *   earliest deadline (rounded up to the next millisecond, so it never wakes early). The loop
 *   counts its wakeups, and a wakeup that found nothing to do (no fd ready, no timer due) is
 *   counted as idle: the figure behind "no wakeups beyond the configured timers".
 * - Any fd, timer or signal may be added, changed or removed from inside any callback, the one
 *   being dispatched included. A removed fd or cancelled timer is never called again, even if
 *   it was ready in the same round; an fd added (or re-added under the same number) during a
 *   round is first polled in the next round, so it never sees the previous owner's events.
 *   A timer armed from inside a callback does not fire in the same round, even with delay 0.
 * - An fd registered with events 0 is not polled at all (not even for POLLHUP/POLLERR); set
 *   POLLOUT only while output is queued. EVLOOP_HANGUP keeps an fd polled for POLLHUP/POLLERR
 *   alone while it asks for nothing else (a socket whose peer shut its sending side may still
 *   go away altogether); its callback must then end the fd or drop EVLOOP_HANGUP, since poll()
 *   reports a hangup for as long as it lasts.
 * - A callback receiving POLLNVAL (an fd closed without evloop_del_fd) is called once, then the
 *   fd is dropped from the loop, so a forgotten fd cannot make the loop spin.
 * - Signals given to evloop_add_signal() are blocked with pthread_sigmask() and read from a
 *   signalfd. Add them before starting threads, so every thread inherits the blocked mask.
 *   Standard signals coalesce: one SIGCHLD callback may stand for several exited children, so
 *   reap with waitpid(WNOHANG) in a loop. A signal belongs to one loop per process.
 * - evloop_free() and evloop_run() must not be called from inside a callback.
 */
#ifndef SHAREDLINK_SVC_EVLOOP_H
#define SHAREDLINK_SVC_EVLOOP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define EVLOOP_FDS_MAX          1024    /* fds per loop (links, control clients, wakeup fds) */
#define EVLOOP_TIMERS_MAX       4096    /* armed timers per loop */
#define EVLOOP_TIMER_IDLE       SIZE_MAX
/* Not a poll(2) event (those fit in a short): poll the fd for POLLHUP/POLLERR even when it
 * asks for no other event. */
#define EVLOOP_HANGUP           0x10000u

struct evloop;
struct evloop_timer;

/* An fd is ready: revents holds the ready subset of its events plus POLLERR/POLLHUP/POLLNVAL. */
typedef void (*evloop_fd_cb)(struct evloop *loop, int fd, unsigned revents, void *arg);
/* A timer is due. A one-shot timer is idle again when this runs (so it may re-arm itself). */
typedef void (*evloop_timer_cb)(struct evloop *loop, struct evloop_timer *timer, void *arg);
/* A signal arrived (once per coalesced delivery). */
typedef void (*evloop_signal_cb)(struct evloop *loop, int signo, void *arg);

/*
 * A timer lives in its owner's struct (no allocation per timer). Its fields are private to the
 * loop; set it up with evloop_timer_init() and cancel it before freeing its memory.
 */
struct evloop_timer {
        struct evloop *loop;
        evloop_timer_cb cb;
        void *arg;
        uint64_t deadline_ns;           /* CLOCK_MONOTONIC */
        uint64_t interval_ns;           /* 0: one-shot */
        uint64_t seq;                   /* arming order: equal deadlines fire in arming order */
        size_t heap_index;              /* EVLOOP_TIMER_IDLE while not armed */
};

/* Wakeup and dispatch counters since evloop_new(). */
struct evloop_stats {
        uint64_t wakeups;               /* poll() returns, for any reason */
        uint64_t idle_wakeups;          /* wakeups that dispatched nothing (EINTR included) */
        uint64_t fd_events;             /* fd callbacks run */
        uint64_t timer_fires;           /* timer callbacks run */
        uint64_t signals;               /* signal callbacks run */
        uint64_t nval_drops;            /* fds dropped after POLLNVAL */
};

/* Creates a loop; 0 or -errno. */
int evloop_new(struct evloop **ret_loop);

/* Closes the signalfd, unblocks the signals it blocked, disarms every timer; returns NULL. */
struct evloop *evloop_free(struct evloop *loop);

/* Watches fd for events (POLLIN, POLLOUT, POLLPRI, EVLOOP_HANGUP); -EEXIST, -EINVAL, -ENOSPC or
 * -ENOMEM. */
int evloop_add_fd(struct evloop *loop, int fd, unsigned events, evloop_fd_cb cb, void *arg);

/* Changes the events of a watched fd (0 stops polling it); 0 or -ENOENT, -EINVAL. */
int evloop_mod_fd(struct evloop *loop, int fd, unsigned events);

/* Stops watching fd (the caller closes it); 0 or -ENOENT. */
int evloop_del_fd(struct evloop *loop, int fd);

/* Prepares a timer of `loop`; it stays idle until armed. */
void evloop_timer_init(struct evloop_timer *timer, struct evloop *loop, evloop_timer_cb cb,
                       void *arg);

/* Arms (or re-arms) a timer to fire delay_ms from now, then every interval_ms (0: once).
 * A periodic timer that falls behind skips the missed periods rather than firing in a burst.
 * 0 or -ENOSPC (EVLOOP_TIMERS_MAX armed), -ENOMEM, -EINVAL (timer not initialised). */
int evloop_timer_arm(struct evloop_timer *timer, uint64_t delay_ms, uint64_t interval_ms);

/* Disarms a timer; idle timers (and NULL) are fine. */
void evloop_timer_cancel(struct evloop_timer *timer);

/* Whether the timer is armed. */
bool evloop_timer_armed(const struct evloop_timer *timer);

/* Calls cb on each delivery of signo (blocked from now on); -EEXIST, -EINVAL or -errno. */
int evloop_add_signal(struct evloop *loop, int signo, evloop_signal_cb cb, void *arg);

/* Stops handling signo: pending deliveries are discarded, the old blocked state restored. */
int evloop_del_signal(struct evloop *loop, int signo);

/* Polls once (waiting as long as the next timer allows) and dispatches; 0 or -errno. */
int evloop_run_once(struct evloop *loop);

/* Runs until evloop_exit(); returns its code, or -errno if poll() failed for good. */
int evloop_run(struct evloop *loop);

/* Makes evloop_run() return `code` (>= 0) after the current round (at once if called before). */
void evloop_exit(struct evloop *loop, int code);

/* Whether evloop_exit() was called since evloop_run() last returned. */
bool evloop_exiting(const struct evloop *loop);

/* The poll timeout the next round would use: -1 (no timer: forever), 0, or milliseconds. */
int evloop_next_timeout_ms(const struct evloop *loop);

/* CLOCK_MONOTONIC in ns as of the last wakeup (cheap; use it for timestamps in callbacks). */
uint64_t evloop_now_ns(const struct evloop *loop);

/* A fresh CLOCK_MONOTONIC reading in ns. */
uint64_t evloop_clock_ns(void);

/* Copies the counters. */
void evloop_get_stats(const struct evloop *loop, struct evloop_stats *ret_stats);

#endif
