/*
 * sl_scoreboard: drive a CIRCE display through sharedlinkd's control socket, and follow the gate
 * passages that come back as events. Commands go through the daemon (milliseconds); the events
 * and values are read from shared memory (nanoseconds).
 *
 *     cc sl_scoreboard.c $(pkg-config --cflags --libs sharedlink) -o sl_scoreboard
 *     ./sl_scoreboard LINK DISPLAY [COMPETITOR]      e.g. ./sl_scoreboard agility D15D15 12
 *
 * It synchronises the devices' clocks, shows COMPETITOR (default 1) on the display with its
 * timer started, then prints each gate passage (action event) for ten seconds. The instance is
 * $SHAREDLINK_INSTANCE; the control socket is found through $SHAREDLINK_RUNTIME_DIR when the
 * daemon's configuration puts it somewhere else than /run/sharedlink.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sharedlink.h>

#define FOLLOW_MS       10000
#define WAIT_SLICE_MS   1000
#define LINK_WAIT_MS    5000    /* commands wait this long for a link that is still connecting */

/* One line per device, as the synchronisation goes. */
static int on_sync(const char *addr, int succeeded, void *arg)
{
        (void)arg;
        printf("clock of %s: %s\n", addr, succeeded ? "synchronised" : "timed out");
        return 0;
}

int main(int argc, char **argv)
{
        char reply[SL_REPLY_LINE_MAX + 1];
        const char *dests[1];
        struct sl_circe_visualize v = { .size = sizeof(v) };
        struct sl_event ev = { .size = sizeof(ev) };
        struct sl_client *c;
        uint64_t events;
        uint32_t cursor = 0;
        int r;

        if (argc < 3) {
                fprintf(stderr, "usage: sl_scoreboard LINK DISPLAY [COMPETITOR]\n");
                return 2;
        }
        r = sl_open(NULL, &c);
        if (r < 0) {
                fprintf(stderr, "sl_scoreboard: %s\n", sl_strerror(r));
                return 3;
        }
        sl_set_command_wait(c, LINK_WAIT_MS);
        sl_events_now(c, &events);
        sl_wait(c, &cursor, 0);

        r = sl_circe_sync_clocks(c, argv[1], on_sync, NULL, reply, sizeof(reply));
        if (r < 0)
                fprintf(stderr, "sync-clocks: %s\n", reply);    /* the reason, ready to show */

        dests[0] = argv[2];
        v.dests = dests;
        v.dest_count = 1;
        v.has_current = 1;
        v.current = argc > 3 ? atoi(argv[3]) : 1;
        v.start_timer = 1;
        r = sl_circe_visualize(c, argv[1], &v, reply, sizeof(reply));
        if (r < 0) {
                fprintf(stderr, "visualize: %s\n", reply);
                sl_close(c);
                return r == -ECONNREFUSED ? 3 : 1;
        }
        printf("showing competitor %d on %s\n", v.current, argv[2]);

        for (int waited = 0; waited < FOLLOW_MS; waited += WAIT_SLICE_MS) {
                if (sl_wait(c, &cursor, WAIT_SLICE_MS) <= 0)
                        continue;
                while (sl_events_read(c, &events, &ev, 1) == 1)
                        if (strcmp(ev.type_name, "action") == 0)
                                printf("%s: %s\n", ev.link_name, ev.text);
        }
        sl_close(c);
        return 0;
}
