/*
 * The waker: how a daemon that is a client of sharedlinkd (sharedlink-mqtt, sharedlink-agility,
 * ...) hears that the tables changed, on its event loop. A change is a futex on the tables'
 * change word (sl_wait), which poll cannot watch; so a small thread sleeps in sl_wait and rings
 * an eventfd on the loop, and the loop calls the daemon back. Built only on <sharedlink.h>.
 */
#ifndef SVC_WAKER_H
#define SVC_WAKER_H

#include <stdbool.h>
#include <stdint.h>

#include <sharedlink.h>

#include "svc/evloop.h"

#define WAKER_SLICE_MS          250     /* sl_wait slice: how soon the thread sees a stop */

struct waker;

/* Called on the loop after one or more changes (coalesced). */
typedef void (*waker_fn)(void *arg);

/*
 * Called on the waker's own thread after each change, before the loop hears of it: for a daemon
 * whose hot path must not pay the loop's wake-up on top of the waker's (on a virtual machine
 * each costs tens of microseconds). It runs concurrently with the loop, so it may touch only
 * what the caller guards itself, never the loop. Returns true when fn must run on the loop too
 * (coalesced as ever), false when the thread did all there was to do.
 */
typedef bool (*waker_thread_fn)(void *arg);

/* Options of waker_start_with; all zero is exactly waker_start. */
struct waker_opts {
        waker_thread_fn on_thread;      /* NULL: every change goes to the loop */
        uint32_t spin_us;               /* > 0: sl_wait_with SL_WAIT_SPIN, polling the table
                                         * this long before each sleep (a CPU kept busy for it);
                                         * at most SL_WAIT_SPIN_MAX_US */
};

/*
 * Starts following c's changes: fn(arg) runs on loop after each. c must outlive the waker. 0, or
 * -errno (logged) with nothing started; the caller then rescans on a timer of its own.
 */
int waker_start(struct evloop *loop, struct sl_client *c, waker_fn fn, void *arg,
                struct waker **ret);

/* waker_start with opts (NULL: none). -EINVAL for a spin_us above SL_WAIT_SPIN_MAX_US. */
int waker_start_with(struct evloop *loop, struct sl_client *c, waker_fn fn, void *arg,
                     const struct waker_opts *opts, struct waker **ret);

/* Stops the thread and takes the eventfd off the loop; accepts NULL; returns NULL. */
struct waker *waker_stop(struct waker *w);

#endif
