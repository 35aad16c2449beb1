/*
 * sharedlink-ros2: the bridge between a sharedlinkd instance (through the public libsharedlink
 * only) and ROS 2 over DDS (ros2_dds.h). Not thread-safe: main.c drives it from its loop and from
 * the waker's thread (scan and pump, where a change is heard first), one at a time under its lock:
 *
 *   ros2_bridge_new      the participant and the bridge's own topics (events, set_errors,
 *                        /diagnostics); a domain that cannot be created fails here
 *   ros2_bridge_attach   opens the instance (retried while no daemon runs)
 *   ros2_bridge_scan     plans topics for the variables (names, collisions) when they change,
 *                        publishes what changed, NavSatFix messages, and notes link states
 *   ros2_bridge_pump     events from the ring, in order, to <namespace>/events, from the
 *                        place in cursor_file (svc/cursor.h) across restarts
 *   ros2_bridge_dds      what DDS delivered (its listener rang ros2_bridge_fd): writes from
 *                        <namespace>/set/<name>, writers discovered on set topics
 *   ros2_bridge_diagnostics  one DiagnosticArray on /diagnostics
 *
 * Topics and QoS: docs/ros2.md.
 */
#ifndef SHAREDLINK_ROS2_BRIDGE_H
#define SHAREDLINK_ROS2_BRIDGE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "ros2/ros2_config.h"

#define ROS2_LINKS_MAX          64      /* links with a diagnostic status */

/* What the bridge counts (in its diagnostic status). */
struct ros2_counters {
        uint64_t values_published;
        uint64_t unconvertible;         /* values that are not their type's text (not sent) */
        uint64_t events_published;
        uint64_t events_lost;           /* overwritten in the ring before the bridge read them */
        uint64_t events_blocked;        /* writes that found the events history full */
        uint64_t cursor_errors;         /* failed writes of cursor_file */
        uint64_t set_written;
        uint64_t set_refused;
        uint64_t set_writers_waiting;   /* on set topics, seen before the first plan: judged
                                         * by it (a gauge) */
        uint64_t navsatfix_published;
        uint64_t dds_errors;            /* writes or endpoints DDS refused */
};

struct ros2_bridge;

/* A bridge for cfg (kept by pointer: it must outlive the bridge). 0, or -errno with the reason
 * in err ("domain 7: ..."). */
int ros2_bridge_new(const struct ros2_config *cfg, struct ros2_bridge **ret, char *err,
                    size_t err_size);

/* Frees; NULL-safe; returns NULL. */
struct ros2_bridge *ros2_bridge_free(struct ros2_bridge *b);

/* Opens the instance if it is not open yet. 0, -ENOENT while no daemon runs, or -errno. */
int ros2_bridge_attach(struct ros2_bridge *b);

/* The library handle (NULL before attach): for main.c's waker. */
struct sl_client *ros2_bridge_client(struct ros2_bridge *b);

/* The namespace in use. */
const char *ros2_bridge_namespace(const struct ros2_bridge *b);

/* The fd DDS's listeners ring (readable: call ros2_bridge_dds). */
int ros2_bridge_fd(const struct ros2_bridge *b);

/* See above. Each returns what it published (>= 0) or -errno. */
int ros2_bridge_scan(struct ros2_bridge *b);
int ros2_bridge_pump(struct ros2_bridge *b);
int ros2_bridge_dds(struct ros2_bridge *b);
int ros2_bridge_diagnostics(struct ros2_bridge *b);

/* Stores the events' place in cursor_file once the events readers acknowledged every event
 * written (waiting up to wait_ms for them; 0: only looking). 0, -EAGAIN (not all acknowledged
 * yet: again later), or -errno. */
int ros2_bridge_cursor_flush(struct ros2_bridge *b, int64_t wait_ms);

/* The events' place moved past what cursor_file holds (a flush to try again soon). */
bool ros2_bridge_cursor_pending(const struct ros2_bridge *b);

/* Whether a /diagnostics message is due before the next tick (a link's state changed, a
 * write was refused, the variables were planned again). */
bool ros2_bridge_diag_due(const struct ros2_bridge *b);

/* Whether the events history was full at the last pump (main.c retries on its tick). */
bool ros2_bridge_events_blocked(const struct ros2_bridge *b);

/* "running", "sharedlinkd not running", ... for STATUS=. */
const char *ros2_bridge_status(struct ros2_bridge *b);

const struct ros2_counters *ros2_bridge_counters(const struct ros2_bridge *b);

/*
 * The -n check against a running daemon's tables (the file alone cannot know the variables:
 * Pronto4 peers declare theirs at run time): navsatfix: variables that do not exist or are not
 * numbers, and two published variables (or a variable and a navsatfix topic, or one of the
 * bridge's own names) on one topic. 0 and nothing in err when all is well, -ENOENT when no
 * daemon runs (nothing checked), or -EINVAL with "FILE:LINE:COL: message" (path given).
 */
int ros2_bridge_check(const struct ros2_config *cfg, const char *path, char *err,
                      size_t err_size);

#endif
