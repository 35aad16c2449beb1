/*
 * sharedlink-agility: the completed runs of a class in SQLite (docs/agility.md §6).
 *
 * One table, `runs`, one row per class and competitor (a run again replaces the row): what
 * struct agility_result holds, the penalty and placement as last computed, the order runs
 * completed in (seq) and when (completed_at, UTC). The database is in WAL mode with
 * synchronous=FULL, and every completed run is one transaction committed before the caller
 * lets the displays show it: a SIGKILL (or a power cut) at any moment loses no completed run,
 * and a restart loads the class as it was (agilityd_store_load).
 *
 * Schema (user_version 1):
 *
 *   runs(class TEXT, competitor INTEGER, seq INTEGER, finished INTEGER, eliminated INTEGER,
 *        faults INTEGER, refusals INTEGER,
 *        intermediate1_ms INTEGER, intermediate1_precision TEXT, ... intermediate3_...,
 *        finish_ms INTEGER, finish_precision TEXT,        -- NULL: not taken; 'high' / 'low'
 *        penalty_ms INTEGER, placement INTEGER,            -- placement NULL: not placed
 *        completed_at TEXT, PRIMARY KEY (class, competitor))
 */
#ifndef SHAREDLINK_AGILITYD_STORE_H
#define SHAREDLINK_AGILITYD_STORE_H

#include <stddef.h>
#include <stdint.h>

#include "agility/agility_competitors.h"
#include "agility/agility_rank.h"

#define AGILITYD_STORE_ERROR_MAX 512
#define AGILITYD_STORE_BUSY_MS  2000    /* another reader holds a lock: wait this long */

struct agilityd_store;

/* Opens (creating) the database at path for class_name. 0, or -errno with the message in err. */
int agilityd_store_open(const char *path, const char *class_name, struct agilityd_store **ret,
                        char *err, size_t err_size);

/* Closes; NULL-safe; returns NULL. */
struct agilityd_store *agilityd_store_close(struct agilityd_store *s);

/*
 * Loads the class's completed runs into results (parallel to competitors, count entries,
 * zeroed by the caller) and the last completed competitor into *ret_last (0: none). A stored
 * run of a competitor no longer in the list is skipped and counted in *ret_skipped. 0 or -errno
 * with the message in err.
 */
int agilityd_store_load(struct agilityd_store *s, const struct agility_competitor *competitors,
                        size_t count, struct agility_result *results, uint16_t *ret_last,
                        unsigned *ret_skipped, char *err, size_t err_size);

/*
 * Stores results[index] as the class's latest completed run and the penalty and placement of
 * every completed run of results (count entries: placements move for everyone), in one
 * transaction. 0 once committed, or -errno (nothing changed) with the message in err.
 */
int agilityd_store_save(struct agilityd_store *s, const struct agility_result *results,
                        size_t count, size_t index, char *err, size_t err_size);

#endif
