/*
 * SharedLink link session: the protocol logic of one SharedLink link (link_sharedlink.h says
 * what it promises), with no file descriptor, timer or shm table of its own. It is fed received
 * bytes, client writes, queries and the time, and acts through the hooks below: send a frame,
 * find or add a variable, read or publish a value, mark one stale, raise an event, count. So the
 * fuzzer (tests/fuzz/fuzz_sharedlink_session.c) and the unit tests
 * (tests/unit/test_link_sharedlink_session.c) drive it with any input and any clock.
 *
 * The engine (link_sharedlink.c) wires the hooks to the channel, the table and the control
 * socket, and calls tick() once the time deadline() asks for has come.
 *
 * The session owns: the peers' outbound and inbound lists and their positional mapping, every
 * per-peer schedule as a deadline (period, full refresh under compression, the on-change rate
 * limit and its retry, stale after silence), the pending queries with their timeouts, inbound
 * apply (N, D, R, Q, P, G), ad hoc variables, reply packing and every counter, by reason; and,
 * for a peer with dialect pronto4 (docs/pronto4.md, in link_sharedlink_pronto4.c, which reads
 * frames through src/proto/pronto4.c; both share link_sharedlink_peers.c): declarations
 * (sent, or learned into variables), acknowledgements, list queries, self-describing frames, E
 * and MU commands as events, type checks, whole-list data and the host's connect sequence.
 *
 * Time is CLOCK_MONOTONIC in milliseconds; LINK_SHAREDLINK_NEVER means "no deadline".
 */
#ifndef SHAREDLINK_DAEMON_LINK_SHAREDLINK_SESSION_H
#define SHAREDLINK_DAEMON_LINK_SHAREDLINK_SESSION_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daemon/config.h"
#include "daemon/link_sharedlink_hooks.h"

/*
 * Creates the session of a SharedLink link (cfg must outlive it), resolving each configured
 * list entry through find(). It starts down: call up() when the channel is open. 0, -EINVAL (not
 * a SharedLink link), -ENOENT (a configured variable is unknown to find()) or -ENOMEM.
 */
int link_sharedlink_session_new(const struct config_link *cfg, bool datagram,
                                const struct link_sharedlink_hooks *hooks, void *arg,
                                struct link_sharedlink_session **ret_session);

/* Ends every pending query with ECANCELED through answer(), frees. NULL ok; returns NULL. */
struct link_sharedlink_session *link_sharedlink_session_free(struct link_sharedlink_session *s);

/* The channel is open: every peer gets its full list, periods start. */
void link_sharedlink_session_up(struct link_sharedlink_session *s, uint64_t now_ms);

/* The channel closed: schedules stop, sent queries end with ENOTCONN. (The engine marks the
 * link's variables stale: that is one table call for all of them.) */
void link_sharedlink_session_down(struct link_sharedlink_session *s, uint64_t now_ms);

/* Bytes from the channel (a whole datagram when the session was made with datagram true);
 * ignored while down. */
void link_sharedlink_session_input(struct link_sharedlink_session *s, uint64_t now_ms,
                                   const uint8_t *data, size_t len);

/* A client wrote value to outbound variable id (ignored when it is not in one of the lists). */
void link_sharedlink_session_outbound(struct link_sharedlink_session *s, uint64_t now_ms,
                                      uint32_t id, const char *value);

/* The index of the configured peer at address (one letter), or -1. */
int link_sharedlink_session_peer(const struct link_sharedlink_session *s, const char *address);

/*
 * Sends Q<name> to peer (an index from link_sharedlink_session_peer()) and follows the answer
 * for timeout_ms; answer(token) is called once later. Returns 0, or -ENOTCONN (down), -EBUSY
 * (LINK_SHAREDLINK_QUERIES_MAX pending; queries whose client left are ended first to make room),
 * -EINVAL (bad peer or name), -EMSGSIZE (the Q frame is longer than the peer's max_frame) or
 * the send error, with nothing pending.
 */
int link_sharedlink_session_query(struct link_sharedlink_session *s, uint64_t now_ms,
                                  void *token, int peer, const char *name, unsigned timeout_ms);

/*
 * Sends the command E<module>|D<text> to peer (an index from link_sharedlink_session_peer()),
 * or to every pronto4 peer when peer is -1. Returns 0, -EOPNOTSUPP (no such pronto4 peer),
 * -EINVAL (a bad peer index, module or text: slp_encode_command()), -ENOTCONN (down) or the
 * send error.
 */
int link_sharedlink_session_command(struct link_sharedlink_session *s, uint64_t now_ms, int peer,
                                    const char *module, const char *text);

/* Sends the ping P0 to peer (an index from link_sharedlink_session_peer()); its G0 comes to the
 * pong hook. 0, -EINVAL (a bad peer index), -ENOTCONN (down) or the send error. */
int link_sharedlink_session_ping(struct link_sharedlink_session *s, int peer);

/* Handles every deadline that has passed. */
void link_sharedlink_session_tick(struct link_sharedlink_session *s, uint64_t now_ms);

/* The earliest pending deadline, or LINK_SHAREDLINK_NEVER. */
uint64_t link_sharedlink_session_deadline(const struct link_sharedlink_session *s);

/* Whether up() was called last (rather than down()). */
bool link_sharedlink_session_is_up(const struct link_sharedlink_session *s);

#endif
