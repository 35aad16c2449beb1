/*
 * Prints what the C compiler makes of include/sharedlink.h: every public struct's size and each
 * member's offset, and the constants. python/tests/test_layout.py compares the ctypes mirror in
 * python/sharedlink/_lib.py with this, member by member, so the two cannot drift apart.
 *
 * Output: one "size STRUCT N", "offset STRUCT.MEMBER N" or "const NAME VALUE" per line.
 */
#include <stddef.h>
#include <stdio.h>

#include <sharedlink.h>

#define SIZE(s)         printf("size %s %zu\n", #s, sizeof(struct s))
#define OFF(s, m)       printf("offset %s.%s %zu\n", #s, #m, offsetof(struct s, m))
#define CONST(c)        printf("const %s %lld\n", #c, (long long)(c))
#define CONST_STR(c)    printf("const %s %s\n", #c, c)

static void structs(void)
{
        SIZE(sl_meta);
        OFF(sl_meta, size); OFF(sl_meta, mono_ns); OFF(sl_meta, real_ns); OFF(sl_meta, age_ns);
        OFF(sl_meta, sequence); OFF(sl_meta, flags);

        SIZE(sl_var_info);
        OFF(sl_var_info, size); OFF(sl_var_info, name); OFF(sl_var_info, direction);
        OFF(sl_var_info, type); OFF(sl_var_info, link); OFF(sl_var_info, peer);
        OFF(sl_var_info, position); OFF(sl_var_info, flags);

        SIZE(sl_counter);
        OFF(sl_counter, name); OFF(sl_counter, value);

        SIZE(sl_link_info);
        OFF(sl_link_info, size); OFF(sl_link_info, name); OFF(sl_link_info, protocol);
        OFF(sl_link_info, state); OFF(sl_link_info, state_name); OFF(sl_link_info, state_age_ns);
        OFF(sl_link_info, counter_count); OFF(sl_link_info, counters);
        OFF(sl_link_info, state_text);

        SIZE(sl_daemon_info);
        OFF(sl_daemon_info, size); OFF(sl_daemon_info, pid); OFF(sl_daemon_info, alive);
        OFF(sl_daemon_info, epoch); OFF(sl_daemon_info, heartbeat_age_ns);
        OFF(sl_daemon_info, heartbeat_interval_ms); OFF(sl_daemon_info, started_real_ns);
        OFF(sl_daemon_info, counter_count); OFF(sl_daemon_info, counters);

        SIZE(sl_wait_opts);
        OFF(sl_wait_opts, size); OFF(sl_wait_opts, flags); OFF(sl_wait_opts, spin_us);
        SIZE(sl_event);
        OFF(sl_event, size); OFF(sl_event, seq); OFF(sl_event, lost); OFF(sl_event, mono_ns);
        OFF(sl_event, real_ns); OFF(sl_event, type); OFF(sl_event, type_name);
        OFF(sl_event, link); OFF(sl_event, link_name); OFF(sl_event, flags);
        OFF(sl_event, text);

        SIZE(sl_circe_visualize);
        OFF(sl_circe_visualize, size); OFF(sl_circe_visualize, dests);
        OFF(sl_circe_visualize, dest_count); OFF(sl_circe_visualize, has_current);
        OFF(sl_circe_visualize, current); OFF(sl_circe_visualize, has_next);
        OFF(sl_circe_visualize, next); OFF(sl_circe_visualize, start_timer);
        OFF(sl_circe_visualize, has_primary); OFF(sl_circe_visualize, primary_ms);
        OFF(sl_circe_visualize, has_secondary); OFF(sl_circe_visualize, secondary_ms);
        OFF(sl_circe_visualize, has_faults); OFF(sl_circe_visualize, faults);
        OFF(sl_circe_visualize, has_refusals); OFF(sl_circe_visualize, refusals);
        OFF(sl_circe_visualize, has_eliminated); OFF(sl_circe_visualize, eliminated);
        OFF(sl_circe_visualize, has_placement); OFF(sl_circe_visualize, placement);
}

static void constants(void)
{
        CONST(SL_NAME_SIZE); CONST(SL_VALUE_SIZE); CONST(SL_PEER_SIZE); CONST(SL_LINK_NAME_SIZE);
        CONST(SL_WRITE_REASON_SIZE);
        CONST(SL_PROTOCOL_SIZE); CONST(SL_STATE_NAME_SIZE); CONST(SL_STATE_TEXT_SIZE); CONST(SL_TYPE_NAME_SIZE);
        CONST(SL_EVENT_TEXT_SIZE); CONST(SL_COUNTERS_MAX);
        CONST(SL_DIR_IN); CONST(SL_DIR_OUT);
        CONST(SL_VAR_STRING); CONST(SL_VAR_LONG); CONST(SL_VAR_DOUBLE); CONST(SL_VAR_ADHOC);
        CONST(SL_FLAG_VALID); CONST(SL_FLAG_STALE); CONST(SL_FLAG_OUTBOUND);
        CONST(SL_FLAG_REPAIRED);
        CONST(SL_EVENT_TRUNCATED); CONST(SL_EVENT_RESTARTED);
        CONST(SL_WAIT_SPIN); CONST(SL_WAIT_SPIN_MAX_US); CONST(SL_READ_BUSY_MS);
        CONST(SL_CHANGED_ALL); CONST(SL_CHANGED_START); CONST(SL_CHANGED_OVERRUN);
        CONST(SL_CHANGED_REMAPPED); CONST(SL_CHANGED_UNAVAILABLE); CONST(SL_CHANGED_MORE);
        CONST(SL_COUNTER_SHAREDLINK); CONST(SL_COUNTER_CIRCE); CONST(SL_COUNTER_DAEMON);
        CONST_STR(SL_RUNTIME_DIR_DEFAULT);
        CONST(SL_REQUEST_LINE_MAX); CONST(SL_REQUEST_WORDS_MAX); CONST(SL_REPLY_LINE_MAX);
        CONST(SL_REQUEST_TIMEOUT_MS); CONST(SL_WAIT_MAX_MS); CONST(SL_QUERY_TIMEOUT_MAX_MS);
        CONST(SL_CIRCE_ADDRESS_SIZE); CONST(SL_CIRCE_DESTS_MAX); CONST(SL_COMMAND_TEXT_MAX);
        CONST(SL_COMMAND_WORDS_MAX);
}

int main(void)
{
        structs();
        constants();
        return fflush(stdout) == 0 ? 0 : 1;
}
