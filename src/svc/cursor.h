/*
 * The event cursor on disk: where a client daemon (sharedlink-mqtt, sharedlink-ros2) stands in
 * sharedlinkd's event ring, so that a restarted daemon neither loses nor repeats an event.
 *
 * One line, "OWNER-cursor 1 EPOCH CURSOR SEQ\n" (OWNER the program, e.g. "sharedlink-mqtt", so
 * that one program never takes another's file for its own; epoch in hex: the daemon run the
 * cursor belongs to; CURSOR is the library's opaque event cursor after event SEQ). It is
 * replaced atomically: written to "<file>.tmp", then rename(2)d over the file, so a reader sees
 * the old line or the new one, never half of one.
 *
 * fsync policy: a rename without fsync survives a crash or kill of the program (the page cache
 * belongs to the kernel), which is what "a restart" needs. Surviving a power loss needs the data
 * on the disk: cursor_store(..., sync=true) fsyncs the file before the rename and the directory
 * after it. When to ask for it is the caller's policy (sharedlink-mqtt: at most every
 * cursor_sync_ms and on a clean stop; docs/mqtt.md, docs/ros2.md).
 */
#ifndef SHAREDLINK_SVC_CURSOR_H
#define SHAREDLINK_SVC_CURSOR_H

#include <stdbool.h>
#include <stdint.h>

#define CURSOR_SUFFIX           ".cursor"       /* of a default file name */

struct cursor {
        uint64_t epoch;                 /* daemon epoch of the run the cursor belongs to */
        uint64_t cursor;                /* sl_events_read cursor after event seq */
        uint64_t seq;                   /* the last event done with (published, acknowledged) */
};

/* Reads owner's cursor in path into *ret: 0, -ENOENT (no cursor yet), -EBADMSG (not a cursor
 * file of owner's) or -errno. */
int cursor_load(const char *path, const char *owner, struct cursor *ret);

/* Replaces path atomically with owner's cursor c (fsync of file and directory when sync).
 * 0 or -errno. */
int cursor_store(const char *path, const char *owner, const struct cursor *c, bool sync);

#endif
