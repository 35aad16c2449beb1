/*
 * The control-command vocabulary: every request the control socket carries (DESIGN.md §2.6), its
 * words, the ranges of its arguments and the shape of its reply, in one table per request
 * (request.c), as chrony keeps its requests in one header for client and daemon. The library
 * fills a struct reqp_request and encodes it (src/lib/request.c); the daemon decodes the words of
 * a line into the same struct once (daemon.c) and hands it to the engine of the link it names.
 * The line grammar beneath (words, replies, wait=MS): control.h. Pure code: no syscalls, no
 * allocation, no logging, no global state; the caller owns every buffer.
 *
 * Names carry the prefix reqp_ / REQP_ ("request protocol"): request_ is the library's client.
 *
 *   request                                                reply (then OK, unless said)
 *   ping                                                   OK PID EPOCH
 *   stats                                                  DATA TEXT per line
 *   record LINK                                            DATA LINE per line of a recording
 *                                                          (recording.h), until the client leaves
 *                                                          or the daemon ends it with OK SUMMARY
 *   query LINK PEER NAME [TIMEOUT_MS]                      OK VALUE (maybe empty)
 *   command LINK MODULE [TEXT...]
 *   ping-peer LINK PEER [TIMEOUT_MS]                      OK RTT_NS: P0 sent, G0 back after RTT_NS
 *   circe LINK alert ADDR
 *   circe LINK network-setup ADDR join|leave ROLES
 *   circe LINK device-setup ASSIGN [DEST|-] [CAPABILITIES|-]
 *   circe LINK sync-clocks                                 DATA ADDR succeeded|timed-out per
 *                                                          device (reqp_sync_result_*)
 *   circe LINK visualize ADDR[,ADDR...] [current=N] [next=N] [start-timer] [primary=MS]
 *             [secondary=MS] [faults=N] [refusals=N] [eliminated=0|1] [placement=N]
 *   circe LINK emulate action ADDR [keys=N] [sensor-time=MS]
 *
 * Every request may fail with "ERR ERRNO TEXT". The requests on a link (query, command, ping-peer,
 * circe)
 * may end in wait=MS (CTLP_WAIT_PREFIX): the engine then waits up to MS for the link instead of
 * failing with ENOTCONN; as the last word only, so the encoder adds "wait=0" after a last word
 * that would read as one. A CIRCE address is six uppercase hex digits, not FFFFFF; numbers are
 * decimal digits, in the ranges of PROTOCOLS.md 2.3 (proto/circe.h); KEY=VALUE options come in any
 * order, at most once each, and are sent in the order above.
 *
 * To add a request: its kind below, its data in struct reqp_request when it needs new fields, one
 * table entry in request.c; the line, the checks, the messages and the tests' round trip follow.
 */
#ifndef SHAREDLINK_PROTO_REQUEST_H
#define SHAREDLINK_PROTO_REQUEST_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "proto/circe.h"
#include "proto/control.h"
#include "proto/sharedlink.h"

/* ---- Limits ------------------------------------------------------------------------------- */

/* The table's sizes (shm/layout.h), pinned equal where both meet: lib/request.c and
 * daemon/daemon_request.c. Spelled here so the grammar needs nothing above src/proto/. */
#define REQP_LINK_SIZE          32      /* a link name + NUL (SHM_LINK_NAME_SIZE) */
#define REQP_NAME_SIZE          48      /* query: a variable name + NUL (SHM_NAME_SIZE) */
#define REQP_MODULE_SIZE        (SLP_VALUE_MAX + 1)     /* command: E<module> + NUL */
#define REQP_TEXT_SIZE          (SLP_VALUE_MAX + 1)     /* command: D<text> + NUL */
#define REQP_PEER_SIZE          2                       /* query: "A".."P" + NUL */
#define REQP_QUERY_TIMEOUT_MAX_MS 60000                 /* query: largest TIMEOUT_MS */
/* "command LINK MODULE" and "wait=MS" leave the rest of a line's words to the text. */
#define REQP_TEXT_WORDS_MAX     (CTLP_WORDS_MAX - 4)
/* Room for a message from the encoder or the decoder. */
#define REQP_ERR_MAX            256
/* A sync-clocks DATA line: "ADDR timed-out" + NUL. */
#define REQP_SYNC_RESULT_SIZE   (CIRCE_ADDRESS_LEN + sizeof(" timed-out"))

/* ---- Requests ----------------------------------------------------------------------------- */

enum reqp_kind {
        REQP_PING,
        REQP_STATS,
        REQP_RECORD,
        REQP_QUERY,                     /* SharedLink Q to a peer */
        REQP_COMMAND,                   /* SharedLink (Pronto4) module command E<module>|D<text> */
        REQP_PEER_PING,                 /* SharedLink P0 to a peer, timed until its G0 */
        REQP_CIRCE_ALERT,               /* CIRCE operations a controller sends ... */
        REQP_CIRCE_NETWORK_SETUP,
        REQP_CIRCE_DEVICE_SETUP,
        REQP_CIRCE_SYNC_CLOCKS,
        REQP_CIRCE_VISUALIZE,
        REQP_CIRCE_EMULATE_ACTION,      /* ... and what a mediator emulator is told to report */
        REQP_KIND_COUNT
};

/* The shape of a request's successful reply (a failure is always one ERR line). */
enum reqp_reply {
        REQP_REPLY_OK,                  /* "OK" */
        REQP_REPLY_PING,                /* "OK <pid> <epoch>": the daemon and its tables' epoch */
        REQP_REPLY_VALUE,               /* "OK <value>": the peer's answer, maybe empty */
        REQP_REPLY_RTT,                 /* "OK <ns>": a ping's round trip, decimal nanoseconds */
        REQP_REPLY_LINES,               /* "DATA <text>" lines of counters, then "OK" */
        REQP_REPLY_RECORDING,           /* "DATA <line>" of a recording, open-ended */
        REQP_REPLY_SYNC,                /* "DATA <ADDR> succeeded|timed-out" per device, "OK" */
};

struct reqp_query {
        char peer[REQP_PEER_SIZE];      /* the node asked, "A".."P" */
        char name[REQP_NAME_SIZE];      /* its variable */
        bool has_timeout;
        uint32_t timeout_ms;            /* 1..REQP_QUERY_TIMEOUT_MAX_MS; else the daemon's */
};

struct reqp_peer_ping {
        char peer[REQP_PEER_SIZE];      /* the node pinged, "A".."P" */
        bool has_timeout;
        uint32_t timeout_ms;            /* 1..REQP_QUERY_TIMEOUT_MAX_MS; else the daemon's */
};

struct reqp_command {
        char module[REQP_MODULE_SIZE];  /* slp_name_check() */
        char text[REQP_TEXT_SIZE];      /* wire charset, words separated by single spaces */
};

/* One request. Start one with reqp_init(): what a kind does not use stays zero. */
struct reqp_request {
        enum reqp_kind kind;
        char link[REQP_LINK_SIZE];      /* every kind but ping and stats */
        uint32_t wait_ms;               /* query, command, circe: 0..CTLP_WAIT_MAX_MS, 0 none */
        union {
                struct reqp_query query;
                struct reqp_command command;
                struct reqp_peer_ping ping;
                /* circe: the packet a controller sends (op set by the kind); emulate action: the
                 * Notify Action the emulated device reports (origin: the device). */
                struct circe_msg circe;
        } u;
};

/* Empties r and makes it a request of kind. */
void reqp_init(struct reqp_request *r, enum reqp_kind kind);

/* The request's words before its arguments, for messages: "ping", "query", "alert",
 * "emulate action" (a CIRCE operation by its own name). "?" for no kind. */
const char *reqp_name(enum reqp_kind kind);

/* Its first word ("query", "circe"): the daemon routes a request on a link by it. */
const char *reqp_verb(enum reqp_kind kind);

/* Whether the request names a link (its second word); those take wait=MS too. */
bool reqp_has_link(enum reqp_kind kind);

/* Whether kind is a CIRCE operation for a controller (true) or a mediator emulator (false). */
bool reqp_circe_for_controller(enum reqp_kind kind);

/* The shape of its successful reply. */
enum reqp_reply reqp_reply_shape(enum reqp_kind kind);

/* ---- The library's side: fill, then encode ------------------------------------------------- */

/*
 * Sets r's link: 1..REQP_LINK_SIZE - 1 bytes of printable ASCII without space. 0, or -EINVAL
 * with the reason in err (NUL-terminated, cut to errsz; err may be NULL with errsz 0). r is
 * unchanged on failure; so for every setter.
 */
int reqp_set_link(struct reqp_request *r, const char *link, char *err, size_t errsz);

/*
 * Sets the argument called key (the table's name: "address", "peer", "variable name", "module",
 * "command text", "destination", ...) from its text, checked the way the decoder checks the word:
 * "bad KEY ...: ... expected" in err. A destination list takes one address per call.
 */
int reqp_set_text(struct reqp_request *r, const char *key, const char *text, char *err,
                  size_t errsz);

/*
 * Sets the numeric argument called key ("roles", "membership" 0 leave 1 join, "current",
 * "start-timer" 0 or 1, "keys", "sensor-time", "timeout", ...) checked against its range before it
 * is narrowed to its field: "bad KEY V: MIN..MAX expected" in err.
 */
int reqp_set_number(struct reqp_request *r, const char *key, long value, char *err,
                    size_t errsz);

/*
 * Writes r as one request line (words of control.h, no '\n') and a NUL into buf; every argument
 * is checked first as the decoder would. Returns the length, or -EINVAL (a value the decoder
 * refuses, a kind that does not exist, a mandatory argument missing) with the reason in err,
 * -EMSGSIZE (more than CTLP_LINE_MAX - 1 bytes or CTLP_WORDS_MAX words), -ENOBUFS (size).
 */
int reqp_encode(const struct reqp_request *r, char *buf, size_t size, char *err, size_t errsz);

/* ---- The daemon's side: decode ------------------------------------------------------------- */

/*
 * Decodes the words of one request (argv[0..argc), as ctlp_request_split() gives them) into
 * *ret, checking every argument. Returns 0, or -EINVAL with a one-line reason in err (unknown
 * request, usage, a bad argument); *ret is written only on success.
 */
int reqp_decode(int argc, char *const *argv, struct reqp_request *ret, char *err, size_t errsz);

/* ---- Replies ------------------------------------------------------------------------------ */

/* Writes a sync-clocks result "ADDR succeeded|timed-out" (size >= REQP_SYNC_RESULT_SIZE). */
void reqp_sync_result_format(char *buf, size_t size, uint32_t address, bool succeeded);

/* Parses the text of a sync-clocks DATA line; 0 or -EPROTO. */
int reqp_sync_result_parse(const char *text, uint32_t *ret_address, bool *ret_succeeded);

#endif
