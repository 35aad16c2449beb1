/*
 * MQTT test helpers: a private mosquitto broker on 127.0.0.1 (a free port, its own config and
 * persistence in the test's directory; never the system's broker), the sharedlink-mqtt bridge
 * under test (started like the daemon: READY=1 on a test NOTIFY_SOCKET), and a real MQTT client
 * (libmosquitto with its own thread) that records what arrives.
 *
 * Every wait has a timeout in milliseconds and returns -ETIMEDOUT when it passes.
 */
#pragma once

#include <pthread.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "common/harness.h"

#define MQTT_TOPIC_MAX          256
#define MQTT_PAYLOAD_MAX        1024
#define MQTT_VALUES_MAX         4096    /* topics whose last payload a client keeps */
#define MQTT_BROKER_INFLIGHT    1000    /* the broker's max_inflight_messages: see mqtt.c */

struct mqtt_broker {
        char dir[HARNESS_PATH_MAX];
        char conf[HARNESS_PATH_MAX + 32];
        char log[HARNESS_PATH_MAX + 32];
        int port;
        pid_t pid;                      /* 0 when not running */
        /* Lines for the listener (cafile/certfile/keyfile: TLS) and its security
         * (password_file, allow_anonymous false); NULL: anonymous plain TCP. */
        const char *listener_conf;
};

struct mqtt_bridge {
        struct harness *h;
        char notify_path[HARNESS_PATH_MAX + 32];
        char log_path[HARNESS_PATH_MAX + 32];
        int notify_fd;
        pid_t pid;
        char status[1024];              /* the last STATUS= notification seen */
};

/* The last payload seen on one topic. */
struct mqtt_value {
        char topic[MQTT_TOPIC_MAX];
        char payload[MQTT_PAYLOAD_MAX];
        size_t len;
        uint64_t count;                 /* messages seen on this topic */
};

/* One message on an events topic, as the test needs it. */
struct mqtt_event {
        uint64_t seq;
        int mid;                        /* the broker's message id (a redelivery keeps it) */
        uint64_t lost;                  /* an "overrun" notice: events lost */
        long sensor_time;               /* -1 when none */
        char type[24];
};

/* Called from the client's thread for every message (bench: timestamps). */
typedef void (*mqtt_message_fn)(void *arg, const char *topic, const void *payload, size_t len);

struct mqtt_client {
        struct mosquitto *m;
        pthread_mutex_t lock;
        pthread_cond_t cond;
        bool connected;
        uint64_t connects;
        struct mqtt_value *values;      /* MQTT_VALUES_MAX */
        unsigned n_values;
        struct mqtt_event *events;      /* growing */
        size_t n_events, cap_events;
        uint64_t messages;
        char subscription[MQTT_TOPIC_MAX];
        int qos;
        mqtt_message_fn on_message;
        void *on_message_arg;
};

/* Path of the bridge under test: $SHAREDLINK_BUILD/sharedlink-mqtt. */
const char *mqtt_bridge_path(void);

/* 1 when a mosquitto broker binary is installed. */
int mqtt_broker_available(void);

/* Writes a broker config into dir (listener 127.0.0.1:port, a free port when port is 0,
 * b->listener_conf or anonymous, persistence in dir) and starts mosquitto; 0 once it accepts
 * TCP connections. */
int mqtt_broker_start(struct mqtt_broker *b, const char *dir, int port, int timeout_ms);

/* SIGTERM (the broker saves its persistence file) and wait; 0 or -ETIMEDOUT. */
int mqtt_broker_stop(struct mqtt_broker *b, int timeout_ms);

/* Starts the bridge with `-c config` (environment of h); 0 once READY=1 came, -ECHILD when it
 * exited first (*ret_status), -ETIMEDOUT. Its stderr goes to <h->dir>/bridge.log. */
int mqtt_bridge_start(struct mqtt_bridge *br, struct harness *h, const char *config,
                      int timeout_ms, int *ret_status);

/* Sends sig and waits for the exit; the wait status, or -ETIMEDOUT. */
int mqtt_bridge_stop(struct mqtt_bridge *br, int sig, int timeout_ms);

/* Closes the notify socket (after the bridge stopped for good). */
void mqtt_bridge_cleanup(struct mqtt_bridge *br);

/* Whether the bridge's log contains needle: 1, 0 or -errno. */
int mqtt_bridge_log_contains(struct mqtt_bridge *br, const char *needle);

/* Waits until the bridge's log contains needle at least n times; 0 or -ETIMEDOUT. */
int mqtt_bridge_wait_log(struct mqtt_bridge *br, const char *needle, unsigned n,
                         int timeout_ms);

/* Waits until the bridge's last STATUS= notification (sd_notify) contains needle, e.g.
 * "STATUS=broker disconnected (refused"; 0 or -ETIMEDOUT. */
int mqtt_bridge_wait_status(struct mqtt_bridge *br, const char *needle, int timeout_ms);

/* Connects a client (id; clean: clean session) to 127.0.0.1:port, subscribes to subscription
 * (may be NULL) with qos, and runs it in its own thread (reconnecting by itself). 0 once
 * subscribed, or -errno. */
int mqtt_client_start(struct mqtt_client *c, int port, const char *id, bool clean,
                      const char *subscription, int qos, int timeout_ms);

/* TLS and credentials of a client (each NULL: not used). */
struct mqtt_client_auth {
        const char *ca_file;            /* TLS, the broker's certificate checked against it */
        const char *username, *password;
};

/* mqtt_client_start with TLS and/or a username and password. */
int mqtt_client_start_auth(struct mqtt_client *c, int port, const char *id, bool clean,
                           const char *subscription, int qos,
                           const struct mqtt_client_auth *auth, int timeout_ms);

/* A raw MQTT 3.1.1 connection (no library between the test and the wire, so that it can send
 * what libmosquitto refuses to): CONNECT, a QoS 0 PUBLISH of topic (topic_len bytes, any
 * bytes) with payload, then PINGREQ. Returns 1 when the broker closed the connection instead
 * of answering the ping (it refused the PUBLISH), 0 when it answered, or -errno. */
int mqtt_raw_publish(int port, const void *topic, size_t topic_len, const void *payload,
                     size_t len, int timeout_ms);

/* Stops and frees (NULL-safe on a zeroed struct). */
void mqtt_client_stop(struct mqtt_client *c);

/* Publishes (waits for nothing). 0 or -errno. */
int mqtt_client_publish(struct mqtt_client *c, const char *topic, const void *payload,
                        size_t len, int qos, bool retain);

/* Waits until the last payload on topic equals want (a NUL-terminated text); 0 or -ETIMEDOUT. */
int mqtt_client_wait_value(struct mqtt_client *c, const char *topic, const char *want,
                           int timeout_ms);

/* Waits until the last payload on topic contains needle and copies it to out (size bytes). */
int mqtt_client_wait_contains(struct mqtt_client *c, const char *topic, const char *needle,
                              char *out, size_t size, int timeout_ms);

/* Messages seen on topic so far (0 when none). */
uint64_t mqtt_client_count(struct mqtt_client *c, const char *topic);

/* Waits until at least n messages were seen on topic; 0 or -ETIMEDOUT. */
int mqtt_client_wait_count(struct mqtt_client *c, const char *topic, uint64_t n, int timeout_ms);

/* Waits until at least n events were recorded; 0 or -ETIMEDOUT. */
int mqtt_client_wait_events(struct mqtt_client *c, size_t n, int timeout_ms);

/* Waits until an event with that sensor_time was recorded; 0 or -ETIMEDOUT. */
int mqtt_client_wait_sensor_time(struct mqtt_client *c, long sensor_time, int timeout_ms);

/* Waits until an event of that type (e.g. "overrun") was recorded; 0 or -ETIMEDOUT. */
int mqtt_client_wait_event_type(struct mqtt_client *c, const char *type, int timeout_ms);

/* Events recorded so far. */
size_t mqtt_client_events(struct mqtt_client *c);

/* Waits until the client has (re)connected more than `after` times. */
int mqtt_client_wait_connects(struct mqtt_client *c, uint64_t after, int timeout_ms);
