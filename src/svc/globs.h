/*
 * Lists of variable-name globs (fnmatch(3): * ? [...]), as the bridges' publish: and writable:
 * keys take them: read from the configuration with the toolkit's reader, matched against the
 * names of the tables. '/' has no special meaning (variable names have none), and '+', '#' and
 * '/' are refused in a glob: they cannot match a variable name, so one is a mistake (an MQTT
 * topic or a ROS name where a variable name belongs).
 */
#ifndef SHAREDLINK_SVC_GLOBS_H
#define SHAREDLINK_SVC_GLOBS_H

#include <stdbool.h>

#include <sharedlink.h>

#include "svc/conf.h"

#define GLOBS_MAX               64      /* entries of one list */
#define GLOB_SIZE               SL_NAME_SIZE

struct globs {
        unsigned count;
        char glob[GLOBS_MAX][GLOB_SIZE];
};

/* Reads list N (the value of KEY) into *g; 0 or -EINVAL with the error in c. */
int globs_read(struct conf *c, const char *key, const struct conf_node *n, struct globs *g);

/* Whether name matches one of the globs. */
bool globs_match(const struct globs *g, const char *name);

#endif
