/*
 * CIRCE control commands (control.h): "circe LINK <operation> ..." words -> a typed command,
 * every argument validated with a clear message before anything is sent. Pure: no I/O.
 *
 *   alert ADDR
 *   network-setup ADDR join|leave ROLES
 *   device-setup ASSIGN [DEST|-] [CAPABILITIES|-]
 *   sync-clocks
 *   visualize ADDR[,ADDR...] [current=N] [next=N] [start-timer] [primary=MS] [secondary=MS]
 *             [faults=N] [refusals=N] [eliminated=0|1] [placement=N]
 *   emulate action ADDR [keys=N] [sensor-time=MS]
 * each optionally ending with wait=MS (proto/control.h: wait up to MS for the link instead of ERR
 * ENOTCONN), which the core takes off before the engine parses the rest (link_command_wait()).
 * Addresses are six hex digits (lowercase accepted, FFFFFF refused); numbers are decimal.
 */
#ifndef SHAREDLINK_DAEMON_LINK_CIRCE_COMMAND_H
#define SHAREDLINK_DAEMON_LINK_CIRCE_COMMAND_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "proto/circe.h"

#define LINK_CIRCE_CMD_ERR_MAX  160u    /* room for an error message */

enum link_circe_cmd_kind {
        LINK_CIRCE_CMD_ALERT,
        LINK_CIRCE_CMD_NETWORK_SETUP,
        LINK_CIRCE_CMD_DEVICE_SETUP,
        LINK_CIRCE_CMD_SYNC_CLOCKS,
        LINK_CIRCE_CMD_VISUALIZE,
        LINK_CIRCE_CMD_EMULATE_ACTION,  /* mediator role only */
};

struct link_circe_cmd {
        enum link_circe_cmd_kind kind;
        struct circe_msg msg;           /* controller operations: the packet to send */
        uint32_t address;               /* emulate action: the device */
        long keys;                      /* emulate action: -1 when not given */
        long sensor_time_ms;            /* emulate action: -1 when not given */
};

/*
 * Parses argv[0..argc) ("circe", LINK, operation, arguments...). Returns 0 and fills *ret, or
 * -EINVAL with a one-line reason in err (NUL-terminated, at most errsz bytes).
 */
int link_circe_command_parse(int argc, char *const *argv, struct link_circe_cmd *ret, char *err,
                             size_t errsz);

/* The operation word of a kind ("alert", ..., "emulate action"). */
const char *link_circe_command_name(enum link_circe_cmd_kind kind);

/* Whether a kind is an operation a controller sends (every kind but emulate action). */
bool link_circe_command_for_controller(enum link_circe_cmd_kind kind);

#endif
