/*
 * sharedlinkd's own scalar values in its configuration (config_ctx.h lists the module's files);
 * N is the value of KEY, which starts every message.
 */
#ifndef SHAREDLINK_DAEMON_CONFIG_VALUE_H
#define SHAREDLINK_DAEMON_CONFIG_VALUE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/config_ctx.h"

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

#endif
