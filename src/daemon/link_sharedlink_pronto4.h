/*
 * The Pronto4 dialect of a SharedLink link session (docs/pronto4.md), a private header: what a
 * pronto4 peer adds to the session (declarations and their learning, the acknowledgement, list
 * queries, self-describing frames, commands, the host's connect sequence and the type checks).
 *
 * The seam: link_sharedlink_session.c calls sls_p4_*() at five points (a frame from a pronto4
 * peer, the link coming up, a deadline, a client write, a command to send); the dialect reads
 * each frame once through p4_decode() (src/proto/pronto4.c) and acts through the helpers of
 * link_sharedlink_peers.h. It never calls the session back.
 */
#ifndef SHAREDLINK_DAEMON_LINK_SHAREDLINK_PRONTO4_H
#define SHAREDLINK_DAEMON_LINK_SHAREDLINK_PRONTO4_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/link_sharedlink_peers.h"

/* Handles a frame from pronto4 peer p; false when it is bulletin traffic (data, ping, R|D ...)
 * for the session's field walk (which then checks types through sls_p4_value_ok()). */
bool sls_p4_frame(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now,
                  const struct slp_frame *f);

/* The host's connect sequence to p (E SetIP, outbound on, inbound on, the N0 and L0
 * declarations), each frame its own datagram. */
void sls_p4_connect(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now);

/* link_sharedlink_session_command(): E<module>|D<text> to pronto4 peer `peer`, or to every one
 * (-1); the same returns. */
int sls_p4_command(struct link_sharedlink_session *s, int peer, const char *module,
                   const char *text);

/* Whether a received value fits the type of position pos of p's inbound list (counted
 * type_mismatch when not). */
bool sls_p4_value_ok(struct link_sharedlink_session *s, const struct sls_peer *p, size_t pos,
                     const char *value, size_t len);

/* A client's value for position pos of p's outbound list, checked against its type and put in
 * its shortest form (a long double text) into out[SHM_VALUE_SIZE]; false (counted
 * type_mismatch) when it must not be sent. */
bool sls_p4_outbound_value(struct link_sharedlink_session *s, const struct sls_peer *p,
                           size_t pos, const char *value, char *out);

/* The slp type of a configured entry. */
enum slp_type sls_p4_type_of(enum config_var_type type);

#endif
