/*
 * The instance's shm tables (daemon_tables.h).
 */
#include "daemon/daemon_tables.h"

#include <errno.h>
#include <inttypes.h>
#include <string.h>

#include "shm/table.h"
#include "svc/log.h"

/* The socket path is published in the .in header (layout 1.2): the field must hold any path. */
_Static_assert(CONFIG_SOCKET_PATH_MAX <= SHM_SOCKET_PATH_SIZE, "socket path field");

int daemon_tables_create(const struct config *cfg, const struct daemon_plan *plan,
                         struct shm_table **ret_table)
{
        struct shm_link_def links[CONFIG_LINKS_MAX];
        struct shm_table_config tc = {
                .instance = cfg->instance,
                .vars = plan->decl->vars,
                .nvars = plan->decl->nvars,
                .links = links,
                .nlinks = cfg->n_links,
                .adhoc_capacity = plan->adhoc_capacity,
                .out_spare = plan->out_spare,
                .heartbeat_interval_ms = DAEMON_HEARTBEAT_MS,
                .has_group = plan->has_group,
                .gid = plan->gid,
                .control_socket = plan->socket_path,
        };
        int r;

        for (unsigned i = 0; i < cfg->n_links; i++) {
                links[i].name = cfg->links[i].name;
                links[i].protocol = config_protocol_name(cfg->links[i].protocol);
        }
        r = shm_table_create(&tc, ret_table);
        if (r < 0) {
                log_warnx("cannot create the shared memory tables of instance %s: %s%s",
                          cfg->instance, strerror(-r),
                          r == -EBUSY ? " (another sharedlinkd runs this instance)" : "");
                return r;
        }
        log_info("tables /sharedlink.%s.{in,out}: %" PRIu32 " variables, epoch %" PRIu64,
                 cfg->instance, plan->decl->nvars, shm_table_epoch(*ret_table));
        return 0;
}
