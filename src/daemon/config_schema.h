/*
 * The configuration's top level and links (config_ctx.h lists the module's files).
 */
#ifndef SHAREDLINK_DAEMON_CONFIG_SCHEMA_H
#define SHAREDLINK_DAEMON_CONFIG_SCHEMA_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/config_ctx.h"

/* The whole document (node ROOT_INDEX) into c->cfg, checks included. */
int cfg_parse_root(struct ctx *c, uint32_t root_index);

#endif
