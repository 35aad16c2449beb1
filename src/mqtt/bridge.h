/*
 * sharedlink-mqtt: the bridge between a sharedlinkd instance (through the public libsharedlink
 * only) and an MQTT broker (through a sink: one per connection of bridge_mqtt.c in the program,
 * a fake one in tests/unit/test_bridge.c). The logic lives here, independent of libmosquitto;
 * it is driven from one thread by main.c:
 *
 *   bridge_attach     opens the instance (retried while no daemon runs)
 *   bridge_scan       publishes what changed: values (+ meta), link states, status
 *   bridge_pump       publishes events from the ring, at most events_window unacknowledged
 *   bridge_acked      the broker acknowledged message mid: the cursor moves over acked events
 *   bridge_set        a message on base/set/<name>: written, or refused with an error reply
 *                     (always refused when it was retained or waited through a disconnection)
 *
 * Events: every event is published with QoS events_qos; the cursor on disk (svc/cursor.h)
 * only moves over events whose PUBACK (QoS 1) or PUBCOMP (QoS 2) came back, in ring order, so
 * a bridge that stops at any moment resumes with the first event the broker has not confirmed.
 * What that gives across restarts:
 *  - bridge restart: a clean stop (SIGTERM) first waits up to drain_ms for the outstanding
 *    acknowledgements, so nothing is sent twice; a crash re-sends the unconfirmed tail (at most
 *    events_window events): at least once, never lost, with seq/epoch in every payload to drop
 *    the repeats.
 *  - broker restart or a dropped connection: the session is persistent (clean_session false,
 *    fixed client id), so libmosquitto re-sends the unconfirmed messages with their message ids
 *    after reconnecting. With events_qos 2 the broker keeps the ids of the QoS 2 messages it has
 *    received (in its persistence file across its own restart) and drops a re-sent one: exactly
 *    once, and in order at the subscribers given the broker settings of sharedlink-mqtt(8),
 *    BROKER REQUIREMENTS. With QoS 1 the protocol has no such memory: a message whose PUBACK
 *    was lost with the connection arrives twice (same seq).
 *  - the daemon's ring overran (events written faster than the bridge got them out): an
 *    "overrun" notice with the number lost goes out before the next event, never hidden.
 */
#ifndef SHAREDLINK_MQTT_BRIDGE_H
#define SHAREDLINK_MQTT_BRIDGE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "mqtt/bridge_config.h"

#define BRIDGE_BASE_MAX         (BRIDGE_PREFIX_MAX + BRIDGE_INSTANCE_MAX + 2)
#define BRIDGE_LINKS_MAX        64      /* links whose state is published */
#define BRIDGE_VARS_MAX         65536   /* variables followed (the daemon's table is smaller) */

/* Where messages go. publish returns 0 with *ret_mid set (the id bridge_acked gets later for
 * QoS > 0), or -errno when the message could not be queued (not connected, say). */
struct bridge_sink {
        int (*publish)(void *arg, const char *topic, const void *payload, size_t len, int qos,
                       bool retain, int *ret_mid);
        void *arg;
};

/* What the bridge counts; published as JSON on base/bridge. */
struct bridge_counters {
        uint64_t values_published;
        uint64_t events_published;
        uint64_t events_acked;
        uint64_t events_lost;           /* overwritten in the ring before the bridge read them */
        uint64_t set_written;
        uint64_t set_refused;
        uint64_t unpublishable;         /* variables whose name cannot be a topic */
        uint64_t publish_errors;
        uint64_t cursor_errors;
        uint64_t broker_errors;         /* connections refused, failed or dropped */
};

struct bridge;

/* A bridge for cfg (kept by pointer: it must outlive the bridge). 0, -ENOMEM or -EINVAL (a base
 * topic that does not fit). */
int bridge_new(const struct bridge_config *cfg, struct bridge **ret);

/* Frees; NULL-safe; returns NULL. */
struct bridge *bridge_free(struct bridge *b);

/* Opens the instance if it is not open yet and loads the cursor. 0, or -ENOENT while no daemon
 * runs (call again later), or -errno. */
int bridge_attach(struct bridge *b);

/* Whether the instance is open. */
bool bridge_attached(const struct bridge *b);

/* The library handle (NULL before bridge_attach succeeded): for sl_wait in main.c's waker. */
struct sl_client *bridge_client(struct bridge *b);

/* "<prefix>/<instance>". */
const char *bridge_base(const struct bridge *b);

/* Publishes what changed since the last scan; with full, everything (after a (re)connect: QoS 0
 * messages queued at a disconnect are gone). Returns the number of messages queued or -errno. */
int bridge_scan(struct bridge *b, const struct bridge_sink *sink, bool full);

/* Publishes events until the ring is empty or events_window are unacknowledged. Returns the
 * number published or -errno. */
int bridge_pump(struct bridge *b, const struct bridge_sink *sink);

/* The broker acknowledged mid; unknown mids (values) are ignored. */
void bridge_acked(struct bridge *b, int mid);

/* Counts a broker connection that was refused, failed or dropped (published once connected
 * again: the history of the link to the broker). */
void bridge_broker_error(struct bridge *b);

/* Number of events published and not yet acknowledged. */
unsigned bridge_unacked(const struct bridge *b);

/* Writes the cursor if it moved (sync: with fsync, see svc/cursor.h). 0 or -errno. */
int bridge_cursor_flush(struct bridge *b, bool sync);

/* How a set/ message reached the bridge (bridge_mqtt.c tells it from the connection it came on
 * and its retain flag; see bridge_mqtt.h for why there are two connections). */
enum bridge_set_via {
        BRIDGE_SET_LIVE,                /* as it was published, to the bridge's clean session */
        BRIDGE_SET_RETAINED,            /* the broker kept it (retain flag): never a write */
        BRIDGE_SET_QUEUED,              /* on the persistent session: it waited for the bridge */
};

/* Handles a message that arrived on topic (under base/set/): writes the variable, or refuses
 * (counted, and an error JSON on base/set/<name>/error through sink). Only a LIVE message is
 * ever written. Returns 1 written, 0 ignored (one of our own error replies, or an empty
 * retained message: a publisher clearing one), or -EPERM (not allowed: inbound, not writable,
 * retained, queued) / -EINVAL (anything else). */
int bridge_set(struct bridge *b, const struct bridge_sink *sink, const char *topic,
               const void *payload, size_t len, enum bridge_set_via via);

/* Whether set/ messages reach the bridge now (its set/ subscription was acknowledged). While
 * writable: names anything and they do not, base/status says offline: writes are not taken. */
void bridge_writes_ready(struct bridge *b, bool ready);

/* "online" when the daemon is running, else "offline" (base/status also needs writes ready). */
const char *bridge_status(struct bridge *b);

/* The counters; and the JSON of them into buf (length or -ENOBUFS). */
const struct bridge_counters *bridge_counters(const struct bridge *b);
int bridge_counters_json(const struct bridge *b, char *buf, size_t size);

/* Changes whenever a counter changes: a cheap "is there something new to publish". */
uint64_t bridge_counters_version(const struct bridge *b);

#endif
