/*
 * The instance's shm tables (/sharedlink.<instance>.{in,out}, shm/table.h), created from a plan:
 * its declaration, group and socket path, and room for what links learn at run time.
 */
#ifndef SHAREDLINK_DAEMON_DAEMON_TABLES_H
#define SHAREDLINK_DAEMON_DAEMON_TABLES_H

#include "daemon/config.h"
#include "daemon/daemon_plan.h"

/* The heartbeat the tables announce (clients judge staleness by it), which daemon_status.c
 * keeps, with the engines' heartbeats and the STATUS refresh. */
#define DAEMON_HEARTBEAT_MS     1000

struct shm_table;

/* Creates the tables of plan (made from cfg) with a new epoch. 0 or -errno (logged; -EBUSY:
 * another sharedlinkd runs this instance). */
int daemon_tables_create(const struct config *cfg, const struct daemon_plan *plan,
                         struct shm_table **ret_table);

#endif
