/*
 * Value slots (struct shm_slot): the bounded seqlock reader, the single writer (.in), and the
 * claim/store/publish steps of a writer of .out, plus the daemon's repair of an abandoned slot.
 * Everything here touches the slot only through relaxed atomic words (see seqlock.h).
 */
#ifndef SHM_SLOT_H
#define SHM_SLOT_H

#include <errno.h>
#include <stdint.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "shm/layout.h"
#include "shm/seqlock.h"

#define SHM_SLOT_CLAIM_SPINS    64u     /* claim attempts before yielding the CPU */
#define SHM_SLOT_CLAIM_TRIES    1024u   /* claim attempts in all before -EBUSY */

/* A private copy of a slot: what the bounded reader hands out (never a torn one). */
struct shm_slot_copy {
        uint64_t word;                  /* the even seqlock word the copy was taken under */
        uint64_t mono_ns;
        uint64_t real_ns;
        uint32_t flags;
        uint32_t length;
        char value[SHM_VALUE_SIZE];     /* raw bytes as found: validate before trusting */
        uint64_t source;                /* shm_slot.source */
        uint32_t dir_stamp;             /* shm_slot.dir_stamp (.out, layout 1.5) */
};

/*
 * Bounded seqlock read: copies the slot into *copy and returns 0, or returns -EAGAIN after
 * SHM_SEQLOCK_TRIES attempts that all found it odd or changing. The copy is consistent but not
 * validated (length, charset): use shm_slot_copy_check for memory a client can write.
 * Unlike a ret_ parameter, *copy is the scratch buffer of the attempts and holds garbage after
 * -EAGAIN: copying a private copy out on success instead cost 2.7x (26 vs 9.5 ns, x86-64, a
 * store-forwarding stall), and this is the hot path of every client read.
 */
int shm_slot_read(const struct shm_slot *slot, struct shm_slot_copy *copy);

/* What shm_slot_read_to hands out besides the value: struct shm_slot_copy without its value. */
struct shm_slot_head {
        uint64_t word;
        uint64_t mono_ns;
        uint64_t real_ns;
        uint32_t flags;
        uint32_t length;
        uint64_t source;                /* shm_slot.source (a .in mirror), else 0 */
        uint32_t dir_stamp;             /* shm_slot.dir_stamp (.out, layout 1.5), else 0 */
};

/* Fields of struct shm_slot_head a read loads besides word, flags and length (others read 0). */
#define SHM_SLOT_HEAD_TIMES     0x1u    /* mono_ns, real_ns */
#define SHM_SLOT_HEAD_SOURCE    0x2u    /* source */
#define SHM_SLOT_HEAD_STAMP     0x4u    /* dir_stamp */
#define SHM_SLOT_HEAD_ALL       (SHM_SLOT_HEAD_TIMES | SHM_SLOT_HEAD_SOURCE | SHM_SLOT_HEAD_STAMP)

/*
 * shm_slot_read with the value going straight to value[0..SHM_VALUE_SIZE) and the rest to *head,
 * loading only the head fields named in `fields` (a constant once inlined: an inbound read needs
 * neither source nor dir_stamp, a read without metadata no time stamps, and each load left out is
 * one saved on every client read); the same garbage rule holds for both after -EAGAIN. For the
 * client's read into its caller's buffer: a second copy of the value from a private one would be
 * read with wider loads than the 8-byte stores that wrote it, and stall on store forwarding
 * (x86-64: sl_read 40 -> 31 ns). Inline, so that the client's read keeps *head in registers: the
 * call and the copy in memory were a third of an sl_read.
 */
static inline __attribute__((always_inline)) int
shm_slot_read_fields(const struct shm_slot *slot, struct shm_slot_head *head, char *value,
                     unsigned fields)
{
        for (unsigned attempt = 0; attempt < SHM_SEQLOCK_TRIES; attempt++) {
                uint64_t start = shm_seqlock_read_begin(&slot->seq);

                if (shm_seqlock_odd(start)) {
                        shm_seqlock_relax();
                        continue;
                }
                head->mono_ns = 0;
                head->real_ns = 0;
                head->source = 0;
                head->dir_stamp = 0;
                if (fields & SHM_SLOT_HEAD_TIMES) {
                        head->mono_ns = atomic_load_explicit(&slot->mono_ns,
                                                             SHM_SEQLOCK_PAYLOAD_LOAD);
                        head->real_ns = atomic_load_explicit(&slot->real_ns,
                                                             SHM_SEQLOCK_PAYLOAD_LOAD);
                }
                head->flags = atomic_load_explicit(&slot->flags, SHM_SEQLOCK_PAYLOAD_LOAD);
                head->length = atomic_load_explicit(&slot->length, SHM_SEQLOCK_PAYLOAD_LOAD);
                if (fields & SHM_SLOT_HEAD_SOURCE)
                        head->source = atomic_load_explicit(&slot->source,
                                                            SHM_SEQLOCK_PAYLOAD_LOAD);
                if (fields & SHM_SLOT_HEAD_STAMP)
                        head->dir_stamp = atomic_load_explicit(&slot->dir_stamp,
                                                               SHM_SEQLOCK_PAYLOAD_LOAD);
#if defined(__SSE2__) && !defined(SHM_SEQLOCK_TSAN)
                /* Four 16-byte loads and stores instead of eight of 8 bytes: the value is 16-byte
                 * aligned in every slot (struct shm_slot), but a scribbled .out could move its
                 * slots, so the loads do not assume it. Loads outside the C memory model, as a
                 * seqlock's payload may be: the retry below (its acquire fence is a compiler
                 * barrier too) throws away whatever they saw torn. ThreadSanitizer builds keep
                 * the atomic loads, which it understands. */
                {
                        _Static_assert(SHM_VALUE_SIZE == 4u * sizeof(__m128i), "value size");
                        const __m128i *src = (const __m128i *)(uintptr_t)slot->value;
                        __m128i v0 = _mm_loadu_si128(src), v1 = _mm_loadu_si128(src + 1);
                        __m128i v2 = _mm_loadu_si128(src + 2), v3 = _mm_loadu_si128(src + 3);

                        _mm_storeu_si128((__m128i *)(void *)value, v0);
                        _mm_storeu_si128((__m128i *)(void *)(value + 16), v1);
                        _mm_storeu_si128((__m128i *)(void *)(value + 32), v2);
                        _mm_storeu_si128((__m128i *)(void *)(value + 48), v3);
                }
#else
                /* Unrolled: the loop's own counting was a fifth of an sl_read. */
#pragma GCC unroll 8
                for (unsigned i = 0; i < SHM_VALUE_WORDS; i++) {
                        uint64_t w = atomic_load_explicit(&slot->value[i],
                                                          SHM_SEQLOCK_PAYLOAD_LOAD);

                        memcpy(value + 8u * i, &w, sizeof(w));  /* one 8-byte store */
                }
#endif
                if (shm_seqlock_read_retry(&slot->seq, start))
                        continue;
                head->word = start;
                return 0;
        }
        return -EAGAIN;
}

/* shm_slot_read_fields of every field. */
static inline __attribute__((always_inline)) int
shm_slot_read_to(const struct shm_slot *slot, struct shm_slot_head *head, char *value)
{
        return shm_slot_read_fields(slot, head, value, SHM_SLOT_HEAD_ALL);
}

/* Acquire load of the seqlock word (the daemon's "did it change since the last scan"). */
uint64_t shm_slot_word(const struct shm_slot *slot);

/*
 * Single writer of an .in slot: stores value[0..len) (len <= SHM_VALUE_MAX, not checked here),
 * flags and time stamps under the seqlock.
 */
void shm_slot_write(struct shm_slot *slot, const char *value, uint32_t len, uint32_t flags,
                    uint64_t mono_ns, uint64_t real_ns);

/*
 * Single writer: shm_slot_write of the .in mirror of an outbound variable, recording the .out
 * lock word (`source`, even) the value was copied under.
 */
void shm_slot_write_mirror(struct shm_slot *slot, const char *value, uint32_t len, uint32_t flags,
                           uint64_t mono_ns, uint64_t real_ns, uint64_t source);

/* Single writer: rewrites only the flags of an .in slot (value and time stamps kept). */
void shm_slot_write_flags(struct shm_slot *slot, uint32_t flags);

/*
 * Writer of an .out slot, step 1: takes the slot for pid (bounded spinning, then yielding).
 * Returns 0 with the odd word in *ret_word, or -EBUSY when another writer keeps it.
 */
int shm_slot_claim(struct shm_slot *slot, uint32_t pid, uint64_t *ret_word);

/* Step 2 (with shm_slot_store): the dir_rewrites of the writer's view (layout 1.5). */
void shm_slot_store_stamp(struct shm_slot *slot, uint32_t dir_stamp);

/* Step 2: stores the payload into a claimed slot (any number of times, in any order). */
void shm_slot_store(struct shm_slot *slot, const char *value, uint32_t len, uint32_t flags,
                    uint64_t mono_ns, uint64_t real_ns);

/* Step 2, piecemeal (tests kill writers half-way): stores value word i only. */
void shm_slot_store_word(struct shm_slot *slot, unsigned i, uint64_t w);

/* Step 3: publishes and frees the slot. Returns 0, or -ECANCELED when the daemon took it over. */
int shm_slot_publish(struct shm_slot *slot, uint64_t odd_word);

/*
 * Daemon: takes over a slot left odd (odd_word) by a writer that is gone or stalled past the
 * bound, marks it not valid (SHM_SLOT_REPAIRED, zero value, SHM_SLOT_LENGTH_NONE) and releases it
 * even. Returns 0, or -EAGAIN when the word is no
 * longer odd_word (the writer finished after all, or another repair won).
 */
int shm_slot_repair(struct shm_slot *slot, uint64_t odd_word, uint32_t self_pid,
                    uint64_t mono_ns, uint64_t real_ns);

/*
 * Validates a copy taken from memory a client can write: SHM_SLOT_VALID set, length <= 63, every
 * byte of the value in the wire charset, NUL at value[length]. Returns 0 or -EINVAL.
 */
int shm_slot_copy_check(const struct shm_slot_copy *copy);

/* shm_slot_copy_check for what shm_slot_read_to handed out. */
int shm_slot_head_check(const struct shm_slot_head *head, const char *value);

#endif
