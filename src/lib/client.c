/*
 * Client handle: open/close, mapping the tables, refreshing after a daemon restart, stable ids.
 */
#include "lib/client.h"

#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <linux/membarrier.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#include <sharedlink.h>

#include "lib/export.h"
#include "shm/futex.h"
#include "shm/seqlock.h"

#define NS_PER_S                1000000000ull
#define NS_PER_MS               1000000ull
#define CLIENT_HASH_EMPTY       (-1)
#define CLIENT_IDS_INITIAL      64u
#define CLIENT_REFRESH_TRIES    2

uint64_t client_now(clockid_t id)
{
        struct timespec ts;

        clock_gettime(id, &ts);
        return (uint64_t)ts.tv_sec * NS_PER_S + (uint64_t)ts.tv_nsec;
}

void client_struct_out(void *ret, const void *full, size_t full_size)
{
        size_t size;

        memcpy(&size, ret, sizeof(size));
        memcpy((char *)ret + sizeof(size), (const char *)full + sizeof(size),
               (size < full_size ? size : full_size) - sizeof(size));
}

void client_copy_field(char *dst, size_t size, const char *src, size_t src_size)
{
        size_t len = strnlen(src, src_size < size ? src_size : size - 1u);

        memcpy(dst, src, len);
        dst[len] = '\0';
}

/* ---- mappings ------------------------------------------------------------------------------ */

/* Maps .in read-only and checks it. Returns 0, -ENOENT (no daemon), -EACCES, -EAGAIN, -EPROTO. */
static int map_open(const char *name, struct client_map **ret_map)
{
        const struct shm_in_header *h;
        struct client_map *m;
        struct stat st;
        void *base;
        int fd, r;

        fd = shm_open(name, O_RDONLY | O_CLOEXEC, 0);
        if (fd < 0)
                return -errno;
        if (fstat(fd, &st) < 0) {
                r = -errno;
                close(fd);
                return r;
        }
        if ((size_t)st.st_size < sizeof(*h)) {
                close(fd);
                return -EAGAIN;         /* being created */
        }
        base = mmap(NULL, (size_t)st.st_size, PROT_READ, MAP_SHARED, fd, 0);
        r = base == MAP_FAILED ? -errno : 0;
        close(fd);
        if (r < 0)
                return r;
        h = base;
        r = shm_layout_check_in(h, (uint64_t)st.st_size);
        if (r < 0)
                goto fail;
        m = calloc(1, sizeof(*m));
        if (!m) {
                r = -ENOMEM;
                goto fail;
        }
        atomic_init(&m->refs, 1);
        m->in = h;
        m->size = (size_t)st.st_size;
        m->links = (const struct shm_link *)((const char *)base + h->links_offset);
        if (shm_layout_has_link_texts(h, (uint64_t)st.st_size))
                m->link_texts = (const struct shm_link_text *)((const char *)base +
                                                               h->link_texts_offset);
        m->events = (const struct shm_event *)((const char *)base + h->events_offset);
        m->dir = (const struct shm_dir_entry *)((const char *)base + h->dir_offset);
        m->slots = (const struct shm_slot *)((const char *)base + h->slots_offset);
        m->capacity = h->capacity;
        m->event_capacity = h->event_capacity;
        m->epoch = h->epoch;
        m->waiter_flag = (h->layout_version & 0xffffu) >= SHM_LAYOUT_MINOR_WAITER;
        m->doorbell = (h->layout_version & 0xffffu) >= SHM_LAYOUT_MINOR_DOORBELL;
        m->dev = st.st_dev;
        m->ino = st.st_ino;
        *ret_map = m;
        return 0;
fail:
        munmap(base, (size_t)st.st_size);
        return r;
}

struct client_map *client_map_put(struct client_map *m)
{
        if (!m)
                return NULL;
        if (atomic_fetch_sub_explicit(&m->refs, 1, memory_order_acq_rel) == 1) {
                munmap((void *)(uintptr_t)m->in, m->size);
                free(m);
        }
        return NULL;
}

struct client_map *client_map_get(struct sl_client *c)
{
        atomic_fetch_add_explicit(&c->map->refs, 1, memory_order_relaxed);
        return c->map;
}

int client_map_replaced(const struct sl_client *c, const struct client_map *m)
{
        struct stat st;
        int fd, replaced;

        fd = shm_open(c->in_name, O_RDONLY | O_CLOEXEC, 0);
        if (fd < 0)
                return 0;       /* gone, not replaced (yet) */
        replaced = fstat(fd, &st) == 0 && (st.st_ino != m->ino || st.st_dev != m->dev);
        close(fd);
        return replaced;
}

static void out_map(struct sl_client *c);

void client_ring_daemon(const struct sl_client *c)
{
        const struct client_map *m = c->map;

        /* FUTEX_WAKE neither reads nor writes the word: fine on our read-only mapping. */
        if (m->doorbell)
                shm_futex_wake((_Atomic uint32_t *)(uintptr_t)&m->in->out_doorbell, 1);
}

static void out_unmap(struct sl_client *c)
{
        if (c->out)
                munmap(c->out, c->out_size);
        c->out = NULL;
        c->out_slots = NULL;
        c->out_touched = NULL;
        c->out_size = 0;
        c->out_capacity = 0;
}

/*
 * Maps .out read-write if this user may. On failure out_error keeps the reason (-EACCES: not in
 * the group) for sl_write to return; reading never needs .out. An object that is there but
 * unusable (truncated, scribbled, left from another epoch or generation) rings the daemon, which
 * recreates it: nobody else may be left to tell it.
 */
static void out_open(struct sl_client *c)
{
        out_map(c);
        if (!c->out && c->out_error != -EACCES && c->out_error != -EPERM)
                client_ring_daemon(c);
}

static void out_map(struct sl_client *c)
{
        const struct client_map *m = c->map;
        uint32_t generation = atomic_load_explicit(&m->in->out_generation, memory_order_acquire);
        struct shm_out_header *h;
        struct stat st;
        void *base;
        int fd, r;

        out_unmap(c);
        c->out_generation = generation;
        fd = shm_open(c->out_name, O_RDWR | O_CLOEXEC, 0);
        if (fd < 0) {
                c->out_error = errno == ENOENT ? -EAGAIN : -errno;
                return;
        }
        r = fstat(fd, &st) < 0 ? -errno : 0;
        if (r == 0 && (size_t)st.st_size < sizeof(*h))
                r = -EAGAIN;
        if (r < 0) {
                close(fd);
                c->out_error = r;
                return;
        }
        base = mmap(NULL, (size_t)st.st_size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
        r = base == MAP_FAILED ? -errno : 0;
        close(fd);
        if (r < 0) {
                c->out_error = r;
                return;
        }
        h = base;
        r = shm_layout_check_out(h, (uint64_t)st.st_size);
        /* Another client may have scribbled on it (-EPROTO too: .in told us the layout): the
         * daemon will recreate it, so it is "try again". Whatever the daemon's scan refuses
         * (shm/table.c out_check) is refused here too, the exact version included, or a write
         * could land in an object about to be thrown away. */
        if (r == -EPROTO || (r == 0 && (h->epoch != m->epoch || h->generation != generation ||
                                        h->capacity != m->in->out_capacity ||
                                        h->layout_version != m->in->layout_version)))
                r = -EAGAIN;
        if (r < 0) {
                munmap(base, (size_t)st.st_size);
                c->out_error = r;
                return;
        }
        c->out = h;
        c->out_size = (size_t)st.st_size;
        c->out_slots = (struct shm_slot *)((char *)base + h->slots_offset);
        c->out_capacity = h->capacity;
        /* Layout 1.6: writers mark their slot there (vars.c), so the daemon looks at it alone. */
        if (shm_layout_has_touched(h, (uint64_t)st.st_size))
                c->out_touched = (_Atomic uint64_t *)(void *)((char *)base + h->touched_offset);
        c->out_error = 0;
}

/* ---- ids ----------------------------------------------------------------------------------- */

int client_id_lookup(const struct sl_client *c, const char *name)
{
        uint32_t mask = c->name_hash_size - 1u;

        if (!c->name_hash_size)
                return -ENOENT;
        for (uint32_t i = shm_layout_name_hash(name) & mask, n = 0; n < c->name_hash_size;
             i = (i + 1u) & mask, n++) {
                int32_t id = c->name_hash[i];

                if (id == CLIENT_HASH_EMPTY)
                        return -ENOENT;
                if (strncmp(c->id_names[id], name, SHM_NAME_SIZE) == 0)
                        return id;
        }
        return -ENOENT;
}

static void id_hash_insert(struct sl_client *c, uint32_t id)
{
        uint32_t mask = c->name_hash_size - 1u;
        uint32_t i = shm_layout_name_hash(c->id_names[id]) & mask;

        while (c->name_hash[i] != CLIENT_HASH_EMPTY)
                i = (i + 1u) & mask;
        c->name_hash[i] = (int32_t)id;
}

/* Makes room for at least `need` ids. */
static int ids_reserve(struct sl_client *c, uint32_t need)
{
        uint32_t cap = c->ids_cap ? c->ids_cap : CLIENT_IDS_INITIAL;
        char (*names)[SHM_NAME_SIZE];
        int32_t *index, *hash;
        uint32_t hash_size, *out;

        if (need <= c->ids_cap)
                return 0;
        if (need > CLIENT_IDS_MAX)
                return -ENOSPC;
        while (cap < need)
                cap *= 2u;
        names = realloc(c->id_names, (size_t)cap * sizeof(*names));
        if (!names)
                return -ENOMEM;
        c->id_names = names;
        index = realloc(c->id_index, (size_t)cap * sizeof(*index));
        if (!index)
                return -ENOMEM;
        c->id_index = index;
        out = realloc(c->id_out, (size_t)cap * sizeof(*out));
        if (!out)
                return -ENOMEM;
        c->id_out = out;
        hash_size = 2u * cap;
        hash = malloc((size_t)hash_size * sizeof(*hash));
        if (!hash)
                return -ENOMEM;
        free(c->name_hash);
        c->name_hash = hash;
        c->name_hash_size = hash_size;
        c->ids_cap = cap;
        for (uint32_t i = 0; i < hash_size; i++)
                c->name_hash[i] = CLIENT_HASH_EMPTY;
        for (uint32_t id = 0; id < c->nids; id++)
                id_hash_insert(c, id);
        return 0;
}

/*
 * Gives ids to the directory entries published since the last sync (write lock held); with
 * `all`, to every entry again (layout 1.5: entries below count were rewritten). The view is the
 * one of the dir_rewrites read first: a rewrite during the walk leaves the two different, so
 * the next lock refreshes again and no read or write trusts what the walk may have torn.
 * Each index is marked CLIENT_INDEX_LEARNED unless the walk saw a configured entry for sure: no
 * rewrite under way when it began, none begun by its end (dir_rewrites is their seqlock).
 */
static void ids_sync_view(struct sl_client *c, int all)
{
        const struct client_map *m = c->map;
        uint32_t rewrites = atomic_load_explicit(&m->in->dir_rewrites, memory_order_acquire);
        uint32_t count = atomic_load_explicit(&m->in->count, memory_order_acquire);
        uint32_t first;

        if (count > m->capacity)
                count = m->capacity;
        if (all) {
                for (uint32_t id = 0; id < c->nids; id++)
                        c->id_index[id] = -1;
                c->synced = 0;
                c->view++;      /* ids may name other entries now: sl_changed says so */
        }
        c->synced_rewrites = rewrites;
        first = c->synced;
        for (; c->synced < count; c->synced++) {
                const struct shm_dir_entry *e = &m->dir[c->synced];
                char name[SHM_NAME_SIZE];
                int id;

                c->index_id[c->synced] = -1;
                if (e->flags & SHM_DIR_RETIRED)
                        continue;               /* a name that is gone */
                client_copy_field(name, sizeof(name), e->name, sizeof(e->name));
                id = client_id_lookup(c, name);
                if (id < 0) {
                        if (ids_reserve(c, c->nids + 1u) < 0)
                                break;          /* out of memory or ids: retried next refresh */
                        id = (int)c->nids++;
                        memcpy(c->id_names[id], name, sizeof(name));
                        id_hash_insert(c, (uint32_t)id);
                }
                c->id_index[id] = (int32_t)c->synced |
                                  (e->flags & SHM_DIR_ADHOC ? CLIENT_INDEX_LEARNED : 0);
                c->id_out[id] = e->direction == SHM_DIR_OUT ? e->out_slot : SHM_OUT_NONE;
                c->index_id[c->synced] = id;
        }
        /* As a seqlock reader: the entries' loads before the reload. */
        atomic_thread_fence(memory_order_acquire);
        if ((rewrites & 1u) == 0 &&
            atomic_load_explicit(&m->in->dir_rewrites, memory_order_relaxed) == rewrites)
                return;
        for (uint32_t i = first; i < c->synced; i++)
                if (c->index_id[i] >= 0)
                        c->id_index[c->index_id[i]] |= CLIENT_INDEX_LEARNED;
}

static void ids_sync(struct sl_client *c)
{
        uint32_t rewrites = atomic_load_explicit(&c->map->in->dir_rewrites,
                                                 memory_order_acquire);

        ids_sync_view(c, rewrites != c->synced_rewrites);
}

/* Installs a freshly opened map in place of the current one and re-resolves every id. */
static int map_install(struct sl_client *c, struct client_map *m)
{
        int32_t *index_id = calloc(m->capacity ? m->capacity : 1u, sizeof(*index_id));

        if (!index_id)
                return -ENOMEM;
        client_map_put(c->map);
        c->map = m;
        free(c->index_id);
        c->index_id = index_id;
        ids_sync_view(c, 1);
        out_open(c);
        return 0;
}

/* Write lock held: follow a daemon restart, new names, a recreated .out. */
static void refresh(struct sl_client *c)
{
        struct client_map *m;

        if (client_closed(c) && map_open(c->in_name, &m) == 0) {
                if (m->epoch != c->map->epoch && map_install(c, m) == 0)
                        return;
                client_map_put(m);
        }
        ids_sync(c);
        if (atomic_load_explicit(&c->map->in->out_generation, memory_order_acquire) !=
            c->out_generation || (!c->out && c->out_error == -EAGAIN))
                out_open(c);
}

/*
 * The handle's lock: a reader count and a writer flag instead of a pthread_rwlock, so that a read
 * costs two uncontended atomic read-modify-writes, inlined (pthread_rwlock_rdlock + unlock took
 * ~10 ns of a 31 ns sl_read, x86-64). Writers (refresh: a daemon restart, new names, a new .out)
 * are rare; they take turns on a mutex, raise the flag, and wait (futex) for the readers inside
 * to leave. A reader that finds the flag raised steps back out and sleeps until it drops, so a
 * writer never starves behind a stream of readers.
 *
 * Ordering: the reader's "readers += 1; is writer 0?" against the writer's "writer = 1; is
 * readers 0?", all seq_cst, is Dekker's pattern: in the single total order of seq_cst operations
 * one side sees the other, so no reader is inside while a writer is. The reader's decrement
 * (release) pairs with the writer's load of the count (seq_cst, so acquire): the writer starts
 * after every read has finished. The writer's clearing store (release) pairs with the reader's
 * load of the flag: a reader that gets in sees everything the writer changed. A reader whose
 * decrement empties the count while a writer waits wakes it; the writer re-checks the count
 * before each sleep (FUTEX_WAIT compares it), so the wake-up cannot be lost.
 */
void client_unlock_wake(struct sl_client *c)
{
        shm_futex_wake_private(&c->readers, 1);
}

/*
 * Reader slots: the two locked read-modify-writes of the shared count were half of an sl_read
 * (about 13 ns of 25 on an x86-64 VM). A thread that owns a slot enters with a plain store of
 * active = 1 and a load of writer, exits with a release store of 0. Dekker's pattern still needs
 * a full fence between its store and its load; the writer, which is rare, supplies it for every
 * thread of the process at once: membarrier(MEMBARRIER_CMD_PRIVATE_EXPEDITED) after it raised
 * the flag makes each running thread execute a full barrier (a sleeping one gets it when it is
 * scheduled). So either a reader's store is visible to the writer's scan of the slots that
 * follows, or the reader's load comes after the barrier and sees the flag: the writer waits for
 * it, or it steps back. Slots are claimed once per thread (CAS on owner) at the slot its thread
 * pointer hashes to; a thread whose slot is taken uses the shared count. Under ThreadSanitizer,
 * which does not model membarrier, and where membarrier is missing, there are no slots.
 */
#define CLIENT_SLOT_SPINS       64      /* a writer's polls of a busy slot before it sleeps */
#define CLIENT_SLOT_NAP_NS      50000L

static long client_membarrier_cmd(int cmd)
{
        return syscall(SYS_membarrier, cmd, 0u, 0);
}

/* Registers the process for the expedited barrier; 0 or -errno. */
static int client_membarrier_register(void)
{
        long cmds = client_membarrier_cmd(MEMBARRIER_CMD_QUERY);

        if (cmds < 0 || !(cmds & MEMBARRIER_CMD_PRIVATE_EXPEDITED))
                return -ENOSYS;
        return client_membarrier_cmd(MEMBARRIER_CMD_REGISTER_PRIVATE_EXPEDITED) == 0 ? 0 : -errno;
}

/*
 * A full barrier on every running thread of the process. The registration of the process may be
 * gone (a child after fork(): it is per address space), so on EPERM it registers again; the
 * global barrier is the fallback the kernel has had longest.
 */
static void client_membarrier(void)
{
        if (client_membarrier_cmd(MEMBARRIER_CMD_PRIVATE_EXPEDITED) == 0)
                return;
        if (errno == EPERM && client_membarrier_register() == 0 &&
            client_membarrier_cmd(MEMBARRIER_CMD_PRIVATE_EXPEDITED) == 0)
                return;
        client_membarrier_cmd(MEMBARRIER_CMD_GLOBAL);
}

/*
 * Giving slots back. A thread that exits keeps its thread pointer's claim forever unless someone
 * clears it, and a program that starts many short-lived threads would fill every slot with dead
 * owners, leaving its live threads on the shared count. So each thread keeps a list of its claims
 * under one pthread key of the library, whose destructor clears each owner word when the thread
 * exits. A claim holds a reference on the slot set, so the destructor may run before, during or
 * after sl_close of that handle: the set is freed by whichever of the two lets go last. Claims on
 * handles that were closed are dropped from the list at the thread's next claim, so a long-lived
 * thread that opens and closes handles keeps no more than it uses. The key is the library's only
 * process-wide state, made once; when it cannot be made, threads simply do not claim.
 */
struct client_claim {
        struct client_claim *next;
        struct client_reader_set *set;
        struct client_reader *slot;
};

static pthread_once_t claims_once = PTHREAD_ONCE_INIT;
static pthread_key_t claims_key;
static int claims_key_ok;

/* Drops a reference on a slot set; the last one frees it. */
static void reader_set_put(struct client_reader_set *set)
{
        /* acq_rel: every use of the set happens before the free that follows the last drop. */
        if (atomic_fetch_sub_explicit(&set->refs, 1u, memory_order_acq_rel) == 1u)
                free(set);
}

/* The key's destructor: the exiting thread gives back every slot it holds. */
static void claims_release(void *list)
{
        struct client_claim *next;

        for (struct client_claim *cl = list; cl; cl = next) {
                next = cl->next;
                /* Only the owner writes its claimed owner word, and it is outside every read
                 * section now; release: its last section is over before another thread's CAS
                 * can take the slot. */
                cl->slot->claim = NULL;
                atomic_store_explicit(&cl->slot->owner, 0u, memory_order_release);
                reader_set_put(cl->set);
                free(cl);
        }
}

static void claims_key_create(void)
{
        claims_key_ok = pthread_key_create(&claims_key, claims_release) == 0;
}

/*
 * An unloaded library must not leave its destructor registered with the threads that outlive it
 * (dlclose); their claims then stay with them, as before there was a key.
 */
__attribute__((destructor)) static void claims_key_delete(void)
{
        if (claims_key_ok)
                pthread_key_delete(claims_key);
}

/* Drops the claims behind *link that belong to closed handles (the calling thread's list). */
static void claims_prune(struct client_claim **link)
{
        while (*link) {
                struct client_claim *cl = *link;

                if (atomic_load_explicit(&cl->set->closed, memory_order_acquire)) {
                        *link = cl->next;
                        cl->slot->claim = NULL;
                        reader_set_put(cl->set);
                        free(cl);
                } else {
                        link = &cl->next;
                }
        }
}

void client_reader_claim(struct sl_client *c, uintptr_t self)
{
        struct client_reader *r = client_reader_of(c, self);
        struct client_claim *cl;
        uintptr_t expected = 0;

        if (pthread_once(&claims_once, claims_key_create) != 0 || !claims_key_ok)
                return;
        cl = malloc(sizeof(*cl));
        if (!cl)
                return;
        if (!atomic_compare_exchange_strong_explicit(&r->owner, &expected, self,
                                                     memory_order_acquire, memory_order_relaxed)) {
                free(cl);
                return;
        }
        atomic_fetch_add_explicit(&c->reader_set->refs, 1u, memory_order_relaxed);
        cl->set = c->reader_set;
        cl->slot = r;
        cl->next = pthread_getspecific(claims_key);
        /* The new claim goes first: a failed setspecific leaves the stored list as it was. */
        if (pthread_setspecific(claims_key, cl) != 0) {
                atomic_store_explicit(&r->owner, 0u, memory_order_release);
                reader_set_put(cl->set);
                free(cl);
                return;
        }
        r->claim = cl;
        claims_prune(&cl->next);
}

/* Writer: waits until no thread is inside a read section through its slot. */
static void slots_wait_idle(struct sl_client *c)
{
        for (unsigned i = 0; i < CLIENT_READER_SLOTS; i++) {
                for (int n = 0; atomic_load_explicit(&c->slots[i].active, memory_order_acquire);
                     n++) {
                        struct timespec nap = { 0, CLIENT_SLOT_NAP_NS };

                        if (n < CLIENT_SLOT_SPINS)
                                sched_yield();
                        else
                                nanosleep(&nap, NULL);
                }
        }
}

/* Allocates the reader slots when the process can have them (sl_open). */
static void slots_init(struct sl_client *c)
{
#if !defined(SHM_SEQLOCK_TSAN)
        struct client_reader_set *set;

        if (client_membarrier_register() < 0)
                return;
        set = aligned_alloc(_Alignof(struct client_reader_set), sizeof(*set));
        if (!set)
                return;
        memset(set, 0, sizeof(*set));
        atomic_init(&set->refs, 1u);
        atomic_init(&set->closed, 0u);
        c->reader_set = set;
        c->slots = set->slot;
#else
        (void)c;
#endif
}

/* Enters as a reader once no writer is in or waiting. */
static void read_enter(struct sl_client *c)
{
        for (;;) {
                atomic_fetch_add_explicit(&c->readers, 1u, memory_order_seq_cst);
                if (atomic_load_explicit(&c->writer, memory_order_seq_cst) == 0)
                        return;
                client_unlock(c);
                while (atomic_load_explicit(&c->writer, memory_order_acquire) != 0)
                        shm_futex_wait_private(&c->writer, 1u, -1);
        }
}

void client_wrlock(struct sl_client *c)
{
        uint32_t n;

        pthread_mutex_lock(&c->writers);
        atomic_store_explicit(&c->writer, 1u, memory_order_seq_cst);
        if (c->slots) {
                client_membarrier();
                slots_wait_idle(c);
        }
        while ((n = atomic_load_explicit(&c->readers, memory_order_seq_cst)) != 0)
                shm_futex_wait_private(&c->readers, n, -1);
}

void client_wrunlock(struct sl_client *c)
{
        atomic_store_explicit(&c->writer, 0u, memory_order_release);
        shm_futex_wake_private(&c->writer, INT_MAX);
        pthread_mutex_unlock(&c->writers);
}

void client_rdlock_slow(struct sl_client *c)
{
        for (int attempt = 0;; attempt++) {
                read_enter(c);
                /* Bounded: with the daemon gone for good, serve the last values (flagged stale). */
                if (attempt == CLIENT_REFRESH_TRIES || !client_needs_refresh(c))
                        return;
                client_unlock(c);
                client_wrlock(c);
                refresh(c);
                client_wrunlock(c);
        }
}

/* ---- open / close -------------------------------------------------------------------------- */

/* The vDSO's clock_gettime entry by its name on this architecture. */
#if defined(__x86_64__)
#define CLIENT_VDSO_CLOCK       "__vdso_clock_gettime"
#elif defined(__aarch64__)
#define CLIENT_VDSO_CLOCK       "__kernel_clock_gettime"
#endif
#define CLIENT_VDSO_NAME        "linux-vdso.so.1"

/*
 * The vDSO's clock_gettime (client_now_coarse), or NULL: none on this architecture, no vDSO, a
 * program linked statically. RTLD_NOLOAD: the vDSO is already among the loaded objects, nothing is
 * loaded; the handle only counts a reference, given back at once (the vDSO is never unloaded).
 */
static client_clock_fn vdso_clock(void)
{
        client_clock_fn fn = NULL;
#if defined(CLIENT_VDSO_CLOCK)
        void *h = dlopen(CLIENT_VDSO_NAME, RTLD_NOW | RTLD_NOLOAD);

        if (!h)
                return NULL;
        *(void **)&fn = dlsym(h, CLIENT_VDSO_CLOCK);
        dlclose(h);
#endif
        return fn;
}

SL_EXPORT int sl_open(const char *instance, struct sl_client **ret)
{
        struct client_map *m;
        struct sl_client *c;
        int r;

        if (!ret)
                return -EINVAL;
        if (!instance || !*instance)
                instance = getenv("SHAREDLINK_INSTANCE");
        if (!instance || !*instance)
                instance = "default";
        c = calloc(1, sizeof(*c));
        if (!c)
                return -ENOMEM;
        if (shm_layout_object_name(instance, "in", c->in_name, sizeof(c->in_name)) < 0 ||
            shm_layout_object_name(instance, "out", c->out_name, sizeof(c->out_name)) < 0) {
                free(c);
                return -EINVAL;
        }
        snprintf(c->instance, sizeof(c->instance), "%s", instance);
        atomic_init(&c->command_wait_ms, 0);
        sockpath_default(&c->sock, c->instance);        /* an error stays in it for requests */
        c->c_locale = newlocale(LC_ALL_MASK, "C", (locale_t)0);
        if (c->c_locale == (locale_t)0) {
                free(c);
                return -ENOMEM;
        }
        c->pid = (uint32_t)getpid();
        c->vdso_clock_gettime = vdso_clock();
        c->changes_all = client_changes_all_env();
        r = map_open(c->in_name, &m);
        if (r < 0) {
                freelocale(c->c_locale);
                free(c);
                return r;
        }
        atomic_init(&c->readers, 0u);
        atomic_init(&c->writer, 0u);
        pthread_mutex_init(&c->writers, NULL);
        slots_init(c);
        c->out_error = -EAGAIN;
        r = map_install(c, m);
        if (r < 0) {
                client_map_put(m);
                sl_close(c);
                return r;
        }
        *ret = c;
        return 0;
}

SL_EXPORT struct sl_client *sl_close(struct sl_client *c)
{
        if (!c)
                return NULL;
        out_unmap(c);
        client_map_put(c->map);
        pthread_mutex_destroy(&c->writers);
        if (c->reader_set) {
                /* Threads that still hold slots free the set when they exit. */
                atomic_store_explicit(&c->reader_set->closed, 1u, memory_order_release);
                reader_set_put(c->reader_set);
        }
        freelocale(c->c_locale);
        free(c->id_names);
        free(c->id_index);
        free(c->id_out);
        free(c->index_id);
        free(c->name_hash);
        free(c);
        return NULL;
}
