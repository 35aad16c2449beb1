/*
 * sharedlink-agility's results database (agilityd_store.h): SQLite, WAL, one transaction per
 * completed run.
 */
#include "agility/agilityd_store.h"

#include <errno.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sqlite3.h>

#define NAME_MAX_BYTES          64

struct agilityd_store {
        sqlite3 *db;
        sqlite3_stmt *upsert, *rank, *load;
        char class_name[NAME_MAX_BYTES];
        char path[256];
};

static const char schema[] =
        "CREATE TABLE IF NOT EXISTS runs ("
        " class TEXT NOT NULL,"
        " competitor INTEGER NOT NULL CHECK (competitor BETWEEN 1 AND 999),"
        " seq INTEGER NOT NULL,"
        " finished INTEGER NOT NULL,"
        " eliminated INTEGER NOT NULL,"
        " faults INTEGER NOT NULL,"
        " refusals INTEGER NOT NULL,"
        " intermediate1_ms INTEGER, intermediate1_precision TEXT,"
        " intermediate2_ms INTEGER, intermediate2_precision TEXT,"
        " intermediate3_ms INTEGER, intermediate3_precision TEXT,"
        " finish_ms INTEGER, finish_precision TEXT,"
        " penalty_ms INTEGER NOT NULL,"
        " placement INTEGER,"
        " completed_at TEXT NOT NULL,"
        " PRIMARY KEY (class, competitor));"
        "PRAGMA user_version = 1;";

/* The columns of one run, in the order of the statements below (after class, competitor). */
enum {
        COL_CLASS = 1, COL_COMPETITOR, COL_FINISHED, COL_ELIMINATED, COL_FAULTS, COL_REFUSALS,
        COL_INTERMEDIATE1, /* ms, precision, x3 */
        COL_FINISH = COL_INTERMEDIATE1 + 2 * AGILITY_INTERMEDIATES_MAX, COL_FINISH_PRECISION,
        COL_PENALTY, COL_PLACEMENT,
};

static const char sql_upsert[] =
        "INSERT OR REPLACE INTO runs (class, competitor, finished, eliminated, faults, refusals,"
        " intermediate1_ms, intermediate1_precision, intermediate2_ms, intermediate2_precision,"
        " intermediate3_ms, intermediate3_precision, finish_ms, finish_precision, penalty_ms,"
        " placement, seq, completed_at)"
        " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16,"
        " (SELECT IFNULL(MAX(seq), 0) + 1 FROM runs WHERE class = ?1),"
        " strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))";
static const char sql_rank[] =
        "UPDATE runs SET penalty_ms = ?3, placement = ?4 WHERE class = ?1 AND competitor = ?2";
static const char sql_load[] =
        "SELECT competitor, finished, eliminated, faults, refusals,"
        " intermediate1_ms, intermediate1_precision, intermediate2_ms, intermediate2_precision,"
        " intermediate3_ms, intermediate3_precision, finish_ms, finish_precision"
        " FROM runs WHERE class = ?1 ORDER BY seq";

static int fail(struct agilityd_store *s, int rc, const char *what, char *err, size_t err_size)
{
        snprintf(err, err_size, "%s: %s: %s", s->path, what,
                 s->db ? sqlite3_errmsg(s->db) : sqlite3_errstr(rc));
        switch (rc & 0xff) {
        case SQLITE_NOMEM:
                return -ENOMEM;
        case SQLITE_BUSY:
        case SQLITE_LOCKED:
                return -EBUSY;
        case SQLITE_READONLY:
        case SQLITE_PERM:
        case SQLITE_AUTH:
                return -EACCES;
        case SQLITE_FULL:
                return -ENOSPC;
        case SQLITE_CANTOPEN:
                return -ENOENT;
        default:
                return -EIO;
        }
}

static const char *precision_text(enum agility_precision p)
{
        return agility_timing_precision_name(p);
}

static enum agility_precision precision_of(const unsigned char *t)
{
        return t && strcmp((const char *)t, precision_text(AGILITY_PRECISION_HIGH)) == 0 ?
               AGILITY_PRECISION_HIGH : AGILITY_PRECISION_LOW;
}

int agilityd_store_open(const char *path, const char *class_name, struct agilityd_store **ret,
                        char *err, size_t err_size)
{
        struct agilityd_store *s = calloc(1, sizeof(*s));
        char *msg = NULL;
        int rc, r;

        if (!s) {
                snprintf(err, err_size, "%s: out of memory", path);
                return -ENOMEM;
        }
        snprintf(s->path, sizeof(s->path), "%s", path);
        snprintf(s->class_name, sizeof(s->class_name), "%s", class_name);
        rc = sqlite3_open_v2(path, &s->db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE |
                             SQLITE_OPEN_NOMUTEX, NULL);
        if (rc != SQLITE_OK) {
                r = fail(s, rc, "open", err, err_size);
                agilityd_store_close(s);
                return r;
        }
        sqlite3_busy_timeout(s->db, AGILITYD_STORE_BUSY_MS);
        /* WAL: readers (the scoreboard, sqlite3 by hand) never block the commit of a run;
         * FULL: the commit is on disk before the display shows the result. */
        rc = sqlite3_exec(s->db, "PRAGMA journal_mode = WAL; PRAGMA synchronous = FULL;",
                          NULL, NULL, &msg);
        if (rc == SQLITE_OK)
                rc = sqlite3_exec(s->db, schema, NULL, NULL, &msg);
        sqlite3_free(msg);
        if (rc == SQLITE_OK)
                rc = sqlite3_prepare_v2(s->db, sql_upsert, -1, &s->upsert, NULL);
        if (rc == SQLITE_OK)
                rc = sqlite3_prepare_v2(s->db, sql_rank, -1, &s->rank, NULL);
        if (rc == SQLITE_OK)
                rc = sqlite3_prepare_v2(s->db, sql_load, -1, &s->load, NULL);
        if (rc != SQLITE_OK) {
                r = fail(s, rc, "schema", err, err_size);
                agilityd_store_close(s);
                return r;
        }
        *ret = s;
        return 0;
}

struct agilityd_store *agilityd_store_close(struct agilityd_store *s)
{
        if (!s)
                return NULL;
        sqlite3_finalize(s->upsert);
        sqlite3_finalize(s->rank);
        sqlite3_finalize(s->load);
        sqlite3_close(s->db);
        free(s);
        return NULL;
}

static long find(const struct agility_competitor *competitors, size_t count, int number)
{
        for (size_t i = 0; i < count; i++)
                if (competitors[i].number == number)
                        return (long)i;
        return -1;
}

int agilityd_store_load(struct agilityd_store *s, const struct agility_competitor *competitors,
                        size_t count, struct agility_result *results, uint16_t *ret_last,
                        unsigned *ret_skipped, char *err, size_t err_size)
{
        int rc;

        *ret_last = 0;
        *ret_skipped = 0;
        sqlite3_reset(s->load);
        sqlite3_bind_text(s->load, 1, s->class_name, -1, SQLITE_STATIC);
        while ((rc = sqlite3_step(s->load)) == SQLITE_ROW) {
                int number = sqlite3_column_int(s->load, 0);
                long i = find(competitors, count, number);
                struct agility_result *r;

                if (i < 0) {
                        (*ret_skipped)++;
                        continue;
                }
                r = &results[i];
                memset(r, 0, sizeof(*r));
                r->competitor = (uint16_t)number;
                r->completed = true;
                r->finished = sqlite3_column_int(s->load, 1) != 0;
                r->eliminated = sqlite3_column_int(s->load, 2) != 0;
                r->faults = (uint8_t)sqlite3_column_int(s->load, 3);
                r->refusals = (uint8_t)sqlite3_column_int(s->load, 4);
                for (int k = 0; k < AGILITY_INTERMEDIATES_MAX; k++) {
                        int col = 5 + 2 * k;

                        if (sqlite3_column_type(s->load, col) == SQLITE_NULL)
                                break;
                        r->intermediate_ms[k] = (uint32_t)sqlite3_column_int64(s->load, col);
                        r->intermediate_precision[k] =
                                precision_of(sqlite3_column_text(s->load, col + 1));
                        r->intermediates = (uint8_t)(k + 1);
                }
                if (r->finished) {
                        r->finish_ms = (uint32_t)sqlite3_column_int64(s->load, 11);
                        r->finish_precision = precision_of(sqlite3_column_text(s->load, 12));
                }
                *ret_last = (uint16_t)number;
        }
        sqlite3_reset(s->load);
        if (rc != SQLITE_DONE)
                return fail(s, rc, "load", err, err_size);
        return 0;
}

static void bind_time(sqlite3_stmt *st, int col, bool taken, uint32_t ms,
                      enum agility_precision p)
{
        if (taken) {
                sqlite3_bind_int64(st, col, ms);
                sqlite3_bind_text(st, col + 1, precision_text(p), -1, SQLITE_STATIC);
        } else {
                sqlite3_bind_null(st, col);
                sqlite3_bind_null(st, col + 1);
        }
}

static int step_once(sqlite3_stmt *st)
{
        int rc = sqlite3_step(st);

        sqlite3_reset(st);
        return rc == SQLITE_DONE ? SQLITE_OK : rc;
}

int agilityd_store_save(struct agilityd_store *s, const struct agility_result *results,
                        size_t count, size_t index, char *err, size_t err_size)
{
        const struct agility_result *r = &results[index];
        int rc = sqlite3_exec(s->db, "BEGIN IMMEDIATE", NULL, NULL, NULL);
        int ret;

        if (rc != SQLITE_OK)
                return fail(s, rc, "begin", err, err_size);
        sqlite3_clear_bindings(s->upsert);
        sqlite3_bind_text(s->upsert, COL_CLASS, s->class_name, -1, SQLITE_STATIC);
        sqlite3_bind_int(s->upsert, COL_COMPETITOR, r->competitor);
        sqlite3_bind_int(s->upsert, COL_FINISHED, r->finished);
        sqlite3_bind_int(s->upsert, COL_ELIMINATED, r->eliminated);
        sqlite3_bind_int(s->upsert, COL_FAULTS, r->faults);
        sqlite3_bind_int(s->upsert, COL_REFUSALS, r->refusals);
        for (int k = 0; k < AGILITY_INTERMEDIATES_MAX; k++)
                bind_time(s->upsert, COL_INTERMEDIATE1 + 2 * k, k < r->intermediates,
                          r->intermediate_ms[k], r->intermediate_precision[k]);
        bind_time(s->upsert, COL_FINISH, r->finished, r->finish_ms, r->finish_precision);
        sqlite3_bind_int64(s->upsert, COL_PENALTY, r->penalty_ms);
        if (r->placement)
                sqlite3_bind_int(s->upsert, COL_PLACEMENT, r->placement);
        else
                sqlite3_bind_null(s->upsert, COL_PLACEMENT);
        rc = step_once(s->upsert);
        for (size_t i = 0; rc == SQLITE_OK && i < count; i++) {
                if (!results[i].completed || i == index)
                        continue;
                sqlite3_bind_text(s->rank, 1, s->class_name, -1, SQLITE_STATIC);
                sqlite3_bind_int(s->rank, 2, results[i].competitor);
                sqlite3_bind_int64(s->rank, 3, results[i].penalty_ms);
                if (results[i].placement)
                        sqlite3_bind_int(s->rank, 4, results[i].placement);
                else
                        sqlite3_bind_null(s->rank, 4);
                rc = step_once(s->rank);
        }
        if (rc == SQLITE_OK)
                rc = sqlite3_exec(s->db, "COMMIT", NULL, NULL, NULL);
        if (rc == SQLITE_OK)
                return 0;
        ret = fail(s, rc, "store", err, err_size);
        sqlite3_exec(s->db, "ROLLBACK", NULL, NULL, NULL);
        return ret;
}
