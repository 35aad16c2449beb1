/*
 * Daemon side of the shared-memory tables (see table.h, layout.h, seqlock.h).
 *
 * Creation protocol, so that clients and a second daemon never act on a half-made object:
 *   1. shm_open(O_CREAT|O_EXCL, 0600) and flock(LOCK_EX) the new .in: until the magic is written,
 *      only the owner can open it, and a daemon racing for the same name sees it locked;
 *   2. replace .out (unlink the old one, create the new one, write its magic);
 *   3. fill .in, fchmod/fchown both to their final modes, then release-store .in's magic.
 * An existing .in is replaced only if its daemon is gone: a valid header whose pid is alive (and
 * has the same start time, so a recycled pid does not count) means -EBUSY; a header without magic
 * is replaced only if nobody holds its lock. The replaced object is marked closed and its change
 * word woken first, so clients blocked on it notice at once and reopen by name.
 */
#include "shm/table.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "shm/changes.h"
#include "shm/events.h"
#include "shm/futex.h"
#include "shm/guard.h"
#include "shm/seqlock.h"
#include "shm/slot.h"
#include "shm/wake.h"

#define TABLE_MODE_PRIVATE      0600
#define TABLE_MODE_IN           0644
#define TABLE_MODE_IN_GROUP     0640
#define TABLE_MODE_OUT          0660
#define TABLE_PID_MAX           (1 << 22)       /* PID_MAX_LIMIT on 64-bit Linux */
#define TABLE_STAT_BUF          1024
#define TABLE_STARTTIME_FIELD   22              /* proc(5): field 22 of /proc/<pid>/stat */
#define TABLE_HASH_EMPTY        (-1)
#define NS_PER_S                1000000000ull
#define NS_PER_MS               1000000ull

/* Daemon-private facts about one variable: the authoritative copy, never read back from shm. */
struct table_var {
        char name[SHM_NAME_SIZE];
        uint32_t direction;
        uint32_t link;
        uint32_t out_slot;
        uint32_t flags;                 /* current SHM_SLOT_* flags of its .in slot */
        uint32_t retired;               /* 1: its name is gone, the entry awaits another */
};

/* Scan state of one .out slot. */
enum table_scan_state {
        SCAN_SAME,                      /* word unchanged since the last scan */
        SCAN_COPIED,                    /* changed, consistent copy taken */
        SCAN_HELD,                      /* odd: a writer holds it (alive or not) */
        SCAN_CHURN,                     /* kept changing during every bounded attempt */
        SCAN_REPAIR,                    /* odd, writer gone: to repair */
        SCAN_REPAIRED,
};

struct table_scan {
        uint8_t state;
        uint8_t taken;                  /* SCAN_REPAIR(ED): from a writer kill() finds alive */
        uint32_t held_scans;            /* periodic scans that found held_word */
        uint64_t word;                  /* word copied under, or the odd word seen */
        uint64_t held_word;             /* odd word the slot is held under, 0: not held */
        uint64_t held_since_ns;         /* CLOCK_MONOTONIC when held_word was first found */
};

struct shm_table {
        char in_name[SHM_OBJECT_NAME_SIZE];
        char out_name[SHM_OBJECT_NAME_SIZE];
        int in_fd;                      /* kept open: it holds the flock */
        int out_fd;                     /* kept open: fstat before every scan */
        struct shm_in_header *in;
        size_t in_size;
        struct shm_out_header *out;
        size_t out_size;
        struct shm_link *links;
        struct shm_link_text *link_texts;
        struct shm_event *events;
        struct shm_dir_entry *dir;
        struct shm_slot *slots;
        struct shm_slot *out_slots;
        struct shm_changes changes;     /* the change record in .in (layout 1.7) */
        uint64_t changes_next;          /* entries noted; published at the next change bump */
        _Atomic uint64_t *out_touched;  /* the touched map in .out (layout 1.6): client data */
        uint32_t capacity;
        uint32_t count;
        uint32_t out_capacity;          /* configured outbound variables + out_spare */
        uint32_t out_used;              /* .out slots given to a variable: [0, out_used) */
        uint32_t out_touched_words;     /* words of the touched map (and of out_want) */
        uint32_t out_old_steps;         /* change & SHM_OUT_CHANGE_UNTOUCHED at the last scan */
        uint32_t event_capacity;
        uint32_t link_count;
        uint32_t out_generation;
        uint32_t dir_rewrites;          /* what shm_in_header.dir_rewrites holds */
        uint64_t epoch;
        pid_t pid;
        int has_group;
        gid_t gid;
        struct table_var *vars;
        uint32_t *out_ids;              /* .out slot -> variable id */
        uint64_t *out_seen;             /* lock word of each .out slot at the last scan */
        struct shm_slot_copy *out_copy; /* copy-out buffer, one per .out slot */
        struct table_scan *out_scan;    /* per .out slot: the held-slot tracking is bounded by it */
        uint64_t held_min_ns;           /* SHM_TABLE_HELD_HEARTBEATS intervals (0: no heartbeat) */
        int out_periodic;               /* the scan under way is shm_table_out_scan's */
        uint64_t *out_want;             /* private touched map: slots the next scan looks at */
        uint32_t *out_list;             /* the slots of the scan under way, ascending */
        uint32_t out_nlist;
        int out_full;                   /* the scan under way looks at every slot */
        int32_t *hash;                  /* open addressing over vars, by name */
        uint32_t hash_size;             /* a power of two, >= 2 * capacity */
        int in_batch;
        int dirty;
        uint64_t batch_mono;
        uint64_t batch_real;
        struct shm_wake *wake;
};

static uint64_t clock_ns(clockid_t id)
{
        struct timespec ts;

        clock_gettime(id, &ts);
        return (uint64_t)ts.tv_sec * NS_PER_S + (uint64_t)ts.tv_nsec;
}

/* Copies a string into a fixed field, NUL-padded; 0, or -EINVAL when it does not fit. */
static int copy_field(char *dst, size_t size, const char *src)
{
        size_t len = src ? strnlen(src, size) : 0;

        if (len >= size)
                return -EINVAL;
        memset(dst, 0, size);
        if (len)
                memcpy(dst, src, len);
        return 0;
}

static int hash_lookup(const struct shm_table *t, const char *name)
{
        uint32_t mask = t->hash_size - 1u;

        for (uint32_t i = shm_layout_name_hash(name) & mask, n = 0; n < t->hash_size;
             i = (i + 1u) & mask, n++) {
                int32_t id = t->hash[i];

                if (id == TABLE_HASH_EMPTY)
                        return -ENOENT;
                if (strcmp(t->vars[id].name, name) == 0)
                        return id;
        }
        return -ENOENT;
}

static void hash_insert(struct shm_table *t, const char *name, int32_t id)
{
        uint32_t mask = t->hash_size - 1u;
        uint32_t i = shm_layout_name_hash(name) & mask;

        while (t->hash[i] != TABLE_HASH_EMPTY)
                i = (i + 1u) & mask;
        t->hash[i] = id;
}

/* The index without retired names (open addressing has no cheap delete; retiring is rare). */
static void hash_rebuild(struct shm_table *t)
{
        for (uint32_t i = 0; i < t->hash_size; i++)
                t->hash[i] = TABLE_HASH_EMPTY;
        for (uint32_t id = 0; id < t->count; id++)
                if (!t->vars[id].retired)
                        hash_insert(t, t->vars[id].name, (int32_t)id);
}

/* Start time of a process (clock ticks after boot), so a recycled pid is not taken for ours. */
static int read_start_time(pid_t pid, uint64_t *ret_start)
{
        char path[64], buf[TABLE_STAT_BUF];
        unsigned long long start;
        const char *p;
        ssize_t n;
        int fd;

        snprintf(path, sizeof(path), "/proc/%d/stat", (int)pid);
        fd = open(path, O_RDONLY | O_CLOEXEC);
        if (fd < 0)
                return -errno;
        n = read(fd, buf, sizeof(buf) - 1u);
        close(fd);
        if (n <= 0)
                return -EIO;
        buf[n] = '\0';
        /* The command name (field 2) may contain spaces and parentheses: skip to the last ')'. */
        p = strrchr(buf, ')');
        if (!p)
                return -EIO;
        p++;
        for (int field = 2; field < TABLE_STARTTIME_FIELD - 1; field++) {
                p = strchr(p + 1, ' ');
                if (!p)
                        return -EIO;
        }
        if (sscanf(p, " %llu", &start) != 1)
                return -EIO;
        *ret_start = start;
        return 0;
}

/* True when the daemon recorded in a valid header still runs. */
static int daemon_alive(pid_t pid, uint64_t start)
{
        uint64_t now_start;

        if (pid <= 0 || pid > TABLE_PID_MAX)
                return 0;
        if (kill(pid, 0) < 0 && errno == ESRCH)
                return 0;
        if (start != 0 && read_start_time(pid, &now_start) == 0 && now_start != start)
                return 0;               /* the pid was recycled by another process */
        return 1;
}

/* Marks a superseded .in closed and wakes everyone waiting on it. */
static void close_in_header(struct shm_in_header *h)
{
        atomic_store_explicit(&h->state, SHM_STATE_CLOSED, memory_order_release);
        atomic_fetch_add_explicit(&h->change, 1u, memory_order_release);
        shm_futex_wake(&h->change, INT_MAX);
}

/*
 * An .in object exists already. Returns 0 when it was left by a dead daemon (it is then marked
 * closed and unlinked), -EBUSY when its daemon (or a daemon creating it right now) is alive.
 */
static int replace_stale_in(const char *name)
{
        struct shm_in_header *h = NULL;
        struct stat st;
        int fd, r = 0;

        fd = shm_open(name, O_RDWR | O_CLOEXEC, 0);
        if (fd < 0)
                return errno == ENOENT ? 0 : -errno;
        if (fstat(fd, &st) < 0) {
                r = -errno;
                goto out;
        }
        if ((size_t)st.st_size >= sizeof(*h)) {
                h = mmap(NULL, sizeof(*h), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
                if (h == MAP_FAILED) {
                        r = -errno;
                        h = NULL;
                        goto out;
                }
        }
        if (h && atomic_load_explicit(&h->magic, memory_order_acquire) == SHM_IN_MAGIC) {
                if (daemon_alive(h->daemon_pid, h->daemon_start)) {
                        r = -EBUSY;
                        goto out;
                }
                close_in_header(h);
        } else if (flock(fd, LOCK_EX | LOCK_NB) < 0) {
                r = errno == EWOULDBLOCK ? -EBUSY : -errno;     /* being created right now */
                goto out;
        }
        if (shm_unlink(name) < 0 && errno != ENOENT)
                r = -errno;
out:
        if (h)
                munmap(h, sizeof(*h));
        close(fd);
        return r;
}

/* True when name refers to the very object open as fd. */
static int name_is_fd(const char *name, int fd)
{
        struct stat ours, now;
        int nfd, same;

        if (fd < 0 || fstat(fd, &ours) < 0)
                return 0;
        nfd = shm_open(name, O_RDONLY | O_CLOEXEC, 0);
        if (nfd < 0)
                return 0;
        same = fstat(nfd, &now) == 0 && now.st_ino == ours.st_ino && now.st_dev == ours.st_dev;
        close(nfd);
        return same;
}

static int random_epoch(uint64_t *ret_epoch)
{
        uint64_t e = 0;

        if (getrandom(&e, sizeof(e), GRND_NONBLOCK) != (ssize_t)sizeof(e))
                e = clock_ns(CLOCK_REALTIME) ^ ((uint64_t)getpid() << 40);
        if (e == 0)
                e = 1;
        *ret_epoch = e;
        return 0;
}

/* Creates an object exclusively with size bytes and maps it. */
static int create_object(const char *name, uint64_t size, int *ret_fd, void **ret_map)
{
        void *map;
        int fd, r;

        fd = shm_open(name, O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC, TABLE_MODE_PRIVATE);
        if (fd < 0)
                return -errno;
        if (ftruncate(fd, (off_t)size) < 0) {
                r = -errno;
                goto fail;
        }
        map = mmap(NULL, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
        if (map == MAP_FAILED) {
                r = -errno;
                goto fail;
        }
        *ret_fd = fd;
        *ret_map = map;
        return 0;
fail:
        shm_unlink(name);
        close(fd);
        return r;
}

static int set_mode(const struct shm_table *t, int fd, mode_t mode)
{
        /* fchmod after creation: the mode given to shm_open is filtered by the umask. */
        if (t->has_group && fchown(fd, (uid_t)-1, t->gid) < 0)
                return -errno;
        if (fchmod(fd, mode) < 0)
                return -errno;
        return 0;
}

/* Creates (or recreates) .out, fully initialised, magic written; does not touch .in. */
static int out_create(struct shm_table *t, uint32_t generation)
{
        struct shm_out_header *h;
        struct shm_out_geometry g;
        uint64_t size;
        uint32_t change;
        void *map;
        int fd, r;

        shm_layout_out_geometry(t->out_capacity, &g);
        size = g.object_size;
        if (shm_unlink(t->out_name) < 0 && errno != ENOENT)
                return -errno;
        r = create_object(t->out_name, size, &fd, &map);
        if (r < 0)
                return r;
        h = map;
        h->layout_version = SHM_LAYOUT_VERSION;
        h->header_size = sizeof(*h);
        h->total_size = g.total_size;
        h->epoch = t->epoch;
        h->slot_size = sizeof(struct shm_slot);
        h->capacity = t->out_capacity;
        h->slots_offset = sizeof(*h);
        h->generation = generation;
        h->touched_words = g.touched_words;
        h->touched_offset = g.touched_offset;
        /* A fresh word per object, so a client cursor from the old one rarely matches; without
         * the waiter flag: nobody sleeps on it yet. */
        change = ((uint32_t)t->epoch + generation) & ~SHM_OUT_WAITING;
        atomic_store_explicit(&h->change, change, memory_order_relaxed);
        r = set_mode(t, fd, TABLE_MODE_OUT);
        if (r < 0) {
                munmap(map, size);
                shm_unlink(t->out_name);
                close(fd);
                return r;
        }
        atomic_store_explicit(&h->magic, SHM_OUT_MAGIC, memory_order_release);

        if (t->out)
                munmap(t->out, t->out_size);
        if (t->out_fd >= 0)
                close(t->out_fd);
        t->out = h;
        t->out_size = size;
        t->out_fd = fd;
        t->out_slots = (struct shm_slot *)((char *)map + h->slots_offset);
        t->out_touched = (_Atomic uint64_t *)(void *)((char *)map + g.touched_offset);
        t->out_touched_words = g.touched_words;
        t->out_old_steps = change & SHM_OUT_CHANGE_UNTOUCHED;
        for (uint32_t i = 0; i < t->out_capacity; i++) {
                t->out_seen[i] = 0;
                t->out_scan[i].held_word = 0;
        }
        /* What the old object's scans left to look at again is gone with it. */
        for (uint32_t w = 0; w < g.touched_words; w++)
                t->out_want[w] = 0;
        return 0;
}

static void dir_fill(struct shm_dir_entry *e, const struct shm_var *v, uint32_t out_slot,
                     uint16_t flags)
{
        memset(e, 0, sizeof(*e));
        copy_field(e->name, sizeof(e->name), v->name);
        copy_field(e->peer, sizeof(e->peer), v->peer);
        e->link = v->link;
        e->position = v->position;
        e->out_slot = out_slot;
        e->direction = (uint8_t)v->direction;
        e->type = (uint8_t)v->type;
        e->flags = flags;
}

static int var_check(const struct shm_var *v, uint32_t nlinks_max)
{
        if (shm_layout_name_check(v->name) < 0)
                return -EINVAL;
        if (v->direction != SHM_DIR_IN && v->direction != SHM_DIR_OUT)
                return -EINVAL;
        if (v->type >= SHM_TYPE_COUNT)
                return -EINVAL;
        if (v->link != SHM_LINK_NONE && v->link >= nlinks_max)
                return -EINVAL;
        if (v->peer && strnlen(v->peer, SHM_PEER_SIZE) >= SHM_PEER_SIZE)
                return -EINVAL;
        return 0;
}

static int link_fill(struct shm_link *l, const struct shm_link_def *def)
{
        if (!def->name || def->name[0] == '\0')
                return -EINVAL;
        if (copy_field(l->name, sizeof(l->name), def->name) < 0 ||
            copy_field(l->protocol, sizeof(l->protocol), def->protocol) < 0)
                return -EINVAL;
        return 0;
}

static int config_check(const struct shm_table_config *cfg)
{
        uint64_t capacity = (uint64_t)cfg->nvars + cfg->adhoc_capacity;

        if (shm_layout_instance_check(cfg->instance) < 0)
                return -EINVAL;
        if (capacity > SHM_CAPACITY_MAX || cfg->nlinks > SHM_LINKS_MAX)
                return -EINVAL;
        if (cfg->out_spare > cfg->adhoc_capacity)
                return -EINVAL;         /* a spare slot without a directory entry to name it */
        if (cfg->nvars && !cfg->vars)
                return -EINVAL;
        if (cfg->nlinks && !cfg->links)
                return -EINVAL;
        if (cfg->event_capacity > SHM_EVENTS_MAX)
                return -EINVAL;
        if (cfg->control_socket && (cfg->control_socket[0] != '/' ||
                                    strnlen(cfg->control_socket, SHM_SOCKET_PATH_SIZE) >=
                                    SHM_SOCKET_PATH_SIZE))
                return -EINVAL;
        for (uint32_t i = 0; i < cfg->nvars; i++)
                if (var_check(&cfg->vars[i], SHM_LINKS_MAX) < 0)
                        return -EINVAL;
        return 0;
}

static uint32_t events_capacity(uint32_t wanted)
{
        uint32_t c = SHM_EVENTS_MIN;

        if (wanted == 0)
                return SHM_EVENTS_DEFAULT;
        while (c < wanted)
                c <<= 1;
        return c;
}

static int table_alloc(struct shm_table *t)
{
        uint32_t n = t->out_capacity ? t->out_capacity : 1u;

        t->hash_size = 16;
        while (t->hash_size < 2u * t->capacity)
                t->hash_size <<= 1;
        t->vars = calloc(t->capacity ? t->capacity : 1u, sizeof(*t->vars));
        t->hash = malloc(t->hash_size * sizeof(*t->hash));
        t->out_ids = calloc(n, sizeof(*t->out_ids));
        t->out_seen = calloc(n, sizeof(*t->out_seen));
        t->out_copy = calloc(n, sizeof(*t->out_copy));
        t->out_scan = calloc(n, sizeof(*t->out_scan));
        t->out_want = calloc((n + SHM_TOUCHED_WORD_BITS - 1u) / SHM_TOUCHED_WORD_BITS,
                             sizeof(*t->out_want));
        t->out_list = calloc(n, sizeof(*t->out_list));
        if (!t->vars || !t->hash || !t->out_ids || !t->out_seen || !t->out_copy || !t->out_scan ||
            !t->out_want || !t->out_list)
                return -ENOMEM;
        for (uint32_t i = 0; i < t->hash_size; i++)
                t->hash[i] = TABLE_HASH_EMPTY;
        return 0;
}

static void table_free(struct shm_table *t)
{
        shm_wake_stop(t->wake);
        if (t->in)
                munmap(t->in, t->in_size);
        if (t->out)
                munmap(t->out, t->out_size);
        if (t->in_fd >= 0)
                close(t->in_fd);
        if (t->out_fd >= 0)
                close(t->out_fd);
        free(t->vars);
        free(t->hash);
        free(t->out_ids);
        free(t->out_seen);
        free(t->out_copy);
        free(t->out_scan);
        free(t->out_want);
        free(t->out_list);
        free(t);
}

/* Private bookkeeping of the configured variables; outbound ones get .out slots in order. */
static int vars_index(struct shm_table *t, const struct shm_table_config *cfg)
{
        uint32_t out = 0;

        for (uint32_t i = 0; i < cfg->nvars; i++) {
                const struct shm_var *v = &cfg->vars[i];
                struct table_var *tv = &t->vars[i];

                if (v->link != SHM_LINK_NONE && v->link >= cfg->nlinks)
                        return -EINVAL;
                if (hash_lookup(t, v->name) >= 0)
                        return -EEXIST;
                copy_field(tv->name, sizeof(tv->name), v->name);
                tv->direction = v->direction;
                tv->link = v->link;
                tv->out_slot = SHM_OUT_NONE;
                if (v->direction == SHM_DIR_OUT) {
                        tv->out_slot = out;
                        t->out_ids[out++] = i;
                }
                hash_insert(t, tv->name, (int32_t)i);
        }
        t->out_used = out;
        return 0;
}

static int in_fill(struct shm_table *t, const struct shm_table_config *cfg,
                   const struct shm_in_geometry *g)
{
        struct shm_in_header *h = t->in;
        uint64_t start = 0;

        read_start_time(t->pid, &start);
        h->layout_version = SHM_LAYOUT_VERSION;
        h->header_size = sizeof(*h);
        h->total_size = g->total_size;
        h->link_texts_offset = g->link_texts_offset;
        h->link_text_size = sizeof(struct shm_link_text);
        h->changes_offset = g->changes_offset;
        h->changes_capacity = g->changes_capacity;
        h->epoch = t->epoch;
        h->daemon_pid = (int32_t)t->pid;
        h->heartbeat_interval_ms = cfg->heartbeat_interval_ms;
        h->daemon_start = start;
        h->created_real_ns = clock_ns(CLOCK_REALTIME);
        atomic_store_explicit(&h->state, SHM_STATE_LIVE, memory_order_relaxed);
        atomic_store_explicit(&h->out_generation, t->out_generation, memory_order_relaxed);
        h->capacity = t->capacity;
        h->slot_size = sizeof(struct shm_slot);
        h->dir_entry_size = sizeof(struct shm_dir_entry);
        h->link_max = SHM_LINKS_MAX;
        h->link_size = sizeof(struct shm_link);
        h->counter_max = SHM_COUNTERS_MAX;
        h->event_size = sizeof(struct shm_event);
        h->event_capacity = t->event_capacity;
        h->out_capacity = t->out_capacity;
        h->links_offset = g->links_offset;
        h->events_offset = g->events_offset;
        h->dir_offset = g->dir_offset;
        h->slots_offset = g->slots_offset;
        atomic_store_explicit(&h->heartbeat_ns, clock_ns(CLOCK_MONOTONIC), memory_order_relaxed);
        atomic_store_explicit(&h->change, (uint32_t)(t->epoch >> 32), memory_order_relaxed);
        copy_field(h->control_socket, sizeof(h->control_socket), cfg->control_socket);

        for (uint32_t i = 0; i < cfg->nlinks; i++)
                if (link_fill(&t->links[i], &cfg->links[i]) < 0)
                        return -EINVAL;
        t->link_count = cfg->nlinks;
        atomic_store_explicit(&h->link_count, t->link_count, memory_order_relaxed);
        for (uint32_t i = 0; i < cfg->nvars; i++)
                dir_fill(&t->dir[i], &cfg->vars[i], t->vars[i].out_slot, 0);
        t->count = cfg->nvars;
        atomic_store_explicit(&h->count, t->count, memory_order_relaxed);
        return 0;
}

int shm_table_create(const struct shm_table_config *cfg, struct shm_table **ret_table)
{
        struct shm_in_geometry g;
        struct shm_table *t;
        void *map;
        int r;

        r = config_check(cfg);
        if (r < 0)
                return r;
        r = shm_guard_install();
        if (r < 0)
                return r;
        t = calloc(1, sizeof(*t));
        if (!t)
                return -ENOMEM;
        t->in_fd = t->out_fd = -1;
        t->pid = getpid();
        t->has_group = cfg->has_group;
        t->gid = cfg->gid;
        t->capacity = cfg->nvars + cfg->adhoc_capacity;
        t->event_capacity = events_capacity(cfg->event_capacity);
        t->out_generation = 1;
        for (uint32_t i = 0; i < cfg->nvars; i++)
                if (cfg->vars[i].direction == SHM_DIR_OUT)
                        t->out_capacity++;
        t->out_capacity += cfg->out_spare;
        t->held_min_ns = (uint64_t)SHM_TABLE_HELD_HEARTBEATS * cfg->heartbeat_interval_ms *
                         NS_PER_MS;
        random_epoch(&t->epoch);
        if (shm_layout_object_name(cfg->instance, "in", t->in_name, sizeof(t->in_name)) < 0 ||
            shm_layout_object_name(cfg->instance, "out", t->out_name, sizeof(t->out_name)) < 0) {
                r = -EINVAL;
                goto fail;
        }
        r = table_alloc(t);
        if (r < 0)
                goto fail;
        r = vars_index(t, cfg);
        if (r < 0)
                goto fail;

        /* 1. Claim .in: exclusive create, replacing the object of a dead daemon at most once. */
        shm_layout_in_geometry(t->capacity, t->event_capacity, &g);
        r = create_object(t->in_name, g.object_size, &t->in_fd, &map);
        if (r == -EEXIST) {
                r = replace_stale_in(t->in_name);
                if (r == 0)
                        r = create_object(t->in_name, g.object_size, &t->in_fd, &map);
                if (r == -EEXIST)
                        r = -EBUSY;     /* another daemon was quicker */
        }
        if (r < 0)
                goto fail;
        t->in = map;
        t->in_size = g.object_size;
        /* Between the create and the lock a racing daemon could have taken our object for an
         * abandoned one and replaced it: once locked, check the name is still ours. */
        if (flock(t->in_fd, LOCK_EX | LOCK_NB) < 0 || !name_is_fd(t->in_name, t->in_fd)) {
                r = -EBUSY;
                goto fail;
        }
        t->links = (struct shm_link *)((char *)map + g.links_offset);
        t->link_texts = (struct shm_link_text *)((char *)map + g.link_texts_offset);
        t->events = (struct shm_event *)((char *)map + g.events_offset);
        t->dir = (struct shm_dir_entry *)((char *)map + g.dir_offset);
        t->slots = (struct shm_slot *)((char *)map + g.slots_offset);
        t->changes = (struct shm_changes){
                .head = (struct shm_changes_head *)(void *)((char *)map + g.changes_offset),
                .entries = (_Atomic uint64_t *)(void *)((char *)map + g.changes_offset +
                                                        SHM_CHANGES_HEAD),
                .capacity = g.changes_capacity,
        };

        /* 2. A fresh .out (any old one belonged to the dead daemon). */
        r = out_create(t, t->out_generation);
        if (r < 0)
                goto fail_unlink_in;

        /* 3. Fill .in, final modes, magic last. */
        r = in_fill(t, cfg, &g);
        if (r < 0)
                goto fail_unlink_all;
        r = set_mode(t, t->in_fd, t->has_group ? TABLE_MODE_IN_GROUP : TABLE_MODE_IN);
        if (r < 0)
                goto fail_unlink_all;
        atomic_store_explicit(&t->in->magic, SHM_IN_MAGIC, memory_order_release);
        *ret_table = t;
        return 0;

fail_unlink_all:
        shm_unlink(t->out_name);
fail_unlink_in:
        shm_unlink(t->in_name);
fail:
        table_free(t);
        return r;
}

/* Unlinks name only if it still is the object we hold open (never someone else's). */
static void unlink_if_ours(const char *name, int our_fd)
{
        if (name_is_fd(name, our_fd))
                shm_unlink(name);
}

struct shm_table *shm_table_destroy(struct shm_table *t)
{
        if (!t)
                return NULL;
        /* Stop the wake thread before .out goes away. */
        t->wake = shm_wake_stop(t->wake);
        close_in_header(t->in);
        unlink_if_ours(t->out_name, t->out_fd);
        unlink_if_ours(t->in_name, t->in_fd);
        table_free(t);
        return NULL;
}

uint64_t shm_table_epoch(const struct shm_table *t)
{
        return t->epoch;
}

uint32_t shm_table_count(const struct shm_table *t)
{
        return t->count;
}

int shm_table_find(const struct shm_table *t, const char *name)
{
        if (!name)
                return -ENOENT;
        return hash_lookup(t, name);
}

int shm_table_direction(const struct shm_table *t, uint32_t id)
{
        if (id >= t->count || t->vars[id].retired)
                return -ENOENT;
        return (int)t->vars[id].direction;
}

/* Notes slot id in the change record (layout 1.7); published with the next change bump. */
static void note(struct shm_table *t, uint32_t id)
{
        shm_changes_note(&t->changes, &t->changes_next, id);
}

/* A change outside a batch is published at once; inside one, at commit. */
static void publish(struct shm_table *t)
{
        if (t->in_batch) {
                t->dirty = 1;
                return;
        }
        /* The record's head before the bump: a client that saw the bump finds in the record
         * every slot it covers. */
        shm_changes_publish(&t->changes, t->changes_next);
        /* Release: a client that sees the new change value sees every store before it. */
        atomic_fetch_add_explicit(&t->in->change, 1u, memory_order_release);
        shm_futex_wake(&t->in->change, INT_MAX);
}

void shm_table_begin_at(struct shm_table *t, uint64_t mono_ns, uint64_t real_ns)
{
        t->in_batch = 1;
        t->batch_mono = mono_ns;
        t->batch_real = real_ns;
}

void shm_table_begin(struct shm_table *t)
{
        shm_table_begin_at(t, clock_ns(CLOCK_MONOTONIC), clock_ns(CLOCK_REALTIME));
}

int shm_table_commit(struct shm_table *t)
{
        int dirty = t->dirty;

        t->in_batch = 0;
        t->dirty = 0;
        if (!dirty)
                return 0;
        publish(t);
        return 1;
}

/* shm_table_set with the time stamps and .out word of an accepted client write (mono 0: the
 * batch's, source 0: none). */
static int table_set(struct shm_table *t, uint32_t id, const char *value, size_t len,
                     uint64_t mono_ns, uint64_t real_ns, uint64_t source)
{
        struct table_var *v;
        int implicit = !t->in_batch;

        if (id >= t->count || t->vars[id].retired)
                return -ENOENT;
        if (!value || shm_layout_value_check(value, len) < 0)
                return -EINVAL;
        if (implicit)
                shm_table_begin(t);
        v = &t->vars[id];
        v->flags = SHM_SLOT_VALID | (v->direction == SHM_DIR_OUT ? SHM_SLOT_OUTBOUND : 0u);
        shm_slot_write_mirror(&t->slots[id], value, (uint32_t)len, v->flags,
                              mono_ns ? mono_ns : t->batch_mono,
                              mono_ns ? real_ns : t->batch_real, source);
        note(t, id);
        t->dirty = 1;
        if (implicit)
                shm_table_commit(t);
        return 0;
}

int shm_table_set(struct shm_table *t, uint32_t id, const char *value, size_t len)
{
        return table_set(t, id, value, len, 0, 0, 0);
}

int shm_table_get(const struct shm_table *t, uint32_t id, char *buf, size_t size,
                  uint32_t *ret_flags)
{
        struct shm_slot_copy c;

        if (id >= t->count)
                return -ENOENT;
        /* Our own slot: this thread is its only writer, so the read never finds it odd. */
        if (shm_slot_read(&t->slots[id], &c) < 0)
                return -EAGAIN;
        if (c.length > SHM_VALUE_MAX)
                c.length = 0;
        if (size < (size_t)c.length + 1u)
                return -ENOBUFS;
        memcpy(buf, c.value, c.length);
        buf[c.length] = '\0';
        if (ret_flags)
                *ret_flags = t->vars[id].flags;
        return (int)c.length;
}

int shm_table_set_str(struct shm_table *t, uint32_t id, const char *value)
{
        if (!value)
                return -EINVAL;
        return shm_table_set(t, id, value, strnlen(value, SHM_VALUE_SIZE));
}

/* Rewrites the flags of one slot if they change; 1 if they did. */
static int set_stale_one(struct shm_table *t, uint32_t id, int stale)
{
        struct table_var *v = &t->vars[id];
        uint32_t flags = stale ? (v->flags | SHM_SLOT_STALE) : (v->flags & ~SHM_SLOT_STALE);

        if (flags == v->flags)
                return 0;
        v->flags = flags;
        shm_slot_write_flags(&t->slots[id], flags);
        note(t, id);
        return 1;
}

int shm_table_set_stale(struct shm_table *t, uint32_t id, int stale)
{
        if (id >= t->count || t->vars[id].retired)
                return -ENOENT;
        if (set_stale_one(t, id, stale))
                publish(t);
        return 0;
}

int shm_table_set_link_stale(struct shm_table *t, uint32_t link, int stale)
{
        int changed = 0;

        if (link >= t->link_count)
                return -EINVAL;
        for (uint32_t id = 0; id < t->count; id++)
                if (t->vars[id].link == link && t->vars[id].direction == SHM_DIR_IN &&
                    !t->vars[id].retired)
                        changed += set_stale_one(t, id, stale);
        if (changed)
                publish(t);
        return changed;
}

/*
 * Entries below count are rewritten under dir_rewrites, a seqlock (layout.h, 1.5): odd, then
 * the entry, then even. A client that read the directory across it reads it again.
 */
static void dir_rewrite_begin(struct shm_table *t)
{
        t->dir_rewrites++;
        atomic_store_explicit(&t->in->dir_rewrites, t->dir_rewrites, memory_order_relaxed);
        atomic_thread_fence(memory_order_release);
}

static void dir_rewrite_end(struct shm_table *t)
{
        t->dir_rewrites++;
        atomic_store_explicit(&t->in->dir_rewrites, t->dir_rewrites, memory_order_release);
        atomic_fetch_add_explicit(&t->in->dir_generation, 1u, memory_order_release);
}

/* A retired entry of that direction (an outbound one keeps its .out slot), or -ENOENT. */
static int retired_entry(const struct shm_table *t, unsigned direction)
{
        for (uint32_t id = 0; id < t->count; id++)
                if (t->vars[id].retired && t->vars[id].direction == direction)
                        return (int)id;
        return -ENOENT;
}

int shm_table_retire(struct shm_table *t, uint32_t id)
{
        struct table_var *tv;

        if (id >= t->count || t->vars[id].retired)
                return -ENOENT;
        if (!(t->dir[id].flags & SHM_DIR_ADHOC))
                return -EPERM;
        tv = &t->vars[id];
        tv->retired = 1;
        tv->flags = 0;
        /* No value first: a client that still reads the name finds none, then finds it gone. */
        shm_slot_write(&t->slots[id], "", 0, 0, clock_ns(CLOCK_MONOTONIC),
                       clock_ns(CLOCK_REALTIME));
        dir_rewrite_begin(t);
        t->dir[id].flags |= SHM_DIR_RETIRED;
        dir_rewrite_end(t);
        hash_rebuild(t);
        note(t, id);
        publish(t);
        return 0;
}

/* Gives retired entry id to v (same direction, so an outbound one keeps its .out slot): the
 * .out writes stamped before it were meant for the old name and are dropped (scan_report). */
static void entry_reuse(struct shm_table *t, uint32_t id, const struct shm_var *v)
{
        struct table_var *tv = &t->vars[id];

        copy_field(tv->name, sizeof(tv->name), v->name);
        tv->link = v->link;
        tv->flags = 0;
        tv->retired = 0;
        hash_insert(t, tv->name, (int32_t)id);
        dir_rewrite_begin(t);
        dir_fill(&t->dir[id], v, tv->out_slot, SHM_DIR_ADHOC);
        t->dir[id].born = t->dir_rewrites + 1u;        /* the even value that ends it */
        dir_rewrite_end(t);
        note(t, id);
        publish(t);
}

int shm_table_add(struct shm_table *t, const struct shm_var *v)
{
        uint32_t id = t->count;
        struct table_var *tv;
        int reuse;

        uint32_t slot = SHM_OUT_NONE;

        if (var_check(v, t->link_count) < 0)
                return -EINVAL;
        if (hash_lookup(t, v->name) >= 0)
                return -EEXIST;
        reuse = retired_entry(t, v->direction);
        if (reuse >= 0) {
                entry_reuse(t, (uint32_t)reuse, v);
                return reuse;
        }
        if (id >= t->capacity)
                return -ENOSPC;
        if (v->direction == SHM_DIR_OUT) {
                /* A spare .out slot: the scan has kept its word in out_seen[] all along, so
                 * only what a client writes from now on is reported for the new variable. */
                if (t->out_used >= t->out_capacity)
                        return -ENOSPC;
                slot = t->out_used++;
                t->out_ids[slot] = id;
        }
        tv = &t->vars[id];
        copy_field(tv->name, sizeof(tv->name), v->name);
        tv->direction = v->direction;
        tv->link = v->link;
        tv->out_slot = slot;
        tv->flags = 0;
        tv->retired = 0;
        hash_insert(t, tv->name, (int32_t)id);
        /* Entry and slot first, then the count (release): readers acquire the count, so an entry
         * below it is complete when they read it. */
        dir_fill(&t->dir[id], v, slot, SHM_DIR_ADHOC);
        t->count = id + 1u;
        atomic_store_explicit(&t->in->count, t->count, memory_order_release);
        atomic_fetch_add_explicit(&t->in->dir_generation, 1u, memory_order_release);
        /* After the count: a reader that finds the entry in the record finds the name too. */
        note(t, id);
        publish(t);
        return (int)id;
}

int shm_table_link_add(struct shm_table *t, const struct shm_link_def *def)
{
        if (t->link_count >= SHM_LINKS_MAX)
                return -ENOSPC;
        if (link_fill(&t->links[t->link_count], def) < 0)
                return -EINVAL;
        t->link_count++;
        atomic_store_explicit(&t->in->link_count, t->link_count, memory_order_release);
        publish(t);
        return (int)(t->link_count - 1u);
}

/* Copies text, cut to fit, into size/8 NUL-padded words. */
static void text_words(uint64_t *words, size_t size, const char *text)
{
        size_t len = strnlen(text, size - 1u);

        memset(words, 0, size);
        memcpy(words, text, len);
}

int shm_table_link_state(struct shm_table *t, uint32_t link, uint32_t state, const char *name)
{
        uint64_t words[SHM_STATE_NAME_WORDS], text[SHM_LINK_TEXT_WORDS];
        struct shm_link *l;
        uint64_t odd;

        if (link >= t->link_count || !name)
                return -EINVAL;
        l = &t->links[link];
        /* The whole text (cut at SHM_LINK_TEXT_SIZE - 1), and its first 31 bytes where a 1.3
         * client looks. */
        text_words(words, sizeof(words), name);
        text_words(text, sizeof(text), name);
        odd = shm_seqlock_write_begin(&l->seq);
        atomic_store_explicit(&l->state, state, SHM_SEQLOCK_PAYLOAD_STORE);
        atomic_store_explicit(&l->state_ns, clock_ns(CLOCK_MONOTONIC), SHM_SEQLOCK_PAYLOAD_STORE);
        for (unsigned i = 0; i < SHM_STATE_NAME_WORDS; i++)
                atomic_store_explicit(&l->state_name[i], words[i], SHM_SEQLOCK_PAYLOAD_STORE);
        for (unsigned i = 0; i < SHM_LINK_TEXT_WORDS; i++)
                atomic_store_explicit(&t->link_texts[link].text[i], text[i],
                                      SHM_SEQLOCK_PAYLOAD_STORE);
        shm_seqlock_write_end(&l->seq, odd);
        publish(t);
        return 0;
}

static _Atomic uint64_t *counter_word(const struct shm_table *t, uint32_t link, enum shm_counter c)
{
        if ((unsigned)c >= SHM_COUNTERS_MAX)
                return NULL;
        if (link == SHM_LINK_NONE)
                return &t->in->counters[c];
        if (link >= t->link_count)
                return NULL;
        return &t->links[link].counters[c];
}

void shm_table_counter_add(struct shm_table *t, uint32_t link, enum shm_counter c, uint64_t delta)
{
        _Atomic uint64_t *w = counter_word(t, link, c);

        /* Counters are independent statistics: relaxed is enough, readers need no ordering. */
        if (w)
                atomic_fetch_add_explicit(w, delta, memory_order_relaxed);
}

void shm_table_counter_set(struct shm_table *t, uint32_t link, enum shm_counter c, uint64_t value)
{
        _Atomic uint64_t *w = counter_word(t, link, c);

        if (w)
                atomic_store_explicit(w, value, memory_order_relaxed);
}

uint64_t shm_table_counter_get(const struct shm_table *t, uint32_t link, enum shm_counter c)
{
        _Atomic uint64_t *w = counter_word(t, link, c);

        return w ? atomic_load_explicit(w, memory_order_relaxed) : 0;
}

void shm_table_heartbeat(struct shm_table *t)
{
        atomic_store_explicit(&t->in->heartbeat_ns, clock_ns(CLOCK_MONOTONIC), memory_order_relaxed);
}

uint64_t shm_table_event(struct shm_table *t, enum shm_event_type type, uint32_t link,
                         const char *text)
{
        uint64_t n;

        if (link != SHM_LINK_NONE && link >= t->link_count)
                link = SHM_LINK_NONE;
        n = shm_events_write(t->events, t->event_capacity, &t->in->event_head, (uint32_t)type, link,
                             text, clock_ns(CLOCK_MONOTONIC), clock_ns(CLOCK_REALTIME));
        shm_table_counter_add(t, SHM_LINK_NONE, SHM_COUNTER_EVENTS, 1);
        publish(t);
        return n;
}

uint64_t shm_table_eventf(struct shm_table *t, enum shm_event_type type, uint32_t link,
                          const char *fmt, ...)
{
        char text[SHM_EVENT_TEXT_SIZE + 1u];    /* one more: tells a cut text */
        va_list ap;

        va_start(ap, fmt);
        vsnprintf(text, sizeof(text), fmt, ap);
        va_end(ap);
        return shm_table_event(t, type, link, text);
}

/* ---- outbound ------------------------------------------------------------------------------ */

static void want_set(struct shm_table *t, uint32_t i)
{
        t->out_want[i / SHM_TOUCHED_WORD_BITS] |= UINT64_C(1) << (i % SHM_TOUCHED_WORD_BITS);
}

/*
 * Pass A, first step (guarded): the slots this scan looks at, into out_list in ascending order.
 * The touched map's words are taken (exchange with 0; acquire: the slot a bit names was published
 * before it was set) into out_want, the daemon's own map, which also holds the slots the last scan
 * found held or churning. Bits past the capacity are client garbage: dropped. A move of the
 * change word's low half says a client before layout 1.6 wrote, marking nothing: every slot then.
 * The relaxed load first keeps the exchange (a locked write to a line writers share) to the words
 * that have a bit: a mark it misses was set after the bump that woke us was read, so its own
 * bump, which follows it, wakes us again.
 */
static void scan_collect(struct shm_table *t)
{
        uint32_t words = t->out_touched_words, tail = t->out_capacity % SHM_TOUCHED_WORD_BITS;
        uint32_t old = atomic_load_explicit(&t->out->change, memory_order_acquire) &
                       SHM_OUT_CHANGE_UNTOUCHED;

        if (old != t->out_old_steps) {
                t->out_old_steps = old;
                t->out_full = 1;
        }
        for (uint32_t w = 0; w < words; w++) {
                uint64_t bits = atomic_load_explicit(&t->out_touched[w], memory_order_relaxed);

                if (bits)
                        t->out_want[w] |= atomic_exchange_explicit(&t->out_touched[w], 0,
                                                                   memory_order_acquire);
        }
        if (tail)
                t->out_want[words - 1u] &= (UINT64_C(1) << tail) - 1u;
        t->out_nlist = 0;
        if (t->out_full) {
                for (uint32_t i = 0; i < t->out_capacity; i++)
                        t->out_list[t->out_nlist++] = i;
        }
        for (uint32_t w = 0; w < words; w++) {
                uint64_t bits = t->out_want[w];

                t->out_want[w] = 0;
                for (; bits && !t->out_full; bits &= bits - 1u)
                        t->out_list[t->out_nlist++] = w * SHM_TOUCHED_WORD_BITS +
                                                      (uint32_t)__builtin_ctzll(bits);
        }
        t->out_full = 0;
}

/* Pass A (guarded): copy out every listed slot whose word changed since the last scan. */
static void scan_copy(void *arg)
{
        struct shm_table *t = arg;

        scan_collect(t);
        for (uint32_t k = 0; k < t->out_nlist; k++) {
                uint32_t i = t->out_list[k];
                struct table_scan *s = &t->out_scan[i];
                uint64_t word = shm_slot_word(&t->out_slots[i]);

                s->state = SCAN_SAME;
                if (word == t->out_seen[i])
                        continue;
                if (shm_slot_read(&t->out_slots[i], &t->out_copy[i]) == 0) {
                        s->state = SCAN_COPIED;
                        s->word = t->out_copy[i].word;
                        continue;
                }
                word = shm_slot_word(&t->out_slots[i]);
                s->state = shm_seqlock_odd(word) ? SCAN_HELD : SCAN_CHURN;
                s->word = word;
        }
}

/* Pass C (guarded): repair the slots pass B found abandoned. */
static void scan_repair(void *arg)
{
        struct shm_table *t = arg;
        uint64_t now_mono = clock_ns(CLOCK_MONOTONIC), now_real = clock_ns(CLOCK_REALTIME);

        for (uint32_t k = 0; k < t->out_nlist; k++) {
                uint32_t i = t->out_list[k];
                struct table_scan *s = &t->out_scan[i];

                if (s->state != SCAN_REPAIR)
                        continue;
                if (shm_slot_repair(&t->out_slots[i], s->word, (uint32_t)t->pid, now_mono,
                                    now_real) == 0) {
                        s->state = SCAN_REPAIRED;
                        t->out_seen[i] = shm_slot_word(&t->out_slots[i]);
                } else {
                        s->state = SCAN_CHURN;  /* it moved on: look again next scan */
                }
        }
}

/* Pass B: is the writer holding slot i gone? Never trusts the pid blindly (it is client data). */
static int writer_gone(const struct shm_table *t, uint64_t word)
{
        uint32_t pid = shm_seqlock_pid(word);

        if (pid == 0 || pid > TABLE_PID_MAX || (pid_t)pid == t->pid)
                return 1;       /* no process could hold it: a forged or scribbled word */
        return kill((pid_t)pid, 0) < 0 && errno == ESRCH;
}

/*
 * Pass B: the held slots to repair. One whose writer is gone (writer_gone), at once: the fast
 * path. One whose writer kill() finds alive, once it stayed held under the very same odd word
 * past the bound (SHM_TABLE_HELD_*, table.h): a stopped writer, a reused pid, a forged live pid.
 * Every other finding ends a slot's tracking, so a word that keeps changing (writers taking
 * turns) is never repaired, and the next hold starts from zero. Returns how many to repair.
 */
static int scan_judge(struct shm_table *t)
{
        uint64_t now = 0;
        int repairs = 0;

        for (uint32_t k = 0; k < t->out_nlist; k++) {
                struct table_scan *s = &t->out_scan[t->out_list[k]];

                s->taken = 0;
                if (s->state != SCAN_HELD) {
                        s->held_word = 0;
                        continue;
                }
                if (writer_gone(t, s->word)) {
                        s->state = SCAN_REPAIR;
                        s->held_word = 0;
                        repairs++;
                        continue;
                }
                if (now == 0)
                        now = clock_ns(CLOCK_MONOTONIC);
                if (s->held_word != s->word) {
                        s->held_word = s->word;
                        s->held_scans = 0;
                        s->held_since_ns = now;
                }
                /* Only the periodic scans count: wake-ups come at the pace of clients' writes. */
                if (t->out_periodic)
                        s->held_scans++;
                if (s->held_scans >= SHM_TABLE_HELD_SCANS &&
                    now - s->held_since_ns >= t->held_min_ns) {
                        s->state = SCAN_REPAIR;
                        s->taken = 1;
                        s->held_word = 0;       /* repaired, or moved on: either way a new hold */
                        repairs++;
                }
        }
        return repairs;
}

/* Header of .out still as we made it? Copies it out under the guard first. */
struct scan_header {
        const struct shm_out_header *src;
        struct shm_out_header copy;
};

static void scan_header_copy(void *arg)
{
        struct scan_header *h = arg;
        uint64_t words[sizeof(h->copy) / 8u];
        const _Atomic uint64_t *src = (const _Atomic uint64_t *)(const void *)h->src;

        for (size_t i = 0; i < sizeof(words) / 8u; i++)
                words[i] = atomic_load_explicit(&src[i], memory_order_relaxed);
        memcpy(&h->copy, words, sizeof(words));
}

static int out_check(struct shm_table *t)
{
        struct scan_header h = { .src = t->out };
        struct shm_out_geometry g;
        struct stat st;

        if (fstat(t->out_fd, &st) < 0 || (uint64_t)st.st_size != t->out_size)
                return -EBADMSG;
        shm_layout_out_geometry(t->out_capacity, &g);
        if (shm_guard_run(scan_header_copy, &h) < 0)
                return -EBADMSG;
        if (h.copy.magic != SHM_OUT_MAGIC || h.copy.layout_version != SHM_LAYOUT_VERSION ||
            h.copy.header_size != sizeof(h.copy) ||
            h.copy.total_size != g.total_size || h.copy.touched_words != g.touched_words ||
            h.copy.touched_offset != g.touched_offset ||
            h.copy.epoch != t->epoch || h.copy.slot_size != sizeof(struct shm_slot) ||
            h.copy.capacity != t->out_capacity || h.copy.slots_offset != sizeof(h.copy) ||
            h.copy.generation != t->out_generation)
                return -EBADMSG;
        return 0;
}

int shm_table_out_recreate(struct shm_table *t)
{
        int r;

        /* The wake thread must stop reading the old word before its mapping goes away. */
        if (t->wake)
                shm_wake_watch(t->wake, NULL);
        r = out_create(t, t->out_generation + 1u);
        if (t->wake)
                shm_wake_watch_flagged(t->wake, &t->out->change, SHM_OUT_WAITING);
        if (r < 0)
                return r;
        t->out_generation++;
        atomic_store_explicit(&t->in->out_generation, t->out_generation, memory_order_release);
        shm_table_counter_add(t, SHM_LINK_NONE, SHM_COUNTER_OUT_RECREATED, 1);
        publish(t);
        return 0;
}

static int scan_broken(struct shm_table *t)
{
        int r;

        shm_table_counter_add(t, SHM_LINK_NONE, SHM_COUNTER_OUT_BAD_OBJECT, 1);
        r = shm_table_out_recreate(t);
        return r < 0 ? r : -EBADMSG;
}

/*
 * After a repair: the .in mirror of id now says it was copied under the repaired word, so clients
 * take it (layout.h, 1.1) and not the .out slot: the accepted value it holds, or none when no
 * value was ever accepted (clients trust a mirror of the current word even when it holds none).
 * A writer taken over while stopped before its first store may finish its whole value there
 * after it runs again, under the even word we left and no lock: its publish fails (-ECANCELED)
 * and this scan never sees the word move, so the value must not reach readers either.
 */
static void mirror_rebase(struct shm_table *t, uint32_t id, uint64_t word)
{
        struct shm_slot_copy c;

        /* Our own slot: this thread is its only writer, so the read never finds it odd. */
        if (shm_slot_read(&t->slots[id], &c) < 0)
                return;
        if (!(t->vars[id].flags & SHM_SLOT_VALID)) {
                c.length = 0;
                c.value[0] = '\0';
                c.flags &= ~SHM_SLOT_VALID;
        }
        shm_slot_write_mirror(&t->slots[id], c.value, c.length, c.flags, c.mono_ns, c.real_ns,
                              word);
        t->dirty = 1;
}

/* Pass D: one slot's result to the counters, the .in mirror and the engine. */
static int scan_report(struct shm_table *t, uint32_t i, shm_table_out_fn fn, void *userdata)
{
        struct table_scan *s = &t->out_scan[i];
        const struct shm_slot_copy *c = &t->out_copy[i];
        struct shm_out_change ch;

        if (i >= t->out_used) {
                /* A spare slot no variable owns yet: nothing to report, whatever a client put
                 * there; what it wrote is refused as invalid. */
                if (s->state == SCAN_COPIED) {
                        t->out_seen[i] = s->word;
                        shm_table_counter_add(t, SHM_LINK_NONE, SHM_COUNTER_OUT_INVALID, 1);
                }
                return 0;
        }
        memset(&ch, 0, sizeof(ch));
        ch.id = t->out_ids[i];
        ch.name = t->vars[ch.id].name;
        ch.writer_pid = shm_seqlock_pid(s->word);
        switch (s->state) {
        case SCAN_COPIED:
                t->out_seen[i] = s->word;
                if (c->flags & SHM_SLOT_REPAIRED)
                        return 0;       /* our own repair, reported when we made it */
                if (t->vars[ch.id].retired ||
                    shm_layout_stamp_before(c->dir_stamp, t->dir[ch.id].born)) {
                        /* Meant for a retired name (layout.h, 1.5): never the new one's. */
                        shm_table_counter_add(t, SHM_LINK_NONE, SHM_COUNTER_OUT_INVALID, 1);
                        return 0;
                }
                if (shm_slot_copy_check(c) < 0) {
                        shm_table_counter_add(t, SHM_LINK_NONE, SHM_COUNTER_OUT_INVALID, 1);
                        ch.status = SHM_OUT_INVALID;
                        break;
                }
                ch.status = SHM_OUT_CHANGED;
                ch.mono_ns = c->mono_ns;
                ch.real_ns = c->real_ns;
                ch.length = c->length;
                memcpy(ch.value, c->value, c->length);
                ch.value[c->length] = '\0';
                shm_table_counter_add(t, SHM_LINK_NONE, SHM_COUNTER_OUT_ACCEPTED, 1);
                /* The mirror: the writer's stamps and word, so that a client whose .out word
                 * still equals it can read this checked copy instead (layout.h, 1.1). A writer
                 * whose stamp is 0 gets the scan's. */
                table_set(t, ch.id, ch.value, ch.length, c->mono_ns, c->real_ns, s->word);
                break;
        case SCAN_REPAIRED:
                shm_table_counter_add(t, SHM_LINK_NONE, SHM_COUNTER_OUT_REPAIRED, 1);
                if (s->taken)
                        shm_table_counter_add(t, SHM_LINK_NONE, SHM_COUNTER_OUT_TAKEN_OVER, 1);
                ch.status = SHM_OUT_REPAIRED;
                ch.taken_over = s->taken;
                if (!t->vars[ch.id].retired)
                        mirror_rebase(t, ch.id, t->out_seen[i]);
                break;
        case SCAN_HELD:
        case SCAN_CHURN:
                /* A live writer is in the middle of it, or it keeps changing: next scan. */
                shm_table_counter_add(t, SHM_LINK_NONE, SHM_COUNTER_OUT_BUSY, 1);
                return 0;
        default:
                return 0;
        }
        if (fn)
                fn(userdata, &ch);
        return 1;
}

/* One scan of the slots scan_collect lists (every one when t->out_full is set). */
static int out_scan(struct shm_table *t, shm_table_out_fn fn, void *userdata)
{
        int implicit, repairs = 0, reported = 0;

        if (t->out_capacity == 0)
                return 0;
        /* Cheap (one sigaction) and robust against anyone having replaced the handler since. */
        if (shm_guard_install() < 0)
                return -EFAULT;
        if (out_check(t) < 0 || shm_guard_run(scan_copy, t) < 0)
                return scan_broken(t);
        repairs = scan_judge(t);
        if (repairs && shm_guard_run(scan_repair, t) < 0)
                return scan_broken(t);

        implicit = !t->in_batch;
        if (implicit)
                shm_table_begin(t);
        for (uint32_t k = 0; k < t->out_nlist; k++) {
                uint32_t i = t->out_list[k];
                uint8_t state = t->out_scan[i].state;

                reported += scan_report(t, i, fn, userdata);
                /* Held by a live writer, or churning: look again at the next scan, whoever
                 * wakes us (its writer's mark may be long taken). */
                if (state == SCAN_HELD || state == SCAN_CHURN)
                        want_set(t, i);
        }
        if (implicit)
                shm_table_commit(t);
        return reported;
}

int shm_table_out_scan(struct shm_table *t, shm_table_out_fn fn, void *userdata)
{
        int r;

        t->out_full = 1;
        t->out_periodic = 1;
        r = out_scan(t, fn, userdata);
        t->out_periodic = 0;
        return r;
}

int shm_table_out_scan_touched(struct shm_table *t, shm_table_out_fn fn, void *userdata)
{
        return out_scan(t, fn, userdata);
}

int shm_table_out_wake_fd(struct shm_table *t)
{
        int r;

        if (!t->wake) {
                r = shm_wake_start(&t->wake);
                if (r < 0)
                        return r;
                shm_wake_watch_flagged(t->wake, &t->out->change, SHM_OUT_WAITING);
                shm_wake_doorbell(t->wake, &t->in->out_doorbell);
        }
        return shm_wake_fd(t->wake);
}

uint64_t shm_table_out_wake_stamp(const struct shm_table *t)
{
        return t->wake ? shm_wake_signal_ns(t->wake) : 0;
}

int shm_table_out_wake_ack(struct shm_table *t)
{
        return t->wake ? shm_wake_ack(t->wake) : 0;
}
