/*
 * sharedlink-mqtt: the libmosquitto side (see bridge_mqtt.h).
 *
 * libmosquitto is used without its thread: every call, and every callback, happens in main.c's
 * loop thread, so the bridge logic needs no locks. Connections are started with
 * mosquitto_connect_async / mosquitto_reconnect_async (a non-blocking TCP connect; the CONNECT
 * packet goes out when the socket becomes writable) so that a broker that does not answer never
 * stalls the loop; only the host name lookup may block.
 */
#include "mqtt/bridge_mqtt.h"

#include <errno.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <mosquitto.h>

#include "mqtt/bridge_format.h"
#include "svc/log.h"

#define NS_PER_MS               1000000ull
#define MISC_INTERVAL_MS        1000u   /* keepalive pings and retries: mosquitto_loop_misc */
#define PACKETS_PER_CALL        64      /* mosquitto_loop_read/_write max_packets */
#define STATUS_OFFLINE          "offline"
#define STATUS_QOS              1
#define CLIENT_ID_PREFIX        "sharedlink-mqtt-"
#define BRIDGE_ERROR_TEXT_MAX   160

enum conn_state {
        CONN_IDLE,                      /* no connection; next attempt at next_ns */
        CONN_CONNECTING,                /* TCP connect or CONNECT/CONNACK under way */
        CONN_UP,                        /* CONNACK accepted */
};

struct bridge_mqtt {
        const struct bridge_config *cfg;
        struct bridge *b;
        struct mosquitto *m;
        struct bridge_sink sink;
        enum conn_state state;
        bool ever_started;              /* the first attempt is a connect, later ones reconnect */
        bool fresh;
        unsigned backoff_ms;
        uint64_t next_ns;               /* CONN_IDLE: the next attempt */
        uint64_t misc_ns;               /* the next mosquitto_loop_misc */
        uint64_t connect_ns;            /* CONN_CONNECTING: when the attempt gives up */
        bool refused;                   /* the broker refused the CONNECT ... */
        char refusal[BRIDGE_ERROR_TEXT_MAX];    /* ... for this reason */
        char error[BRIDGE_ERROR_TEXT_MAX];      /* why the last attempt failed ("" while up) */
        char tls_error[BRIDGE_ERROR_TEXT_MAX];  /* libmosquitto's last OpenSSL message */
        char status_topic[BRIDGE_TOPIC_MAX];
        char set_topic[BRIDGE_TOPIC_MAX];
        char client_id[BRIDGE_CLIENT_ID_MAX + BRIDGE_INSTANCE_MAX];
};

static int sink_publish(void *arg, const char *topic, const void *payload, size_t len, int qos,
                        bool retain, int *ret_mid)
{
        struct bridge_mqtt *bm = arg;
        int r;

        if (bm->state != CONN_UP)
                return -ENOTCONN;
        r = mosquitto_publish(bm->m, ret_mid, topic, (int)len, payload, qos, retain);
        switch (r) {
        case MOSQ_ERR_SUCCESS:
                return 0;
        case MOSQ_ERR_NO_CONN:
                return -ENOTCONN;
        case MOSQ_ERR_NOMEM:
                return -ENOMEM;
        case MOSQ_ERR_PAYLOAD_SIZE:
                return -EMSGSIZE;
        case MOSQ_ERR_MALFORMED_UTF8:
        case MOSQ_ERR_INVAL:
                return -EINVAL;
        default:
                return -EIO;
        }
}

/* The broker is gone (refused, dropped, or never answered): try again after the backoff. A
 * refusal (bad credentials, say) is the reason, not the connection closing that follows it. A
 * warning when the connection was up or the reason is new; the same reason at every retry is
 * only debug, so a broker that stays away does not flood the journal. */
static void connection_lost(struct bridge_mqtt *bm, uint64_t now_ns, const char *why)
{
        char text[BRIDGE_ERROR_TEXT_MAX];
        bool news;

        snprintf(text, sizeof(text), "%s", bm->refused ? bm->refusal : why);
        news = bm->state == CONN_UP || strcmp(text, bm->error) != 0;
        bm->refused = false;
        memcpy(bm->error, text, sizeof(text));
        bridge_broker_error(bm->b);
        log_msg(news ? LOG_PRIO_WARNING : LOG_PRIO_DEBUG,
                "broker %s:%d: %s; retrying in %u ms", bm->cfg->host, bm->cfg->port, text,
                bm->backoff_ms);
        bm->state = CONN_IDLE;
        bm->next_ns = now_ns + (uint64_t)bm->backoff_ms * NS_PER_MS;
        bm->backoff_ms = bm->backoff_ms * 2u > bm->cfg->reconnect_max_ms ?
                         bm->cfg->reconnect_max_ms : bm->backoff_ms * 2u;
}

/* What a failed libmosquitto call means, into why: OpenSSL's own words for a TLS error. */
static void error_text(struct bridge_mqtt *bm, int r, char *why, size_t size)
{
        if (r == MOSQ_ERR_TLS)
                snprintf(why, size, "TLS: %.150s", bm->tls_error[0] ? bm->tls_error :
                         mosquitto_strerror(r));
        else if (r == MOSQ_ERR_ERRNO)
                snprintf(why, size, "%s", strerror(errno));
        else if (r == MOSQ_ERR_EAI)
                snprintf(why, size, "host name not resolved");
        else
                snprintf(why, size, "%s", mosquitto_strerror(r));
        bm->tls_error[0] = '\0';
}

static uint64_t now_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

static void on_connect(struct mosquitto *m, void *arg, int rc)
{
        struct bridge_mqtt *bm = arg;
        int r;

        if (rc != 0) {
                char why[BRIDGE_ERROR_TEXT_MAX];
                size_t n;

                /* The broker closes the connection next; connection_lost backs off. Logged as
                 * an error once, not at every retry of the same refusal. */
                n = (size_t)snprintf(why, sizeof(why), "refused the connection: %s",
                                     mosquitto_connack_string(rc));
                if (n > 0 && n < sizeof(why) && why[n - 1] == '.')
                        why[n - 1] = '\0';
                log_msg(strcmp(why, bm->error) ? LOG_PRIO_ERR : LOG_PRIO_DEBUG,
                        "broker %s:%d: %s", bm->cfg->host, bm->cfg->port, why);
                memcpy(bm->refusal, why, sizeof(why));
                bm->refused = true;
                return;
        }
        bm->error[0] = '\0';
        log_msg(LOG_PRIO_INFO, "broker %s:%d: connected as %s", bm->cfg->host,
                bm->cfg->port, bm->client_id);
        bm->state = CONN_UP;
        bm->backoff_ms = bm->cfg->reconnect_min_ms;
        bm->fresh = true;
        if (bm->cfg->writable.count == 0)
                return;
        r = mosquitto_subscribe(m, NULL, bm->set_topic, bm->cfg->set_qos);
        if (r != MOSQ_ERR_SUCCESS)
                log_msg(LOG_PRIO_ERR, "subscribe %s: %s", bm->set_topic,
                        mosquitto_strerror(r));
}

static void on_disconnect(struct mosquitto *m, void *arg, int rc)
{
        struct bridge_mqtt *bm = arg;
        char why[BRIDGE_ERROR_TEXT_MAX];

        (void)m;
        if (bm->state == CONN_IDLE)
                return;
        /* Some libmosquitto versions report a failed TLS handshake here (rc MOSQ_ERR_TLS)
         * rather than as the result of the read: the reason is told the same way. */
        if (rc == 0)
                snprintf(why, sizeof(why), "disconnected");
        else if (rc == MOSQ_ERR_CONN_LOST)
                snprintf(why, sizeof(why), "connection lost");
        else
                error_text(bm, rc, why, sizeof(why));
        connection_lost(bm, now_ns(), why);
}

static void on_publish(struct mosquitto *m, void *arg, int mid)
{
        struct bridge_mqtt *bm = arg;

        (void)m;
        bridge_acked(bm->b, mid);
}

static void on_message(struct mosquitto *m, void *arg, const struct mosquitto_message *msg)
{
        struct bridge_mqtt *bm = arg;

        (void)m;
        if (msg->payloadlen < 0)
                return;
        bridge_set(bm->b, &bm->sink, msg->topic, msg->payload, (size_t)msg->payloadlen);
}

/* libmosquitto says what OpenSSL objected to only through its log: kept for the error of
 * the attempt (a certificate that does not verify, say), the rest is dropped. */
static void on_log(struct mosquitto *m, void *arg, int level, const char *text)
{
        struct bridge_mqtt *bm = arg;

        (void)m;
        if (level == MOSQ_LOG_ERR && strstr(text, "SSL"))
                snprintf(bm->tls_error, sizeof(bm->tls_error), "%s", text);
}

static int setup_tls(struct bridge_mqtt *bm, char *err, size_t err_size)
{
        const struct bridge_config *c = bm->cfg;
        int r = mosquitto_tls_set(bm->m, c->ca_file[0] ? c->ca_file : NULL,
                                  c->ca_path[0] ? c->ca_path : NULL,
                                  c->cert_file[0] ? c->cert_file : NULL,
                                  c->key_file[0] ? c->key_file : NULL, NULL);

        if (r != MOSQ_ERR_SUCCESS) {
                snprintf(err, err_size, "tls: %s (ca_file, ca_path, cert_file, key_file)",
                         mosquitto_strerror(r));
                return -EINVAL;
        }
        if (c->tls_insecure && mosquitto_tls_insecure_set(bm->m, true) != MOSQ_ERR_SUCCESS) {
                snprintf(err, err_size, "tls: insecure: not supported");
                return -EINVAL;
        }
        return 0;
}

static int setup(struct bridge_mqtt *bm, char *err, size_t err_size)
{
        const struct bridge_config *c = bm->cfg;
        const char *base = bridge_base(bm->b);
        int r;

        bridge_format_topic(bm->status_topic, sizeof(bm->status_topic), base, "status", NULL);
        bridge_format_topic(bm->set_topic, sizeof(bm->set_topic), base, "set", "#");
        r = mosquitto_will_set(bm->m, bm->status_topic, (int)strlen(STATUS_OFFLINE),
                               STATUS_OFFLINE, STATUS_QOS, true);
        if (r == MOSQ_ERR_SUCCESS && c->username[0])
                r = mosquitto_username_pw_set(bm->m, c->username,
                                              c->password[0] ? c->password : NULL);
        if (r != MOSQ_ERR_SUCCESS) {
                snprintf(err, err_size, "broker: %s", mosquitto_strerror(r));
                return -EINVAL;
        }
        /* At most max_inflight unacknowledged messages on the wire (the broker's limit); the
         * rest of the bridge's event window waits in libmosquitto's queue. */
        mosquitto_max_inflight_messages_set(bm->m, c->max_inflight);
        mosquitto_int_option(bm->m, MOSQ_OPT_TCP_NODELAY, 1);
        if (c->tls && setup_tls(bm, err, err_size) < 0)
                return -EINVAL;
        mosquitto_connect_callback_set(bm->m, on_connect);
        mosquitto_disconnect_callback_set(bm->m, on_disconnect);
        mosquitto_publish_callback_set(bm->m, on_publish);
        mosquitto_message_callback_set(bm->m, on_message);
        mosquitto_log_callback_set(bm->m, on_log);
        return 0;
}

int bridge_mqtt_new(const struct bridge_config *cfg, struct bridge *b, struct bridge_mqtt **ret,
                    char *err, size_t err_size)
{
        struct bridge_mqtt *bm = calloc(1, sizeof(*bm));
        const char *base;

        if (!bm)
                return -ENOMEM;
        bm->cfg = cfg;
        bm->b = b;
        bm->sink = (struct bridge_sink){ .publish = sink_publish, .arg = bm };
        bm->backoff_ms = cfg->reconnect_min_ms;
        base = strchr(bridge_base(b), '/');
        if (cfg->client_id[0])
                snprintf(bm->client_id, sizeof(bm->client_id), "%s", cfg->client_id);
        else
                snprintf(bm->client_id, sizeof(bm->client_id), CLIENT_ID_PREFIX "%s",
                         base ? base + 1 : "default");
        /* clean_session false: the broker keeps the session (subscription, QoS 1/2 state) and
         * the ids of the QoS 2 messages it received across our reconnections. */
        bm->m = mosquitto_new(bm->client_id, false, bm);
        if (!bm->m) {
                snprintf(err, err_size, "mosquitto_new: %s", strerror(errno));
                free(bm);
                return -ENOMEM;
        }
        if (setup(bm, err, err_size) < 0) {
                bridge_mqtt_free(bm);
                return -EINVAL;
        }
        *ret = bm;
        return 0;
}

struct bridge_mqtt *bridge_mqtt_free(struct bridge_mqtt *bm)
{
        if (!bm)
                return NULL;
        mosquitto_destroy(bm->m);
        free(bm);
        return NULL;
}

const struct bridge_sink *bridge_mqtt_sink(struct bridge_mqtt *bm)
{
        return &bm->sink;
}

void bridge_mqtt_connect_due(struct bridge_mqtt *bm, uint64_t now)
{
        char why[BRIDGE_ERROR_TEXT_MAX];
        int r;

        if (bm->state != CONN_IDLE || now < bm->next_ns)
                return;
        if (bm->ever_started)
                r = mosquitto_reconnect_async(bm->m);
        else
                r = mosquitto_connect_async(bm->m, bm->cfg->host, bm->cfg->port,
                                            bm->cfg->keepalive_s);
        if (r == MOSQ_ERR_SUCCESS || r == MOSQ_ERR_CONN_PENDING) {
                bm->ever_started = true;
                bm->state = CONN_CONNECTING;
                bm->misc_ns = now + MISC_INTERVAL_MS * NS_PER_MS;
                bm->connect_ns = now + (uint64_t)bm->cfg->keepalive_s * 1000u * NS_PER_MS;
                return;
        }
        /* Even a failed first attempt set host and port up for reconnect_async, unless the
         * name did not resolve. */
        bm->ever_started = r != MOSQ_ERR_EAI;
        error_text(bm, r, why, sizeof(why));
        connection_lost(bm, now, why);
}

int bridge_mqtt_fd(struct bridge_mqtt *bm)
{
        return bm->state == CONN_IDLE ? -1 : mosquitto_socket(bm->m);
}

bool bridge_mqtt_want_write(struct bridge_mqtt *bm)
{
        return bm->state != CONN_IDLE && mosquitto_want_write(bm->m);
}

static void io_result(struct bridge_mqtt *bm, int r, uint64_t now)
{
        char why[BRIDGE_ERROR_TEXT_MAX];

        if (r == MOSQ_ERR_SUCCESS || bm->state == CONN_IDLE)
                return;
        error_text(bm, r, why, sizeof(why));
        connection_lost(bm, now, why);
}

void bridge_mqtt_io(struct bridge_mqtt *bm, short revents, uint64_t now)
{
        if (bm->state == CONN_IDLE)
                return;
        if (revents & (POLLIN | POLLERR | POLLHUP))
                io_result(bm, mosquitto_loop_read(bm->m, PACKETS_PER_CALL), now);
        if (bm->state != CONN_IDLE && (revents & POLLOUT))
                io_result(bm, mosquitto_loop_write(bm->m, PACKETS_PER_CALL), now);
        /* A broker that takes the TCP connection but never answers CONNECT (a reconnect_async
         * later closes the socket). */
        if (bm->state == CONN_CONNECTING && now >= bm->connect_ns) {
                connection_lost(bm, now, "no CONNACK");
                return;
        }
        if (bm->state != CONN_IDLE && now >= bm->misc_ns) {
                bm->misc_ns = now + MISC_INTERVAL_MS * NS_PER_MS;
                io_result(bm, mosquitto_loop_misc(bm->m), now);
        }
}

int bridge_mqtt_timeout_ms(const struct bridge_mqtt *bm, uint64_t now)
{
        uint64_t at = bm->state == CONN_IDLE ? bm->next_ns : bm->misc_ns;

        if (at <= now)
                return 0;
        return (int)((at - now + NS_PER_MS - 1u) / NS_PER_MS);
}

bool bridge_mqtt_connected(const struct bridge_mqtt *bm)
{
        return bm->state == CONN_UP;
}

const char *bridge_mqtt_error(const struct bridge_mqtt *bm)
{
        return bm->state == CONN_UP ? "" : bm->error;
}

bool bridge_mqtt_take_fresh(struct bridge_mqtt *bm)
{
        bool f = bm->fresh;

        bm->fresh = false;
        return f;
}

void bridge_mqtt_disconnect(struct bridge_mqtt *bm)
{
        uint64_t deadline;

        if (bm->state != CONN_UP)
                return;
        mosquitto_publish(bm->m, NULL, bm->status_topic, (int)strlen(STATUS_OFFLINE),
                          STATUS_OFFLINE, STATUS_QOS, true);
        bm->state = CONN_IDLE;          /* on_disconnect: no reconnection now */
        mosquitto_disconnect(bm->m);
        /* Flush the last packets (bounded): the socket is local or the broker is gone. */
        deadline = now_ns() + MISC_INTERVAL_MS * NS_PER_MS;
        while (mosquitto_want_write(bm->m) && now_ns() < deadline) {
                struct pollfd p = { .fd = mosquitto_socket(bm->m), .events = POLLOUT };

                if (p.fd < 0 || poll(&p, 1, (int)MISC_INTERVAL_MS) <= 0)
                        break;
                if (mosquitto_loop_write(bm->m, PACKETS_PER_CALL) != MOSQ_ERR_SUCCESS)
                        break;
        }
}
