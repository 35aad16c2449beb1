/*
 * The C side of tests/bench/python_read.py: ns per sl_read and sl_read_double of one variable
 * of a running daemon, through libsharedlink.so.1 as the Python binding calls it (dynamically
 * linked, by id, no meta). Best (lowest) mean of BEST_OF rounds: other work only adds time.
 *
 *     read_loop INSTANCE NAME ROUNDS    prints "sl_read NS" and "sl_read_double NS"
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include <sharedlink.h>

#define BEST_OF 5

static double now_ns(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

int main(int argc, char **argv)
{
        struct sl_client *c;
        char buf[SL_VALUE_SIZE];
        double best_read = 1e30, best_double = 1e30, v, sink = 0;
        long rounds;
        int id, r;

        if (argc != 4 || (rounds = strtol(argv[3], NULL, 10)) <= 0) {
                fprintf(stderr, "usage: read_loop INSTANCE NAME ROUNDS\n");
                return 2;
        }
        r = sl_open(argv[1], &c);
        if (r < 0 || (id = sl_find(c, argv[2])) < 0 || sl_read_double(c, id, &v, NULL) < 0) {
                fprintf(stderr, "read_loop: %s: %s\n", argv[2], sl_strerror(r < 0 ? r : -2));
                return 1;
        }
        for (int b = 0; b < BEST_OF; b++) {
                double t0 = now_ns(), t1, t2;

                for (long i = 0; i < rounds; i++)
                        sink += sl_read(c, id, buf, sizeof(buf), NULL);
                t1 = now_ns();
                for (long i = 0; i < rounds; i++) {
                        sl_read_double(c, id, &v, NULL);
                        sink += v;
                }
                t2 = now_ns();
                if ((t1 - t0) / (double)rounds < best_read)
                        best_read = (t1 - t0) / (double)rounds;
                if ((t2 - t1) / (double)rounds < best_double)
                        best_double = (t2 - t1) / (double)rounds;
        }
        printf("sl_read %.1f\nsl_read_double %.1f\n", best_read, best_double);
        sl_close(c);
        return sink == 0 ? 1 : 0;      /* the reads produced something: keeps them in the loop */
}
