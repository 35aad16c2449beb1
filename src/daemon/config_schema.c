/*
 * The config module's top level and links (config_schema.h; config_ctx.h lists the module's
 * files): their key tables, where each link key applies (protocol, role, transport), and what
 * each key sets.
 */
#include "daemon/config_schema.h"

#include <stdlib.h>
#include <string.h>

#include "daemon/config_check.h"
#include "daemon/config_names.h"
#include "daemon/config_peer.h"
#include "daemon/config_value.h"

/* ---------------------------------------------------------------------------------------------
 * Links */

enum {
        LK_NAME, LK_PROTOCOL, LK_TRANSPORT, LK_ROLE, LK_DEVICE, LK_DEVICES, LK_BAUD, LK_PARITY,
        LK_DATA_BITS, LK_STOP_BITS, LK_FLOW_CONTROL, LK_LOCAL, LK_REMOTE, LK_ADDRESS, LK_PEERS,
        LK_CHECKSUM, LK_EXPECT_VERSION, LK_LOGIN_TIMEOUT_MS, LK_IDLE_TIMEOUT_MS, LK_VERSION,
        LK_STATUS, LK_KEEPALIVE_MS, LK_EMULATE, LK_CRLF, LK_FILE, LK_SPEED, LK_LOOP, LK_COUNT
};

/* Where a link key applies: protocol/role bits and transport bits. */
enum {
        SCOPE_SL = 1 << 0,
        SCOPE_CONTROLLER = 1 << 1,
        SCOPE_MEDIATOR = 1 << 2,
        SCOPE_CIRCE = SCOPE_CONTROLLER | SCOPE_MEDIATOR,
        SCOPE_ANY_PROTOCOL = SCOPE_SL | SCOPE_CIRCE,
        SCOPE_SERIAL = 1 << 3,
        SCOPE_UDP = 1 << 4,
        SCOPE_PTY = 1 << 5,
        SCOPE_REPLAY = 1 << 6,
        SCOPE_TTY = SCOPE_SERIAL | SCOPE_PTY,
        /* A replay link takes (and ignores) the keys of the transport it was recorded on, so a
         * field configuration is replayed by changing only transport and adding file. */
        SCOPE_WIRE = SCOPE_TTY | SCOPE_UDP | SCOPE_REPLAY,
        SCOPE_ANY_TRANSPORT = SCOPE_WIRE,
        SCOPE_ANY = SCOPE_ANY_PROTOCOL | SCOPE_ANY_TRANSPORT,
};

static const struct link_key {
        const char *name;
        unsigned scope;
} link_keys[LK_COUNT] = {
        [LK_NAME] = { "name", SCOPE_ANY },
        [LK_PROTOCOL] = { "protocol", SCOPE_ANY },
        [LK_TRANSPORT] = { "transport", SCOPE_ANY },
        [LK_ROLE] = { "role", SCOPE_CIRCE | SCOPE_ANY_TRANSPORT },
        [LK_DEVICE] = { "device", SCOPE_ANY_PROTOCOL | SCOPE_TTY | SCOPE_REPLAY },
        [LK_DEVICES] = { "devices", SCOPE_ANY_PROTOCOL | SCOPE_SERIAL | SCOPE_REPLAY },
        [LK_BAUD] = { "baud", SCOPE_ANY_PROTOCOL | SCOPE_TTY | SCOPE_REPLAY },
        [LK_PARITY] = { "parity", SCOPE_ANY_PROTOCOL | SCOPE_TTY | SCOPE_REPLAY },
        [LK_DATA_BITS] = { "data_bits", SCOPE_ANY_PROTOCOL | SCOPE_TTY | SCOPE_REPLAY },
        [LK_STOP_BITS] = { "stop_bits", SCOPE_ANY_PROTOCOL | SCOPE_TTY | SCOPE_REPLAY },
        [LK_FLOW_CONTROL] = { "flow_control", SCOPE_ANY_PROTOCOL | SCOPE_TTY | SCOPE_REPLAY },
        [LK_LOCAL] = { "local", SCOPE_ANY_PROTOCOL | SCOPE_UDP | SCOPE_REPLAY },
        [LK_REMOTE] = { "remote", SCOPE_ANY_PROTOCOL | SCOPE_UDP | SCOPE_REPLAY },
        [LK_ADDRESS] = { "address", SCOPE_SL | SCOPE_MEDIATOR | SCOPE_ANY_TRANSPORT },
        [LK_PEERS] = { "peers", SCOPE_SL | SCOPE_ANY_TRANSPORT },
        [LK_CHECKSUM] = { "checksum", SCOPE_CIRCE | SCOPE_ANY_TRANSPORT },
        [LK_EXPECT_VERSION] = { "expect_version", SCOPE_CONTROLLER | SCOPE_ANY_TRANSPORT },
        [LK_LOGIN_TIMEOUT_MS] = { "login_timeout_ms", SCOPE_CONTROLLER | SCOPE_ANY_TRANSPORT },
        [LK_IDLE_TIMEOUT_MS] = { "idle_timeout_ms", SCOPE_CONTROLLER | SCOPE_ANY_TRANSPORT },
        [LK_VERSION] = { "version", SCOPE_MEDIATOR | SCOPE_ANY_TRANSPORT },
        [LK_STATUS] = { "status", SCOPE_MEDIATOR | SCOPE_ANY_TRANSPORT },
        [LK_KEEPALIVE_MS] = { "keepalive_ms", SCOPE_MEDIATOR | SCOPE_ANY_TRANSPORT },
        [LK_EMULATE] = { "emulate", SCOPE_MEDIATOR | SCOPE_ANY_TRANSPORT },
        [LK_CRLF] = { "crlf", SCOPE_SL | SCOPE_UDP | SCOPE_REPLAY },
        [LK_FILE] = { "file", SCOPE_ANY_PROTOCOL | SCOPE_REPLAY },
        [LK_SPEED] = { "speed", SCOPE_ANY_PROTOCOL | SCOPE_REPLAY },
        [LK_LOOP] = { "loop", SCOPE_ANY_PROTOCOL | SCOPE_REPLAY },
};

static unsigned link_scope(const struct config_link *l)
{
        unsigned s;

        if (l->protocol == CONFIG_PROTOCOL_SHAREDLINK)
                s = SCOPE_SL;
        else
                s = l->circe.role == CONFIG_ROLE_CONTROLLER ? SCOPE_CONTROLLER : SCOPE_MEDIATOR;
        switch (l->transport) {
        case CONFIG_TRANSPORT_SERIAL:
                return s | SCOPE_SERIAL;
        case CONFIG_TRANSPORT_UDP:
                return s | SCOPE_UDP;
        case CONFIG_TRANSPORT_PTY:
                return s | SCOPE_PTY;
        case CONFIG_TRANSPORT_REPLAY:
                return s | SCOPE_REPLAY;
        }
        return s;
}

/* Every key present must apply to this protocol, role and transport; checked in file order. */
static int link_check_scope(struct ctx *c, const struct conf_node *map, const struct config_link *l)
{
        unsigned scope = link_scope(l);

        for (const struct conf_node *k = cfg_child(c, map->first); k;
             k = cfg_next(c, cfg_next(c, k))) {
                const struct link_key *lk = &link_keys[0];

                /* cfg_map_read() has accepted every key, so each is in the table. */
                while (!cfg_scalar_is(k, lk->name))
                        lk++;
                if ((lk->scope & scope & SCOPE_ANY_PROTOCOL) == 0) {
                        if (l->protocol == CONFIG_PROTOCOL_CIRCE && (lk->scope & SCOPE_CIRCE))
                                return cfg_fail(c, k, "key %s is not valid for role %s",
                                                cfg_quote_node(c, k),
                                                config_role_name(l->circe.role));
                        return cfg_fail(c, k, "key %s is not valid for protocol %s",
                                        cfg_quote_node(c, k), config_protocol_name(l->protocol));
                }
                if ((lk->scope & scope & SCOPE_ANY_TRANSPORT) == 0)
                        return cfg_fail(c, k, "key %s is not valid for transport %s",
                                        cfg_quote_node(c, k), config_transport_name(l->transport));
        }
        return 0;
}

static int parse_devices(struct ctx *c, const struct conf_node *const *keys,
                         const struct conf_node *const *vals, const struct conf_node *map,
                         struct config_link *l, unsigned link_index)
{
        const struct conf_node **nodes = c->device_nodes[link_index];
        int r;

        if (vals[LK_DEVICE] && vals[LK_DEVICES])
                return cfg_fail(c, keys[LK_DEVICES],
                                "keys \"device\" and \"devices\" are exclusive");
        if (vals[LK_DEVICE]) {
                nodes[0] = vals[LK_DEVICE];
                l->n_devices = 1;
                return cfg_get_path(c, "device", vals[LK_DEVICE], l->devices[0],
                                    sizeof(l->devices[0]));
        }
        if (!vals[LK_DEVICES])
                return cfg_fail(c, map, l->transport == CONFIG_TRANSPORT_PTY
                                ? "missing key \"device\" in link"
                                : "missing key \"device\" (or \"devices\") in link");
        r = cfg_need_kind(c, "devices", vals[LK_DEVICES], CONF_NODE_SEQUENCE);
        if (r < 0)
                return r;
        if (vals[LK_DEVICES]->count == 0)
                return cfg_fail(c, vals[LK_DEVICES], "devices: at least one device is needed");
        for (const struct conf_node *item = cfg_child(c, vals[LK_DEVICES]->first); item;
             item = cfg_next(c, item)) {
                if (l->n_devices >= CONFIG_DEVICES_MAX)
                        return cfg_fail(c, item, "too many devices (at most %u)",
                                        CONFIG_DEVICES_MAX);
                nodes[l->n_devices] = item;
                r = cfg_get_path(c, "devices", item, l->devices[l->n_devices],
                                 sizeof(l->devices[0]));
                if (r < 0)
                        return r;
                l->n_devices++;
        }
        return 0;
}

static int parse_serial(struct ctx *c, const struct conf_node *const *vals, struct config_serial *s)
{
        uint32_t v;
        int e, r;

        if (vals[LK_BAUD] && (r = cfg_get_uint(c, "baud", vals[LK_BAUD], CONFIG_BAUD_MIN,
                                               CONFIG_BAUD_MAX, &s->baud)) < 0)
                return r;
        if (vals[LK_PARITY]) {
                r = cfg_get_enum(c, "parity", vals[LK_PARITY], &cfg_parities, &e);
                if (r < 0)
                        return r;
                s->parity = (enum config_parity)e;
        }
        if (vals[LK_DATA_BITS]) {
                r = cfg_get_uint(c, "data_bits", vals[LK_DATA_BITS], 7, 8, &v);
                if (r < 0)
                        return r;
                s->data_bits = (uint8_t)v;
        }
        if (vals[LK_STOP_BITS]) {
                r = cfg_get_uint(c, "stop_bits", vals[LK_STOP_BITS], 1, 2, &v);
                if (r < 0)
                        return r;
                s->stop_bits = (uint8_t)v;
        }
        if (vals[LK_FLOW_CONTROL]) {
                r = cfg_get_enum(c, "flow_control", vals[LK_FLOW_CONTROL], &cfg_flows, &e);
                if (r < 0)
                        return r;
                s->flow_control = (enum config_flow)e;
        }
        return 0;
}

/*
 * crlf (udp, and a replay: it may be of udp) defaults to on when a peer is pronto4: the public C++ adapter aborts on a
 * datagram without "]\r\n". A byte stream always ends frames with CR LF, so the one-frame checks
 * of pronto4 peers count it on every transport, and on udp unless crlf: false says otherwise.
 */
/*
 * A key of a SharedLink link written under one of its peers (crlf, remote, ...) is indentation
 * gone wrong, not an unknown key: say where it belongs. "address" is a key of both.
 */
static int check_peer_keys(struct ctx *c, const struct conf_node *peers)
{
        if (peers->kind != CONF_NODE_SEQUENCE)
                return 0;       /* cfg_parse_peers() says what is wrong with it */
        for (const struct conf_node *p = cfg_child(c, peers->first); p; p = cfg_next(c, p)) {
                if (p->kind != CONF_NODE_MAPPING)
                        continue;
                for (const struct conf_node *k = cfg_child(c, p->first); k;
                     k = cfg_next(c, cfg_next(c, k))) {
                        if (k->kind != CONF_NODE_SCALAR || cfg_scalar_is(k, "address"))
                                continue;
                        for (size_t i = 0; i < LK_COUNT; i++)
                                if ((link_keys[i].scope & SCOPE_SL) &&
                                    cfg_scalar_is(k, link_keys[i].name))
                                        return cfg_fail(c, k, "key %s is a link key: it goes in "
                                                        "the link, beside \"peers\", not under "
                                                        "a peer", cfg_quote_node(c, k));
                }
        }
        return 0;
}

static int parse_link_sharedlink(struct ctx *c, const struct conf_node *const *vals,
                                 const struct conf_node *map, enum config_transport transport,
                                 struct config_sharedlink *sl)
{
        bool crlf_set = false, datagrams;
        int r;

        if (!vals[LK_ADDRESS])
                return cfg_fail(c, map, "missing key \"address\" in link");
        r = cfg_get_sl_address(c, "address", vals[LK_ADDRESS], &sl->address);
        if (r < 0)
                return r;
        if (vals[LK_CRLF]) {
                r = cfg_get_bool(c, "crlf", vals[LK_CRLF], &sl->crlf);
                if (r < 0)
                        return r;
                crlf_set = true;
        }
        if (!vals[LK_PEERS])
                return cfg_fail(c, map, "missing key \"peers\" in link");
        /* crlf matters where the engine takes datagrams: udp, and a replay, whose recording
         * may be of a udp link (the replay then sends as the field link did). */
        datagrams = transport == CONFIG_TRANSPORT_UDP || transport == CONFIG_TRANSPORT_REPLAY;
        r = check_peer_keys(c, vals[LK_PEERS]);
        if (r < 0)
                return r;
        r = cfg_parse_peers(c, vals[LK_PEERS], !datagrams || !crlf_set || sl->crlf, sl);
        if (r < 0 || crlf_set || !datagrams)
                return r;
        for (unsigned i = 0; i < sl->n_peers; i++)
                sl->crlf |= sl->peers[i].dialect == CONFIG_DIALECT_PRONTO4;
        return 0;
}

static int parse_link_circe(struct ctx *c, const struct conf_node *const *vals,
                            struct config_circe *ci)
{
        uint32_t v;
        int r;

        ci->checksum = true;
        ci->login_timeout_ms = CONFIG_LOGIN_TIMEOUT_MS_DEFAULT;
        ci->idle_timeout_ms = CONFIG_IDLE_TIMEOUT_MS_DEFAULT;
        ci->keepalive_ms = CONFIG_KEEPALIVE_MS_DEFAULT;
        ci->expect_version = (struct config_circe_version){ "0.2", 0, 2, 0 };
        ci->version = (struct config_circe_version){ "0.2.3", 0, 2, 3 };
        if (vals[LK_CHECKSUM] && (r = cfg_get_bool(c, "checksum", vals[LK_CHECKSUM],
                                                   &ci->checksum)) < 0)
                return r;
        if (vals[LK_EXPECT_VERSION] &&
            (r = cfg_get_circe_version(c, "expect_version", vals[LK_EXPECT_VERSION], 2,
                                       &ci->expect_version)) < 0)
                return r;
        if (vals[LK_LOGIN_TIMEOUT_MS] &&
            (r = cfg_get_uint(c, "login_timeout_ms", vals[LK_LOGIN_TIMEOUT_MS],
                              CONFIG_TIMEOUT_MS_MIN, CONFIG_TIMEOUT_MS_MAX,
                              &ci->login_timeout_ms)) < 0)
                return r;
        if (vals[LK_IDLE_TIMEOUT_MS] &&
            (r = cfg_get_uint(c, "idle_timeout_ms", vals[LK_IDLE_TIMEOUT_MS], CONFIG_TIMEOUT_MS_MIN,
                              CONFIG_TIMEOUT_MS_MAX, &ci->idle_timeout_ms)) < 0)
                return r;
        if (vals[LK_VERSION] && (r = cfg_get_circe_version(c, "version", vals[LK_VERSION], 3,
                                                           &ci->version)) < 0)
                return r;
        if (vals[LK_STATUS]) {
                r = cfg_get_uint(c, "status", vals[LK_STATUS], 0, CIRCE_STATUS_MAX, &v);
                if (r < 0)
                        return r;
                ci->status = (uint16_t)v;
        }
        if (vals[LK_ADDRESS]) {
                r = cfg_get_circe_address(c, "address", vals[LK_ADDRESS], &ci->address);
                if (r < 0)
                        return r;
                ci->has_address = true;
        }
        if (vals[LK_KEEPALIVE_MS] &&
            (r = cfg_get_uint(c, "keepalive_ms", vals[LK_KEEPALIVE_MS], CONFIG_KEEPALIVE_MS_MIN,
                              CONFIG_KEEPALIVE_MS_MAX, &ci->keepalive_ms)) < 0)
                return r;
        if (vals[LK_EMULATE] && (r = cfg_parse_emulate(c, vals[LK_EMULATE], ci)) < 0)
                return r;
        return 0;
}

static int parse_link_name(struct ctx *c, const struct conf_node *map,
                           const struct conf_node *const *vals, unsigned index)
{
        struct config_link *l = &c->cfg->links[index];
        int r;

        if (!vals[LK_NAME])
                return cfg_fail(c, map, "missing key \"name\" in link");
        r = cfg_get_ident(c, "link name", vals[LK_NAME], l->name, sizeof(l->name));
        if (r < 0)
                return r;
        c->link_name_nodes[index] = vals[LK_NAME];
        for (unsigned i = 0; i < index; i++)
                if (strcmp(c->cfg->links[i].name, l->name) == 0)
                        return cfg_fail(c, vals[LK_NAME], "duplicate link name %s (first at %u:%u)",
                                        cfg_quote_node(c, vals[LK_NAME]),
                                        c->link_name_nodes[i]->line,
                                        c->link_name_nodes[i]->column);
        return 0;
}

static int get_required_enum(struct ctx *c, const struct conf_node *map, const char *key,
                             const struct conf_node *n, const struct conf_enum *e, int *ret)
{
        if (!n)
                return cfg_fail(c, map, "missing key \"%s\" in link", key);
        return cfg_get_enum(c, key, n, e, ret);
}

/* Protocol, transport and role: what every other key of the link is checked against. */
static int parse_link_kind(struct ctx *c, const struct conf_node *map,
                           const struct conf_node *const *vals, struct config_link *l)
{
        int e, r;

        r = get_required_enum(c, map, "protocol", vals[LK_PROTOCOL], &cfg_protocols, &e);
        if (r < 0)
                return r;
        l->protocol = (enum config_protocol)e;
        r = get_required_enum(c, map, "transport", vals[LK_TRANSPORT], &cfg_transports, &e);
        if (r < 0)
                return r;
        l->transport = (enum config_transport)e;
        l->circe.role = CONFIG_ROLE_NONE;
        if (l->protocol == CONFIG_PROTOCOL_CIRCE) {
                r = get_required_enum(c, map, "role", vals[LK_ROLE], &cfg_roles, &e);
                if (r < 0)
                        return r;
                l->circe.role = (enum config_role)e;
        }
        return link_check_scope(c, map, l);
}

/* "max" (0: no pacing), or a plain decimal number (digits, at most one point) in range. */
static int parse_speed(struct ctx *c, const struct conf_node *n, double *ret)
{
        char text[CONFIG_REPLAY_SPEED_TEXT_MAX];
        bool point = false, digit = false;
        double v;
        int r;

        if (cfg_scalar_is(n, "max")) {
                *ret = 0;
                return 0;
        }
        r = cfg_get_string(c, "speed", n, text, sizeof(text));
        if (r < 0)
                return r;
        for (const char *p = text; *p; p++) {
                if (*p == '.' && !point) {
                        point = true;
                        continue;
                }
                if (*p < '0' || *p > '9')
                        return cfg_fail(c, n, "speed: expected max or a number like 1.0, 0.5 or "
                                        "10, got %s", cfg_quote_node(c, n));
                digit = true;
        }
        v = digit ? strtod(text, NULL) : 0;
        if (!digit || v < CONFIG_REPLAY_SPEED_MIN || v > CONFIG_REPLAY_SPEED_MAX)
                return cfg_fail(c, n, "speed: %s is out of range (%g..%g, or max)",
                                cfg_quote_node(c, n), CONFIG_REPLAY_SPEED_MIN,
                                CONFIG_REPLAY_SPEED_MAX);
        *ret = v;
        return 0;
}

/* file, speed (default 1.0), loop (default false); the recorded transport's keys are ignored. */
static int parse_replay(struct ctx *c, const struct conf_node *map,
                        const struct conf_node *const *vals, struct config_link *l)
{
        int r;

        if (!vals[LK_FILE])
                return cfg_fail(c, map, "missing key \"file\" in link (the recording to replay)");
        r = cfg_get_path(c, "file", vals[LK_FILE], l->replay_file, sizeof(l->replay_file));
        if (r < 0)
                return r;
        l->replay_speed = 1.0;
        if (vals[LK_SPEED] && (r = parse_speed(c, vals[LK_SPEED], &l->replay_speed)) < 0)
                return r;
        if (vals[LK_LOOP] && (r = cfg_get_bool(c, "loop", vals[LK_LOOP], &l->replay_loop)) < 0)
                return r;
        return 0;
}

static int parse_link_transport(struct ctx *c, const struct conf_node *map,
                                const struct conf_node *const *keys,
                                const struct conf_node *const *vals, unsigned index)
{
        struct config_link *l = &c->cfg->links[index];
        int r;

        l->serial = (struct config_serial){ CONFIG_BAUD_DEFAULT, CONFIG_PARITY_NONE, 8, 1,
                                            CONFIG_FLOW_NONE };
        if (l->transport == CONFIG_TRANSPORT_REPLAY)
                return parse_replay(c, map, vals, l);
        if (l->transport != CONFIG_TRANSPORT_UDP) {
                r = parse_devices(c, keys, vals, map, l, index);
                if (r < 0)
                        return r;
                return parse_serial(c, vals, &l->serial);
        }
        if (!vals[LK_LOCAL])
                return cfg_fail(c, map, "missing key \"local\" in link");
        r = cfg_get_endpoint(c, "local", vals[LK_LOCAL], 0, &l->local);
        if (r < 0)
                return r;
        if (vals[LK_REMOTE]) {
                r = cfg_get_endpoint(c, "remote", vals[LK_REMOTE], 1, &l->remote);
                if (r < 0)
                        return r;
                l->has_remote = true;
        }
        return 0;
}

static int parse_link(struct ctx *c, const struct conf_node *map, unsigned index)
{
        const struct conf_node *keys[LK_COUNT], *vals[LK_COUNT];
        struct config_link *l = &c->cfg->links[index];
        int r;

        r = cfg_need_kind(c, "link", map, CONF_NODE_MAPPING);
        if (r < 0)
                return r;
        r = cfg_map_read(c, map, "in link", CFG_KEYS(link_keys), keys, vals);
        if (r < 0)
                return r;
        r = parse_link_name(c, map, vals, index);
        if (r < 0)
                return r;
        r = parse_link_kind(c, map, vals, l);
        if (r < 0)
                return r;
        r = parse_link_transport(c, map, keys, vals, index);
        if (r < 0)
                return r;
        if (l->protocol == CONFIG_PROTOCOL_SHAREDLINK)
                return parse_link_sharedlink(c, vals, map, l->transport, &l->sl);
        return parse_link_circe(c, vals, &l->circe);
}

static int parse_links(struct ctx *c, const struct conf_node *n)
{
        unsigned i = 0;
        int r = cfg_need_kind(c, "links", n, CONF_NODE_SEQUENCE);

        if (r < 0)
                return r;
        if (n->count == 0)
                return cfg_fail(c, n, "links: at least one link is needed");
        for (const struct conf_node *item = cfg_child(c, n->first); item;
             item = cfg_next(c, item), i++) {
                if (i >= CONFIG_LINKS_MAX)
                        return cfg_fail(c, item, "too many links (at most %u)", CONFIG_LINKS_MAX);
                c->cfg->n_links = i + 1;        /* config_free() then sees this link's lists */
                r = parse_link(c, item, i);
                if (r < 0)
                        return r;
        }
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Top level */

enum { TK_INSTANCE, TK_RUNTIME_DIR, TK_GROUP, TK_LINKS, TK_COUNT };
static const char *const top_keys[TK_COUNT] = {
        [TK_INSTANCE] = "instance", [TK_RUNTIME_DIR] = "runtime_dir", [TK_GROUP] = "group",
        [TK_LINKS] = "links",
};

int cfg_parse_root(struct ctx *c, uint32_t root_index)
{
        const struct conf_node *keys[TK_COUNT], *vals[TK_COUNT];
        const struct conf_node *root = cfg_child(c, root_index);
        struct config *cfg = c->cfg;
        int r;

        if (!root || cfg_is_null(root))
                return cfg_fail_at(c, 1, 1, "empty configuration");
        if (root->kind != CONF_NODE_MAPPING)
                return cfg_fail(c, root, "the configuration must be a mapping, not %s",
                                cfg_describe(c, root));
        r = cfg_map_read(c, root, "at top level", CFG_KEYS(top_keys), keys, vals);
        if (r < 0)
                return r;

        strcpy(cfg->instance, CONFIG_INSTANCE_DEFAULT);
        strcpy(cfg->runtime_dir, CONFIG_RUNTIME_DIR_DEFAULT);
        if (vals[TK_INSTANCE] && (r = cfg_get_ident(c, "instance", vals[TK_INSTANCE], cfg->instance,
                                                    sizeof(cfg->instance))) < 0)
                return r;
        if (vals[TK_RUNTIME_DIR]) {
                r = cfg_get_path(c, "runtime_dir", vals[TK_RUNTIME_DIR], cfg->runtime_dir,
                                 sizeof(cfg->runtime_dir));
                if (r < 0)
                        return r;
                c->runtime_dir_node = vals[TK_RUNTIME_DIR];
                cfg->runtime_dir_set = true;
        }
        if (vals[TK_GROUP] && (r = cfg_get_group(c, vals[TK_GROUP], cfg->group,
                                                 sizeof(cfg->group))) < 0)
                return r;
        if (vals[TK_GROUP]) {
                cfg->group_line = vals[TK_GROUP]->line;
                cfg->group_column = vals[TK_GROUP]->column;
        }
        if (!vals[TK_LINKS])
                return cfg_fail(c, root, "missing key \"links\"");
        r = parse_links(c, vals[TK_LINKS]);
        if (r < 0)
                return r;
        r = cfg_check_devices(c);
        if (r < 0)
                return r;
        r = cfg_check_reserved_names(c);
        if (r < 0)
                return r;
        return cfg_check_socket_path(c);
}
