/*
 * sharedlink-mqtt: what goes on the wire, as pure functions (no I/O, no allocation): topics, the
 * JSON of metadata, events and errors, and the checks of what arrives on a set/ topic. Unit
 * tested on their own (tests/unit/test_bridge_format.c).
 *
 * Topics, under base = "<prefix>/<instance>":
 *   base/<name>             a variable's value text (retained)
 *   base/<name>/meta        its metadata as JSON (retained)
 *   base/events/<link>      events of a link (JSON, QoS events_qos); base/events for none
 *   base/set/<name>         writes to an outbound variable (subscribed)
 *   base/set/<name>/error   the bridge's answer to a refused write (JSON)
 *   base/links/<link>       a link's state name (retained)
 *   base/status             online / offline (retained; "offline" is the last will)
 *   base/bridge             the bridge's counters (JSON, retained)
 */
#ifndef SHAREDLINK_MQTT_BRIDGE_FORMAT_H
#define SHAREDLINK_MQTT_BRIDGE_FORMAT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <sharedlink.h>

#define BRIDGE_TOPIC_MAX        512     /* bytes of a topic + NUL */

/* The bridge's own topic words under base (the only place they are spelled): each is also a
 * name no variable or link can publish under (bridge_format_name_ok). */
#define BRIDGE_TOPIC_SET        "set"
#define BRIDGE_TOPIC_EVENTS     "events"
#define BRIDGE_TOPIC_LINKS      "links"
#define BRIDGE_TOPIC_STATUS     "status"
#define BRIDGE_TOPIC_BRIDGE     "bridge"
/* ... and the words after a name: base/<name>/meta, base/set/<name>/error. */
#define BRIDGE_TOPIC_META       "meta"
#define BRIDGE_TOPIC_ERROR      "error"
#define BRIDGE_TOPIC_ALL        "#"     /* the MQTT multi-level wildcard: base/set/# */
/* base/status: its two payloads (retained; "offline" is also the last will) and their QoS. */
#define BRIDGE_STATUS_ONLINE    "online"
#define BRIDGE_STATUS_OFFLINE   "offline"
#define BRIDGE_STATUS_QOS       1
#define BRIDGE_JSON_MAX         1024    /* bytes of one JSON payload + NUL */
#define BRIDGE_SET_PAYLOAD_MAX  (SL_VALUE_SIZE - 1)

/* Why a set/ message was refused (bridge_format_refusal names them). */
enum bridge_refusal {
        BRIDGE_REFUSE_NONE,
        BRIDGE_REFUSE_TOPIC,            /* not base/set/<one level> */
        BRIDGE_REFUSE_UNKNOWN,          /* no such variable */
        BRIDGE_REFUSE_INBOUND,          /* an inbound variable: read only */
        BRIDGE_REFUSE_NOT_WRITABLE,     /* outbound, but not in writable: */
        BRIDGE_REFUSE_TOO_LONG,         /* payload over the value size */
        BRIDGE_REFUSE_NOT_UTF8,         /* payload is not UTF-8 */
        BRIDGE_REFUSE_BAD_VALUE,        /* the library refused the text (-EINVAL) */
        BRIDGE_REFUSE_FAILED,           /* the write failed (no daemon, no permission, busy) */
        BRIDGE_REFUSE_RETAINED,         /* a retained message: never a write */
        BRIDGE_REFUSE_QUEUED,           /* it waited in the broker while the bridge was away */
        BRIDGE_REFUSE_COUNT
};

/* "<base>/<a>[/<b>]" into buf (BRIDGE_TOPIC_MAX); b may be NULL. 0 or -ENAMETOOLONG. */
int bridge_format_topic(char *buf, size_t size, const char *base, const char *a, const char *b);

/* 1 when a variable or link name can be a topic level under base: a name the tables can hold
 * (1..47 bytes of letters, digits, _ . -: slp_name_byte, the one rule of every name) and not one
 * of the bridge's own words (set, events, links, status, bridge); 0 otherwise. */
int bridge_format_name_ok(const char *name);

/*
 * Splits a topic received under base/set/: returns 1 and the variable name in ret_name
 * (SL_NAME_SIZE) for "base/set/<name>", 0 for the bridge's own "base/set/<name>/error" replies
 * (to be ignored; <name> a name the bridge could answer for), -EINVAL for anything else (other
 * levels, a name too long or not allowed: wildcards, not UTF-8, control characters).
 */
int bridge_format_set_topic(const char *base, const char *topic, char *ret_name);

/* Checks a set/ payload before it goes to sl_write: BRIDGE_REFUSE_NONE, _TOO_LONG, _NOT_UTF8
 * or _BAD_VALUE (a NUL byte). */
enum bridge_refusal bridge_format_check_value(const void *payload, size_t len);

/* A short English reason, e.g. "an inbound variable is read only". */
const char *bridge_format_refusal(enum bridge_refusal r);

/* {"error":"<reason>","name":"...","code":"...","detail":"..."} for base/set/<name>/error,
 * detail being why (NULL: sl_strerror(err) when err < 0, else none); its length or -ENOBUFS. */
int bridge_format_error(char *buf, size_t size, const char *name, enum bridge_refusal r,
                        int err, const char *detail);

/* The metadata JSON of a variable: valid, stale, age_ms, seq, time_ns, direction, type, link,
 * peer, repaired. link_name may be "". Its length or -ENOBUFS. */
int bridge_format_meta(char *buf, size_t size, const struct sl_var_info *info,
                       const struct sl_meta *meta, const char *link_name);

#endif
