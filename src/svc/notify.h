/*
 * Service manager notifications (sd_notify(3)): READY=1, STATUS=, WATCHDOG=1, RELOADING=1,
 * STOPPING=1. Built with libsystemd (HAVE_LIBSYSTEMD=1) it calls sd_notify() and
 * sd_watchdog_enabled(). Built without (WITH_SYSTEMD=0) it speaks the protocol itself rather
 * than doing nothing: a unit with Type=notify would otherwise never see READY=1 and time out.
 * The protocol is one AF_UNIX datagram of newline-separated assignments to $NOTIFY_SOCKET (a
 * path, or an abstract name written with a leading '@'); systemd documents it as stable.
 *
 * Without $NOTIFY_SOCKET (started by hand, or by a test) every call is a no-op returning 0.
 */
#ifndef SHAREDLINK_SVC_NOTIFY_H
#define SHAREDLINK_SVC_NOTIFY_H

#include <stdbool.h>
#include <stdint.h>

#define NOTIFY_STATUS_MAX       256     /* bytes of STATUS= text kept */
#define NOTIFY_MESSAGE_MAX      512     /* one datagram */

struct notify;

/* Reads $NOTIFY_SOCKET and the watchdog settings once; 0 or -ENOMEM. */
int notify_new(struct notify **ret_notify);

/* Frees; returns NULL. */
struct notify *notify_free(struct notify *n);

/* Whether there is a service manager to tell ($NOTIFY_SOCKET set). */
bool notify_enabled(const struct notify *n);

/* Sends raw newline-separated assignments; 1 sent, 0 no service manager, or -errno. */
int notify_send(struct notify *n, const char *assignments);

/* READY=1: startup finished (tables exist, every link tried). */
int notify_ready(struct notify *n);

/* STATUS=<text>: one line shown by systemctl status (newlines become spaces). */
int notify_status(struct notify *n, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* WATCHDOG=1: the main loop is alive. */
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

/* The protocol without libsystemd: sends `text` as one datagram to the socket `path` ('/...'
 * or '@abstract'); 1 or -errno. Used by WITH_SYSTEMD=0 builds, exported so that both builds
 * test it. */
int notify_send_datagram(const char *path, const char *text);

#endif
