/*
 * Variables: find, describe, read and write (the hot path: one read lock, one bounded seqlock copy).
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <sharedlink.h>

#include "lib/client.h"
#include "lib/export.h"
#include "proto/sharedlink.h"
#include "shm/futex.h"
#include "shm/seqlock.h"
#include "shm/slot.h"

#define VARS_DOUBLE_DIGITS_MAX  17      /* enough to read a double back exactly */
#define VARS_NUMBER_BUF         (SHM_VALUE_SIZE + 64)
/* The read path is a handful of small steps: inline them into sl_read whatever the heuristics. */
#define VARS_HOT                inline __attribute__((always_inline))
/* Reads that found a directory entry rewritten under them before one gives up -EAGAIN: each
 * refreshes the view first, and a rewrite is one daemon step (layout 1.5). */
#define VARS_MOVED_TRIES        8

/* The library's flag bits are the table's: a value read is handed out without translation. */
_Static_assert(SL_FLAG_VALID == SHM_SLOT_VALID && SL_FLAG_STALE == SHM_SLOT_STALE &&
               SL_FLAG_OUTBOUND == SHM_SLOT_OUTBOUND && SL_FLAG_REPAIRED == SHM_SLOT_REPAIRED,
               "flag bits");
_Static_assert(SL_NAME_SIZE == SHM_NAME_SIZE && SL_VALUE_SIZE == SHM_VALUE_SIZE &&
               SL_PEER_SIZE == SHM_PEER_SIZE && SL_LINK_NAME_SIZE == SHM_LINK_NAME_SIZE,
               "public sizes");
_Static_assert(SL_DIR_IN == SHM_DIR_IN && SL_DIR_OUT == SHM_DIR_OUT, "directions");
_Static_assert(SL_VAR_STRING == SHM_TYPE_STRING && SL_VAR_LONG == SHM_TYPE_LONG &&
               SL_VAR_DOUBLE == SHM_TYPE_DOUBLE, "types");
_Static_assert(SL_VAR_ADHOC == SHM_DIR_ADHOC, "directory flags");

/* sl_write_check quotes a value (up to 63 bytes) and adds at most 96 bytes of reason. */
_Static_assert(SL_WRITE_REASON_SIZE >= SHM_VALUE_SIZE + 96, "reason size");

/* Extensible structs: the caller's size must cover at least the first version. */
#define SL_META_SIZE_V1         sizeof(struct sl_meta)
#define SL_VAR_INFO_SIZE_V1     sizeof(struct sl_var_info)

SL_EXPORT int sl_find(struct sl_client *c, const char *name)
{
        int id;

        if (!c || !name)
                return -EINVAL;
        if (strnlen(name, SHM_NAME_SIZE) > SHM_NAME_MAX)
                return -ENOENT;
        client_rdlock(c);
        id = client_id_lookup(c, name);
        if (id >= 0 && client_index(c, id) < 0)
                id = -ENOENT;   /* a name the current daemon does not have */
        client_unlock(c);
        return id;
}

SL_EXPORT int sl_count(struct sl_client *c)
{
        int n;

        if (!c)
                return -EINVAL;
        client_rdlock(c);
        n = (int)c->nids;
        client_unlock(c);
        return n;
}

/* The read lock (its token in *token) and id's directory index with CLIENT_INDEX_LEARNED (try
 * `attempt` after a rewrite: layout 1.5), or -errno with no lock held. */
static VARS_HOT int lock_entry(struct sl_client *c, int id, int attempt,
                               struct client_reader **token)
{
        int index;

        if (attempt == VARS_MOVED_TRIES)
                return -EAGAIN;
        *token = client_rdlock_token(c);
        index = client_index_entry(c, id);
        if (index < 0)
                client_unlock_token(c, *token);
        return index;
}

SL_EXPORT int sl_info(struct sl_client *c, int id, struct sl_var_info *ret)
{
        const struct shm_dir_entry *e;
        struct client_reader *token;
        struct sl_var_info info;
        int index;

        if (!c || !ret || ret->size < SL_VAR_INFO_SIZE_V1)
                return -EINVAL;
        for (int attempt = 0;; attempt++) {
                index = lock_entry(c, id, attempt, &token);
                if (index < 0)
                        return index;
                e = &c->map->dir[index & ~CLIENT_INDEX_LEARNED];
                memset(&info, 0, sizeof(info));
                client_copy_field(info.name, sizeof(info.name), e->name, sizeof(e->name));
                client_copy_field(info.peer, sizeof(info.peer), e->peer, sizeof(e->peer));
                info.direction = e->direction;
                info.type = e->type;
                info.link = e->link == SHM_LINK_NONE ? -1 : (int)e->link;
                info.position = e->position;
                info.flags = e->flags;
                /* Rewritten meanwhile (layout 1.5): maybe torn, or another name's. */
                if (!client_dir_moved(c))
                        break;
                client_unlock_token(c, token);
        }
        client_unlock_token(c, token);
        client_struct_out(ret, &info, sizeof(info));
        return 0;
}

/*
 * What a read hands out besides the value: the slot's head, the value's sequence, and with
 * metadata the flags that apply on top and the time the age counts to. The hot path keeps it in
 * registers: no function that is not inlined ever gets its address (the slow paths fill one of
 * their own, which is then assigned), so the compiler neither spills it to the stack nor reloads
 * it from there.
 */
struct vars_read {
        struct shm_slot_head head;
        uint64_t sequence;
        uint64_t now;
        uint32_t extra;
};

/* The metadata of one read, as meta_fill stores it. */
static VARS_HOT void meta_store(struct sl_meta *out, const struct vars_read *rd)
{
        out->mono_ns = rd->head.mono_ns;
        out->real_ns = rd->head.real_ns;
        out->age_ns = rd->head.mono_ns && rd->now > rd->head.mono_ns ?
                      rd->now - rd->head.mono_ns : 0;
        out->sequence = rd->sequence;
        out->flags = (rd->head.flags & (SL_FLAG_VALID | SL_FLAG_STALE | SL_FLAG_OUTBOUND |
                                        SL_FLAG_REPAIRED)) | rd->extra;
}

/* meta_fill for a caller's struct older than ours: built whole, then copied out as far as it goes. */
static void __attribute__((noinline)) meta_fill_small(struct sl_meta *meta, struct vars_read rd)
{
        struct sl_meta m = { .size = sizeof(m) };

        meta_store(&m, &rd);
        client_struct_out(meta, &m, sizeof(m));
}

/*
 * Fills *meta from what a read handed out (meta->size already checked). A caller's struct of the
 * size we know (or a newer, larger one) gets its fields stored directly: building the whole struct
 * and copying it out cost a memset and a memcpy call on every read with metadata (and a local
 * whose address escapes costs the hot path a stack canary).
 */
static VARS_HOT void meta_fill(struct sl_meta *meta, const struct vars_read *rd)
{
        if (meta->size >= sizeof(*meta))
                meta_store(meta, rd);
        else
                meta_fill_small(meta, *rd);
}

/*
 * Reads .out slot out_slot (< out_capacity) of the outbound variable at directory index `index`,
 * its value to value[0..SHM_VALUE_SIZE) (read lock held). Returns 1 with a valid copy, 0 when it
 * holds no valid value (never written, repaired, recreated, scribbled), or -EAGAIN. The slot is
 * client-writable: the copy is validated like the daemon does before it is used.
 */
static int __attribute__((noinline)) read_out_slot(const struct sl_client *c, int index,
                                                   uint32_t out_slot, char *value,
                                                   unsigned fields, struct vars_read *ret)
{
        int r;

        r = shm_slot_read_fields(&c->out_slots[out_slot], &ret->head, value,
                                 fields | SHM_SLOT_HEAD_STAMP);
        if (r < 0)
                return r;
        /* A value written for the entry's retired name (layout 1.5) is none of this one's. */
        if (shm_slot_head_check(&ret->head, value) < 0 ||
            shm_layout_stamp_before(ret->head.dir_stamp, c->map->dir[index].born))
                return 0;
        ret->head.flags |= SHM_SLOT_OUTBOUND;
        ret->sequence = shm_seqlock_sequence(ret->head.word) / 2u;
        return 1;
}

/*
 * An outbound variable (.out slot out_slot, from c->id_out): the daemon's mirror in .in when it
 * was copied from the .out slot as it still is (same lock word: layout.h, 1.1), which needs no
 * check; else the .out slot itself, checked. Returns as read_out_slot (read lock held).
 */
static VARS_HOT int read_outbound(const struct sl_client *c, int index, uint32_t out_slot,
                                  char *value, unsigned fields, struct vars_read *rd)
{
        struct vars_read slow;
        uint64_t word;
        int r;

        if (!c->out || out_slot >= c->out_capacity)
                return 0;
        word = atomic_load_explicit(&c->out_slots[out_slot].seq, memory_order_acquire);
        if (!shm_seqlock_odd(word) && word != 0 &&
            shm_slot_read_fields(&c->map->slots[index], &rd->head, value,
                                 fields | SHM_SLOT_HEAD_SOURCE) == 0 &&
            rd->head.source == word) {
                /* The daemon's word for what the slot holds: its value, or none (a writer taken
                 * over before any value was accepted, whose late stores the slot may hold). */
                if (!(rd->head.flags & SHM_SLOT_VALID) || rd->head.length > SHM_VALUE_MAX)
                        return 0;
                rd->head.flags |= SHM_SLOT_OUTBOUND;
                rd->sequence = shm_seqlock_sequence(word) / 2u;
                return 1;
        }
        r = read_out_slot(c, index, out_slot, value, fields, &slow);
        if (r > 0)
                *rd = slow;
        return r;
}

/*
 * One consistent, validated copy of variable id's value into value[0..SHM_VALUE_SIZE),
 * NUL-terminated (scratch space, unspecified on failure), the rest in *rd; with_meta, also the
 * flags that apply on top and the time the age counts to. The hot path of every read: one read
 * lock, one inline seqlock copy straight into the caller's buffer.
 */
static VARS_HOT int read_value(struct sl_client *c, int id, char *value, struct vars_read *rd,
                               int with_meta)
{
        /* The time stamps only for the metadata. */
        unsigned fields = with_meta ? SHM_SLOT_HEAD_TIMES : 0u;
        struct client_reader *token;
        uint32_t out_slot;
        int entry, index, r = 0;

        rd->sequence = 0;
        for (int attempt = 0;; attempt++) {
                entry = lock_entry(c, id, attempt, &token);
                if (entry < 0)
                        return entry;
                index = entry & ~CLIENT_INDEX_LEARNED;
                out_slot = c->id_out[id];
                r = 0;
                if (out_slot != SHM_OUT_NONE)
                        r = read_outbound(c, index, out_slot, value, fields, rd);
                if (r == 0) {
                        /* .in: the daemon's own value, or its mirror of the last accepted
                         * outbound one */
                        r = shm_slot_read_fields(&c->map->slots[index], &rd->head, value,
                                                 fields);
                        if (r == 0) {
                                rd->sequence = rd->head.word / 2u;
                                if (rd->head.length > SHM_VALUE_MAX ||
                                    !(rd->head.flags & SHM_SLOT_VALID))
                                        rd->head.length = 0;
                        }
                }
                /* A learned name's entry may have been given to another name meanwhile: the
                 * copy may be its value. A configured name's never is (CLIENT_INDEX_LEARNED). */
                if (!(entry & CLIENT_INDEX_LEARNED) || !client_dir_moved(c))
                        break;
                client_unlock_token(c, token);
        }
        if (with_meta) {
                /* Age and liveness from the coarse clock: see client_now_coarse. */
                rd->now = client_now_coarse(c);
                rd->extra = client_alive(c, rd->now, NULL) ? 0 : SL_FLAG_STALE;
        }
        client_unlock_token(c, token);
        if (r < 0)
                return r;
        value[rd->head.length] = '\0';
        return 0;
}

/*
 * A slot that stayed odd or changing through SHM_SEQLOCK_TRIES attempts (about a microsecond) has
 * a writer that is off its CPU in the middle of a write: preempted (a busy machine), sharing our
 * CPU, stopped, or dead (the daemon repairs that slot at its next scan). Rather than hand the
 * caller -EAGAIN for what is over once the writer runs again (about 0.02% of reads of an
 * outbound variable under a steady writer), read_value is tried again after giving the CPU away:
 * a few sched_yield()s, then sleeps that double from VARS_BUSY_NAP_NS to VARS_BUSY_NAP_MAX_NS, at
 * most SL_READ_BUSY_MS of sleep in all. Every sleep is followed by one more attempt.
 */
#define VARS_BUSY_YIELDS        4
#define VARS_BUSY_NAP_NS        50000L
#define VARS_BUSY_NAP_MAX_NS    2000000L
#define VARS_NS_PER_MS          1000000L

static int __attribute__((noinline)) read_busy(struct sl_client *c, int id, char *value,
                                               struct vars_read *ret, int with_meta)
{
        long slept = 0, nap = VARS_BUSY_NAP_NS;
        int r = -EAGAIN;

        for (unsigned round = 0; r == -EAGAIN && slept < SL_READ_BUSY_MS * VARS_NS_PER_MS;
             round++) {
                if (round < VARS_BUSY_YIELDS) {
                        sched_yield();
                } else {
                        struct timespec ts = { 0, nap };

                        nanosleep(&ts, NULL);
                        slept += nap;
                        nap = nap * 2 < VARS_BUSY_NAP_MAX_NS ? nap * 2 : VARS_BUSY_NAP_MAX_NS;
                }
                r = read_value(c, id, value, ret, with_meta);
        }
        return r;
}

/*
 * read_value, then read_busy when the slot stayed busy (its own vars_read, assigned back: see
 * struct vars_read).
 */
static VARS_HOT int read_any(struct sl_client *c, int id, char *value, struct vars_read *rd,
                             int with_meta)
{
        struct vars_read slow;
        int r;

        r = read_value(c, id, value, rd, with_meta);
        if (__builtin_expect(r != -EAGAIN, 1))
                return r;
        r = read_busy(c, id, value, &slow, with_meta);
        if (r == 0)
                *rd = slow;
        return r;
}

/* sl_read into a buffer that cannot hold every value: through a private copy. */
static int __attribute__((noinline)) read_small(struct sl_client *c, int id, char *buf, size_t size,
                                                struct sl_meta *meta)
{
        char value[SHM_VALUE_SIZE];
        struct vars_read rd = { .now = 0, .extra = 0 };
        int r;

        r = read_any(c, id, value, &rd, meta != NULL);
        if (r < 0)
                return r;
        if (size < (size_t)rd.head.length + 1u)
                return -ENOBUFS;
        memcpy(buf, value, rd.head.length + 1u);
        if (meta)
                meta_fill(meta, &rd);
        return (int)rd.head.length;
}

/*
 * sl_read into a buffer that holds any value: read into directly. with_meta is a constant, so
 * that the read without metadata neither loads the time stamps nor reads the clock, and neither
 * tests for it.
 */
static VARS_HOT int read_direct(struct sl_client *c, int id, char *buf, struct sl_meta *meta,
                                int with_meta)
{
        struct vars_read rd = { .now = 0, .extra = 0 };
        int r;

        /* The clock only matters for the metadata: age, and stale by heartbeat. */
        r = read_any(c, id, buf, &rd, with_meta);
        if (r < 0)
                return r;
        if (with_meta)
                meta_fill(meta, &rd);
        return (int)rd.head.length;
}

SL_EXPORT int sl_read(struct sl_client *c, int id, char *buf, size_t size, struct sl_meta *meta)
{
        if (!c || !buf || (meta && meta->size < SL_META_SIZE_V1))
                return -EINVAL;
        /* A buffer that holds any value is read into directly; a smaller one gets a copy. */
        if (size < SHM_VALUE_SIZE)
                return read_small(c, id, buf, size, meta);
        if (meta)
                return read_direct(c, id, buf, meta, 1);
        return read_direct(c, id, buf, NULL, 0);
}

/* Reads a value into text; -ENODATA when it is not valid or empty. */
static int read_text(struct sl_client *c, int id, char *text, struct sl_meta *meta)
{
        struct sl_meta m = { .size = sizeof(m) };
        int r = sl_read(c, id, text, SHM_VALUE_SIZE, &m);

        if (r < 0)
                return r;
        if (meta) {
                if (meta->size < SL_META_SIZE_V1)
                        return -EINVAL;
                client_struct_out(meta, &m, sizeof(m));
        }
        if (r == 0 || !(m.flags & SL_FLAG_VALID))
                return -ENODATA;
        return 0;
}

/*
 * Reads id's value as a number: strtod (is_double) or base-10 strtol, in the C locale whatever the
 * program's (strtod follows LC_NUMERIC, and other locales may accept other forms of integers; the
 * wire has only one). -EDOM when the text is not one whole number, -ERANGE when it overflows.
 */
static int read_number(struct sl_client *c, int id, int is_double, double *ret_double,
                       long *ret_long, struct sl_meta *meta)
{
        char text[SHM_VALUE_SIZE], *end;
        locale_t old;
        double d = 0;
        long l = 0;
        int r, err;

        r = read_text(c, id, text, meta);
        if (r < 0)
                return r;
        old = uselocale(c->c_locale);
        errno = 0;
        if (is_double)
                d = strtod(text, &end);
        else
                l = strtol(text, &end, 10);
        err = errno;
        uselocale(old);
        if (end == text || *end != '\0')
                return -EDOM;
        /* strtod also sets ERANGE on underflow, where its result is still usable */
        if (err == ERANGE && (!is_double || d == HUGE_VAL || d == -HUGE_VAL))
                return -ERANGE;
        if (is_double)
                *ret_double = d;
        else
                *ret_long = l;
        return 0;
}

SL_EXPORT int sl_read_double(struct sl_client *c, int id, double *ret, struct sl_meta *meta)
{
        if (!ret)
                return -EINVAL;
        return read_number(c, id, 1, ret, NULL, meta);
}

SL_EXPORT int sl_read_long(struct sl_client *c, int id, long *ret, struct sl_meta *meta)
{
        if (!ret)
                return -EINVAL;
        return read_number(c, id, 0, NULL, ret, meta);
}

/*
 * Tells the daemon about a write (read lock held): bumps the .out change word after the publish
 * (release orders it after the value) and wakes the daemon's wake thread, the only waiter on the
 * word, when it sleeps. A daemon of layout 1.1 or later says so with SHM_OUT_WAITING, set before
 * it sleeps: the add returns the word as it was, so only a writer that finds the flag set (and
 * is the one to clear it) makes the system call. All of this is one word's modification order:
 * an add after the flag was set sees it; one before makes the daemon's CAS fail, and it looks
 * again instead of sleeping.
 */
static void out_notify(struct sl_client *c)
{
        _Atomic uint32_t *change = &c->out->change;
        /* A 1.6 daemon tells a marked write (high half) from an older client's (low half). */
        uint32_t step = c->out_touched ? SHM_OUT_CHANGE_TOUCHED : SHM_OUT_CHANGE_STEP;
        uint32_t old;

        if (!c->map->waiter_flag) {
                atomic_fetch_add_explicit(change, 1u, memory_order_release);
                shm_futex_wake(change, 1);
                return;
        }
        old = atomic_fetch_add_explicit(change, step, memory_order_release);
        if ((old & SHM_OUT_WAITING) &&
            (atomic_fetch_and_explicit(change, ~SHM_OUT_WAITING, memory_order_relaxed) &
             SHM_OUT_WAITING))
                shm_futex_wake(change, 1);
}

/*
 * Marks .out slot i in the touched map (layout 1.6; read lock held), so that the daemon's scan
 * looks at it alone. After the publish and before the change word's bump: the release orders the
 * value before the bit, which the daemon takes with an acquire exchange, and the bump after it
 * wakes a daemon that took the map too early. A writer killed before it marks leaves the write to
 * the daemon's full scan at its next heartbeat.
 */
static void out_touch(struct sl_client *c, uint32_t i)
{
        if (c->out_touched)
                atomic_fetch_or_explicit(&c->out_touched[i / SHM_TOUCHED_WORD_BITS],
                                         UINT64_C(1) << (i % SHM_TOUCHED_WORD_BITS),
                                         memory_order_release);
}

/* Writes a checked value into the .out slot of id (read lock held). */
static int write_locked(struct sl_client *c, int id, const char *value, size_t len)
{
        const struct shm_dir_entry *e;
        struct shm_slot *slot;
        uint64_t word;
        int index, r;

        index = client_index(c, id);
        if (index < 0)
                return index;
        e = &c->map->dir[index];
        if (e->direction != SHM_DIR_OUT)
                return -EPERM;
        if (client_closed(c))
                return -ENOTCONN;       /* nobody would read it */
        if (!c->out)
                return c->out_error < 0 ? c->out_error : -EAGAIN;
        if (e->out_slot >= c->out_capacity)
                return -EPROTO;
        slot = &c->out_slots[e->out_slot];
        r = shm_slot_claim(slot, c->pid, &word);
        if (r < 0) {
                /* Held for every bounded attempt: perhaps by a writer that died in it, or a
                 * scribbled word; the daemon's scan repairs that, so have it scan the slot now. */
                out_touch(c, e->out_slot);
                client_ring_daemon(c);
                return r;
        }
        shm_slot_store(slot, value, (uint32_t)len, SHM_SLOT_VALID | SHM_SLOT_OUTBOUND,
                       client_now(CLOCK_MONOTONIC), client_now(CLOCK_REALTIME));
        /* The view's stamp: the daemon drops the write if the entry changed name since. */
        shm_slot_store_stamp(slot, c->synced_rewrites);
        r = shm_slot_publish(slot, word);
        if (r < 0)
                return r;
        out_touch(c, e->out_slot);
        out_notify(c);
        return 0;
}

/*
 * Whether sl_write takes value for id (read lock held): 0 with its length in *ret_len, or its
 * error with one line that says why in reason (reason_size bytes; NULL/0 for none). A long or
 * double variable takes only what the daemon would send for that type (slp_value_check, the
 * daemon's own rule, after the wire's charset checked eight bytes at a time): refused here, the
 * table keeps its value, instead of a write that stays local and is counted type_mismatch.
 */
static int write_refusal(const struct sl_client *c, int id, const char *value, char *reason,
                         size_t reason_size, size_t *ret_len)
{
        const struct shm_dir_entry *e;
        size_t len = strnlen(value, SHM_VALUE_SIZE);
        const char *why = NULL;
        int index = client_index(c, id), r = 0;

        if (index < 0) {
                r = index;
                why = "no such variable";
        } else if (c->map->dir[index].direction != SHM_DIR_OUT) {
                r = -EPERM;
                why = "an inbound variable: only the daemon writes it";
        } else if (shm_layout_value_check(value, len) < 0) {
                r = -EINVAL;
                why = len >= SHM_VALUE_SIZE ? "longer than 63 bytes" :
                      "a byte the wire cannot carry (printable ASCII except | [ ])";
        } else {
                e = &c->map->dir[index];
                if (e->type == SHM_TYPE_LONG &&
                    slp_value_type_check(SLP_TYPE_LONG, value, len) < 0)
                        why = "not a long: [+-] decimal digits within 64 bits";
                else if (e->type == SHM_TYPE_DOUBLE &&
                         slp_value_type_check(SLP_TYPE_DOUBLE, value, len) < 0)
                        why = "not a double: a finite decimal number such as -1.5 or 2e-3";
                if (why) {
                        /* The value passed the wire's check: safe to quote. */
                        if (reason && reason_size > 0)
                                snprintf(reason, reason_size, "\"%s\" is %s", value, why);
                        return -EINVAL;
                }
        }
        if (reason && reason_size > 0 && why)
                snprintf(reason, reason_size, "%s", why);
        *ret_len = len;
        return r;
}

SL_EXPORT int sl_write_check(struct sl_client *c, int id, const char *value, char *reason,
                             size_t reason_size)
{
        size_t len;
        int r;

        if (reason && reason_size > 0)
                reason[0] = '\0';
        if (!c || !value)
                return -EINVAL;
        client_rdlock(c);
        r = write_refusal(c, id, value, reason, reason_size, &len);
        client_unlock(c);
        return r;
}

SL_EXPORT int sl_write(struct sl_client *c, int id, const char *value)
{
        size_t len;
        int r;

        if (!c || !value)
                return -EINVAL;
        client_rdlock(c);
        r = write_refusal(c, id, value, NULL, 0, &len);
        if (r >= 0)
                r = write_locked(c, id, value, len);
        client_unlock(c);
        return r;
}

SL_EXPORT int sl_write_long(struct sl_client *c, int id, long v)
{
        char text[VARS_NUMBER_BUF];

        snprintf(text, sizeof(text), "%ld", v);
        return sl_write(c, id, text);
}

/* Formats v in the C locale; decimals < 0 picks the shortest text that reads back as v. */
static int format_double(const struct sl_client *c, double v, int decimals, char *text, size_t size)
{
        locale_t old;
        int n = 0;

        if (!isfinite(v) || decimals > VARS_DOUBLE_DIGITS_MAX)
                return -EINVAL;
        old = uselocale(c->c_locale);
        if (decimals >= 0) {
                n = snprintf(text, size, "%.*f", decimals, v);
        } else {
                for (int digits = 1; digits <= VARS_DOUBLE_DIGITS_MAX; digits++) {
                        n = snprintf(text, size, "%.*g", digits, v);
                        if (n > 0 && (size_t)n < size && strtod(text, NULL) == v)
                                break;
                }
        }
        uselocale(old);
        if (n < 0 || (size_t)n >= size)
                return -EINVAL;
        return 0;
}

SL_EXPORT int sl_write_double(struct sl_client *c, int id, double v, int decimals)
{
        char text[VARS_NUMBER_BUF];
        int r;

        if (!c)
                return -EINVAL;
        r = format_double(c, v, decimals, text, sizeof(text));
        if (r < 0)
                return r;
        return sl_write(c, id, text);   /* refuses a text longer than 63 bytes */
}
