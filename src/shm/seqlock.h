/*
 * Seqlocks over a 64-bit word in shared memory, in Concurrency Kit's vocabulary (ck_sequence.h):
 * read_begin / read_retry on the reader side, write_begin / write_end for a single writer, and
 * claim / release for several writers in different processes.
 *
 * The protected payload must be read and written with *relaxed atomic* loads and stores of
 * lock-free 4/8-byte words, never plain memcpy: the reader races with the writer on purpose, a
 * plain access would be a data race (undefined behaviour, and the compiler may re-load a field
 * after it was validated). On x86-64 relaxed atomics compile to the same plain movs.
 *
 * Word: even = stable, odd = a write is in progress. For the multi-writer form the low 32 bits
 * are the sequence and the high 32 bits the pid of the writer holding (or last holding) the slot,
 * so oddness is always bit 0 and a reader compares the whole 64-bit word.
 *
 * Why the fences stand where they do (Boehm, "Can seqlocks get along with programming language
 * memory models?", fig. 6; the same pattern as jemalloc seq.h, DPDK rte_seqcount.h):
 *
 *   writer:  seq = s+1 (relaxed);  RELEASE FENCE;  payload stores (relaxed);  seq = s+2 (release)
 *   reader:  s0 = seq (acquire);  payload loads (relaxed);  ACQUIRE FENCE;  s1 = seq (relaxed)
 *
 *   - The writer's release fence after the odd store pairs with the reader's acquire fence: if any
 *     payload load read a value stored after the writer's fence, the fences synchronize, so the
 *     odd store (before the writer's fence) happens-before the reader's s1 load (after its fence)
 *     and s1 != s0. Without the writer's fence the payload stores could become visible before the
 *     odd seq; without the reader's fence the payload loads could be performed after the s1 load.
 *     An acquire *load* for s1 would be the wrong tool: acquire stops later accesses moving up,
 *     not earlier loads moving down.
 *   - The release store of the even seq pairs with the acquire load of s0: a reader that sees s+2
 *     sees every payload store of that write.
 *   - A read-modify-write for s1 (Boehm's alternative) is not usable: clients map .in PROT_READ.
 *   - On x86-64 both fences are compiler barriers only; on arm64 they are dmb ishld / dmb ish.
 *
 * ThreadSanitizer does not model standalone fences (and GCC refuses them under -fsanitize=thread,
 * -Wtsan). In a TSAN build the fences are therefore replaced by ordering on the payload accesses
 * themselves: payload stores become release and payload loads acquire. That is a correct seqlock
 * on its own (a reader whose acquire load reads a payload store of write W synchronizes with it,
 * so W's odd seq store happens-before the reader's reload of seq, which then differs), which TSAN
 * models completely; it is merely stronger than needed. Normal builds keep the relaxed accesses
 * and the fences; the stress test checks those by checksums (on x86-64 both compile to plain movs).
 */
#ifndef SHM_SEQLOCK_H
#define SHM_SEQLOCK_H

#include <errno.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#define SHM_SEQLOCK_TRIES       64u     /* bounded reader: attempts before -EAGAIN */
#define SHM_SEQLOCK_SEQ_MASK    UINT64_C(0xffffffff)

#if defined(__SANITIZE_THREAD__)
#define SHM_SEQLOCK_TSAN        1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define SHM_SEQLOCK_TSAN        1
#endif
#endif

/* Memory order of the payload loads and stores inside read and write sections (see above). */
#if defined(SHM_SEQLOCK_TSAN)
#define SHM_SEQLOCK_PAYLOAD_LOAD        memory_order_acquire
#define SHM_SEQLOCK_PAYLOAD_STORE       memory_order_release
#else
#define SHM_SEQLOCK_PAYLOAD_LOAD        memory_order_relaxed
#define SHM_SEQLOCK_PAYLOAD_STORE       memory_order_relaxed
#endif

/* Writer side: after the seq word went odd, before the payload stores (see above). */
static inline void shm_seqlock_fence_release(void)
{
#if !defined(SHM_SEQLOCK_TSAN)
        atomic_thread_fence(memory_order_release);
#endif
}

/* Reader side: after the payload loads, before the reload of seq (see above). */
static inline void shm_seqlock_fence_acquire(void)
{
#if !defined(SHM_SEQLOCK_TSAN)
        atomic_thread_fence(memory_order_acquire);
#endif
}

/* Pause hint inside a spin loop. */
static inline void shm_seqlock_relax(void)
{
#if defined(__x86_64__) || defined(__i386__)
        __builtin_ia32_pause();
#elif defined(__aarch64__)
        __asm__ __volatile__("yield" ::: "memory");
#else
        atomic_signal_fence(memory_order_seq_cst);
#endif
}

/* True when the word says a write is in progress. */
static inline bool shm_seqlock_odd(uint64_t word)
{
        return (word & 1u) != 0;
}

/* Pid part of a multi-writer word. */
static inline uint32_t shm_seqlock_pid(uint64_t word)
{
        return (uint32_t)(word >> 32);
}

/* Sequence part (low 32 bits) of a multi-writer word. */
static inline uint32_t shm_seqlock_sequence(uint64_t word)
{
        return (uint32_t)(word & SHM_SEQLOCK_SEQ_MASK);
}

/*
 * Reader: start of a read section. The acquire load orders the payload loads after it and pairs
 * with write_end's release store. The caller checks oddness (and retries) itself.
 */
static inline uint64_t shm_seqlock_read_begin(const _Atomic uint64_t *seq)
{
        return atomic_load_explicit(seq, memory_order_acquire);
}

/*
 * Reader: end of a read section; true when the copy must be thrown away. The acquire fence keeps
 * every payload load before the reload of seq (pairs with the writer's release fence, see above);
 * the reload itself can then be relaxed.
 */
static inline bool shm_seqlock_read_retry(const _Atomic uint64_t *seq, uint64_t start)
{
        shm_seqlock_fence_acquire();
        return atomic_load_explicit(seq, memory_order_relaxed) != start;
}

/*
 * Single writer (the daemon on .in, the event ring): makes seq odd and returns the odd value to
 * pass to write_end. Only one thread may ever write a given word: the plain load+store is not an
 * atomic increment. The release fence after the odd store keeps the payload stores that follow
 * from becoming visible before it.
 */
static inline uint64_t shm_seqlock_write_begin(_Atomic uint64_t *seq)
{
        uint64_t odd = atomic_load_explicit(seq, memory_order_relaxed) + 1u;

        atomic_store_explicit(seq, odd, memory_order_relaxed);
        shm_seqlock_fence_release();
        return odd;
}

/* Single writer: publishes the payload; the release store pairs with read_begin's acquire. */
static inline void shm_seqlock_write_end(_Atomic uint64_t *seq, uint64_t odd)
{
        atomic_store_explicit(seq, odd + 1u, memory_order_release);
}

/*
 * Several writers: one attempt to take the slot for `pid`. Succeeds only from an even word, moving
 * it to (pid, seq+1). On success *ret_word holds the odd word to hand to release; on -EBUSY
 * *busy_word holds the word that was in the way. The CAS is acquire so this write is ordered after
 * the previous holder's (its release), and the release fence after it has the same role as in
 * write_begin.
 */
static inline int shm_seqlock_claim(_Atomic uint64_t *seq, uint32_t pid, uint64_t *ret_word,
                                    uint64_t *busy_word)
{
        uint64_t seen = atomic_load_explicit(seq, memory_order_relaxed);
        uint64_t odd;

        if (shm_seqlock_odd(seen)) {
                *busy_word = seen;
                return -EBUSY;
        }
        odd = ((uint64_t)pid << 32) | ((seen + 1u) & SHM_SEQLOCK_SEQ_MASK);
        if (!atomic_compare_exchange_strong_explicit(seq, &seen, odd, memory_order_acquire,
                                                     memory_order_relaxed)) {
                *busy_word = seen;
                return -EBUSY;
        }
        shm_seqlock_fence_release();
        *ret_word = odd;
        return 0;
}

/*
 * Several writers: publishes and frees the slot taken by claim. A CAS rather than a store, so that
 * a writer whose slot was taken over (the daemon judged it dead or stalled) learns it:
 * -ECANCELED. Release order pairs with read_begin's acquire, as write_end does.
 */
static inline int shm_seqlock_release(_Atomic uint64_t *seq, uint64_t odd)
{
        uint64_t expected = odd;
        uint64_t even = (odd & ~SHM_SEQLOCK_SEQ_MASK) | ((odd + 1u) & SHM_SEQLOCK_SEQ_MASK);

        if (!atomic_compare_exchange_strong_explicit(seq, &expected, even, memory_order_release,
                                                     memory_order_relaxed))
                return -ECANCELED;
        return 0;
}

#endif
