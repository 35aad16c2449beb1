/*
 * sharedlink-ros2 configuration (see ros2_config.h and conf/sharedlink-ros2.yaml), read with
 * the toolkit's reader (svc/conf.h). Each mapping is a table of keys below; what spans several
 * keys is the check of its mapping.
 */
#include "ros2/ros2_config.h"

#include <errno.h>
#include <libgen.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "svc/conf.h"
#include "svc/cursor.h"

#define INSTANCE_ENV            "SHAREDLINK_INSTANCE"
#define INSTANCE_DEFAULT        "default"
#define DECIMAL                 10

/* The table writes unsigned fields as uint32_t. */
_Static_assert(sizeof(unsigned) == sizeof(uint32_t), "CONF_UINT fields");

#define CFG                     struct ros2_config
#define NSF                     struct ros2_navsatfix

/* ---- values with rules of their own ---------------------------------------------------------- */

static int check_instance(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                          void *obj)
{
        const char *s = ((CFG *)obj)->instance;

        if (strchr(s, '/'))
                return conf_fail(c, n, "%s: %s: '/' is not allowed", k->name,
                                 conf_quote(c, s, strlen(s)));
        return 0;
}

static int check_namespace(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                           void *obj)
{
        const char *s = ((CFG *)obj)->ns;

        if (!ros2_names_valid(s, true))
                return conf_fail(c, n, "%s: %s: not a ROS namespace (an absolute name: '/' and "
                                 "tokens of letters, digits and '_', not starting with a digit)",
                                 k->name, conf_quote(c, s, strlen(s)));
        return 0;
}

static int parse_publish(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                         void *obj)
{
        CFG *cfg = obj;

        cfg->publish_line = n->line;
        cfg->publish_column = n->column;
        return globs_read(c, k->name, n, &cfg->publish);
}

static int parse_writable(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                          void *obj)
{
        return globs_read(c, k->name, n, &((CFG *)obj)->writable);
}

static int parse_domain(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                        void *obj)
{
        CFG *cfg = obj;
        uint32_t v;
        int r = conf_get_uint(c, k->name, n, 0, ROS2_DOMAIN_MAX, &v);

        if (r < 0)
                return r;
        cfg->domain_id = v;
        cfg->domain_set = true;
        return 0;
}

/* A variable name as sharedlink.h spells them (checked here; whether the daemon has it is
 * -n's question, main.c). */
static int check_var(struct conf *c, const struct conf_node *n, const char *key, const char *s)
{
        char rel[ROS2_REL_SIZE];

        if (ros2_names_map(s, rel, sizeof(rel)) < 0)
                return conf_fail(c, n, "navsatfix: %s: %s: not a variable name (1..47 letters, "
                                 "digits, '_', '.', '-')", key, conf_quote(c, s, strlen(s)));
        return 0;
}

static const struct conf_key navsatfix_keys[] = {
        CONF_KEY_STRING("topic", NSF, topic),
        CONF_KEY_STRING("latitude", NSF, latitude),
        CONF_KEY_STRING("longitude", NSF, longitude),
        CONF_KEY_STRING("altitude", NSF, altitude),
        CONF_KEY_STRING("frame_id", NSF, frame_id),
};

static int check_navsatfix(struct conf *c, const struct conf_node *n, const NSF *f)
{
        bool abs = f->topic[0] == '/';
        int r;

        if (!f->topic[0] || !f->latitude[0] || !f->longitude[0])
                return conf_fail(c, n, "navsatfix: needs topic, latitude and longitude");
        if (abs ? !ros2_names_valid(f->topic, false) : !ros2_names_valid_relative(f->topic))
                return conf_fail(c, n, "navsatfix: topic: %s: not a ROS topic name (tokens of "
                                 "letters, digits and '_' separated by '/', not starting with "
                                 "a digit)", conf_quote(c, f->topic, strlen(f->topic)));
        if ((r = check_var(c, n, "latitude", f->latitude)) < 0 ||
            (r = check_var(c, n, "longitude", f->longitude)) < 0 ||
            (f->altitude[0] && (r = check_var(c, n, "altitude", f->altitude)) < 0))
                return r;
        if (!strcmp(f->latitude, f->longitude) ||
            (f->altitude[0] && (!strcmp(f->altitude, f->latitude) ||
                                !strcmp(f->altitude, f->longitude))))
                return conf_fail(c, n, "navsatfix: latitude, longitude and altitude must be "
                                 "three different variables");
        for (const char *p = f->frame_id; *p; p++)
                if ((unsigned char)*p <= ' ' || (unsigned char)*p >= 0x7f)
                        return conf_fail(c, n, "navsatfix: frame_id: %s: printable ASCII "
                                         "without spaces", conf_quote(c, f->frame_id,
                                                                      strlen(f->frame_id)));
        return 0;
}

static int parse_navsatfix(struct conf *c, const struct conf_key *k, const struct conf_node *n,
                           void *obj)
{
        CFG *cfg = obj;
        int r = conf_need_kind(c, k->name, n, CONF_NODE_SEQUENCE);

        if (r < 0)
                return r;
        cfg->n_navsatfix = 0;
        for (const struct conf_node *item = conf_child(c, n->first); item;
             item = conf_next(c, item)) {
                NSF *f = &cfg->navsatfix[cfg->n_navsatfix];

                if (cfg->n_navsatfix >= ROS2_NAVSATFIX_MAX)
                        return conf_fail(c, item, "%s: more than %u entries", k->name,
                                         ROS2_NAVSATFIX_MAX);
                memset(f, 0, sizeof(*f));
                snprintf(f->frame_id, sizeof(f->frame_id), ROS2_FRAME_DEFAULT);
                f->line = item->line;
                f->column = item->column;
                r = conf_table_read(c, item, k->name, "in navsatfix", navsatfix_keys,
                                    sizeof(navsatfix_keys) / sizeof(navsatfix_keys[0]), f);
                if (r < 0 || (r = check_navsatfix(c, item, f)) < 0)
                        return r;
                for (unsigned i = 0; i < cfg->n_navsatfix; i++)
                        if (!strcmp(cfg->navsatfix[i].topic, f->topic))
                                return conf_fail(c, item, "%s: topic %s: used twice", k->name,
                                                 conf_quote(c, f->topic, strlen(f->topic)));
                cfg->n_navsatfix++;
        }
        return 0;
}

static const struct conf_key root_keys[] = {
        { .name = "instance", .type = CONF_STRING, CONF_FIELD(CFG, instance),
          .check = check_instance },
        { .name = "namespace", .type = CONF_STRING, CONF_FIELD(CFG, ns),
          .check = check_namespace },
        CONF_KEY_CUSTOM("publish", parse_publish),
        CONF_KEY_CUSTOM("writable", parse_writable),
        CONF_KEY_CUSTOM("domain_id", parse_domain),
        CONF_KEY_STRING("cyclonedds_uri", CFG, cyclonedds_uri),
        CONF_KEY_CUSTOM("navsatfix", parse_navsatfix),
        CONF_KEY_UINT("wait_spin_us", CFG, wait_spin_us, 0, SL_WAIT_SPIN_MAX_US),
        CONF_KEY_PATH("cursor_file", CFG, cursor_file),
};
#define N_ROOT_KEYS             (sizeof(root_keys) / sizeof(root_keys[0]))

void ros2_config_defaults(struct ros2_config *ret)
{
        memset(ret, 0, sizeof(*ret));
        ret->publish.count = 1;
        snprintf(ret->publish.glob[0], sizeof(ret->publish.glob[0]), "*");
}

int ros2_config_parse(const char *name, const char *text, size_t len, struct ros2_config *ret,
                      char *err, size_t err_size)
{
        struct ros2_config cfg;
        int r;

        ros2_config_defaults(&cfg);
        r = conf_read_text(name, text, len, ROS2_FILE_MAX, root_keys, N_ROOT_KEYS, &cfg, err,
                           err_size);
        if (r == 0)
                *ret = cfg;
        return r;
}

int ros2_config_load(const char *path, struct ros2_config *ret, char *err, size_t err_size)
{
        struct ros2_config cfg;
        int r;

        ros2_config_defaults(&cfg);
        r = conf_read_file(path, ROS2_FILE_MAX, root_keys, N_ROOT_KEYS, &cfg, err, err_size);
        if (r == 0)
                *ret = cfg;
        return r;
}

int ros2_config_check_cursor(const struct ros2_config *cfg, const char *name, char *err,
                             size_t err_size)
{
        char dir[ROS2_PATH_MAX];
        struct cursor c;
        int r;

        if (!cfg->cursor_file[0])
                return 0;
        r = cursor_load(cfg->cursor_file, ROS2_CURSOR_OWNER, &c);
        if (r == -ENOENT) {
                snprintf(dir, sizeof(dir), "%s", cfg->cursor_file);
                r = access(dirname(dir), W_OK | X_OK) < 0 ? -errno : 0;
        }
        if (r == 0)
                return 0;
        snprintf(err, err_size, "%s: cursor_file %s: %s", name, cfg->cursor_file,
                 r == -EBADMSG ? "not a " ROS2_CURSOR_OWNER " cursor (another program's file?)" :
                 r == -ENOENT ? "its directory does not exist" : strerror(-r));
        return r;
}

int ros2_config_names(const struct ros2_config *cfg, char instance[ROS2_INSTANCE_MAX],
                      char ns[ROS2_NAMESPACE_MAX])
{
        const char *inst = cfg->instance[0] ? cfg->instance : getenv(INSTANCE_ENV);
        int n;

        if (!inst || !inst[0])
                inst = INSTANCE_DEFAULT;
        n = snprintf(instance, ROS2_INSTANCE_MAX, "%s", inst);
        if (n < 0 || n >= ROS2_INSTANCE_MAX)
                return -EINVAL;
        if (cfg->ns[0]) {
                n = snprintf(ns, ROS2_NAMESPACE_MAX, "%s", cfg->ns);
        } else {
                char rel[ROS2_REL_SIZE];

                /* The instance by the variables' rule ("t12-x" is t12_x, "2nd" is _2nd). */
                if (ros2_names_map(instance, rel, sizeof(rel)) < 0)
                        return -EINVAL;
                n = snprintf(ns, ROS2_NAMESPACE_MAX, ROS2_NAMESPACE_PREFIX "%s", rel);
        }
        if (n < 0 || n >= ROS2_NAMESPACE_MAX || !ros2_names_valid(ns, true))
                return -EINVAL;
        return 0;
}

int ros2_config_domain(const struct ros2_config *cfg, unsigned *ret)
{
        const char *env = getenv(ROS2_DOMAIN_ENV);
        unsigned long v;
        char *end;

        if (cfg->domain_set) {
                *ret = cfg->domain_id;
                return 0;
        }
        if (!env || !env[0]) {
                *ret = 0;
                return 0;
        }
        errno = 0;
        v = strtoul(env, &end, DECIMAL);
        if (errno || *end || env[0] < '0' || env[0] > '9' || v > ROS2_DOMAIN_MAX)
                return -EINVAL;
        *ret = (unsigned)v;
        return 0;
}
