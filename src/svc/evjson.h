/*
 * The JSON of the daemon's events, as every bridge publishes them (sharedlink-mqtt on
 * base/events, sharedlink-ros2 on <namespace>/events): one object per event, and one per notice
 * a bridge makes itself (an overrun of the ring, a daemon restart), so that a consumer reads
 * the same fields whichever bridge it listens to. Built only on <sharedlink.h> and svc/json.
 *
 *   event   {"epoch":"<16 hex>","seq":N,"time_ns":N,"link":"...","type":"...","text":"...",
 *            "fields":{"key":"value",...},"truncated":false}
 *   notice  {"epoch":"<16 hex>","seq":N,"link":"","type":"overrun","lost":N}
 */
#ifndef SHAREDLINK_SVC_EVJSON_H
#define SHAREDLINK_SVC_EVJSON_H

#include <stddef.h>
#include <stdint.h>

#include <sharedlink.h>

#define EVJSON_MAX              4096    /* one event's JSON, escapes and fields included */
#define EVJSON_OVERRUN          "overrun"               /* notice: events lost in the ring */
#define EVJSON_RESTARTED        "daemon-restarted"      /* notice: a new daemon run */

/* The JSON of an event: epoch (hex), seq, time_ns, link, type, text, fields (text split at
 * spaces into key=value), truncated. Its length or -ENOBUFS. */
int evjson_event(char *buf, size_t size, uint64_t epoch, const struct sl_event *ev);

/* The JSON of a notice of the bridge's own (EVJSON_OVERRUN with the number lost,
 * EVJSON_RESTARTED); seq is the number of the event that follows. Its length or -ENOBUFS. */
int evjson_notice(char *buf, size_t size, const char *type, uint64_t epoch, uint64_t seq,
                  uint64_t lost);

#endif
