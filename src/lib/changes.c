/*
 * Which variables changed since a cursor: the daemon's change record in .in (layout 1.7,
 * src/shm/changes.h) read through the handle's ids.
 *
 * A cursor is the record's position (the number of the next entry to read) in its low 48 bits
 * and a tag of the handle's view above it: the view moves whenever the ids are resolved anew (a
 * daemon restart, a name retired or reused: client.c), after which a directory index in the
 * record may name another id than it did, so a cursor of an older view answers "read
 * everything". 48 bits of position are 2.8e14 changes: years at any rate a daemon reaches.
 */
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include <sharedlink.h>

#include "lib/client.h"
#include "lib/export.h"
#include "shm/changes.h"

#define CHANGES_CURSOR_SHIFT    48
#define CHANGES_POS_MASK        ((UINT64_C(1) << CHANGES_CURSOR_SHIFT) - 1u)
#define CHANGES_TAGS            0xffffu         /* tags 1..0xffff: 0 is the new cursor's */
#define CHANGES_CHUNK           64u             /* record entries copied at a time */
#define CHANGES_ENV             "SHAREDLINK_CHANGES"
#define CHANGES_ENV_ALL         "all"

int client_changes_all_env(void)
{
        const char *v = getenv(CHANGES_ENV);

        return v && strcmp(v, CHANGES_ENV_ALL) == 0;
}

/* The tag of the handle's current view (read lock held). */
static uint64_t view_tag(const struct sl_client *c)
{
        return (uint64_t)(c->view % CHANGES_TAGS) + 1u;
}

static uint64_t cursor_make(const struct sl_client *c, uint64_t pos)
{
        return view_tag(c) << CHANGES_CURSOR_SHIFT | (pos & CHANGES_POS_MASK);
}

/*
 * Where a cursor of this view stands in the record whose head is head: 0 with *ret_pos, or the
 * SL_CHANGED_* reason why everything must be read.
 */
static uint32_t cursor_position(const struct sl_client *c, const struct shm_changes *rec,
                                uint64_t cursor, uint64_t head, uint64_t *ret_pos)
{
        uint64_t behind;

        if (cursor == 0)
                return SL_CHANGED_START;
        if (cursor >> CHANGES_CURSOR_SHIFT != view_tag(c))
                return SL_CHANGED_REMAPPED;
        behind = (head - cursor) & CHANGES_POS_MASK;
        if (behind > CHANGES_POS_MASK / 2u)
                return SL_CHANGED_REMAPPED;     /* ahead of the record: not one of its cursors */
        if (behind > rec->capacity)
                return SL_CHANGED_OVERRUN;
        *ret_pos = head - behind;
        return 0;
}

/*
 * Copies ids of the entries from *pos on into ids[*n..max-1] (read lock held). Returns 0 when
 * it stopped (nothing more, or ids full), 1 when an entry names a directory index the view has
 * not given an id yet (*pos at it: a name added after the lock was taken), or the SL_CHANGED_*
 * reason to read everything. relocked: the view was refreshed for such an entry already; one
 * still without an id then has none to read (the handle is out of ids) and is passed over.
 */
static int collect(const struct sl_client *c, const struct shm_changes *rec, uint64_t *pos,
                   int *ids, size_t max, size_t *n, int relocked)
{
        uint32_t idx[CHANGES_CHUNK];

        while (*n < max) {
                size_t want = max - *n < CHANGES_CHUNK ? max - *n : CHANGES_CHUNK;
                uint64_t at = *pos;
                int r = shm_changes_read(rec, pos, c->map->capacity, idx, want);

                if (r < 0)
                        return r == -ESTALE ? SL_CHANGED_REMAPPED : SL_CHANGED_OVERRUN;
                if (r == 0)
                        return 0;
                for (int k = 0; k < r; k++) {
                        uint32_t i = idx[k];

                        if (i >= c->synced) {
                                if (relocked)
                                        continue;
                                *pos = at + (uint64_t)k;
                                return 1;
                        }
                        /* A retired entry has no id: the name's end came with a new view. */
                        if (c->index_id[i] >= 0)
                                ids[(*n)++] = c->index_id[i];
                }
        }
        return 0;
}

SL_EXPORT int sl_changed(struct sl_client *c, uint64_t *cursor, int *ids, size_t max,
                         uint32_t *ret_flags)
{
        struct shm_changes rec;
        uint64_t pos = 0, tag;
        uint32_t flags;
        size_t n = 0;
        int r;

        if (!c || !cursor || !ret_flags || (max && !ids))
                return -EINVAL;
        client_rdlock(c);
        if (c->changes_all || shm_changes_map(c->map->in, c->map->size, c->map->in, &rec) < 0) {
                /* A cursor of no record: a record that shows up (a new daemon) starts it. */
                flags = SL_CHANGED_ALL | SL_CHANGED_UNAVAILABLE;
                *cursor = 0;
                goto out;
        }
        flags = cursor_position(c, &rec, *cursor, shm_changes_head(&rec), &pos);
        tag = view_tag(c);
        for (int relocked = 0; !flags; relocked = 1) {
                r = collect(c, &rec, &pos, ids, max, &n, relocked);
                if (r != 1) {
                        flags = (uint32_t)r;
                        break;
                }
                /* A name added after the lock was taken (shm_table_add notes it after the
                 * count): the next lock gives it an id. If the ids were resolved anew meanwhile,
                 * those taken so far may be of the old view: everything then. */
                client_unlock(c);
                client_rdlock(c);
                if (view_tag(c) != tag ||
                    shm_changes_map(c->map->in, c->map->size, c->map->in, &rec) < 0)
                        flags = SL_CHANGED_REMAPPED;
        }
        if (flags) {
                /* From the head as it is before the caller's full read: every change after it
                 * is in the next answer. */
                flags |= SL_CHANGED_ALL;
                n = 0;
                if (shm_changes_map(c->map->in, c->map->size, c->map->in, &rec) == 0)
                        pos = shm_changes_head(&rec);
        } else if (pos < shm_changes_head(&rec)) {
                flags = SL_CHANGED_MORE;
        }
        *cursor = cursor_make(c, pos);
out:
        *ret_flags = flags;
        client_unlock(c);
        return (int)n;
}
