/*
 * CIRCE link sessions: what the controller (link_circe_controller.h) and the mediator emulator
 * (link_circe_mediator.h) share. A session is pure logic: it is fed decoded messages and the
 * time, and acts through the hooks below (send a packet, drop the port, publish a device, raise
 * an event, count). It never touches a file descriptor, a timer or the shm table itself, so the
 * fuzzer (tests/fuzz/fuzz_circe_session.c) can drive it with any packet stream and any clock.
 *
 * The engine (link_circe.c) wires the hooks to the channel, the table and the control socket,
 * and calls the session's tick() when the deadline the session asks for has passed.
 *
 * Time is CLOCK_MONOTONIC in milliseconds; LINK_CIRCE_NEVER means "no deadline".
 */
#ifndef SHAREDLINK_DAEMON_LINK_CIRCE_SESSION_H
#define SHAREDLINK_DAEMON_LINK_CIRCE_SESSION_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "proto/circe.h"
#include "shm/layout.h"

/* Devices one controller link tracks at once; the emulator plays at most CONFIG_EMULATE_MAX. */
#define LINK_CIRCE_DEVICES_MAX          64u
/* PROTOCOLS.md 2.4: a device is offline when more than 3 s passed since its last status. */
#define LINK_CIRCE_OFFLINE_MS           3000u
/* PROTOCOLS.md 2.4: Synchronize Clocks succeeds for a device that reports 027:2 within 3 s. */
#define LINK_CIRCE_SYNC_WINDOW_MS       3000u
/* The emulator sends a Notify Status per device every second (PROTOCOLS.md 2.4). */
#define LINK_CIRCE_STATUS_PERIOD_MS     1000u
/* An emulated device reports 027:2 for four seconds after a synchronisation (CIRCE spec,
 * Notify Status). */
#define LINK_CIRCE_SYNC_SHOWN_MS        4000u
/* Sensor Time (025) is 0..999999 ms: an emulated device's clock wraps there. */
#define LINK_CIRCE_SENSOR_CLOCK_MOD     1000000u
/* Longest one-line diagnostic a session hands to the diag hook. */
#define LINK_CIRCE_DIAG_MAX             160u
#define LINK_CIRCE_NEVER                UINT64_MAX

/* Link states, DESIGN.md 2.8 (the names are link_circe_state_name()). */
enum link_circe_state {
        LINK_CIRCE_DISCONNECTED = 0,    /* port closed (or backing off) */
        LINK_CIRCE_CONNECTING,          /* controller: Login sent; mediator: waiting for Login */
        LINK_CIRCE_CONNECTED,           /* logged in, mediator status not 1 */
        LINK_CIRCE_VERSION_MISMATCH,    /* controller: the mediator speaks another major.minor */
        LINK_CIRCE_UNCONFIGURED,        /* logged in, mediator status 1 (unconfigured mediator) */
        LINK_CIRCE_STATE_COUNT
};

/* What a device publishes as <link>.device.<ADDR>.<name> (link_circe_field_name()). */
enum link_circe_field {
        LINK_CIRCE_F_ONLINE = 0,
        LINK_CIRCE_F_MEMBERSHIP,
        LINK_CIRCE_F_CAPABILITIES,
        LINK_CIRCE_F_ROLES,
        LINK_CIRCE_F_SIGNAL,
        LINK_CIRCE_F_BATTERY,
        LINK_CIRCE_F_ALIGNED,
        LINK_CIRCE_F_CLOCK_SYNC,
        LINK_CIRCE_F_VERSION_MISMATCH,
        LINK_CIRCE_F_KEYS,
        LINK_CIRCE_F_SENSOR_TIME,
        /* emulator only: every device */
        LINK_CIRCE_F_ALERTS,
        /* emulator only: displays (capability 64) */
        LINK_CIRCE_F_CURRENT,
        LINK_CIRCE_F_NEXT,
        LINK_CIRCE_F_TIMER_RUNNING,
        LINK_CIRCE_F_PRIMARY,
        LINK_CIRCE_F_SECONDARY,
        LINK_CIRCE_F_FAULTS,
        LINK_CIRCE_F_REFUSALS,
        LINK_CIRCE_F_ELIMINATED,
        LINK_CIRCE_F_PLACEMENT,
        LINK_CIRCE_F_COUNT
};

#define LINK_CIRCE_BIT(f)               (UINT32_C(1) << (f))
/* Everything a Notify Status carries, online included. */
#define LINK_CIRCE_FIELDS_STATUS        (LINK_CIRCE_BIT(LINK_CIRCE_F_KEYS) - 1u)
#define LINK_CIRCE_FIELDS_CONTROLLER    (LINK_CIRCE_BIT(LINK_CIRCE_F_ALERTS) - 1u)
#define LINK_CIRCE_FIELDS_DISPLAY       ((LINK_CIRCE_BIT(LINK_CIRCE_F_COUNT) - 1u) & \
                                         ~(LINK_CIRCE_BIT(LINK_CIRCE_F_CURRENT) - 1u))
#define LINK_CIRCE_FIELDS_ALL           (LINK_CIRCE_BIT(LINK_CIRCE_F_COUNT) - 1u)

/* What an emulated display shows (Visualize, PROTOCOLS.md 2.2); has_* false: never set. */
struct link_circe_display {
        bool has_current, has_next, has_timer, has_primary, has_secondary;
        bool has_faults, has_refusals, has_eliminated, has_placement;
        uint16_t current, next;
        bool timer_running;
        uint32_t primary_ms, secondary_ms;
        uint8_t faults, refusals;
        bool eliminated;
        uint16_t placement;
};

/* One device as a link knows it. An optional value never received has its has_* false and is
 * published as an empty value (DESIGN.md 2.8). */
struct link_circe_device {
        uint32_t address;
        bool online;
        bool has_status;                /* a Notify Status arrived (controller) / was set up */
        bool membership;
        uint8_t capabilities, roles, signal;
        bool has_battery, has_aligned, has_clock_sync, has_version_mismatch;
        uint8_t battery;
        bool aligned;
        uint8_t clock_sync;             /* enum circe_clock_sync */
        bool version_mismatch;
        bool has_keys, has_sensor_time;
        uint16_t keys;                  /* last Notify Action */
        uint32_t sensor_time_ms;
        uint32_t alerts;                /* emulator: Alerts received */
        struct link_circe_display display;
};

/*
 * How a session acts. Every hook gets the arg given at init; each may be NULL except send.
 * A session calls them synchronously from its own functions; hooks must not call back into the
 * session.
 */
struct link_circe_hooks {
        /* Encode and send one packet; 0 or -errno (the session counts nothing itself). */
        int (*send)(void *arg, const struct circe_msg *m);
        /* Controller: give up on this port (close, back off, next device). */
        void (*fail)(void *arg, const char *reason);
        /* The link state changed; detail is "" or extra "key=value" words for the event. */
        void (*state)(void *arg, enum link_circe_state state, const char *detail);
        /* Mediator version or status changed (controller: received; emulator: its own). */
        void (*mediator)(void *arg, const struct circe_version *version, unsigned status);
        /* A device's fields changed: bits of LINK_CIRCE_BIT(field). index is stable for the
         * life of the session; old_address differs from d->address after a re-addressing. */
        void (*device)(void *arg, unsigned index, const struct link_circe_device *d,
                       uint32_t fields, uint32_t old_address);
        /* An event for the table's ring ("key=value ..." text). */
        void (*event)(void *arg, enum shm_event_type type, const char *text);
        /* Add delta to a link counter. */
        void (*count)(void *arg, enum shm_counter counter, uint64_t delta);
        /* A rejected packet (res->kind == CIRCE_RESULT_REJECTED), for a rate-limited log. */
        void (*rejected)(void *arg, const struct circe_result *res);
        /* A one-line diagnostic worth a rate-limited log line (ignored input and the like). */
        void (*diag)(void *arg, const char *text);
        /* Controller: a Log (54) from the mediator. */
        void (*log)(void *arg, const uint8_t *data, size_t len);
        /* Controller: result of one device in a clock synchronisation. */
        void (*sync_result)(void *arg, uint32_t address, bool succeeded);
        /* Controller: the clock synchronisation ended (0, or -errno when the link went down). */
        void (*sync_done)(void *arg, int err);
};

/* A decoder plus what it has already counted as noise. */
struct link_circe_wire {
        struct circe_decoder dec;
        uint64_t noise_counted;
};

/* Resets the decoder (e.g. for a newly opened port). */
void link_circe_wire_init(struct link_circe_wire *w);

/*
 * Feeds bytes to the decoder until one packet ends or buf is used up (see circe_decoder_feed),
 * counts what happened through h->count (frames_in, noise, drops by reason, skipped and repeated
 * parameters) and reports a rejection through h->rejected. Returns the bytes consumed.
 */
size_t link_circe_wire_feed(struct link_circe_wire *w, const uint8_t *buf, size_t len,
                            struct circe_result *ret, const struct link_circe_hooks *h,
                            void *arg);

/* The counter a rejection reason is counted under. */
enum shm_counter link_circe_reason_counter(enum circe_reason reason);

/* "connecting", "connected", ... (DESIGN.md 2.8); "unknown" for a bad value. */
const char *link_circe_state_name(enum link_circe_state state);

/* "online", "membership", ..., "placement"; NULL for a bad value. */
const char *link_circe_field_name(enum link_circe_field field);

/* Writes field f of d as decimal text (NUL-terminated); returns its length, 0 for a value
 * never received. size must be at least 12. */
size_t link_circe_device_format(const struct link_circe_device *d, enum link_circe_field f,
                                char *buf, size_t size);

/* True when the two major.minor pairs are equal. */
bool link_circe_version_compatible(const struct circe_version *v, unsigned major,
                                   unsigned minor);

/* Fills ret with the Notify Status that d would send (emulator) from its fields. */
void link_circe_device_status(const struct link_circe_device *d, struct circe_msg *ret);

#endif
