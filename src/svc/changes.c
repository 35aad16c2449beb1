/*
 * Following sl_changed (see changes.h).
 */
#include "svc/changes.h"

int changes_follow(struct changes *ch, struct sl_client *c, bool skip, changes_fn fn, void *arg)
{
        bool all = skip;

        for (unsigned round = 0;; round++) {
                uint32_t flags = 0;
                int n;

                /* Bounded: what is still pending stays past the cursor (the next call hands it
                 * out again), and reading everything now covers it. */
                if (round == CHANGES_ROUNDS)
                        return 1;
                n = sl_changed(c, &ch->cursor, ch->ids, CHANGES_BATCH, &flags);
                if (n < 0 || (flags & SL_CHANGED_ALL))
                        return 1;
                for (int k = 0; !all && k < n; k++) {
                        int r = fn(arg, ch->ids[k]);

                        if (r < 0)
                                return r;
                }
                if (!(flags & SL_CHANGED_MORE))
                        return all ? 1 : 0;
        }
}
