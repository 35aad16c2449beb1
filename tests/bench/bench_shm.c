/*
 * Costs of the shared-memory hot paths, measured side by side in one run: a plain copy of a slot
 * (baseline), the bounded seqlock read of a slot, sl_read (lock, id, seqlock, meta), sl_write,
 * and an inbound publish (set + commit with its FUTEX_WAKE). Prints ns per operation and ratios.
 */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sharedlink.h>

#include "shm/slot.h"
#include "shm/table.h"

#define ROUNDS          2000000u
#define NS_PER_S        1000000000.0

static double now_s(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (double)ts.tv_sec + (double)ts.tv_nsec / NS_PER_S;
}

int main(void)
{
        static const struct shm_var vars[] = {
                { "In", SHM_DIR_IN, SHM_TYPE_DOUBLE, SHM_LINK_NONE, NULL, SHM_POSITION_NONE },
                { "Out", SHM_DIR_OUT, SHM_TYPE_DOUBLE, SHM_LINK_NONE, NULL, SHM_POSITION_NONE },
        };
        struct shm_table_config cfg = { .vars = vars, .nvars = 2 };
        struct sl_meta meta = { .size = sizeof(meta) };
        struct shm_slot *slot = aligned_alloc(64, sizeof(*slot));
        struct shm_slot_copy copy;
        struct shm_slot plain;
        struct shm_table *t;
        struct sl_client *c;
        char instance[64], buf[SL_VALUE_SIZE];
        double t0, base, seq, rd, rdm, wr, pub;
        volatile uint64_t sink = 0;

        snprintf(instance, sizeof(instance), "bench-%d", (int)getpid());
        cfg.instance = instance;
        if (shm_table_create(&cfg, &t) < 0 || sl_open(instance, &c) < 0) {
                fprintf(stderr, "bench_shm: cannot create the tables\n");
                return 1;
        }
        shm_table_set_str(t, 0, "40.12345678901234567890123456789");
        memset(slot, 0, sizeof(*slot));
        shm_slot_write(slot, "40.12345678901234567890123456789", 32, SHM_SLOT_VALID, 1, 1);

        t0 = now_s();
        for (unsigned i = 0; i < ROUNDS; i++) {
                /* The barriers keep the compiler from skipping or hoisting the copy. */
                __asm__ __volatile__("" : : "r"(slot) : "memory");
                memcpy(&plain, (const void *)(uintptr_t)slot, sizeof(plain));
                __asm__ __volatile__("" : : "r"(&plain) : "memory");
        }
        base = (now_s() - t0) / ROUNDS * NS_PER_S;
        t0 = now_s();
        for (unsigned i = 0; i < ROUNDS; i++) {
                shm_slot_read(slot, &copy);
                sink += copy.length;
        }
        seq = (now_s() - t0) / ROUNDS * NS_PER_S;
        t0 = now_s();
        for (unsigned i = 0; i < ROUNDS; i++)
                sink += (uint64_t)sl_read(c, 0, buf, sizeof(buf), NULL);
        rd = (now_s() - t0) / ROUNDS * NS_PER_S;
        t0 = now_s();
        for (unsigned i = 0; i < ROUNDS; i++)
                sink += (uint64_t)sl_read(c, 0, buf, sizeof(buf), &meta);
        rdm = (now_s() - t0) / ROUNDS * NS_PER_S;
        t0 = now_s();
        for (unsigned i = 0; i < ROUNDS / 10u; i++)
                sink += (uint64_t)sl_write(c, 1, "0.25");
        wr = (now_s() - t0) / (ROUNDS / 10u) * NS_PER_S;
        t0 = now_s();
        for (unsigned i = 0; i < ROUNDS / 10u; i++) {
                shm_table_begin(t);
                shm_table_set(t, 0, "41.5", 4);
                shm_table_commit(t);
        }
        pub = (now_s() - t0) / (ROUNDS / 10u) * NS_PER_S;

        printf("plain slot copy        %8.1f ns\n", base);
        printf("seqlock slot read      %8.1f ns   %.2fx plain\n", seq, seq / base);
        printf("sl_read                %8.1f ns   %.2fx plain\n", rd, rd / base);
        printf("sl_read with meta      %8.1f ns   %.2fx plain (+ clock_gettime)\n", rdm, rdm / base);
        printf("sl_write (+FUTEX_WAKE) %8.1f ns   %.2fx sl_read\n", wr, wr / rd);
        printf("publish (set+commit)   %8.1f ns   %.2fx sl_read\n", pub, pub / rd);
        sl_close(c);
        shm_table_destroy(t);
        free(slot);
        return sink == 42 ? 2 : 0;
}
