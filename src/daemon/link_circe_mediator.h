/*
 * CIRCE mediator emulator session (PROTOCOLS.md 2.4, DESIGN.md 2.8): plays a mediator and the
 * wireless devices of its configuration, so a controller (ours or one under test) can be run
 * without hardware.
 *
 * Pure state machine (link_circe_session.h). Behaviour:
 *   Login          -> Keep Alive (configured version, current status), then a Notify Status per
 *                     device at once and every second while logged in
 *   idle           -> Keep Alive when nothing was sent for keepalive_ms
 *   Logout         -> silent until the next Login
 *   Alert          -> the device's alert count goes up
 *   Network Setup  -> join: membership 1, the roles given, clock "requires sync" (027:1) until
 *                     synchronised; leave: membership 0, roles untouched (the spec: a leave must
 *                     not alter another network's roles)
 *   Device Setup   -> without capabilities: the mediator takes the address (an unconfigured
 *                     mediator becomes configured) and answers with a Keep Alive; with them: the
 *                     device at the destination (default 000000) takes address and capabilities
 *                     and reports a Notify Status at once
 *   Sync Clocks    -> every device restarts its sensor clock, reports one status without 027
 *                     at once, then 027:2 in its periodic statuses for 4 s
 *   Visualize      -> each destination that is an emulated display applies the fields given,
 *                     in the protocol's order (Start Timer: timer from 0, running; a Primary
 *                     Timer Value stops it)
 *   action()       -> Notify Action with the keys given and the sensor time given, or the
 *                     device's own clock when it is a time sensor or a timing key was pressed
 * A device at address 000000 is unconfigured: it sends no status until it gets an address.
 */
#ifndef SHAREDLINK_DAEMON_LINK_CIRCE_MEDIATOR_H
#define SHAREDLINK_DAEMON_LINK_CIRCE_MEDIATOR_H

#include <stdbool.h>
#include <stdint.h>

#include "daemon/config.h"
#include "daemon/link_circe_session.h"

/* Where an emulated device is in a clock synchronisation. */
enum link_circe_emu_sync {
        LINK_CIRCE_EMU_SYNC_NONE = 0,
        LINK_CIRCE_EMU_SYNC_SHOWING,    /* reports 027:2 until sync_until */
};

struct link_circe_mediator_stats {
        uint64_t logins, logouts, keep_alives, statuses, actions;
        uint64_t alerts, network_setups, device_setups, syncs, visualizes;
        uint64_t ignored;               /* operations before Login, unknown destinations ... */
        uint64_t unexpected_ops;        /* mediator operations received */
        uint64_t send_errors;
};

struct link_circe_mediator {
        const struct link_circe_hooks *hooks;
        void *arg;
        struct circe_version version;
        unsigned status;
        bool has_address;
        uint32_t address;
        uint32_t keepalive_ms;

        enum link_circe_state state;
        bool up, logged_in;
        uint64_t last_sent_ms;
        uint64_t next_status_ms;

        struct link_circe_device devices[CONFIG_EMULATE_MAX];
        uint64_t clock_zero_ms[CONFIG_EMULATE_MAX];     /* sensor clock origin */
        uint8_t sync[CONFIG_EMULATE_MAX];               /* enum link_circe_emu_sync */
        uint64_t sync_until_ms[CONFIG_EMULATE_MAX];
        unsigned n_devices;

        struct link_circe_mediator_stats stats;
};

/* Prepares the emulator from a link's CIRCE settings; sensor clocks start at now_ms. */
void link_circe_mediator_init(struct link_circe_mediator *m, const struct config_circe *cfg,
                              const struct link_circe_hooks *hooks, void *arg, uint64_t now_ms);

/* The port is open: wait for Login. */
void link_circe_mediator_up(struct link_circe_mediator *m, uint64_t now_ms);

/* The port closed: state disconnected, logged out. */
void link_circe_mediator_down(struct link_circe_mediator *m, uint64_t now_ms);

/* One decoded packet. Ignored while down. */
void link_circe_mediator_message(struct link_circe_mediator *m, uint64_t now_ms,
                                 const struct circe_msg *msg);

/* Sends what is due: Keep Alive when idle, the periodic statuses; ends 027:2 windows. */
void link_circe_mediator_tick(struct link_circe_mediator *m, uint64_t now_ms);

/* The earliest pending deadline, or LINK_CIRCE_NEVER. */
uint64_t link_circe_mediator_deadline(const struct link_circe_mediator *m);

/* Whether a controller is logged in (injected actions can go out). */
bool link_circe_mediator_ready(const struct link_circe_mediator *m);

/* The fields an emulated device publishes: the controller's, alerts, and the display fields
 * for a display. */
uint32_t link_circe_mediator_fields(const struct link_circe_device *d);

/* Index of the emulated device at addr, or -ENOENT. */
int link_circe_mediator_find(const struct link_circe_mediator *m, uint32_t addr);

/*
 * Injects a gate passage or a key press/release of device addr as a Notify Action. keys < 0:
 * none; sensor_time_ms < 0: the device's clock when it is a time sensor or one of its timing
 * keys (pass start/intermediate/finish, with the matching capability) is down, else none.
 * Returns 0, -ENOTCONN (no controller logged in), -ENOENT (no such device) or the send error.
 */
int link_circe_mediator_action(struct link_circe_mediator *m, uint64_t now_ms, uint32_t addr,
                               long keys, long sensor_time_ms);

#endif
