/*
 * Waiting for a value through the real client library, as a client would: the change word
 * (sl_wait) between looks, never a sleep, always with a timeout. Plain C, no cmocka: the caller
 * decides what a timeout means.
 */
#ifndef TESTS_SLWAIT_H
#define TESTS_SLWAIT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <sharedlink.h>

#define SLWAIT_SLICE_MS 100     /* the longest sl_wait between two looks */

/* Whether the variable name exists and reads want (as text) now. */
bool slwait_value_is(struct sl_client *c, const char *name, const char *want);

/* Waits until name reads want; 0, or -ETIMEDOUT after timeout_ms with the last text read in
 * last (lastsz bytes, 0 for none; "" when it never read). */
int slwait_value(struct sl_client *c, const char *name, const char *want, int timeout_ms,
                 char *last, size_t lastsz);

/* Waits until link (an index) has a state name that starts with prefix ("up"); 0, or
 * -ETIMEDOUT after timeout_ms. */
int slwait_link_state(struct sl_client *c, int link, const char *prefix, int timeout_ms);

/* The daemon's change record (sl_changed) through c: a cursor at its head now into *ret_cursor;
 * 0, or -errno (-EPROTO: c had taken a cursor before, which the first call does not expect). */
int slwait_changes_now(struct sl_client *c, uint64_t *ret_cursor);

/* 1 when the daemon made more changes since cursor than its change record holds, 0 when not,
 * or -errno. The cursor is not moved. */
int slwait_changes_overrun(struct sl_client *c, uint64_t cursor);

#endif
