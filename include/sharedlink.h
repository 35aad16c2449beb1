/*
 * libsharedlink: read and write the shared variables of a running sharedlinkd at memory speed.
 *
 * The daemon publishes what it hears in a POSIX shared-memory table that clients map read-only;
 * clients in the daemon's group write outbound variables into a second table that the daemon reads.
 * Every call returns a negative errno value on failure (sl_strerror explains it); nothing logs,
 * nothing is global, and one handle may be used by many threads at once (sl_close excepted).
 *
 *     #include <sharedlink.h>
 *
 *     struct sl_client *c;
 *     struct sl_meta meta = { .size = sizeof(meta) };
 *     char value[SL_VALUE_SIZE];
 *     uint32_t cursor = 0;
 *     int lat, throttle, r;
 *
 *     r = sl_open(NULL, &c);                   // $SHAREDLINK_INSTANCE, or "default"
 *     if (r < 0) { fprintf(stderr, "sharedlink: %s\n", sl_strerror(r)); return 1; }
 *     lat = sl_find(c, "AutoGpsLat");
 *     throttle = sl_find(c, "CmdThrottle");
 *     for (;;) {
 *             if (sl_read(c, lat, value, sizeof(value), &meta) >= 0 && (meta.flags & SL_FLAG_VALID))
 *                     printf("lat %s (%s)\n", value, meta.flags & SL_FLAG_STALE ? "stale" : "fresh");
 *             sl_write_double(c, throttle, 0.25, 2);   // outbound: sent to the peer by the daemon
 *             sl_wait(c, &cursor, 1000);               // until something changes, or 1 s
 *     }
 *     sl_close(c);
 *
 * Build: cc prog.c $(pkg-config --cflags --libs sharedlink)
 *
 * Ids: sl_find and sl_info give ids 0..sl_count()-1. An id keeps naming the same variable for the
 * life of the handle, also across a daemon restart: the library notices the new table (new epoch),
 * remaps it and re-resolves its ids by name. A variable that the new daemon no longer has reads as
 * -ENOENT; names that are new get new ids. The same holds for a name the daemon retired while it
 * runs (a Pronto4 peer's learned name its new declaration dropped, docs/pronto4.md §4): its id
 * reads as -ENOENT, never as the variable that took its place in the table.
 *
 * Values are text: printable ASCII 0x20-0x7E except '|', '[' and ']', at most 63 bytes (what the
 * wire can carry).
 *
 * Trust: the daemon treats everything clients write as hostile and survives any of it. Writers
 * share one outbound table, so a member of the group that truncates it can make other processes
 * of the group that write (or read outbound variables) fault (SIGBUS) until the daemon has
 * recreated it: at once when a client that opens the table finds it unusable (it wakes the
 * daemon through the read-only table), else at the daemon's next heartbeat (a second). The
 * library installs no signal handlers. Processes outside the group only map the daemon's
 * read-only table and are not exposed to this. The extensible structs below start with a `size` member that the caller sets
 * to sizeof(the struct); the library fills only what fits, so newer fields never break old callers.
 *
 * Commands to the daemon (CIRCE operations, SharedLink queries) go through its control socket:
 * see "Commands" at the end of this header.
 */
#ifndef SHAREDLINK_H
#define SHAREDLINK_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define SL_NAME_SIZE            48      /* variable name buffer: at most 47 bytes + NUL */
#define SL_VALUE_SIZE           64      /* value buffer: at most 63 bytes + NUL */
#define SL_PEER_SIZE            16
#define SL_LINK_NAME_SIZE       32
#define SL_PROTOCOL_SIZE        16
#define SL_STATE_NAME_SIZE      32
#define SL_STATE_TEXT_SIZE      256     /* a link's whole state text + NUL (sl_link_info) */
#define SL_TYPE_NAME_SIZE       24
#define SL_EVENT_TEXT_SIZE      216     /* "key=value ..." + NUL */
#define SL_COUNTERS_MAX         64      /* counters per link (named ones + spare room) */

/* sl_var_info.direction */
#define SL_DIR_IN               0       /* published by the daemon: read only */
#define SL_DIR_OUT              1       /* written by clients, sent by the daemon */

/* sl_var_info.type: how the daemon describes the value on the wire (text in any case) */
#define SL_VAR_STRING           0
#define SL_VAR_LONG             1
#define SL_VAR_DOUBLE           2

/* sl_var_info.flags */
#define SL_VAR_ADHOC            0x1u    /* created at run time, not from the configuration */

/* sl_meta.flags */
#define SL_FLAG_VALID           0x1u    /* a complete value was written (else never set, or lost) */
#define SL_FLAG_STALE           0x2u    /* link down, peer silent, or the daemon is not running
                                         * (its heartbeat is 3 intervals old: 3 s by default) */
#define SL_FLAG_OUTBOUND        0x4u    /* an outbound variable: the value a client wrote */
#define SL_FLAG_REPAIRED        0x8u    /* outbound: its last writer died (or stalled) mid-write */

/* sl_event.flags */
#define SL_EVENT_TRUNCATED      0x1u    /* the text was cut to fit */
#define SL_EVENT_RESTARTED      0x2u    /* first event of a new daemon: the cursor was reset */

struct sl_client;

/* Metadata of a value, filled by the sl_read* functions. */
struct sl_meta {
        size_t size;                    /* set by the caller: sizeof(struct sl_meta) */
        uint64_t mono_ns;               /* time of the last update, CLOCK_MONOTONIC */
        uint64_t real_ns;               /* time of the last update, CLOCK_REALTIME */
        uint64_t age_ns;                /* now - mono_ns (0 if never updated), "now" being the
                                         * kernel's coarse clock: resolution one tick (1-4 ms),
                                         * and it reads 1-2 ticks low; for a finer age, compare
                                         * mono_ns with your own CLOCK_MONOTONIC */
        uint64_t sequence;              /* number of updates so far */
        uint32_t flags;                 /* SL_FLAG_* */
};

/* Description of a variable (sl_info). */
struct sl_var_info {
        size_t size;                    /* set by the caller: sizeof(struct sl_var_info) */
        char name[SL_NAME_SIZE];
        int direction;                  /* SL_DIR_* */
        int type;                       /* SL_VAR_* */
        int link;                       /* link index (sl_link_info), or -1 */
        char peer[SL_PEER_SIZE];        /* peer address, or "" */
        int position;                   /* place in the peer's list, or -1 */
        uint32_t flags;                 /* SL_VAR_* flags */
};

/* One named counter. */
struct sl_counter {
        const char *name;               /* static string, e.g. "frames_in" */
        uint64_t value;
};

/* State and counters of a link (sl_link_info). */
struct sl_link_info {
        size_t size;                    /* set by the caller: sizeof(struct sl_link_info) */
        char name[SL_LINK_NAME_SIZE];
        char protocol[SL_PROTOCOL_SIZE];
        int state;                      /* small integer chosen by the link's engine */
        char state_name[SL_STATE_NAME_SIZE];    /* e.g. "connected" */
        uint64_t state_age_ns;          /* time since the last state change */
        unsigned counter_count;         /* entries used in counters[] */
        struct sl_counter counters[SL_COUNTERS_MAX];
        /* Added after 0.1.0 (an older caller's size stops before it): the whole state text,
         * of which state_name holds the first 31 bytes, e.g. "down: /srv/rec/run.rec:12: bad
         * line" (cut at SL_STATE_TEXT_SIZE - 1) */
        char state_text[SL_STATE_TEXT_SIZE];
};

/* The daemon behind the tables (sl_daemon_info). */
struct sl_daemon_info {
        size_t size;                    /* set by the caller: sizeof(struct sl_daemon_info) */
        int pid;
        int alive;                      /* 1: heartbeat recent and tables current */
        uint64_t epoch;                 /* changes at every daemon start */
        uint64_t heartbeat_age_ns;
        uint32_t heartbeat_interval_ms; /* 0: the daemon does not run a heartbeat */
        uint64_t started_real_ns;       /* CLOCK_REALTIME when the tables were created */
        unsigned counter_count;
        struct sl_counter counters[SL_COUNTERS_MAX];    /* daemon-wide, e.g. "out_invalid" */
};

/* One event (sl_events_read). */
struct sl_event {
        size_t size;                    /* set by the caller: sizeof(struct sl_event) */
        uint64_t seq;                   /* event number, increasing within one daemon run */
        uint64_t lost;                  /* events overwritten before this one could be read */
        uint64_t mono_ns;
        uint64_t real_ns;
        int type;                       /* small integer; type_name is what to print */
        char type_name[SL_TYPE_NAME_SIZE];      /* e.g. "action", "link-state" */
        int link;                       /* link index, or -1 */
        char link_name[SL_LINK_NAME_SIZE];      /* "" when none */
        uint32_t flags;                 /* SL_EVENT_* */
        char text[SL_EVENT_TEXT_SIZE];  /* "key=value ...", e.g. "device=E1E1E1 sensor_time=5000" */
};

/* Opens an instance (NULL: $SHAREDLINK_INSTANCE, else "default"); -ENOENT if it is not running. */
int sl_open(const char *instance, struct sl_client **ret);

/* Closes a handle; NULL-safe; returns NULL. No other call on it may be running. */
struct sl_client *sl_close(struct sl_client *c);

/* Id of the variable called name, or -ENOENT. */
int sl_find(struct sl_client *c, const char *name);

/* Number of ids; ids are 0..count-1 (some may read -ENOENT after a daemon restart). */
int sl_count(struct sl_client *c);

/* Describes variable id into *ret (ret->size set by the caller); 0 or -ENOENT. */
int sl_info(struct sl_client *c, int id, struct sl_var_info *ret);

/*
 * Copies the value of variable id (NUL-terminated) into buf; meta may be NULL. Returns its length
 * (0 and no SL_FLAG_VALID when it was never set), -ENOENT, -ENOBUFS (size < length + 1), or
 * -EAGAIN when its writer stayed in the middle of a write for every bounded attempt and then
 * SL_READ_BUSY_MS of sleeping: a writer that is stopped, or was killed mid-write (the daemon
 * repairs such a slot within a second, and takes one a live process holds over after two
 * heartbeats); try again. A writer that was merely preempted mid-write
 * costs the read a yield or a short sleep, not an error, so a read normally takes nanoseconds and
 * only then up to about SL_READ_BUSY_MS. An outbound variable reads as what was last written to
 * it. On failure buf holds nothing meaningful (a buffer of SL_VALUE_SIZE bytes or more is used as
 * scratch space by the read: the fastest path).
 */
#define SL_READ_BUSY_MS         20      /* sl_read's longest wait for a writer mid-write */

int sl_read(struct sl_client *c, int id, char *buf, size_t size, struct sl_meta *meta);

/* Reads a value as a double; -ENODATA when not valid or empty, -EDOM when not a number. */
int sl_read_double(struct sl_client *c, int id, double *ret, struct sl_meta *meta);

/* Reads a value as a long (decimal); -ENODATA, -EDOM (not an integer) or -ERANGE. */
int sl_read_long(struct sl_client *c, int id, long *ret, struct sl_meta *meta);

/*
 * Writes an outbound variable. Returns 0; -EPERM for an inbound variable; -EINVAL when the value
 * cannot go on the wire (bytes, length) or is not of the variable's type (sl_var_info.type: a
 * long takes [+-] decimal digits within 64 bits, a double a finite decimal number; the table
 * keeps its value, sl_write_check says why); -EACCES when this user may not write (not in the
 * group); -EBUSY when other writers kept the slot for every bounded attempt (a writer stopped
 * mid-write keeps it until the daemon takes it over, after two heartbeats); -ECANCELED when this
 * write was abandoned: this writer was kept from its CPU (stopped, debugged) in the middle of it
 * for that long and the daemon took the slot over; nothing of it is read or sent; -ENOTCONN when
 * no daemon runs.
 */
int sl_write(struct sl_client *c, int id, const char *value);

/*
 * Checks value for id as sl_write does, writing nothing: 0 when sl_write would take it, else the
 * error it would return (-ENOENT, -EPERM, -EINVAL) with one line that says why in reason
 * (reason_size bytes, NULL/0 allowed; "" on success), e.g. "\"abc\" is not a long: ...", ready
 * to show to a user. Since SHAREDLINK_1.3.
 */
#define SL_WRITE_REASON_SIZE    160     /* always holds sl_write_check's whole reason + NUL */

int sl_write_check(struct sl_client *c, int id, const char *value, char *reason,
                   size_t reason_size);

/* Writes v with that many decimals (0..17; < 0: the shortest text that reads back as v). */
int sl_write_double(struct sl_client *c, int id, double v, int decimals);

/* Writes v in decimal. */
int sl_write_long(struct sl_client *c, int id, long v);

/*
 * Waits until the table changed since *cursor (a value from an earlier call; start with 0), at
 * most timeout_ms (< 0: no limit; 0: just check). Returns 1 and updates *cursor when something
 * changed (values, names, links, events, a daemon restart), 0 on timeout, or -errno.
 */
int sl_wait(struct sl_client *c, uint32_t *cursor, int timeout_ms);

/* sl_wait_opts.flags */
#define SL_WAIT_SPIN            0x1u    /* poll the table for up to spin_us before sleeping */
#define SL_WAIT_SPIN_MAX_US     10000   /* the largest spin budget */

/* Options of sl_wait_with. */
struct sl_wait_opts {
        size_t size;                    /* set by the caller: sizeof(struct sl_wait_opts) */
        uint32_t flags;                 /* SL_WAIT_* */
        uint32_t spin_us;               /* SL_WAIT_SPIN: the spin budget, 0..SL_WAIT_SPIN_MAX_US */
};

/*
 * sl_wait with options (opts NULL: exactly sl_wait). With SL_WAIT_SPIN it first polls the table
 * on this CPU for up to spin_us (never past timeout_ms), and sleeps as sl_wait does only if nothing
 * changed by then: a change that comes within the budget is seen without the futex wake-up of the
 * daemon's thread and the scheduler's latency (microseconds on a virtual machine), at the price of
 * a CPU kept busy for the whole spin. For a loop that waits for data due within microseconds; -EINVAL
 * for unknown flags or a budget above SL_WAIT_SPIN_MAX_US. Returns as sl_wait. The spin yields its
 * CPU every 10 us to any other runnable thread there (the daemon and the tty it waits for may need
 * it), and a thread allowed on one CPU only does not spin at all.
 */
int sl_wait_with(struct sl_client *c, uint32_t *cursor, int timeout_ms,
                 const struct sl_wait_opts *opts);

/* sl_changed flags: SL_CHANGED_ALL with the reason(s), or SL_CHANGED_MORE, or 0 */
#define SL_CHANGED_ALL          0x1u    /* read every variable once: the ids do not say it all */
#define SL_CHANGED_START        0x2u    /* ... the cursor was 0 */
#define SL_CHANGED_OVERRUN      0x4u    /* ... the caller fell behind: more changes since the
                                         * cursor than the daemon's record holds */
#define SL_CHANGED_REMAPPED     0x8u    /* ... ids were resolved anew since the cursor: a daemon
                                         * restart, a name retired or reused, or a cursor that is
                                         * not this handle's */
#define SL_CHANGED_UNAVAILABLE  0x10u   /* ... the daemon keeps no change record (older than the
                                         * library), or $SHAREDLINK_CHANGES=all: every call */
#define SL_CHANGED_MORE         0x100u  /* more ids are pending than max: call again */

/*
 * Which variables changed since *cursor (start with 0): their ids, in the order of the changes,
 * into ids[0..max-1]; returns how many (0: none) and advances *cursor past them, or -errno
 * (-EINVAL). A change is anything sl_read would show differently: a value, its flags (valid,
 * stale, repaired), a name that appeared or went away. An id may appear more than once in one
 * answer (it changed more than once): reading it again costs a read, never a wrong value.
 *
 * When *ret_flags has SL_CHANGED_ALL, the ids cannot tell everything (the reasons are the other
 * bits): the caller must read every variable once, then go on from the new *cursor as usual;
 * no ids come with it. That happens for a new cursor, after a daemon restart or a name retired
 * or reused (ids resolved anew), when the caller fell behind the daemon's record (about one
 * change per variable of the table), and always with a daemon older than this library.
 * SL_CHANGED_MORE: not all pending ids fitted; call again.
 *
 * Use it after sl_wait: every change the daemon made before the change sl_wait returned for is
 * in the answer; one made later may be there too, and is anyway in the answer after the next
 * sl_wait, which returns at once for it. So a caller that reads what it is told after each
 * wake-up never holds a value older than the table's at that wake-up. Staleness that comes from
 * the daemon having stopped (no heartbeat: SL_FLAG_STALE on every value) is not a change the
 * daemon records: read everything when sl_daemon_alive changes, or on a timer. A cursor belongs
 * to the handle that gave it. Since SHAREDLINK_1.4.
 */
int sl_changed(struct sl_client *c, uint64_t *cursor, int *ids, size_t max, uint32_t *ret_flags);

/*
 * Reads up to ret_size events after *cursor (start with 0: the oldest retained; or with
 * sl_events_now) into ret[0..ret_size-1], each element's size set by the caller. Returns the
 * number read (0: none new) and advances *cursor. Events are never skipped silently: lost counts
 * the ones overwritten before they could be read. After a daemon restart the first event read
 * from the new daemon carries SL_EVENT_RESTARTED, once, however many calls found nothing before it.
 */
int sl_events_read(struct sl_client *c, uint64_t *cursor, struct sl_event *ret, size_t ret_size);

/* Sets *ret_cursor to "now": sl_events_read then returns only later events. 0 or -errno. */
int sl_events_now(struct sl_client *c, uint64_t *ret_cursor);

/* Number of links. */
int sl_link_count(struct sl_client *c);

/* State and counters of link index link (0..sl_link_count-1); 0, -ENOENT or -EAGAIN. */
int sl_link_info(struct sl_client *c, int link, struct sl_link_info *ret);

/* The daemon's pid, epoch, heartbeat and daemon-wide counters. 0 or -errno. */
int sl_daemon_info(struct sl_client *c, struct sl_daemon_info *ret);

/* 1 when the daemon is running (heartbeat recent, tables current), 0 when not, or -errno. */
int sl_daemon_alive(struct sl_client *c);

/* sl_counter_scope: where a counter is moved */
#define SL_COUNTER_SHAREDLINK   0x1u    /* by SharedLink links */
#define SL_COUNTER_CIRCE        0x2u    /* by CIRCE links */
#define SL_COUNTER_DAEMON       0x4u    /* daemon-wide: the outbound table, the event ring */

/*
 * Where the counter called name is moved: SL_COUNTER_* bits (both link bits for one that every
 * link moves), or 0 for a name this library does not know. A counter outside a link's protocol
 * (or the daemon's) always reads 0 there: for showing only those that apply. Since SHAREDLINK_1.2.
 */
unsigned sl_counter_scope(const char *name);

/* Name of counter i, in the order of the counters of sl_link_info and sl_daemon_info (0, 1, ...),
 * or NULL past the last. Since SHAREDLINK_1.2. */
const char *sl_counter_name(unsigned i);

/* A static English message for a value returned by any sl_* function (negative or not). */
const char *sl_strerror(int err);

/*
 * ---- Commands: the daemon's control socket ------------------------------------------------------
 *
 * SharedLink queries and CIRCE operations go to the daemon over a Unix stream socket,
 * "<runtime_dir>/<instance>.sock": one connection, one request line and one reply per call. A
 * command is a round trip through the daemon (and often the peer): milliseconds, not the
 * nanoseconds of sl_read. Use them for operations, never to poll data.
 *
 * Where the socket is, first that applies: the directory given to sl_set_runtime_dir;
 * $SHAREDLINK_RUNTIME_DIR as it was at sl_open (or at sl_set_runtime_dir(c, NULL)); the socket
 * path the daemon publishes in its tables (table layout 1.2: wherever its configuration or its
 * environment put runtime_dir, so usually nothing needs setting); SL_RUNTIME_DIR_DEFAULT. A
 * published path is used only when it is absolute, NUL-terminated within its field and names
 * "<instance>.sock" of this handle's instance; otherwise, and with an older daemon that publishes
 * none, the default applies.
 *
 * Every argument is checked here before anything is sent, with the ranges of the protocol
 * (PROTOCOLS.md 2.3 for CIRCE): a bad one fails with -EINVAL and nothing reaches the daemon. Each
 * call takes reply/reply_size (NULL/0 allowed): on success it receives the answer's text ("" for
 * most commands; the value for sl_query), on failure one line that says why (the daemon's message,
 * the argument refused here, or what failed locally), ready to show to a user.
 *
 * Errors: -EINVAL (bad argument), -ECONNREFUSED (nobody listens on the socket: the daemon is not
 * running, or uses another runtime directory), -EACCES (this user may not use the socket),
 * -ETIMEDOUT (no complete reply in time), -ECONNRESET (the daemon closed the connection early),
 * -EPROTO (a reply not understood), or the errno of the daemon's answer, e.g. -ENOENT (no such
 * link), -ENOTCONN (the link is down), -EOPNOTSUPP (a command for another protocol or role),
 * -EBUSY.
 */

#define SL_RUNTIME_DIR_DEFAULT  "/run/sharedlink"
#define SL_REQUEST_LINE_MAX     1023    /* bytes of a request line, without its '\n' */
#define SL_REQUEST_WORDS_MAX    32      /* words of a request line */
#define SL_REPLY_LINE_MAX       4095    /* bytes of a reply line, without its '\n' */
#define SL_REQUEST_TIMEOUT_MS   5000    /* sl_request with timeout_ms 0; margin of the others */
#define SL_WAIT_MAX_MS          60000   /* sl_set_command_wait */
#define SL_QUERY_TIMEOUT_MAX_MS 60000   /* sl_query */
#define SL_CIRCE_ADDRESS_SIZE   7       /* "E1E1E1" + NUL: six uppercase hex digits, not FFFFFF */
#define SL_CIRCE_DESTS_MAX      92      /* destinations of one Visualize */
#define SL_COMMAND_TEXT_MAX     63      /* bytes of a module command's text (sl_command) */
#define SL_COMMAND_WORDS_MAX    28      /* space-separated words of that text */

/* Receives the text of one "DATA" line; returns 0 to go on, or a negative errno to stop. */
typedef int (*sl_data_fn)(const char *text, void *arg);

/* Receives one device's result of sl_circe_sync_clocks; returns 0, or a negative errno to stop. */
typedef int (*sl_sync_fn)(const char *addr, int succeeded, void *arg);

/* A CIRCE Visualize (sl_circe_visualize): the destinations and the display fields to set. */
struct sl_circe_visualize {
        size_t size;                    /* set by the caller: sizeof(struct sl_circe_visualize) */
        const char *const *dests;       /* dest_count addresses (1..SL_CIRCE_DESTS_MAX) */
        unsigned dest_count;
        int has_current;                /* set at least one has_* (or start_timer) */
        int current;                    /* current competitor, 0..999 */
        int has_next;
        int next;                       /* next competitor, 0..999 */
        int start_timer;                /* 1: start the timer */
        int has_primary;
        long primary_ms;                /* primary timer, 0..999999 ms */
        int has_secondary;
        long secondary_ms;              /* secondary timer, 0..999999 ms */
        int has_faults;
        int faults;                     /* 0..99 */
        int has_refusals;
        int refusals;                   /* 0..99 */
        int has_eliminated;
        int eliminated;                 /* 0 or 1 */
        int has_placement;
        int placement;                  /* previous placement, 0..999 */
};

/* Sets the control socket's directory (NULL: back to $SHAREDLINK_RUNTIME_DIR, else the path the
 * daemon publishes, else the default). */
int sl_set_runtime_dir(struct sl_client *c, const char *dir);

/* Commands to a link that is down wait up to wait_ms (0..SL_WAIT_MAX_MS) for it; 0: no wait. */
int sl_set_command_wait(struct sl_client *c, int wait_ms);

/*
 * Sends one request line (words of printable ASCII separated by single spaces, no '\n'; see
 * src/proto/control.h) and reads the reply: on_data (may be NULL) gets each DATA line, reply the
 * final text. timeout_ms bounds the whole exchange (0: SL_REQUEST_TIMEOUT_MS; < 0: no limit).
 * Returns 0 on "OK", or a negative errno (above).
 */
int sl_request(struct sl_client *c, const char *line, int timeout_ms, sl_data_fn on_data,
               void *arg, char *reply, size_t reply_size);

/*
 * SharedLink query: asks peer (a node address, "A".."P") on link for its variable name (1 to 47
 * bytes of letters, digits, '_', '.' and '-', as every variable name), waiting at
 * most timeout_ms for the answer (0: the daemon's default; at most SL_QUERY_TIMEOUT_MAX_MS).
 * Returns the value's length with the value in reply, -ENOBUFS when it does not fit, -ETIMEDOUT
 * when the peer did not answer, or another negative errno (above).
 */
int sl_query(struct sl_client *c, const char *link, const char *peer, const char *name,
             int timeout_ms, char *reply, size_t reply_size);

/*
 * SharedLink ping: sends "P0" to peer (a node address, "A".."P") on link and waits at most
 * timeout_ms (0: the daemon's default, 1000 ms; at most SL_QUERY_TIMEOUT_MAX_MS) for its "G0".
 * Returns 0 with the round trip in *ret_rtt_ns (may be NULL; measured by the daemon, from before
 * the send to the pong's arrival), -ETIMEDOUT when no pong came in time, -ENOTCONN (the link is
 * down, or went down while waiting; see sl_set_command_wait), -EBUSY (too many pings pending on
 * the link), -EINVAL (a bad argument, or not a peer of link), or another negative errno (above).
 * Since SHAREDLINK_1.3.
 */
int sl_ping(struct sl_client *c, const char *link, const char *peer, int timeout_ms,
            uint64_t *ret_rtt_ns, char *reply, size_t reply_size);

/*
 * SharedLink module command (Pronto4 dialect, docs/pronto4.md §9): sends "E<module>|D<text>" to
 * the pronto4 peer(s) of link, e.g. module "ServoPod", text "0,TELEOP START"; a bare module
 * request (module "MUI", "MUO", "ML" or "MW", text NULL or "") goes out bare, "MUI". module: 1..63
 * letters, digits, '_', '.', '-'; text (NULL = ""): at most SL_COMMAND_TEXT_MAX bytes of
 * 0x20-0x7E without '|', '[' or ']', words separated by single spaces (no leading, trailing or
 * double space: the request line splits on spaces), at most SL_COMMAND_WORDS_MAX words. Returns
 * 0 once the frame is queued, -EINVAL for a bad argument (nothing sent), -ENOTCONN (the link is
 * down; see sl_set_command_wait), -EOPNOTSUPP (the link has no pronto4 peer), or another negative
 * errno (above). Since SHAREDLINK_1.1.
 */
int sl_command(struct sl_client *c, const char *link, const char *module, const char *text);

/* CIRCE Alert: makes device addr signal itself. 0 or a negative errno. */
int sl_circe_alert(struct sl_client *c, const char *link, const char *addr, char *reply,
                   size_t reply_size);

/* CIRCE Network Setup: device addr joins (join 1) or leaves (0) the network with roles 0..127. */
int sl_circe_network_setup(struct sl_client *c, const char *link, const char *addr, int join,
                           int roles, char *reply, size_t reply_size);

/* CIRCE Device Setup: assigns address assign to the device at dest (if has_dest; else the
 * unconfigured one), with capabilities 0..127 if has_caps. */
int sl_circe_device_setup(struct sl_client *c, const char *link, const char *assign, int has_dest,
                          const char *dest, int has_caps, int caps, char *reply,
                          size_t reply_size);

/* CIRCE Synchronize Clocks: on_result (may be NULL) gets each device's outcome, then 0 returns. */
int sl_circe_sync_clocks(struct sl_client *c, const char *link, sl_sync_fn on_result, void *arg,
                         char *reply, size_t reply_size);

/* CIRCE Visualize: shows v's fields on v's displays. 0 or a negative errno. */
int sl_circe_visualize(struct sl_client *c, const char *link, const struct sl_circe_visualize *v,
                       char *reply, size_t reply_size);

/* Mediator role (emulator): makes emulated device addr report an action (input keys 0..65535,
 * sensor time 0..999999 ms, each when its has_* is set). */
int sl_circe_emulate_action(struct sl_client *c, const char *link, const char *addr, int has_keys,
                            int keys, int has_sensor_time, long sensor_time_ms, char *reply,
                            size_t reply_size);

#ifdef __cplusplus
}
#endif

#endif
