/*
 * Lists of variable-name globs (see globs.h).
 */
#include "svc/globs.h"

#include <fnmatch.h>
#include <string.h>

int globs_read(struct conf *c, const char *key, const struct conf_node *n, struct globs *g)
{
        int r = conf_need_kind(c, key, n, CONF_NODE_SEQUENCE);

        if (r < 0)
                return r;
        g->count = 0;
        for (const struct conf_node *item = conf_child(c, n->first); item;
             item = conf_next(c, item)) {
                if (g->count >= GLOBS_MAX)
                        return conf_fail(c, item, "%s: more than %u entries", key, GLOBS_MAX);
                r = conf_get_string(c, key, item, g->glob[g->count], sizeof(g->glob[0]));
                if (r < 0)
                        return r;
                if (strpbrk(g->glob[g->count], "+#/"))
                        return conf_fail(c, item, "%s: %s: '+', '#' and '/' are not allowed "
                                         "(globs match variable names: * ? [...])", key,
                                         conf_quote_node(c, item));
                g->count++;
        }
        return 0;
}

bool globs_match(const struct globs *g, const char *name)
{
        for (unsigned i = 0; i < g->count; i++)
                if (fnmatch(g->glob[i], name, 0) == 0)
                        return true;
        return false;
}
