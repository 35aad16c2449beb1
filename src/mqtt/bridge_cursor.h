/*
 * The event cursor on disk: where the bridge stands in the daemon's event ring, so that a
 * restarted bridge neither loses nor repeats an event.
 *
 * One line, "sharedlink-mqtt-cursor 1 EPOCH CURSOR SEQ\n" (epoch in hex: the daemon run the
 * cursor belongs to; CURSOR is the library's opaque event cursor after event SEQ). It is
 * replaced atomically: written to "<file>.tmp", then rename(2)d over the file, so a reader sees
 * the old line or the new one, never half of one.
 *
 * fsync policy: a rename without fsync survives a crash or kill of the bridge (the page cache
 * belongs to the kernel), which is what "a bridge restart" needs. Surviving a power loss needs
 * the data on the disk: bridge_cursor_store(..., sync=true) fsyncs the file before the rename and
 * the directory after it. The bridge asks for that at most every cursor_sync_ms and on a clean
 * stop; the cursor only ever trails what the broker acknowledged, so a power loss can repeat the
 * events of at most that interval, never lose one.
 */
#ifndef SHAREDLINK_MQTT_BRIDGE_CURSOR_H
#define SHAREDLINK_MQTT_BRIDGE_CURSOR_H

#include <stdbool.h>
#include <stdint.h>

struct bridge_cursor {
        uint64_t epoch;                 /* daemon epoch of the run the cursor belongs to */
        uint64_t cursor;                /* sl_events_read cursor after event seq */
        uint64_t seq;                   /* the last event acknowledged by the broker */
};

/* Reads path into *ret: 0, -ENOENT (no cursor yet), -EBADMSG (not a cursor file) or -errno. */
int bridge_cursor_load(const char *path, struct bridge_cursor *ret);

/* Replaces path atomically with c (fsync of file and directory when sync). 0 or -errno. */
int bridge_cursor_store(const char *path, const struct bridge_cursor *c, bool sync);

#endif
