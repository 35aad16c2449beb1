/*
 * Service manager notifications (sd_notify(3)): READY=1, STATUS=, WATCHDOG=1, RELOADING=1,
 * STOPPING=1. It speaks the protocol itself, in every build: one AF_UNIX datagram of
 * newline-separated assignments to $NOTIFY_SOCKET (a path, or an abstract name written with a
 * leading '@'), which systemd documents as stable. Not sd_notify(): it waits without bound when
 * the manager's queue is full, and the loop that sends must never stall on a manager (or a
 * test) that does not read. The periodic messages (STATUS=, WATCHDOG=1) do not wait at all: one
 * that finds no room is dropped and the next one says the same. The ones sent once (READY=1,
 * RELOADING=1, STOPPING=1, notify_send()) wait up to NOTIFY_ONCE_WAIT_MS. Every message not
 * sent is counted (notify_failed()). With libsystemd (HAVE_LIBSYSTEMD=1) the watchdog settings
 * are read by sd_watchdog_enabled(); without it, from the same variables by hand.
 *
 * Without $NOTIFY_SOCKET (started by hand, or by a test) every call is a no-op returning 0.
 */
#ifndef SHAREDLINK_SVC_NOTIFY_H
#define SHAREDLINK_SVC_NOTIFY_H

#include <stdbool.h>
#include <stdint.h>

#define NOTIFY_STATUS_MAX       256     /* bytes of STATUS= text kept */
#define NOTIFY_MESSAGE_MAX      512     /* one datagram */
#define NOTIFY_ONCE_WAIT_MS     1000    /* READY=1 & co. wait this long for room in the queue */

struct notify;

/* Reads $NOTIFY_SOCKET and the watchdog settings once; 0 or -ENOMEM. */
int notify_new(struct notify **ret_notify);

/* Frees; returns NULL. */
struct notify *notify_free(struct notify *n);

/* Whether there is a service manager to tell ($NOTIFY_SOCKET set). */
bool notify_enabled(const struct notify *n);

/* Sends raw newline-separated assignments, waiting up to NOTIFY_ONCE_WAIT_MS for room; 1 sent,
 * 0 no service manager, or -errno (-EAGAIN: the manager's queue stayed full). */
int notify_send(struct notify *n, const char *assignments);

/* How many messages could not be sent (queue full, socket gone...). */
uint64_t notify_failed(const struct notify *n);

/* READY=1: startup finished (tables exist, every link tried). */
int notify_ready(struct notify *n);

/* STATUS=<text>: one line shown by systemctl status (newlines become spaces). Never waits:
 * -EAGAIN when the manager's queue is full. */
int notify_status(struct notify *n, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* WATCHDOG=1: the main loop is alive. Never waits (-EAGAIN when the queue is full). */
int notify_watchdog(struct notify *n);

/* RELOADING=1 with MONOTONIC_USEC=now: a reload started (send READY=1 when it is done). */
int notify_reloading(struct notify *n);

/* STOPPING=1: a clean stop started. */
int notify_stopping(struct notify *n);

/* WatchdogSec= of the unit in microseconds (WATCHDOG_USEC, when WATCHDOG_PID is ours or
 * unset); 0 when there is no watchdog. */
uint64_t notify_watchdog_usec(const struct notify *n);

/* How often to send WATCHDOG=1: half the watchdog period, as sd_watchdog_enabled(3) advises;
 * 0 when there is no watchdog. */
uint64_t notify_watchdog_interval_ms(const struct notify *n);

/* The protocol: sends `text` as one datagram to the socket `path` ('/...' or '@abstract'),
 * waiting up to wait_ms for room in the receiver's queue (0: not at all); 1 or -errno
 * (-EAGAIN: no room in time). */
int notify_send_datagram(const char *path, const char *text, unsigned wait_ms);

#endif
