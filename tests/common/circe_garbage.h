/*
 * The bad input both CIRCE controller tests send (the engine in process,
 * tests/unit/test_link_circe.c, and the real daemon, tests/integration/test_circe.c), so that
 * both check the very same bytes against the same counts: noise, a bad and a lowercase
 * checksum, no checksum, an unknown operation, bad values, a missing, a repeated and a skipped
 * parameter, a second STX, an overlong packet, non-compliant statuses, an operation of the
 * controller's own; valid Notify Actions (devices A0000n) in between. Built with wire.h.
 */
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "proto/circe.h"

#define CIRCE_GARBAGE_STEPS     24      /* writes, each of circe_garbage_bytes() */
#define CIRCE_GARBAGE_STEP_MAX  (CIRCE_PACKET_MAX + 16)         /* bytes of the largest */
#define CIRCE_GARBAGE_COUNTERS  11

struct circe_garbage_count {
        const char *counter;            /* as in `slctl stats --json` */
        uint64_t value;
};

/* The link's counters once every step has landed after one Keep Alive of the mediator (which
 * frames_in includes). */
extern const struct circe_garbage_count circe_garbage_counts[CIRCE_GARBAGE_COUNTERS];

/* The bytes of step i (0 .. CIRCE_GARBAGE_STEPS - 1) into out (CIRCE_GARBAGE_STEP_MAX); the
 * length. */
size_t circe_garbage_bytes(unsigned i, uint8_t *out, size_t size);
