/*
 * Following what changed in the tables (sl_changed) after each wake-up, for a daemon that is a
 * client of sharedlinkd and republishes variables (sharedlink-mqtt, sharedlink-ros2): it reads
 * only the variables the daemon's change record names, and every one when the library says the
 * ids cannot tell it all. Built only on <sharedlink.h>.
 *
 * Why a value read this way is never older than the table's at the wake-up: the cursor moves
 * (sl_changed) before the caller reads what it names, so each read returns the change it was
 * told of or a later one. A change that lands after the call, even between it and the read, has
 * its entry past the cursor and its change word bump after the waker's sl_wait returned: the
 * waker wakes again at once and the next call hands it out (read twice, it is the same update:
 * the caller compares with what it published).
 */
#ifndef SVC_CHANGES_H
#define SVC_CHANGES_H

#include <stdbool.h>
#include <stdint.h>

#include <sharedlink.h>

#define CHANGES_BATCH           256     /* ids taken from sl_changed at a time */
#define CHANGES_ROUNDS          64      /* batches of one call before "read everything" */

struct changes {
        uint64_t cursor;                /* sl_changed's; 0 to start (everything, once) */
        int ids[CHANGES_BATCH];
};

/* Receives one id that changed; 0 to go on, or a negative errno to stop. */
typedef int (*changes_fn)(void *arg, int id);

/*
 * Hands fn each id that changed since the last call on ch. Returns 0 when that was all; 1 when
 * the caller must read every variable now (sl_changed said so: a first call, a daemon restart,
 * names retired, a caller that fell behind, an older daemon; or it failed; or more than
 * CHANGES_ROUNDS batches were pending); or the negative value fn returned, the ids after it
 * lost: the caller must then read everything at its next scan. With skip the cursor moves to
 * now and fn is not called (the caller reads everything anyway); it returns 1.
 */
int changes_follow(struct changes *ch, struct sl_client *c, bool skip, changes_fn fn, void *arg);

#endif
