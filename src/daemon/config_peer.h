/*
 * The mappings inside a link: SharedLink peers, CIRCE emulated devices (config_ctx.h lists
 * the module's files).
 */
#ifndef SHAREDLINK_DAEMON_CONFIG_PEER_H
#define SHAREDLINK_DAEMON_CONFIG_PEER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/config_ctx.h"

/* A link's "peers" list into SL (whose address is already set); CRLF: frames end in CR LF. */
int cfg_parse_peers(struct ctx *c, const struct conf_node *n, bool crlf,
                    struct config_sharedlink *sl);
/* A mediator link's "emulate" list into CI. */
int cfg_parse_emulate(struct ctx *c, const struct conf_node *n, struct config_circe *ci);

#endif
