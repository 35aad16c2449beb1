/*
 * Retry pacing for the daemons that attach to sharedlinkd (sharedlink-mqtt, sharedlink-agility,
 * sharedlink-ros2): the first retry BACKOFF_MIN_MS after a failure, each next one twice as late,
 * at most BACKOFF_MAX_MS apart; a success starts over, so that the next outage is retried fast
 * and reported again. Times are the caller's monotonic milliseconds.
 */
#ifndef SHAREDLINK_SVC_BACKOFF_H
#define SHAREDLINK_SVC_BACKOFF_H

#include <stdbool.h>
#include <stdint.h>

#define BACKOFF_MIN_MS          100u    /* sl_open retries while no daemon runs ... */
#define BACKOFF_MAX_MS          5000u   /* ... doubling to this */

struct backoff {
        unsigned delay_ms;              /* after the next failure */
        uint64_t due_ms;                /* the next try; 0: at once */
};

/* Due at once, the first delay BACKOFF_MIN_MS. Also what a success does. */
void backoff_reset(struct backoff *b);

/* Whether a try is due at now_ms. */
bool backoff_due(const struct backoff *b, uint64_t now_ms);

/* When the next try is due (0: at once). */
uint64_t backoff_due_ms(const struct backoff *b);

/* A try failed at now_ms: the next is due one delay later and the delay doubles (bounded).
 * true for the first failure since the last reset: the one worth a log line. */
bool backoff_failed(struct backoff *b, uint64_t now_ms);

#endif
