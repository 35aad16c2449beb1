/*
 * sharedlink-mqtt configuration: one YAML file, read with the toolkit's reader (svc/conf.h), as
 * sharedlinkd's is: unknown keys, wrong types, out-of-range numbers, duplicate keys, anchors,
 * aliases and tags are errors "FILE:LINE:COL: message" worded as sharedlinkd's, never a silent
 * default.
 */
#ifndef SHAREDLINK_MQTT_BRIDGE_CONFIG_H
#define SHAREDLINK_MQTT_BRIDGE_CONFIG_H

#include <stdbool.h>
#include <stddef.h>

#include <sharedlink.h>

#include "svc/globs.h"

#define BRIDGE_CONFIG_DEFAULT   "/etc/sharedlink/sharedlink-mqtt.yaml"
#define BRIDGE_CURSOR_DIR       "/var/lib/sharedlink-mqtt"
#define BRIDGE_CURSOR_OWNER     "sharedlink-mqtt"       /* svc/cursor.h: the file's first word */
#define BRIDGE_FILE_MAX         (64u * 1024u)   /* bytes of a configuration file */
#define BRIDGE_ERROR_MAX        512
#define BRIDGE_PATH_MAX         256
#define BRIDGE_INSTANCE_MAX     64
#define BRIDGE_PREFIX_MAX       128     /* bytes of the topic prefix */
#define BRIDGE_HOST_MAX         256
#define BRIDGE_CLIENT_ID_MAX    128
#define BRIDGE_USER_MAX         128
#define BRIDGE_PASSWORD_MAX     256
#define BRIDGE_WINDOW_MIN       2u      /* a notice and its event */
#define BRIDGE_WINDOW_MAX       1024u   /* events in flight (published, not yet acknowledged) */
#define BRIDGE_PORT_DEFAULT     1883
#define BRIDGE_KEEPALIVE_DEFAULT 30
#define BRIDGE_RECONNECT_MIN_DEFAULT 100u
#define BRIDGE_RECONNECT_MAX_DEFAULT 5000u
#define BRIDGE_RECONNECT_LIMIT  600000u /* reconnect_*_ms */
#define BRIDGE_WINDOW_DEFAULT   64u
/* At most the broker's max_inflight_messages (mosquitto's default is 20; sharedlink-mqtt(8) asks
 * for 1000): an MQTT 3.1.1 broker cannot tell a client its limit, mosquitto drops the connection
 * of a client far over it and answers a QoS 2 message over its incoming quota with a PUBREC that
 * a 3.1.1 client cannot tell from success. 10 also keeps a broker at its default safe. */
#define BRIDGE_INFLIGHT_DEFAULT 10u
#define BRIDGE_INFLIGHT_MAX     65535u
#define BRIDGE_CURSOR_SYNC_DEFAULT 1000u
#define BRIDGE_CURSOR_SYNC_LIMIT 60000u
#define BRIDGE_DRAIN_DEFAULT    5000u   /* stop: wait this long for acknowledgements */

enum bridge_meta {
        BRIDGE_META_JSON,               /* <prefix>/<instance>/<name>/meta, retained JSON */
        BRIDGE_META_NONE,
};

struct bridge_config {
        char instance[BRIDGE_INSTANCE_MAX];     /* "" : $SHAREDLINK_INSTANCE or "default" */
        char prefix[BRIDGE_PREFIX_MAX];
        /* broker: */
        char host[BRIDGE_HOST_MAX];
        int port;
        char client_id[BRIDGE_CLIENT_ID_MAX];   /* "" : sharedlink-mqtt-<instance> */
        int keepalive_s;
        char username[BRIDGE_USER_MAX];
        char password[BRIDGE_PASSWORD_MAX];     /* inline, or read from password_file */
        char password_file[BRIDGE_PATH_MAX];
        unsigned reconnect_min_ms, reconnect_max_ms;
        unsigned max_inflight;                  /* QoS 1/2 messages unacknowledged at once */
        bool tls;                               /* any tls: key given */
        char ca_file[BRIDGE_PATH_MAX], ca_path[BRIDGE_PATH_MAX];
        char cert_file[BRIDGE_PATH_MAX], key_file[BRIDGE_PATH_MAX];
        bool tls_insecure;
        /* values */
        struct globs publish;            /* default: ["*"] */
        int qos;
        bool retain;
        enum bridge_meta meta;
        /* events */
        bool events;
        int events_qos;
        unsigned events_window;
        char cursor_file[BRIDGE_PATH_MAX];      /* "" : BRIDGE_CURSOR_DIR/<instance>.cursor */
        unsigned cursor_sync_ms;
        unsigned drain_ms;
        /* set */
        struct globs writable;           /* default: none */
        int set_qos;
};

/* Fills *ret with every default (what an empty file gives). */
void bridge_config_defaults(struct bridge_config *ret);

/* Parses text (len bytes; name is used in messages) into *ret. 0, or -EINVAL / -ENOMEM with
 * "NAME:LINE:COL: message" in err (err_size bytes). */
int bridge_config_parse(const char *name, const char *text, size_t len, struct bridge_config *ret,
                        char *err, size_t err_size);

/* Reads and parses a file (and the password_file it names). 0 or -errno, message in err. */
int bridge_config_load(const char *path, struct bridge_config *ret, char *err, size_t err_size);

#endif
