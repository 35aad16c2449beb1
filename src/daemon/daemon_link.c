/*
 * The links of the instance (daemon_link.h).
 */
#include "daemon/daemon_link.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shm/table.h"
#include "svc/log.h"

#define DAEMON_LINK_FAILED      0u      /* shm link state of a link whose engine did not start */

const char *daemon_link_status_text(const struct daemon_link *dl)
{
        const char *s;

        if (!dl->engine)
                return dl->failure;
        s = dl->ops->status ? dl->ops->status(dl->engine) : NULL;
        return s && *s ? s : "running";
}

bool daemon_link_is_up(const struct daemon_link *dl)
{
        const char *s = daemon_link_status_text(dl);

        return dl->engine && strncmp(s, "up", 2) == 0 &&
               (s[2] == '\0' || s[2] == ' ' || s[2] == ':' || s[2] == ',' || s[2] == ';');
}

struct daemon_link *daemon_link_free(struct daemon_link *dl)
{
        if (!dl)
                return NULL;
        if (dl->engine) {
                log_debug("link %s: stopping", dl->env.cfg->name);
                dl->ops->destroy(dl->engine);
        }
        recorder_tap_free(dl->tap, "link stopped");
        daemon_config_unref(dl->dc);
        free(dl);
        return NULL;
}

int daemon_link_new(struct evloop *loop, struct shm_table *table,
                    struct recorder_stats *rec_stats, unsigned i, struct daemon_config *dc,
                    const struct link_ops *ops, struct daemon_link **ret_link)
{
        struct daemon_link *dl = calloc(1, sizeof(*dl));
        const struct config_link *l = &dc->config->links[i];
        struct recorder_link_info info = {
                .link = l->name,
                .protocol = config_protocol_name(l->protocol),
                .transport = config_transport_name(l->transport),
                .instance = dc->config->instance,
        };
        int r;

        if (!dl)
                return -ENOMEM;
        dl->tap = recorder_tap_new(&info, rec_stats);
        if (!dl->tap) {
                free(dl);
                return -ENOMEM;
        }
        dl->ops = ops;
        dl->dc = daemon_config_ref(dc);
        dl->env.loop = loop;
        dl->env.table = table;
        dl->env.shm_link = i;
        dl->env.config = dc->config;
        dl->env.cfg = l;
        dl->env.tap = dl->tap;
        *ret_link = dl;
        r = ops->create(&dl->env, &dl->engine);
        if (r < 0) {
                dl->engine = NULL;
                snprintf(dl->failure, sizeof(dl->failure), "failed: %s", strerror(-r));
                log_warnx("link %s (%s over %s): cannot start: %s", l->name,
                          config_protocol_name(l->protocol), config_transport_name(l->transport),
                          strerror(-r));
                shm_table_link_state(table, i, DAEMON_LINK_FAILED, "failed");
                return 0;
        }
        log_info("link %s (%s over %s): started", l->name, config_protocol_name(l->protocol),
                 config_transport_name(l->transport));
        return 0;
}
