/*
 * sharedlink-mqtt: the libmosquitto side. Driven without a thread of its own from main.c's poll
 * loop (one fd, want_write, misc), with TLS and username/password from the configuration, and
 * reconnection with a doubling backoff (reconnect_min_ms .. reconnect_max_ms) whenever the
 * broker is down or drops a connection.
 *
 * Two connections, because what the events need and what the writes need are opposite:
 *  - the bridge's own (client id client_id): MQTT 3.1.1 with a persistent session (clean_session
 *    false, fixed client id: see bridge.h for what that buys the events), the last will
 *    "offline" on base/status. Everything the bridge publishes goes out on it. It subscribes to
 *    nothing: it unsubscribes base/set/# at every connection (the subscription an older bridge
 *    kept there), and a set/ message that still arrives on it waited in the session while the
 *    bridge was away: refused ("queued"), never written.
 *  - the writes' (client id client_id + "-set", only when writable: names anything): MQTT 5,
 *    clean start and no session expiry, so the broker keeps nothing for it while it is away and
 *    a write published meanwhile is dropped by the broker, never delivered late; subscribed to
 *    base/set/# with retain-as-published (a retained write keeps its flag, also when it arrives
 *    as it is published, and is refused) and no-local. The answers to what arrives on it go out
 *    on it; base/status says online only while its subscription stands.
 * With both, main.c polls an epoll fd that holds the two sockets.
 */
#ifndef SHAREDLINK_MQTT_BRIDGE_MQTT_H
#define SHAREDLINK_MQTT_BRIDGE_MQTT_H

#include <stdbool.h>
#include <stdint.h>

#include "mqtt/bridge.h"
#include "mqtt/bridge_config.h"

struct bridge_mqtt;

/* A client for cfg that hands acknowledgements and set/ messages to b. 0 or -errno (message in
 * err: a TLS file that cannot be used, say). */
int bridge_mqtt_new(const struct bridge_config *cfg, struct bridge *b, struct bridge_mqtt **ret,
                    char *err, size_t err_size);

/* Frees; NULL-safe; returns NULL. */
struct bridge_mqtt *bridge_mqtt_free(struct bridge_mqtt *bm);

/* The sink that publishes through this client. */
const struct bridge_sink *bridge_mqtt_sink(struct bridge_mqtt *bm);

/* Starts a connection attempt when none runs and the backoff allows it at now_ns. */
void bridge_mqtt_connect_due(struct bridge_mqtt *bm, uint64_t now_ns);

/* The fd to poll (-1 when none; call it before each poll: it also sets up what the epoll fd
 * watches) and whether POLLOUT is wanted (the bridge's own connection has output queued: main.c
 * also lets values wait on it). */
int bridge_mqtt_fd(struct bridge_mqtt *bm);
bool bridge_mqtt_want_write(struct bridge_mqtt *bm);

/* Handles poll results of the socket (revents may be 0) and the periodic keepalive work. */
void bridge_mqtt_io(struct bridge_mqtt *bm, short revents, uint64_t now_ns);

/* Milliseconds until bridge_mqtt_io or _connect_due have something to do (a bound). */
int bridge_mqtt_timeout_ms(const struct bridge_mqtt *bm, uint64_t now_ns);

/* 1 once CONNACK accepted and until the connection drops (the bridge's own connection). */
bool bridge_mqtt_connected(const struct bridge_mqtt *bm);

/* Why the last connection attempt failed or the connection dropped ("" while connected or
 * before the first attempt), the bridge's own or else the writes' ("set/: ..."): for the
 * service status. */
const char *bridge_mqtt_error(struct bridge_mqtt *bm);

/* 1 once after each accepted (re)connection: the caller then publishes everything. */
bool bridge_mqtt_take_fresh(struct bridge_mqtt *bm);

/* Publishes "offline" and disconnects both cleanly (the broker then drops the will). */
void bridge_mqtt_disconnect(struct bridge_mqtt *bm);

#endif
