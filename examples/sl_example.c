/*
 * sl_example: list the variables of a running sharedlinkd with their values, the links with
 * their state, then print changes as they happen.
 *
 *     cc sl_example.c $(pkg-config --cflags --libs sharedlink) -o sl_example
 *     ./sl_example [INSTANCE [CHANGES]]     CHANGES: how many changes to wait for (default 0)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sharedlink.h>

#define WAIT_MS 1000

static void print_var(struct sl_client *c, int id)
{
        struct sl_var_info info = { .size = sizeof(info) };
        struct sl_meta meta = { .size = sizeof(meta) };
        char value[SL_VALUE_SIZE];
        int r;

        if (sl_info(c, id, &info) < 0)
                return;
        r = sl_read(c, id, value, sizeof(value), &meta);
        if (r < 0) {
                printf("%-40s %s (%s)\n", info.name, "?", sl_strerror(r));
                return;
        }
        printf("%-40s %-3s %s%s%s\n", info.name, info.direction == SL_DIR_OUT ? "out" : "in",
               (meta.flags & SL_FLAG_VALID) ? value : "-",
               (meta.flags & SL_FLAG_STALE) ? " (stale)" : "",
               (meta.flags & SL_FLAG_REPAIRED) ? " (lost write)" : "");
}

static void print_links(struct sl_client *c)
{
        struct sl_link_info link = { .size = sizeof(link) };
        int n = sl_link_count(c);

        for (int i = 0; i < n; i++) {
                if (sl_link_info(c, i, &link) < 0)
                        continue;
                printf("link %-16s %-10s %s\n", link.name, link.protocol, link.state_name);
                for (unsigned k = 0; k < link.counter_count; k++)
                        if (link.counters[k].value)
                                printf("    %-20s %llu\n", link.counters[k].name,
                                       (unsigned long long)link.counters[k].value);
        }
}

int main(int argc, char **argv)
{
        const char *instance = argc > 1 ? argv[1] : NULL;
        long changes = argc > 2 ? strtol(argv[2], NULL, 10) : 0;
        struct sl_event ev = { .size = sizeof(ev) };
        struct sl_client *c;
        uint64_t events = 0;
        uint32_t cursor = 0;
        int r, n;

        r = sl_open(instance, &c);
        if (r < 0) {
                fprintf(stderr, "sl_example: %s\n", sl_strerror(r));
                return 3;
        }
        printf("daemon %s\n", sl_daemon_alive(c) == 1 ? "running" : "not running");
        n = sl_count(c);
        for (int id = 0; id < n; id++)
                print_var(c, id);
        print_links(c);
        sl_events_now(c, &events);
        sl_wait(c, &cursor, 0);
        while (changes-- > 0) {
                r = sl_wait(c, &cursor, WAIT_MS);
                if (r < 0)
                        break;
                if (r == 0) {
                        changes++;      /* a quiet second: keep waiting */
                        continue;
                }
                while (sl_events_read(c, &events, &ev, 1) == 1)
                        printf("event %llu %s %s %s\n", (unsigned long long)ev.seq,
                               ev.link_name[0] ? ev.link_name : "-", ev.type_name, ev.text);
                n = sl_count(c);
                for (int id = 0; id < n; id++)
                        print_var(c, id);
        }
        sl_close(c);
        return 0;
}
