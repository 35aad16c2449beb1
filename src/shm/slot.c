/*
 * Value slots: bounded seqlock reads and the writers of .in and .out (see slot.h, seqlock.h).
 */
#include "shm/slot.h"

#include <errno.h>
#include <sched.h>
#include <string.h>

#include "shm/seqlock.h"

int shm_slot_read(const struct shm_slot *slot, struct shm_slot_copy *copy)
{
        struct shm_slot_head head;
        int r = shm_slot_read_to(slot, &head, copy->value);

        if (r < 0)
                return r;       /* *copy is scratch space after -EAGAIN anyway */
        copy->word = head.word;
        copy->mono_ns = head.mono_ns;
        copy->real_ns = head.real_ns;
        copy->flags = head.flags;
        copy->length = head.length;
        copy->source = head.source;
        copy->dir_stamp = head.dir_stamp;
        return 0;
}

uint64_t shm_slot_word(const struct shm_slot *slot)
{
        return atomic_load_explicit(&slot->seq, memory_order_acquire);
}

static void slot_store_value(struct shm_slot *slot, const char *value, uint32_t len)
{
        uint64_t words[SHM_VALUE_WORDS];

        /* NUL-padded to the whole field, so a reader never sees bytes of an older, longer value. */
        memset(words, 0, sizeof(words));
        memcpy(words, value, len);
        for (unsigned i = 0; i < SHM_VALUE_WORDS; i++)
                atomic_store_explicit(&slot->value[i], words[i], SHM_SEQLOCK_PAYLOAD_STORE);
}

void shm_slot_store(struct shm_slot *slot, const char *value, uint32_t len, uint32_t flags,
                    uint64_t mono_ns, uint64_t real_ns)
{
        atomic_store_explicit(&slot->mono_ns, mono_ns, SHM_SEQLOCK_PAYLOAD_STORE);
        atomic_store_explicit(&slot->real_ns, real_ns, SHM_SEQLOCK_PAYLOAD_STORE);
        atomic_store_explicit(&slot->length, len, SHM_SEQLOCK_PAYLOAD_STORE);
        slot_store_value(slot, value, len);
        atomic_store_explicit(&slot->flags, flags, SHM_SEQLOCK_PAYLOAD_STORE);
}

void shm_slot_store_stamp(struct shm_slot *slot, uint32_t dir_stamp)
{
        atomic_store_explicit(&slot->dir_stamp, dir_stamp, SHM_SEQLOCK_PAYLOAD_STORE);
}

void shm_slot_store_word(struct shm_slot *slot, unsigned i, uint64_t w)
{
        if (i < SHM_VALUE_WORDS)
                atomic_store_explicit(&slot->value[i], w, SHM_SEQLOCK_PAYLOAD_STORE);
}

void shm_slot_write_mirror(struct shm_slot *slot, const char *value, uint32_t len, uint32_t flags,
                           uint64_t mono_ns, uint64_t real_ns, uint64_t source)
{
        uint64_t odd = shm_seqlock_write_begin(&slot->seq);

        shm_slot_store(slot, value, len, flags, mono_ns, real_ns);
        atomic_store_explicit(&slot->source, source, SHM_SEQLOCK_PAYLOAD_STORE);
        shm_seqlock_write_end(&slot->seq, odd);
}

void shm_slot_write(struct shm_slot *slot, const char *value, uint32_t len, uint32_t flags,
                    uint64_t mono_ns, uint64_t real_ns)
{
        shm_slot_write_mirror(slot, value, len, flags, mono_ns, real_ns, 0);
}

void shm_slot_write_flags(struct shm_slot *slot, uint32_t flags)
{
        uint64_t odd = shm_seqlock_write_begin(&slot->seq);

        atomic_store_explicit(&slot->flags, flags, SHM_SEQLOCK_PAYLOAD_STORE);
        shm_seqlock_write_end(&slot->seq, odd);
}

int shm_slot_claim(struct shm_slot *slot, uint32_t pid, uint64_t *ret_word)
{
        for (unsigned attempt = 0; attempt < SHM_SLOT_CLAIM_TRIES; attempt++) {
                uint64_t word, seen;

                if (shm_seqlock_claim(&slot->seq, pid, &word, &seen) == 0) {
                        *ret_word = word;
                        return 0;
                }
                /* Another writer holds it: spin briefly, then let it run (it may share our CPU). */
                if (attempt < SHM_SLOT_CLAIM_SPINS)
                        shm_seqlock_relax();
                else
                        sched_yield();
        }
        return -EBUSY;
}

int shm_slot_publish(struct shm_slot *slot, uint64_t odd_word)
{
        return shm_seqlock_release(&slot->seq, odd_word);
}

int shm_slot_repair(struct shm_slot *slot, uint64_t odd_word, uint32_t self_pid,
                    uint64_t mono_ns, uint64_t real_ns)
{
        uint64_t expected = odd_word;
        /* Still odd, now ours: a writer cannot claim it, and readers keep retrying. */
        uint64_t ours = ((uint64_t)self_pid << 32) |
                        ((odd_word + 2u) & SHM_SEQLOCK_SEQ_MASK);

        if (!atomic_compare_exchange_strong_explicit(&slot->seq, &expected, ours,
                                                     memory_order_acquire, memory_order_relaxed))
                return -EAGAIN;
        shm_seqlock_fence_release();                    /* as in shm_seqlock_claim */
        shm_slot_store(slot, "", 0, SHM_SLOT_REPAIRED, mono_ns, real_ns);
        /* A length no value has. The writer taken over may be alive (stopped past the daemon's
         * bound) and store the rest of its value once it runs again, the lock no longer its.
         * Whatever tail of its stores lands, the value words or the flags, this length stays and
         * every check refuses the slot: never half a value. (One stopped before its length
         * store leaves its whole value under our even word: see shm_table_out_scan.) */
        atomic_store_explicit(&slot->length, SHM_SLOT_LENGTH_NONE, SHM_SEQLOCK_PAYLOAD_STORE);
        return shm_seqlock_release(&slot->seq, ours) == 0 ? 0 : -EAGAIN;
}

static int slot_check(uint32_t flags, uint32_t length, const char *value)
{
        if (!(flags & SHM_SLOT_VALID))
                return -EINVAL;
        if (length > SHM_VALUE_MAX || value[length] != '\0')
                return -EINVAL;
        return shm_layout_value_check_field(value, length);
}

int shm_slot_head_check(const struct shm_slot_head *head, const char *value)
{
        return slot_check(head->flags, head->length, value);
}

int shm_slot_copy_check(const struct shm_slot_copy *copy)
{
        return slot_check(copy->flags, copy->length, copy->value);
}
