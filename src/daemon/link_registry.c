/*
 * The protocol -> engine table (link.h: link_ops_for). A protocol whose engine is not part of
 * this build maps to NULL, and the daemon refuses a configuration naming it ("protocol X not
 * available in this build") instead of starting a link that would do nothing.
 */
#include "daemon/link.h"

#include <errno.h>
#include <stddef.h>
#include <string.h>

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

bool link_ops_has_word(const struct link_ops *ops, const char *word)
{
        for (const char *const *w = ops->command_words; w && *w; w++)
                if (strcmp(*w, word) == 0)
                        return true;
        return false;
}

int link_protocol_for_command(const char *word, enum config_protocol *ret_protocol)
{
        static const enum config_protocol protocols[] = {
                CONFIG_PROTOCOL_SHAREDLINK,
                CONFIG_PROTOCOL_CIRCE,
        };

        for (size_t i = 0; i < sizeof(protocols) / sizeof(protocols[0]); i++) {
                const struct link_ops *ops = link_ops_for(protocols[i]);

                if (ops && link_ops_has_word(ops, word)) {
                        *ret_protocol = protocols[i];
                        return 0;
                }
        }
        return -ENOENT;
}
