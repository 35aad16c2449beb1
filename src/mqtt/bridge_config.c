/*
 * sharedlink-mqtt configuration (see bridge_config.h and conf/sharedlink-mqtt.yaml), read with the
 * toolkit's reader (svc/conf.h): the same file rules and messages as sharedlinkd's. Each mapping
 * is a table of keys below; what spans several keys is the check of its mapping.
 */
#include "mqtt/bridge_config.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "svc/conf.h"
#include "svc/globs.h"
#include "svc/io.h"

#define PORT_MAX                65535u
#define KEEPALIVE_MIN           5u      /* seconds; libmosquitto refuses less */
#define KEEPALIVE_MAX           65535u
#define QOS_MAX                 2u
#define PASSWORD_FILE_MAX       4096u   /* bytes read from password_file */

/* The table writes unsigned fields as uint32_t, and the meta enum as an int. */
_Static_assert(sizeof(unsigned) == sizeof(uint32_t), "CONF_UINT fields");
_Static_assert(sizeof(enum bridge_meta) == sizeof(int), "CONF_ENUM field");

#define CFG                     struct bridge_config

/* ---- values with rules of their own ---------------------------------------------------------- */

/* A topic level or prefix: non-empty levels without MQTT wildcards, no leading '$' or '/'. */
static int check_topic_part(struct conf *c, const struct conf_node *n, const char *what,
                            const char *s)
{
        size_t len = strlen(s);

        if (strpbrk(s, "+#"))
                return conf_fail(c, n, "%s: %s: MQTT wildcards '+' and '#' are not allowed in a "
                                 "topic", what, conf_quote(c, s, len));
        if (s[0] == '$')
                return conf_fail(c, n, "%s: %s: topics starting with '$' are reserved to the "
                                 "broker", what, conf_quote(c, s, len));
        if (s[0] == '/' || s[len - 1] == '/' || strstr(s, "//"))
                return conf_fail(c, n, "%s: %s: empty topic level", what, conf_quote(c, s, len));
        return 0;
}

static int check_prefix(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                        void *obj)
{
        return check_topic_part(c, n, k->name, ((CFG *)obj)->prefix);
}

static int check_instance(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                          void *obj)
{
        const char *s = ((CFG *)obj)->instance;

        if (strpbrk(s, "/+#"))
                return conf_fail(c, n, "%s: %s: '/', '+' and '#' are not allowed", k->name,
                                 conf_quote(c, s, strlen(s)));
        return 0;
}

static int parse_publish(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                         void *obj)
{
        return globs_read(c, k->name, n, &((CFG *)obj)->publish);
}

static int parse_writable(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                          void *obj)
{
        return globs_read(c, k->name, n, &((CFG *)obj)->writable);
}

/* ---- mappings -------------------------------------------------------------------------------- */

static int check_tls(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                     void *obj)
{
        CFG *cfg = obj;

        (void)k;
        cfg->tls = true;
        if (!cfg->ca_file[0] && !cfg->ca_path[0])
                return conf_fail(c, n, "tls: needs ca_file or ca_path");
        if (!cfg->cert_file[0] != !cfg->key_file[0])
                return conf_fail(c, n, "tls: cert_file and key_file go together");
        return 0;
}

static int check_broker(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                        void *obj)
{
        const CFG *cfg = obj;

        (void)k;
        if (cfg->reconnect_min_ms > cfg->reconnect_max_ms)
                return conf_fail(c, n, "broker: reconnect_min_ms (%u) is more than "
                                 "reconnect_max_ms (%u)", cfg->reconnect_min_ms,
                                 cfg->reconnect_max_ms);
        if (cfg->password[0] && cfg->password_file[0])
                return conf_fail(c, n, "broker: password and password_file exclude each other");
        if ((cfg->password[0] || cfg->password_file[0]) && !cfg->username[0])
                return conf_fail(c, n, "broker: a password needs a username");
        return 0;
}

static const struct conf_enum_name meta_names[] = {
        { "json", BRIDGE_META_JSON },
        { "none", BRIDGE_META_NONE },
};
static const struct conf_enum metas = { meta_names, sizeof(meta_names) / sizeof(meta_names[0]) };

static const struct conf_key tls_keys[] = {
        CONF_KEY_STRING("ca_file", CFG, ca_file),
        CONF_KEY_STRING("ca_path", CFG, ca_path),
        CONF_KEY_STRING("cert_file", CFG, cert_file),
        CONF_KEY_STRING("key_file", CFG, key_file),
        CONF_KEY_BOOL("insecure", CFG, tls_insecure),
};

static const struct conf_key broker_keys[] = {
        CONF_KEY_STRING("host", CFG, host),
        CONF_KEY_INT("port", CFG, port, 1, PORT_MAX),
        CONF_KEY_STRING("client_id", CFG, client_id),
        CONF_KEY_INT("keepalive_s", CFG, keepalive_s, KEEPALIVE_MIN, KEEPALIVE_MAX),
        CONF_KEY_STRING("username", CFG, username),
        CONF_KEY_STRING("password", CFG, password),
        CONF_KEY_STRING("password_file", CFG, password_file),
        CONF_KEY_UINT("reconnect_min_ms", CFG, reconnect_min_ms, 1, BRIDGE_RECONNECT_LIMIT),
        CONF_KEY_UINT("reconnect_max_ms", CFG, reconnect_max_ms, 1, BRIDGE_RECONNECT_LIMIT),
        CONF_KEY_UINT("max_inflight", CFG, max_inflight, 1, BRIDGE_INFLIGHT_MAX),
        CONF_KEY_MAPPING("tls", tls_keys, check_tls),
};

static const struct conf_key root_keys[] = {
        { .name = "instance", .type = CONF_STRING, CONF_FIELD(CFG, instance),
          .check = check_instance },
        { .name = "prefix", .type = CONF_STRING, CONF_FIELD(CFG, prefix), .check = check_prefix },
        CONF_KEY_MAPPING("broker", broker_keys, check_broker),
        CONF_KEY_CUSTOM("publish", parse_publish),
        CONF_KEY_INT("qos", CFG, qos, 0, QOS_MAX),
        CONF_KEY_BOOL("retain", CFG, retain),
        CONF_KEY_ENUM("meta", CFG, meta, &metas),
        CONF_KEY_BOOL("events", CFG, events),
        /* Events need an acknowledgement before the cursor moves: QoS 0 is refused. */
        CONF_KEY_INT("events_qos", CFG, events_qos, 1, QOS_MAX),
        CONF_KEY_UINT("events_window", CFG, events_window, BRIDGE_WINDOW_MIN, BRIDGE_WINDOW_MAX),
        CONF_KEY_PATH("cursor_file", CFG, cursor_file),
        CONF_KEY_UINT("cursor_sync_ms", CFG, cursor_sync_ms, 0, BRIDGE_CURSOR_SYNC_LIMIT),
        CONF_KEY_UINT("drain_ms", CFG, drain_ms, 0, BRIDGE_RECONNECT_LIMIT),
        CONF_KEY_CUSTOM("writable", parse_writable),
        CONF_KEY_INT("set_qos", CFG, set_qos, 0, QOS_MAX),
};

void bridge_config_defaults(struct bridge_config *ret)
{
        memset(ret, 0, sizeof(*ret));
        snprintf(ret->prefix, sizeof(ret->prefix), "sharedlink");
        snprintf(ret->host, sizeof(ret->host), "localhost");
        ret->port = BRIDGE_PORT_DEFAULT;
        ret->keepalive_s = BRIDGE_KEEPALIVE_DEFAULT;
        ret->reconnect_min_ms = BRIDGE_RECONNECT_MIN_DEFAULT;
        ret->reconnect_max_ms = BRIDGE_RECONNECT_MAX_DEFAULT;
        ret->max_inflight = BRIDGE_INFLIGHT_DEFAULT;
        ret->publish.count = 1;
        snprintf(ret->publish.glob[0], sizeof(ret->publish.glob[0]), "*");
        ret->qos = 0;
        ret->retain = true;
        ret->meta = BRIDGE_META_JSON;
        ret->events = true;
        ret->events_qos = 1;
        ret->events_window = BRIDGE_WINDOW_DEFAULT;
        ret->cursor_sync_ms = BRIDGE_CURSOR_SYNC_DEFAULT;
        ret->drain_ms = BRIDGE_DRAIN_DEFAULT;
        ret->set_qos = 1;
}

int bridge_config_parse(const char *name, const char *text, size_t len, struct bridge_config *ret,
                        char *err, size_t err_size)
{
        struct bridge_config *cfg = malloc(sizeof(*cfg));
        int r;

        if (!cfg) {
                snprintf(err, err_size, "%s: out of memory", name);
                return -ENOMEM;
        }
        bridge_config_defaults(cfg);
        r = conf_read_text(name, text, len, BRIDGE_FILE_MAX, root_keys,
                           sizeof(root_keys) / sizeof(root_keys[0]), cfg, err, err_size);
        if (r == 0)
                *ret = *cfg;
        free(cfg);
        return r;
}

/* The first line of password_file, without its newline. */
static int load_password(struct bridge_config *cfg, const char *path, char *err, size_t err_size)
{
        char *text;
        size_t len;
        int r = io_read_file(cfg->password_file, PASSWORD_FILE_MAX, &text, &len);

        if (r < 0) {
                snprintf(err, err_size, "%s: password_file %s: %s", path, cfg->password_file,
                         strerror(-r));
                return r;
        }
        len = strcspn(text, "\r\n");
        if (len == 0 || len >= sizeof(cfg->password)) {
                snprintf(err, err_size, "%s: password_file %s: %s", path, cfg->password_file,
                         len ? "password too long" : "empty first line");
                free(text);
                return -EINVAL;
        }
        memcpy(cfg->password, text, len);
        cfg->password[len] = '\0';
        explicit_bzero(text, len);
        free(text);
        return 0;
}

int bridge_config_load(const char *path, struct bridge_config *ret, char *err, size_t err_size)
{
        struct bridge_config *cfg = malloc(sizeof(*cfg));
        int r;

        if (!cfg) {
                snprintf(err, err_size, "%s: out of memory", path);
                return -ENOMEM;
        }
        bridge_config_defaults(cfg);
        r = conf_read_file(path, BRIDGE_FILE_MAX, root_keys,
                           sizeof(root_keys) / sizeof(root_keys[0]), cfg, err, err_size);
        if (r == 0 && cfg->password_file[0])
                r = load_password(cfg, path, err, err_size);
        if (r == 0)
                *ret = *cfg;
        free(cfg);
        return r;
}
