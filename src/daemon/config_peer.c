/*
 * The config module's mappings inside a link (config_peer.h; config_ctx.h lists the module's
 * files): variables, SharedLink peers (with the Pronto4 dialect's keys) and CIRCE emulated
 * devices. Each mapping has its key table (an enum of indices and their names) next to the
 * function that reads it.
 */
#include "daemon/config_peer.h"

#include <errno.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "daemon/config_check.h"
#include "daemon/config_names.h"
#include "daemon/config_value.h"
#include "proto/sharedlink.h"
#include "shm/layout.h"

/* ---------------------------------------------------------------------------------------------
 * Variables */

static int var_name_check(struct ctx *c, const struct conf_node *n, const char *name)
{
        for (size_t i = 0; name[i]; i++)
                if (!slp_name_byte(name[i]))
                        return cfg_fail(c, n, "variable name %s: invalid character %s (allowed: "
                                        "letters, digits, _ . -)", cfg_quote_node(c, n),
                                        cfg_quote(c, name + i, 1));
        return 0;
}

/*
 * Names are unique per instance. Each name is looked up in the set of those seen before it
 * (c->name_set, by hash), then added: one probe per name, so that a configuration at the cap
 * (CONFIG_VARS_MAX) costs as many probes as names, not a comparison per pair of names. The set
 * never fills (twice the cap), so a probe always meets an empty slot.
 */
static int var_register(struct ctx *c, const struct conf_node *n, const char *name)
{
        const uint32_t mask = CFG_NAME_SET_SIZE - 1u;
        uint32_t i = shm_layout_name_hash(name) & mask;

        for (; c->name_set[i] != 0; i = (i + 1u) & mask) {
                const struct seen_var *first = &c->vars[c->name_set[i] - 1u];

                if (strcmp(first->name, name) == 0)
                        return cfg_fail(c, n, "duplicate variable name %s (first at %u:%u)",
                                        cfg_quote_node(c, n), first->node->line,
                                        first->node->column);
        }
        if (c->cfg->n_vars >= CONFIG_VARS_MAX)
                return cfg_fail(c, n, "too many variables (at most %u per instance)",
                                CONFIG_VARS_MAX);
        c->vars[c->cfg->n_vars].name = name;
        c->vars[c->cfg->n_vars].node = n;
        c->name_set[i] = ++c->cfg->n_vars;
        return 0;
}

enum { VK_NAME, VK_TYPE, VK_COUNT };
static const char *const var_keys[VK_COUNT] = { [VK_NAME] = "name", [VK_TYPE] = "type" };

static int parse_var(struct ctx *c, const struct conf_node *n, struct config_var *ret)
{
        const struct conf_node *keys[VK_COUNT], *vals[VK_COUNT];
        const struct conf_node *name_node = n;
        int type = CONFIG_VAR_STRING;
        int r;

        if (n->kind == CONF_NODE_MAPPING) {
                r = cfg_map_read(c, n, "in variable", CFG_KEYS(var_keys), keys, vals);
                if (r < 0)
                        return r;
                if (!vals[VK_NAME])
                        return cfg_fail(c, n, "missing key \"name\" in variable");
                name_node = vals[VK_NAME];
                if (vals[VK_TYPE]) {
                        r = cfg_get_enum(c, "type", vals[VK_TYPE], &cfg_var_types, &type);
                        if (r < 0)
                                return r;
                }
        } else if (n->kind != CONF_NODE_SCALAR) {
                return cfg_fail(c, n, "variable: expected a name or {name, type}, got a list");
        }
        r = cfg_get_string(c, "variable name", name_node, ret->name, sizeof(ret->name));
        if (r < 0)
                return r;
        r = var_name_check(c, name_node, ret->name);
        if (r < 0)
                return r;
        ret->type = (enum config_var_type)type;
        return var_register(c, name_node, ret->name);
}

static int parse_var_list(struct ctx *c, const char *key, const struct conf_node *n,
                          struct config_var **ret_vars, unsigned *ret_count)
{
        struct config_var *vars;
        unsigned i = 0;
        int r = cfg_need_kind(c, key, n, CONF_NODE_SEQUENCE);

        if (r < 0)
                return r;
        if (n->count > CONFIG_LIST_MAX)
                return cfg_fail(c, n, "%s: too many variables (%u, at most %u per list)", key,
                                n->count, CONFIG_LIST_MAX);
        if (n->count == 0)
                return 0;
        vars = calloc(n->count, sizeof(*vars));
        if (!vars)
                return cfg_fail_nomem(c);
        /* Owned by the config from here on, so config_free() releases it on any later error. */
        *ret_vars = vars;
        for (const struct conf_node *item = cfg_child(c, n->first); item;
             item = cfg_next(c, item)) {
                r = parse_var(c, item, &vars[i]);
                if (r < 0)
                        return r;
                *ret_count = ++i;
        }
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * SharedLink peers */

enum {
        PK_ADDRESS, PK_PERIOD_MS, PK_REFRESH_MS, PK_COMPRESSION, PK_ON_CHANGE, PK_MIN_INTERVAL_MS,
        PK_STALE_MS, PK_MAX_FRAME, PK_OUTBOUND, PK_INBOUND, PK_DIALECT, PK_DECLARE, PK_LEARN_MAX,
        PK_ROLE, PK_COUNT
};

/*
 * How each peer key is read. A plain integer or boolean key is its row alone (parse_peer() reads
 * them in this order, which decides which of two bad keys is reported); the others are read by
 * their own code below.
 */
enum peer_key_kind { PEER_KEY_OWN, PEER_KEY_UINT, PEER_KEY_BOOL };

static const struct peer_key {
        const char *name;
        enum peer_key_kind kind;
        uint32_t min, max, def;         /* UINT: the range; UINT, BOOL: the default */
        size_t offset;                  /* of the field in struct config_peer */
} peer_keys[PK_COUNT] = {
#define PEER_UINT(name, min, max, def, field) \
        { name, PEER_KEY_UINT, min, max, def, offsetof(struct config_peer, field) }
#define PEER_BOOL(name, def, field) \
        { name, PEER_KEY_BOOL, 0, 1, def, offsetof(struct config_peer, field) }
        [PK_ADDRESS] = { "address", PEER_KEY_OWN, 0, 0, 0, 0 },
        [PK_PERIOD_MS] = PEER_UINT("period_ms", 0, CONFIG_PERIOD_MS_MAX, CONFIG_PERIOD_MS_DEFAULT,
                                   period_ms),
        [PK_REFRESH_MS] = PEER_UINT("refresh_ms", CONFIG_REFRESH_MS_MIN, CONFIG_REFRESH_MS_MAX,
                                    CONFIG_REFRESH_MS_DEFAULT, refresh_ms),
        [PK_COMPRESSION] = PEER_BOOL("compression", true, compression),
        [PK_ON_CHANGE] = PEER_BOOL("on_change", false, on_change),
        [PK_MIN_INTERVAL_MS] = PEER_UINT("min_interval_ms", 0, CONFIG_MIN_INTERVAL_MS_MAX,
                                         CONFIG_MIN_INTERVAL_MS_DEFAULT, min_interval_ms),
        /* 0 here; parse_peer() makes the default CONFIG_STALE_REFRESHES x refresh_ms */
        [PK_STALE_MS] = PEER_UINT("stale_ms", 0, CONFIG_STALE_MS_MAX, 0, stale_ms),
        [PK_MAX_FRAME] = PEER_UINT("max_frame", CONFIG_MAX_FRAME_MIN, CONFIG_MAX_FRAME_MAX,
                                   CONFIG_MAX_FRAME_DEFAULT, max_frame),
        [PK_OUTBOUND] = { "outbound", PEER_KEY_OWN, 0, 0, 0, 0 },
        [PK_INBOUND] = { "inbound", PEER_KEY_OWN, 0, 0, 0, 0 },
        [PK_DIALECT] = { "dialect", PEER_KEY_OWN, 0, 0, 0, 0 },
        [PK_DECLARE] = { "declare", PEER_KEY_OWN, 0, 0, 0, 0 },
        [PK_LEARN_MAX] = { "learn_max", PEER_KEY_OWN, 0, 0, 0, 0 },
        [PK_ROLE] = { "role", PEER_KEY_OWN, 0, 0, 0, 0 },
#undef PEER_UINT
#undef PEER_BOOL
};

/* An outbound or inbound list, or the word "learn" (the list comes from the peer). */
static int parse_peer_list(struct ctx *c, const char *key, const struct conf_node *n,
                           struct config_var **ret_vars, unsigned *ret_count, bool *ret_learn)
{
        int r;

        if (n->kind == CONF_NODE_SCALAR && cfg_scalar_is(n, "learn")) {
                *ret_learn = true;
                return 0;
        }
        r = cfg_check_list_not_learn(c, key, n);
        return r < 0 ? r : parse_var_list(c, key, n, ret_vars, ret_count);
}

/* The keys that only a pronto4 peer may have: refused, by name, on a bulletin peer. */
static int check_bulletin_peer(struct ctx *c, const struct conf_node *const *keys,
                               const struct conf_node *const *vals, const struct config_peer *p)
{
        static const unsigned only_pronto4[] = { PK_DECLARE, PK_LEARN_MAX, PK_ROLE };

        for (size_t i = 0; i < sizeof(only_pronto4) / sizeof(only_pronto4[0]); i++)
                if (keys[only_pronto4[i]])
                        return cfg_fail(c, keys[only_pronto4[i]], "key %s needs dialect: pronto4",
                                        cfg_quote_node(c, keys[only_pronto4[i]]));
        if (p->outbound_learn)
                return cfg_fail(c, vals[PK_OUTBOUND], "outbound: learn needs dialect: pronto4 (a "
                                "bulletin peer never declares its lists)");
        if (p->inbound_learn)
                return cfg_fail(c, vals[PK_INBOUND], "inbound: learn needs dialect: pronto4 (a "
                                "bulletin peer never declares its lists)");
        return 0;
}

/*
 * Decision (docs/pronto4.md §1): we are the host toward a pronto4 peer when this link is node A,
 * the vehicle when it is node B (the nodes of every Pronto4); on any other address, the host
 * when our lists are configured and nothing is learned, else the vehicle.
 */
static enum config_p4_role p4_role_default(char own_address, bool listed, bool learned)
{
        if (own_address == 'A')
                return CONFIG_P4_HOST;
        if (own_address == 'B')
                return CONFIG_P4_VEHICLE;
        return listed && !learned ? CONFIG_P4_HOST : CONFIG_P4_VEHICLE;
}

/*
 * dialect, role, declare, learn_max, after the lists. Decision: the host declares its configured
 * lists by default; the vehicle (and a peer that learns) answers declarations and sends none of
 * its own unless `declare: true` says so.
 */
static int parse_peer_dialect(struct ctx *c, const struct conf_node *const *keys,
                              const struct conf_node *const *vals, struct config_peer *p, bool crlf,
                              char own_address)
{
        bool learned = p->outbound_learn || p->inbound_learn;
        bool listed = p->n_outbound + p->n_inbound > 0;
        int e, r;

        p->dialect = CONFIG_DIALECT_BULLETIN;
        if (vals[PK_DIALECT]) {
                r = cfg_get_enum(c, "dialect", vals[PK_DIALECT], &cfg_dialects, &e);
                if (r < 0)
                        return r;
                p->dialect = (enum config_dialect)e;
        }
        if (p->dialect == CONFIG_DIALECT_BULLETIN)
                return check_bulletin_peer(c, keys, vals, p);

        p->role = p4_role_default(own_address, listed, learned);
        if (vals[PK_ROLE]) {
                r = cfg_get_enum(c, "role", vals[PK_ROLE], &cfg_p4_roles, &e);
                if (r < 0)
                        return r;
                p->role = (enum config_p4_role)e;
        }
        p->declare = p->role == CONFIG_P4_HOST && listed && !learned;
        if (vals[PK_DECLARE] && (r = cfg_get_bool(c, "declare", vals[PK_DECLARE], &p->declare)) < 0)
                return r;
        if (p->declare && learned)
                return cfg_fail(c, vals[PK_DECLARE], "declare: true with a learned list (the side "
                                "that learns answers declarations, it does not send them)");
        if (p->declare && !listed)
                return cfg_fail(c, vals[PK_DECLARE], "declare: true, but the peer has no outbound "
                                "or inbound variables to declare");
        p->learn_max = learned ? CONFIG_LEARN_MAX_DEFAULT : 0;
        if (vals[PK_LEARN_MAX]) {
                if (!learned)
                        return cfg_fail(c, keys[PK_LEARN_MAX], "learn_max needs outbound: learn or "
                                        "inbound: learn");
                r = cfg_get_uint(c, "learn_max", vals[PK_LEARN_MAX], CONFIG_LEARN_MAX_MIN,
                                 CONFIG_LEARN_MAX_MAX, &p->learn_max);
                if (r < 0)
                        return r;
        }
        return cfg_check_pronto4_frames(c, p, crlf, vals[PK_OUTBOUND], vals[PK_INBOUND],
                                        vals[PK_MAX_FRAME]);
}

/* The rows PEER_KEY_UINT and PEER_KEY_BOOL of peer_keys: their defaults, then the values given. */
static int parse_peer_plain(struct ctx *c, const struct conf_node *const *vals,
                            struct config_peer *p)
{
        for (size_t i = 0; i < PK_COUNT; i++) {
                const struct peer_key *k = &peer_keys[i];
                char *field = (char *)p + k->offset;
                int r = 0;

                if (k->kind == PEER_KEY_UINT) {
                        *(uint32_t *)(void *)field = k->def;
                        if (vals[i])
                                r = cfg_get_uint(c, k->name, vals[i], k->min, k->max,
                                                 (uint32_t *)(void *)field);
                } else if (k->kind == PEER_KEY_BOOL) {
                        *(bool *)(void *)field = k->def != 0;
                        if (vals[i])
                                r = cfg_get_bool(c, k->name, vals[i], (bool *)(void *)field);
                }
                if (r < 0)
                        return r;
        }
        return 0;
}

static int parse_peer(struct ctx *c, const struct conf_node *n, char own_address, bool crlf,
                      struct config_peer *p, const struct conf_node **ret_address_node)
{
        const struct conf_node *keys[PK_COUNT], *vals[PK_COUNT];
        int r = cfg_need_kind(c, "peer", n, CONF_NODE_MAPPING);

        if (r < 0)
                return r;
        r = cfg_map_read(c, n, "in peer", CFG_KEYS(peer_keys), keys, vals);
        if (r < 0)
                return r;
        if (!vals[PK_ADDRESS])
                return cfg_fail(c, n, "missing key \"address\" in peer");
        r = cfg_get_sl_address(c, "address", vals[PK_ADDRESS], &p->address);
        if (r < 0)
                return r;
        *ret_address_node = vals[PK_ADDRESS];
        if (p->address == own_address)
                return cfg_fail(c, vals[PK_ADDRESS], "peer address %c is the link's own address",
                                p->address);
        r = parse_peer_plain(c, vals, p);
        if (r < 0)
                return r;
        if (!vals[PK_STALE_MS])
                p->stale_ms = CONFIG_STALE_REFRESHES * p->refresh_ms;
        if (vals[PK_OUTBOUND] && (r = parse_peer_list(c, "outbound", vals[PK_OUTBOUND],
                                                      &p->outbound, &p->n_outbound,
                                                      &p->outbound_learn)) < 0)
                return r;
        if (vals[PK_INBOUND] && (r = parse_peer_list(c, "inbound", vals[PK_INBOUND],
                                                     &p->inbound, &p->n_inbound,
                                                     &p->inbound_learn)) < 0)
                return r;
        return parse_peer_dialect(c, keys, vals, p, crlf, own_address);
}

int cfg_parse_peers(struct ctx *c, const struct conf_node *n, bool crlf,
                    struct config_sharedlink *sl)
{
        const struct conf_node *address_nodes[CONFIG_PEERS_MAX];
        int r = cfg_need_kind(c, "peers", n, CONF_NODE_SEQUENCE);

        if (r < 0)
                return r;
        if (n->count == 0)
                return cfg_fail(c, n, "peers: at least one peer is needed");
        for (const struct conf_node *item = cfg_child(c, n->first); item;
             item = cfg_next(c, item)) {
                struct config_peer *p;

                if (sl->n_peers >= CONFIG_PEERS_MAX)
                        return cfg_fail(c, item, "too many peers (at most %u)", CONFIG_PEERS_MAX);
                /* Counted before parsing: config_free() then sees its variable lists. */
                p = &sl->peers[sl->n_peers++];
                r = parse_peer(c, item, sl->address, crlf, p, &address_nodes[sl->n_peers - 1]);
                if (r < 0)
                        return r;
                for (unsigned i = 0; i + 1 < sl->n_peers; i++)
                        if (sl->peers[i].address == p->address)
                                return cfg_fail(c, address_nodes[sl->n_peers - 1],
                                                "duplicate peer address %c (first at %u:%u)",
                                                p->address, address_nodes[i]->line,
                                                address_nodes[i]->column);
        }
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * CIRCE emulated devices */

enum { EK_ADDRESS, EK_CAPABILITIES, EK_SIGNAL, EK_BATTERY, EK_ROLES, EK_MEMBERSHIP, EK_COUNT };
static const char *const emulate_keys[EK_COUNT] = {
        [EK_ADDRESS] = "address", [EK_CAPABILITIES] = "capabilities", [EK_SIGNAL] = "signal",
        [EK_BATTERY] = "battery", [EK_ROLES] = "roles", [EK_MEMBERSHIP] = "membership",
};

static int parse_emulated(struct ctx *c, const struct conf_node *n,
                          struct config_emulated_device *d,
                          const struct conf_node **ret_address_node)
{
        const struct conf_node *keys[EK_COUNT], *vals[EK_COUNT];
        uint32_t v;
        int r = cfg_need_kind(c, "emulated device", n, CONF_NODE_MAPPING);

        if (r < 0)
                return r;
        r = cfg_map_read(c, n, "in emulated device", CFG_KEYS(emulate_keys), keys, vals);
        if (r < 0)
                return r;
        if (!vals[EK_ADDRESS])
                return cfg_fail(c, n, "missing key \"address\" in emulated device");
        r = cfg_get_circe_address(c, "address", vals[EK_ADDRESS], &d->address);
        if (r < 0)
                return r;
        *ret_address_node = vals[EK_ADDRESS];
        if (!vals[EK_CAPABILITIES])
                return cfg_fail(c, n, "missing key \"capabilities\" in emulated device");
        r = cfg_get_uint(c, "capabilities", vals[EK_CAPABILITIES], CONFIG_CIRCE_CAPABILITIES_MIN,
                         CIRCE_CAPABILITIES_MAX, &v);
        if (r < 0)
                return r;
        d->capabilities = (uint8_t)v;
        v = CONFIG_CIRCE_SIGNAL_DEFAULT;
        if (vals[EK_SIGNAL] &&
            (r = cfg_get_uint(c, "signal", vals[EK_SIGNAL], 0, CIRCE_LEVEL_MAX, &v)) < 0)
                return r;
        d->signal = (uint8_t)v;
        if (vals[EK_BATTERY]) {
                r = cfg_get_uint(c, "battery", vals[EK_BATTERY], 0, CIRCE_LEVEL_MAX, &v);
                if (r < 0)
                        return r;
                d->battery = (uint8_t)v;
                d->has_battery = true;
        }
        v = 0;
        if (vals[EK_ROLES] &&
            (r = cfg_get_uint(c, "roles", vals[EK_ROLES], 0, CIRCE_ROLES_MAX, &v)) < 0)
                return r;
        d->roles = (uint8_t)v;
        if (vals[EK_MEMBERSHIP] &&
            (r = cfg_get_bool(c, "membership", vals[EK_MEMBERSHIP], &d->membership)) < 0)
                return r;
        return 0;
}

int cfg_parse_emulate(struct ctx *c, const struct conf_node *n, struct config_circe *ci)
{
        const struct conf_node *address_nodes[CONFIG_EMULATE_MAX];
        int r = cfg_need_kind(c, "emulate", n, CONF_NODE_SEQUENCE);

        if (r < 0)
                return r;
        for (const struct conf_node *item = cfg_child(c, n->first); item;
             item = cfg_next(c, item)) {
                struct config_emulated_device *d;

                if (ci->n_emulate >= CONFIG_EMULATE_MAX)
                        return cfg_fail(c, item, "too many emulated devices (at most %u)",
                                        CONFIG_EMULATE_MAX);
                d = &ci->emulate[ci->n_emulate];
                r = parse_emulated(c, item, d, &address_nodes[ci->n_emulate]);
                if (r < 0)
                        return r;
                for (unsigned i = 0; i < ci->n_emulate; i++)
                        if (ci->emulate[i].address == d->address)
                                return cfg_fail(c, address_nodes[ci->n_emulate],
                                                "duplicate emulated device %06X (first at %u:%u)",
                                                d->address, address_nodes[i]->line,
                                                address_nodes[i]->column);
                ci->n_emulate++;
        }
        return 0;
}
