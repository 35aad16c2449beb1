/*
 * The configuration's checks that need more than one key (config_ctx.h lists the module's
 * files).
 */
#ifndef SHAREDLINK_DAEMON_CONFIG_CHECK_H
#define SHAREDLINK_DAEMON_CONFIG_CHECK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/config_ctx.h"

/* Pronto4 peer P's lists each fit one frame of max_frame; OUT_NODE/IN_NODE: where to point. */
int cfg_check_pronto4_frames(struct ctx *c, const struct config_peer *p, bool crlf,
                             const struct conf_node *out_node, const struct conf_node *in_node);
/* Across links, after all are read: device paths, reserved names, the control socket path. */
int cfg_check_devices(struct ctx *c);
int cfg_check_reserved_names(struct ctx *c);
int cfg_check_socket_path(struct ctx *c);

#endif
