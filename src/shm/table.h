/*
 * Daemon side of the shared-memory tables of one instance: creates /sharedlink.<instance>.in and
 * .out (layout.h), publishes inbound values in batches, keeps the directory, link state, counters,
 * heartbeat and event ring, and reads what clients wrote to .out as hostile input.
 *
 * One thread (the daemon's poll loop) calls everything here; the only other thread is the optional
 * wake thread, which touches nothing but its eventfd (wake.h).
 *
 * Typical engine use:
 *     shm_table_begin(t);                          one frame decoded
 *     shm_table_set(t, id, "40.12", 5);            ... for each value in it
 *     shm_table_commit(t);                         one change-word bump + one FUTEX_WAKE
 *     poll(... shm_table_out_wake_fd(t) ...);      readable after a client write
 *     shm_table_out_wake_ack(t); shm_table_out_scan_touched(t, on_change, engine);
 *     shm_table_out_scan(t, on_change, engine);    at every heartbeat: every slot
 */
#ifndef SHM_TABLE_H
#define SHM_TABLE_H

#include <stdarg.h>
#include <stdint.h>
#include <sys/types.h>

#include "shm/layout.h"

/* One variable, as the daemon declares it (config) or adds it at run time (ad hoc). */
struct shm_var {
        const char *name;               /* unique within the instance, shm_layout_name_check */
        unsigned direction;             /* SHM_DIR_IN or SHM_DIR_OUT */
        unsigned type;                  /* SHM_TYPE_* */
        uint32_t link;                  /* link index, or SHM_LINK_NONE */
        const char *peer;               /* NULL or "" when none; < SHM_PEER_SIZE bytes */
        int32_t position;               /* place in the peer's list, or SHM_POSITION_NONE */
};

/* One link, as declared at creation or added later. */
struct shm_link_def {
        const char *name;               /* < SHM_LINK_NAME_SIZE bytes */
        const char *protocol;           /* "sharedlink", "circe", ...; may be NULL */
};

struct shm_table_config {
        const char *instance;           /* shm_layout_instance_check */
        const struct shm_var *vars;     /* ids are indices into this array */
        uint32_t nvars;
        const struct shm_link_def *links;
        uint32_t nlinks;                /* <= SHM_LINKS_MAX */
        uint32_t adhoc_capacity;        /* room for names added at run time (either direction) */
        uint32_t out_spare;             /* .out slots kept for outbound names added at run time
                                         * (lists learned from a peer); they also take room
                                         * from adhoc_capacity */
        uint32_t event_capacity;        /* 0: SHM_EVENTS_DEFAULT; rounded up to a power of two */
        uint32_t heartbeat_interval_ms; /* how often the daemon calls shm_table_heartbeat; 0: never */
        int has_group;                  /* 1: .in 0640 and both objects owned by `gid` */
        gid_t gid;
        const char *control_socket;     /* published in the header (layout 1.2): absolute,
                                         * < SHM_SOCKET_PATH_SIZE bytes; NULL: none */
};

/*
 * A slot held by a writer that kill() says exists is taken over once the same odd word was found
 * by SHM_TABLE_HELD_SCANS periodic scans (shm_table_out_scan: one per heartbeat) and
 * SHM_TABLE_HELD_HEARTBEATS heartbeat intervals have passed since the first. A write section is
 * a dozen stores, well under a microsecond; it lasts longer only while its writer is off the CPU:
 * preempted (tens of ms on a busy machine, a few hundred at worst), stopped (SIGSTOP, a
 * debugger), killed with its pid since reused, or it is a forged word naming a live pid (pid 1,
 * a hostile client's own), which nothing else would ever clear. Two heartbeats (sharedlinkd's:
 * 2 s) are an order of magnitude above the longest preemption, and both bounds run on the
 * daemon's own clock and scans: a daemon starved of CPU as well only takes longer. A writer
 * misjudged all the same loses its write (its publish returns -ECANCELED); it never gets a torn
 * value accepted. The scan count alone rules without a heartbeat (heartbeat_interval_ms 0).
 */
#define SHM_TABLE_HELD_SCANS            3u
#define SHM_TABLE_HELD_HEARTBEATS       2u

/* What the outbound scan found in one slot. */
enum shm_out_status {
        SHM_OUT_CHANGED,                /* a new, valid value */
        SHM_OUT_INVALID,                /* changed, but not a valid value (bad bytes, length...) */
        SHM_OUT_REPAIRED,               /* its writer died, or stalled past the bound,
                                         * mid-write: value discarded (taken_over) */
};

struct shm_out_change {
        uint32_t id;                    /* variable id */
        enum shm_out_status status;
        const char *name;               /* the variable's, valid during the call */
        uint32_t writer_pid;            /* as claimed by the lock word: informational only */
        uint32_t taken_over;            /* REPAIRED only: 1 when kill() found writer_pid alive
                                         * (stopped, a reused pid, a forged word) and the slot
                                         * was taken over after it stayed held past the bound */
        uint64_t mono_ns;               /* the writer's time stamps (CHANGED only) */
        uint64_t real_ns;
        uint32_t length;                /* CHANGED only */
        char value[SHM_VALUE_SIZE];     /* CHANGED only; NUL-terminated, validated */
};

/* Called once per changed outbound slot by shm_table_out_scan. */
typedef void (*shm_table_out_fn)(void *userdata, const struct shm_out_change *change);

struct shm_table;

/*
 * Creates both objects (O_CREAT|O_EXCL, modes 0644/0640 and 0660). An object left by a dead daemon
 * is marked closed (its clients wake and reopen) and replaced; one whose daemon is alive is not:
 * -EBUSY. Other errors: -EINVAL (config), -EEXIST (duplicate name), -EACCES/-EPERM, -ENOMEM.
 */
int shm_table_create(const struct shm_table_config *cfg, struct shm_table **ret_table);

/* Clean shutdown: marks .in closed, wakes waiters, unlinks both objects, frees. NULL-safe. */
struct shm_table *shm_table_destroy(struct shm_table *t);

/* Epoch of this table (new at every creation, never 0). */
uint64_t shm_table_epoch(const struct shm_table *t);

/* Number of variables (configured + ad hoc); ids are 0..count-1. */
uint32_t shm_table_count(const struct shm_table *t);

/* Id of the variable called name, or -ENOENT. */
int shm_table_find(const struct shm_table *t, const char *name);

/* Direction (SHM_DIR_*) of variable id, or -ENOENT. */
int shm_table_direction(const struct shm_table *t, uint32_t id);

/* Starts a batch of inbound updates stamped with the current time. */
void shm_table_begin(struct shm_table *t);

/* Starts a batch whose updates carry these time stamps (CLOCK_MONOTONIC, CLOCK_REALTIME). */
void shm_table_begin_at(struct shm_table *t, uint64_t mono_ns, uint64_t real_ns);

/*
 * Copies the value of variable id as published in .in (for an outbound variable: the last value
 * accepted from a client) into buf, NUL-terminated. Returns its length (0, and no SHM_SLOT_VALID
 * in *ret_flags, when never set), -ENOENT or -ENOBUFS (size < length + 1). ret_flags may be NULL.
 */
int shm_table_get(const struct shm_table *t, uint32_t id, char *buf, size_t size,
                  uint32_t *ret_flags);

/*
 * Sets variable id to value[0..len) (valid, fresh). Outside a batch it is a batch of its own.
 * Returns 0, -ENOENT (id) or -EINVAL (more than 63 bytes, or a byte outside the wire charset).
 */
int shm_table_set(struct shm_table *t, uint32_t id, const char *value, size_t len);

/* shm_table_set with a NUL-terminated value. */
int shm_table_set_str(struct shm_table *t, uint32_t id, const char *value);

/* Marks variable id stale (stale != 0) or fresh again; 0 or -ENOENT. */
int shm_table_set_stale(struct shm_table *t, uint32_t id, int stale);

/* Marks every inbound variable of a link stale or fresh; returns how many changed, or -EINVAL. */
int shm_table_set_link_stale(struct shm_table *t, uint32_t link, int stale);

/*
 * Ends a batch: if anything changed, bumps the change word once (release) and issues one shared
 * FUTEX_WAKE. Returns 1 if it published, 0 if the batch was empty.
 */
int shm_table_commit(struct shm_table *t);

/*
 * Adds a variable at run time: bumps the directory generation and publishes a change. An outbound
 * one takes a spare .out slot (shm_table_config.out_spare) that clients may write from then on.
 * A retired entry of the same direction is given to the name first (shm_table_retire).
 * Returns the new id, -ENOSPC when the ad hoc room (or, outbound, the spare slots) is used up,
 * -EEXIST or -EINVAL.
 */
int shm_table_add(struct shm_table *t, const struct shm_var *v);

/*
 * Retires a variable added at run time (shm_table_add): its name is gone (find, set and clients
 * no longer know it: layout.h, 1.5) and its entry, with its .out slot, goes to the next name
 * added in its direction. 0, -ENOENT (no such variable, or retired already) or -EPERM (a
 * configured variable: those stay for the table's life).
 */
int shm_table_retire(struct shm_table *t, uint32_t id);

/* Adds a link; returns its index, -ENOSPC (SHM_LINKS_MAX) or -EINVAL. */
int shm_table_link_add(struct shm_table *t, const struct shm_link_def *def);

/*
 * Sets a link's state (a small integer and its text, e.g. "up" or "down: FILE:LINE: message", cut
 * at SHM_LINK_TEXT_SIZE - 1 bytes; shm_link.state_name gets its first 31) and publishes a change.
 * 0 or -EINVAL.
 */
int shm_table_link_state(struct shm_table *t, uint32_t link, uint32_t state, const char *name);

/* Adds delta to counter c of a link (SHM_LINK_NONE: the daemon-wide counters). */
void shm_table_counter_add(struct shm_table *t, uint32_t link, enum shm_counter c, uint64_t delta);

/* Sets counter c of a link (SHM_LINK_NONE: daemon-wide). */
void shm_table_counter_set(struct shm_table *t, uint32_t link, enum shm_counter c, uint64_t value);

/* Reads counter c of a link (SHM_LINK_NONE: daemon-wide); 0 for a bad index. */
uint64_t shm_table_counter_get(const struct shm_table *t, uint32_t link, enum shm_counter c);

/* Refreshes the heartbeat (CLOCK_MONOTONIC). */
void shm_table_heartbeat(struct shm_table *t);

/*
 * Appends an event ("key=value ..." text, cut at SHM_EVENT_TEXT_SIZE - 1 bytes) and publishes a
 * change (inside a batch: at commit). Returns the event's number (>= 1).
 */
uint64_t shm_table_event(struct shm_table *t, enum shm_event_type type, uint32_t link,
                         const char *text);

/* shm_table_event with printf formatting. */
uint64_t shm_table_eventf(struct shm_table *t, enum shm_event_type type, uint32_t link,
                          const char *fmt, ...) __attribute__((format(printf, 4, 5)));

/*
 * Scans .out for slots changed since the last scan: copies each out (under the SIGBUS guard),
 * validates the copy, mirrors accepted values into their .in slot, repairs slots left odd by a
 * writer that no longer exists, skips (and counts) slots a live writer holds, takes over (repairs
 * and counts out_taken_over) one held under the same odd word for 3 of these scans and 2
 * heartbeat intervals whatever its pid, and calls fn once per changed slot. Never waits on a
 * client-controlled word. Only these scans, at the heartbeat's pace, move a held slot towards
 * being taken over: shm_table_out_scan_touched's come at the pace of clients' writes.
 * Returns the number of changes reported, or -EBADMSG when the object was truncated or its header
 * overwritten: it was then recreated empty (clients reopen it) and the scan is void.
 * Call it when the wake fd is readable, and also on a periodic timer (the daemon: every
 * heartbeat): a writer that died mid-write never bumps the change word, and a client that
 * truncated .out under everyone may leave no client able to wake the daemon, so only a later scan
 * repairs the slot or recreates the object.
 */
int shm_table_out_scan(struct shm_table *t, shm_table_out_fn fn, void *userdata);

/*
 * shm_table_out_scan of the slots writers marked in the touched map (layout 1.6) since the last
 * scan, and of those a scan found held or churning: what a wake-up costs grows with the writes,
 * not with the table (at most the map's words and every slot, whatever a client scribbled).
 * Every slot, as shm_table_out_scan, when the change word says a client before 1.6 wrote. A
 * write whose mark was lost (its writer killed before it marked, the map scribbled) is found by
 * the next shm_table_out_scan: call that on the periodic timer. Same returns.
 */
int shm_table_out_scan_touched(struct shm_table *t, shm_table_out_fn fn, void *userdata);

/* Replaces .out by a fresh, empty object (clients notice through out_generation). 0 or -errno. */
int shm_table_out_recreate(struct shm_table *t);

/*
 * An eventfd that becomes readable after clients write to .out, or ring the doorbell in .in
 * because .out is unusable (layout 1.3; starts the wake thread on first use; shm_table_destroy
 * stops it). Returns the fd or -errno.
 */
int shm_table_out_wake_fd(struct shm_table *t);

/* Drains the wake eventfd; 1 if it had been signalled. */
int shm_table_out_wake_ack(struct shm_table *t);

/* CLOCK_MONOTONIC (ns) when the wake thread last signalled its eventfd (0: never, or no thread). */
uint64_t shm_table_out_wake_stamp(const struct shm_table *t);

#endif
