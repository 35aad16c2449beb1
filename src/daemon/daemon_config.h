/*
 * A configuration shared by the instance and the links created from it, reference counted: a
 * link keeps the configuration it was created with (its link_env points into it), so a reload
 * that leaves a link untouched does not pull its settings from under it; the old configuration
 * is freed when its last link stops.
 */
#ifndef SHAREDLINK_DAEMON_DAEMON_CONFIG_H
#define SHAREDLINK_DAEMON_DAEMON_CONFIG_H

#include "daemon/config.h"

struct daemon_config {
        struct config *config;
        unsigned refs;
};

/* Takes config over (freed on failure too) with one reference; NULL when out of memory. */
struct daemon_config *daemon_config_new(struct config *config);

/* Adds a reference; returns dc. */
struct daemon_config *daemon_config_ref(struct daemon_config *dc);

/* Drops a reference; the last one frees the configuration. NULL ok; returns NULL. */
struct daemon_config *daemon_config_unref(struct daemon_config *dc);

#endif
