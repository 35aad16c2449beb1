/*
 * Reference-counted configurations (daemon_config.h).
 */
#include "daemon/daemon_config.h"

#include <stdlib.h>

struct daemon_config *daemon_config_new(struct config *config)
{
        struct daemon_config *dc = calloc(1, sizeof(*dc));

        if (!dc) {
                config_free(config);
                return NULL;
        }
        dc->config = config;
        dc->refs = 1;
        return dc;
}

struct daemon_config *daemon_config_ref(struct daemon_config *dc)
{
        dc->refs++;
        return dc;
}

struct daemon_config *daemon_config_unref(struct daemon_config *dc)
{
        if (dc && --dc->refs == 0) {
                config_free(dc->config);
                free(dc);
        }
        return NULL;
}
