/*
 * Unit tests of the change record (layout 1.7, src/shm/changes.h) and of sl_changed against real
 * tables made by the daemon-side module in this process: the ring's positions, wrap, overrun,
 * entries noted ahead of the head, scribbled entries and headers, a record missing (an older
 * daemon), and the library's answers: ids of values, flags and names, new cursors, restarts,
 * retired and reused names, falling behind, more than fits.
 */
#include <errno.h>
#include <pthread.h>
#include <sched.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include <sharedlink.h>

#include "common/shmtest.h"
#include "shm/changes.h"
#include "shm/layout.h"
#include "shm/table.h"

#define RING            16u     /* entries of the hand-made rings */
#define LIMIT           1000u   /* indexes below this are valid in the hand-made rings */
#define ADHOC           4u
#define IDS_MAX         256
#define RACE_ENTRIES    200000u /* the writer thread's work: bounded, not timed */

/* ---- the ring, by hand --------------------------------------------------------------------- */

struct ring {
        void *mem;
        struct shm_changes r;
        uint64_t next;                  /* the producer's */
};

static void ring_make(struct ring *g, uint32_t capacity)
{
        g->mem = aligned_alloc(SHM_CACHE_LINE, SHM_CHANGES_HEAD + capacity * sizeof(uint64_t));
        assert_non_null(g->mem);
        memset(g->mem, 0, SHM_CHANGES_HEAD + capacity * sizeof(uint64_t));
        g->r.head = g->mem;
        g->r.entries = (_Atomic uint64_t *)(void *)((char *)g->mem + SHM_CHANGES_HEAD);
        g->r.capacity = capacity;
        g->next = 0;
}

static void ring_free(struct ring *g)
{
        free(g->mem);
}

/* Notes indexes first, first + 1, ... (n of them) and publishes them. */
static void ring_put(struct ring *g, uint32_t first, unsigned n)
{
        for (unsigned i = 0; i < n; i++)
                shm_changes_note(&g->r, &g->next, (first + i) % LIMIT);
        shm_changes_publish(&g->r, g->next);
}

static void test_ring_read(void **state)
{
        struct ring g;
        uint32_t got[RING];
        uint64_t pos = 0;

        (void)state;
        ring_make(&g, RING);
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), 0);
        ring_put(&g, 7, 3);
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), 3);
        assert_int_equal(got[0], 7);
        assert_int_equal(got[2], 9);
        assert_int_equal(pos, 3);
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), 0);
        /* max: the rest comes at the next call, in order */
        ring_put(&g, 20, 5);
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, 2), 2);
        assert_int_equal(got[1], 21);
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), 3);
        assert_int_equal(got[0], 22);
        assert_int_equal(pos, 8);
        /* a position past the head is another record's */
        pos = 9;
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), -ESTALE);
        assert_int_equal(pos, 9);
        ring_free(&g);
}

/* Laps of the ring, read a little behind: every entry, in order, none lost. */
static void test_ring_wrap(void **state)
{
        struct ring g;
        uint32_t got[RING], expect = 0;
        uint64_t pos = 0;

        (void)state;
        ring_make(&g, RING);
        for (unsigned round = 0; round < 10; round++) {
                int n;

                ring_put(&g, (uint32_t)(round * (RING - 3u)), RING - 3u);
                n = shm_changes_read(&g.r, &pos, LIMIT, got, RING);
                assert_int_equal(n, RING - 3u);
                for (int i = 0; i < n; i++)
                        assert_int_equal(got[i], expect++ % LIMIT);
        }
        assert_int_equal(pos, 10u * (RING - 3u));
        /* exactly one capacity behind is not an overrun yet */
        ring_put(&g, 0, RING);
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), RING);
        ring_free(&g);
}

static void test_ring_overrun(void **state)
{
        struct ring g;
        uint32_t got[RING];
        uint64_t pos = 0;

        (void)state;
        ring_make(&g, RING);
        ring_put(&g, 0, RING + 1u);
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), -EOVERFLOW);
        assert_int_equal(pos, RING + 1u);               /* from the head on */
        ring_put(&g, 500, 2);
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), 2);
        assert_int_equal(got[0], 500);
        ring_free(&g);
}

/*
 * The producer notes entries before it publishes the head (one head store per batch): within a
 * capacity of the head by the head's count, the reader's entries may be overwritten already by a
 * batch under way. The positions they hold say so.
 */
static void test_ring_noted_ahead(void **state)
{
        struct ring g;
        uint32_t got[RING];
        uint64_t pos = 0;

        (void)state;
        ring_make(&g, RING);
        ring_put(&g, 100, 4);                           /* positions 0..3, published */
        for (unsigned i = 0; i < RING; i++)             /* 4..19 noted: 0..3 overwritten */
                shm_changes_note(&g.r, &g.next, 200);
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), -EOVERFLOW);
        assert_int_equal(pos, 4);                       /* the head as published */
        shm_changes_publish(&g.r, g.next);
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), RING);
        assert_int_equal(got[RING - 1u], 200);
        ring_free(&g);
}

/* .in is the daemon's, but it may be of another version or damaged: an entry that is not the
 * one asked for, or that names no slot, is an overrun, never an index handed out. */
static void test_ring_scribbled(void **state)
{
        struct ring g;
        uint32_t got[RING];
        uint64_t pos = 0;

        (void)state;
        ring_make(&g, RING);
        ring_put(&g, 1, 3);
        atomic_store(&g.r.entries[1], (UINT64_C(1) << 32) | LIMIT);     /* index off the table */
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), -EOVERFLOW);
        ring_put(&g, 1, 3);
        atomic_store(&g.r.entries[4], 0);                               /* position 0, not 4 */
        assert_int_equal(shm_changes_read(&g.r, &pos, LIMIT, got, RING), -EOVERFLOW);
        assert_int_equal(pos, 6);
        ring_free(&g);
}

/*
 * A reader racing the producer: what it gets is exactly the producer's sequence, with gaps only
 * where it was told it fell behind. The first half of the work goes in step with the reader (the
 * producer waits until the reader is at most half a ring behind), so reads that find entries are
 * certain; the second half runs free, so overruns are likely.
 */
#define RACE_RING       64u

struct race {
        struct ring *g;
        _Atomic uint64_t reader;        /* the reader's position */
        _Atomic int done;
};

static void *race_writer(void *arg)
{
        struct race *rc = arg;

        for (uint32_t i = 0; i < RACE_ENTRIES; i++) {
                shm_changes_note(&rc->g->r, &rc->g->next, i % LIMIT);
                if (i % 3u != 2u)
                        continue;
                shm_changes_publish(&rc->g->r, rc->g->next);
                while (i < RACE_ENTRIES / 2u &&
                       rc->g->next - atomic_load(&rc->reader) > RACE_RING / 2u)
                        sched_yield();
        }
        shm_changes_publish(&rc->g->r, rc->g->next);
        atomic_store(&rc->done, 1);
        return NULL;
}

static void test_ring_race(void **state)
{
        struct ring g;
        struct race rc = { &g, 0, 0 };
        uint32_t got[RACE_RING];
        uint64_t pos = 0, taken = 0;
        pthread_t th;
        int done;

        (void)state;
        ring_make(&g, RACE_RING);
        assert_int_equal(pthread_create(&th, NULL, race_writer, &rc), 0);
        do {
                uint64_t at = pos;
                int n;

                done = atomic_load(&rc.done);
                n = shm_changes_read(&g.r, &pos, LIMIT, got, RACE_RING);
                atomic_store(&rc.reader, pos);
                if (n == -EOVERFLOW)
                        continue;
                assert_true(n >= 0);
                for (int i = 0; i < n; i++)
                        assert_int_equal(got[i], (at + (uint64_t)i) % LIMIT);
                taken += (uint64_t)n;
        } while (!done || pos < shm_changes_head(&g.r));
        pthread_join(th, NULL);
        assert_int_equal(pos, RACE_ENTRIES);
        assert_true(taken >= RACE_ENTRIES / 2u - RACE_RING);
        ring_free(&g);
}

/* ---- geometry and header ------------------------------------------------------------------- */

static void test_geometry(void **state)
{
        static const uint32_t caps[] = { 0, 1, 64, 65, 1000, 3048, SHM_CAPACITY_MAX };
        struct shm_in_geometry g;

        (void)state;
        for (size_t i = 0; i < sizeof(caps) / sizeof(caps[0]); i++) {
                uint32_t n = shm_layout_changes_capacity(caps[i]);

                assert_true(n >= caps[i] && n >= SHM_CHANGES_MIN && n <= SHM_CAPACITY_MAX);
                assert_int_equal(n & (n - 1u), 0);
                assert_true(n / 2u < caps[i] || n == SHM_CHANGES_MIN);
                shm_layout_in_geometry(caps[i], SHM_EVENTS_DEFAULT, &g);
                /* What a 1.6 client computes and checks is where it was. */
                assert_int_equal(g.total_size, g.slots_offset + caps[i] * sizeof(struct shm_slot));
                assert_true(g.link_texts_offset >= g.total_size);
                assert_int_equal(g.link_texts_end, g.link_texts_offset +
                                 SHM_LINKS_MAX * sizeof(struct shm_link_text));
                assert_true(g.changes_offset >= g.link_texts_end);
                assert_int_equal(g.changes_offset % SHM_CACHE_LINE, 0);
                assert_int_equal(g.changes_capacity, n);
                assert_int_equal(g.object_size, g.changes_offset + SHM_CHANGES_HEAD + n * 8u);
        }
}

static void test_header(void **state)
{
        struct shm_in_header *h = calloc(1, sizeof(*h));
        struct shm_in_geometry g;
        struct shm_changes rec;

        (void)state;
        shm_layout_in_geometry(10, SHM_EVENTS_MIN, &g);
        h->layout_version = SHM_LAYOUT_VERSION;
        h->capacity = 10;
        h->event_capacity = SHM_EVENTS_MIN;
        h->link_texts_offset = g.link_texts_offset;
        h->link_text_size = sizeof(struct shm_link_text);
        h->changes_offset = g.changes_offset;
        h->changes_capacity = g.changes_capacity;
        assert_int_equal(shm_layout_has_changes(h, g.object_size), 1);
        assert_int_equal(shm_changes_map(h, g.object_size, h, &rec), 0);
        assert_ptr_equal((char *)rec.head, (char *)h + g.changes_offset);
        assert_int_equal(rec.capacity, g.changes_capacity);
        /* truncated */
        assert_int_equal(shm_layout_has_changes(h, g.object_size - 8), 0);
        assert_int_equal(shm_changes_map(h, g.object_size - 8, h, &rec), -ENOENT);
        /* moved, or of another size: scribbled */
        h->changes_offset += SHM_CACHE_LINE;
        assert_int_equal(shm_layout_has_changes(h, g.object_size + SHM_CACHE_LINE), 0);
        h->changes_offset = g.changes_offset;
        h->changes_capacity = g.changes_capacity / 2u;
        assert_int_equal(shm_layout_has_changes(h, g.object_size), 0);
        h->changes_capacity = g.changes_capacity;
        /* a 1.6 daemon: none, and the link texts end where its object ends */
        h->layout_version = (SHM_LAYOUT_MAJOR << 16) | SHM_LAYOUT_MINOR_TOUCHED;
        assert_int_equal(shm_layout_has_changes(h, g.object_size), 0);
        assert_int_equal(shm_layout_has_link_texts(h, g.link_texts_end), 1);
        free(h);
}

/* ---- sl_changed against a table -------------------------------------------------------------- */

enum { A, B, C, OUT, NVARS };

static const struct shm_var vars[NVARS] = {
        { "a", SHM_DIR_IN, SHM_TYPE_LONG, 0, "A", 0 },
        { "b", SHM_DIR_IN, SHM_TYPE_LONG, 0, "A", 1 },
        { "c", SHM_DIR_IN, SHM_TYPE_LONG, 1, NULL, SHM_POSITION_NONE },
        { "out", SHM_DIR_OUT, SHM_TYPE_LONG, 0, "A", 0 },
};

struct fixture {
        struct shmtest_table tb;
        struct sl_client *c;
        uint64_t cursor;
        int ids[IDS_MAX];
        uint32_t flags;
};

static int setup(void **state)
{
        struct fixture *f = calloc(1, sizeof(*f));

        *state = f;
        shmtest_table_init(&f->tb, "chg");
        shmtest_table_config(&f->tb, vars, NVARS, ADHOC);
        if (shmtest_table_create(&f->tb) < 0 || sl_open(f->tb.instance, &f->c) < 0)
                return -1;
        return 0;
}

static int teardown(void **state)
{
        struct fixture *f = *state;

        sl_close(f->c);
        shmtest_table_destroy(&f->tb);
        free(f);
        return 0;
}

/* One call into f->ids; returns the count. */
static int changed(struct fixture *f, size_t max)
{
        return sl_changed(f->c, &f->cursor, f->ids, max, &f->flags);
}

/* A first call: everything (and a cursor from then on). */
static void start(struct fixture *f)
{
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_START);
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, 0);
}

static void test_values_and_flags(void **state)
{
        struct fixture *f = *state;
        int b = sl_find(f->c, "b"), c = sl_find(f->c, "c");

        assert_int_equal(sl_changed(f->c, NULL, f->ids, 1, &f->flags), -EINVAL);
        assert_int_equal(sl_changed(f->c, &f->cursor, NULL, 1, &f->flags), -EINVAL);
        assert_int_equal(sl_changed(f->c, &f->cursor, f->ids, 1, NULL), -EINVAL);
        start(f);
        shm_table_begin(f->tb.t);
        shm_table_set_str(f->tb.t, B, "1");
        shm_table_set_str(f->tb.t, C, "2");
        shm_table_commit(f->tb.t);
        assert_int_equal(changed(f, IDS_MAX), 2);
        assert_int_equal(f->flags, 0);
        assert_int_equal(f->ids[0], b);
        assert_int_equal(f->ids[1], c);
        assert_int_equal(changed(f, IDS_MAX), 0);
        /* a flag alone is a change; setting what is set already is none */
        assert_int_equal(shm_table_set_link_stale(f->tb.t, 1, 1), 1);
        assert_int_equal(shm_table_set_link_stale(f->tb.t, 1, 1), 0);
        assert_int_equal(changed(f, IDS_MAX), 1);
        assert_int_equal(f->ids[0], c);
        /* the daemon's mirror of an accepted client write */
        assert_int_equal(sl_write(f->c, sl_find(f->c, "out"), "5"), 0);
        assert_int_equal(shm_table_out_scan(f->tb.t, NULL, NULL), 1);
        assert_int_equal(changed(f, IDS_MAX), 1);
        assert_int_equal(f->ids[0], sl_find(f->c, "out"));
}

/* Twice the same variable: twice its id (duplicates are kept, in change order). */
static void test_duplicates_and_more(void **state)
{
        struct fixture *f = *state;
        int a = sl_find(f->c, "a"), b = sl_find(f->c, "b");

        start(f);
        shm_table_set_str(f->tb.t, A, "1");
        shm_table_set_str(f->tb.t, B, "1");
        shm_table_set_str(f->tb.t, A, "2");
        assert_int_equal(changed(f, 2), 2);
        assert_int_equal(f->flags, SL_CHANGED_MORE);
        assert_int_equal(f->ids[0], a);
        assert_int_equal(f->ids[1], b);
        assert_int_equal(changed(f, 0), 0);
        assert_int_equal(f->flags, SL_CHANGED_MORE);
        assert_int_equal(changed(f, 2), 1);
        assert_int_equal(f->flags, 0);
        assert_int_equal(f->ids[0], a);
}

/* More changes since the cursor than the record holds: everything, then on as usual. */
static void test_overrun(void **state)
{
        struct fixture *f = *state;
        uint32_t cap = shm_layout_changes_capacity(NVARS + ADHOC);
        char v[16];

        start(f);
        for (uint32_t i = 0; i <= cap; i++) {
                snprintf(v, sizeof(v), "%u", i);
                shm_table_set_str(f->tb.t, A, v);
        }
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_OVERRUN);
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, 0);
        shm_table_set_str(f->tb.t, B, "x");
        assert_int_equal(changed(f, IDS_MAX), 1);
        assert_int_equal(f->ids[0], sl_find(f->c, "b"));
}

/* A name made at run time comes with its new id; one retired or its entry reused remaps ids:
 * everything once. */
static void test_names(void **state)
{
        struct fixture *f = *state;
        struct shm_var learned = { "learned", SHM_DIR_IN, SHM_TYPE_LONG, 0, "A",
                                   SHM_POSITION_NONE };
        struct shm_var other = { "other", SHM_DIR_IN, SHM_TYPE_LONG, 0, "A", SHM_POSITION_NONE };
        int index, id;

        start(f);
        index = shm_table_add(f->tb.t, &learned);
        assert_true(index >= 0);
        assert_int_equal(changed(f, IDS_MAX), 1);
        assert_int_equal(f->flags, 0);
        id = sl_find(f->c, "learned");
        assert_true(id >= 0);
        assert_int_equal(f->ids[0], id);
        shm_table_set_str(f->tb.t, (uint32_t)index, "3");
        assert_int_equal(changed(f, IDS_MAX), 1);
        assert_int_equal(f->ids[0], id);

        assert_int_equal(shm_table_retire(f->tb.t, (uint32_t)index), 0);
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_REMAPPED);
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, 0);
        assert_int_equal(shm_table_add(f->tb.t, &other), index);      /* the entry reused */
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_REMAPPED);
        assert_int_equal(sl_find(f->c, "learned"), -ENOENT);
}

/* A view refreshed by another call (here a read after a rewrite) between two calls is a
 * remap too: the cursor's ids may be the old view's. */
static void test_remap_by_other_call(void **state)
{
        struct fixture *f = *state;
        struct shm_var learned = { "learned", SHM_DIR_IN, SHM_TYPE_LONG, 0, "A",
                                   SHM_POSITION_NONE };
        char buf[SL_VALUE_SIZE];
        int index;

        index = shm_table_add(f->tb.t, &learned);
        start(f);
        assert_int_equal(shm_table_retire(f->tb.t, (uint32_t)index), 0);
        assert_int_equal(sl_read(f->c, sl_find(f->c, "a"), buf, sizeof(buf), NULL), 0);
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_REMAPPED);
}

/* A daemon restart: everything once, then the new daemon's changes under the same ids. */
static void test_restart(void **state)
{
        struct fixture *f = *state;
        static const struct shm_var vars2[] = {
                { "c", SHM_DIR_IN, SHM_TYPE_LONG, 1, NULL, SHM_POSITION_NONE },
                { "a", SHM_DIR_IN, SHM_TYPE_LONG, 0, "A", 0 },
        };
        int a = sl_find(f->c, "a");

        start(f);
        f->tb.t = shm_table_destroy(f->tb.t);
        f->tb.cfg.vars = vars2;
        f->tb.cfg.nvars = 2;
        assert_int_equal(shm_table_create(&f->tb.cfg, &f->tb.t), 0);
        shm_table_set_str(f->tb.t, 1, "9");
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_REMAPPED);
        assert_int_equal(sl_find(f->c, "a"), a);
        shm_table_set_str(f->tb.t, 1, "10");
        assert_int_equal(changed(f, IDS_MAX), 1);
        assert_int_equal(f->flags, 0);
        assert_int_equal(f->ids[0], a);
}

/* A cursor that is not this handle's (here: from the future of the record) is a remap. */
static void test_foreign_cursor(void **state)
{
        struct fixture *f = *state;

        start(f);
        f->cursor += 5;
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_REMAPPED);
        f->cursor ^= UINT64_C(0x7) << 56;
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_REMAPPED);
}

/* A daemon without a record (1.6 and before), or one whose record the header does not place
 * where the layout does: everything, every time. */
static void test_old_daemon(void **state)
{
        struct fixture *f = *state;
        struct shmtest_view in = shmtest_view_open(f->tb.in_name, true);
        struct shm_in_header *h = shmtest_in_header(&in);
        uint32_t version = h->layout_version;

        start(f);
        h->layout_version = (SHM_LAYOUT_MAJOR << 16) | SHM_LAYOUT_MINOR_TOUCHED;
        for (int i = 0; i < 2; i++) {
                assert_int_equal(changed(f, IDS_MAX), 0);
                assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_UNAVAILABLE);
        }
        h->layout_version = version;
        h->changes_offset += SHM_CACHE_LINE;
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_UNAVAILABLE);
        h->changes_offset -= SHM_CACHE_LINE;
        /* back: the cursor of "unavailable" is not one of the record's */
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, SL_CHANGED_ALL | SL_CHANGED_START);
        assert_int_equal(changed(f, IDS_MAX), 0);
        assert_int_equal(f->flags, 0);
        shmtest_view_close(&in);
}

/* $SHAREDLINK_CHANGES=all (at sl_open): everything, every time. */
static void test_env_all(void **state)
{
        struct fixture *f = *state;
        struct sl_client *c2;
        uint64_t cursor = 0;
        uint32_t flags;

        setenv("SHAREDLINK_CHANGES", "all", 1);
        assert_int_equal(sl_open(f->tb.instance, &c2), 0);
        unsetenv("SHAREDLINK_CHANGES");
        for (int i = 0; i < 2; i++) {
                shm_table_set_str(f->tb.t, A, "1");
                assert_int_equal(sl_changed(c2, &cursor, f->ids, IDS_MAX, &flags), 0);
                assert_int_equal(flags, SL_CHANGED_ALL | SL_CHANGED_UNAVAILABLE);
        }
        sl_close(c2);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_ring_read),
                cmocka_unit_test(test_ring_wrap),
                cmocka_unit_test(test_ring_overrun),
                cmocka_unit_test(test_ring_noted_ahead),
                cmocka_unit_test(test_ring_scribbled),
                cmocka_unit_test(test_ring_race),
                cmocka_unit_test(test_geometry),
                cmocka_unit_test(test_header),
                cmocka_unit_test_setup_teardown(test_values_and_flags, setup, teardown),
                cmocka_unit_test_setup_teardown(test_duplicates_and_more, setup, teardown),
                cmocka_unit_test_setup_teardown(test_overrun, setup, teardown),
                cmocka_unit_test_setup_teardown(test_names, setup, teardown),
                cmocka_unit_test_setup_teardown(test_remap_by_other_call, setup, teardown),
                cmocka_unit_test_setup_teardown(test_restart, setup, teardown),
                cmocka_unit_test_setup_teardown(test_foreign_cursor, setup, teardown),
                cmocka_unit_test_setup_teardown(test_old_daemon, setup, teardown),
                cmocka_unit_test_setup_teardown(test_env_all, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
