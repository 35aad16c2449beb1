/*
 * The benchmarks' many-variable link (see benchlink.h).
 */
#include "common/benchlink.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "common/harness.h"
#include "common/wire.h"

#define NS_PER_S        1000000000ull

/* Appends printf output at *n, keeping count past the end (so a short buffer shows as n >= size). */
#define ADD(out, size, n, ...) \
        (*(n) += (size_t)snprintf((out) + (*(n) < (size) ? *(n) : (size)), \
                                  *(n) < (size) ? (size) - *(n) : 0, __VA_ARGS__))

size_t benchlink_config(char *out, size_t size, const char *instance, const char *device,
                        const char *var_type, const char *outbound)
{
        size_t n = 0;

        ADD(out, size, &n, "instance: %s\nlinks:\n  - name: peer\n    protocol: sharedlink\n"
            "    transport: serial\n    device: %s\n    address: %c\n    peers:\n", instance,
            device, BENCHLINK_DST);
        for (int p = 0; p < BENCHLINK_PEERS; p++) {
                ADD(out, size, &n, "      - address: %c\n        period_ms: 0\n"
                    "        on_change: true\n        min_interval_ms: 0\n"
                    "        max_frame: 4096\n", 'B' + p);
                if (p == 0 && outbound)
                        ADD(out, size, &n, "        outbound: [%s]\n", outbound);
                ADD(out, size, &n, "        inbound:\n");
                for (int i = p * BENCHLINK_PER_PEER; i < (p + 1) * BENCHLINK_PER_PEER; i++) {
                        if (var_type)
                                ADD(out, size, &n, "          - {name: v%d, type: %s}\n", i,
                                    var_type);
                        else
                                ADD(out, size, &n, "          - v%d\n", i);
                }
        }
        return n < size ? n : 0;
}

size_t benchlink_round_frame(char *out, int f, unsigned long long round)
{
        char body[BENCHLINK_FRAME_MAX];
        int first = f * BENCHLINK_PER_FRAME, peer = first / BENCHLINK_PER_PEER;
        size_t o = (size_t)snprintf(body, sizeof(body), "N%d", first - peer * BENCHLINK_PER_PEER);

        for (int k = 0; k < BENCHLINK_PER_FRAME; k++)
                o += (size_t)snprintf(body + o, sizeof(body) - o, "|D%llu", round);
        return wire_slp_frame(out, BENCHLINK_FRAME_MAX, BENCHLINK_DST, (char)('B' + peer), body,
                              true);
}

unsigned long long benchlink_offer(int fd, unsigned seconds, int wait_ms)
{
        static char frame[BENCHLINK_FRAME_MAX];
        uint64_t t0 = harness_now_ns();
        unsigned long long rounds = 0;

        while (harness_now_ns() - t0 < (uint64_t)seconds * NS_PER_S) {
                for (int f = 0; f < BENCHLINK_FRAMES; f++)
                        harness_write_all(fd, frame, benchlink_round_frame(frame, f, rounds),
                                          wait_ms);
                rounds++;
        }
        return rounds;
}
