/*
 * MQTT test helpers (see mqtt.h). Plain POSIX + libmosquitto, no cmocka: the benchmark uses them
 * too. Only binaries that call these link libmosquitto (the Makefile's MQTT_TESTS).
 */
#define _GNU_SOURCE
#include "common/mqtt.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <mosquitto.h>

#define MQTT_SLICE_MS           20      /* polling a port or a child that gives no event */
#define MQTT_BROKER_BIN         "mosquitto"
#define MQTT_BROKER_PATHS       "/usr/sbin/mosquitto"
#define MQTT_KEEPALIVE_S        10
#define MQTT_NOTIFY_MAX         1024
#define NS_PER_MS               1000000ull

static uint64_t deadline_of(int timeout_ms)
{
        return harness_now_ns() + (uint64_t)timeout_ms * NS_PER_MS;
}

static int left_ms(uint64_t deadline)
{
        uint64_t now = harness_now_ns();

        return now >= deadline ? 0 : (int)((deadline - now + NS_PER_MS - 1) / NS_PER_MS);
}

static void timespec_at(struct timespec *ts, int ms)
{
        clock_gettime(CLOCK_REALTIME, ts);
        ts->tv_sec += ms / 1000;
        ts->tv_nsec += (long)(ms % 1000) * 1000000L;
        if (ts->tv_nsec >= 1000000000L) {
                ts->tv_sec++;
                ts->tv_nsec -= 1000000000L;
        }
}

const char *mqtt_bridge_path(void)
{
        static char path[HARNESS_PATH_MAX];
        const char *b = getenv("SHAREDLINK_BUILD");

        snprintf(path, sizeof(path), "%s/sharedlink-mqtt", b ? b : "build/asan");
        return path;
}

int mqtt_broker_available(void)
{
        return access(MQTT_BROKER_PATHS, X_OK) == 0;
}

static int free_port(void)
{
        struct sockaddr_in sa = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
        socklen_t len = sizeof(sa);
        int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0), port = -errno;

        if (fd < 0)
                return port;
        if (bind(fd, (struct sockaddr *)&sa, sizeof(sa)) == 0 &&
            getsockname(fd, (struct sockaddr *)&sa, &len) == 0)
                port = ntohs(sa.sin_port);
        else
                port = -errno;
        close(fd);
        return port;
}

static int port_open(int port)
{
        struct sockaddr_in sa = { .sin_family = AF_INET, .sin_port = htons((uint16_t)port),
                                  .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
        int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0), ok;

        if (fd < 0)
                return 0;
        ok = connect(fd, (struct sockaddr *)&sa, sizeof(sa)) == 0;
        close(fd);
        return ok;
}

/* Reaps pid if it exited: 1 (status in *st), 0 still running. */
static int reaped(pid_t pid, int *st)
{
        return waitpid(pid, st, WNOHANG) == pid;
}

static int wait_exit(pid_t *pid, int timeout_ms)
{
        uint64_t deadline = deadline_of(timeout_ms);
        int st;

        while (!reaped(*pid, &st)) {
                if (left_ms(deadline) == 0)
                        return -ETIMEDOUT;
                poll(NULL, 0, 5);
        }
        *pid = 0;
        return st;
}

int mqtt_broker_start(struct mqtt_broker *b, const char *dir, int port, int timeout_ms)
{
        uint64_t deadline = deadline_of(timeout_ms);
        FILE *f;
        int st;

        snprintf(b->dir, sizeof(b->dir), "%s", dir);
        snprintf(b->conf, sizeof(b->conf), "%s/broker.conf", dir);
        snprintf(b->log, sizeof(b->log), "%s/broker.log", dir);
        b->port = port > 0 ? port : free_port();
        if (b->port < 0)
                return b->port;
        f = fopen(b->conf, "we");
        if (!f)
                return -errno;
        /* Persistence: the broker-restart test needs the sessions and queued messages back.
         * No message limit per client: the test's subscriber may lag behind a burst.
         * max_inflight_messages: large and finite, the deployment requirement in
         * sharedlink-mqtt(8). mosquitto 2.0.11 keeps QoS 1/2 messages to one client in order
         * only while that client's in-flight quota is not full (over it, messages are queued
         * and a new one can overtake them when a QoS 1 PUBACK frees a slot; its count also
         * lets more than the limit be in flight: 29 QoS 2 messages awaiting PUBCOMP at 20),
         * and after its own restart it restores only max_inflight_messages in-flight messages
         * per client with their state; "no maximum" (0, and 65535 behaves the same) restores
         * none. The others, even a QoS 2 message whose PUBREL had gone out, are sent again as
         * new PUBLISHes, which the subscriber delivers a second time
         * (tests/tools/mosquitto_qos2_restore.py shows it). As root, mosquitto would switch to its own user, which cannot
         * write the test's directory. MQTT_BROKER_LOG_ALL=1: every packet in broker.log. */
        fprintf(f, "listener %d 127.0.0.1\n%s%spersistence true\npersistence_location %s/\n"
                   "max_queued_messages 0\nmax_inflight_messages %d\n%s%s", b->port,
                b->listener_conf ? b->listener_conf : "",
                b->listener_conf && strstr(b->listener_conf, "allow_anonymous") ? "" :
                "allow_anonymous true\n", dir, MQTT_BROKER_INFLIGHT,
                geteuid() == 0 ? "user root\n" : "",
                getenv("MQTT_BROKER_LOG_ALL") ? "log_type all\n" : "");
        if (fclose(f) != 0)
                return -errno;
        b->pid = fork();
        if (b->pid < 0)
                return -errno;
        if (b->pid == 0) {
                int fd = open(b->log, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);

                prctl(PR_SET_PDEATHSIG, SIGKILL);
                if (fd >= 0) {
                        dup2(fd, STDOUT_FILENO);
                        dup2(fd, STDERR_FILENO);
                }
                execl(MQTT_BROKER_PATHS, MQTT_BROKER_BIN, "-c", b->conf, (char *)NULL);
                _exit(127);
        }
        /* A TCP port gives no readiness event: try to connect in short slices. */
        while (!port_open(b->port)) {
                if (reaped(b->pid, &st)) {
                        b->pid = 0;
                        return -ECHILD;
                }
                if (left_ms(deadline) == 0)
                        return -ETIMEDOUT;
                poll(NULL, 0, MQTT_SLICE_MS);
        }
        return 0;
}

int mqtt_broker_stop(struct mqtt_broker *b, int timeout_ms)
{
        int r;

        if (b->pid <= 0)
                return 0;
        kill(b->pid, SIGTERM);
        r = wait_exit(&b->pid, timeout_ms);
        if (r == -ETIMEDOUT) {
                kill(b->pid, SIGKILL);
                wait_exit(&b->pid, timeout_ms);
        }
        return r < 0 ? r : 0;
}

/* ---- the bridge ------------------------------------------------------------------------------ */

static int notify_open(struct mqtt_bridge *br)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };

        if (br->notify_fd >= 0)
                return 0;
        snprintf(br->notify_path, sizeof(br->notify_path), "%s/bridge-notify.sock", br->h->dir);
        if (strlen(br->notify_path) >= sizeof(sa.sun_path))
                return -ENAMETOOLONG;
        strcpy(sa.sun_path, br->notify_path);
        unlink(br->notify_path);
        br->notify_fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
        if (br->notify_fd < 0)
                return -errno;
        if (bind(br->notify_fd, (struct sockaddr *)&sa, sizeof(sa)) < 0)
                return -errno;
        return 0;
}

static int notify_ready(struct mqtt_bridge *br)
{
        char buf[MQTT_NOTIFY_MAX];
        ssize_t n;
        int found = 0;

        while ((n = recv(br->notify_fd, buf, sizeof(buf) - 1, 0)) >= 0) {
                buf[n] = '\0';
                if (strstr(buf, "READY=1"))
                        found = 1;
                if (strstr(buf, "STATUS="))
                        snprintf(br->status, sizeof(br->status), "%s", buf);
        }
        return found;
}

int mqtt_bridge_start(struct mqtt_bridge *br, struct harness *h, const char *config,
                      int timeout_ms, int *ret_status)
{
        uint64_t deadline = deadline_of(timeout_ms);
        int r, st;

        if (br->h != h) {
                br->h = h;
                br->notify_fd = -1;
        }
        if ((r = notify_open(br)) < 0)
                return r;
        snprintf(br->log_path, sizeof(br->log_path), "%s/bridge.log", h->dir);
        notify_ready(br);       /* forget an earlier run's datagrams */
        br->status[0] = '\0';
        br->pid = fork();
        if (br->pid < 0)
                return -errno;
        if (br->pid == 0) {
                int fd = open(br->log_path, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);

                prctl(PR_SET_PDEATHSIG, SIGTERM);
                if (fd >= 0)
                        dup2(fd, STDERR_FILENO);
                setenv("NOTIFY_SOCKET", br->notify_path, 1);
                setenv("SHAREDLINK_RUNTIME_DIR", h->dir, 1);
                setenv("SHAREDLINK_INSTANCE", h->instance, 1);
                execl(mqtt_bridge_path(), "sharedlink-mqtt", "-c", config, "-v", (char *)NULL);
                _exit(127);
        }
        for (;;) {
                struct pollfd p = { .fd = br->notify_fd, .events = POLLIN };
                int left = left_ms(deadline);

                if (notify_ready(br))
                        return 0;
                if (reaped(br->pid, &st)) {
                        br->pid = 0;
                        if (ret_status)
                                *ret_status = st;
                        return -ECHILD;
                }
                if (left == 0)
                        return -ETIMEDOUT;
                /* Short slices: a bridge that dies sends no datagram to wake us. */
                poll(&p, 1, left < MQTT_SLICE_MS ? left : MQTT_SLICE_MS);
        }
}

int mqtt_bridge_stop(struct mqtt_bridge *br, int sig, int timeout_ms)
{
        int r;

        if (br->pid <= 0)
                return -ECHILD;
        kill(br->pid, sig);
        r = wait_exit(&br->pid, timeout_ms);
        if (r == -ETIMEDOUT) {
                kill(br->pid, SIGKILL);
                wait_exit(&br->pid, timeout_ms);
        }
        return r;
}

void mqtt_bridge_cleanup(struct mqtt_bridge *br)
{
        if (br->pid > 0)
                mqtt_bridge_stop(br, SIGKILL, 5000);
        if (br->h && br->notify_fd >= 0)
                close(br->notify_fd);
        br->notify_fd = -1;
}

int mqtt_bridge_log_contains(struct mqtt_bridge *br, const char *needle)
{
        char buf[65536];
        int fd = open(br->log_path, O_RDONLY | O_CLOEXEC);
        ssize_t n;

        if (fd < 0)
                return -errno;
        n = read(fd, buf, sizeof(buf) - 1);
        close(fd);
        if (n < 0)
                return -errno;
        buf[n] = '\0';
        return strstr(buf, needle) != NULL;
}

/* Occurrences of needle in the bridge's log (its first 1 MiB), or -errno. */
static int log_count(struct mqtt_bridge *br, const char *needle)
{
        enum { LOG_READ_MAX = 1 << 20 };
        char *buf = malloc(LOG_READ_MAX + 1);
        int fd = open(br->log_path, O_RDONLY | O_CLOEXEC), n = 0;
        ssize_t len;

        if (!buf || fd < 0) {
                n = fd < 0 ? -errno : -ENOMEM;
                free(buf);
                if (fd >= 0)
                        close(fd);
                return n;
        }
        len = read(fd, buf, LOG_READ_MAX);
        close(fd);
        if (len < 0) {
                free(buf);
                return -EIO;
        }
        buf[len] = '\0';
        for (const char *p = buf; (p = strstr(p, needle)); p += strlen(needle))
                n++;
        free(buf);
        return n;
}

int mqtt_bridge_wait_log(struct mqtt_bridge *br, const char *needle, unsigned n,
                         int timeout_ms)
{
        uint64_t deadline = deadline_of(timeout_ms);

        /* A file gives no event when it grows: look in short slices. */
        while (log_count(br, needle) < (int)n) {
                if (left_ms(deadline) == 0)
                        return -ETIMEDOUT;
                poll(NULL, 0, MQTT_SLICE_MS);
        }
        return 0;
}

int mqtt_bridge_wait_status(struct mqtt_bridge *br, const char *needle, int timeout_ms)
{
        uint64_t deadline = deadline_of(timeout_ms);

        for (;;) {
                struct pollfd p = { .fd = br->notify_fd, .events = POLLIN };

                notify_ready(br);
                if (strstr(br->status, needle))
                        return 0;
                if (left_ms(deadline) == 0)
                        return -ETIMEDOUT;
                poll(&p, 1, left_ms(deadline));
        }
}

/* ---- a raw connection ------------------------------------------------------------------------ */

#define RAW_CONNECT             0x10
#define RAW_CONNACK             0x20
#define RAW_PUBLISH             0x30
#define RAW_PINGREQ             0xc0
#define RAW_PINGRESP            0xd0
#define RAW_HEAD_MAX            8       /* fixed header and topic length */
#define RAW_REMAINING_MAX       (128u * 128u * 128u - 1u)       /* what 3 length bytes say */

/* Appends the fixed header (type, remaining length) to out; the bytes written. */
static size_t raw_header(unsigned char *out, unsigned type, size_t remaining)
{
        size_t n = 0;

        out[n++] = (unsigned char)type;
        do {
                out[n] = (unsigned char)(remaining % 128u);
                remaining /= 128u;
                if (remaining)
                        out[n] |= 0x80u;
                n++;
        } while (remaining);
        return n;
}

static int raw_send(int fd, const void *buf, size_t len)
{
        const unsigned char *p = buf;

        while (len) {
                ssize_t w = send(fd, p, len, MSG_NOSIGNAL);

                if (w < 0 && errno == EINTR)
                        continue;
                if (w < 0)
                        return errno == EPIPE || errno == ECONNRESET ? 1 : -errno;
                p += w;
                len -= (size_t)w;
        }
        return 0;
}

/* The first byte of the next packet, -ECONNRESET at EOF, -ETIMEDOUT. */
static int raw_next(int fd, uint64_t deadline)
{
        unsigned char b[4];
        struct pollfd p = { .fd = fd, .events = POLLIN };
        ssize_t n;

        if (poll(&p, 1, left_ms(deadline)) <= 0)
                return -ETIMEDOUT;
        n = recv(fd, b, sizeof(b), 0);  /* CONNACK and PINGRESP are 4 and 2 bytes */
        if (n <= 0)
                return -ECONNRESET;
        return b[0];
}

int mqtt_raw_publish(int port, const void *topic, size_t topic_len, const void *payload,
                     size_t len, int timeout_ms)
{
        static const unsigned char connect_body[] = {
                0, 4, 'M', 'Q', 'T', 'T', 4, 0x02 /* clean session */, 0, 10 /* keepalive */,
                0, 7, 'r', 'a', 'w', 't', 'e', 's', 't' };
        static const unsigned char ping[] = { RAW_PINGREQ, 0 };
        struct sockaddr_in sa = { .sin_family = AF_INET, .sin_port = htons((uint16_t)port),
                                  .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
        uint64_t deadline = deadline_of(timeout_ms);
        unsigned char head[RAW_HEAD_MAX + 2];
        size_t remaining = 2 + topic_len + len, n;
        int fd, r;

        if (topic_len > UINT16_MAX || remaining > RAW_REMAINING_MAX)
                return -EMSGSIZE;
        fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        if (fd < 0)
                return -errno;
        if (connect(fd, (struct sockaddr *)&sa, sizeof(sa)) < 0) {
                r = -errno;
                goto out;
        }
        n = raw_header(head, RAW_CONNECT, sizeof(connect_body));
        if ((r = raw_send(fd, head, n)) != 0 ||
            (r = raw_send(fd, connect_body, sizeof(connect_body))) != 0)
                goto out;
        if ((r = raw_next(fd, deadline)) != RAW_CONNACK) {
                r = r < 0 ? r : -EPROTO;
                goto out;
        }
        n = raw_header(head, RAW_PUBLISH, remaining);
        head[n++] = (unsigned char)(topic_len >> 8);
        head[n++] = (unsigned char)(topic_len & 0xffu);
        if ((r = raw_send(fd, head, n)) != 0 || (r = raw_send(fd, topic, topic_len)) != 0 ||
            (r = raw_send(fd, payload, len)) != 0 || (r = raw_send(fd, ping, sizeof(ping))) != 0)
                goto out;
        r = raw_next(fd, deadline);
        r = r == RAW_PINGRESP ? 0 : r == -ECONNRESET ? 1 : r < 0 ? r : -EPROTO;
out:
        close(fd);
        return r;
}

/* ---- a client -------------------------------------------------------------------------------- */

static const char *json_after(const char *p, size_t len, const char *key)
{
        const char *k = memmem(p, len, key, strlen(key));

        return k ? k + strlen(key) : NULL;
}

static void record_event(struct mqtt_client *c, const char *p, size_t len, int mid)
{
        struct mqtt_event e = { .sensor_time = -1, .mid = mid };
        const char *s;

        if (c->n_events == c->cap_events) {
                size_t cap = c->cap_events ? c->cap_events * 2 : 1024;
                struct mqtt_event *ne = realloc(c->events, cap * sizeof(*ne));

                if (!ne)
                        return;
                c->events = ne;
                c->cap_events = cap;
        }
        if ((s = json_after(p, len, "\"seq\":")))
                e.seq = strtoull(s, NULL, 10);
        if ((s = json_after(p, len, "\"lost\":")))
                e.lost = strtoull(s, NULL, 10);
        if ((s = json_after(p, len, "\"sensor_time\":\"")))
                e.sensor_time = strtol(s, NULL, 10);
        if ((s = json_after(p, len, "\"type\":\""))) {
                size_t n = strcspn(s, "\"");

                snprintf(e.type, sizeof(e.type), "%.*s", (int)n, s);
        }
        c->events[c->n_events++] = e;
}

static struct mqtt_value *value_slot(struct mqtt_client *c, const char *topic)
{
        for (unsigned i = 0; i < c->n_values; i++)
                if (!strcmp(c->values[i].topic, topic))
                        return &c->values[i];
        if (c->n_values == MQTT_VALUES_MAX || strlen(topic) >= MQTT_TOPIC_MAX)
                return NULL;
        snprintf(c->values[c->n_values].topic, MQTT_TOPIC_MAX, "%s", topic);
        return &c->values[c->n_values++];
}

static void on_message(struct mosquitto *m, void *arg, const struct mosquitto_message *msg)
{
        struct mqtt_client *c = arg;
        size_t len = msg->payloadlen > 0 ? (size_t)msg->payloadlen : 0;
        struct mqtt_value *v;

        (void)m;
        if (c->on_message)
                c->on_message(c->on_message_arg, msg->topic, msg->payload, len);
        pthread_mutex_lock(&c->lock);
        c->messages++;
        if (strstr(msg->topic, "/events") && len)
                record_event(c, msg->payload, len, msg->mid);
        else if ((v = value_slot(c, msg->topic))) {
                size_t n = len < MQTT_PAYLOAD_MAX - 1 ? len : MQTT_PAYLOAD_MAX - 1;

                if (n)
                        memcpy(v->payload, msg->payload, n);
                v->payload[n] = '\0';
                v->len = len;
                v->count++;
        }
        pthread_cond_broadcast(&c->cond);
        pthread_mutex_unlock(&c->lock);
}

static void on_connect(struct mosquitto *m, void *arg, int rc)
{
        struct mqtt_client *c = arg;

        if (rc != 0)
                return;
        if (c->subscription[0])
                mosquitto_subscribe(m, NULL, c->subscription, c->qos);
        else {
                pthread_mutex_lock(&c->lock);
                c->connected = true;
                c->connects++;
                pthread_cond_broadcast(&c->cond);
                pthread_mutex_unlock(&c->lock);
        }
}

static void on_subscribe(struct mosquitto *m, void *arg, int mid, int n, const int *granted)
{
        struct mqtt_client *c = arg;

        (void)m;
        (void)mid;
        (void)n;
        (void)granted;
        pthread_mutex_lock(&c->lock);
        c->connected = true;
        c->connects++;
        pthread_cond_broadcast(&c->cond);
        pthread_mutex_unlock(&c->lock);
}

static void on_disconnect(struct mosquitto *m, void *arg, int rc)
{
        struct mqtt_client *c = arg;

        (void)m;
        (void)rc;
        pthread_mutex_lock(&c->lock);
        c->connected = false;
        pthread_mutex_unlock(&c->lock);
}

int mqtt_client_wait_connects(struct mqtt_client *c, uint64_t after, int timeout_ms)
{
        struct timespec ts;
        int r = 0;

        timespec_at(&ts, timeout_ms);
        pthread_mutex_lock(&c->lock);
        while (c->connects <= after && r == 0)
                r = pthread_cond_timedwait(&c->cond, &c->lock, &ts);
        pthread_mutex_unlock(&c->lock);
        return r == 0 ? 0 : -ETIMEDOUT;
}

int mqtt_client_start(struct mqtt_client *c, int port, const char *id, bool clean,
                      const char *subscription, int qos, int timeout_ms)
{
        return mqtt_client_start_auth(c, port, id, clean, subscription, qos, NULL, timeout_ms);
}

int mqtt_client_start_auth(struct mqtt_client *c, int port, const char *id, bool clean,
                           const char *subscription, int qos,
                           const struct mqtt_client_auth *auth, int timeout_ms)
{
        int r;

        memset(c, 0, sizeof(*c));
        pthread_mutex_init(&c->lock, NULL);
        pthread_cond_init(&c->cond, NULL);
        c->values = calloc(MQTT_VALUES_MAX, sizeof(*c->values));
        if (!c->values)
                return -ENOMEM;
        snprintf(c->subscription, sizeof(c->subscription), "%s", subscription ? subscription : "");
        c->qos = qos;
        mosquitto_lib_init();
        c->m = mosquitto_new(id, clean, c);
        if (!c->m)
                return -ENOMEM;
        mosquitto_connect_callback_set(c->m, on_connect);
        mosquitto_subscribe_callback_set(c->m, on_subscribe);
        mosquitto_disconnect_callback_set(c->m, on_disconnect);
        mosquitto_message_callback_set(c->m, on_message);
        mosquitto_reconnect_delay_set(c->m, 1, 1, false);
        /* QoS 1/2 messages from the broker are acknowledged as they arrive: no inflight cap. */
        mosquitto_max_inflight_messages_set(c->m, 0);
        if (auth && auth->ca_file &&
            mosquitto_tls_set(c->m, auth->ca_file, NULL, NULL, NULL, NULL) != MOSQ_ERR_SUCCESS)
                return -EINVAL;
        if (auth && auth->username &&
            mosquitto_username_pw_set(c->m, auth->username, auth->password) != MOSQ_ERR_SUCCESS)
                return -EINVAL;
        r = mosquitto_connect(c->m, "127.0.0.1", port, MQTT_KEEPALIVE_S);
        if (r != MOSQ_ERR_SUCCESS)
                return -ECONNREFUSED;
        if (mosquitto_loop_start(c->m) != MOSQ_ERR_SUCCESS)
                return -EIO;
        return mqtt_client_wait_connects(c, 0, timeout_ms);
}

void mqtt_client_stop(struct mqtt_client *c)
{
        if (c->m) {
                mosquitto_disconnect(c->m);
                mosquitto_loop_stop(c->m, false);
                mosquitto_destroy(c->m);
                c->m = NULL;
                pthread_mutex_destroy(&c->lock);
                pthread_cond_destroy(&c->cond);
        }
        free(c->values);
        free(c->events);
        c->values = NULL;
        c->events = NULL;
}

int mqtt_client_publish(struct mqtt_client *c, const char *topic, const void *payload,
                        size_t len, int qos, bool retain)
{
        int r = mosquitto_publish(c->m, NULL, topic, (int)len, payload, qos, retain);

        return r == MOSQ_ERR_SUCCESS ? 0 : -EIO;
}

/* Waits until pred(c, arg) holds, with the lock held around each test. */
static int wait_until(struct mqtt_client *c, int (*pred)(struct mqtt_client *, const void *),
                      const void *arg, int timeout_ms)
{
        struct timespec ts;
        int r = 0;

        timespec_at(&ts, timeout_ms);
        pthread_mutex_lock(&c->lock);
        while (!pred(c, arg) && r == 0)
                r = pthread_cond_timedwait(&c->cond, &c->lock, &ts);
        if (r != 0 && pred(c, arg))
                r = 0;
        pthread_mutex_unlock(&c->lock);
        return r == 0 ? 0 : -ETIMEDOUT;
}

struct value_want {
        const char *topic, *want;
        bool contains;
        char *out;
        size_t size;
};

static int value_matches(struct mqtt_client *c, const void *arg)
{
        const struct value_want *w = arg;

        for (unsigned i = 0; i < c->n_values; i++) {
                const struct mqtt_value *v = &c->values[i];

                if (strcmp(v->topic, w->topic))
                        continue;
                if (w->contains ? !strstr(v->payload, w->want) : strcmp(v->payload, w->want))
                        return 0;
                if (w->out)
                        snprintf(w->out, w->size, "%s", v->payload);
                return 1;
        }
        return 0;
}

int mqtt_client_wait_value(struct mqtt_client *c, const char *topic, const char *want,
                           int timeout_ms)
{
        struct value_want w = { .topic = topic, .want = want };

        return wait_until(c, value_matches, &w, timeout_ms);
}

int mqtt_client_wait_contains(struct mqtt_client *c, const char *topic, const char *needle,
                              char *out, size_t size, int timeout_ms)
{
        struct value_want w = { .topic = topic, .want = needle, .contains = true, .out = out,
                                .size = size };

        return wait_until(c, value_matches, &w, timeout_ms);
}

uint64_t mqtt_client_count(struct mqtt_client *c, const char *topic)
{
        uint64_t n = 0;

        pthread_mutex_lock(&c->lock);
        for (unsigned i = 0; i < c->n_values; i++)
                if (!strcmp(c->values[i].topic, topic))
                        n = c->values[i].count;
        pthread_mutex_unlock(&c->lock);
        return n;
}

struct count_want {
        const char *topic;
        uint64_t n;
};

static int count_reached(struct mqtt_client *c, const void *arg)
{
        const struct count_want *w = arg;

        for (unsigned i = 0; i < c->n_values; i++)
                if (!strcmp(c->values[i].topic, w->topic))
                        return c->values[i].count >= w->n;
        return w->n == 0;
}

int mqtt_client_wait_count(struct mqtt_client *c, const char *topic, uint64_t n, int timeout_ms)
{
        struct count_want w = { .topic = topic, .n = n };

        return wait_until(c, count_reached, &w, timeout_ms);
}

static int events_at_least(struct mqtt_client *c, const void *arg)
{
        return c->n_events >= *(const size_t *)arg;
}

int mqtt_client_wait_events(struct mqtt_client *c, size_t n, int timeout_ms)
{
        return wait_until(c, events_at_least, &n, timeout_ms);
}

/* Events arrive in order: only the newest ones need a look. */
static int sensor_time_seen(struct mqtt_client *c, const void *arg)
{
        for (size_t i = c->n_events; i-- > 0;)
                if (c->events[i].sensor_time == *(const long *)arg)
                        return 1;
                else if (c->events[i].sensor_time >= 0)
                        return 0;
        return 0;
}

int mqtt_client_wait_sensor_time(struct mqtt_client *c, long sensor_time, int timeout_ms)
{
        return wait_until(c, sensor_time_seen, &sensor_time, timeout_ms);
}

static int type_seen(struct mqtt_client *c, const void *arg)
{
        for (size_t i = 0; i < c->n_events; i++)
                if (!strcmp(c->events[i].type, arg))
                        return 1;
        return 0;
}

int mqtt_client_wait_event_type(struct mqtt_client *c, const char *type, int timeout_ms)
{
        return wait_until(c, type_seen, type, timeout_ms);
}

size_t mqtt_client_events(struct mqtt_client *c)
{
        size_t n;

        pthread_mutex_lock(&c->lock);
        n = c->n_events;
        pthread_mutex_unlock(&c->lock);
        return n;
}
