/*
 * The change record (see changes.h).
 */
#include "shm/changes.h"

#include <errno.h>

#define CHANGES_TAG_SHIFT       32
#define CHANGES_INDEX_MASK      UINT64_C(0xffffffff)

int shm_changes_map(const struct shm_in_header *h, uint64_t object_size, const void *base,
                    struct shm_changes *ret)
{
        char *p;

        if (!shm_layout_has_changes(h, object_size))
                return -ENOENT;
        /* The daemon's side maps the same object writable; a reader never stores through it. */
        p = (char *)(uintptr_t)base + h->changes_offset;
        ret->head = (struct shm_changes_head *)(void *)p;
        ret->entries = (_Atomic uint64_t *)(void *)(p + SHM_CHANGES_HEAD);
        ret->capacity = h->changes_capacity;
        return 0;
}

static uint64_t entry_word(uint64_t n, uint32_t index)
{
        return (n & CHANGES_INDEX_MASK) << CHANGES_TAG_SHIFT | index;
}

void shm_changes_note(struct shm_changes *r, uint64_t *next, uint32_t index)
{
        uint64_t n = (*next)++;

        /* Relaxed: published by the head's release store; a reader that gets here before it
         * sees a position it did not ask for. */
        atomic_store_explicit(&r->entries[n & (r->capacity - 1u)], entry_word(n, index),
                              memory_order_relaxed);
}

void shm_changes_publish(struct shm_changes *r, uint64_t next)
{
        atomic_store_explicit(&r->head->head, next, memory_order_release);
}

uint64_t shm_changes_head(const struct shm_changes *r)
{
        return atomic_load_explicit(&r->head->head, memory_order_acquire);
}

int shm_changes_read(const struct shm_changes *r, uint64_t *pos, uint32_t limit, uint32_t *ret,
                     size_t max)
{
        uint64_t head = shm_changes_head(r), n = *pos;
        size_t got = 0;

        if (n > head)
                return -ESTALE;
        if (head - n > r->capacity)
                goto overrun;
        for (; n < head && got < max; n++) {
                uint64_t w = atomic_load_explicit(&r->entries[n & (r->capacity - 1u)],
                                                  memory_order_relaxed);

                /* Another position: a later lap overwrote it (or the word is not an entry). */
                if (w >> CHANGES_TAG_SHIFT != (n & CHANGES_INDEX_MASK) ||
                    (w & CHANGES_INDEX_MASK) >= limit)
                        goto overrun;
                ret[got++] = (uint32_t)(w & CHANGES_INDEX_MASK);
        }
        *pos = n;
        return (int)got;
overrun:
        *pos = shm_changes_head(r);
        return -EOVERFLOW;
}
