/*
 * Variables: find, describe, read and write (the hot path: one read lock, one bounded seqlock copy).
 */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sharedlink.h>

#include "lib/client.h"
#include "lib/export.h"
#include "shm/futex.h"
#include "shm/seqlock.h"
#include "shm/slot.h"

#define VARS_DOUBLE_DIGITS_MAX  17      /* enough to read a double back exactly */
#define VARS_NUMBER_BUF         (SHM_VALUE_SIZE + 64)

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

SL_EXPORT int sl_info(struct sl_client *c, int id, struct sl_var_info *ret)
{
        const struct shm_dir_entry *e;
        struct sl_var_info info;
        int index;

        if (!c || !ret || ret->size < SL_VAR_INFO_SIZE_V1)
                return -EINVAL;
        client_rdlock(c);
        index = client_index(c, id);
        if (index < 0) {
                client_unlock(c);
                return index;
        }
        e = &c->map->dir[index];
        memset(&info, 0, sizeof(info));
        client_copy_field(info.name, sizeof(info.name), e->name, sizeof(e->name));
        client_copy_field(info.peer, sizeof(info.peer), e->peer, sizeof(e->peer));
        info.direction = e->direction;
        info.type = e->type;
        info.link = e->link == SHM_LINK_NONE ? -1 : (int)e->link;
        info.position = e->position;
        info.flags = e->flags;
        client_unlock(c);
        client_struct_out(ret, &info, sizeof(info));
        return 0;
}

/* Fills *meta from a slot copy (meta->size already checked). */
static void meta_fill(struct sl_meta *meta, const struct shm_slot_copy *copy, uint64_t sequence,
                      uint32_t extra_flags, uint64_t now)
{
        struct sl_meta m;

        memset(&m, 0, sizeof(m));
        m.mono_ns = copy->mono_ns;
        m.real_ns = copy->real_ns;
        m.age_ns = copy->mono_ns && now > copy->mono_ns ? now - copy->mono_ns : 0;
        m.sequence = sequence;
        m.flags = (copy->flags & (SL_FLAG_VALID | SL_FLAG_STALE | SL_FLAG_OUTBOUND |
                                  SL_FLAG_REPAIRED)) | extra_flags;
        client_struct_out(meta, &m, sizeof(m));
}

/*
 * Reads the .out slot of an outbound variable into *copy (read lock held). Returns 1 with a valid
 * copy, 0 when it holds no valid value (never written, repaired, recreated, scribbled), or -EAGAIN.
 * The slot is client-writable: the copy is validated like the daemon does before it is used.
 */
static int read_out_slot(const struct sl_client *c, const struct shm_dir_entry *e,
                         struct shm_slot_copy *copy, uint64_t *ret_sequence)
{
        int r;

        if (!c->out || e->out_slot >= c->out_capacity)
                return 0;
        r = shm_slot_read(&c->out_slots[e->out_slot], copy);
        if (r < 0)
                return r;
        if (shm_slot_copy_check(copy) < 0)
                return 0;
        copy->flags |= SHM_SLOT_OUTBOUND;
        *ret_sequence = shm_seqlock_sequence(copy->word) / 2u;
        return 1;
}

/*
 * One consistent, validated copy of variable id's value, plus the flags that apply to it: the
 * value NUL-terminated in value[0..SHM_VALUE_SIZE) (the caller's buffer, or copy->value; either is
 * scratch space, unspecified on failure), the rest in *copy. Reading straight into the caller's
 * buffer spares the hot path a second copy of the value (see shm_slot_read_to).
 */
static int read_copy(struct sl_client *c, int id, struct shm_slot_copy *copy, char *value,
                     uint64_t *ret_sequence, uint32_t *ret_extra, uint64_t now)
{
        const struct shm_dir_entry *e;
        uint64_t sequence = 0;
        int index, r = 0;

        client_rdlock(c);
        index = client_index(c, id);
        if (index < 0) {
                client_unlock(c);
                return index;
        }
        e = &c->map->dir[index];
        if (e->direction == SHM_DIR_OUT) {
                r = read_out_slot(c, e, copy, &sequence);
                if (r == 1 && value != copy->value)
                        memcpy(value, copy->value, SHM_VALUE_SIZE);
        }
        if (r == 0) {
                /* .in: the daemon's own value, or its mirror of the last accepted outbound one */
                r = shm_slot_read_to(&c->map->slots[index], copy, value);
                if (r == 0) {
                        sequence = copy->word / 2u;
                        if (copy->length > SHM_VALUE_MAX || !(copy->flags & SHM_SLOT_VALID))
                                copy->length = 0;
                }
        }
        *ret_extra = !now || client_alive(c, now, NULL) ? 0 : SL_FLAG_STALE;
        client_unlock(c);
        if (r < 0)
                return r;
        value[copy->length] = '\0';
        *ret_sequence = sequence;
        return 0;
}

SL_EXPORT int sl_read(struct sl_client *c, int id, char *buf, size_t size, struct sl_meta *meta)
{
        struct shm_slot_copy copy;
        uint64_t sequence, now;
        uint32_t extra;
        char *value;
        int r;

        if (!c || !buf || (meta && meta->size < SL_META_SIZE_V1))
                return -EINVAL;
        /* The clock (~20-30 ns) only matters for the metadata: age, and stale by heartbeat. */
        now = meta ? client_now(CLOCK_MONOTONIC) : 0;
        /* A buffer that holds any value is read into directly; a smaller one gets a copy. */
        value = size >= SHM_VALUE_SIZE ? buf : copy.value;
        r = read_copy(c, id, &copy, value, &sequence, &extra, now);
        if (r < 0)
                return r;
        if (value != buf) {
                if (size < (size_t)copy.length + 1u)
                        return -ENOBUFS;
                memcpy(buf, copy.value, copy.length + 1u);
        }
        if (meta)
                meta_fill(meta, &copy, sequence, extra, now);
        return (int)copy.length;
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
        if (r < 0)
                return r;
        shm_slot_store(slot, value, (uint32_t)len, SHM_SLOT_VALID | SHM_SLOT_OUTBOUND,
                       client_now(CLOCK_MONOTONIC), client_now(CLOCK_REALTIME));
        r = shm_slot_publish(slot, word);
        if (r < 0)
                return r;
        /* Tell the daemon: bump after the publish (release orders it after the value), and wake
         * its wake thread, the only waiter on this word. */
        atomic_fetch_add_explicit(&c->out->change, 1u, memory_order_release);
        shm_futex_wake(&c->out->change, 1);
        return 0;
}

SL_EXPORT int sl_write(struct sl_client *c, int id, const char *value)
{
        size_t len;
        int r;

        if (!c || !value)
                return -EINVAL;
        client_rdlock(c);
        r = client_index(c, id);
        if (r >= 0 && c->map->dir[r].direction != SHM_DIR_OUT)
                r = -EPERM;
        if (r >= 0) {
                len = strnlen(value, SHM_VALUE_SIZE);
                r = shm_layout_value_check(value, len);
        }
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
