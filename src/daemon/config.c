/*
 * sharedlinkd configuration parser: the public entry points (config.h).
 *
 * The module is split along its stages (config_ctx.h lists the files): the toolkit's reader
 * (svc/conf.h) turns the file into a tree of nodes with positions, config_schema.c and
 * config_peer.c walk the tree mapping by mapping into struct config with the toolkit's and
 * config_value.c's scalar readers, and config_check.c checks what spans several keys or links.
 * Every problem is reported as "FILE:LINE:COL: text", the first one only. The rules of the file
 * (plain numbers and booleans, no leading zeros, no yes/no, no anchors, tags or merge keys) are
 * the toolkit's, shared by every daemon: see svc/conf.h.
 *
 * Adding a key. Each mapping has one key table, next to the function that reads it: top_keys
 * (top level) and link_keys (a link, with where the key applies: protocol, role, transport) in
 * config_schema.c; var_keys, peer_keys and emulate_keys in config_peer.c. A peer's plain integer
 * or boolean key is one row of peer_keys (name, range, default, field) under a new PK_ index:
 * parse_peer_plain() reads it. Any other key gets its index and name in its table, and is read
 * in that mapping's function with a cfg_get_*() (svc/conf.h or config_value.c: it gives the
 * type, range and message); its default goes where the others' are set. Then add its field to
 * config_types.h (and to config_link_equal() below if it is a link's setting, so that a reload sees
 * the change), document it in conf/sharedlinkd.yaml, and test it in tests/unit/test_config.c. A
 * check that involves other keys or links goes to config_check.c.
 */
#include "daemon/config.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "daemon/config_ctx.h"
#include "daemon/config_schema.h"
#include "svc/io.h"

/* ---------------------------------------------------------------------------------------------
 * API */

/* The reader's error is the config's: the same fields, copied out. */
static void error_copy(struct config_error *dst, const struct conf_error *src)
{
        _Static_assert(sizeof(dst->message) == sizeof(src->message), "config_error message");
        dst->line = src->line;
        dst->column = src->column;
        memcpy(dst->message, src->message, sizeof(dst->message));
}

int config_parse(const char *text, size_t len, const char *filename, struct config **ret_config,
                 struct config_error *ret_error)
{
        struct ctx *c;
        uint32_t root = CONF_NONE;
        int r;

        /* The context holds about 100 KiB of bookkeeping (config_ctx.h): heap, not stack. */
        c = calloc(1, sizeof(*c));
        if (!c) {
                if (ret_error) {
                        memset(ret_error, 0, sizeof(*ret_error));
                        snprintf(ret_error->message, sizeof(ret_error->message),
                                 "%s: out of memory", filename ? filename : "<config>");
                }
                return -ENOMEM;
        }
        r = conf_init(&c->conf, filename, text, len, CONFIG_INPUT_MAX);
        if (r < 0)
                goto out;
        c->cfg = calloc(1, sizeof(*c->cfg));
        if (!c->cfg) {
                r = cfg_fail_nomem(c);
                goto out;
        }
        r = conf_tree_build(&c->conf, &root);
        if (r == 0)
                r = cfg_parse_root(c, root);
        if (r == 0) {
                *ret_config = c->cfg;
                c->cfg = NULL;
        }
out:
        if (r < 0 && ret_error)
                error_copy(ret_error, &c->conf.err);
        config_free(c->cfg);
        conf_free(&c->conf);
        free(c);
        return r;
}

int config_load_file(const char *path, struct config **ret_config, struct config_error *ret_error)
{
        char *text;
        size_t len;
        int r = io_read_file(path, CONFIG_INPUT_MAX, &text, &len);

        if (r < 0) {
                if (ret_error) {
                        memset(ret_error, 0, sizeof(*ret_error));
                        /* io_read_file() stops one byte past the limit: that is all we know. */
                        if (r == -EFBIG)
                                snprintf(ret_error->message, sizeof(ret_error->message),
                                         "%s: too large (%u bytes, at most %u)", path,
                                         CONFIG_INPUT_MAX + 1, CONFIG_INPUT_MAX);
                        else
                                snprintf(ret_error->message, sizeof(ret_error->message),
                                         "%s: %s", path, strerror(-r));
                }
                return r;
        }
        r = config_parse(text, len, path, ret_config, ret_error);
        free(text);
        return r;
}

struct config *config_free(struct config *config)
{
        if (!config)
                return NULL;
        for (unsigned i = 0; i < config->n_links; i++) {
                struct config_sharedlink *sl = &config->links[i].sl;

                for (unsigned j = 0; j < sl->n_peers; j++) {
                        free(sl->peers[j].outbound);
                        free(sl->peers[j].inbound);
                }
        }
        free(config);
        return NULL;
}

static bool vars_equal(const struct config_var *a, unsigned na, const struct config_var *b,
                       unsigned nb)
{
        if (na != nb)
                return false;
        for (unsigned i = 0; i < na; i++)
                if (a[i].type != b[i].type || strcmp(a[i].name, b[i].name) != 0)
                        return false;
        return true;
}

static bool peer_equal(const struct config_peer *a, const struct config_peer *b)
{
        return a->address == b->address && a->period_ms == b->period_ms &&
               a->refresh_ms == b->refresh_ms && a->min_interval_ms == b->min_interval_ms &&
               a->stale_ms == b->stale_ms && a->max_frame == b->max_frame &&
               a->compression == b->compression && a->on_change == b->on_change &&
               vars_equal(a->outbound, a->n_outbound, b->outbound, b->n_outbound) &&
               vars_equal(a->inbound, a->n_inbound, b->inbound, b->n_inbound) &&
               a->dialect == b->dialect && a->role == b->role && a->declare == b->declare &&
               a->outbound_learn == b->outbound_learn && a->inbound_learn == b->inbound_learn &&
               a->learn_max == b->learn_max;
}

static bool version_equal(const struct config_circe_version *a,
                          const struct config_circe_version *b)
{
        return strcmp(a->text, b->text) == 0;   /* the numbers follow from the text */
}

static bool emulated_equal(const struct config_emulated_device *a,
                           const struct config_emulated_device *b)
{
        return a->address == b->address && a->capabilities == b->capabilities &&
               a->roles == b->roles && a->signal == b->signal &&
               a->has_battery == b->has_battery && (!a->has_battery || a->battery == b->battery) &&
               a->membership == b->membership;
}

static bool circe_equal(const struct config_circe *a, const struct config_circe *b)
{
        if (a->role != b->role || a->checksum != b->checksum ||
            !version_equal(&a->expect_version, &b->expect_version) ||
            a->login_timeout_ms != b->login_timeout_ms ||
            a->idle_timeout_ms != b->idle_timeout_ms || !version_equal(&a->version, &b->version) ||
            a->status != b->status || a->has_address != b->has_address ||
            (a->has_address && a->address != b->address) || a->keepalive_ms != b->keepalive_ms ||
            a->n_emulate != b->n_emulate)
                return false;
        for (unsigned i = 0; i < a->n_emulate; i++)
                if (!emulated_equal(&a->emulate[i], &b->emulate[i]))
                        return false;
        return true;
}

static bool sharedlink_equal(const struct config_sharedlink *a, const struct config_sharedlink *b)
{
        if (a->address != b->address || a->n_peers != b->n_peers || a->crlf != b->crlf)
                return false;
        for (unsigned i = 0; i < a->n_peers; i++)
                if (!peer_equal(&a->peers[i], &b->peers[i]))
                        return false;
        return true;
}

bool config_link_equal(const struct config_link *a, const struct config_link *b)
{
        if (strcmp(a->name, b->name) != 0 || a->protocol != b->protocol ||
            a->transport != b->transport || a->n_devices != b->n_devices)
                return false;
        for (unsigned i = 0; i < a->n_devices; i++)
                if (strcmp(a->devices[i], b->devices[i]) != 0)
                        return false;
        if (a->serial.baud != b->serial.baud || a->serial.parity != b->serial.parity ||
            a->serial.data_bits != b->serial.data_bits ||
            a->serial.stop_bits != b->serial.stop_bits ||
            a->serial.flow_control != b->serial.flow_control)
                return false;
        /* The text is the address as written; equal text means an equal address. */
        if (strcmp(a->local.text, b->local.text) != 0 || a->has_remote != b->has_remote ||
            strcmp(a->remote.text, b->remote.text) != 0)
                return false;
        if (strcmp(a->replay_file, b->replay_file) != 0 || a->replay_speed != b->replay_speed ||
            a->replay_loop != b->replay_loop)
                return false;
        if (a->protocol == CONFIG_PROTOCOL_SHAREDLINK)
                return sharedlink_equal(&a->sl, &b->sl);
        return circe_equal(&a->circe, &b->circe);
}

const struct config_link *config_link_find(const struct config *config, const char *name)
{
        for (unsigned i = 0; i < config->n_links; i++)
                if (strcmp(config->links[i].name, name) == 0)
                        return &config->links[i];
        return NULL;
}

