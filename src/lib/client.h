/*
 * The client handle behind <sharedlink.h>: mappings of .in (read-only) and .out (read-write when
 * the user may), the id translation that keeps ids stable across daemon restarts, and the lock
 * that makes one handle usable from many threads.
 *
 * Locking: every call holds the handle's lock for reading (client_rdlock) while it touches the
 * mappings; only a refresh (daemon restart, new names, recreated .out) takes it for writing.
 * sl_wait must not hold the lock while it sleeps, so it pins the current .in mapping with a
 * reference instead (struct client_map). The lock is not recursive: never take it twice in one
 * thread.
 */
#ifndef SL_CLIENT_H
#define SL_CLIENT_H

#include <errno.h>
#include <locale.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <sys/types.h>
#include <time.h>

#include "lib/sockpath.h"
#include "shm/layout.h"

#define CLIENT_IDS_MAX          (4u * SHM_CAPACITY_MAX)  /* ids a handle hands out in its life */
#define CLIENT_HEARTBEAT_MISSES 3u      /* heartbeat older than this many intervals: not alive */
#define CLIENT_NS_PER_MS        1000000ull
#define CLIENT_READER_SLOTS     64u     /* threads that read without a locked instruction */
#define CLIENT_READER_SHIFT     (64u - 6u)      /* log2(CLIENT_READER_SLOTS) bits of a hash */
/*
 * In id_index: the entry may be rewritten under its index (a learned name, or one whose entry the
 * id sync could not be sure of). An entry made with the table (a configured name) never is: the
 * daemon retires and reuses learned entries only (shm_table_retire), so a read of a configured
 * name needs no check that the directory moved under it (client_dir_moved: with the load of the
 * slot's stamp, layout 1.5 took sl_read with metadata from 13.8 to 16.3 ns). Taken at the id
 * sync, not from the entry's flags in shm at read time: a rewrite passes through flags a torn
 * read would take for a configured entry's.
 */
#define CLIENT_INDEX_LEARNED    INT32_C(0x40000000)
_Static_assert(SHM_CAPACITY_MAX < (uint32_t)CLIENT_INDEX_LEARNED, "a directory index and the bit");

/* clock_gettime's signature: the vDSO's entry (client_now_coarse). */
typedef int (*client_clock_fn)(clockid_t id, struct timespec *ts);

/* One mapping of .in, shared by the handle and any sl_wait sleeping on it. */
struct client_map {
        _Atomic int refs;
        const struct shm_in_header *in;
        size_t size;
        const struct shm_link *links;
        const struct shm_link_text *link_texts;         /* layout >= 1.4, else NULL */
        const struct shm_event *events;
        const struct shm_dir_entry *dir;
        const struct shm_slot *slots;
        uint32_t capacity;
        uint32_t event_capacity;
        uint64_t epoch;
        int waiter_flag;                /* layout >= 1.1: the daemon sets SHM_OUT_WAITING */
        int doorbell;                   /* layout >= 1.3: the daemon sleeps on out_doorbell */
        dev_t dev;                      /* identity of the object, to notice a replacement */
        ino_t ino;
};

/*
 * A reader slot of the handle's lock (client.c): one per thread that claimed it, its own cache
 * line. Only the owning thread writes `active`; a writer of the handle reads it.
 */
struct client_claim;

struct client_reader {
        _Atomic uintptr_t owner;        /* the owning thread (client_thread_id), 0: free */
        /* The owner's claim (client.c), written by the owner only and read by nobody: it keeps
         * the claim reachable from the handle for leak checkers, which may look after the
         * library's thread key is gone (at exit, with a thread still inside a request) */
        struct client_claim *claim;
        _Atomic uint32_t active;        /* 1 while that thread is inside a read section */
        uint8_t pad[64 - sizeof(uintptr_t) - sizeof(struct client_claim *) - sizeof(uint32_t)];
} __attribute__((aligned(64)));
_Static_assert(sizeof(struct client_reader) == 64, "one reader slot, one cache line");

/*
 * A handle's reader slots, allocated apart from the handle: a thread that claimed a slot gives it
 * back when it exits (client.c), which may be after sl_close. Each claim and the handle hold a
 * reference; the last one frees the set.
 */
struct client_reader_set {
        struct client_reader slot[CLIENT_READER_SLOTS];
        _Atomic uint32_t refs;
        _Atomic uint32_t closed;        /* 1 once sl_close dropped the handle's reference */
};

struct sl_client {
        /* the handle's lock (client.c): readers inside, a writer wanting in, writers in turn */
        _Atomic uint32_t readers;
        _Atomic uint32_t writer;
        pthread_mutex_t writers;
        struct client_reader *slots;    /* reader_set->slot, or NULL: readers count only */
        struct client_reader_set *reader_set;
        char in_name[SHM_OBJECT_NAME_SIZE];
        char out_name[SHM_OBJECT_NAME_SIZE];
        struct client_map *map;
        /* .out: mapped read-write when this user may, else out_error says why */
        struct shm_out_header *out;
        size_t out_size;
        struct shm_slot *out_slots;
        uint32_t out_capacity;
        _Atomic uint64_t *out_touched;  /* layout >= 1.6: the touched map, else NULL */
        uint32_t out_generation;
        int out_error;
        /* ids: stable for the life of the handle, resolved by name against the current map */
        uint32_t nids;
        uint32_t ids_cap;
        char (*id_names)[SHM_NAME_SIZE];
        int32_t *id_index;              /* id -> directory index in the current map (with
                                         * CLIENT_INDEX_LEARNED), or -1 */
        uint32_t *id_out;               /* id -> its entry's .out slot when outbound, else
                                         * SHM_OUT_NONE (the read path's copy of the entry) */
        int32_t *index_id;              /* directory index -> id, map->capacity entries */
        uint32_t synced;                /* directory entries of the current map given ids */
        uint32_t synced_rewrites;       /* dir_rewrites the ids were resolved under (1.5) */
        uint32_t view;                  /* bumped whenever ids are resolved anew (changes.c) */
        int changes_all;                /* $SHAREDLINK_CHANGES=all at sl_open (changes.c) */
        int32_t *name_hash;             /* open addressing: name -> id */
        uint32_t name_hash_size;
        uint32_t pid;                   /* written into .out lock words */
        locale_t c_locale;              /* numbers are formatted and parsed in the C locale */
        client_clock_fn vdso_clock_gettime;     /* or NULL: the C library's (client.c) */
        /* control socket (request.c): "<runtime_dir>/<instance>.sock", under the lock */
        char instance[SHM_INSTANCE_MAX + 1];
        struct sockpath sock;
        _Atomic int command_wait_ms;    /* "wait=MS" on query/circe requests; 0: none */
};

/* 1 when $SHAREDLINK_CHANGES is "all" (changes.c): the handle's sl_changed then always says
 * "read everything" (read once, at sl_open). */
int client_changes_all_env(void);

/* Takes the lock for writing (no refresh): waits for the readers inside to leave. */
void client_wrlock(struct sl_client *c);

/* Releases the write lock. */
void client_wrunlock(struct sl_client *c);

/* client_rdlock's slow path: waits out a writer, refreshes the view when needed (no lock held). */
void client_rdlock_slow(struct sl_client *c);

/* client_unlock's slow path: wakes the writer waiting for the last reader to leave. */
void client_unlock_wake(struct sl_client *c);

/* Id ever given to name by this handle (read lock held), or -ENOENT. */
int client_id_lookup(const struct sl_client *c, const char *name);

/*
 * The read side is inline: sl_read is a few dependent loads and two atomic increments, and calls
 * into client.c cost a quarter of it (see client.c for the lock and its memory ordering).
 */

/* 1 when the tables changed underneath the view (read lock held). */
static inline int client_needs_refresh(const struct sl_client *c)
{
        const struct shm_in_header *h = c->map->in;

        uint32_t out_generation = atomic_load_explicit(&h->out_generation, memory_order_acquire);

        return atomic_load_explicit(&h->state, memory_order_acquire) != SHM_STATE_LIVE ||
               atomic_load_explicit(&h->count, memory_order_acquire) != c->synced ||
               atomic_load_explicit(&h->dir_rewrites, memory_order_acquire) !=
                       c->synced_rewrites ||
               out_generation != c->out_generation || (!c->out && c->out_error == -EAGAIN);
}

/*
 * 1 when a directory entry was rewritten (layout 1.5: a name retired or given to its entry)
 * since the ids were resolved (read lock held). Asked after copying a slot: the copy may then
 * hold the value of the entry's next name, and the read goes again on a refreshed view.
 */
static inline int client_dir_moved(const struct sl_client *c)
{
        return atomic_load_explicit(&c->map->in->dir_rewrites, memory_order_acquire) !=
               c->synced_rewrites;
}

/*
 * Claims a reader slot for the calling thread if its slot is free, to be given back when the
 * thread exits (client.c).
 */
void client_reader_claim(struct sl_client *c, uintptr_t self);

/* The calling thread: its thread pointer, unique among live threads and cheap to read. */
static inline uintptr_t client_thread_id(void)
{
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 11 && \
        (defined(__x86_64__) || defined(__aarch64__))
        return (uintptr_t)__builtin_thread_pointer();
#else
        return (uintptr_t)pthread_self();
#endif
}

/* The reader slot a thread hashes to (slots != NULL). */
static inline struct client_reader *client_reader_of(const struct sl_client *c, uintptr_t self)
{
        uint64_t h = ((uint64_t)self >> 6) * UINT64_C(0x9e3779b97f4a7c15);

        return &c->slots[h >> CLIENT_READER_SHIFT];
}

/* Leaves through the shared count, waking a writer that waits for the last reader. */
static inline __attribute__((always_inline)) void client_unlock_count(struct sl_client *c)
{
        if (atomic_fetch_sub_explicit(&c->readers, 1u, memory_order_release) == 1u &&
            atomic_load_explicit(&c->writer, memory_order_seq_cst) != 0)
                client_unlock_wake(c);
}

/* Releases a read lock (through the thread's slot when it entered through it). */
static inline __attribute__((always_inline)) void client_unlock(struct sl_client *c)
{
        if (c->slots) {
                uintptr_t self = client_thread_id();
                struct client_reader *r = client_reader_of(c, self);

                if (atomic_load_explicit(&r->owner, memory_order_relaxed) == self &&
                    atomic_load_explicit(&r->active, memory_order_relaxed)) {
                        /* Release: the section's loads are done before a writer sees 0. */
                        atomic_store_explicit(&r->active, 0u, memory_order_release);
                        return;
                }
        }
        client_unlock_count(c);
}

/* client_rdlock_token's token when the slow path took the lock: release with client_unlock. */
#define CLIENT_LOCK_ANY         ((struct client_reader *)1)

/*
 * Takes the lock for reading, first refreshing the view if the tables changed underneath, and
 * says how it got in: the thread's reader slot, NULL for the shared count, CLIENT_LOCK_ANY after
 * the slow path. A thread with a slot announces itself with a plain store: the writer's
 * membarrier supplies the StoreLoad order that the locked increment of the shared count gives the
 * others (client.c). The token lets client_unlock_token release without finding the slot again
 * (the hot path's unlock reloaded owner and active, the latter from the store just made).
 */
static inline __attribute__((always_inline)) struct client_reader *
client_rdlock_token(struct sl_client *c)
{
        if (c->slots) {
                uintptr_t self = client_thread_id();
                struct client_reader *r = client_reader_of(c, self);
                uintptr_t owner = atomic_load_explicit(&r->owner, memory_order_relaxed);

                if (owner == self) {
                        atomic_store_explicit(&r->active, 1u, memory_order_relaxed);
                        /* The compiler must not sink the store below the load (the CPU may:
                         * that is what the writer's membarrier is for). */
                        atomic_signal_fence(memory_order_seq_cst);
                        if (atomic_load_explicit(&c->writer, memory_order_acquire) == 0 &&
                            !client_needs_refresh(c))
                                return r;
                        atomic_store_explicit(&r->active, 0u, memory_order_release);
                        client_rdlock_slow(c);
                        return CLIENT_LOCK_ANY;
                }
                if (owner == 0)
                        client_reader_claim(c, self);   /* for the next call */
        }
        atomic_fetch_add_explicit(&c->readers, 1u, memory_order_seq_cst);
        if (atomic_load_explicit(&c->writer, memory_order_seq_cst) == 0 &&
            !client_needs_refresh(c))
                return NULL;
        client_unlock_count(c);
        client_rdlock_slow(c);
        return CLIENT_LOCK_ANY;
}

/* Releases a lock taken by client_rdlock_token. */
static inline __attribute__((always_inline)) void
client_unlock_token(struct sl_client *c, struct client_reader *token)
{
        if (token == CLIENT_LOCK_ANY)
                client_unlock(c);
        else if (token)
                atomic_store_explicit(&token->active, 0u, memory_order_release);
        else
                client_unlock_count(c);
}

/* client_rdlock_token without the token: release with client_unlock. */
static inline __attribute__((always_inline)) void client_rdlock(struct sl_client *c)
{
        (void)client_rdlock_token(c);
}

/*
 * Directory index of id in the current map, with CLIENT_INDEX_LEARNED when its entry may be
 * rewritten (read lock held), or -ENOENT.
 */
static inline int client_index_entry(const struct sl_client *c, int id)
{
        if (id < 0 || (uint32_t)id >= c->nids || c->id_index[id] < 0)
                return -ENOENT;
        return c->id_index[id];
}

/* Directory index of id in the current map (read lock held), or -ENOENT. */
static inline int client_index(const struct sl_client *c, int id)
{
        int index = client_index_entry(c, id);

        return index < 0 ? index : index & ~CLIENT_INDEX_LEARNED;
}

/* 1 when the current .in was closed by its daemon (shut down or superseded, no successor yet). */
static inline int client_closed(const struct sl_client *c)
{
        return atomic_load_explicit(&c->map->in->state, memory_order_acquire) != SHM_STATE_LIVE;
}

/*
 * 1 when the daemon looks alive: table live and heartbeat recent (read lock held). Inline: every
 * read with metadata asks.
 */
static inline int client_alive(const struct sl_client *c, uint64_t now_mono, uint64_t *ret_age)
{
        const struct shm_in_header *h = c->map->in;
        uint64_t beat = atomic_load_explicit(&h->heartbeat_ns, memory_order_relaxed);
        uint64_t age = now_mono > beat ? now_mono - beat : 0;

        if (ret_age)
                *ret_age = age;
        if (client_closed(c))
                return 0;
        if (h->heartbeat_interval_ms == 0)
                return 1;
        return age <= (uint64_t)CLIENT_HEARTBEAT_MISSES * h->heartbeat_interval_ms *
                      CLIENT_NS_PER_MS;
}

/*
 * Wakes the daemon because .out is unusable (truncated, scribbled, a slot held for every bounded
 * attempt): a FUTEX_WAKE of the doorbell in .in (layout 1.3), which needs only read access. Read
 * or write lock held.
 */
void client_ring_daemon(const struct sl_client *c);

/* Takes a reference on the current map (read lock held); release with client_map_put. */
struct client_map *client_map_get(struct sl_client *c);

/* Drops a reference; the last one unmaps. NULL-safe; returns NULL. */
struct client_map *client_map_put(struct client_map *m);

/* 1 when the name of .in now refers to another object than m (a new daemon replaced it). */
int client_map_replaced(const struct sl_client *c, const struct client_map *m);

/* CLOCK_MONOTONIC / CLOCK_REALTIME in ns. */
uint64_t client_now(clockid_t id);

/*
 * CLOCK_MONOTONIC_COARSE in ns: the time sl_read's age and its liveness check count to. It is the
 * kernel's time as of its last tick (resolution: clock_getres, 1-4 ms), read from the vDSO without
 * the TSC: ~5 ns against ~35 ns for CLOCK_MONOTONIC on an x86-64 VM, which was most of a read with
 * metadata. It lags CLOCK_MONOTONIC by one to two ticks (3-6.5 ms measured at HZ=250), so ages
 * read that much low and a value updated within that lag reads as age 0. The heartbeat is judged
 * over seconds, so stale is not affected. Through the vDSO's own entry when the handle found it
 * (c->vdso_clock_gettime): the C library's clock_gettime is a wrapper around that very function,
 * and the wrapper cost 2 of the 5 ns a call (x86-64 VM, 5.0 -> 3.0 ns), on every read with
 * metadata.
 */
static inline uint64_t client_now_coarse(const struct sl_client *c)
{
        struct timespec ts;

        if (!c->vdso_clock_gettime || c->vdso_clock_gettime(CLOCK_MONOTONIC_COARSE, &ts) != 0)
                clock_gettime(CLOCK_MONOTONIC_COARSE, &ts);
        return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

/*
 * Hands a filled extensible struct (one starting with `size_t size`) to the caller: copies as much
 * of full[0..full_size) as the caller's struct holds (its size member says how much), keeping that
 * size member as the caller set it. Callers check the size against their first version first.
 */
void client_struct_out(void *ret, const void *full, size_t full_size);

/* Copies a fixed-size, possibly unterminated field into dst[size] with a NUL. */
void client_copy_field(char *dst, size_t size, const char *src, size_t src_size);

#endif
