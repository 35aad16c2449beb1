/*
 * Counter scopes: which code moves which counter is part of the one counter list (shm/layout.h),
 * which slctl reads through the public library (sl_counter_name, sl_counter_scope).
 * tests/integration/test_slctl.c checks that the real daemon moves no counter outside its scope.
 */
#include "cli/counters.h"

#include <string.h>

unsigned counters_known(void)
{
        unsigned n = 0;

        while (sl_counter_name(n))
                n++;
        return n;
}

const char *counters_known_name(unsigned i)
{
        return sl_counter_name(i);
}

unsigned counters_scope(const char *name)
{
        unsigned scope = name ? sl_counter_scope(name) : 0;

        return scope ? scope : COUNTERS_ALL;
}

unsigned counters_protocol_scope(const char *protocol)
{
        if (strcmp(protocol, "sharedlink") == 0)
                return COUNTERS_SHAREDLINK;
        if (strcmp(protocol, "circe") == 0)
                return COUNTERS_CIRCE;
        return COUNTERS_ALL;
}

unsigned counters_select(const struct sl_counter *in, unsigned n, unsigned scope,
                         const struct sl_counter **ret)
{
        unsigned got = 0;

        /* Two passes: the non-zero ones, then the zero ones. */
        for (int zero = 0; zero <= 1; zero++)
                for (unsigned i = 0; i < n; i++)
                        if ((in[i].value == 0) == zero && (counters_scope(in[i].name) & scope))
                                ret[got++] = &in[i];
        return got;
}
