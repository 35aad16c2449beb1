/*
 * Control requests (control.h) the core answers itself (ping, stats, record) and the routing of
 * the others, "<command word> LINK ...", to the engine of LINK (link_ops.command).
 */
#ifndef SHAREDLINK_DAEMON_DAEMON_REQUEST_H
#define SHAREDLINK_DAEMON_DAEMON_REQUEST_H

#include "daemon/control.h"

/* The control socket's handler (control_request_fn); arg is the struct daemon. */
void daemon_on_request(struct control_request *req, int argc, char **argv, void *arg);

#endif
