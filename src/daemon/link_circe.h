/*
 * CIRCE link engine (DESIGN.md 2.7-2.8, PROTOCOLS.md 2): a controller of a real mediator, or the
 * built-in mediator emulator, on one channel.
 *
 * The engine is glue: the channel's bytes go through the CIRCE decoder into the session of the
 * link's role (link_circe_controller.h, link_circe_mediator.h), and the session's actions come
 * back as packets on the channel, values and events in the shm table, counters, log lines and
 * control-socket replies (the core decodes the commands: proto/request.h).
 *
 * Variables (link L):
 *   L.state                        connecting | connected | version-mismatch | unconfigured |
 *                                  disconnected
 *   L.mediator.version             controller: as received; emulator: as configured
 *   L.mediator.status              decimal
 *   L.mediator.address             emulator only: its own address ("" until it has one)
 *   L.device.<ADDR>.<field>        controller: made at run time as devices appear;
 *                                  emulator: declared for the configured devices (run time for
 *                                  an address assigned by Device Setup)
 * Events: link-state, device-online, device-offline, action, clock-sync, log.
 */
#ifndef SHAREDLINK_DAEMON_LINK_CIRCE_H
#define SHAREDLINK_DAEMON_LINK_CIRCE_H

#include "daemon/link.h"

/* Requests that may wait for the link at once ("... wait=MS"), per link. */
#define LINK_CIRCE_PENDING_MAX  LINK_WAITQ_MAX

/* The CIRCE engine: both roles, chosen by the link's `role`. */
extern const struct link_ops link_circe_ops;

#endif
