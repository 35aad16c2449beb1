/*
 * Which counters mean something where: the library reports every named counter for every
 * link and for the daemon, most of them always 0 there because no code of that protocol moves
 * them. slctl stats shows the ones that apply, non-zero first (--all: every one).
 */
#ifndef SLCTL_COUNTERS_H
#define SLCTL_COUNTERS_H

#include <sharedlink.h>

/* Scope bits: where a counter is moved (the library's SL_COUNTER_*). */
#define COUNTERS_SHAREDLINK     SL_COUNTER_SHAREDLINK
#define COUNTERS_CIRCE          SL_COUNTER_CIRCE
#define COUNTERS_DAEMON         SL_COUNTER_DAEMON
#define COUNTERS_LINKS          (COUNTERS_SHAREDLINK | COUNTERS_CIRCE)
#define COUNTERS_ALL            (COUNTERS_LINKS | COUNTERS_DAEMON)

/* Number of counters the library names (and knows the scope of). */
unsigned counters_known(void);

/* Name of known counter i (0..counters_known()-1), or NULL. */
const char *counters_known_name(unsigned i);

/* Scope bits of the counter called name; COUNTERS_ALL for one the library does not know (a
 * newer daemon's), so that it is shown rather than hidden. */
unsigned counters_scope(const char *name);

/* Scope of a link speaking protocol; COUNTERS_ALL for a protocol this slctl does not know. */
unsigned counters_protocol_scope(const char *protocol);

/* Puts into ret (room for n) the counters of in[0..n-1] whose scope meets scope: the non-zero
 * ones first, then the zero ones, each group in the library's order. Returns how many. */
unsigned counters_select(const struct sl_counter *in, unsigned n, unsigned scope,
                         const struct sl_counter **ret);

#endif
