/*
 * The benchmarks' many-variable link: a sharedlinkd configuration with one SharedLink link on a
 * serial device (the slave of a pty whose master the benchmark holds, playing the peer) and
 * BENCHLINK_VARS inbound variables v0..v999 spread over BENCHLINK_PEERS peers (the daemon takes
 * at most 256 inbound per list), and the rounds of frames that change every one of them. Used by
 * bench_mqtt and bench_ros2, so both bridges are driven by the same input.
 */
#pragma once

#include <stddef.h>

#define BENCHLINK_VARS          1000
#define BENCHLINK_PEERS         4
#define BENCHLINK_PER_PEER      (BENCHLINK_VARS / BENCHLINK_PEERS)
#define BENCHLINK_PER_FRAME     125     /* values per frame of a round */
#define BENCHLINK_FRAMES        (BENCHLINK_VARS / BENCHLINK_PER_FRAME)
#define BENCHLINK_FRAME_MAX     2048
#define BENCHLINK_DST           'A'     /* the daemon's address; peers are 'B' + p */

/* Writes the daemon's configuration into out (size bytes): instance, the link on device, the
 * variables of type var_type ("long", "double"; NULL: untyped, i.e. string) and, when outbound
 * is not NULL, that one outbound variable on the first peer. The length, or 0 if it did not fit. */
size_t benchlink_config(char *out, size_t size, const char *instance, const char *device,
                        const char *var_type, const char *outbound);

/* Frame f (0 .. BENCHLINK_FRAMES-1) of round `round`: BENCHLINK_PER_FRAME values "round" from
 * peer 'B' + f's peer, into out (BENCHLINK_FRAME_MAX bytes). The length. */
size_t benchlink_round_frame(char *out, int f, unsigned long long round);

/* Writes whole rounds of frames into the pty master fd for `seconds` (each write may wait up to
 * wait_ms for room); returns the number of rounds written. */
unsigned long long benchlink_offer(int fd, unsigned seconds, int wait_ms);
