/*
 * Counter scopes, from which code increments which counter (src/daemon/): link.c (the transport)
 * for every link, link_sharedlink.c for SharedLink, link_circe*.c for CIRCE, and the table's
 * outbound scan and event ring (src/shm/table.c) daemon-wide. tests/unit/test_counters.c checks
 * that every counter of the layout has a scope here, and tests/integration/test_slctl.c that the
 * real daemon moves no counter outside it.
 */
#include "cli/counters.h"

#include <string.h>

#define SL      COUNTERS_SHAREDLINK
#define CI      COUNTERS_CIRCE
#define LINKS   COUNTERS_LINKS
#define DAEMON  COUNTERS_DAEMON

static const struct {
        const char *name;
        unsigned scope;
} known[] = {
        { "frames_in", LINKS },
        { "frames_out", LINKS },
        { "bytes_in", LINKS },
        { "bytes_out", LINKS },
        { "noise_bytes", LINKS },
        { "bad_checksum", LINKS },
        { "resync", LINKS },
        { "overlong", LINKS },
        { "bad_address", SL },
        { "bad_field", LINKS },
        { "unknown_field", SL },
        { "empty_field", SL },
        { "list_mismatch", SL },
        { "unknown_peer", SL },
        { "not_for_us", SL },
        { "adhoc_full", LINKS },
        { "queries_in", SL },
        { "answers_out", SL },
        { "reopens", LINKS },
        { "io_errors", LINKS },
        { "bad_header", LINKS },
        { "unknown_op", CI },
        { "bad_value", LINKS },
        { "missing_param", CI },
        { "skipped_param", CI },
        { "repeated_param", CI },
        { "noncompliant_status", CI },
        { "log_messages", CI },
        { "tx_dropped", LINKS },
        { "queries_out", SL },
        { "answers_in", SL },
        { "timeouts", LINKS },
        { "out_accepted", DAEMON },
        { "out_invalid", DAEMON },
        { "out_busy", DAEMON },
        { "out_repaired", DAEMON },
        { "out_bad_object", DAEMON },
        { "out_recreated", DAEMON },
        { "events", DAEMON },
        { "declarations_in", SL },
        { "declarations_out", SL },
        { "acks_in", SL },
        { "learn_full", SL },
        { "learn_conflict", SL },
        { "bad_type", SL },
        { "type_mismatch", SL },
        { "undeclared_data", SL },
        { "redeclared", SL },
        { "commands_in", SL },
        { "commands_out", SL },
        { "bad_command", SL },
        { "udp_refused", LINKS },
};

#define NKNOWN (sizeof(known) / sizeof(known[0]))

unsigned counters_known(void)
{
        return NKNOWN;
}

const char *counters_known_name(unsigned i)
{
        return i < NKNOWN ? known[i].name : NULL;
}

unsigned counters_scope(const char *name)
{
        for (unsigned i = 0; name && i < NKNOWN; i++)
                if (strcmp(known[i].name, name) == 0)
                        return known[i].scope;
        return COUNTERS_ALL;
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
