/*
 * A plan: everything derived from one configuration before anything is touched: the engine of
 * each link, the group id, the runtime directory and the control socket path, and the
 * declaration (the variables and links the tables are created with). Start and reload both make
 * a plan first, so a configuration that cannot work is refused while the running one is still
 * intact; `sharedlinkd -n` makes one and throws it away.
 *
 * runtime_dir: the config's when the file sets it; otherwise $SHAREDLINK_RUNTIME_DIR when set
 * (absolute), else the default /run/sharedlink.
 */
#ifndef SHAREDLINK_DAEMON_DAEMON_PLAN_H
#define SHAREDLINK_DAEMON_DAEMON_PLAN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "daemon/config.h"
#include "daemon/link.h"

#define DAEMON_VARS_MAX         16384   /* variables all links may declare together */
#define DAEMON_ADHOC_CAPACITY   2048    /* inbound names engines may add at run time */
#define DAEMON_NAMES_SIZE       (DAEMON_VARS_MAX * 48)  /* scratch for generated names */
#define DAEMON_ERROR_MAX        512     /* a one-line reason: a refused plan, a failed link */
#define DAEMON_RUNTIME_DIR_ENV  "SHAREDLINK_RUNTIME_DIR"

/* What the tables were created with; compared on reload to decide whether to keep them. */
struct daemon_decl {
        char instance[CONFIG_INSTANCE_MAX + 1];
        bool has_group;
        gid_t gid;
        unsigned nlinks;
        char link_names[CONFIG_LINKS_MAX][CONFIG_LINK_NAME_MAX + 1];
        enum config_protocol protocols[CONFIG_LINKS_MAX];
        struct shm_var *vars;           /* names and peers point into strings */
        uint32_t nvars;
        char *strings;
};

struct daemon_plan {
        const struct link_ops *ops[CONFIG_LINKS_MAX];
        bool has_group;
        gid_t gid;
        char runtime_dir[CONFIG_PATH_MAX];
        char socket_path[CONFIG_SOCKET_PATH_MAX];
        struct daemon_decl *decl;
        uint32_t adhoc_capacity;        /* names the links may add at run time, and ... */
        uint32_t out_spare;             /* ... the outbound ones among them (link_ops.learning) */
        unsigned err_line, err_column;          /* the failing key of the file, 0: none */
};

/*
 * Makes the plan of cfg: resolves the group, the paths and every link's engine, and asks each
 * engine for its variables (link_ops.declare), checked for names, peers and duplicates. 0, or
 * -errno with a one-line message in err ("link x: protocol circe not available in this build").
 * plan is overwritten either way: daemon_plan_clear() it after.
 */
int daemon_plan_make(const struct config *cfg, struct daemon_plan *plan, char *err,
                     size_t errsz);

/* Where daemon_plan_make()'s error points, into buf: "<path>:<line>:<col>" for a key of the file
 * (a group that does not exist), as every configuration error, else "<path>". */
void daemon_plan_where(const struct daemon_plan *plan, const char *path, char *buf, size_t size);

/* Frees what daemon_plan_make() allocated (the declaration). */
void daemon_plan_clear(struct daemon_plan *plan);

/* Whether b's tables would be a's: the same declaration (instance, group, links and their
 * protocols, every variable) and the same socket path, which the header publishes. */
bool daemon_plan_same_tables(const struct daemon_plan *a, const struct daemon_plan *b);

/* Whether b's control socket would be a's: the same path and group. */
bool daemon_plan_same_socket(const struct daemon_plan *a, const struct daemon_plan *b);

#endif
