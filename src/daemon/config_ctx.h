/*
 * The parse context the files of the config module share, and nothing outside it sees (prefix
 * cfg_): one parse's reader, the config being filled, what later checks need, and the module's
 * short names for the reader's calls. The files, each depending only on those below it:
 *
 * svc/conf.h       the toolkit's YAML reader: libyaml events -> a tree of struct conf_node
 *                  with positions; errors and quoting; mappings against key tables; the generic
 *                  scalars (strings, integers, booleans, enums, paths)
 * config_names.c   the spellings of the enums (also public, through config.h)
 * config_value.c   sharedlinkd's own scalars: names, groups, addresses, versions, endpoints
 * config_schema.c  the top level and the links: their key tables and what each key sets
 * config_peer.c    the mappings inside a link: variables, SharedLink peers, CIRCE emulated devices
 * config_check.c   checks that need more than one key: pronto4 frame sizes, devices, names,
 *                  the control socket path
 * config.c         the public entry points (config.h)
 *
 *   config.c -> config_schema -> config_peer -> config_check, config_value, config_names
 *   and all of them -> config_ctx.h -> config_types.h (the model: limits, enums, structs)
 */
#ifndef SHAREDLINK_DAEMON_CONFIG_CTX_H
#define SHAREDLINK_DAEMON_CONFIG_CTX_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/config_types.h"
#include "svc/conf.h"

struct seen_var {
        const char *name;
        const struct conf_node *node;
};

/* The set of the names seen so far (config_peer.c): open addressing with linear probing, twice
 * as many slots as names at most, a power of two, so that a probe ends soon. */
#define CFG_NAME_SET_SIZE       (2u * CONFIG_VARS_MAX)
_Static_assert((CFG_NAME_SET_SIZE & (CFG_NAME_SET_SIZE - 1u)) == 0, "a power of two");

/* One parse: the reader (first, see below), the config being filled, what later checks need. */
struct ctx {
        struct conf conf;
        struct config *cfg;
        struct seen_var vars[CONFIG_VARS_MAX];
        uint32_t name_set[CFG_NAME_SET_SIZE];   /* 0: empty, else a position in vars + 1 */
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

#endif
