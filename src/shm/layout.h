/*
 * Shared-memory layout of one sharedlink instance, defined once for the daemon and the library.
 *
 * Two POSIX shm objects per instance:
 *   /sharedlink.<instance>.in   the daemon writes, clients map PROT_READ (mode 0644, 0640 with a group)
 *   /sharedlink.<instance>.out  clients in the group write, the daemon reads (mode 0660)
 *
 * .in:   [struct shm_in_header][struct shm_link x SHM_LINKS_MAX][struct shm_event x event_capacity]
 *        [struct shm_dir_entry x capacity][struct shm_slot x capacity]
 * .out:  [struct shm_out_header][struct shm_slot x out_capacity]
 *
 * Every region starts on a cache line; the header records every offset and size, and readers check
 * them against the size of the object before touching anything past the header. Fields are fixed
 * width integers or char arrays (no bool, enum, pointer or float): the .out object is written by
 * clients and is hostile input to the daemon, and a byte that does not fit a C type is undefined
 * behaviour once loaded as that type.
 *
 * A variable's id is its directory index. Its inbound slot has the same index in both directions:
 * for an outbound variable the daemon mirrors there the last value it accepted, so clients outside
 * the group (which cannot map .out) and watchers see it too. Outbound variables also own a slot in
 * .out (dir_entry.out_slot), which is where clients write.
 *
 * Concurrency (see seqlock.h for the fence reasoning):
 *   - header fields without _Atomic are written once before `magic` is release-stored, and never
 *     change afterwards; readers acquire-load `magic` first;
 *   - directory entries and links below `count` / `link_count` are immutable once published: the
 *     daemon fills the entry, then release-stores the count; readers acquire-load the count;
 *   - slots, link state and event records are seqlocked; counters are independent relaxed words.
 *
 * Layout version history (major << 16 | minor; a client refuses another major):
 *   1.0  first layout: links with 64 counters, event ring of 256-byte records, 128-byte slots,
 *        96-byte directory entries, outbound slots locked by a (pid << 32 | seq) word.
 *   1.1  the .out change word carries a waiter flag (SHM_OUT_WAITING): the daemon's wake thread
 *        sets it before it sleeps on the word, and clients add SHM_OUT_CHANGE_STEP and issue a
 *        FUTEX_WAKE only when they found the flag set and cleared it, so a write to an awake
 *        daemon costs no system call. Clients of a 1.0 daemon (no flag ever set) wake always.
 *        The .in mirror of an outbound variable carries the writer's time stamps and, in
 *        shm_slot.source (reserved bytes before), the .out lock word it was copied under: a
 *        client whose .out word still equals it reads the daemon's validated mirror instead of
 *        validating the client-writable slot again. A 1.0 daemon leaves source 0: never equal
 *        to a written word.
 *   1.2  the header publishes the daemon's control socket path (control_socket, reserved bytes
 *        before), so clients find the socket with no environment. An older daemon leaves it
 *        empty: clients use $SHAREDLINK_RUNTIME_DIR or the default, as before. The path is
 *        written once at creation; a reload that moves the socket recreates the tables.
 *   1.3  the .in header carries the outbound doorbell (out_doorbell, reserved bytes before): a
 *        word no one ever changes, on which the daemon's wake thread also sleeps. A client that
 *        finds .out unusable (truncated, scribbled, of another epoch) or a slot held for every
 *        bounded attempt FUTEX_WAKEs it, so the daemon checks .out at once. It lives in .in
 *        because .in is the daemon's own object, which no client can truncate or write: the
 *        .out change word is gone with the object it is in, and waking needs only read access.
 *        An older daemon sleeps on nothing there (the wake is lost: its .out is looked at when
 *        a client wakes it through .out, as before); the daemon also checks .out at every
 *        heartbeat whatever the layout.
 *   1.4  each link's whole state text (shm_link_text, SHM_LINK_TEXT_SIZE bytes, e.g. "down:
 *        FILE:LINE: message" of a broken recording) in a region of its own after the slots,
 *        under the link's seqlock; link_texts_offset and link_text_size in the header (reserved
 *        bytes before) say where. shm_link.state_name keeps the text cut to 31 bytes, as before.
 *        total_size keeps counting the regions up to the slots, which is what a 1.3 client
 *        computes and compares it with, so the region lies past total_size: the object is
 *        link_texts_offset + SHM_LINKS_MAX * link_text_size bytes, and a client checks that
 *        against the object's size. An older daemon leaves both fields 0: no texts.
 *   1.5  names added at run time can be retired and their entries given to new names, so a peer
 *        that declares new names again and again never fills the directory (docs/pronto4.md §4).
 *        A retired entry carries SHM_DIR_RETIRED; dir_rewrites (reserved bytes before) counts
 *        the rewrites of entries below `count` as a seqlock: odd while the daemon rewrites one,
 *        then even again. A client re-reads the whole directory when it changed, and after
 *        copying a slot checks that it did not change since its view was taken (else the copy
 *        may hold the value of the entry's next name): a retired name reads as gone, never as
 *        another variable. A client writing to .out puts the dir_rewrites of its view in the
 *        slot's dir_stamp; the daemon drops a write whose stamp is older than the last rewrite
 *        of the entry owning the slot (a write meant for the retired name). A client before
 *        1.5 never re-reads a rewritten entry and stamps 0: its writes to a reused entry drop.
 *   1.6  .out carries a touched map (touched_offset, touched_words in its header, reserved bytes
 *        before): one bit per .out slot, in 64-bit words, after the slots. A writer sets its
 *        slot's bit (fetch_or, release) after it published the slot and before it bumps the
 *        change word, and adds SHM_OUT_CHANGE_TOUCHED (the word's high half) instead of
 *        SHM_OUT_CHANGE_STEP; a writer that finds its slot held for every bounded attempt sets
 *        the bit before it rings the doorbell. On a wake-up the daemon takes the words
 *        (exchange with 0, acquire) and looks at those slots only, plus the ones it found held
 *        before: its work grows with the writes, not with the table. The map is client data like
 *        the rest of .out: a set bit only makes the daemon look at a slot (which it validates as
 *        ever), bits past the capacity are ignored, and a lost bit (a writer killed between its
 *        publish and its mark, a scribble) costs at most the wait for the daemon's full scan at
 *        every heartbeat. total_size keeps counting up to the slots (what a 1.5 client checks),
 *        so the map lies past it: the object is touched_offset + the map rounded to a cache
 *        line. A client before 1.6 sets no bit and adds SHM_OUT_CHANGE_STEP, which lands in the
 *        change word's low half: the daemon scans all of .out when that half moved since its
 *        last scan (as every scan did before). A 1.0 client adds 1: seen at once when the
 *        daemon sleeps (the add carries out of the waiter flag), else at the next heartbeat.
 *        An older daemon has no map (both fields 0): clients set no bit and add the old step.
 *   1.7  .in carries a change record (changes_offset, changes_capacity in the header, reserved
 *        bytes before): a ring of SHM_CHANGES_HEAD bytes of head, then changes_capacity 64-bit
 *        entries, after the link texts. The daemon, the only writer of .in, notes there the slot
 *        index of every slot it rewrites (a value, its flags, a name made or retired) and
 *        release-stores the head (entries written so far) before each bump of the change word,
 *        so a client that saw a bump finds every slot the bump covers in the ring. An entry
 *        holds its position's low 32 bits above the index: a reader tells an entry overwritten
 *        by a later lap by the position it holds, without writing anything (src/shm/changes.h),
 *        so any number of readers follow the ring read-only, each with its own position. The
 *        ring has a table's worth of entries (a power of two, at least SHM_CHANGES_MIN): a
 *        reader further behind than that reads every variable, which costs no more. It lies
 *        past the link texts and past total_size (what a 1.6 client checks): older clients
 *        never look there. An older daemon leaves both fields 0: no record, and a client reads
 *        everything at every change, as before.
 */
#ifndef SHM_LAYOUT_H
#define SHM_LAYOUT_H

#include <assert.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#define SHM_LAYOUT_MAJOR        1u
#define SHM_LAYOUT_MINOR        7u
#define SHM_LAYOUT_MINOR_WAITER 1u      /* first minor with SHM_OUT_WAITING */
#define SHM_LAYOUT_MINOR_SOCKET 2u      /* first minor with shm_in_header.control_socket */
#define SHM_LAYOUT_MINOR_DOORBELL 3u    /* first minor with shm_in_header.out_doorbell */
#define SHM_LAYOUT_MINOR_LINK_TEXT 4u   /* first minor with the link texts region */
#define SHM_LAYOUT_MINOR_RETIRE 5u      /* first minor with dir_rewrites and retired entries */
#define SHM_LAYOUT_MINOR_TOUCHED 6u     /* first minor with the .out touched map */
#define SHM_LAYOUT_MINOR_CHANGES 7u     /* first minor with the .in change record */
#define SHM_LAYOUT_VERSION      ((SHM_LAYOUT_MAJOR << 16) | SHM_LAYOUT_MINOR)

/* "SLNK.IN\0" and "SLNK.OUT" as little-endian words: recognisable in a hex dump. */
#define SHM_IN_MAGIC            UINT64_C(0x004e492e4b4e4c53)
#define SHM_OUT_MAGIC           UINT64_C(0x54554f2e4b4e4c53)

#define SHM_CACHE_LINE          64u
#define SHM_NAME_SIZE           48u     /* variable name: at most 47 bytes + NUL */
#define SHM_NAME_MAX            (SHM_NAME_SIZE - 1u)
#define SHM_VALUE_SIZE          64u     /* value: at most 63 bytes + NUL */
#define SHM_VALUE_MAX           (SHM_VALUE_SIZE - 1u)
#define SHM_VALUE_WORDS         (SHM_VALUE_SIZE / 8u)
#define SHM_PEER_SIZE           16u     /* peer address (SharedLink node, CIRCE device) + NUL */
#define SHM_LINK_NAME_SIZE      32u
#define SHM_PROTOCOL_SIZE       16u
#define SHM_STATE_NAME_SIZE     32u
#define SHM_STATE_NAME_WORDS    (SHM_STATE_NAME_SIZE / 8u)
#define SHM_LINK_TEXT_SIZE      256u    /* a link's whole state text + NUL (layout 1.4) */
#define SHM_LINK_TEXT_WORDS     (SHM_LINK_TEXT_SIZE / 8u)
#define SHM_LINKS_MAX           32u
#define SHM_COUNTERS_MAX        64u     /* counter slots per link: named ones + spare room */
#define SHM_EVENT_TEXT_SIZE     216u    /* "key=value ..." + NUL */
#define SHM_EVENT_TEXT_WORDS    (SHM_EVENT_TEXT_SIZE / 8u)
#define SHM_EVENTS_DEFAULT      1024u   /* event ring records unless configured */
#define SHM_EVENTS_MIN          16u
#define SHM_EVENTS_MAX          65536u
#define SHM_CAPACITY_MAX        65536u  /* directory entries (configured + ad hoc) */
#define SHM_CHANGES_MIN         64u     /* change record entries (1.7) of the smallest table */
#define SHM_CHANGES_HEAD        64u     /* bytes before the entries: the head, on its own line */
#define SHM_INSTANCE_MAX        32u     /* instance name length, without NUL (shm_layout_instance_check) */
#define SHM_OBJECT_NAME_SIZE    (SHM_INSTANCE_MAX + 32u)
#define SHM_SOCKET_PATH_SIZE    108u    /* sizeof(sockaddr_un.sun_path): path + NUL */

#define SHM_LINK_NONE           UINT32_MAX      /* dir_entry.link, event.link: no link */
#define SHM_OUT_NONE            UINT32_MAX      /* dir_entry.out_slot of an inbound variable */
#define SHM_POSITION_NONE       (-1)

/* shm_in_header.state */
#define SHM_STATE_LIVE          1u      /* the daemon that created the object owns it */
#define SHM_STATE_CLOSED        2u      /* superseded or shut down: clients reopen by name */

/* shm_dir_entry.direction */
#define SHM_DIR_IN              0u      /* the daemon publishes it */
#define SHM_DIR_OUT             1u      /* clients write it */

/* shm_dir_entry.type */
#define SHM_TYPE_STRING         0u
#define SHM_TYPE_LONG           1u
#define SHM_TYPE_DOUBLE         2u
#define SHM_TYPE_COUNT          3u

/* shm_dir_entry.flags */
#define SHM_DIR_ADHOC           0x1u    /* added at run time (e.g. an R frame for an unknown name) */
#define SHM_DIR_RETIRED         0x2u    /* 1.5: the name is gone; the entry may get another */

/* shm_slot.flags (the library's SL_FLAG_* use the same bits) */
#define SHM_SLOT_VALID          0x1u    /* the value was written completely */
#define SHM_SLOT_STALE          0x2u    /* link down or peer silent */
#define SHM_SLOT_OUTBOUND       0x4u    /* a value written by a client (mirror or .out slot) */
#define SHM_SLOT_REPAIRED       0x8u    /* .out: the writer died (or stalled) mid-write, value
                                                 * discarded (length SHM_SLOT_LENGTH_NONE) */
/* The length the daemon leaves in a repaired .out slot: above SHM_VALUE_MAX, so that whatever
 * tail of its stores a writer taken over while stopped makes once it runs again, the slot never
 * passes a check (a length of 0 with one stored value word passed as ""). */
#define SHM_SLOT_LENGTH_NONE    UINT32_MAX

/* shm_out_header.change (layout 1.1, see the history above) */
#define SHM_OUT_WAITING         0x1u    /* the daemon's wake thread sleeps (or is about to) */
#define SHM_OUT_CHANGE_STEP     0x2u    /* what a client adds after each write (before 1.6) */
#define SHM_OUT_CHANGE_TOUCHED  0x10000u        /* 1.6: what a client that marked its slot adds */
#define SHM_OUT_CHANGE_UNTOUCHED 0xfffeu        /* 1.6: the bits older clients' steps move */

/* .out touched map (layout 1.6) */
#define SHM_TOUCHED_WORD_BITS   64u     /* slots per map word */

/* shm_event.flags */
#define SHM_EVENT_TRUNCATED     0x1u    /* the text did not fit and was cut */

/*
 * Counters: one fixed, named list shared by the daemon, the library and (through the library's
 * sl_counter_scope) slctl. Per-link counters and the daemon-wide counters (in the header) use the
 * same indices; a counter that does not apply stays 0. Append only: the index is part of the
 * layout. The third column is the counter's scope, where code moves it (SHM_SCOPE_*): SharedLink
 * links (src/daemon/link_sharedlink*.c), CIRCE links (link_circe*.c), both (the transport,
 * link.c), or the daemon (the outbound scan and the event ring, src/shm/table.c);
 * tests/integration/test_slctl.c checks that the real daemon moves no counter outside it.
 */
#define SHM_SCOPE_SHAREDLINK    0x1u
#define SHM_SCOPE_CIRCE         0x2u
#define SHM_SCOPE_LINKS         (SHM_SCOPE_SHAREDLINK | SHM_SCOPE_CIRCE)
#define SHM_SCOPE_DAEMON        0x4u
#define SHM_SCOPE_ALL           (SHM_SCOPE_LINKS | SHM_SCOPE_DAEMON)

#define SHM_COUNTER_LIST(X) \
        X(FRAMES_IN,            "frames_in",            LINKS) \
        X(FRAMES_OUT,           "frames_out",           LINKS) \
        X(BYTES_IN,             "bytes_in",             LINKS) \
        X(BYTES_OUT,            "bytes_out",            LINKS) \
        X(NOISE_BYTES,          "noise_bytes",          LINKS) \
        X(BAD_CHECKSUM,         "bad_checksum",         LINKS) \
        X(RESYNC,               "resync",               LINKS) \
        X(OVERLONG,             "overlong",             LINKS) \
        X(BAD_ADDRESS,          "bad_address",          SHAREDLINK) \
        X(BAD_FIELD,            "bad_field",            LINKS) \
        X(UNKNOWN_FIELD,        "unknown_field",        SHAREDLINK) \
        X(EMPTY_FIELD,          "empty_field",          SHAREDLINK) \
        X(LIST_MISMATCH,        "list_mismatch",        SHAREDLINK) \
        X(UNKNOWN_PEER,         "unknown_peer",         SHAREDLINK) \
        X(NOT_FOR_US,           "not_for_us",           SHAREDLINK) \
        X(ADHOC_FULL,           "adhoc_full",           LINKS) \
        X(QUERIES_IN,           "queries_in",           SHAREDLINK) \
        X(ANSWERS_OUT,          "answers_out",          SHAREDLINK) \
        X(REOPENS,              "reopens",              LINKS) \
        X(IO_ERRORS,            "io_errors",            LINKS) \
        X(BAD_HEADER,           "bad_header",           LINKS) \
        X(UNKNOWN_OP,           "unknown_op",           CIRCE) \
        X(BAD_VALUE,            "bad_value",            LINKS) \
        X(MISSING_PARAM,        "missing_param",        CIRCE) \
        X(SKIPPED_PARAM,        "skipped_param",        CIRCE) \
        X(REPEATED_PARAM,       "repeated_param",       CIRCE) \
        X(NONCOMPLIANT_STATUS,  "noncompliant_status",  CIRCE) \
        X(LOG_MESSAGES,         "log_messages",         CIRCE) \
        X(TX_DROPPED,           "tx_dropped",           LINKS) \
        X(QUERIES_OUT,          "queries_out",          SHAREDLINK) \
        X(ANSWERS_IN,           "answers_in",           SHAREDLINK) \
        X(TIMEOUTS,             "timeouts",             LINKS) \
        X(OUT_ACCEPTED,         "out_accepted",         DAEMON) \
        X(OUT_INVALID,          "out_invalid",          DAEMON) \
        X(OUT_BUSY,             "out_busy",             DAEMON) \
        X(OUT_REPAIRED,         "out_repaired",         DAEMON) \
        X(OUT_BAD_OBJECT,       "out_bad_object",       DAEMON) \
        X(OUT_RECREATED,        "out_recreated",        DAEMON) \
        X(EVENTS,               "events",               DAEMON) \
        X(DECLARATIONS_IN,      "declarations_in",      SHAREDLINK) \
        X(DECLARATIONS_OUT,     "declarations_out",     SHAREDLINK) \
        X(ACKS_IN,              "acks_in",              SHAREDLINK) \
        X(LEARN_FULL,           "learn_full",           SHAREDLINK) \
        X(LEARN_CONFLICT,       "learn_conflict",       SHAREDLINK) \
        X(BAD_TYPE,             "bad_type",             SHAREDLINK) \
        X(TYPE_MISMATCH,        "type_mismatch",        SHAREDLINK) \
        X(UNDECLARED_DATA,      "undeclared_data",      SHAREDLINK) \
        X(REDECLARED,           "redeclared",           SHAREDLINK) \
        X(COMMANDS_IN,          "commands_in",          SHAREDLINK) \
        X(COMMANDS_OUT,         "commands_out",         SHAREDLINK) \
        X(BAD_COMMAND,          "bad_command",          SHAREDLINK) \
        X(UDP_REFUSED,          "udp_refused",          LINKS) \
        X(LIST_UNKNOWN,         "list_unknown",         SHAREDLINK) \
        X(INBOUND_OFF,          "inbound_off",          SHAREDLINK) \
        X(OUT_TAKEN_OVER,       "out_taken_over",       DAEMON)

#define SHM_COUNTER_ENUM(id, name, scope) SHM_COUNTER_##id,
enum shm_counter {
        SHM_COUNTER_LIST(SHM_COUNTER_ENUM)
        SHM_COUNTER_COUNT
};
#undef SHM_COUNTER_ENUM

/* Event types: "SEQ LINK TYPE key=value ..." prints the name. Append only. */
#define SHM_EVENT_LIST(X) \
        X(NONE,                 "none") \
        X(LINK_STATE,           "link-state") \
        X(DEVICE_ONLINE,        "device-online") \
        X(DEVICE_OFFLINE,       "device-offline") \
        X(ACTION,               "action") \
        X(QUERY_ANSWER,         "query-answer") \
        X(ADHOC_VARIABLE,       "adhoc-variable") \
        X(LOG,                  "log") \
        X(KEYS,                 "keys") \
        X(CLOCK_SYNC,           "clock-sync") \
        X(DAEMON,               "daemon") \
        X(OUTBOUND,             "outbound") \
        X(COMMAND,              "command")

#define SHM_EVENT_ENUM(id, name) SHM_EVENT_##id,
enum shm_event_type {
        SHM_EVENT_LIST(SHM_EVENT_ENUM)
        SHM_EVENT_TYPE_COUNT
};
#undef SHM_EVENT_ENUM

/* Header of the .in object. Offsets are pinned below. */
struct shm_in_header {
        _Atomic uint64_t magic;                 /* SHM_IN_MAGIC, release-stored last */
        uint32_t layout_version;                /* SHM_LAYOUT_VERSION */
        uint32_t header_size;                   /* sizeof(struct shm_in_header) */
        uint64_t total_size;                    /* bytes of the whole object */
        uint64_t epoch;                         /* random, new at every daemon start, never 0 */
        int32_t daemon_pid;
        uint32_t heartbeat_interval_ms;         /* 0: the daemon does not refresh heartbeat_ns */
        uint64_t daemon_start;                  /* /proc/<pid>/stat starttime: tells pid reuse */
        uint64_t created_real_ns;               /* CLOCK_REALTIME at creation */
        _Atomic uint32_t state;                 /* SHM_STATE_* */
        _Atomic uint32_t out_generation;        /* bumped when .out is recreated */
        uint32_t capacity;                      /* directory entries = inbound slots */
        _Atomic uint32_t count;                 /* published entries; grows with ad hoc names */
        _Atomic uint32_t dir_generation;        /* bumped whenever names are added or retired */
        uint32_t slot_size;
        uint32_t dir_entry_size;
        uint32_t link_max;
        uint32_t link_size;
        _Atomic uint32_t link_count;
        uint32_t counter_max;
        uint32_t event_size;
        uint32_t event_capacity;                /* records in the ring (a power of two) */
        uint32_t out_capacity;                  /* slots in .out */
        uint64_t links_offset;
        uint64_t events_offset;
        uint64_t dir_offset;
        uint64_t slots_offset;
        _Atomic uint64_t heartbeat_ns;          /* CLOCK_MONOTONIC, refreshed by the daemon */
        _Atomic uint64_t event_head;            /* number of the last event written (0: none) */
        uint64_t link_texts_offset;             /* 1.4: SHM_LINKS_MAX shm_link_text; 0: none */
        uint32_t link_text_size;                /* 1.4: sizeof(struct shm_link_text) */
        /* 1.5: rewrites of entries below count, a seqlock (odd while one is rewritten) */
        _Atomic uint32_t dir_rewrites;
        uint64_t changes_offset;                /* 1.7: the change record; 0: none */
        uint32_t changes_capacity;              /* 1.7: its entries (a power of two) */
        uint8_t reserved0[4];
        /* Own cache line: the futex clients wait on, bumped once per committed batch. */
        _Atomic uint32_t change;
        /* 1.3: clients FUTEX_WAKE it when .out is unusable; never written (see the history) */
        _Atomic uint32_t out_doorbell;
        uint8_t reserved1[56];
        _Atomic uint64_t counters[SHM_COUNTERS_MAX];    /* daemon-wide (outbound object health) */
        /* 1.2: absolute path of the control socket, NUL-terminated and NUL-padded; "" if none */
        char control_socket[SHM_SOCKET_PATH_SIZE];
        uint8_t reserved2[256 - SHM_SOCKET_PATH_SIZE];
};

/* One link: name and protocol fixed once published; state seqlocked; counters relaxed words. */
struct shm_link {
        _Atomic uint64_t seq;                   /* seqlock over state, state_ns, state_name */
        _Atomic uint64_t state_ns;              /* CLOCK_MONOTONIC of the last state change */
        _Atomic uint32_t state;                 /* small integer, meaning set by the engine */
        uint32_t reserved0;
        _Atomic uint64_t state_name[SHM_STATE_NAME_WORDS];      /* NUL-terminated text */
        char name[SHM_LINK_NAME_SIZE];
        char protocol[SHM_PROTOCOL_SIZE];
        uint8_t reserved1[24];
        _Atomic uint64_t counters[SHM_COUNTERS_MAX];
};

/* A link's whole state text (1.4), written and read under its shm_link's seq. */
struct shm_link_text {
        _Atomic uint64_t text[SHM_LINK_TEXT_WORDS];     /* NUL-terminated, NUL-padded */
};

/*
 * One event record. seq encodes the record number n (>= 1): 2n+1 while the producer writes it,
 * 2n+2 once complete, so a reader knows both "torn" and "overwritten by a later lap".
 */
struct shm_event {
        _Atomic uint64_t seq;
        _Atomic uint64_t mono_ns;
        _Atomic uint64_t real_ns;
        _Atomic uint32_t type;                  /* enum shm_event_type */
        _Atomic uint32_t link;                  /* link index or SHM_LINK_NONE */
        _Atomic uint32_t length;                /* text bytes, without NUL */
        _Atomic uint32_t flags;                 /* SHM_EVENT_* */
        _Atomic uint64_t text[SHM_EVENT_TEXT_WORDS];
};

/* One directory entry: immutable once published. */
struct shm_dir_entry {
        char name[SHM_NAME_SIZE];
        char peer[SHM_PEER_SIZE];               /* "" when none */
        uint32_t link;                          /* SHM_LINK_NONE when none */
        int32_t position;                       /* place in the peer's list, SHM_POSITION_NONE */
        uint32_t out_slot;                      /* index in .out, SHM_OUT_NONE for inbound */
        uint8_t direction;                      /* SHM_DIR_* */
        uint8_t type;                           /* SHM_TYPE_* */
        uint16_t flags;                         /* SHM_DIR_* flags */
        /* 1.5: dir_rewrites when the entry got this name (0: when the table was made or the
         * name appended); a .out write stamped earlier was meant for a retired name */
        uint32_t born;
        uint8_t reserved[12];
};

/*
 * One value slot, in .in (single writer: the daemon) and in .out (many writers). `seq` is the
 * seqlock word; in .out it is the lock word (writer pid << 32 | sequence): the low 32 bits are the
 * sequence (odd while written), the high 32 bits the pid of the last writer.
 */
struct shm_slot {
        _Atomic uint64_t seq;
        _Atomic uint64_t mono_ns;               /* CLOCK_MONOTONIC of the update */
        _Atomic uint64_t real_ns;               /* CLOCK_REALTIME of the update */
        _Atomic uint32_t flags;                 /* SHM_SLOT_* */
        _Atomic uint32_t length;                /* value bytes, without NUL */
        _Atomic uint64_t value[SHM_VALUE_WORDS];        /* NUL-terminated, NUL-padded */
        /* .in mirror of an outbound variable (1.1): the .out lock word whose value it holds, 0
         * for none; in .out and for inbound variables 0 */
        _Atomic uint64_t source;
        /* 1.5, .out only: the dir_rewrites of the writer's view; 0 elsewhere */
        _Atomic uint32_t dir_stamp;
        uint8_t reserved[20];
} __attribute__((aligned(64)));

/* Header of the .out object: written once by the daemon, but clients can scribble over it. */
struct shm_out_header {
        _Atomic uint64_t magic;                 /* SHM_OUT_MAGIC, release-stored last */
        uint32_t layout_version;
        uint32_t header_size;
        uint64_t total_size;
        uint64_t epoch;                         /* the epoch of the matching .in */
        uint32_t slot_size;
        uint32_t capacity;
        uint64_t slots_offset;
        uint32_t generation;                    /* equals shm_in_header.out_generation */
        uint32_t touched_words;                 /* 1.6: 64-bit words of the touched map; 0: none */
        uint64_t touched_offset;                /* 1.6: where the map starts, past total_size */
        /* Own cache line: clients bump it after every write; the daemon's wake thread waits on it. */
        _Atomic uint32_t change;
        uint8_t reserved1[60];
};

/* Whether a dir_rewrites value `stamp` is older than `born` (serial arithmetic: it wraps). */
static inline int shm_layout_stamp_before(uint32_t stamp, uint32_t born)
{
        return (int32_t)(stamp - born) < 0;
}

/* Lock-free 4- and 8-byte atomics are address-free, so they work across processes. */
static_assert(ATOMIC_INT_LOCK_FREE == 2, "32-bit atomics must be lock-free for shared memory");
static_assert(ATOMIC_LLONG_LOCK_FREE == 2, "64-bit atomics must be lock-free for shared memory");
static_assert(sizeof(_Atomic uint64_t) == 8 && sizeof(_Atomic uint32_t) == 4, "atomic sizes");

static_assert(sizeof(struct shm_in_header) == 1024, "in header size");
static_assert(offsetof(struct shm_in_header, magic) == 0, "magic offset");
static_assert(offsetof(struct shm_in_header, layout_version) == 8, "version offset");
static_assert(offsetof(struct shm_in_header, epoch) == 24, "epoch offset");
static_assert(offsetof(struct shm_in_header, daemon_pid) == 32, "pid offset");
static_assert(offsetof(struct shm_in_header, state) == 56, "state offset");
static_assert(offsetof(struct shm_in_header, capacity) == 64, "capacity offset");
static_assert(offsetof(struct shm_in_header, count) == 68, "count offset");
static_assert(offsetof(struct shm_in_header, out_capacity) == 108, "out capacity offset");
static_assert(offsetof(struct shm_in_header, links_offset) == 112, "links offset offset");
static_assert(offsetof(struct shm_in_header, heartbeat_ns) == 144, "heartbeat offset");
static_assert(offsetof(struct shm_in_header, event_head) == 152, "event head offset");
static_assert(offsetof(struct shm_in_header, dir_rewrites) == 172, "dir rewrites offset");
static_assert(offsetof(struct shm_in_header, changes_offset) == 176, "changes offset offset");
static_assert(offsetof(struct shm_in_header, changes_capacity) == 184, "changes capacity offset");
static_assert(offsetof(struct shm_in_header, change) == 192, "change word offset");
static_assert(offsetof(struct shm_in_header, change) % SHM_CACHE_LINE == 0, "change word line");
static_assert(offsetof(struct shm_in_header, out_doorbell) == 196, "doorbell offset");
static_assert(offsetof(struct shm_in_header, counters) == 256, "counters offset");
static_assert(offsetof(struct shm_in_header, control_socket) == 768, "control socket offset");
static_assert(offsetof(struct shm_in_header, link_texts_offset) == 160, "link texts offset");
static_assert(offsetof(struct shm_in_header, link_text_size) == 168, "link text size offset");
static_assert(sizeof(struct shm_link) == 640, "link size");
static_assert(sizeof(struct shm_link_text) == SHM_LINK_TEXT_SIZE, "link text size");
static_assert(SHM_LINK_TEXT_SIZE % SHM_CACHE_LINE == 0, "link texts on whole cache lines");
static_assert(offsetof(struct shm_link, name) == 56, "link name offset");
static_assert(offsetof(struct shm_link, counters) == 128, "link counters offset");
static_assert(sizeof(struct shm_event) == 256, "event size");
static_assert(offsetof(struct shm_event, text) == 40, "event text offset");
static_assert(sizeof(struct shm_dir_entry) == 96, "directory entry size");
static_assert(offsetof(struct shm_dir_entry, link) == 64, "directory link offset");
static_assert(offsetof(struct shm_dir_entry, direction) == 76, "directory direction offset");
static_assert(offsetof(struct shm_dir_entry, born) == 80, "directory born offset");
static_assert(sizeof(struct shm_slot) == 128, "slot size");
static_assert(offsetof(struct shm_slot, flags) == 24, "slot flags offset");
static_assert(offsetof(struct shm_slot, length) == 28, "slot length offset");
static_assert(offsetof(struct shm_slot, value) == 32, "slot value offset");
static_assert(offsetof(struct shm_slot, source) == 96, "slot source offset");
static_assert(offsetof(struct shm_slot, dir_stamp) == 104, "slot dir stamp offset");
static_assert(sizeof(struct shm_out_header) == 128, "out header size");
static_assert(offsetof(struct shm_out_header, generation) == 48, "out generation offset");
static_assert(offsetof(struct shm_out_header, change) == 64, "out change word offset");
static_assert(offsetof(struct shm_out_header, touched_words) == 52, "out touched words offset");
static_assert(offsetof(struct shm_out_header, touched_offset) == 56, "out touched offset offset");
static_assert((SHM_OUT_CHANGE_TOUCHED & SHM_OUT_CHANGE_UNTOUCHED) == 0 &&
              (SHM_OUT_CHANGE_STEP & SHM_OUT_CHANGE_UNTOUCHED) == SHM_OUT_CHANGE_STEP &&
              (SHM_OUT_WAITING & SHM_OUT_CHANGE_UNTOUCHED) == 0, "change word halves");
static_assert(SHM_COUNTER_COUNT <= SHM_COUNTERS_MAX, "too many counters");
static_assert(SHM_VALUE_SIZE % 8 == 0 && SHM_EVENT_TEXT_SIZE % 8 == 0, "text in whole words");
static_assert(SHM_STATE_NAME_SIZE % 8 == 0, "state name in whole words");

/* The .in layout of a table with these capacities (for create and check). */
struct shm_in_geometry {
        uint64_t links_offset;
        uint64_t events_offset;
        uint64_t dir_offset;
        uint64_t slots_offset;
        uint64_t total_size;            /* the header's total_size: up to the end of the slots */
        uint64_t link_texts_offset;     /* 1.4, past total_size */
        uint64_t link_texts_end;        /* the object of a 1.4 to 1.6 daemon ends here */
        uint64_t changes_offset;        /* 1.7, past the link texts */
        uint32_t changes_capacity;      /* 1.7: entries of the change record */
        uint64_t object_size;           /* the whole object, change record included */
};

/* Computes where each region of .in lives for the given capacities. */
void shm_layout_in_geometry(uint32_t capacity, uint32_t event_capacity,
                            struct shm_in_geometry *ret_geometry);

/* The .out layout of a table with this many slots. */
struct shm_out_geometry {
        uint64_t total_size;            /* the header's total_size: up to the end of the slots */
        uint64_t touched_offset;        /* 1.6, past total_size */
        uint32_t touched_words;
        uint64_t object_size;           /* the whole object, touched map included */
};

/* Computes where each region of .out lives for out_capacity slots. */
void shm_layout_out_geometry(uint32_t out_capacity, struct shm_out_geometry *ret_geometry);

/* The header's total_size of a .out object with out_capacity slots (up to the slots' end). */
uint64_t shm_layout_out_size(uint32_t out_capacity);

/*
 * Checks a mapped .in header against the object size: magic, major version, sizes, offsets.
 * Returns 0, -EAGAIN (magic not written yet) or -EPROTO (not a layout we understand).
 */
int shm_layout_check_in(const struct shm_in_header *h, uint64_t object_size);

/* 1 when a checked .in header has the link texts region (1.4) and it fits the object, else 0. */
int shm_layout_has_link_texts(const struct shm_in_header *h, uint64_t object_size);

/* Entries of the change record (1.7) of a table of `capacity` slots: a power of two, at least
 * the capacity and SHM_CHANGES_MIN. */
uint32_t shm_layout_changes_capacity(uint32_t capacity);

/* 1 when a checked .in header has the change record (1.7) where its geometry puts it, of the
 * size it gives, and the record fits the object; else 0 (an older daemon, a scribbled header,
 * a truncated object). */
int shm_layout_has_changes(const struct shm_in_header *h, uint64_t object_size);

/* Same for .out; returns 0, -EAGAIN or -EPROTO. Does not compare epoch/generation. */
int shm_layout_check_out(const struct shm_out_header *h, uint64_t object_size);

/* 1 when a checked .out header has the touched map (1.6) and it fits the object, else 0. */
int shm_layout_has_touched(const struct shm_out_header *h, uint64_t object_size);

/* Name of counter i, or NULL beyond the named list. */
const char *shm_layout_counter_name(unsigned i);

/* Scope (SHM_SCOPE_*) of the counter called name, or 0 for a name not in the list. */
unsigned shm_layout_counter_scope(const char *name);

/* Name of event type t ("none" .. ), or "unknown". */
const char *shm_layout_event_name(unsigned t);

/* Name of variable type t ("string", "long", "double"), or "unknown". */
const char *shm_layout_type_name(unsigned t);

/* 1 if c may appear in a value on the wire (slp_value_byte(): 0x20-0x7E except | [ ]). */
int shm_layout_value_char(int c);

/* 0 if v[0..len) is a valid value (length <= SHM_VALUE_MAX, wire charset), else -EINVAL. */
int shm_layout_value_check(const char *v, size_t len);

/* shm_layout_value_check of v[0..len) where v is a whole value field (SHM_VALUE_SIZE bytes). */
int shm_layout_value_check_field(const char *v, size_t len);

/* 0 if name is a valid variable name (1..47 bytes of slp_name_byte(): letters, digits, _ . -),
 * else -EINVAL. */
int shm_layout_name_check(const char *name);

/* The hash of a variable name (FNV-1a over at most SHM_NAME_SIZE bytes, up to its NUL) that
 * every index of names uses: the daemon's table, the library's ids, the configuration's check. */
uint32_t shm_layout_name_hash(const char *name);

/*
 * The one rule for instance names (and, in the daemon's configuration, link names): letters,
 * digits, '_' and '-', not starting with '-'. They appear on slctl's command line, in shm object
 * and socket file names and, for links, before the '.' of variable names, so no '.' and no '/'.
 * Returns the index of the first byte that breaks the rule (0 for a leading '-'), or -1 if none.
 */
long shm_layout_ident_bad(const char *name);

/* 0 if instance is a valid instance name (1..SHM_INSTANCE_MAX bytes, shm_layout_ident_bad). */
int shm_layout_instance_check(const char *instance);

/* Writes "/sharedlink.<instance>.<suffix>" into buf; returns 0, -EINVAL or -ENAMETOOLONG. */
int shm_layout_object_name(const char *instance, const char *suffix, char *buf, size_t size);

#endif
