/*
 * read_latency: what sl_read costs a program built the ordinary way, against a running daemon.
 *
 *     cc -O2 read_latency.c $(pkg-config --cflags --libs sharedlink) -o read_latency
 *     cc -O2 read_latency.c $(pkg-config --cflags --libs --static sharedlink) -static-libgcc \
 *         -Wl,-Bstatic -lsharedlink -Wl,-Bdynamic -o read_latency_static    # against the .a
 *     ./read_latency [-i INSTANCE] [-r ROUNDS] [-n CALLS] NAME...
 *
 * For each variable: ROUNDS (default 7) rounds of CALLS (default 1000000) sl_read calls with
 * metadata, and as many without, interleaved; prints the best round and the median of the rounds
 * in ns per call. Only the public header is used. `make bench` builds it against a temporary
 * `make install` and runs it against a daemon of its own (tests/bench/bench_install.sh).
 */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sharedlink.h>

#define ROUNDS_DEFAULT  7
#define ROUNDS_MAX      101
#define CALLS_DEFAULT   1000000L
#define NS_PER_S        1000000000.0

static double now_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (double)ts.tv_sec * NS_PER_S + (double)ts.tv_nsec;
}

/* One round: ns per sl_read call; < 0 when a read failed. */
static double round_ns(struct sl_client *c, int id, long calls, int with_meta)
{
        struct sl_meta meta = { .size = sizeof(meta) };
        char buf[128];
        double t0 = now_ns();
        long sum = 0;

        for (long i = 0; i < calls; i++) {
                int r = sl_read(c, id, buf, sizeof(buf), with_meta ? &meta : NULL);

                if (r < 0)
                        return -1;
                sum += r;
        }
        return sum >= 0 ? (now_ns() - t0) / (double)calls : -1;
}

static int cmp_double(const void *a, const void *b)
{
        double x = *(const double *)a, y = *(const double *)b;

        return (x > y) - (x < y);
}

static int usage(void)
{
        fprintf(stderr, "usage: read_latency [-i INSTANCE] [-r ROUNDS] [-n CALLS] NAME...\n");
        return 2;
}

int main(int argc, char **argv)
{
        const char *instance = NULL;
        int rounds = ROUNDS_DEFAULT, opt, r;
        long calls = CALLS_DEFAULT;
        struct sl_client *c;

        while ((opt = getopt(argc, argv, "i:r:n:")) != -1) {
                if (opt == 'i')
                        instance = optarg;
                else if (opt == 'r')
                        rounds = atoi(optarg);
                else if (opt == 'n')
                        calls = atol(optarg);
                else
                        return usage();
        }
        if (optind >= argc || rounds < 1 || rounds > ROUNDS_MAX || calls < 1)
                return usage();
        r = sl_open(instance, &c);
        if (r < 0) {
                fprintf(stderr, "read_latency: %s\n", sl_strerror(r));
                return 1;
        }
        printf("%-36s %10s %10s   (ns per call, %d rounds of %ld)\n", "sl_read", "best",
               "median", rounds, calls);
        for (int a = optind; a < argc; a++) {
                double t[2][ROUNDS_MAX];
                int id = sl_find(c, argv[a]);

                if (id < 0) {
                        fprintf(stderr, "read_latency: %s: %s\n", argv[a], sl_strerror(id));
                        sl_close(c);
                        return 1;
                }
                round_ns(c, id, calls / 10 + 1, 1);     /* warm up */
                for (int i = 0; i < rounds; i++) {
                        t[0][i] = round_ns(c, id, calls, 1);
                        t[1][i] = round_ns(c, id, calls, 0);
                        if (t[0][i] < 0 || t[1][i] < 0) {
                                fprintf(stderr, "read_latency: %s: a read failed\n", argv[a]);
                                sl_close(c);
                                return 1;
                        }
                }
                for (int k = 0; k < 2; k++) {
                        char what[96];

                        qsort(t[k], (size_t)rounds, sizeof(double), cmp_double);
                        snprintf(what, sizeof(what), "%s, %s", argv[a],
                                 k == 0 ? "with metadata" : "without metadata");
                        printf("%-36s %10.1f %10.1f\n", what, t[k][0], t[k][rounds / 2]);
                }
        }
        sl_close(c);
        return 0;
}
