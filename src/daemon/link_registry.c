/*
 * The protocol -> engine table (link.h: link_ops_for). A protocol whose engine is not part of
 * this build maps to NULL, and the daemon refuses a configuration naming it ("protocol X not
 * available in this build") instead of starting a link that would do nothing.
 */
#include "daemon/link.h"

#include <stddef.h>

#include "daemon/link_circe.h"
#include "daemon/link_sharedlink.h"

const struct link_ops *link_ops_for(enum config_protocol protocol)
{
        switch (protocol) {
        case CONFIG_PROTOCOL_SHAREDLINK:
                return &link_sharedlink_ops;
        case CONFIG_PROTOCOL_CIRCE:
                return &link_circe_ops;
        default:
                return NULL;
        }
}
