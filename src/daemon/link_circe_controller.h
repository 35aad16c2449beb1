/*
 * CIRCE controller session (PROTOCOLS.md 2.4, DESIGN.md 2.8): the computer side of a mediator.
 *
 * Pure state machine (link_circe_session.h): the engine calls up() when the port opened,
 * down() when it closed, message() for every decoded packet, tick() when deadline() passed.
 *
 *   up()          -> Login, state connecting, login deadline armed
 *   Keep Alive    -> version check against expect_version (major.minor): a mismatch logs out,
 *                    fails the port (next device) and reports version-mismatch; otherwise state
 *                    connected, or unconfigured for mediator status 1
 *   no Keep Alive within login_timeout_ms, or no valid operation (Log excluded) for
 *   idle_timeout_ms -> Logout (best effort), fail the port, state disconnected
 *   Notify Status -> device online (event on the transition), its fields published; a
 *                    non-compliant one (capabilities 0, time sensor or display combined with
 *                    another capability, address 000000) is ignored and counted
 *   3 s without a status -> device offline (event)
 *   Notify Action -> always an event (device, keys, sensor_time), and the device's last keys /
 *                    sensor time
 *   Log           -> counted, handed to the log hook (never counts as the link being alive)
 */
#ifndef SHAREDLINK_DAEMON_LINK_CIRCE_CONTROLLER_H
#define SHAREDLINK_DAEMON_LINK_CIRCE_CONTROLLER_H

#include <stdbool.h>
#include <stdint.h>

#include "daemon/config.h"
#include "daemon/link_circe_session.h"

/* Where one device stands in a clock synchronisation. */
enum link_circe_sync_phase {
        LINK_CIRCE_SYNC_UNTRACKED = 0,  /* not online when the synchronisation started */
        LINK_CIRCE_SYNC_WAIT_DROP,      /* still showed 027:2 from an earlier one: wait for a
                                         * status without it first */
        LINK_CIRCE_SYNC_ARMED,          /* the next 027:2 is this synchronisation's */
        LINK_CIRCE_SYNC_DONE,           /* succeeded (reported) */
};

struct link_circe_controller_stats {
        uint64_t logins, logouts;
        uint64_t login_timeouts, idle_timeouts, mismatches;
        uint64_t keep_alives, statuses, actions, logs;
        uint64_t noncompliant, unexpected_ops, devices_full;
        uint64_t online_events, offline_events, action_events;
        uint64_t syncs, sync_succeeded, sync_timed_out;
};

struct link_circe_controller {
        const struct link_circe_hooks *hooks;
        void *arg;
        unsigned expect_major, expect_minor;
        uint32_t login_timeout_ms, idle_timeout_ms;

        enum link_circe_state state;
        bool up;                        /* port open */
        bool answered;                  /* a valid Keep Alive arrived since Login */
        uint64_t login_deadline, idle_deadline;

        bool has_mediator;              /* a Keep Alive was seen on this link */
        struct circe_version version;
        unsigned status;

        struct link_circe_device devices[LINK_CIRCE_DEVICES_MAX];
        uint64_t last_status_ms[LINK_CIRCE_DEVICES_MAX];
        unsigned n_devices;

        bool sync_active;
        uint64_t sync_deadline;
        unsigned sync_pending;          /* tracked devices not yet succeeded */
        uint8_t sync_phase[LINK_CIRCE_DEVICES_MAX];     /* enum link_circe_sync_phase */

        struct link_circe_controller_stats stats;
};

/* Prepares a session from a link's CIRCE settings; it starts disconnected. */
void link_circe_controller_init(struct link_circe_controller *c, const struct config_circe *cfg,
                                const struct link_circe_hooks *hooks, void *arg);

/* The port is open: sends Login. */
void link_circe_controller_up(struct link_circe_controller *c, uint64_t now_ms);

/* The port closed under us (not through the fail hook): state disconnected; a running clock
 * synchronisation ends with -ECONNRESET. */
void link_circe_controller_down(struct link_circe_controller *c, uint64_t now_ms);

/* One decoded packet. Ignored while down. */
void link_circe_controller_message(struct link_circe_controller *c, uint64_t now_ms,
                                   const struct circe_msg *m);

/* Handles every deadline that has passed (timeouts, offline devices, synchronisation end). */
void link_circe_controller_tick(struct link_circe_controller *c, uint64_t now_ms);

/* The earliest pending deadline, or LINK_CIRCE_NEVER. */
uint64_t link_circe_controller_deadline(const struct link_circe_controller *c);

/* Whether operations may be sent: logged in, connected or unconfigured. */
bool link_circe_controller_ready(const struct link_circe_controller *c);

/*
 * Sends Synchronize Clocks and follows every online device for LINK_CIRCE_SYNC_WINDOW_MS:
 * sync_result() for each (succeeded as soon as it reports 027:2 after the request, timed-out at
 * the end), then sync_done(0) (at once when no device is online). Returns 0, -ENOTCONN (not
 * ready), -EBUSY (one is running) or the send error.
 */
int link_circe_controller_sync_start(struct link_circe_controller *c, uint64_t now_ms);

/* Logout, best effort (the engine calls it before closing the link for good). */
void link_circe_controller_logout(struct link_circe_controller *c);

#endif
