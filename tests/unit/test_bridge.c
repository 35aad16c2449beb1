/*
 * Unit tests of the MQTT bridge's logic (src/mqtt/bridge.c) with a fake sink in place of
 * libmosquitto and real tables made by the daemon-side module (tests/common/shmtest.h): what a
 * set/ message does (written, or refused with its reply on base/set/<name>/error, and never
 * written when it was retained or waited in the broker), what a scan publishes, and when
 * base/status says online.
 */
#include <errno.h>
#include <inttypes.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include <sharedlink.h>

#include "common/shmtest.h"
#include "mqtt/bridge.h"
#include "mqtt/bridge_config.h"
#include "svc/cursor.h"
#include "mqtt/bridge_format.h"

#define SINK_MAX        64      /* messages a test looks at */
#define EVENTS_WINDOW   4u      /* events_window of the kill test: a few rounds fit the ring */
#define KILL_ROUNDS     3u
#define PAYLOAD_MAX     BRIDGE_JSON_MAX

enum { LAT, THROTTLE, STEER, NVARS };

static const struct shm_var vars[NVARS] = {
        { "AutoGpsLat", SHM_DIR_IN, SHM_TYPE_DOUBLE, 0, "A", 0 },
        { "CmdThrottle", SHM_DIR_OUT, SHM_TYPE_DOUBLE, 0, "A", 0 },
        { "CmdSteer", SHM_DIR_OUT, SHM_TYPE_LONG, 0, "A", 1 },
};

/* One message the bridge handed to the sink. */
struct message {
        char topic[BRIDGE_TOPIC_MAX];
        char payload[PAYLOAD_MAX];
        size_t len;
        int qos;
        bool retain;
        int mid;
};

/* The fake sink: records what is published, or refuses it (a broker that is gone). */
struct fake_sink {
        struct message msg[SINK_MAX];
        unsigned n;
        bool down;
        int next_mid;
};

struct fixture {
        struct shmtest_table tb;        /* the daemon's side */
        struct bridge_config cfg;
        struct bridge *b;
        struct fake_sink fs;
        struct bridge_sink sink;
        struct sl_client *c;            /* another client, to look at the values */
        char base[BRIDGE_BASE_MAX];
};

static int sink_publish(void *arg, const char *topic, const void *payload, size_t len, int qos,
                        bool retain, int *ret_mid)
{
        struct fake_sink *fs = arg;
        struct message *m;

        if (fs->down)
                return -ENOTCONN;
        if (fs->n < SINK_MAX) {
                m = &fs->msg[fs->n];
                snprintf(m->topic, sizeof(m->topic), "%s", topic);
                m->len = len < sizeof(m->payload) ? len : sizeof(m->payload) - 1;
                memcpy(m->payload, payload, m->len);
                m->payload[m->len] = '\0';
                m->qos = qos;
                m->retain = retain;
                m->mid = fs->next_mid + 1;
        }
        fs->n++;
        *ret_mid = ++fs->next_mid;
        return 0;
}

static int setup(void **state)
{
        struct fixture *f = calloc(1, sizeof(*f));

        if (!f)
                return -1;
        *state = f;
        shmtest_table_init(&f->tb, "bridge");
        shmtest_table_config(&f->tb, vars, NVARS, 0);
        if (shmtest_table_create(&f->tb) < 0 || sl_open(f->tb.instance, &f->c) < 0)
                return -1;
        bridge_config_defaults(&f->cfg);
        snprintf(f->cfg.instance, sizeof(f->cfg.instance), "%s", f->tb.instance);
        f->cfg.events = false;                  /* no cursor file */
        f->cfg.writable.count = 1;
        snprintf(f->cfg.writable.glob[0], sizeof(f->cfg.writable.glob[0]), "CmdThrottle");
        f->sink = (struct bridge_sink){ .publish = sink_publish, .arg = &f->fs };
        snprintf(f->base, sizeof(f->base), "%s/%s", f->cfg.prefix, f->tb.instance);
        if (bridge_new(&f->cfg, &f->b) < 0 || bridge_attach(f->b) < 0)
                return -1;
        return 0;
}

static int teardown(void **state)
{
        struct fixture *f = *state;

        bridge_free(f->b);
        sl_close(f->c);
        shmtest_table_destroy(&f->tb);
        free(f);
        return 0;
}

/* "<base>/<a>[/<b>]" */
static const char *topic(struct fixture *f, const char *a, const char *b)
{
        static char t[BRIDGE_TOPIC_MAX];

        assert_int_equal(bridge_format_topic(t, sizeof(t), f->base, a, b), 0);
        return t;
}

static int set(struct fixture *f, const char *name, const char *payload,
               enum bridge_set_via via)
{
        char t[BRIDGE_TOPIC_MAX];

        snprintf(t, sizeof(t), "%s", topic(f, BRIDGE_TOPIC_SET, name));
        return bridge_set(f->b, &f->sink, t, payload, strlen(payload), via);
}

static void assert_value(struct fixture *f, int id, const char *want)
{
        char v[SL_VALUE_SIZE];
        struct sl_meta meta = { .size = sizeof(meta) };

        assert_true(sl_read(f->c, id, v, sizeof(v), &meta) >= 0);
        assert_string_equal(v, want);
}

/* The last message is the refusal of name with code; it is not retained. */
static void assert_refusal(struct fixture *f, const char *name, const char *code)
{
        char t[BRIDGE_TOPIC_MAX], want[64];
        const struct message *m;

        assert_true(f->fs.n > 0);
        m = &f->fs.msg[f->fs.n - 1];
        snprintf(t, sizeof(t), "%s/" BRIDGE_TOPIC_ERROR, topic(f, BRIDGE_TOPIC_SET, name));
        assert_string_equal(m->topic, t);
        snprintf(want, sizeof(want), "\"code\":\"%s\"", code);
        assert_non_null(strstr(m->payload, want));
        assert_int_equal(m->qos, f->cfg.set_qos);
        assert_false(m->retain);
}

/* The index of the message on t, or -1. */
static int find(struct fixture *f, const char *t)
{
        for (unsigned i = 0; i < f->fs.n && i < SINK_MAX; i++)
                if (!strcmp(f->fs.msg[i].topic, t))
                        return (int)i;
        return -1;
}

/* A live write is written, and only that: nothing is published. */
static void test_set_live(void **state)
{
        struct fixture *f = *state;

        assert_int_equal(set(f, "CmdThrottle", "0.25", BRIDGE_SET_LIVE), 1);
        assert_value(f, THROTTLE, "0.25");
        assert_int_equal(f->fs.n, 0);
        assert_int_equal(bridge_counters(f->b)->set_written, 1);
        assert_int_equal(bridge_counters(f->b)->set_refused, 0);
}

/* A retained or queued write is never written, whatever it says: refused with its reason. An
 * empty retained message (clearing one) is ignored; so are the bridge's own replies. */
static void test_set_old(void **state)
{
        struct fixture *f = *state;
        char t[BRIDGE_TOPIC_MAX];

        assert_int_equal(set(f, "CmdThrottle", "0.25", BRIDGE_SET_LIVE), 1);
        assert_int_equal(set(f, "CmdThrottle", "0.75", BRIDGE_SET_RETAINED), -EPERM);
        assert_refusal(f, "CmdThrottle", "retained");
        assert_int_equal(set(f, "CmdThrottle", "0.5", BRIDGE_SET_QUEUED), -EPERM);
        assert_refusal(f, "CmdThrottle", "queued");
        /* Also for a name that would be refused anyway: old is said first. */
        assert_int_equal(set(f, "AutoGpsLat", "1", BRIDGE_SET_QUEUED), -EPERM);
        assert_refusal(f, "AutoGpsLat", "queued");
        assert_value(f, THROTTLE, "0.25");
        assert_int_equal(bridge_counters(f->b)->set_refused, 3);

        assert_int_equal(set(f, "CmdThrottle", "", BRIDGE_SET_RETAINED), 0);
        snprintf(t, sizeof(t), "%s/" BRIDGE_TOPIC_ERROR, topic(f, BRIDGE_TOPIC_SET,
                                                               "CmdThrottle"));
        assert_int_equal(bridge_set(f->b, &f->sink, t, "{}", 2, BRIDGE_SET_LIVE), 0);
        assert_int_equal(f->fs.n, 3);
        assert_int_equal(bridge_counters(f->b)->set_refused, 3);
        assert_value(f, THROTTLE, "0.25");
}

/* The other refusals, each with its reply; a topic of more levels has no name to answer on. */
static void test_set_refused(void **state)
{
        struct fixture *f = *state;
        char t[BRIDGE_TOPIC_MAX];

        static const struct {
                const char *name, *payload;
                int r;
                const char *code;
        } cases[] = {
                { "AutoGpsLat", "1", -EPERM, "inbound" },
                { "CmdSteer", "1", -EPERM, "not-writable" },
                { "CmdNope", "1", -EINVAL, "unknown" },
                { "CmdThrottle", "1|2", -EINVAL, "bad-value" },
        };

        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                assert_int_equal(set(f, cases[i].name, cases[i].payload, BRIDGE_SET_LIVE),
                                 cases[i].r);
                assert_refusal(f, cases[i].name, cases[i].code);
        }
        assert_int_equal(bridge_set(f->b, &f->sink, topic(f, BRIDGE_TOPIC_SET, "a/b"), "1", 1,
                                    BRIDGE_SET_LIVE), -EINVAL);
        snprintf(t, sizeof(t), "%s", topic(f, BRIDGE_TOPIC_EVENTS, "CmdThrottle"));
        assert_int_equal(bridge_set(f->b, &f->sink, t, "1", 1, BRIDGE_SET_LIVE), -EINVAL);
        assert_int_equal(f->fs.n, 4);
        assert_int_equal(bridge_counters(f->b)->set_refused, 6);
        assert_int_equal(bridge_counters(f->b)->set_written, 0);
}

/* A value the variable's type refuses (CmdThrottle is a double) is refused with the library's
 * reason, and the variable keeps its value. */
static void test_set_wrong_type(void **state)
{
        struct fixture *f = *state;

        assert_int_equal(set(f, "CmdThrottle", "0.25", BRIDGE_SET_LIVE), 1);
        assert_int_equal(set(f, "CmdThrottle", "abc", BRIDGE_SET_LIVE), -EINVAL);
        assert_refusal(f, "CmdThrottle", "bad-value");
        assert_non_null(strstr(f->fs.msg[f->fs.n - 1].payload,
                               "\"detail\":\"\\\"abc\\\" is not a double"));
        assert_value(f, THROTTLE, "0.25");
        assert_int_equal(bridge_counters(f->b)->set_refused, 1);
        assert_int_equal(bridge_counters(f->b)->set_written, 1);
}

/* The status the last scan published, or NULL. */
static const char *status_sent(struct fixture *f)
{
        int i = find(f, topic(f, BRIDGE_TOPIC_STATUS, NULL));

        if (i < 0)
                return NULL;
        assert_true(f->fs.msg[i].retain);
        assert_int_equal(f->fs.msg[i].qos, BRIDGE_STATUS_QOS);
        return f->fs.msg[i].payload;
}

/* What the daemon does on a client's write before anyone hears of it: takes it from .out into
 * .in, where the change record names it (the bridge follows that record). */
static void daemon_takes_writes(struct fixture *f)
{
        assert_true(shm_table_out_scan(f->tb.t, NULL, NULL) > 0);
}

static void scan(struct fixture *f, bool full)
{
        f->fs.n = 0;
        assert_true(bridge_scan(f->b, &f->sink, full) >= 0);
}

/* A full scan publishes every variable (value and meta) and the links; a later scan only what
 * changed. */
static void test_scan(void **state)
{
        struct fixture *f = *state;
        int i;

        assert_true(bridge_scan(f->b, &f->sink, true) > 0);
        for (unsigned id = 0; id < NVARS; id++) {
                assert_true(find(f, topic(f, vars[id].name, NULL)) >= 0);
                assert_true(find(f, topic(f, vars[id].name, BRIDGE_TOPIC_META)) >= 0);
        }
        assert_true(find(f, topic(f, BRIDGE_TOPIC_LINKS, shmtest_links[0].name)) >= 0);

        f->fs.n = 0;
        assert_int_equal(set(f, "CmdThrottle", "0.5", BRIDGE_SET_LIVE), 1);
        daemon_takes_writes(f);
        assert_int_equal(bridge_scan(f->b, &f->sink, false), 1);
        i = find(f, topic(f, "CmdThrottle", NULL));
        assert_true(i >= 0);
        assert_string_equal(f->fs.msg[i].payload, "0.5");
        assert_true(find(f, topic(f, "CmdThrottle", BRIDGE_TOPIC_META)) >= 0);
        assert_int_equal(f->fs.n, 2);
}

/* base/status is online only while writes are taken (the daemon, this process, runs): nothing
 * while the writes' subscription is pending after a connection (the broker holds offline),
 * online once it stands, offline when it is lost, and nothing again after a new connection
 * until it stands again. Without writable:, the writes do not count. */
static void test_status(void **state)
{
        struct fixture *f = *state;

        scan(f, true);
        assert_null(status_sent(f));
        bridge_writes_ready(f->b, true);
        scan(f, false);
        assert_string_equal(status_sent(f), BRIDGE_STATUS_ONLINE);
        scan(f, false);
        assert_null(status_sent(f));
        scan(f, true);
        assert_string_equal(status_sent(f), BRIDGE_STATUS_ONLINE);

        bridge_writes_ready(f->b, false);
        scan(f, false);
        assert_string_equal(status_sent(f), BRIDGE_STATUS_OFFLINE);
        scan(f, true);
        assert_null(status_sent(f));
        bridge_writes_ready(f->b, true);
        scan(f, false);
        assert_string_equal(status_sent(f), BRIDGE_STATUS_ONLINE);

        f->cfg.writable.count = 0;
        bridge_writes_ready(f->b, false);
        scan(f, true);
        assert_string_equal(status_sent(f), BRIDGE_STATUS_ONLINE);
}

/* A sink that refuses (the broker is gone): the scan fails and counts it, and publishes what
 * it could not once the sink takes messages again. */
static void test_scan_sink_down(void **state)
{
        struct fixture *f = *state;

        assert_true(bridge_scan(f->b, &f->sink, true) > 0);
        assert_int_equal(set(f, "CmdThrottle", "0.5", BRIDGE_SET_LIVE), 1);
        daemon_takes_writes(f);
        f->fs.down = true;
        assert_true(bridge_scan(f->b, &f->sink, false) < 0);
        assert_true(bridge_counters(f->b)->publish_errors > 0);
        f->fs.down = false;
        f->fs.n = 0;
        assert_int_equal(bridge_scan(f->b, &f->sink, false), 1);
        assert_true(find(f, topic(f, "CmdThrottle", NULL)) >= 0);
}

/* Between two scans the daemon made more changes than its record holds (one value, then one
 * other variable again and again): the scan that follows reads everything, so the first value
 * goes out too. */
static void test_scan_overrun(void **state)
{
        struct fixture *f = *state;
        uint32_t cap = shm_layout_changes_capacity(NVARS);
        char v[16];
        int i;

        scan(f, true);
        assert_int_equal(shm_table_set_str(f->tb.t, LAT, "12.5"), 0);
        for (uint32_t k = 0; k <= cap; k++) {
                snprintf(v, sizeof(v), "%u", k);
                assert_int_equal(shm_table_set_str(f->tb.t, STEER, v), 0);
        }
        scan(f, false);
        i = find(f, topic(f, "AutoGpsLat", NULL));
        assert_true(i >= 0);
        assert_string_equal(f->fs.msg[i].payload, "12.5");
        i = find(f, topic(f, "CmdSteer", NULL));
        assert_true(i >= 0);
        assert_string_equal(f->fs.msg[i].payload, v);
        /* and from there on, only what changes */
        assert_int_equal(shm_table_set_str(f->tb.t, LAT, "13"), 0);
        scan(f, false);
        assert_int_equal(f->fs.n, 2);
        assert_true(find(f, topic(f, "AutoGpsLat", NULL)) >= 0);
}

/* The daemon stops: no change is recorded, but every value turns stale (no heartbeat), which the
 * next scan publishes; a new daemon's values go out again in full. */
static void test_scan_daemon_stops(void **state)
{
        struct fixture *f = *state;
        int i;

        assert_int_equal(shm_table_set_str(f->tb.t, LAT, "1.5"), 0);
        scan(f, true);
        f->tb.t = shm_table_destroy(f->tb.t);
        scan(f, false);
        i = find(f, topic(f, "AutoGpsLat", BRIDGE_TOPIC_META));
        assert_true(i >= 0);
        assert_non_null(strstr(f->fs.msg[i].payload, "\"stale\":true"));
        assert_int_equal(shmtest_table_create(&f->tb), 0);
        assert_int_equal(shm_table_set_str(f->tb.t, LAT, "2.5"), 0);
        scan(f, false);
        i = find(f, topic(f, "AutoGpsLat", NULL));
        assert_true(i >= 0);
        assert_string_equal(f->fs.msg[i].payload, "2.5");
        assert_true(find(f, topic(f, "CmdThrottle", NULL)) >= 0);     /* in full */
}

/* The largest "seq" among the events the last pump published (0: none). */
static uint64_t published_seq(struct fixture *f)
{
        uint64_t max = 0;

        for (unsigned i = 0; i < f->fs.n && i < SINK_MAX; i++) {
                const char *p = strstr(f->fs.msg[i].payload, "\"seq\":");
                uint64_t seq;

                if (p && sscanf(p, "\"seq\":%" SCNu64, &seq) == 1 && seq > max)
                        max = seq;
        }
        return max;
}

/* A bridge killed at any moment sends at most events_window events again: those published
 * beyond the cursor on disk. Events acknowledged since the cursor was last written count too,
 * so the cursor is written before the window refills. */
static void test_events_kill_bound(void **state)
{
        struct fixture *f = *state;
        struct bridge_config cfg = f->cfg;
        struct bridge *b;
        uint64_t seq = 0;

        cfg.events = true;
        cfg.events_window = EVENTS_WINDOW;
        snprintf(cfg.cursor_file, sizeof(cfg.cursor_file), "/tmp/%s.cursor", f->tb.instance);
        unlink(cfg.cursor_file);
        assert_int_equal(bridge_new(&cfg, &b), 0);
        assert_int_equal(bridge_attach(b), 0);
        for (unsigned i = 0; i < SHMTEST_EVENTS; i++)
                shm_table_eventf(f->tb.t, SHM_EVENT_LOG, SHM_LINK_NONE, "i=%u", i);

        for (unsigned round = 0; round < KILL_ROUNDS; round++) {
                struct cursor disk = { 0 };

                f->fs.n = 0;
                assert_true(bridge_pump(b, &f->sink) > 0);
                if (published_seq(f) > seq)
                        seq = published_seq(f);
                /* Killed here: a new bridge resumes after the cursor on disk. */
                if (cursor_load(cfg.cursor_file, BRIDGE_CURSOR_OWNER, &disk) == -ENOENT)
                        disk.seq = 0;
                if (seq - disk.seq > EVENTS_WINDOW)
                        fail_msg("round %u: events up to %" PRIu64 " published, %" PRIu64
                                 " on disk: a killed bridge repeats more than the window",
                                 round, seq, disk.seq);
                for (unsigned i = 0; i < f->fs.n && i < SINK_MAX; i++)
                        bridge_acked(b, f->fs.msg[i].mid);
        }
        unlink(cfg.cursor_file);
        bridge_free(b);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_set_live, setup, teardown),
                cmocka_unit_test_setup_teardown(test_set_old, setup, teardown),
                cmocka_unit_test_setup_teardown(test_set_refused, setup, teardown),
                cmocka_unit_test_setup_teardown(test_set_wrong_type, setup, teardown),
                cmocka_unit_test_setup_teardown(test_scan, setup, teardown),
                cmocka_unit_test_setup_teardown(test_status, setup, teardown),
                cmocka_unit_test_setup_teardown(test_scan_sink_down, setup, teardown),
                cmocka_unit_test_setup_teardown(test_scan_overrun, setup, teardown),
                cmocka_unit_test_setup_teardown(test_scan_daemon_stops, setup, teardown),
                cmocka_unit_test_setup_teardown(test_events_kill_bound, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
