/*
 * What a sharedlinkd configuration holds: its limits, ranges and defaults (the only ones; every
 * key is documented in conf/sharedlinkd.yaml), its enums and its structs. Data only, no code:
 * config.h (the parser's entry points) and the parser's files (config_ctx.h lists them) include
 * it, so that they depend on the model and never on each other backwards.
 */
#ifndef SHAREDLINK_DAEMON_CONFIG_TYPES_H
#define SHAREDLINK_DAEMON_CONFIG_TYPES_H

#include <netinet/in.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/socket.h>

#include "proto/circe.h"
#include "shm/layout.h"

/* Input bounds: a config file larger than this is refused before parsing. */
#define CONFIG_INPUT_MAX        (1024u * 1024u)
#define CONFIG_NODES_MAX        65536u  /* YAML nodes (scalars, lists, mappings) per file */
#define CONFIG_DEPTH_MAX        16u     /* nesting; the schema itself needs 8 */

/* Names. A variable name is what the shm directory holds (DESIGN.md §2.4: <= 47 bytes). */
#define CONFIG_VAR_NAME_MAX     47u
#define CONFIG_INSTANCE_MAX     SHM_INSTANCE_MAX  /* part of an shm name and a socket file name */
#define CONFIG_GROUP_MAX        32u
/*
 * A CIRCE link publishes "<link>.device.<ADDR>.current_competitor" (DESIGN.md §2.8), the longest
 * generated name: 33 bytes after the link name, so a link name of at most 47 - 33 = 14 bytes keeps
 * every generated name within CONFIG_VAR_NAME_MAX. The same limit applies to every protocol so a
 * link can change protocol without being renamed.
 */
#define CONFIG_LINK_NAME_MAX    14u
#define CONFIG_PATH_MAX         256u    /* device paths and runtime_dir, terminator included */
#define CONFIG_SOCKET_PATH_MAX  108u    /* sizeof(sun_path): "<runtime_dir>/<instance>.sock", NUL */
#define CONFIG_ENDPOINT_MAX     64u     /* "host:port" text, terminator included */
#define CONFIG_VERSION_TEXT_MAX (CIRCE_VERSION_LEN_MAX + 1u)   /* "999.999.999" + NUL */

/* Counts. */
#define CONFIG_LINKS_MAX        16u
#define CONFIG_PEERS_MAX        15u     /* SharedLink addresses A..P, minus the link's own */
#define CONFIG_DEVICES_MAX      8u      /* device paths a link scans in turn */
#define CONFIG_EMULATE_MAX      32u     /* devices one CIRCE mediator emulator plays */
/*
 * Why these two (docs/testing.md, "Why 256 variables per list and 4,096 per instance"): a list
 * is held by the wire (a full list of eight-byte values is 0.22 s of line at 115,200 baud). The
 * instance is held by no structure: the tables are sized from the configuration, names are
 * hashed in the daemon, the library and this parser, and a wake-up scans only the .out slots
 * written. 4,096 is where it is measured (bench_scale's cap row) and tested
 * (tests/integration/test_scale.c); the once-a-second full .out scan grows with it.
 */
#define CONFIG_LIST_MAX         256u    /* variables in one outbound or inbound list */
#define CONFIG_VARS_MAX         4096u   /* configured variables per instance, all lists together */

/* Numeric ranges (inclusive) and defaults. */
#define CONFIG_BAUD_MIN                 1200u
#define CONFIG_BAUD_MAX                 4000000u
#define CONFIG_BAUD_DEFAULT             115200u
#define CONFIG_PERIOD_MS_MAX            60000u          /* 0 = no periodic send */
#define CONFIG_PERIOD_MS_DEFAULT        100u
#define CONFIG_REFRESH_MS_MIN           10u
#define CONFIG_REFRESH_MS_MAX           3600000u
#define CONFIG_REFRESH_MS_DEFAULT       1000u
#define CONFIG_MIN_INTERVAL_MS_MAX      60000u          /* 0 = no rate limit */
#define CONFIG_MIN_INTERVAL_MS_DEFAULT  10u
#define CONFIG_STALE_MS_MAX             3600000u        /* 0 = never stale */
#define CONFIG_STALE_REFRESHES          3u              /* default stale_ms = 3 x refresh_ms */
#define CONFIG_MAX_FRAME_MIN            32u
#define CONFIG_MAX_FRAME_MAX            4096u
#define CONFIG_MAX_FRAME_DEFAULT        1024u
/* pronto4: both public clients read a datagram into 1024 bytes (docs/pronto4.md §1). */
#define CONFIG_P4_MAX_FRAME_MAX         1024u
#define CONFIG_TIMEOUT_MS_MIN           100u            /* login_timeout_ms, idle_timeout_ms */
#define CONFIG_TIMEOUT_MS_MAX           60000u
#define CONFIG_LOGIN_TIMEOUT_MS_DEFAULT 1000u
#define CONFIG_IDLE_TIMEOUT_MS_DEFAULT  2000u
#define CONFIG_KEEPALIVE_MS_MIN         10u
#define CONFIG_KEEPALIVE_MS_MAX         60000u
#define CONFIG_KEEPALIVE_MS_DEFAULT     750u
#define CONFIG_LEARN_MAX_MIN            1u              /* pronto4: entries of a learned list */
#define CONFIG_LEARN_MAX_MAX            CONFIG_LIST_MAX
#define CONFIG_LEARN_MAX_DEFAULT        128u
/* CIRCE value ranges are proto/circe.h's (CIRCE_*_MAX); these are the config's own choices. */
#define CONFIG_CIRCE_CAPABILITIES_MIN   1u              /* an emulated device can do something */
#define CONFIG_CIRCE_SIGNAL_DEFAULT     CIRCE_LEVEL_MAX

#define CONFIG_INSTANCE_DEFAULT         "default"
#define CONFIG_RUNTIME_DIR_DEFAULT      "/run/sharedlink"

/* replay: speed is a factor on the recorded pace, e.g. 0.5 or 10 ("max": no pacing) */
#define CONFIG_REPLAY_SPEED_MIN         0.001
#define CONFIG_REPLAY_SPEED_MAX         1000.0
#define CONFIG_REPLAY_SPEED_TEXT_MAX    16u     /* "1000.000000" and a little more */

#define CONFIG_ERROR_MAX        512u

enum config_protocol {
        CONFIG_PROTOCOL_SHAREDLINK,
        CONFIG_PROTOCOL_CIRCE,
};

enum config_transport {
        CONFIG_TRANSPORT_SERIAL,
        CONFIG_TRANSPORT_UDP,
        CONFIG_TRANSPORT_PTY,           /* creates a pty, symlinks its slave at devices[0] */
        CONFIG_TRANSPORT_REPLAY,        /* plays a recording (docs/recording.md) into the engine */
};

enum config_role {
        CONFIG_ROLE_NONE,               /* SharedLink links */
        CONFIG_ROLE_CONTROLLER,
        CONFIG_ROLE_MEDIATOR,           /* the built-in emulator */
};

enum config_parity {
        CONFIG_PARITY_NONE,
        CONFIG_PARITY_EVEN,
        CONFIG_PARITY_ODD,
};

enum config_flow {
        CONFIG_FLOW_NONE,
        CONFIG_FLOW_RTSCTS,
        CONFIG_FLOW_XONXOFF,
};

enum config_var_type {
        CONFIG_VAR_STRING,
        CONFIG_VAR_LONG,
        CONFIG_VAR_DOUBLE,
};

/* What a SharedLink peer speaks (docs/pronto4.md). */
enum config_dialect {
        CONFIG_DIALECT_BULLETIN,        /* BUL-049 as in PROTOCOLS.md §1 (the default) */
        CONFIG_DIALECT_PRONTO4,         /* the Kairos Pronto4 field dialect */
};

/* Which end of a Pronto4 link we are toward a pronto4 peer (docs/pronto4.md §1, §9). */
enum config_p4_role {
        CONFIG_P4_HOST,                 /* node A: sends the connect sequence, declares */
        CONFIG_P4_VEHICLE,              /* node B: answers, obeys ELink outbound/inbound */
};

struct config_var {
        char name[CONFIG_VAR_NAME_MAX + 1];
        enum config_var_type type;
};

/* One SharedLink peer of a link: what we send it and what it sends us. */
struct config_peer {
        char address;                   /* 'A'..'P' */
        uint32_t period_ms;
        uint32_t refresh_ms;
        uint32_t min_interval_ms;
        uint32_t stale_ms;
        uint32_t max_frame;
        bool compression;
        bool on_change;
        struct config_var *outbound;    /* positions 0..n_outbound-1 of our list to this peer */
        unsigned n_outbound;
        struct config_var *inbound;     /* positions of the peer's outbound list */
        unsigned n_inbound;
        /* Pronto4 dialect; a bulletin peer has declare and both learns false, learn_max 0. */
        enum config_dialect dialect;
        enum config_p4_role role;       /* role: host | vehicle (default from the addresses) */
        bool declare;                   /* send our typed N0/L0 declarations to this peer */
        bool outbound_learn;            /* outbound: learn (from the peer's L0 declaration) */
        bool inbound_learn;             /* inbound: learn (from the peer's N0 declaration) */
        uint32_t learn_max;             /* entries a learned list may hold (either list) */
};

struct config_sharedlink {
        char address;                   /* this node on this link, 'A'..'P' */
        struct config_peer peers[CONFIG_PEERS_MAX];
        unsigned n_peers;
        bool crlf;                      /* udp: end every datagram's frame with CR LF */
};

struct config_circe_version {
        char text[CONFIG_VERSION_TEXT_MAX];     /* as written: "0.2" or "0.2.3" */
        uint16_t major, minor, patch;
};

struct config_emulated_device {
        uint32_t address;               /* 0x000000..0xFFFFFE */
        uint8_t capabilities;           /* 1..127 */
        uint8_t roles;                  /* 0..127 */
        uint8_t signal;
        uint8_t battery;                /* meaningful only when has_battery */
        bool has_battery;               /* 022 is optional in Notify Status */
        bool membership;
};

struct config_circe {
        enum config_role role;
        bool checksum;                  /* send a checksum; received ones are always checked */
        /* controller */
        struct config_circe_version expect_version;     /* major.minor only */
        uint32_t login_timeout_ms;
        uint32_t idle_timeout_ms;
        /* mediator (emulator) */
        struct config_circe_version version;
        uint16_t status;
        bool has_address;
        uint32_t address;
        uint32_t keepalive_ms;
        struct config_emulated_device emulate[CONFIG_EMULATE_MAX];
        unsigned n_emulate;
};

struct config_serial {
        uint32_t baud;
        enum config_parity parity;
        uint8_t data_bits;              /* 7 or 8 */
        uint8_t stop_bits;              /* 1 or 2 */
        enum config_flow flow_control;
};

struct config_endpoint {
        char text[CONFIG_ENDPOINT_MAX]; /* as written, for messages */
        struct sockaddr_storage addr;   /* AF_INET or AF_INET6, port set */
        socklen_t addr_len;
};

struct config_link {
        char name[CONFIG_LINK_NAME_MAX + 1];
        enum config_protocol protocol;
        enum config_transport transport;
        /* serial, pty: devices[0..n_devices-1] (pty: exactly one, the symlink path) */
        char devices[CONFIG_DEVICES_MAX][CONFIG_PATH_MAX];
        unsigned n_devices;
        struct config_serial serial;    /* serial, pty */
        struct config_endpoint local;   /* udp */
        struct config_endpoint remote;  /* udp, when has_remote */
        bool has_remote;
        /* replay: the recording (absolute path), the pace (0: as fast as the engine takes it,
         * else a factor on the recorded times' pace) and whether to start over at the end */
        char replay_file[CONFIG_PATH_MAX];
        double replay_speed;
        bool replay_loop;
        struct config_sharedlink sl;    /* protocol sharedlink */
        struct config_circe circe;      /* protocol circe */
};

struct config {
        char instance[CONFIG_INSTANCE_MAX + 1];
        char runtime_dir[CONFIG_PATH_MAX];
        bool runtime_dir_set;           /* runtime_dir came from the file, not the default */
        char group[CONFIG_GROUP_MAX + 1];       /* "" = none */
        unsigned group_line, group_column;      /* where group: is written (0: not given), for
                                                 * the check that it exists (daemon_plan.c) */
        struct config_link links[CONFIG_LINKS_MAX];
        unsigned n_links;
        unsigned n_vars;                /* configured variables, all links and lists */
};

struct config_error {
        unsigned line, column;          /* 1-based; 0 when the error has no position (I/O) */
        char message[CONFIG_ERROR_MAX]; /* "FILE:LINE:COL: text" or "FILE: text", no newline */
};

#endif
