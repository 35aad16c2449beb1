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

/* Pronto4 peer P: max_frame within what the clients read, every list entry typed, its lists
 * each fitting one frame of max_frame, and room for what it may learn; OUT_NODE, IN_NODE,
 * MAX_NODE (the lists, max_frame; NULL when absent): where to point. */
int cfg_check_pronto4_frames(struct ctx *c, const struct config_peer *p, bool crlf,
                             const struct conf_node *out_node, const struct conf_node *in_node,
                             const struct conf_node *max_node);
/* A variable list whose entry is the bare word learn: meant as KEY: learn, said so. */
int cfg_check_list_not_learn(struct ctx *c, const char *key, const struct conf_node *list);
/* Across links, after all are read: device paths, reserved names, the control socket path. */
int cfg_check_devices(struct ctx *c);
int cfg_check_reserved_names(struct ctx *c);
int cfg_check_socket_path(struct ctx *c);

#endif
