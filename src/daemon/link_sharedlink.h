/*
 * SharedLink link engine (PROTOCOLS.md §1): keeps the outbound lists of a link's peers on the
 * wire and their inbound lists in the shm table. The core drives it through struct link_ops
 * (link.h); everything else in link_sharedlink.c is static.
 *
 * Behaviour, beyond what PROTOCOLS.md fixes (these are the engine's decisions):
 *
 * Sending, per peer
 *   - Every period_ms (0: never) the whole outbound list goes out, split by slp_encode_list() into
 *     frames of at most max_frame bytes (CR LF included on byte streams; UDP frames carry no CR
 *     LF). With compression, a position goes as an empty D unless a client wrote it since it was
 *     last sent to this peer; every refresh_ms / period_ms periods (at least 1) the list goes
 *     full. The cadence counts periods, not wall time, so it is exact under load.
 *   - on_change: a client write is sent at once as a frame covering the written positions
 *     ("N<first>|D..|D<last>", unwritten positions in between empty with compression). At most
 *     one such frame per min_interval_ms: writes inside the interval are sent together when it
 *     ends, the last value of each. Nothing is ever dropped: a frame the channel refuses leaves
 *     its positions pending and is retried.
 *   - When the channel comes up (first open or reopen), every peer gets its full list at once.
 *   - Values never written by a client go as empty D (the wire cannot tell "" from unchanged).
 *
 * Receiving
 *   - Counters (shm link counters): frames_in counts every frame with a valid checksum;
 *     not_for_us and unknown_peer count those among them that are then ignored. Decoder
 *     rejections: noise_bytes (bytes), bad_checksum (also a missing or malformed checksum
 *     field), resync (also a frame cut short by the end of a datagram), overlong (also a frame
 *     longer than its peer's max_frame), bad_header, bad_address, bad_field (also "only a
 *     checksum", and an R not followed by its D). unknown_field counts every field skipped: an
 *     unknown letter, and the Pronto4 fields T, L, E, N?, with what belongs to them (the Q of a
 *     declaration "T<n>|Q<name>", a D after E, D fields after L or N? until the next N).
 *     empty_field counts "||". list_mismatch counts each D beyond the inbound list. bad_value
 *     counts values that cannot be stored (longer than 63 bytes) or names that cannot be
 *     answered or stored.
 *   - A D field with a value sets the variable and makes it fresh; an empty D changes nothing
 *     (not even the stale flag: after an outage, values become fresh at the peer's next full
 *     refresh). All D fields of one frame are published as one batch (one change-word bump).
 *   - Stale: a peer's inbound variables (configured and ad hoc) are marked stale when nothing
 *     came from it for stale_ms (0: never), and every inbound variable of the link is marked
 *     stale when the link goes down, and at start until the peer is heard.
 *   - Q<name> is answered R<name>|D<value> with the value of the instance's variable of that
 *     name as published in the table (so: this link's outbound variable, else any variable), or
 *     an empty D for an unknown name. Answers (and the pong G<v> to a ping P<v>) to one frame are
 *     packed into as few frames as max_frame allows.
 *   - R<name>|D<value> goes to this peer's configured inbound variable called <name>; else to
 *     the ad hoc inbound variable "<link>.<peer>.<name>" (e.g. "vehicle.A.Foo"), created on
 *     first use (event adhoc-variable). The prefix keeps ad hoc names of different links and
 *     peers apart and away from configured names. When that name is taken by a variable that is
 *     not this peer's ad hoc variable, or the table's ad hoc room is used up, or the link's
 *     own bound LINK_SHAREDLINK_ADHOC_MAX is reached, the value is dropped and counted
 *     (adhoc_full);
 *     a name that makes an invalid variable name (too long, bad bytes) counts as bad_value.
 *
 * Link state (shm link state, and a link-state event on every change of the state number):
 *   LINK_SHAREDLINK_STATE_CONNECTING "connecting", LINK_SHAREDLINK_STATE_UP "up",
 *   LINK_SHAREDLINK_STATE_DOWN "down: <reason>" (cut to fit), LINK_SHAREDLINK_STATE_STOPPED
 *   "stopped" (destroy()).
 *
 * Control: "query LINK PEER NAME [TIMEOUT_MS] [wait=MS]" sends Q<NAME> to PEER and replies
 * "OK <value>" when R<NAME>|D<value> comes back from that peer (an empty value replies "OK "
 * followed by nothing), "ERR ETIMEDOUT" after TIMEOUT_MS (default 1000, at most 60000),
 * "ERR ENOTCONN" when the link is down (or goes down before the answer; with wait=MS, when it
 * is not up within MS), "ERR EINVAL" for a peer that is not configured, a bad name or number,
 * "ERR EBUSY" when LINK_SHAREDLINK_QUERIES_MAX queries are pending (or LINK_WAITQ_MAX wait for
 * the link), "ERR ECANCELED" when the engine is destroyed. Each answer to a pending query is
 * also a query-answer event ("peer=A name=X value=V", the value last and possibly with spaces).
 */
#ifndef SHAREDLINK_DAEMON_LINK_SHAREDLINK_H
#define SHAREDLINK_DAEMON_LINK_SHAREDLINK_H

#include "daemon/link.h"
#include "daemon/link_sharedlink_session.h"

#define LINK_SHAREDLINK_QUERY_TIMEOUT_MS        1000    /* default answer timeout of a query */
#define LINK_SHAREDLINK_QUERY_TIMEOUT_MAX_MS    60000   /* largest TIMEOUT_MS */

/* The shm link state numbers (sl_link_info().state); 0 is the core's "failed" (no engine). */
enum link_sharedlink_state {
        LINK_SHAREDLINK_STATE_CONNECTING = 1,
        LINK_SHAREDLINK_STATE_UP = 2,
        LINK_SHAREDLINK_STATE_DOWN = 3,
        LINK_SHAREDLINK_STATE_STOPPED = 4,
};

/* The SharedLink engine's operations (link_ops_for(CONFIG_PROTOCOL_SHAREDLINK)). */
extern const struct link_ops link_sharedlink_ops;

#endif
