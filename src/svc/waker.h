/*
 * The waker: how a daemon that is a client of sharedlinkd (sharedlink-mqtt, sharedlink-agility,
 * ...) hears that the tables changed, on its event loop. A change is a futex on the tables'
 * change word (sl_wait), which poll cannot watch; so a small thread sleeps in sl_wait and rings
 * an eventfd on the loop, and the loop calls the daemon back. Built only on <sharedlink.h>.
 */
#ifndef SVC_WAKER_H
#define SVC_WAKER_H

#include <sharedlink.h>

#include "svc/evloop.h"

#define WAKER_SLICE_MS          250     /* sl_wait slice: how soon the thread sees a stop */

struct waker;

/* Called on the loop after one or more changes (coalesced). */
typedef void (*waker_fn)(void *arg);

/*
 * Starts following c's changes: fn(arg) runs on loop after each. c must outlive the waker. 0, or
 * -errno (logged) with nothing started; the caller then rescans on a timer of its own.
 */
int waker_start(struct evloop *loop, struct sl_client *c, waker_fn fn, void *arg,
                struct waker **ret);

/* Stops the thread and takes the eventfd off the loop; accepts NULL; returns NULL. */
struct waker *waker_stop(struct waker *w);

#endif
