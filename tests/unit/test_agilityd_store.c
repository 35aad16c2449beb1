/*
 * Unit tests for sharedlink-agility's results database (src/agility/agilityd_store.c): a run
 * stored comes back as it was (times, precisions, intermediates, counts), a run again replaces
 * the row, the last completed competitor is the one stored last, placements of the others are
 * updated in the same transaction, runs of other classes and of competitors no longer listed
 * stay out, and a database that cannot be opened or written says why.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>
#include <sqlite3.h>

#include "agility/agilityd_store.h"

#define PATH_BUF        256
#define COMPETITORS     3

struct fx {
        char dir[PATH_BUF / 2];
        char db[PATH_BUF];
        struct agility_competitor list[COMPETITORS];
};

static int setup(void **state)
{
        struct fx *f = calloc(1, sizeof(*f));

        if (!f)
                return -1;
        snprintf(f->dir, sizeof(f->dir), "/tmp/agstore.XXXXXX");
        if (!mkdtemp(f->dir))
                return -1;
        snprintf(f->db, sizeof(f->db), "%s/r.db", f->dir);
        for (int i = 0; i < COMPETITORS; i++)
                f->list[i].number = (uint16_t)(i + 1);
        *state = f;
        return 0;
}

static int teardown(void **state)
{
        struct fx *f = *state;
        char p[PATH_BUF + 8];
        static const char *const suffix[] = { "", "-wal", "-shm" };

        for (size_t i = 0; i < sizeof(suffix) / sizeof(suffix[0]); i++) {
                snprintf(p, sizeof(p), "%s%s", f->db, suffix[i]);
                unlink(p);
        }
        rmdir(f->dir);
        free(f);
        return 0;
}

static struct agilityd_store *open_class(struct fx *f, const char *name)
{
        struct agilityd_store *s = NULL;
        char err[AGILITYD_STORE_ERROR_MAX];

        if (agilityd_store_open(f->db, name, &s, err, sizeof(err)) < 0)
                fail_msg("%s", err);
        return s;
}

static void save(struct agilityd_store *s, const struct agility_result *r, size_t index)
{
        char err[AGILITYD_STORE_ERROR_MAX];

        if (agilityd_store_save(s, r, COMPETITORS, index, err, sizeof(err)) < 0)
                fail_msg("%s", err);
}

static uint16_t load(struct agilityd_store *s, struct fx *f, struct agility_result *r,
                     size_t count, unsigned *skipped)
{
        char err[AGILITYD_STORE_ERROR_MAX];
        uint16_t last = 0;

        memset(r, 0, sizeof(*r) * COMPETITORS);
        if (agilityd_store_load(s, f->list, count, r, &last, skipped, err, sizeof(err)) < 0)
                fail_msg("%s", err);
        return last;
}

static void test_round_trip(void **state)
{
        struct fx *f = *state;
        struct agility_result r[COMPETITORS] = { 0 }, back[COMPETITORS];
        struct agilityd_store *s = open_class(f, "A");
        unsigned skipped;

        r[1] = (struct agility_result){
                .competitor = 2, .completed = true, .finished = true, .faults = 5,
                .refusals = 10, .intermediates = 2, .intermediate_ms = { 9000, 18040 },
                .intermediate_precision = { AGILITY_PRECISION_HIGH, AGILITY_PRECISION_LOW },
                .finish_ms = 27000, .finish_precision = AGILITY_PRECISION_HIGH,
                .penalty_ms = 15000, .placement = 1,
        };
        r[0] = (struct agility_result){ .competitor = 1, .completed = true, .eliminated = true,
                                        .refusals = 15, .penalty_ms = 15000 };
        save(s, r, 1);
        save(s, r, 0);
        s = agilityd_store_close(s);

        s = open_class(f, "A");
        assert_int_equal(load(s, f, back, COMPETITORS, &skipped), 1);   /* stored last */
        assert_int_equal(skipped, 0);
        assert_true(back[1].completed && back[1].finished && !back[1].eliminated);
        assert_int_equal(back[1].faults, 5);
        assert_int_equal(back[1].refusals, 10);
        assert_int_equal(back[1].intermediates, 2);
        assert_int_equal(back[1].intermediate_ms[1], 18040);
        assert_int_equal(back[1].intermediate_precision[0], AGILITY_PRECISION_HIGH);
        assert_int_equal(back[1].intermediate_precision[1], AGILITY_PRECISION_LOW);
        assert_int_equal(back[1].finish_ms, 27000);
        assert_int_equal(back[1].finish_precision, AGILITY_PRECISION_HIGH);
        assert_true(back[0].completed && back[0].eliminated && !back[0].finished);
        assert_int_equal(back[0].refusals, 15);
        assert_false(back[2].completed);

        /* Competitor 2 runs again: the row is replaced, and it is the last one now. */
        r[1].faults = 0;
        r[1].finish_ms = 26000;
        save(s, r, 1);
        assert_int_equal(load(s, f, back, COMPETITORS, &skipped), 2);
        assert_int_equal(back[1].faults, 0);
        assert_int_equal(back[1].finish_ms, 26000);

        /* Another class in the same file sees none of it; a shorter list skips what it lacks. */
        agilityd_store_close(s);
        s = open_class(f, "B");
        assert_int_equal(load(s, f, back, COMPETITORS, &skipped), 0);
        assert_false(back[0].completed || back[1].completed);
        agilityd_store_close(s);
        s = open_class(f, "A");
        assert_int_equal(load(s, f, back, 1, &skipped), 1);
        assert_int_equal(skipped, 1);
        agilityd_store_close(s);
}

static void test_placements_move(void **state)
{
        struct fx *f = *state;
        struct agility_result r[COMPETITORS] = { 0 };
        struct agilityd_store *s = open_class(f, "A");
        sqlite3 *db;
        sqlite3_stmt *st;

        r[0] = (struct agility_result){ .competitor = 1, .completed = true, .finished = true,
                                        .finish_ms = 30000, .placement = 1 };
        save(s, r, 0);
        /* Competitor 3 is faster: it is placed first and 1 moves to second, in one commit. */
        r[2] = (struct agility_result){ .competitor = 3, .completed = true, .finished = true,
                                        .finish_ms = 25000, .placement = 1 };
        r[0].placement = 2;
        save(s, r, 2);
        agilityd_store_close(s);

        assert_int_equal(sqlite3_open_v2(f->db, &db, SQLITE_OPEN_READONLY, NULL), SQLITE_OK);
        assert_int_equal(sqlite3_prepare_v2(db, "SELECT competitor, placement, seq FROM runs "
                                            "ORDER BY competitor", -1, &st, NULL), SQLITE_OK);
        assert_int_equal(sqlite3_step(st), SQLITE_ROW);
        assert_int_equal(sqlite3_column_int(st, 0), 1);
        assert_int_equal(sqlite3_column_int(st, 1), 2);
        assert_int_equal(sqlite3_column_int(st, 2), 1);
        assert_int_equal(sqlite3_step(st), SQLITE_ROW);
        assert_int_equal(sqlite3_column_int(st, 0), 3);
        assert_int_equal(sqlite3_column_int(st, 1), 1);
        assert_int_equal(sqlite3_column_int(st, 2), 2);
        assert_int_equal(sqlite3_step(st), SQLITE_DONE);
        sqlite3_finalize(st);
        /* WAL: the mode is in the file. */
        assert_int_equal(sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &st, NULL),
                         SQLITE_OK);
        assert_int_equal(sqlite3_step(st), SQLITE_ROW);
        assert_string_equal((const char *)sqlite3_column_text(st, 0), "wal");
        sqlite3_finalize(st);
        sqlite3_close(db);
}

static void test_errors(void **state)
{
        struct fx *f = *state;
        struct agility_result r[COMPETITORS] = { 0 };
        struct agilityd_store *s = NULL;
        char err[AGILITYD_STORE_ERROR_MAX], path[PATH_BUF + 16];
        sqlite3 *db;

        snprintf(path, sizeof(path), "%s/no/such/dir.db", f->dir);
        assert_true(agilityd_store_open(path, "A", &s, err, sizeof(err)) < 0);
        assert_null(s);
        assert_non_null(strstr(err, "no/such/dir.db: open: "));

        /* Another connection holds the write lock: the save fails after the busy wait, and
         * nothing of it is in the file once the lock goes. */
        s = open_class(f, "A");
        assert_int_equal(sqlite3_open_v2(f->db, &db, SQLITE_OPEN_READWRITE, NULL), SQLITE_OK);
        assert_int_equal(sqlite3_exec(db, "BEGIN EXCLUSIVE", NULL, NULL, NULL), SQLITE_OK);
        r[0] = (struct agility_result){ .competitor = 1, .completed = true, .finished = true,
                                        .finish_ms = 30000, .placement = 1 };
        assert_int_equal(agilityd_store_save(s, r, COMPETITORS, 0, err, sizeof(err)), -EBUSY);
        assert_non_null(strstr(err, "r.db: begin: database is locked"));
        assert_int_equal(sqlite3_exec(db, "ROLLBACK", NULL, NULL, NULL), SQLITE_OK);
        sqlite3_close(db);
        save(s, r, 0);
        agilityd_store_close(s);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_round_trip, setup, teardown),
                cmocka_unit_test_setup_teardown(test_placements_move, setup, teardown),
                cmocka_unit_test_setup_teardown(test_errors, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
