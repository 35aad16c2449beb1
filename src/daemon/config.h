/*
 * sharedlinkd configuration: YAML text -> plain structs (DESIGN.md §2.3).
 *
 * The parser is pure (no I/O, no logging, no global state): config_parse() takes the text and
 * either returns a complete, validated struct config or fills a struct config_error whose message
 * is ready to print as "FILE:LINE:COL: text" (1-based line and column of the offending node).
 * config_load_file() reads a file and calls it. What a configuration holds (limits, enums,
 * structs) is in config_types.h, the spellings of its enums in config_names.h.
 */
#ifndef SHAREDLINK_DAEMON_CONFIG_H
#define SHAREDLINK_DAEMON_CONFIG_H

#include <stddef.h>

#include "daemon/config_names.h"
#include "daemon/config_types.h"

/*
 * Parses LEN bytes of YAML (need not be NUL-terminated); FILENAME only prefixes messages (NULL:
 * "<config>"). Returns 0 and a new config in *ret_config, or -EINVAL (bad config), -EFBIG (larger
 * than CONFIG_INPUT_MAX) or -ENOMEM, with *ret_error (if not NULL) filled only on failure.
 */
int config_parse(const char *text, size_t len, const char *filename, struct config **ret_config,
                 struct config_error *ret_error);

/* Reads PATH (at most CONFIG_INPUT_MAX bytes) and parses it; -errno on I/O errors. */
int config_load_file(const char *path, struct config **ret_config, struct config_error *ret_error);

/* Frees a config from config_parse()/config_load_file(); NULL is fine. Returns NULL. */
struct config *config_free(struct config *config);

/* True when two links have the same settings, name and variable lists included (reload). */
bool config_link_equal(const struct config_link *a, const struct config_link *b);

/* The link called NAME, or NULL. */
const struct config_link *config_link_find(const struct config *config, const char *name);

#endif
