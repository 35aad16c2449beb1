/*
 * The instance's pulse: the heartbeat timer (the shm table's heartbeat, each engine's, the
 * recorders' sweep, then STATUS=) and, when systemd asks for one, the watchdog timer, both on
 * the loop, so that a stuck loop shows.
 */
#ifndef SHAREDLINK_DAEMON_DAEMON_STATUS_H
#define SHAREDLINK_DAEMON_DAEMON_STATUS_H

#include <stdbool.h>

struct daemon;

/* Sets the timers up, not armed. */
void daemon_status_init(struct daemon *d);

/* Arms the heartbeat and (when the service manager wants one) the watchdog. 0 or -errno. */
int daemon_status_start(struct daemon *d);

/* Disarms both. */
void daemon_status_stop(struct daemon *d);

/*
 * "N of M links up", then what is wrong with the others while it fits; sent as STATUS= when it
 * changed. With ready, sent in one datagram with READY=1 (so that whoever waits for READY=1 also
 * has the status it came with).
 */
void daemon_status(struct daemon *d, bool ready);

#endif
