/*
 * What the files of the config module share, and nothing outside it sees (prefix cfg_).
 *
 * svc/conf.h       the toolkit's YAML reader: libyaml events -> a tree of struct conf_node
 *                  with positions; errors and quoting; mappings against key tables; the generic
 *                  scalars (strings, integers, booleans, enums, paths)
 * config_value.c   sharedlinkd's own scalars: names, groups, addresses, versions, endpoints,
 *                  and the spellings of its enums
 * config_schema.c  the top level and the links: their key tables and what each key sets
 * config_peer.c    the mappings inside a link: variables, SharedLink peers, CIRCE emulated devices
 * config_check.c   checks that need more than one key: pronto4 frame sizes, devices, names,
 *                  the control socket path
 * config.c         the public entry points (config.h)
 */
#ifndef SHAREDLINK_DAEMON_CONFIG_INTERNAL_H
#define SHAREDLINK_DAEMON_CONFIG_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/config.h"
#include "svc/conf.h"

struct seen_var {
        const char *name;
        const struct conf_node *node;
};

/* One parse: the reader (first, see below), the config being filled, what later checks need. */
struct ctx {
        struct conf conf;
        struct config *cfg;
        struct seen_var vars[CONFIG_VARS_MAX];
        const struct conf_node *link_name_nodes[CONFIG_LINKS_MAX];
        const struct conf_node *device_nodes[CONFIG_LINKS_MAX][CONFIG_DEVICES_MAX];
        const struct conf_node *runtime_dir_node;
};

/* ---------------------------------------------------------------------------------------------
 * The reader (svc/conf.h) on this parse's context C: the module's own short names for it. */

#define cfg_fail_at(c, ...)             conf_fail_at(&(c)->conf, __VA_ARGS__)
#define cfg_fail(c, ...)                conf_fail(&(c)->conf, __VA_ARGS__)
#define cfg_fail_nomem(c)               conf_fail_nomem(&(c)->conf)
#define cfg_quote(c, s, len)            conf_quote(&(c)->conf, s, len)
#define cfg_quote_node(c, n)            conf_quote_node(&(c)->conf, n)
#define cfg_number_text(c, s, len)      conf_number_text(&(c)->conf, s, len)
#define cfg_describe(c, n)              conf_describe(&(c)->conf, n)
#define cfg_child(c, i)                 conf_child(&(c)->conf, i)
#define cfg_next(c, n)                  conf_next(&(c)->conf, n)
#define cfg_scalar_is(n, s)             conf_scalar_is(n, s)
#define cfg_is_null(n)                  conf_is_null(n)
#define cfg_map_read(c, ...)            conf_map_read(&(c)->conf, __VA_ARGS__)
#define CFG_KEYS(table)                 CONF_KEYS(table)
#define cfg_need_kind(c, ...)           conf_need_kind(&(c)->conf, __VA_ARGS__)
#define cfg_get_string(c, ...)          conf_get_string(&(c)->conf, __VA_ARGS__)
#define cfg_get_uint(c, ...)            conf_get_uint(&(c)->conf, __VA_ARGS__)
#define cfg_get_bool(c, ...)            conf_get_bool(&(c)->conf, __VA_ARGS__)
#define cfg_get_enum(c, ...)            conf_get_enum(&(c)->conf, __VA_ARGS__)
#define cfg_get_path(c, ...)            conf_get_path(&(c)->conf, __VA_ARGS__)

/* ---------------------------------------------------------------------------------------------
 * config_value.c: sharedlinkd's scalars; N is the value of KEY (which starts every message) */

extern const struct conf_enum cfg_protocols, cfg_transports, cfg_roles, cfg_parities, cfg_flows,
                             cfg_dialects, cfg_var_types;

/* Letters, digits, '_', '-' (and '.' when DOT): names of instances, links and variables. */
bool cfg_is_name_char(char ch, bool dot);
int cfg_get_ident(struct ctx *c, const char *key, const struct conf_node *n, char *out,
                  size_t size);
int cfg_get_group(struct ctx *c, const struct conf_node *n, char *out, size_t size);
int cfg_get_sl_address(struct ctx *c, const char *key, const struct conf_node *n, char *ret);
int cfg_get_circe_address(struct ctx *c, const char *key, const struct conf_node *n,
                          uint32_t *ret);
/* PARTS (2 or 3) dot-separated numbers. */
int cfg_get_circe_version(struct ctx *c, const char *key, const struct conf_node *n,
                          unsigned parts, struct config_circe_version *ret);
/* "IPV4:PORT", "[IPV6]:PORT" or "localhost:PORT", port in [PORT_MIN, 65535]. */
int cfg_get_endpoint(struct ctx *c, const char *key, const struct conf_node *n, uint32_t port_min,
                     struct config_endpoint *ret);

/* ---------------------------------------------------------------------------------------------
 * config_schema.c and config_peer.c: the mappings */

/* The whole document (node ROOT_INDEX) into c->cfg, checks included. */
int cfg_parse_root(struct ctx *c, uint32_t root_index);
/* A link's "peers" list into SL (whose address is already set); CRLF: frames end in CR LF. */
int cfg_parse_peers(struct ctx *c, const struct conf_node *n, bool crlf,
                    struct config_sharedlink *sl);
/* A mediator link's "emulate" list into CI. */
int cfg_parse_emulate(struct ctx *c, const struct conf_node *n, struct config_circe *ci);

/* ---------------------------------------------------------------------------------------------
 * config_check.c */

/* Pronto4 peer P's lists each fit one frame of max_frame; OUT_NODE/IN_NODE: where to point. */
int cfg_check_pronto4_frames(struct ctx *c, const struct config_peer *p, bool crlf,
                             const struct conf_node *out_node, const struct conf_node *in_node);
/* Across links, after all are read: device paths, reserved names, the control socket path. */
int cfg_check_devices(struct ctx *c);
int cfg_check_reserved_names(struct ctx *c);
int cfg_check_socket_path(struct ctx *c);

#endif
