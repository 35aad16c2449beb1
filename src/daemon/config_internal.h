/*
 * What the files of the config module share, and nothing outside it sees (prefix cfg_).
 *
 * config_yaml.c    libyaml events -> a tree of struct ynode with positions; errors and quoting;
 *                  map_read() (a mapping's keys against a key table)
 * config_value.c   one scalar -> one value: strings, integers, booleans, enums, names, paths,
 *                  addresses, versions, endpoints
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

#define YNONE                   UINT32_MAX
#define QUOTE_MAX               40u     /* bytes of user text echoed in a message */
#define QUOTE_BUF               (QUOTE_MAX * 4u + 8u)
#define QUOTE_SLOTS             2u

/* ---------------------------------------------------------------------------------------------
 * Node tree built from libyaml events */

enum ynode_kind {
        YNODE_SCALAR,
        YNODE_SEQUENCE,
        YNODE_MAPPING,
};

struct ynode {
        enum ynode_kind kind;
        bool plain;                     /* scalar written as a plain (unquoted, non-block) scalar */
        unsigned line, column;          /* 1-based */
        char *text;                     /* scalar bytes + NUL (may contain NULs from escapes) */
        size_t len;
        uint32_t first, last, next;     /* children; a mapping's are key, value, key, value... */
        uint32_t count;
};

struct seen_var {
        const char *name;
        const struct ynode *node;
};

/* One parse: the input, the tree, the config being filled, and what later checks need. */
struct ctx {
        const char *filename;
        const char *text;
        size_t text_len;
        struct config_error *err;
        struct ynode *nodes;
        uint32_t n_nodes, cap_nodes;
        struct config *cfg;
        struct seen_var vars[CONFIG_VARS_MAX];
        const struct ynode *link_name_nodes[CONFIG_LINKS_MAX];
        const struct ynode *device_nodes[CONFIG_LINKS_MAX][CONFIG_DEVICES_MAX];
        const struct ynode *runtime_dir_node;
        char quote[QUOTE_SLOTS][QUOTE_BUF];
        unsigned quote_next;
};

/* ---------------------------------------------------------------------------------------------
 * config_yaml.c: errors (the first one wins) and the tree */

/* Set the error "FILE:LINE:COL: text" (LINE 0: "FILE: text"); return -EINVAL. */
int cfg_fail_at(struct ctx *c, unsigned line, unsigned column, const char *fmt, ...)
        __attribute__((format(printf, 4, 5)));
/* The same at node N's position. */
int cfg_fail(struct ctx *c, const struct ynode *n, const char *fmt, ...)
        __attribute__((format(printf, 3, 4)));
/* "out of memory"; returns -ENOMEM. */
int cfg_fail_nomem(struct ctx *c);

/* User text for a message, quoted and escaped (one of QUOTE_SLOTS buffers in C, reused). */
const char *cfg_quote(struct ctx *c, const char *s, size_t len);
const char *cfg_quote_node(struct ctx *c, const struct ynode *n);
/* A number as written, unquoted, cut short. */
const char *cfg_number_text(struct ctx *c, const char *s, size_t len);
/* "a list", "a mapping" or the quoted scalar, for "expected X, got Y". */
const char *cfg_describe(struct ctx *c, const struct ynode *n);

/* Builds the tree of c->text; *ret_root is YNONE for an empty stream. */
int cfg_tree_build(struct ctx *c, uint32_t *ret_root);
void cfg_nodes_free(struct ctx *c);

/* Node I (NULL for YNONE), and the node after N among its parent's children. */
const struct ynode *cfg_child(const struct ctx *c, uint32_t i);
const struct ynode *cfg_next(const struct ctx *c, const struct ynode *n);
/* N is a scalar holding exactly S; N is a plain empty, "~" or "null" scalar. */
bool cfg_scalar_is(const struct ynode *n, const char *s);
bool cfg_is_null(const struct ynode *n);

/*
 * Checks mapping MAP's keys against a key table (all scalars, no merge key, no unknown key, no
 * duplicate) and files each value under its key's index in vals[] (NULL when absent), keys[]
 * likewise. WHAT ends the unknown-key message ("in link"). The table is N_KNOWN entries of
 * STRIDE bytes, each starting with its name (a const char *): an array of names, or of structs
 * whose first member is the name; CFG_KEYS(table) passes the last three arguments.
 */
int cfg_map_read(struct ctx *c, const struct ynode *map, const char *what, const void *known,
                 size_t n_known, size_t stride, const struct ynode **keys,
                 const struct ynode **vals);
#define CFG_KEYS(table)         (table), sizeof(table) / sizeof((table)[0]), sizeof((table)[0])
/* N is a list or a mapping (KIND); a null N is reported as a missing value of WHAT. */
int cfg_need_kind(struct ctx *c, const char *what, const struct ynode *n, enum ynode_kind kind);

/* ---------------------------------------------------------------------------------------------
 * config_value.c: one scalar N, the value of KEY (which starts every message), into *ret/out */

struct cfg_enum_name {
        const char *name;
        int value;
};

/* The spellings of one enum, as the file writes them. */
struct cfg_enum {
        const struct cfg_enum_name *names;
        size_t count;
};

extern const struct cfg_enum cfg_protocols, cfg_transports, cfg_roles, cfg_parities, cfg_flows,
                             cfg_dialects, cfg_var_types;

int cfg_get_string(struct ctx *c, const char *key, const struct ynode *n, char *out,
                   size_t size);
/* Plain decimal integer in [MIN, MAX], no leading zeros. */
int cfg_get_uint(struct ctx *c, const char *key, const struct ynode *n, uint32_t min,
                 uint32_t max, uint32_t *ret);
int cfg_get_bool(struct ctx *c, const char *key, const struct ynode *n, bool *ret);
int cfg_get_enum(struct ctx *c, const char *key, const struct ynode *n, const struct cfg_enum *e,
                 int *ret);
/* Letters, digits, '_', '-' (and '.' when DOT): names of instances, links and variables. */
bool cfg_is_name_char(char ch, bool dot);
int cfg_get_ident(struct ctx *c, const char *key, const struct ynode *n, char *out,
                  size_t size);
int cfg_get_group(struct ctx *c, const struct ynode *n, char *out, size_t size);
int cfg_get_path(struct ctx *c, const char *key, const struct ynode *n, char *out,
                 size_t size);
int cfg_get_sl_address(struct ctx *c, const char *key, const struct ynode *n, char *ret);
int cfg_get_circe_address(struct ctx *c, const char *key, const struct ynode *n,
                          uint32_t *ret);
/* PARTS (2 or 3) dot-separated numbers. */
int cfg_get_circe_version(struct ctx *c, const char *key, const struct ynode *n,
                          unsigned parts, struct config_circe_version *ret);
/* "IPV4:PORT", "[IPV6]:PORT" or "localhost:PORT", port in [PORT_MIN, 65535]. */
int cfg_get_endpoint(struct ctx *c, const char *key, const struct ynode *n, uint32_t port_min,
                     struct config_endpoint *ret);

/* ---------------------------------------------------------------------------------------------
 * config_schema.c and config_peer.c: the mappings */

/* The whole document (node ROOT_INDEX) into c->cfg, checks included. */
int cfg_parse_root(struct ctx *c, uint32_t root_index);
/* A link's "peers" list into SL (whose address is already set); CRLF: frames end in CR LF. */
int cfg_parse_peers(struct ctx *c, const struct ynode *n, bool crlf,
                    struct config_sharedlink *sl);
/* A mediator link's "emulate" list into CI. */
int cfg_parse_emulate(struct ctx *c, const struct ynode *n, struct config_circe *ci);

/* ---------------------------------------------------------------------------------------------
 * config_check.c */

/* Pronto4 peer P's lists each fit one frame of max_frame; OUT_NODE/IN_NODE: where to point. */
int cfg_check_pronto4_frames(struct ctx *c, const struct config_peer *p, bool crlf,
                             const struct ynode *out_node, const struct ynode *in_node);
/* Across links, after all are read: device paths, reserved names, the control socket path. */
int cfg_check_devices(struct ctx *c);
int cfg_check_reserved_names(struct ctx *c);
int cfg_check_socket_path(struct ctx *c);

#endif
