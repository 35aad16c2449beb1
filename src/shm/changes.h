/*
 * The change record in .in (layout 1.7): a ring of slot indexes the daemon, its single writer,
 * appends to as it rewrites slots, with a 64-bit head (entries written so far). Readers follow it
 * read-only, each with its own position (the number of the next entry to read), and learn when
 * they fell behind.
 *
 * Entry n (numbered from 0) lives at n % capacity and holds (n mod 2^32) << 32 | slot index. A
 * reader checks the position an entry holds against the one it wants: a later lap's entry is an
 * overrun, never taken for the one it replaced. One 64-bit word per entry, so nothing is torn; no
 * per-entry sequence, since readers cannot write to claim or confirm anything.
 *
 * Ordering: the producer stores entries (relaxed) as it notes them, then release-stores the head
 * once per batch, before the change word's bump; a reader acquire-loads the head, so every entry
 * below it is at least as new as the one the head's store covered. An entry may be overwritten
 * after the head was read (the producer notes ahead of its next head store): its position says so.
 */
#ifndef SHM_CHANGES_H
#define SHM_CHANGES_H

#include <stddef.h>
#include <stdint.h>

#include "shm/layout.h"

/* The head, alone on its cache line (SHM_CHANGES_HEAD bytes), before the entries. */
struct shm_changes_head {
        _Atomic uint64_t head;                  /* entries written (published) so far */
        uint8_t reserved[SHM_CHANGES_HEAD - sizeof(uint64_t)];
};

static_assert(sizeof(struct shm_changes_head) == SHM_CHANGES_HEAD, "change record head size");

/* A mapped change record: the head and capacity entries (a power of two). */
struct shm_changes {
        struct shm_changes_head *head;
        _Atomic uint64_t *entries;
        uint32_t capacity;
};

/* The record of a .in object mapped at base (writable or not: readers never write), from a
 * checked header; 0, or -ENOENT when it has none (shm_layout_has_changes). */
int shm_changes_map(const struct shm_in_header *h, uint64_t object_size, const void *base,
                    struct shm_changes *ret);

/* Producer: notes slot index at position *next and advances it; published by the next
 * shm_changes_publish. */
void shm_changes_note(struct shm_changes *r, uint64_t *next, uint32_t index);

/* Producer: publishes every entry noted below next (release). */
void shm_changes_publish(struct shm_changes *r, uint64_t next);

/* Reader: the head (acquire). */
uint64_t shm_changes_head(const struct shm_changes *r);

/*
 * Reader: copies the slot indexes of entries *pos .. head - 1 (at most max) into ret and
 * advances *pos past them. Returns how many, 0 when there is nothing new; -EOVERFLOW when an
 * entry wanted was overwritten (the reader fell behind by more than the capacity) or holds an
 * index not below limit (not a record this reader understands): *pos is then set to the head,
 * and the caller must assume anything changed; -ESTALE when *pos is past the head (a position of
 * another record), *pos untouched.
 */
int shm_changes_read(const struct shm_changes *r, uint64_t *pos, uint32_t limit, uint32_t *ret,
                     size_t max);

#endif
