/*
 * Unit tests of the daemon-side table module on real POSIX shm objects and real processes:
 * creation and modes, replacing a dead daemon's tables and refusing a live one's, batches and the
 * change word, stale marks, ad hoc names, links, counters, events, and the outbound scan against
 * well-behaved, dying and rogue (scribbling, truncating) clients.
 */
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>

#include "common/shmtest.h"
#include "shm/futex.h"
#include "shm/layout.h"
#include "shm/seqlock.h"
#include "shm/slot.h"
#include "shm/table.h"

#define POLL_LIMIT_MS   10000   /* a hang guard, not a timing assertion */
#define ADHOC           3u

/* Variable ids of the fixture (indices into vars[]). */
enum { LAT, LON, THROTTLE, STEER, STATE, NOTE, NVARS };
/* Their .out slots, in declaration order of the outbound ones. */
enum { OUT_THROTTLE, OUT_STEER, OUT_NOTE, NOUT };

static const struct shm_var vars[NVARS] = {
        { "AutoGpsLat", SHM_DIR_IN, SHM_TYPE_DOUBLE, 0, "A", 0 },
        { "AutoGpsLon", SHM_DIR_IN, SHM_TYPE_DOUBLE, 0, "A", 1 },
        { "CmdThrottle", SHM_DIR_OUT, SHM_TYPE_DOUBLE, 0, "A", 0 },
        { "CmdSteer", SHM_DIR_OUT, SHM_TYPE_DOUBLE, 0, "A", 1 },
        { "agility.state", SHM_DIR_IN, SHM_TYPE_STRING, 1, NULL, SHM_POSITION_NONE },
        { "Note", SHM_DIR_OUT, SHM_TYPE_STRING, SHM_LINK_NONE, NULL, SHM_POSITION_NONE },
};

static void config_default(struct shmtest_table *f)
{
        shmtest_table_config(f, vars, NVARS, ADHOC);
}

static int setup(void **state)
{
        struct shmtest_table *f = calloc(1, sizeof(*f));

        shmtest_table_init(f, "table");
        config_default(f);
        if (shmtest_table_create(f) < 0)
                return -1;
        *state = f;
        return 0;
}

static int setup_bare(void **state)
{
        struct shmtest_table *f = calloc(1, sizeof(*f));

        shmtest_table_init(f, "bare");
        config_default(f);
        *state = f;
        return 0;
}

static int teardown(void **state)
{
        struct shmtest_table *f = *state;

        shmtest_table_destroy(f);
        free(f);
        return 0;
}

/* ---- direct views of the objects, as a client (or a rogue) sees them (common/shmtest.h) ---- */

static uint32_t change_of(struct shmtest_view *v)
{
        return atomic_load(&shmtest_in_header(v)->change);
}

static _Atomic uint64_t *touched_map(const struct shmtest_view *v)
{
        const struct shm_out_header *h = v->base;

        return (_Atomic uint64_t *)(void *)((char *)v->base + h->touched_offset);
}

/* How a write in these tests tells the daemon, or fails to. */
enum touch_how {
        TOUCH_V10,              /* as a layout 1.0 client: add 1, always wake (the daemon copes) */
        TOUCH_MARKED,           /* as a 1.6 client: publish, mark, add SHM_OUT_CHANGE_TOUCHED */
        TOUCH_LOST,             /* a 1.6 writer killed between its publish and its mark */
        TOUCH_OLD,              /* as a 1.1-1.5 client: no mark, add SHM_OUT_CHANGE_STEP */
};

/* A well-behaved client write of raw bytes (len bytes of value, flags as given). */
static int out_write_as(const char *out_name, unsigned slot, const char *value, uint32_t len,
                        uint32_t flags, enum touch_how how)
{
        struct shmtest_view v = shmtest_view_open(out_name, 1);
        struct shm_out_header *h = v.base;
        uint64_t word;
        int r;

        if (!v.base)
                return -ENOENT;
        r = shm_slot_claim(shmtest_out_slot(&v, slot), (uint32_t)getpid(), &word);
        if (r == 0) {
                shm_slot_store(shmtest_out_slot(&v, slot), value, len, flags, 1, 2);
                r = shm_slot_publish(shmtest_out_slot(&v, slot), word);
        }
        if (r == 0 && how == TOUCH_V10) {
                atomic_fetch_add(&h->change, 1);
                shm_futex_wake(&h->change, 1);
        } else if (r == 0 && how == TOUCH_MARKED) {
                atomic_fetch_or(&touched_map(&v)[slot / SHM_TOUCHED_WORD_BITS],
                                UINT64_C(1) << (slot % SHM_TOUCHED_WORD_BITS));
                atomic_fetch_add(&h->change, SHM_OUT_CHANGE_TOUCHED);
        } else if (r == 0 && how == TOUCH_OLD) {
                atomic_fetch_add(&h->change, SHM_OUT_CHANGE_STEP);
        }
        shmtest_view_close(&v);
        return r;
}

static int out_write_raw(const char *out_name, unsigned slot, const char *value, uint32_t len,
                         uint32_t flags)
{
        return out_write_as(out_name, slot, value, len, flags, TOUCH_V10);
}

static int out_write(const char *out_name, unsigned slot, const char *value)
{
        return out_write_raw(out_name, slot, value, (uint32_t)strlen(value),
                             SHM_SLOT_VALID | SHM_SLOT_OUTBOUND);
}

/* Records what a scan reported. */
struct seen {
        unsigned n;
        struct shm_out_change c[16];
};

static void on_change(void *userdata, const struct shm_out_change *change)
{
        struct seen *s = userdata;

        if (s->n < 16)
                s->c[s->n] = *change;
        s->n++;
}

static int scan(struct shm_table *t, struct seen *s)
{
        memset(s, 0, sizeof(*s));
        return shm_table_out_scan(t, on_change, s);
}

/* Bytes of a .out object with n slots: the touched map (layout 1.6) after them. */
static long out_object_size(uint32_t n)
{
        struct shm_out_geometry g;

        shm_layout_out_geometry(n, &g);
        return (long)g.object_size;
}

/* ---- creation ------------------------------------------------------------------------------- */

static void test_create_layout(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view v = shmtest_view_open(f->in_name, 0);
        struct shm_in_header *h = shmtest_in_header(&v);
        struct shm_in_geometry g;
        unsigned mode;
        gid_t gid;

        assert_non_null(v.base);
        shm_layout_in_geometry(NVARS + ADHOC, 16, &g);
        /* 1.4: the link texts lie past total_size (what a 1.3 client checks it against). */
        assert_int_equal(v.size, g.object_size);
        assert_int_equal(h->total_size, g.total_size);
        assert_true(g.link_texts_offset >= g.total_size);
        assert_int_equal(h->link_texts_offset, g.link_texts_offset);
        assert_int_equal(shm_layout_check_in(h, v.size), 0);
        assert_int_equal(shm_layout_has_link_texts(h, v.size), 1);
        assert_int_equal(shm_layout_has_link_texts(h, g.link_texts_end), 1);
        assert_int_equal(shm_layout_has_link_texts(h, g.link_texts_end - 1u), 0);
        /* 1.7: the change record past the link texts, where a 1.6 object ended. */
        assert_int_equal(h->changes_offset, g.changes_offset);
        assert_int_equal(h->changes_capacity, shm_layout_changes_capacity(NVARS + ADHOC));
        assert_true(g.changes_offset >= g.link_texts_end);
        assert_int_equal(shm_layout_has_changes(h, v.size), 1);
        assert_int_equal(shm_layout_has_changes(h, v.size - 1u), 0);
        assert_int_equal(atomic_load(&h->magic), SHM_IN_MAGIC);
        assert_int_equal(h->daemon_pid, getpid());
        assert_int_equal(h->epoch, shm_table_epoch(f->t));
        assert_true(h->epoch != 0);
        assert_int_equal(atomic_load(&h->state), SHM_STATE_LIVE);
        assert_int_equal(h->capacity, NVARS + ADHOC);
        assert_int_equal(atomic_load(&h->count), NVARS);
        assert_int_equal(h->out_capacity, NOUT);
        assert_int_equal(atomic_load(&h->link_count), 2);
        assert_string_equal(shmtest_in_link(&v, 1)->name, "agility");
        assert_string_equal(shmtest_in_link(&v, 1)->protocol, "circe");
        for (unsigned i = 0; i < NVARS; i++) {
                struct shm_dir_entry *e = &shmtest_in_dir(&v)[i];

                assert_string_equal(e->name, vars[i].name);
                assert_int_equal(e->direction, vars[i].direction);
                assert_int_equal(e->type, vars[i].type);
                assert_int_equal(e->link, vars[i].link);
                assert_int_equal(e->position, vars[i].position);
                assert_string_equal(e->peer, vars[i].peer ? vars[i].peer : "");
                assert_int_equal(e->flags, 0);
        }
        assert_int_equal(shmtest_in_dir(&v)[THROTTLE].out_slot, OUT_THROTTLE);
        assert_int_equal(shmtest_in_dir(&v)[NOTE].out_slot, OUT_NOTE);
        assert_int_equal(shmtest_in_dir(&v)[LAT].out_slot, SHM_OUT_NONE);
        assert_int_equal(shm_table_count(f->t), NVARS);
        assert_int_equal(shm_table_find(f->t, "CmdSteer"), STEER);
        assert_int_equal(shm_table_find(f->t, "nope"), -ENOENT);
        assert_int_equal(shm_table_direction(f->t, NOTE), SHM_DIR_OUT);
        assert_int_equal(shm_table_direction(f->t, 99), -ENOENT);
        shmtest_view_close(&v);

        assert_int_equal(shmtest_object_mode(f->in_name, &mode, &gid), 0);
        assert_int_equal(mode, 0644);
        assert_int_equal(shmtest_object_mode(f->out_name, &mode, &gid), 0);
        assert_int_equal(mode, 0660);
        assert_int_equal(shmtest_object_size(f->out_name), (long)out_object_size(NOUT));

        f->t = shm_table_destroy(f->t);
        assert_int_equal(shmtest_object_size(f->in_name), -ENOENT);
        assert_int_equal(shmtest_object_size(f->out_name), -ENOENT);
}

static void test_create_group(void **state)
{
        struct shmtest_table *f = *state;
        unsigned mode;
        gid_t gid;

        if (geteuid() != 0)
                skip();
        f->cfg.has_group = 1;
        f->cfg.gid = SHMTEST_GROUP;
        assert_int_equal(shm_table_create(&f->cfg, &f->t), 0);
        assert_int_equal(shmtest_object_mode(f->in_name, &mode, &gid), 0);
        assert_int_equal(mode, 0640);
        assert_int_equal(gid, SHMTEST_GROUP);
        assert_int_equal(shmtest_object_mode(f->out_name, &mode, &gid), 0);
        assert_int_equal(mode, 0660);
        assert_int_equal(gid, SHMTEST_GROUP);
}

static void test_create_errors(void **state)
{
        struct shmtest_table *f = *state;
        struct shm_var bad[2];
        struct shm_link_def many[SHM_LINKS_MAX + 1];
        struct shm_table *t = NULL;
        static const struct { struct shm_var v; int want; } cases[] = {
                { { "", SHM_DIR_IN, SHM_TYPE_LONG, SHM_LINK_NONE, NULL, -1 }, -EINVAL },
                { { "has space", SHM_DIR_IN, SHM_TYPE_LONG, SHM_LINK_NONE, NULL, -1 }, -EINVAL },
                { { "x", 7, SHM_TYPE_LONG, SHM_LINK_NONE, NULL, -1 }, -EINVAL },
                { { "x", SHM_DIR_IN, 9, SHM_LINK_NONE, NULL, -1 }, -EINVAL },
                { { "x", SHM_DIR_IN, SHM_TYPE_LONG, 2, NULL, -1 }, -EINVAL },   /* 2 links */
                { { "x", SHM_DIR_IN, SHM_TYPE_LONG, SHM_LINK_NONE, "0123456789abcdef", -1 }, -EINVAL },
        };

        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                bad[0] = cases[i].v;
                f->cfg.vars = bad;
                f->cfg.nvars = 1;
                assert_int_equal(shm_table_create(&f->cfg, &t), cases[i].want);
                assert_null(t);
        }
        bad[0] = vars[LAT];
        bad[1] = vars[LAT];
        f->cfg.nvars = 2;
        assert_int_equal(shm_table_create(&f->cfg, &t), -EEXIST);

        config_default(f);
        for (unsigned i = 0; i <= SHM_LINKS_MAX; i++)
                many[i] = shmtest_links[0];
        f->cfg.links = many;
        f->cfg.nlinks = SHM_LINKS_MAX + 1;
        assert_int_equal(shm_table_create(&f->cfg, &t), -EINVAL);
        config_default(f);
        f->cfg.adhoc_capacity = SHM_CAPACITY_MAX;
        assert_int_equal(shm_table_create(&f->cfg, &t), -EINVAL);
        config_default(f);
        f->cfg.instance = "no/slash";
        assert_int_equal(shm_table_create(&f->cfg, &t), -EINVAL);
        assert_null(t);
        /* Nothing was left behind by the failures. */
        assert_int_equal(shmtest_object_size(f->in_name), -ENOENT);
        assert_int_equal(shmtest_object_size(f->out_name), -ENOENT);
}

/* Layout 1.2: the header publishes the control socket path, NUL-padded; none is "". */
static void test_create_socket_path(void **state)
{
        struct shmtest_table *f = *state;
        char path[SHM_SOCKET_PATH_SIZE + 1];
        struct shmtest_view v;
        struct shm_table *t = NULL;
        struct shm_in_header *h;

        /* Refused: relative, and one byte too long for sun_path (nothing is left behind). */
        f->cfg.control_socket = "run/x.sock";
        assert_int_equal(shm_table_create(&f->cfg, &t), -EINVAL);
        memset(path, 'p', sizeof(path) - 1);
        path[0] = '/';
        path[SHM_SOCKET_PATH_SIZE] = '\0';
        f->cfg.control_socket = path;
        assert_int_equal(shm_table_create(&f->cfg, &t), -EINVAL);
        assert_null(t);
        assert_int_equal(shmtest_object_size(f->in_name), -ENOENT);
        /* The longest that fits is written whole. */
        path[SHM_SOCKET_PATH_SIZE - 1] = '\0';
        assert_int_equal(shm_table_create(&f->cfg, &f->t), 0);
        v = shmtest_view_open(f->in_name, 0);
        h = shmtest_in_header(&v);
        assert_non_null(v.base);
        assert_true((h->layout_version & 0xffffu) >= SHM_LAYOUT_MINOR_SOCKET);
        assert_memory_equal(h->control_socket, path, SHM_SOCKET_PATH_SIZE);
        shmtest_view_close(&v);
        f->t = shm_table_destroy(f->t);
        /* A short one is NUL-padded to the end of the field. */
        f->cfg.control_socket = "/run/sharedlink/x.sock";
        assert_int_equal(shm_table_create(&f->cfg, &f->t), 0);
        v = shmtest_view_open(f->in_name, 0);
        h = shmtest_in_header(&v);
        assert_string_equal(h->control_socket, "/run/sharedlink/x.sock");
        for (size_t i = strlen("/run/sharedlink/x.sock"); i < SHM_SOCKET_PATH_SIZE; i++)
                assert_int_equal(h->control_socket[i], 0);
        shmtest_view_close(&v);
        f->t = shm_table_destroy(f->t);
        /* None: an empty field, as an older daemon leaves it. */
        f->cfg.control_socket = NULL;
        assert_int_equal(shm_table_create(&f->cfg, &f->t), 0);
        v = shmtest_view_open(f->in_name, 0);
        assert_string_equal(shmtest_in_header(&v)->control_socket, "");
        shmtest_view_close(&v);
}

static void test_refuse_live_self(void **state)
{
        struct shmtest_table *f = *state;
        struct shm_table *t2 = NULL;
        struct shmtest_view v;

        /* Our own tables: this process is alive, so a second create must not replace them. */
        assert_int_equal(shm_table_create(&f->cfg, &t2), -EBUSY);
        assert_null(t2);
        v = shmtest_view_open(f->in_name, 0);
        assert_int_equal(shm_layout_check_in(shmtest_in_header(&v), v.size), 0);
        assert_int_equal(shmtest_in_header(&v)->epoch, shm_table_epoch(f->t));
        assert_int_equal(atomic_load(&shmtest_in_header(&v)->state), SHM_STATE_LIVE);
        shmtest_view_close(&v);
}

struct daemon_child {
        const struct shm_table_config *cfg;
        int report[2];          /* child -> parent: its epoch */
        int hold[2];            /* parent -> child: closed to let it go */
};

/* A "daemon" in a child process: creates the tables, reports its epoch, lives until told. */
static int daemon_child_main(void *arg)
{
        struct daemon_child *d = arg;
        struct shm_table *t;
        uint64_t epoch = 0;
        char c;

        close(d->report[0]);
        close(d->hold[1]);
        if (shm_table_create(d->cfg, &t) == 0)
                epoch = shm_table_epoch(t);
        if (write(d->report[1], &epoch, sizeof(epoch)) != sizeof(epoch))
                return 1;
        while (read(d->hold[0], &c, 1) < 0 && errno == EINTR)
                ;
        _exit(0);       /* dies without destroying: like a crash, the objects stay */
}

static pid_t daemon_child_start(struct daemon_child *d, uint64_t *ret_epoch)
{
        pid_t pid;

        assert_int_equal(pipe(d->report), 0);
        assert_int_equal(pipe(d->hold), 0);
        pid = shmtest_fork(daemon_child_main, d);
        close(d->report[1]);
        close(d->hold[0]);
        assert_int_equal(read(d->report[0], ret_epoch, sizeof(*ret_epoch)), sizeof(*ret_epoch));
        close(d->report[0]);
        return pid;
}

static void test_replace_stale_refuse_live(void **state)
{
        struct shmtest_table *f = *state;
        struct daemon_child d = { .cfg = &f->cfg };
        uint64_t child_epoch;
        struct shm_in_header *old;
        uint32_t old_change;
        struct shmtest_view v;
        pid_t pid;

        pid = daemon_child_start(&d, &child_epoch);
        assert_true(child_epoch != 0);
        /* Alive: refused. */
        assert_int_equal(shm_table_create(&f->cfg, &f->t), -EBUSY);
        v = shmtest_view_open(f->in_name, 0);           /* a client of the child's tables */
        old = shmtest_in_header(&v);
        old_change = atomic_load(&old->change);
        assert_int_equal(old->epoch, child_epoch);

        /* Dead (killed, reaped): replaced, and the old table's clients are told. */
        kill(pid, SIGKILL);
        assert_int_equal(shmtest_wait(pid), 128 + SIGKILL);
        close(d.hold[1]);
        assert_int_equal(shm_table_create(&f->cfg, &f->t), 0);
        assert_true(shm_table_epoch(f->t) != child_epoch);
        assert_int_equal(atomic_load(&old->state), SHM_STATE_CLOSED);
        assert_int_not_equal(atomic_load(&old->change), old_change);
        shmtest_view_close(&v);
        v = shmtest_view_open(f->in_name, 0);
        assert_int_equal(shmtest_in_header(&v)->epoch, shm_table_epoch(f->t));
        assert_int_equal(shmtest_in_header(&v)->daemon_pid, getpid());
        shmtest_view_close(&v);
}

static void test_replace_garbage(void **state)
{
        struct shmtest_table *f = *state;
        unsigned char junk[4096];
        int fd;

        /* Objects with random content (no magic) and nobody holding them: replaced. */
        for (size_t i = 0; i < sizeof(junk); i++)
                junk[i] = (unsigned char)(i * 131u + 7u);
        fd = shm_open(f->in_name, O_RDWR | O_CREAT | O_EXCL, 0600);
        assert_true(fd >= 0);
        assert_int_equal(write(fd, junk, sizeof(junk)), sizeof(junk));
        close(fd);
        fd = shm_open(f->out_name, O_RDWR | O_CREAT | O_EXCL, 0600);
        assert_true(fd >= 0);
        close(fd);
        assert_int_equal(shm_table_create(&f->cfg, &f->t), 0);
        assert_int_equal(shmtest_object_size(f->out_name), (long)out_object_size(NOUT));
}

static void test_refuse_being_created(void **state)
{
        struct shmtest_table *f = *state;
        int fd;

        /* An object without magic whose creator holds the lock: another daemon mid-creation. */
        fd = shm_open(f->in_name, O_RDWR | O_CREAT | O_EXCL, 0600);
        assert_true(fd >= 0);
        assert_int_equal(flock(fd, LOCK_EX), 0);
        assert_int_equal(shm_table_create(&f->cfg, &f->t), -EBUSY);
        assert_null(f->t);
        close(fd);      /* that creator died */
        assert_int_equal(shm_table_create(&f->cfg, &f->t), 0);
}

/* ---- inbound -------------------------------------------------------------------------------- */

static void expect_slot(struct shmtest_view *v, unsigned id, const char *value, uint32_t flags)
{
        struct shm_slot_copy c;

        assert_int_equal(shm_slot_read(shmtest_in_slot(v, id), &c), 0);
        assert_int_equal(c.flags, flags);
        assert_int_equal(c.length, strlen(value));
        assert_string_equal(c.value, value);
}

static void test_batch_change_word(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view v = shmtest_view_open(f->in_name, 0);
        struct shm_slot_copy c;
        uint32_t before = change_of(&v);

        shm_table_begin_at(f->t, 1000, 2000);
        assert_int_equal(shm_table_set(f->t, LAT, "40.12345678", 11), 0);
        assert_int_equal(shm_table_set(f->t, LON, "-113.5", 6), 0);
        assert_int_equal(shm_table_set_str(f->t, STATE, "connected"), 0);
        assert_int_equal(change_of(&v), before);                /* nothing until commit */
        assert_int_equal(shm_table_commit(f->t), 1);
        assert_int_equal(change_of(&v), before + 1);            /* exactly one bump */
        expect_slot(&v, LAT, "40.12345678", SHM_SLOT_VALID);
        expect_slot(&v, STATE, "connected", SHM_SLOT_VALID);
        assert_int_equal(shm_slot_read(shmtest_in_slot(&v, LON), &c), 0);
        assert_int_equal(c.mono_ns, 1000);
        assert_int_equal(c.real_ns, 2000);
        assert_int_equal(c.word, 2);

        shm_table_begin(f->t);
        assert_int_equal(shm_table_commit(f->t), 0);            /* empty batch: no bump */
        assert_int_equal(change_of(&v), before + 1);

        assert_int_equal(shm_table_set_str(f->t, LAT, "41"), 0); /* outside a batch: its own */
        assert_int_equal(change_of(&v), before + 2);
        expect_slot(&v, LAT, "41", SHM_SLOT_VALID);

        /* Refused: nothing written, nothing published. */
        assert_int_equal(shm_table_set(f->t, LAT, "a|b", 3), -EINVAL);
        assert_int_equal(shm_table_set(f->t, LAT, "x\n", 2), -EINVAL);
        assert_int_equal(shm_table_set_str(f->t, LAT,
                         "0123456789012345678901234567890123456789012345678901234567890123"), -EINVAL);
        assert_int_equal(shm_table_set(f->t, 99, "1", 1), -ENOENT);
        assert_int_equal(shm_table_set(f->t, LAT, NULL, 0), -EINVAL);
        assert_int_equal(change_of(&v), before + 2);
        expect_slot(&v, LAT, "41", SHM_SLOT_VALID);
        shmtest_view_close(&v);
}

struct change_waiter {
        _Atomic uint32_t *word;         /* in a mapping the child inherits */
        uint32_t seen;
};

/* A client process blocked on the change word: exits 0 once it moved past `seen`. */
static int change_waiter_main(void *arg)
{
        struct change_waiter *w = arg;
        _Atomic uint32_t *word = w->word;

        while (atomic_load(word) == w->seen)
                if (shm_futex_wait(word, w->seen, POLL_LIMIT_MS) == -ETIMEDOUT)
                        return 1;
        return 0;
}

static void test_commit_wakes_other_process(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view v = shmtest_view_open(f->in_name, 0);
        struct change_waiter w = { &shmtest_in_header(&v)->change, change_of(&v) };
        pid_t pid = shmtest_fork(change_waiter_main, &w);

        shm_table_begin(f->t);
        shm_table_set_str(f->t, LAT, "1");
        shm_table_commit(f->t);
        assert_int_equal(shmtest_wait(pid), 0);
        shmtest_view_close(&v);
}

static void test_stale(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view v = shmtest_view_open(f->in_name, 0);
        uint32_t before;

        shm_table_begin(f->t);
        shm_table_set_str(f->t, LAT, "1");
        shm_table_set_str(f->t, LON, "2");
        shm_table_set_str(f->t, STATE, "up");
        shm_table_commit(f->t);
        before = change_of(&v);
        assert_int_equal(shm_table_set_stale(f->t, STATE, 1), 0);
        expect_slot(&v, STATE, "up", SHM_SLOT_VALID | SHM_SLOT_STALE);
        assert_int_equal(change_of(&v), before + 1);
        /* The link marks only its own inbound variables (not the outbound ones, not link 1's). */
        assert_int_equal(shm_table_set_link_stale(f->t, 0, 1), 2);
        expect_slot(&v, LAT, "1", SHM_SLOT_VALID | SHM_SLOT_STALE);
        expect_slot(&v, LON, "2", SHM_SLOT_VALID | SHM_SLOT_STALE);
        assert_int_equal(change_of(&v), before + 2);
        assert_int_equal(shm_table_set_link_stale(f->t, 0, 1), 0);      /* no change: no bump */
        assert_int_equal(change_of(&v), before + 2);
        /* A fresh value clears the mark. */
        assert_int_equal(shm_table_set_str(f->t, LAT, "3"), 0);
        expect_slot(&v, LAT, "3", SHM_SLOT_VALID);
        assert_int_equal(shm_table_set_link_stale(f->t, 0, 0), 1);
        expect_slot(&v, LON, "2", SHM_SLOT_VALID);
        assert_int_equal(shm_table_set_link_stale(f->t, 7, 0), -EINVAL);
        assert_int_equal(shm_table_set_stale(f->t, 99, 0), -ENOENT);
        shmtest_view_close(&v);
}

/* shm_table_get reads back what was published: inbound values, outbound mirrors, flags. */
static void test_get(void **state)
{
        struct shmtest_table *f = *state;
        char buf[SHM_VALUE_SIZE], small[2];
        uint32_t flags = 0xffu;

        assert_int_equal(shm_table_get(f->t, LAT, buf, sizeof(buf), &flags), 0);
        assert_string_equal(buf, "");
        assert_int_equal(flags, 0);                     /* never set: not valid */
        assert_int_equal(shm_table_set_str(f->t, LAT, "40.12345678"), 0);
        assert_int_equal(shm_table_get(f->t, LAT, buf, sizeof(buf), &flags), 11);
        assert_string_equal(buf, "40.12345678");
        assert_int_equal(flags, SHM_SLOT_VALID);
        assert_int_equal(shm_table_set_stale(f->t, LAT, 1), 0);
        assert_int_equal(shm_table_get(f->t, LAT, buf, sizeof(buf), &flags), 11);
        assert_int_equal(flags, SHM_SLOT_VALID | SHM_SLOT_STALE);
        /* An outbound variable reads as its mirror; flags may be left out. */
        assert_int_equal(shm_table_set_str(f->t, THROTTLE, "0.5"), 0);
        assert_int_equal(shm_table_get(f->t, THROTTLE, buf, sizeof(buf), NULL), 3);
        assert_string_equal(buf, "0.5");
        /* Errors leave the out-parameters alone. */
        flags = 0xffu;
        assert_int_equal(shm_table_get(f->t, LAT, small, sizeof(small), &flags), -ENOBUFS);
        assert_int_equal(shm_table_get(f->t, 99, buf, sizeof(buf), &flags), -ENOENT);
        assert_int_equal(flags, 0xffu);
}

static void test_adhoc(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view v = shmtest_view_open(f->in_name, 0);
        struct shm_var adhoc = { "Adhoc0", SHM_DIR_IN, SHM_TYPE_STRING, 0, "A", SHM_POSITION_NONE };
        uint32_t gen = atomic_load(&shmtest_in_header(&v)->dir_generation);
        uint32_t before = change_of(&v);
        char name[16];
        int id;

        id = shm_table_add(f->t, &adhoc);
        assert_int_equal(id, NVARS);
        assert_int_equal(atomic_load(&shmtest_in_header(&v)->count), NVARS + 1);
        assert_int_equal(atomic_load(&shmtest_in_header(&v)->dir_generation), gen + 1);
        assert_int_equal(change_of(&v), before + 1);
        assert_string_equal(shmtest_in_dir(&v)[id].name, "Adhoc0");
        assert_int_equal(shmtest_in_dir(&v)[id].flags, SHM_DIR_ADHOC);
        assert_int_equal(shm_table_find(f->t, "Adhoc0"), id);
        assert_int_equal(shm_table_set_str(f->t, (uint32_t)id, "v"), 0);
        expect_slot(&v, (unsigned)id, "v", SHM_SLOT_VALID);

        assert_int_equal(shm_table_add(f->t, &adhoc), -EEXIST);
        assert_int_equal(shm_table_add(f->t, &vars[LAT]), -EEXIST);
        adhoc.name = "OutAdhoc";
        adhoc.direction = SHM_DIR_OUT;
        assert_int_equal(shm_table_add(f->t, &adhoc), -ENOSPC);         /* no spare .out slot */
        adhoc.direction = SHM_DIR_IN;
        adhoc.link = 5;
        assert_int_equal(shm_table_add(f->t, &adhoc), -EINVAL);         /* no such link */
        adhoc.link = SHM_LINK_NONE;
        for (unsigned i = 1; i < ADHOC; i++) {
                snprintf(name, sizeof(name), "Adhoc%u", i);
                adhoc.name = name;
                assert_int_equal(shm_table_add(f->t, &adhoc), (int)(NVARS + i));
        }
        adhoc.name = "OneTooMany";
        assert_int_equal(shm_table_add(f->t, &adhoc), -ENOSPC);
        assert_int_equal(atomic_load(&shmtest_in_header(&v)->count), NVARS + ADHOC);
        assert_int_equal(atomic_load(&shmtest_in_header(&v)->dir_generation), gen + ADHOC);
        shmtest_view_close(&v);
}

static void test_links_counters(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view v = shmtest_view_open(f->in_name, 0);
        struct shm_link_def def = { "arena", "circe" };
        struct shm_link *l;
        char name[16];

        assert_int_equal(shm_table_link_add(f->t, &def), 2);
        assert_int_equal(atomic_load(&shmtest_in_header(&v)->link_count), 3);
        assert_string_equal(shmtest_in_link(&v, 2)->name, "arena");
        assert_int_equal(shm_table_link_state(f->t, 1, 2, "connected"), 0);
        l = shmtest_in_link(&v, 1);
        assert_false(shm_seqlock_odd(atomic_load(&l->seq)));
        assert_int_equal(atomic_load(&l->state), 2);
        assert_string_equal((const char *)(uintptr_t)l->state_name, "connected");
        assert_true(atomic_load(&l->state_ns) > 0);
        assert_int_equal(shm_table_link_state(f->t, 9, 1, "x"), -EINVAL);
        /* A long text (1.4): whole in the link text, its first 31 bytes in state_name. */
        assert_int_equal(shm_table_link_state(f->t, 1, 1,
                         "a-state-name-that-is-far-too-long-for-it"), 0);
        assert_string_equal((const char *)(uintptr_t)l->state_name,
                            "a-state-name-that-is-far-too-lo");
        assert_string_equal((const char *)(uintptr_t)((const char *)v.base +
                                                      shmtest_in_header(&v)->link_texts_offset +
                                                      sizeof(struct shm_link_text)),
                            "a-state-name-that-is-far-too-long-for-it");
        assert_int_equal(shm_table_link_state(f->t, 1, 1, NULL), -EINVAL);

        shm_table_counter_add(f->t, 0, SHM_COUNTER_FRAMES_IN, 3);
        shm_table_counter_add(f->t, 0, SHM_COUNTER_FRAMES_IN, 2);
        shm_table_counter_set(f->t, 1, SHM_COUNTER_BAD_CHECKSUM, 42);
        shm_table_counter_add(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_INVALID, 1);
        shm_table_counter_add(f->t, 31, SHM_COUNTER_FRAMES_IN, 1);      /* no such link: ignored */
        assert_int_equal(shm_table_counter_get(f->t, 0, SHM_COUNTER_FRAMES_IN), 5);
        assert_int_equal(atomic_load(&shmtest_in_link(&v, 0)->counters[SHM_COUNTER_FRAMES_IN]), 5);
        assert_int_equal(atomic_load(&shmtest_in_link(&v, 1)->counters[SHM_COUNTER_BAD_CHECKSUM]), 42);
        assert_int_equal(atomic_load(&shmtest_in_header(&v)->counters[SHM_COUNTER_OUT_INVALID]), 1);
        assert_int_equal(shm_table_counter_get(f->t, 31, SHM_COUNTER_FRAMES_IN), 0);

        for (unsigned i = 3; i < SHM_LINKS_MAX; i++) {
                snprintf(name, sizeof(name), "l%u", i);
                def.name = name;
                assert_int_equal(shm_table_link_add(f->t, &def), (int)i);
        }
        assert_int_equal(shm_table_link_add(f->t, &def), -ENOSPC);
        def.name = "";
        assert_int_equal(shm_table_link_add(f->t, &def), -ENOSPC);
        shmtest_view_close(&v);
}

static void test_heartbeat_and_events(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view v = shmtest_view_open(f->in_name, 0);
        struct shm_in_header *h = shmtest_in_header(&v);
        uint64_t beat = atomic_load(&h->heartbeat_ns);
        uint32_t before = change_of(&v);

        shm_table_heartbeat(f->t);
        assert_true(atomic_load(&h->heartbeat_ns) >= beat);
        assert_int_equal(shm_table_event(f->t, SHM_EVENT_LINK_STATE, 1, "state=connected"), 1);
        assert_int_equal(shm_table_eventf(f->t, SHM_EVENT_ACTION, 1, "device=%s sensor_time=%u",
                                          "E1E1E1", 5000u), 2);
        assert_int_equal(atomic_load(&h->event_head), 2);
        assert_int_equal(change_of(&v), before + 2);                    /* one per event */
        shm_table_begin(f->t);
        shm_table_event(f->t, SHM_EVENT_LOG, 77, "link=none");          /* bad link: none */
        shm_table_event(f->t, SHM_EVENT_LOG, SHM_LINK_NONE, "x=1");
        shm_table_commit(f->t);
        assert_int_equal(change_of(&v), before + 3);                    /* batched: one */
        assert_int_equal(atomic_load(&h->counters[SHM_COUNTER_EVENTS]), 4);
        shmtest_view_close(&v);
}

/* ---- outbound: well-behaved clients --------------------------------------------------------- */

/* Outbound variables added at run time take the spare .out slots, in order. */
static void test_out_spare(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view v;
        struct shm_var learned = { "Learned0", SHM_DIR_OUT, SHM_TYPE_LONG, 0, "A", 0 };
        struct seen s;
        int id;

        f->cfg.out_spare = ADHOC + 1;
        assert_int_equal(shmtest_table_create(f), -EINVAL);   /* more than adhoc room */
        f->cfg.out_spare = 2;
        assert_int_equal(shmtest_table_create(f), 0);
        v = shmtest_view_open(f->in_name, 0);
        assert_int_equal(shmtest_in_header(&v)->out_capacity, NOUT + 2);

        /* A client scribbling on a spare slot nobody owns: refused, never reported. */
        assert_int_equal(scan(f->t, &s), 0);
        assert_int_equal(out_write(f->out_name, NOUT, "junk"), 0);
        assert_int_equal(scan(f->t, &s), 0);
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_INVALID), 1);

        id = shm_table_add(f->t, &learned);
        assert_int_equal(id, NVARS);
        assert_int_equal(shmtest_in_dir(&v)[id].out_slot, NOUT);
        assert_int_equal(shmtest_in_dir(&v)[id].direction, SHM_DIR_OUT);
        assert_int_equal(shmtest_in_dir(&v)[id].flags, SHM_DIR_ADHOC);
        assert_int_equal(scan(f->t, &s), 0);            /* what was there before is not news */
        assert_int_equal(out_write(f->out_name, NOUT, "42"), 0);
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].id, (uint32_t)id);
        assert_string_equal(s.c[0].value, "42");
        expect_slot(&v, (unsigned)id, "42", SHM_SLOT_VALID | SHM_SLOT_OUTBOUND);

        learned.name = "Learned1";
        assert_int_equal(shm_table_add(f->t, &learned), NVARS + 1);
        learned.name = "Learned2";
        assert_int_equal(shm_table_add(f->t, &learned), -ENOSPC);      /* spare slots used up */
        learned.direction = SHM_DIR_IN;                                 /* inbound room is left */
        assert_int_equal(shm_table_add(f->t, &learned), NVARS + 2);
        shmtest_view_close(&v);
}

static void test_out_scan(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view v = shmtest_view_open(f->in_name, 0);
        struct seen s;

        assert_int_equal(scan(f->t, &s), 0);
        assert_int_equal(out_write(f->out_name, OUT_THROTTLE, "0.25"), 0);
        assert_int_equal(out_write(f->out_name, OUT_NOTE, "hello world"), 0);
        assert_int_equal(scan(f->t, &s), 2);
        assert_int_equal(s.c[0].id, THROTTLE);
        assert_int_equal(s.c[0].status, SHM_OUT_CHANGED);
        assert_string_equal(s.c[0].value, "0.25");
        assert_int_equal(s.c[0].length, 4);
        assert_int_equal(s.c[0].writer_pid, getpid());
        assert_int_equal(s.c[1].id, NOTE);
        assert_string_equal(s.c[1].value, "hello world");
        /* Mirrored into .in for every reader, marked outbound. */
        expect_slot(&v, THROTTLE, "0.25", SHM_SLOT_VALID | SHM_SLOT_OUTBOUND);
        expect_slot(&v, NOTE, "hello world", SHM_SLOT_VALID | SHM_SLOT_OUTBOUND);
        assert_int_equal(scan(f->t, &s), 0);                            /* nothing new */
        assert_int_equal(out_write(f->out_name, OUT_THROTTLE, "0.5"), 0);
        assert_int_equal(out_write(f->out_name, OUT_THROTTLE, "0.75"), 0);
        assert_int_equal(scan(f->t, &s), 1);                            /* latest value wins */
        assert_string_equal(s.c[0].value, "0.75");
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_ACCEPTED), 3);
        shmtest_view_close(&v);
}

static void test_out_validation(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view v = shmtest_view_open(f->in_name, 0);
        char value[SHM_VALUE_SIZE + 8];
        uint64_t invalid = 0;
        struct seen s;

        assert_int_equal(out_write(f->out_name, OUT_NOTE, "good"), 0);
        assert_int_equal(scan(f->t, &s), 1);
        /* Every byte the wire cannot carry, at the start, middle and end of a value. */
        for (int b = 1; b < 256; b++) {
                if (shm_layout_value_char(b))
                        continue;
                for (unsigned at = 0; at < 3; at++) {
                        memcpy(value, "abcde", 6);
                        value[at * 2] = (char)b;
                        assert_int_equal(out_write_raw(f->out_name, OUT_NOTE, value, 5,
                                                       SHM_SLOT_VALID), 0);
                        assert_int_equal(scan(f->t, &s), 1);
                        assert_int_equal(s.c[0].status, SHM_OUT_INVALID);
                        assert_int_equal(s.c[0].id, NOTE);
                        invalid++;
                }
        }
        /* A NUL inside the declared length. */
        assert_int_equal(out_write_raw(f->out_name, OUT_NOTE, "ab\0de", 5, SHM_SLOT_VALID), 0);
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].status, SHM_OUT_INVALID);
        invalid++;
        /* Lengths: 63 is fine, 64 (no room for the NUL) and huge are not. */
        memset(value, 'x', sizeof(value));
        assert_int_equal(out_write_raw(f->out_name, OUT_NOTE, value, SHM_VALUE_MAX, SHM_SLOT_VALID), 0);
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].status, SHM_OUT_CHANGED);
        assert_int_equal(s.c[0].length, SHM_VALUE_MAX);
        assert_int_equal(out_write_raw(f->out_name, OUT_NOTE, value, SHM_VALUE_SIZE, SHM_SLOT_VALID), 0);
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].status, SHM_OUT_INVALID);
        invalid++;
        /* Not flagged valid. */
        assert_int_equal(out_write_raw(f->out_name, OUT_NOTE, "ok", 2, 0), 0);
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].status, SHM_OUT_INVALID);
        invalid++;
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_INVALID), invalid);
        /* The mirror kept the last valid value (63 x) all along. */
        value[SHM_VALUE_MAX] = '\0';
        expect_slot(&v, NOTE, value, SHM_SLOT_VALID | SHM_SLOT_OUTBOUND);
        shmtest_view_close(&v);
}

static void test_out_length_field_hostile(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view out = shmtest_view_open(f->out_name, 1);
        struct shm_slot *slot = shmtest_out_slot(&out, OUT_STEER);
        uint64_t word;
        struct seen s;

        /* A length field far beyond the value: must be refused, never used as an index. */
        assert_int_equal(shm_slot_claim(slot, (uint32_t)getpid(), &word), 0);
        shm_slot_store(slot, "1", 1, SHM_SLOT_VALID, 1, 1);
        atomic_store(&slot->length, 0xfffffff0u);
        assert_int_equal(shm_slot_publish(slot, word), 0);
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].status, SHM_OUT_INVALID);
        shmtest_view_close(&out);
}

/* ---- outbound: dying writers ----------------------------------------------------------------- */

struct half_writer {
        const char *out_name;
        unsigned slot;
        int hold_fd;            /* >= 0: stay alive (holding the slot) until this pipe closes */
        int ready_fd;           /* >= 0: a byte is written here once the slot is held */
        int close_fd;           /* >= 0: the parent's end of the hold pipe, closed in the child */
        int finish;             /* 1: once let go, store the rest and publish; exit 0 when the
                                 * publish says -ECANCELED (the slot was taken over), else 1 */
};

/* The second half of half_writer_main's value, and the rest shm_slot_store does after it. */
#define HALF_WRITER_REST        0x3232323232323232ull
#define HALF_WRITER_LENGTH      16u

/* Claims a slot, writes half a value, and dies (or hangs) without publishing. */
static int half_writer_main(void *arg)
{
        struct half_writer *w = arg;
        struct shmtest_view v = shmtest_view_open(w->out_name, 1);
        uint64_t word;
        char c;

        if (w->close_fd >= 0)
                close(w->close_fd);
        if (!v.base || shm_slot_claim(shmtest_out_slot(&v, w->slot), (uint32_t)getpid(), &word) < 0)
                return 1;
        /* As shm_slot_store: the length before the value words (and the flags after). */
        atomic_store(&shmtest_out_slot(&v, w->slot)->length, HALF_WRITER_LENGTH);
        shm_slot_store_word(shmtest_out_slot(&v, w->slot), 0, 0x3131313131313131ull);
        if (w->ready_fd >= 0 && write(w->ready_fd, "r", 1) != 1)
                return 1;
        if (w->hold_fd >= 0)
                while (read(w->hold_fd, &c, 1) < 0 && errno == EINTR)
                        ;
        if (w->finish) {
                struct shm_slot *slot = shmtest_out_slot(&v, w->slot);

                shm_slot_store_word(slot, 1, HALF_WRITER_REST);
                atomic_store(&slot->flags, SHM_SLOT_VALID | SHM_SLOT_OUTBOUND);
                _exit(shm_slot_publish(slot, word) == -ECANCELED ? 0 : 1);
        }
        _exit(0);
}

/* Starts a half writer that holds .out slot `slot` until *ret_hold (our end of its pipe) is
 * closed (then finishes its write if `finish`); returns once it holds the slot. */
static pid_t half_writer_start(const char *out_name, unsigned slot, int finish, int *ret_hold)
{
        struct half_writer w = { out_name, slot, -1, -1, -1, finish };
        int hold[2], ready[2];
        pid_t pid;
        char c;

        assert_int_equal(pipe(hold), 0);
        assert_int_equal(pipe(ready), 0);
        w.hold_fd = hold[0];
        w.close_fd = hold[1];
        w.ready_fd = ready[1];
        pid = shmtest_fork(half_writer_main, &w);
        close(hold[0]);
        close(ready[1]);
        assert_int_equal(read(ready[0], &c, 1), 1);                     /* it holds the slot */
        close(ready[0]);
        *ret_hold = hold[1];
        return pid;
}

static pid_t half_writer_holding(const char *out_name, unsigned slot, int *ret_hold)
{
        return half_writer_start(out_name, slot, 0, ret_hold);
}

static void test_out_repair_dead_writer(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view out = shmtest_view_open(f->out_name, 0);
        struct half_writer w = { f->out_name, OUT_STEER, -1, -1, -1, 0 };
        struct shm_slot_copy c;
        struct seen s;
        pid_t pid;

        assert_int_equal(out_write(f->out_name, OUT_STEER, "5"), 0);
        assert_int_equal(scan(f->t, &s), 1);
        pid = shmtest_fork(half_writer_main, &w);
        assert_int_equal(shmtest_wait(pid), 0);                         /* gone, reaped */
        assert_true(shm_seqlock_odd(shm_slot_word(shmtest_out_slot(&out, OUT_STEER))));
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].status, SHM_OUT_REPAIRED);
        assert_int_equal(s.c[0].id, STEER);
        assert_int_equal(s.c[0].writer_pid, pid);
        /* Even again, marked not valid; nothing half-written was handed on. */
        assert_int_equal(shm_slot_read(shmtest_out_slot(&out, OUT_STEER), &c), 0);
        assert_int_equal(c.flags, SHM_SLOT_REPAIRED);
        assert_int_equal(c.length, SHM_SLOT_LENGTH_NONE);
        assert_int_equal(scan(f->t, &s), 0);                            /* reported once */
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_REPAIRED), 1);
        /* Not wedged: the next writer gets it. */
        assert_int_equal(out_write(f->out_name, OUT_STEER, "6"), 0);
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].status, SHM_OUT_CHANGED);
        assert_string_equal(s.c[0].value, "6");
        shmtest_view_close(&out);
}

static void test_out_live_writer_skipped(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view out = shmtest_view_open(f->out_name, 0);
        struct shmtest_view mirror = shmtest_view_open(f->in_name, 0);
        struct seen s;
        pid_t pid;
        int hold;

        pid = half_writer_holding(f->out_name, OUT_THROTTLE, &hold);
        /* Its writer is alive: skipped and counted, not touched, and the scan does not wait
         * (within SHM_TABLE_HELD_SCANS: test_out_held_* for what comes after). */
        assert_int_equal(scan(f->t, &s), 0);
        assert_int_equal(out_write(f->out_name, OUT_STEER, "1"), 0);    /* others unaffected */
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].id, STEER);
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_BUSY), 2);
        assert_true(shm_seqlock_odd(shm_slot_word(shmtest_out_slot(&out, OUT_THROTTLE))));
        /* Once it is gone, the slot is repaired at once: no bound to wait out. */
        close(hold);
        assert_int_equal(shmtest_wait(pid), 0);
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].status, SHM_OUT_REPAIRED);
        assert_int_equal(s.c[0].taken_over, 0);
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_TAKEN_OVER), 0);
        expect_slot(&mirror, THROTTLE, "", 0);                          /* never published */
        shmtest_view_close(&mirror);
        shmtest_view_close(&out);
}

static void test_out_forged_pids(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view out = shmtest_view_open(f->out_name, 1);
        const uint64_t pids[] = { 0, (uint64_t)getpid(), 0xffffffffu, 1u << 23 };
        struct seen s;

        /* Odd words naming no process that could hold them: repaired at once. */
        for (size_t i = 0; i < sizeof(pids) / sizeof(pids[0]); i++) {
                atomic_store(&shmtest_out_slot(&out, OUT_NOTE)->seq, (pids[i] << 32) | (2 * i + 101));
                assert_int_equal(scan(f->t, &s), 1);
                assert_int_equal(s.c[0].status, SHM_OUT_REPAIRED);
                assert_false(shm_seqlock_odd(shm_slot_word(shmtest_out_slot(&out, OUT_NOTE))));
        }
        shmtest_view_close(&out);
}

/* ---- outbound: rogue clients ----------------------------------------------------------------- */

struct rogue {
        const char *out_name;
        off_t truncate_to;      /* >= 0: ftruncate to this; < 0: scribble */
        size_t from;            /* scribble from this offset */
        unsigned seed;
};

static int rogue_main(void *arg)
{
        struct rogue *r = arg;
        struct shmtest_view v;
        int fd;

        if (r->truncate_to >= 0) {
                fd = shm_open(r->out_name, O_RDWR, 0);
                return fd < 0 || ftruncate(fd, r->truncate_to) < 0;
        }
        v = shmtest_view_open(r->out_name, 1);
        if (!v.base)
                return 1;
        srand(r->seed);
        for (size_t i = r->from; i < v.size; i++)
                ((unsigned char *)v.base)[i] = (unsigned char)rand();
        return 0;
}

static void run_rogue(struct rogue *r)
{
        assert_int_equal(shmtest_wait(shmtest_fork(rogue_main, r)), 0);
}

/* After a recreate: clients that reopen .out write and are heard again. */
static void expect_recovered(struct shmtest_table *f, uint32_t generation)
{
        struct shmtest_view v = shmtest_view_open(f->in_name, 0);
        struct shmtest_view out = shmtest_view_open(f->out_name, 0);
        struct seen s;

        assert_int_equal(atomic_load(&shmtest_in_header(&v)->out_generation), generation);
        assert_int_equal(shm_layout_check_out(out.base, out.size), 0);
        assert_int_equal(((struct shm_out_header *)out.base)->generation, generation);
        assert_int_equal(out_write(f->out_name, OUT_THROTTLE, "9.5"), 0);
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].status, SHM_OUT_CHANGED);
        assert_string_equal(s.c[0].value, "9.5");
        shmtest_view_close(&out);
        shmtest_view_close(&v);
}

static void test_rogue_scribble_all(void **state)
{
        struct shmtest_table *f = *state;
        struct rogue r = { f->out_name, -1, 0, 1 };
        struct seen s;

        assert_int_equal(out_write(f->out_name, OUT_THROTTLE, "1"), 0);
        assert_int_equal(scan(f->t, &s), 1);
        for (unsigned round = 0; round < 20; round++) {
                r.seed = round + 1;
                run_rogue(&r);
                /* Header destroyed: reported, recreated, scan void. */
                assert_int_equal(scan(f->t, &s), -EBADMSG);
                assert_int_equal(s.n, 0);
                expect_recovered(f, 2 + round);
        }
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_BAD_OBJECT), 20);
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_RECREATED), 20);
}

static void test_rogue_scribble_slots(void **state)
{
        struct shmtest_table *f = *state;
        struct rogue r = { f->out_name, -1, sizeof(struct shm_out_header), 1 };
        struct shmtest_view out = shmtest_view_open(f->out_name, 0);
        struct seen s;
        int n;

        for (unsigned round = 0; round < 50; round++) {
                r.seed = 1000 + round;
                run_rogue(&r);
                /* Header intact, slots garbage: every slot is judged on its own. */
                n = scan(f->t, &s);
                assert_true(n >= 0 && n <= (int)NOUT);
                for (int i = 0; i < n && i < 16; i++)
                        assert_true(s.c[i].status == SHM_OUT_INVALID ||
                                    s.c[i].status == SHM_OUT_REPAIRED ||
                                    (s.c[i].status == SHM_OUT_CHANGED &&
                                     shm_layout_value_check(s.c[i].value, s.c[i].length) == 0));
        }
        /* Garbage words naming live processes may stay held (skipped); the rest recover. */
        for (unsigned i = 0; i < NOUT; i++) {
                uint64_t word = shm_slot_word(shmtest_out_slot(&out, i));

                if (shm_seqlock_odd(word))
                        assert_int_equal(kill((pid_t)shm_seqlock_pid(word), 0), 0);
        }
        shmtest_view_close(&out);
}

static void test_rogue_truncate(void **state)
{
        struct shmtest_table *f = *state;
        const off_t sizes[] = { 0, 64, (off_t)sizeof(struct shm_out_header) + 100,
                                (off_t)shm_layout_out_size(NOUT) - 1 };
        struct rogue r = { f->out_name, 0, 0, 0 };
        struct seen s;

        for (size_t i = 0; i < sizeof(sizes) / sizeof(sizes[0]); i++) {
                r.truncate_to = sizes[i];
                run_rogue(&r);
                assert_int_equal(scan(f->t, &s), -EBADMSG);
                expect_recovered(f, 2 + (uint32_t)i);
        }
        /* Grown instead of shrunk: also not what we made. */
        r.truncate_to = (off_t)shm_layout_out_size(NOUT) * 4;
        run_rogue(&r);
        assert_int_equal(scan(f->t, &s), -EBADMSG);
        expect_recovered(f, 6);
}

/* ---- outbound: the touched map (layout 1.6) --------------------------------------------------- */

static int scan_touched(struct shm_table *t, struct seen *s)
{
        memset(s, 0, sizeof(*s));
        return shm_table_out_scan_touched(t, on_change, s);
}

static int out_write_how(const char *out_name, unsigned slot, const char *value,
                         enum touch_how how)
{
        return out_write_as(out_name, slot, value, (uint32_t)strlen(value),
                            SHM_SLOT_VALID | SHM_SLOT_OUTBOUND, how);
}

/* A marked slot is looked at alone; a write whose mark was lost waits for the full scan, which
 * finds it; a client before 1.6 (no marks) makes the scan look at every slot. */
static void test_out_touched(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view out = shmtest_view_open(f->out_name, 0);
        const struct shm_out_header *h = out.base;
        struct seen s;

        assert_true((h->layout_version & 0xffffu) >= SHM_LAYOUT_MINOR_TOUCHED);
        assert_int_equal(h->touched_words, 1);
        assert_true(shm_layout_has_touched(h, out.size));
        assert_int_equal(scan_touched(f->t, &s), 0);
        assert_int_equal(out_write_how(f->out_name, OUT_NOTE, "marked", TOUCH_MARKED), 0);
        assert_int_equal(scan_touched(f->t, &s), 1);
        assert_int_equal(s.c[0].id, NOTE);
        assert_string_equal(s.c[0].value, "marked");
        assert_int_equal(atomic_load(&touched_map(&out)[0]), 0);        /* taken */
        assert_int_equal(scan_touched(f->t, &s), 0);                    /* reported once */

        /* Its writer died before it marked: not looked at on a wake-up... */
        assert_int_equal(out_write_how(f->out_name, OUT_STEER, "lost", TOUCH_LOST), 0);
        assert_int_equal(out_write_how(f->out_name, OUT_NOTE, "other", TOUCH_MARKED), 0);
        assert_int_equal(scan_touched(f->t, &s), 1);
        assert_int_equal(s.c[0].id, NOTE);
        /* ... but by the full scan (the daemon's heartbeat), once. */
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].id, STEER);
        assert_string_equal(s.c[0].value, "lost");
        assert_int_equal(scan(f->t, &s), 0);

        /* An older client marks nothing but moves the change word's low half: every slot. */
        assert_int_equal(out_write_how(f->out_name, OUT_THROTTLE, "old", TOUCH_OLD), 0);
        assert_int_equal(scan_touched(f->t, &s), 1);
        assert_int_equal(s.c[0].id, THROTTLE);
        assert_string_equal(s.c[0].value, "old");
        assert_int_equal(scan_touched(f->t, &s), 0);
        shmtest_view_close(&out);
}

/* The map is client data: bits set everywhere (past the capacity too, and in the padding after
 * the map) make the daemon look, never misread; bits wiped lose nothing for good. */
static void test_out_touched_scribbled(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view out = shmtest_view_open(f->out_name, 1);
        struct shm_out_header *h = out.base;
        size_t map_bytes = out.size - h->touched_offset;
        struct seen s;

        assert_int_equal(out_write_how(f->out_name, OUT_NOTE, "before", TOUCH_MARKED), 0);
        assert_int_equal(scan_touched(f->t, &s), 1);
        memset((char *)out.base + h->touched_offset, 0xff, map_bytes);
        assert_int_equal(scan_touched(f->t, &s), 0);                    /* nothing changed */
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_INVALID), 0);
        assert_int_equal(out_write_how(f->out_name, OUT_STEER, "7", TOUCH_MARKED), 0);
        memset((char *)out.base + h->touched_offset, 0xff, map_bytes);
        assert_int_equal(scan_touched(f->t, &s), 1);
        assert_string_equal(s.c[0].value, "7");

        /* Wiped after a write: the wake-up misses it, the full scan does not. */
        assert_int_equal(out_write_how(f->out_name, OUT_THROTTLE, "wiped", TOUCH_MARKED), 0);
        memset((char *)out.base + h->touched_offset, 0, map_bytes);
        assert_int_equal(scan_touched(f->t, &s), 0);
        assert_int_equal(scan(f->t, &s), 1);
        assert_string_equal(s.c[0].value, "wiped");

        /* The map's place in the header scribbled: the object is not what we made. */
        h->touched_offset += SHM_CACHE_LINE;
        assert_int_equal(scan_touched(f->t, &s), -EBADMSG);
        expect_recovered(f, 2);
        shmtest_view_close(&out);
}

/* Scans that must find the slot still held (skipped, counted busy, nothing reported). */
static void scans_held(struct shmtest_table *f, struct shmtest_view *out, unsigned slot,
                       unsigned n)
{
        uint64_t busy = shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_BUSY);
        struct seen s;

        for (unsigned k = 0; k < n; k++)
                assert_int_equal(scan(f->t, &s), 0);
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_BUSY),
                         busy + n);
        assert_true(shm_seqlock_odd(shm_slot_word(shmtest_out_slot(out, slot))));
}

/* The scan that takes a held slot over: one report, both counters, an even slot. */
static void scan_takes_over(struct shmtest_table *f, struct shmtest_view *out, unsigned slot,
                            uint32_t id, uint32_t pid, uint64_t taken_before)
{
        struct seen s;

        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].status, SHM_OUT_REPAIRED);
        assert_int_equal(s.c[0].taken_over, 1);
        assert_int_equal(s.c[0].id, id);
        assert_int_equal(s.c[0].writer_pid, pid);
        assert_string_equal(s.c[0].name, vars[id].name);
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_TAKEN_OVER),
                         taken_before + 1);
        assert_false(shm_seqlock_odd(shm_slot_word(shmtest_out_slot(out, slot))));
        assert_int_equal(scan(f->t, &s), 0);                            /* reported once */
}

/* A write of slot that the next scan accepts and reports. */
static void write_goes_through(struct shmtest_table *f, unsigned slot, const char *value)
{
        struct seen s;

        assert_int_equal(out_write(f->out_name, slot, value), 0);
        assert_int_equal(scan(f->t, &s), 1);
        assert_int_equal(s.c[0].status, SHM_OUT_CHANGED);
        assert_string_equal(s.c[0].value, value);
}

/*
 * An odd word naming a process that exists (pid 1: kill() finds it, ESRCH never comes) is no
 * writer's: a hostile client's. It used to wedge the variable for good; the daemon takes it over
 * once it stayed the same for SHM_TABLE_HELD_SCANS periodic scans, and only those count: wake-ups
 * (other writes) do not hurry it.
 */
static void test_out_held_forged_live_pid(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view out = shmtest_view_open(f->out_name, 1);
        struct shmtest_view mirror = shmtest_view_open(f->in_name, 0);
        struct seen s;

        assert_int_equal(out_write(f->out_name, OUT_NOTE, "kept"), 0);
        assert_int_equal(scan(f->t, &s), 1);
        atomic_store(&shmtest_out_slot(&out, OUT_NOTE)->seq, (UINT64_C(1) << 32) | 7u);
        assert_int_equal(out_write(f->out_name, OUT_NOTE, "lost"), -EBUSY);        /* wedged */
        scans_held(f, &out, OUT_NOTE, SHM_TABLE_HELD_SCANS - 1u);
        for (unsigned k = 0; k < 2u * SHM_TABLE_HELD_SCANS; k++) {
                assert_int_equal(out_write_how(f->out_name, OUT_STEER, "1", TOUCH_MARKED), 0);
                assert_int_equal(scan_touched(f->t, &s), 1);            /* STEER's alone */
                assert_int_equal(s.c[0].id, STEER);
        }
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_TAKEN_OVER), 0);
        scan_takes_over(f, &out, OUT_NOTE, NOTE, 1, 0);
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_REPAIRED), 1);
        expect_slot(&mirror, NOTE, "kept", SHM_SLOT_VALID | SHM_SLOT_OUTBOUND);
        write_goes_through(f, OUT_NOTE, "again");       /* not wedged any more */
        shmtest_view_close(&mirror);
        shmtest_view_close(&out);
}

/* A held word that changes at every scan is writers taking turns (or a hostile client that keeps
 * rewriting it): never taken over, however long it goes on; once it stops changing, the count
 * starts from zero. */
static void test_out_held_changing_not_early(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view out = shmtest_view_open(f->out_name, 1);
        _Atomic uint64_t *seq = &shmtest_out_slot(&out, OUT_NOTE)->seq;
        uint64_t word = (UINT64_C(1) << 32) | 1u;

        for (unsigned k = 0; k < 4u * SHM_TABLE_HELD_SCANS; k++) {
                word += 2u;
                atomic_store(seq, word);
                scans_held(f, &out, OUT_NOTE, 1);
        }
        /* The same word but another pid is another hold too. */
        for (unsigned k = 0; k < 2u * SHM_TABLE_HELD_SCANS; k++) {
                atomic_store(seq, ((uint64_t)(k % 2u ? 1u : (uint32_t)getppid()) << 32) |
                                  (word & SHM_SEQLOCK_SEQ_MASK));
                scans_held(f, &out, OUT_NOTE, 1);
        }
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_TAKEN_OVER), 0);
        /* It stops changing: taken over after the whole bound, counted from then. */
        atomic_store(seq, ((uint64_t)getppid() << 32) | ((word + 2u) & SHM_SEQLOCK_SEQ_MASK));
        scans_held(f, &out, OUT_NOTE, SHM_TABLE_HELD_SCANS - 1u);
        scan_takes_over(f, &out, OUT_NOTE, NOTE, (uint32_t)getppid(), 0);
        shmtest_view_close(&out);
}

/*
 * A real writer, alive, stopped in the middle of its write (here: blocked on a pipe): taken over
 * after the bound. When it runs again its remaining stores land in the repaired slot and its
 * publish fails with -ECANCELED; nothing of its value is reported, mirrored or left readable as
 * a valid value, and the next writer is unaffected.
 */
static void test_out_held_live_writer_taken_over(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view out = shmtest_view_open(f->out_name, 0);
        struct shmtest_view mirror = shmtest_view_open(f->in_name, 0);
        struct shm_slot_copy c;
        struct seen s;
        pid_t pid;
        int hold;

        assert_int_equal(out_write(f->out_name, OUT_THROTTLE, "0.5"), 0);
        assert_int_equal(scan(f->t, &s), 1);
        pid = half_writer_start(f->out_name, OUT_THROTTLE, 1, &hold);
        scans_held(f, &out, OUT_THROTTLE, SHM_TABLE_HELD_SCANS - 1u);
        scan_takes_over(f, &out, OUT_THROTTLE, THROTTLE, (uint32_t)pid, 0);
        /* The writer runs again: the rest of its stores, then a publish that fails. */
        close(hold);
        assert_int_equal(shmtest_wait(pid), 0);                         /* -ECANCELED */
        assert_int_equal(scan(f->t, &s), 0);
        expect_slot(&mirror, THROTTLE, "0.5", SHM_SLOT_VALID | SHM_SLOT_OUTBOUND);
        assert_int_equal(shm_slot_read(shmtest_out_slot(&out, OUT_THROTTLE), &c), 0);
        assert_int_equal(shm_slot_copy_check(&c), -EINVAL);             /* half: not a value */
        write_goes_through(f, OUT_THROTTLE, "0.75");
        shmtest_view_close(&mirror);
        shmtest_view_close(&out);
}

/* A slot held by a live writer stays on the daemon's list: once the writer is gone, the next
 * wake-up (someone else's write) repairs it, with no mark of its own. */
static void test_out_touched_held(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view out = shmtest_view_open(f->out_name, 1);
        struct seen s;
        pid_t pid;
        int hold;

        pid = half_writer_holding(f->out_name, OUT_THROTTLE, &hold);
        /* What the library does when a slot stays held: mark it, ring the daemon. */
        atomic_fetch_or(&touched_map(&out)[0], UINT64_C(1) << OUT_THROTTLE);
        assert_int_equal(scan_touched(f->t, &s), 0);                    /* busy: skipped */
        assert_int_equal(shm_table_counter_get(f->t, SHM_LINK_NONE, SHM_COUNTER_OUT_BUSY), 1);
        close(hold);
        assert_int_equal(shmtest_wait(pid), 0);                         /* dead, still odd */
        assert_int_equal(out_write_how(f->out_name, OUT_STEER, "2", TOUCH_MARKED), 0);
        assert_int_equal(scan_touched(f->t, &s), 2);
        assert_int_equal(s.c[0].id, THROTTLE);
        assert_int_equal(s.c[0].status, SHM_OUT_REPAIRED);
        assert_int_equal(s.c[1].id, STEER);
        assert_int_equal(scan_touched(f->t, &s), 0);
        shmtest_view_close(&out);
}

/* ---- wake fd ----------------------------------------------------------------------------------- */

struct writer_child {
        const char *out_name;
        unsigned slot;
        const char *value;
};

static int writer_child_main(void *arg)
{
        struct writer_child *w = arg;

        return out_write(w->out_name, w->slot, w->value) == 0 ? 0 : 1;
}

static int readable(int fd)
{
        struct pollfd p = { .fd = fd, .events = POLLIN };

        return poll(&p, 1, POLL_LIMIT_MS) == 1 && (p.revents & POLLIN);
}

static void test_wake_fd(void **state)
{
        struct shmtest_table *f = *state;
        struct writer_child w = { f->out_name, OUT_NOTE, "ping" };
        struct rogue r = { f->out_name, 0, 0, 0 };
        struct seen s;
        int fd = shm_table_out_wake_fd(f->t);

        assert_true(fd >= 0);
        assert_int_equal(shm_table_out_wake_fd(f->t), fd);              /* one thread */
        assert_int_equal(shm_table_out_wake_ack(f->t), 0);
        assert_int_equal(shmtest_wait(shmtest_fork(writer_child_main, &w)), 0);
        assert_true(readable(fd));
        assert_int_equal(shm_table_out_wake_ack(f->t), 1);
        assert_int_equal(scan(f->t, &s), 1);
        assert_string_equal(s.c[0].value, "ping");

        /* Truncated under the wake thread: it survives, and watches the recreated object. */
        run_rogue(&r);
        assert_int_equal(scan(f->t, &s), -EBADMSG);
        shm_table_out_wake_ack(f->t);
        w.value = "pong";
        assert_int_equal(shmtest_wait(shmtest_fork(writer_child_main, &w)), 0);
        assert_true(readable(fd));
        assert_int_equal(shm_table_out_wake_ack(f->t), 1);
        assert_int_equal(scan(f->t, &s), 1);
        assert_string_equal(s.c[0].value, "pong");
}

static void test_destroy_wakes_clients(void **state)
{
        struct shmtest_table *f = *state;
        struct shmtest_view v = shmtest_view_open(f->in_name, 0);
        struct change_waiter w = { &shmtest_in_header(&v)->change, change_of(&v) };
        pid_t pid = shmtest_fork(change_waiter_main, &w);

        f->t = shm_table_destroy(f->t);
        assert_int_equal(shmtest_wait(pid), 0);
        assert_int_equal(atomic_load(&shmtest_in_header(&v)->state), SHM_STATE_CLOSED);
        shmtest_view_close(&v);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_create_layout, setup, teardown),
                cmocka_unit_test_setup_teardown(test_create_group, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_create_errors, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_create_socket_path, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_refuse_live_self, setup, teardown),
                cmocka_unit_test_setup_teardown(test_replace_stale_refuse_live, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_replace_garbage, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_refuse_being_created, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_batch_change_word, setup, teardown),
                cmocka_unit_test_setup_teardown(test_commit_wakes_other_process, setup, teardown),
                cmocka_unit_test_setup_teardown(test_stale, setup, teardown),
                cmocka_unit_test_setup_teardown(test_get, setup, teardown),
                cmocka_unit_test_setup_teardown(test_adhoc, setup, teardown),
                cmocka_unit_test_setup_teardown(test_links_counters, setup, teardown),
                cmocka_unit_test_setup_teardown(test_heartbeat_and_events, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_spare, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_out_scan, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_validation, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_length_field_hostile, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_repair_dead_writer, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_live_writer_skipped, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_forged_pids, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_held_forged_live_pid, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_held_changing_not_early, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_out_held_live_writer_taken_over, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_rogue_scribble_all, setup, teardown),
                cmocka_unit_test_setup_teardown(test_rogue_scribble_slots, setup, teardown),
                cmocka_unit_test_setup_teardown(test_rogue_truncate, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_touched, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_touched_scribbled, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_touched_held, setup, teardown),
                cmocka_unit_test_setup_teardown(test_wake_fd, setup, teardown),
                cmocka_unit_test_setup_teardown(test_destroy_wakes_clients, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
