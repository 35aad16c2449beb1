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
#include <sys/epoll.h>
#include <time.h>
#include <unistd.h>

#include <mosquitto.h>
#include <mqtt_protocol.h>

#include "mqtt/bridge_format.h"
#include "svc/log.h"

#define NS_PER_MS               1000000ull
#define MISC_INTERVAL_MS        1000u   /* keepalive pings and retries: mosquitto_loop_misc */
#define PACKETS_PER_CALL        64      /* mosquitto_loop_read/_write max_packets */
#define CLIENT_ID_PREFIX        "sharedlink-mqtt-"
#define WRITES_ID_SUFFIX        "-set"  /* the writes' connection: client_id + this */
#define WRITES_LABEL            "set/: "
#define BRIDGE_ERROR_TEXT_MAX   160
#define CONNS                   2       /* what the epoll fd watches at most */
/* MQTT 5 failure reason codes start here (CONNACK, SUBACK); 3.1.1's CONNACK codes are below
 * and its SUBACK failure is this value. */
#define REASON_FAILURE_MIN      0x80
/* The writes' subscription: a retained message keeps its retain flag when it is forwarded (MQTT
 * 3.1.1 clears it, so a retained write published while the bridge is subscribed would look
 * live), and the bridge's own error replies do not come back to it. */
#define WRITES_SUB_OPTIONS      (MQTT_SUB_OPT_RETAIN_AS_PUBLISHED | MQTT_SUB_OPT_NO_LOCAL)

enum conn_state {
        CONN_IDLE,                      /* no connection; next attempt at next_ns */
        CONN_CONNECTING,                /* TCP connect or CONNECT/CONNACK under way */
        CONN_UP,                        /* CONNACK accepted */
};

/* One connection to the broker, with its own backoff. */
struct conn {
        struct bridge_mqtt *bm;
        const char *label;              /* "" or WRITES_LABEL, before its messages */
        struct mosquitto *m;
        struct bridge_sink sink;
        enum conn_state state;
        bool ever_started;              /* the first attempt is a connect, later ones reconnect */
        unsigned backoff_ms;
        uint64_t next_ns;               /* CONN_IDLE: the next attempt */
        uint64_t misc_ns;               /* the next mosquitto_loop_misc */
        uint64_t connect_ns;            /* CONN_CONNECTING: when the attempt gives up */
        bool refused;                   /* the broker refused the CONNECT ... */
        char refusal[BRIDGE_ERROR_TEXT_MAX];    /* ... for this reason */
        char error[BRIDGE_ERROR_TEXT_MAX];      /* why the last attempt failed ("" while up) */
        bool told;                              /* ... and that was logged as a warning */
        char tls_error[BRIDGE_ERROR_TEXT_MAX];  /* libmosquitto's last OpenSSL message */
        char client_id[BRIDGE_CLIENT_ID_MAX + BRIDGE_INSTANCE_MAX + sizeof(WRITES_ID_SUFFIX)];
        int polled_fd;                  /* the socket the epoll fd watches for it, or -1 */
        uint32_t polled_events;
};

struct bridge_mqtt {
        const struct bridge_config *cfg;
        struct bridge *b;
        struct conn own;                /* the bridge's: persistent session, everything out */
        struct conn writes;             /* set/ in: clean session (when has_writes) */
        bool has_writes;
        bool fresh;
        int epoll_fd;                   /* both sockets (has_writes), else -1 */
        char error[sizeof(WRITES_LABEL) + BRIDGE_ERROR_TEXT_MAX];       /* bridge_mqtt_error */
        char status_topic[BRIDGE_TOPIC_MAX];
        char set_topic[BRIDGE_TOPIC_MAX];
};

static int sink_publish(void *arg, const char *topic, const void *payload, size_t len, int qos,
                        bool retain, int *ret_mid)
{
        struct conn *c = arg;
        int r;

        if (c->state != CONN_UP)
                return -ENOTCONN;
        r = mosquitto_publish(c->m, ret_mid, topic, (int)len, payload, qos, retain);
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

/* ---- what the epoll fd watches --------------------------------------------------------------- */

/* The epoll fd stops watching c's socket. Called while that socket is still open (before a
 * reconnection replaces it, and when the connection is given up: libmosquitto closes a lost
 * socket only after its disconnect callback), so the number cannot be the other connection's
 * yet; the check is a second guard. A socket that is already closed left the set by itself. */
static void poll_forget(struct conn *c)
{
        struct bridge_mqtt *bm = c->bm;
        struct conn *other = c == &bm->own ? &bm->writes : &bm->own;

        if (bm->epoll_fd >= 0 && c->polled_fd >= 0 && c->polled_fd != other->polled_fd)
                epoll_ctl(bm->epoll_fd, EPOLL_CTL_DEL, c->polled_fd, NULL);
        c->polled_fd = -1;
        c->polled_events = 0;
}

/* The epoll fd watches c's socket for input, and for output while libmosquitto has some. */
static void poll_update(struct conn *c)
{
        struct bridge_mqtt *bm = c->bm;
        int fd = c->state == CONN_IDLE ? -1 : mosquitto_socket(c->m);
        struct epoll_event ev = { .events = EPOLLIN, .data.ptr = c };

        if (fd < 0) {
                poll_forget(c);
                return;
        }
        if (mosquitto_want_write(c->m))
                ev.events |= EPOLLOUT;
        if (fd == c->polled_fd && ev.events == c->polled_events)
                return;
        if (fd != c->polled_fd)
                poll_forget(c);
        if (epoll_ctl(bm->epoll_fd, c->polled_fd == fd ? EPOLL_CTL_MOD : EPOLL_CTL_ADD, fd,
                      &ev) < 0 &&
            (errno != EEXIST || epoll_ctl(bm->epoll_fd, EPOLL_CTL_MOD, fd, &ev) < 0)) {
                log_msg(LOG_PRIO_ERR, "broker %s:%d: %sepoll: %s", bm->cfg->host,
                           bm->cfg->port, c->label, strerror(errno));
                return;
        }
        c->polled_fd = fd;
        c->polled_events = ev.events;
}

/* ---- one connection -------------------------------------------------------------------------- */

/* While the bridge's own connection is not up, it tells what is wrong with the broker: the
 * writes' connection, which fails the same way, keeps quiet (debug), so one wrong password is
 * one error in the journal. */
static bool conn_speaks(const struct conn *c)
{
        return c == &c->bm->own || c->bm->own.state == CONN_UP;
}

/* The broker is gone (refused, dropped, or never answered): try again after the backoff. A
 * refusal (bad credentials, say) is the reason, not the connection closing that follows it. A
 * warning when the connection was up or the reason was not told yet; the same reason at every
 * retry is only debug, so a broker that stays away does not flood the journal. */
static void connection_lost(struct conn *c, uint64_t now_ns, const char *why)
{
        struct bridge_mqtt *bm = c->bm;
        char text[BRIDGE_ERROR_TEXT_MAX];
        bool news;

        snprintf(text, sizeof(text), "%s", c->refused ? c->refusal : why);
        if (strcmp(text, c->error) != 0)
                c->told = false;
        news = (c->state == CONN_UP || !c->told) && conn_speaks(c);
        if (news)
                c->told = true;
        c->refused = false;
        memcpy(c->error, text, sizeof(text));
        bridge_broker_error(bm->b);
        if (c == &bm->writes)
                bridge_writes_ready(bm->b, false);
        log_msg(news ? LOG_PRIO_WARNING : LOG_PRIO_DEBUG,
                   "broker %s:%d: %s%s; retrying in %u ms", bm->cfg->host, bm->cfg->port,
                   c->label, text, c->backoff_ms);
        poll_forget(c);
        c->state = CONN_IDLE;
        c->next_ns = now_ns + (uint64_t)c->backoff_ms * NS_PER_MS;
        c->backoff_ms = c->backoff_ms * 2u > bm->cfg->reconnect_max_ms ?
                        bm->cfg->reconnect_max_ms : c->backoff_ms * 2u;
}

/* What a failed libmosquitto call means, into why: OpenSSL's own words for a TLS error. */
static void error_text(struct conn *c, int r, char *why, size_t size)
{
        if (r == MOSQ_ERR_TLS)
                snprintf(why, size, "TLS: %.150s", c->tls_error[0] ? c->tls_error :
                         mosquitto_strerror(r));
        else if (r == MOSQ_ERR_ERRNO)
                snprintf(why, size, "%s", strerror(errno));
        else if (r == MOSQ_ERR_EAI)
                snprintf(why, size, "host name not resolved");
        else
                snprintf(why, size, "%s", mosquitto_strerror(r));
        c->tls_error[0] = '\0';
}

static uint64_t now_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

/* The broker took the connection: the bridge's own drops the set/ subscription an older bridge
 * kept in its session; the writes' subscribes (ready at the SUBACK). */
static void connected(struct conn *c)
{
        struct bridge_mqtt *bm = c->bm;
        int r;

        if (c == &bm->own) {
                bm->fresh = true;
                r = mosquitto_unsubscribe(c->m, NULL, bm->set_topic);
        } else {
                r = mosquitto_subscribe_v5(c->m, NULL, bm->set_topic, bm->cfg->set_qos,
                                           WRITES_SUB_OPTIONS, NULL);
        }
        if (r != MOSQ_ERR_SUCCESS)
                log_msg(LOG_PRIO_ERR, "broker %s:%d: %s%ssubscribe %s: %s",
                           bm->cfg->host, bm->cfg->port, c->label, c == &bm->own ? "un" : "",
                           bm->set_topic, mosquitto_strerror(r));
}

static void on_connect(struct mosquitto *m, void *arg, int rc)
{
        struct conn *c = arg;
        const struct bridge_config *cfg = c->bm->cfg;

        (void)m;
        if (rc != 0) {
                char why[BRIDGE_ERROR_TEXT_MAX];
                size_t n;

                /* The broker closes the connection next; connection_lost backs off. Logged as
                 * an error once, not at every retry of the same refusal. */
                n = (size_t)snprintf(why, sizeof(why), "refused the connection: %s",
                                     rc >= REASON_FAILURE_MIN ? mosquitto_reason_string(rc) :
                                     mosquitto_connack_string(rc));
                if (n > 0 && n < sizeof(why) && why[n - 1] == '.')
                        why[n - 1] = '\0';
                log_msg(strcmp(why, c->error) && conn_speaks(c) ? LOG_PRIO_ERR :
                           LOG_PRIO_DEBUG,
                           "broker %s:%d: %s%s", cfg->host, cfg->port, c->label, why);
                memcpy(c->refusal, why, sizeof(why));
                c->refused = true;
                return;
        }
        c->error[0] = '\0';
        log_msg(LOG_PRIO_INFO, "broker %s:%d: connected as %s", cfg->host, cfg->port,
                   c->client_id);
        c->state = CONN_UP;
        c->backoff_ms = cfg->reconnect_min_ms;
        connected(c);
}

static void on_subscribe(struct mosquitto *m, void *arg, int mid, int n, const int *granted)
{
        struct conn *c = arg;

        (void)m;
        (void)mid;
        if (c != &c->bm->writes)
                return;
        if (n < 1 || granted[0] >= REASON_FAILURE_MIN) {
                log_msg(LOG_PRIO_ERR, "broker %s:%d: %sthe subscription to %s was "
                           "refused (the broker's access rules?): writes are not taken",
                           c->bm->cfg->host, c->bm->cfg->port, c->label, c->bm->set_topic);
                return;
        }
        bridge_writes_ready(c->bm->b, true);
}

static void on_disconnect(struct mosquitto *m, void *arg, int rc)
{
        struct conn *c = arg;
        char why[BRIDGE_ERROR_TEXT_MAX];

        (void)m;
        if (c->state == CONN_IDLE)
                return;
        /* Some libmosquitto versions report a failed TLS handshake here (rc MOSQ_ERR_TLS)
         * rather than as the result of the read: the reason is told the same way. */
        if (rc == 0)
                snprintf(why, sizeof(why), "disconnected");
        else if (rc == MOSQ_ERR_CONN_LOST)
                snprintf(why, sizeof(why), "connection lost");
        else
                error_text(c, rc, why, sizeof(why));
        connection_lost(c, now_ns(), why);
}

/* Only the bridge's own connection publishes events; the writes' message ids are another
 * numbering (its error replies), never to be taken for an event's. */
static void on_publish(struct mosquitto *m, void *arg, int mid)
{
        struct conn *c = arg;

        (void)m;
        if (c == &c->bm->own)
                bridge_acked(c->bm->b, mid);
}

/* A retained message keeps its flag on both connections (MQTT 3.1.1 sets it when a subscription
 * brings it, the writes' subscription keeps it as published); anything else on the bridge's own
 * connection waited in its persistent session. */
static void on_message(struct mosquitto *m, void *arg, const struct mosquitto_message *msg)
{
        struct conn *c = arg;
        enum bridge_set_via via = msg->retain ? BRIDGE_SET_RETAINED :
                                  c == &c->bm->own ? BRIDGE_SET_QUEUED : BRIDGE_SET_LIVE;

        (void)m;
        if (msg->payloadlen < 0)
                return;
        bridge_set(c->bm->b, &c->sink, msg->topic, msg->payload, (size_t)msg->payloadlen, via);
}

/* libmosquitto says what OpenSSL objected to only through its log: kept for the error of
 * the attempt (a certificate that does not verify, say), the rest is dropped. */
static void on_log(struct mosquitto *m, void *arg, int level, const char *text)
{
        struct conn *c = arg;

        (void)m;
        if (level == MOSQ_LOG_ERR && strstr(text, "SSL"))
                snprintf(c->tls_error, sizeof(c->tls_error), "%s", text);
}

static int setup_tls(struct conn *c, char *err, size_t err_size)
{
        const struct bridge_config *cfg = c->bm->cfg;
        int r = mosquitto_tls_set(c->m, cfg->ca_file[0] ? cfg->ca_file : NULL,
                                  cfg->ca_path[0] ? cfg->ca_path : NULL,
                                  cfg->cert_file[0] ? cfg->cert_file : NULL,
                                  cfg->key_file[0] ? cfg->key_file : NULL, NULL);

        if (r != MOSQ_ERR_SUCCESS) {
                snprintf(err, err_size, "tls: %s (ca_file, ca_path, cert_file, key_file)",
                         mosquitto_strerror(r));
                return -EINVAL;
        }
        if (cfg->tls_insecure && mosquitto_tls_insecure_set(c->m, true) != MOSQ_ERR_SUCCESS) {
                snprintf(err, err_size, "tls: insecure: not supported");
                return -EINVAL;
        }
        return 0;
}

/* A client for c: the bridge's own with a persistent session and the will, the writes' with a
 * clean one and MQTT 5 (bridge_mqtt.h says why). */
static int conn_new(struct bridge_mqtt *bm, struct conn *c, const char *id, char *err,
                    size_t err_size)
{
        const struct bridge_config *cfg = bm->cfg;
        bool own = c == &bm->own;
        int r;

        c->bm = bm;
        c->label = own ? "" : WRITES_LABEL;
        c->sink = (struct bridge_sink){ .publish = sink_publish, .arg = c };
        c->backoff_ms = cfg->reconnect_min_ms;
        c->polled_fd = -1;
        snprintf(c->client_id, sizeof(c->client_id), "%s%s", id, own ? "" : WRITES_ID_SUFFIX);
        /* clean_session false: the broker keeps the session (QoS 1/2 state) and the ids of the
         * QoS 2 messages it received across our reconnections. */
        c->m = mosquitto_new(c->client_id, !own, c);
        if (!c->m) {
                snprintf(err, err_size, "mosquitto_new: %s", strerror(errno));
                return -ENOMEM;
        }
        if (own)
                r = mosquitto_will_set(c->m, bm->status_topic,
                                       (int)strlen(BRIDGE_STATUS_OFFLINE), BRIDGE_STATUS_OFFLINE,
                                       BRIDGE_STATUS_QOS, true);
        else
                r = mosquitto_int_option(c->m, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V5);
        if (r == MOSQ_ERR_SUCCESS && cfg->username[0])
                r = mosquitto_username_pw_set(c->m, cfg->username,
                                              cfg->password[0] ? cfg->password : NULL);
        if (r != MOSQ_ERR_SUCCESS) {
                snprintf(err, err_size, "broker: %s", mosquitto_strerror(r));
                return -EINVAL;
        }
        /* At most max_inflight unacknowledged messages on the wire (the broker's limit); the
         * rest of the bridge's event window waits in libmosquitto's queue. */
        mosquitto_max_inflight_messages_set(c->m, cfg->max_inflight);
        mosquitto_int_option(c->m, MOSQ_OPT_TCP_NODELAY, 1);
        if (cfg->tls && setup_tls(c, err, err_size) < 0)
                return -EINVAL;
        mosquitto_connect_callback_set(c->m, on_connect);
        mosquitto_disconnect_callback_set(c->m, on_disconnect);
        mosquitto_publish_callback_set(c->m, on_publish);
        mosquitto_subscribe_callback_set(c->m, on_subscribe);
        mosquitto_message_callback_set(c->m, on_message);
        mosquitto_log_callback_set(c->m, on_log);
        return 0;
}

int bridge_mqtt_new(const struct bridge_config *cfg, struct bridge *b, struct bridge_mqtt **ret,
                    char *err, size_t err_size)
{
        struct bridge_mqtt *bm = calloc(1, sizeof(*bm));
        char id[BRIDGE_CLIENT_ID_MAX + BRIDGE_INSTANCE_MAX];
        const char *base;
        int r;

        if (!bm)
                return -ENOMEM;
        bm->cfg = cfg;
        bm->b = b;
        bm->epoll_fd = -1;
        bm->own.polled_fd = bm->writes.polled_fd = -1;
        bm->has_writes = cfg->writable.count > 0;
        base = strchr(bridge_base(b), '/');
        if (cfg->client_id[0])
                snprintf(id, sizeof(id), "%s", cfg->client_id);
        else
                snprintf(id, sizeof(id), CLIENT_ID_PREFIX "%s", base ? base + 1 : "default");
        bridge_format_topic(bm->status_topic, sizeof(bm->status_topic), bridge_base(b),
                            BRIDGE_TOPIC_STATUS, NULL);
        bridge_format_topic(bm->set_topic, sizeof(bm->set_topic), bridge_base(b),
                            BRIDGE_TOPIC_SET, BRIDGE_TOPIC_ALL);
        r = conn_new(bm, &bm->own, id, err, err_size);
        if (r == 0 && bm->has_writes)
                r = conn_new(bm, &bm->writes, id, err, err_size);
        if (r < 0) {
                bridge_mqtt_free(bm);
                return r;
        }
        if (bm->has_writes) {
                bm->epoll_fd = epoll_create1(EPOLL_CLOEXEC);
                if (bm->epoll_fd < 0) {
                        snprintf(err, err_size, "epoll: %s", strerror(errno));
                        bridge_mqtt_free(bm);
                        return -ENOMEM;
                }
        }
        *ret = bm;
        return 0;
}

struct bridge_mqtt *bridge_mqtt_free(struct bridge_mqtt *bm)
{
        if (!bm)
                return NULL;
        mosquitto_destroy(bm->own.m);
        mosquitto_destroy(bm->writes.m);
        if (bm->epoll_fd >= 0)
                close(bm->epoll_fd);
        free(bm);
        return NULL;
}

const struct bridge_sink *bridge_mqtt_sink(struct bridge_mqtt *bm)
{
        return &bm->own.sink;
}

static void conn_connect_due(struct conn *c, uint64_t now)
{
        const struct bridge_config *cfg = c->bm->cfg;
        char why[BRIDGE_ERROR_TEXT_MAX];
        int r;

        if (c->state != CONN_IDLE || now < c->next_ns)
                return;
        poll_forget(c);         /* the attempt replaces the socket */
        if (c->ever_started)
                r = mosquitto_reconnect_async(c->m);
        else
                r = mosquitto_connect_async(c->m, cfg->host, cfg->port, cfg->keepalive_s);
        if (r == MOSQ_ERR_SUCCESS || r == MOSQ_ERR_CONN_PENDING) {
                c->ever_started = true;
                c->state = CONN_CONNECTING;
                c->misc_ns = now + MISC_INTERVAL_MS * NS_PER_MS;
                c->connect_ns = now + (uint64_t)cfg->keepalive_s * 1000u * NS_PER_MS;
                return;
        }
        /* Even a failed first attempt set host and port up for reconnect_async, unless the
         * name did not resolve. */
        c->ever_started = r != MOSQ_ERR_EAI;
        error_text(c, r, why, sizeof(why));
        connection_lost(c, now, why);
}

void bridge_mqtt_connect_due(struct bridge_mqtt *bm, uint64_t now)
{
        conn_connect_due(&bm->own, now);
        if (bm->has_writes)
                conn_connect_due(&bm->writes, now);
}

static int conn_fd(struct conn *c)
{
        return c->state == CONN_IDLE ? -1 : mosquitto_socket(c->m);
}

int bridge_mqtt_fd(struct bridge_mqtt *bm)
{
        if (!bm->has_writes)
                return conn_fd(&bm->own);
        poll_update(&bm->own);
        poll_update(&bm->writes);
        return bm->own.polled_fd >= 0 || bm->writes.polled_fd >= 0 ? bm->epoll_fd : -1;
}

bool bridge_mqtt_want_write(struct bridge_mqtt *bm)
{
        return bm->own.state != CONN_IDLE && mosquitto_want_write(bm->own.m);
}

static void io_result(struct conn *c, int r, uint64_t now)
{
        char why[BRIDGE_ERROR_TEXT_MAX];

        if (r == MOSQ_ERR_SUCCESS || c->state == CONN_IDLE)
                return;
        error_text(c, r, why, sizeof(why));
        connection_lost(c, now, why);
}

static void conn_io(struct conn *c, short revents, uint64_t now)
{
        if (c->state == CONN_IDLE)
                return;
        if (revents & (POLLIN | POLLERR | POLLHUP))
                io_result(c, mosquitto_loop_read(c->m, PACKETS_PER_CALL), now);
        if (c->state != CONN_IDLE && (revents & POLLOUT))
                io_result(c, mosquitto_loop_write(c->m, PACKETS_PER_CALL), now);
        /* A broker that takes the TCP connection but never answers CONNECT (a reconnect_async
         * later closes the socket). */
        if (c->state == CONN_CONNECTING && now >= c->connect_ns) {
                connection_lost(c, now, "no CONNACK");
                return;
        }
        if (c->state != CONN_IDLE && now >= c->misc_ns) {
                c->misc_ns = now + MISC_INTERVAL_MS * NS_PER_MS;
                io_result(c, mosquitto_loop_misc(c->m), now);
        }
}

/* What epoll says of one socket, as poll would have said it. */
static short poll_events(uint32_t e)
{
        return (short)((e & EPOLLIN ? POLLIN : 0) | (e & EPOLLOUT ? POLLOUT : 0) |
                       (e & EPOLLERR ? POLLERR : 0) | (e & EPOLLHUP ? POLLHUP : 0));
}

void bridge_mqtt_io(struct bridge_mqtt *bm, short revents, uint64_t now)
{
        struct epoll_event ev[CONNS];
        short own = revents, writes = 0;
        int n;

        if (bm->has_writes) {
                own = 0;
                n = revents ? epoll_wait(bm->epoll_fd, ev, CONNS, 0) : 0;
                for (int i = 0; i < n; i++) {
                        if (ev[i].data.ptr == &bm->own)
                                own = poll_events(ev[i].events);
                        else
                                writes = poll_events(ev[i].events);
                }
                conn_io(&bm->writes, writes, now);
        }
        conn_io(&bm->own, own, now);
}

static int conn_timeout_ms(const struct conn *c, uint64_t now)
{
        uint64_t at = c->state == CONN_IDLE ? c->next_ns : c->misc_ns;

        if (at <= now)
                return 0;
        return (int)((at - now + NS_PER_MS - 1u) / NS_PER_MS);
}

int bridge_mqtt_timeout_ms(const struct bridge_mqtt *bm, uint64_t now)
{
        int t = conn_timeout_ms(&bm->own, now), w;

        if (!bm->has_writes)
                return t;
        w = conn_timeout_ms(&bm->writes, now);
        return w < t ? w : t;
}

bool bridge_mqtt_connected(const struct bridge_mqtt *bm)
{
        return bm->own.state == CONN_UP;
}

const char *bridge_mqtt_error(struct bridge_mqtt *bm)
{
        if (bm->own.state != CONN_UP)
                return bm->own.error;
        if (!bm->has_writes || bm->writes.state == CONN_UP || !bm->writes.error[0])
                return "";
        snprintf(bm->error, sizeof(bm->error), WRITES_LABEL "%s", bm->writes.error);
        return bm->error;
}

bool bridge_mqtt_take_fresh(struct bridge_mqtt *bm)
{
        bool f = bm->fresh;

        bm->fresh = false;
        return f;
}

/* Disconnects c and flushes its last packets (bounded: the socket is local or the broker is
 * gone). */
static void conn_close(struct conn *c)
{
        uint64_t deadline;

        poll_forget(c);
        c->state = CONN_IDLE;           /* on_disconnect: no reconnection now */
        mosquitto_disconnect(c->m);
        deadline = now_ns() + MISC_INTERVAL_MS * NS_PER_MS;
        while (mosquitto_want_write(c->m) && now_ns() < deadline) {
                struct pollfd p = { .fd = mosquitto_socket(c->m), .events = POLLOUT };

                if (p.fd < 0 || poll(&p, 1, (int)MISC_INTERVAL_MS) <= 0)
                        break;
                if (mosquitto_loop_write(c->m, PACKETS_PER_CALL) != MOSQ_ERR_SUCCESS)
                        break;
        }
}

void bridge_mqtt_disconnect(struct bridge_mqtt *bm)
{
        if (bm->has_writes && bm->writes.state == CONN_UP)
                conn_close(&bm->writes);
        if (bm->own.state != CONN_UP)
                return;
        mosquitto_publish(bm->own.m, NULL, bm->status_topic, (int)strlen(BRIDGE_STATUS_OFFLINE),
                          BRIDGE_STATUS_OFFLINE, BRIDGE_STATUS_QOS, true);
        conn_close(&bm->own);
}
