/*
 * Stage timing: where the time of a path through the daemon goes, stage by stage, measured in
 * the daemon itself (the outbound path: client write -> wake thread -> poll loop -> frame sent).
 *
 * One pass is a row of CLOCK_MONOTONIC stamps, one per stage boundary; stage k lasted
 * stamps[k + 1] - stamps[k]. The last STAGES_RING passes are kept (a fixed ring, no allocation),
 * and the median, p99 and maximum of each stage are computed from them on request, so a
 * benchmark can read the daemon's own figures from the control socket (`stats`).
 *
 * Single-threaded: record and summarise from the loop's thread.
 */
#ifndef SHAREDLINK_DAEMON_STAGES_H
#define SHAREDLINK_DAEMON_STAGES_H

#include <stddef.h>
#include <stdint.h>

#define STAGES_MAX      3       /* stages per path */
#define STAGES_RING     4096    /* passes kept; older ones are overwritten */

struct stages {
        unsigned n;                             /* stages in use, 1..STAGES_MAX */
        uint64_t passes;                        /* recorded since stages_init() */
        uint64_t dropped;                       /* passes with a missing or backward stamp */
        uint32_t ns[STAGES_MAX][STAGES_RING];   /* durations, saturated at UINT32_MAX */
};

/* Figures of one stage over the passes kept. */
struct stages_summary {
        size_t samples;                 /* passes they are computed from (<= STAGES_RING) */
        uint32_t p50_ns, p99_ns, max_ns;
};

/* Empties s for n stages (clamped to 1..STAGES_MAX). */
void stages_init(struct stages *s, unsigned n);

/* Records one pass from stamps[0 .. n] (n + 1 stamps). A pass with a zero stamp or one earlier
 * than the stamp before it is not a pass through these stages (a write picked up by a scan that
 * answered an earlier wake-up, say): it is only counted in `dropped`. */
void stages_record(struct stages *s, const uint64_t *stamps);

/* The figures of stage k; 0, -EINVAL (k out of range) or -ENODATA (no pass yet). */
int stages_summary(const struct stages *s, unsigned k, struct stages_summary *ret_summary);

#endif
