/*
 * CIRCE (Computer Interface to Race Course Equipment, v0.2.3) codec: a streaming packet framer,
 * a validating packet parser that fills one typed struct per operation, and an encoder that
 * refuses anything the parser would reject.  The byte-level contract is PROTOCOLS.md section 2.
 *
 * Pure code: no syscalls, no allocation, no logging, no global state.  The caller owns the
 * decoder, the results and every buffer.
 *
 * Typical receive loop:
 *
 *      struct circe_decoder dec;
 *      struct circe_result res;
 *
 *      circe_decoder_init(&dec);
 *      while (len > 0) {
 *              size_t n = circe_decoder_feed(&dec, buf, len, &res);
 *              buf += n;
 *              len -= n;
 *              if (res.kind == CIRCE_RESULT_MESSAGE)
 *                      handle(&res.msg);
 *              else if (res.kind == CIRCE_RESULT_REJECTED)
 *                      count(res.reason);
 *      }
 */
#ifndef SHAREDLINK_PROTO_CIRCE_H
#define SHAREDLINK_PROTO_CIRCE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* ---- Limits and wire constants ------------------------------------------------------------ */

#define CIRCE_STX 0x02
#define CIRCE_ETX 0x03
#define CIRCE_TAB 0x09

/* Longest packet accepted or emitted, STX through ETX inclusive (PROTOCOLS.md 2.1 Decision). */
#define CIRCE_PACKET_MAX 1024

/*
 * Most 014 destinations one Visualize can carry: each takes 11 bytes ("014:XXXXXX" TAB) and the
 * shortest rest of a legal Visualize is 11 bytes (STX "07" TAB "030:1" TAB ETX), so a packet of
 * CIRCE_PACKET_MAX bytes holds at most (1024 - 11) / 11 = 92 of them.
 */
#define CIRCE_VISUALIZE_DEST_MAX 92

/*
 * Largest Log (036) payload in bytes: STX "54" TAB "036:" <2 hex digits per byte> TAB ETX is
 * 10 bytes of framing, so a packet of CIRCE_PACKET_MAX bytes carries at most (1024 - 10) / 2.
 * With a checksum the encoder can only fit 506 bytes; it refuses 507 with -EMSGSIZE.
 */
#define CIRCE_LOG_MAX 507

/* Address (014, 015, 026): six uppercase hex digits on the wire, a 24-bit integer here. */
#define CIRCE_ADDRESS_LEN 6
#define CIRCE_ADDRESS_MAX 0xFFFFFFu
#define CIRCE_ADDRESS_UNCONFIGURED 0x000000u  /* legal on the wire: a device with no address yet */
#define CIRCE_ADDRESS_RESERVED 0xFFFFFFu      /* never on the wire */

/* Each part of a Version (010) is 1-3 digits: "999.999.999" is the longest. */
#define CIRCE_VERSION_PART_MAX 999
#define CIRCE_VERSION_PARTS 3
#define CIRCE_VERSION_LEN_MAX 11

/*
 * Value ranges (PROTOCOLS.md 2.3), the one place they are written: the codec's parameter table,
 * the daemon's command parser and config, and the library's argument checks all use these. Every
 * minimum is 0 but for Clock synchronization (1) and Start timer (always 1).
 */
#define CIRCE_STATUS_MAX 999            /* 012 mediator status */
#define CIRCE_CAPABILITIES_MAX 127      /* 019 */
#define CIRCE_ROLES_MAX 127             /* 020 */
#define CIRCE_LEVEL_MAX 255             /* 021 signal, 022 battery */
#define CIRCE_KEYS_MAX 65535            /* 024 input keys */
#define CIRCE_TIME_MS_MAX 999999        /* 025 sensor time, 031 primary and 038 secondary timer */
#define CIRCE_COMPETITOR_MAX 999        /* 028 current, 029 next competitor */
#define CIRCE_COUNT_MAX 99              /* 032 faults, 033 refusals */
#define CIRCE_PLACEMENT_MAX 999         /* 035 */

/* ---- Operations and parameters (PROTOCOLS.md 2.2, 2.3) --------------------------------------- */

enum circe_op {
        CIRCE_OP_NONE = 0,              /* not an operation; never on the wire */
        CIRCE_OP_LOGIN = 1,             /* controller -> mediator */
        CIRCE_OP_LOGOUT = 2,
        CIRCE_OP_ALERT = 3,
        CIRCE_OP_NETWORK_SETUP = 4,
        CIRCE_OP_DEVICE_SETUP = 5,
        CIRCE_OP_SYNC_CLOCKS = 6,
        CIRCE_OP_VISUALIZE = 7,
        CIRCE_OP_KEEP_ALIVE = 51,       /* mediator -> controller */
        CIRCE_OP_NOTIFY_STATUS = 52,
        CIRCE_OP_NOTIFY_ACTION = 53,
        CIRCE_OP_LOG = 54,
};

enum circe_param {
        CIRCE_PARAM_PROTOCOL_VERSION = 10,
        CIRCE_PARAM_MEDIATOR_STATUS = 12,       /* erratum: one section of the spec says 013 */
        CIRCE_PARAM_DESTINATION = 14,
        CIRCE_PARAM_ORIGIN = 15,
        CIRCE_PARAM_GET_MEMBERSHIP = 16,
        CIRCE_PARAM_SET_MEMBERSHIP = 17,
        CIRCE_PARAM_CAPABILITIES = 19,
        CIRCE_PARAM_ROLES = 20,
        CIRCE_PARAM_SIGNAL = 21,
        CIRCE_PARAM_BATTERY = 22,
        CIRCE_PARAM_ALIGNED = 23,
        CIRCE_PARAM_INPUT_KEYS = 24,
        CIRCE_PARAM_SENSOR_TIME = 25,
        CIRCE_PARAM_ASSIGN_ADDRESS = 26,        /* erratum: one table of the spec says 016 */
        CIRCE_PARAM_CLOCK_SYNC = 27,
        CIRCE_PARAM_CURRENT_COMPETITOR = 28,
        CIRCE_PARAM_NEXT_COMPETITOR = 29,
        CIRCE_PARAM_START_TIMER = 30,
        CIRCE_PARAM_PRIMARY_TIMER = 31,
        CIRCE_PARAM_FAULTS = 32,
        CIRCE_PARAM_REFUSALS = 33,
        CIRCE_PARAM_ELIMINATED = 34,
        CIRCE_PARAM_PLACEMENT = 35,
        CIRCE_PARAM_LOG_DATA = 36,
        CIRCE_PARAM_VERSION_MISMATCH = 37,      /* erratum: Notify Status may carry it too */
        CIRCE_PARAM_SECONDARY_TIMER = 38,
};

/* Capabilities (019) bits.  Time sensor and display each exclude every other bit. */
enum circe_capability {
        CIRCE_CAP_CONTROL_KEYPAD = 1,
        CIRCE_CAP_NUMERIC_KEYPAD = 2,
        CIRCE_CAP_START_SENSOR = 4,
        CIRCE_CAP_FINISH_SENSOR = 8,
        CIRCE_CAP_INTERMEDIATE_SENSOR = 16,
        CIRCE_CAP_TIME_SENSOR = 32,
        CIRCE_CAP_DISPLAY = 64,
};

/* Roles (020) bits. */
enum circe_role {
        CIRCE_ROLE_KEYPAD = 1,
        CIRCE_ROLE_START_TIMER = 2,
        CIRCE_ROLE_FINISH_TIMER = 4,
        CIRCE_ROLE_INTERMEDIATE_TIMER_1 = 8,
        CIRCE_ROLE_INTERMEDIATE_TIMER_2 = 16,
        CIRCE_ROLE_INTERMEDIATE_TIMER_3 = 32,
        CIRCE_ROLE_DISPLAY = 64,
};

/* Input keys (024) bits. */
enum circe_key {
        CIRCE_KEY_1 = 1,
        CIRCE_KEY_2 = 2,
        CIRCE_KEY_3 = 4,
        CIRCE_KEY_4 = 8,
        CIRCE_KEY_5 = 16,
        CIRCE_KEY_6 = 32,
        CIRCE_KEY_7 = 64,
        CIRCE_KEY_8 = 128,
        CIRCE_KEY_9 = 256,
        CIRCE_KEY_ENTER_CURRENT = 512,
        CIRCE_KEY_ENTER_NEXT = 1024,
        CIRCE_KEY_0 = 2048,
        CIRCE_KEY_PASS_FINISH = 4096,
        CIRCE_KEY_PASS_START = 8192,
        CIRCE_KEY_RESET_RUN = 16384,
        CIRCE_KEY_READY = 32768,
};

/* Clock synchronization (027) values (a value, not a bitmask: the range is 1-2). */
enum circe_clock_sync {
        CIRCE_CLOCK_SYNC_REQUIRED = 1,
        CIRCE_CLOCK_SYNC_SUCCEEDED = 2,
};

/* Mediator status (012) values. */
enum circe_mediator_status {
        CIRCE_MEDIATOR_NORMAL = 0,
        CIRCE_MEDIATOR_UNCONFIGURED = 1,
        CIRCE_MEDIATOR_SEND_FAILED = 2,         /* failed to send a network packet */
};

/* ---- Typed messages ---------------------------------------------------------------------------
 * Addresses are 24-bit integers.  An optional parameter has a has_* flag; when it is false the
 * value is zero after decoding and ignored by the encoder and by circe_msg_equal().
 * Login, Logout and Synchronize Clocks carry no parameters and have no struct.
 */

struct circe_version {
        uint16_t major, minor, patch;           /* each 0-999 */
};

struct circe_alert {                            /* 03 */
        uint32_t dest;                          /* 014 */
};

struct circe_network_setup {                    /* 04 */
        uint32_t dest;                          /* 014 */
        bool set_membership;                    /* 017: join (true) or leave the network */
        uint8_t roles;                          /* 020: enum circe_role bits, 0-127 */
};

struct circe_device_setup {                     /* 05 */
        bool has_dest;
        uint32_t dest;                          /* 014, optional: absent means 000000 */
        uint32_t assign;                        /* 026: the address to assign */
        bool has_capabilities;
        uint8_t capabilities;                   /* 019: enum circe_capability bits, 0-127 */
};

struct circe_visualize {                        /* 07: at least one display field present */
        uint16_t dest_count;                    /* 014, 1..CIRCE_VISUALIZE_DEST_MAX, wire order */
        uint32_t dests[CIRCE_VISUALIZE_DEST_MAX];
        bool has_eliminated;
        bool eliminated;                        /* 034 */
        bool has_current;
        uint16_t current;                       /* 028: current competitor, 0-999 */
        bool has_next;
        uint16_t next;                          /* 029: next competitor, 0-999 */
        bool start_timer;                       /* 030: present (value is always 1) */
        bool has_primary;
        uint32_t primary_ms;                    /* 031: 0-999999 */
        bool has_secondary;
        uint32_t secondary_ms;                  /* 038: 0-999999 */
        bool has_faults;
        uint8_t faults;                         /* 032: 0-99 */
        bool has_refusals;
        uint8_t refusals;                       /* 033: 0-99 */
        bool has_placement;
        uint16_t placement;                     /* 035: previous placement, 0-999 */
};

struct circe_keep_alive {                       /* 51 */
        struct circe_version version;           /* 010 */
        uint16_t status;                        /* 012: enum circe_mediator_status, 0-999 */
};

struct circe_notify_status {                    /* 52 */
        uint32_t origin;                        /* 015 */
        bool membership;                        /* 016: member of the network */
        uint8_t capabilities;                   /* 019: 0-127 */
        uint8_t roles;                          /* 020: 0-127 */
        uint8_t signal;                         /* 021: 0-255 */
        bool has_battery;
        uint8_t battery;                        /* 022: 0-255 */
        bool has_aligned;
        bool aligned;                           /* 023 */
        bool has_clock_sync;
        uint8_t clock_sync;                     /* 027: enum circe_clock_sync, 1-2 */
        bool has_version_mismatch;
        bool version_mismatch;                  /* 037 */
};

struct circe_notify_action {                    /* 53 */
        uint32_t origin;                        /* 015 */
        bool has_keys;
        uint16_t keys;                          /* 024: enum circe_key bits, 0-65535 */
        bool has_sensor_time;
        uint32_t sensor_time_ms;                /* 025: 0-999999 */
};

struct circe_log {                              /* 54 */
        uint16_t len;                           /* 036, decoded: 1..CIRCE_LOG_MAX bytes */
        uint8_t data[CIRCE_LOG_MAX];
};

struct circe_msg {
        enum circe_op op;
        union {
                struct circe_alert alert;
                struct circe_network_setup network_setup;
                struct circe_device_setup device_setup;
                struct circe_visualize visualize;
                struct circe_keep_alive keep_alive;
                struct circe_notify_status notify_status;
                struct circe_notify_action notify_action;
                struct circe_log log;
        } u;
};

/* ---- Decoding -------------------------------------------------------------------------------- */

/* Why a packet was dropped, in the order the checks run (PROTOCOLS.md 2.3). */
enum circe_reason {
        CIRCE_REASON_NONE = 0,
        CIRCE_REASON_OVERLONG,          /* longer than CIRCE_PACKET_MAX; rest dropped until STX */
        CIRCE_REASON_ABANDONED,         /* a new STX arrived before ETX */
        CIRCE_REASON_BAD_FRAMING,       /* circe_decode(): not STX ... ETX, or STX/ETX inside */
        CIRCE_REASON_CHECKSUM_SYNTAX,   /* byte before ETX is not TAB, but no TAB + 2 hex digits */
        CIRCE_REASON_BAD_CHECKSUM,      /* checksum does not match */
        CIRCE_REASON_BAD_HEADER,        /* not 2 digits + TAB */
        CIRCE_REASON_UNKNOWN_OP,
        CIRCE_REASON_BAD_PARAM_SYNTAX,  /* not 3 digits ':' value TAB, or NUL in a value */
        CIRCE_REASON_VALUE_LENGTH,      /* empty, too long, or an address not 6 digits */
        CIRCE_REASON_VALUE_TYPE,        /* wrong characters for the parameter's type */
        CIRCE_REASON_VALUE_RANGE,       /* well formed, outside the parameter's range */
        CIRCE_REASON_MISSING_PARAM,     /* a mandatory parameter is absent */
        CIRCE_REASON_COUNT
};

enum circe_result_kind {
        CIRCE_RESULT_NONE = 0,          /* input used up before a packet ended */
        CIRCE_RESULT_MESSAGE,           /* msg holds a valid message */
        CIRCE_RESULT_REJECTED,          /* reason says why the packet was dropped */
};

struct circe_result {
        enum circe_result_kind kind;
        enum circe_reason reason;       /* CIRCE_RESULT_REJECTED only */
        /* The parameter a VALUE_* or MISSING_PARAM rejection is about; 0 when it is none, or when
         * a Visualize lacks all of its display parameters. */
        unsigned param;
        unsigned skipped;               /* MESSAGE: parameters not allowed for the op, skipped */
        unsigned repeated;              /* MESSAGE: repeats ignored (the first one counts) */
        bool has_checksum;              /* the packet carried a (valid) checksum */
        /* The packet's bytes (STX ... ETX, or the partial packet for OVERLONG/ABANDONED); from
         * circe_decoder_feed() they live in the decoder and stay valid until its next call. */
        const uint8_t *packet;
        size_t packet_len;
        struct circe_msg msg;           /* CIRCE_RESULT_MESSAGE only (else op is NONE) */
};

struct circe_decoder_stats {
        uint64_t bytes;                 /* every byte fed */
        uint64_t noise;                 /* bytes between packets (stray ETX not included) */
        uint64_t stray_etx;             /* ETX outside a packet */
        uint64_t discarded;             /* bytes dropped after an overlong packet, up to STX */
        uint64_t messages;              /* packets decoded */
        uint64_t rejected[CIRCE_REASON_COUNT];  /* packets dropped, by reason */
        uint64_t skipped_params;        /* in decoded packets: not allowed for the operation */
        uint64_t repeated_params;       /* in decoded packets: repeats ignored */
};

enum circe_decoder_state {
        CIRCE_DECODER_HUNT = 0,         /* between packets, waiting for STX */
        CIRCE_DECODER_PACKET,           /* inside a packet, waiting for ETX */
        CIRCE_DECODER_DISCARD,          /* after an overlong packet, waiting for STX */
};

/* Caller-allocated; only stats is meant to be read, the rest is the framer's state. */
struct circe_decoder {
        enum circe_decoder_state state;
        size_t len;                     /* bytes in buf (STX included) */
        uint8_t buf[CIRCE_PACKET_MAX];
        struct circe_decoder_stats stats;
};

/* Resets the framer and zeroes its statistics. */
void circe_decoder_init(struct circe_decoder *d);

/* Consumes bytes until one packet ends (decoded or rejected) or buf is used up; returns the
 * number of bytes consumed (at least 1 when len > 0) and always fills *ret. */
size_t circe_decoder_feed(struct circe_decoder *d, const uint8_t *buf, size_t len,
                          struct circe_result *ret);

/* Validates one whole packet (STX ... ETX, at most CIRCE_PACKET_MAX bytes) and fills *ret with
 * a message or a rejection; ret->packet points into pkt. */
void circe_decode(const uint8_t *pkt, size_t len, struct circe_result *ret);

/* Human-readable text for a rejection reason ("bad checksum", ...); never NULL. */
const char *circe_reason_str(enum circe_reason reason);

/* ---- Encoding -------------------------------------------------------------------------------- */

/* Writes m as one packet (STX ... ETX, no NUL) with an uppercase checksum if with_checksum;
 * returns its length, or -EINVAL (a value the decoder would reject, unknown op), -EMSGSIZE
 * (longer than CIRCE_PACKET_MAX) or -ENOBUFS (longer than size).  buf is scratch on failure. */
int circe_encode(const struct circe_msg *m, int with_checksum, char *buf, size_t size);

/* ---- Helpers --------------------------------------------------------------------------------- */

/* True when the two messages carry the same operation and the same parameter values. */
bool circe_msg_equal(const struct circe_msg *a, const struct circe_msg *b);

/* Name of an operation ("Notify Status"), or NULL when op is not one. */
const char *circe_op_str(enum circe_op op);

/* True for operations the controller sends (01-07), false for the mediator's (51-54). */
bool circe_op_from_controller(enum circe_op op);

/* True when a capabilities value is one the controller accepts: non-zero, at most 127, and
 * time sensor or display each alone. */
bool circe_capabilities_compliant(unsigned capabilities);

/* Writes addr (at most CIRCE_ADDRESS_MAX) as six uppercase hex digits and a NUL into out. */
void circe_address_format(uint32_t addr, char out[CIRCE_ADDRESS_LEN + 1]);

/* Parses an address as it is on the wire: 0, -EINVAL when s[0..len) is not exactly six
 * uppercase hex digits, -ERANGE when it is the reserved FFFFFF. */
int circe_address_parse(const char *s, size_t len, uint32_t *ret_addr);

/* Parses a Version of parts (1..CIRCE_VERSION_PARTS) dot-separated numbers of 1-3 digits each:
 * 3 is the wire's "X.Y.Z", 2 a "X.Y" (patch 0). 0 or -EINVAL. */
int circe_version_parse(const char *s, size_t len, unsigned parts,
                        struct circe_version *ret_version);

#endif
