/*
 * Which counters mean something where: the library reports every named counter (39) for every
 * link and for the daemon, most of them always 0 there because no code of that protocol moves
 * them. slctl stats shows the ones that apply, non-zero first (--all: every one).
 */
#ifndef SLCTL_COUNTERS_H
#define SLCTL_COUNTERS_H

#include <sharedlink.h>

/* Scope bits: where a counter is moved. */
#define COUNTERS_SHAREDLINK     0x1u    /* by SharedLink links */
#define COUNTERS_CIRCE          0x2u    /* by CIRCE links */
#define COUNTERS_DAEMON         0x4u    /* daemon-wide (the outbound table, the event ring) */
#define COUNTERS_LINKS          (COUNTERS_SHAREDLINK | COUNTERS_CIRCE)
#define COUNTERS_ALL            (COUNTERS_LINKS | COUNTERS_DAEMON)

/* Number of counters this slctl knows the scope of. */
unsigned counters_known(void);

/* Name of known counter i (0..counters_known()-1), or NULL. */
const char *counters_known_name(unsigned i);

/* Scope bits of the counter called name; COUNTERS_ALL for one this slctl does not know (a newer
 * library's), so that it is shown rather than hidden. */
unsigned counters_scope(const char *name);

/* Scope of a link speaking protocol; COUNTERS_ALL for a protocol this slctl does not know. */
unsigned counters_protocol_scope(const char *protocol);

/* Puts into ret (room for n) the counters of in[0..n-1] whose scope meets scope: the non-zero
 * ones first, then the zero ones, each group in the library's order. Returns how many. */
unsigned counters_select(const struct sl_counter *in, unsigned n, unsigned scope,
                         const struct sl_counter **ret);

#endif
