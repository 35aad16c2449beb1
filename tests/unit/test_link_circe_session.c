/*
 * link_circe_session, link_circe_controller, link_circe_mediator: the pure CIRCE sessions on a
 * clock the test sets, so every timing rule of PROTOCOLS.md 2.4 is checked at its exact
 * millisecond boundary (the engine test, test_link_circe.c, checks the same rules on real
 * ptys and timers, as orders and counts).
 *
 * The hooks record what a session does: the packets it sends (as text with <TAB> shown as '|'),
 * its events, states and counters.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "common/wire.h"
#include "daemon/config.h"
#include "daemon/link_circe_controller.h"
#include "daemon/link_circe_mediator.h"
#include "daemon/link_circe_session.h"

#define LOG_MAX         256
#define TEXT_MAX        256
#define T0              100000u         /* the clock starts here (ms) */

struct record {
        char sent[LOG_MAX][TEXT_MAX];   /* "52|015:E1E1E1|..." without STX/checksum/ETX */
        unsigned n_sent;
        char events[LOG_MAX][TEXT_MAX]; /* "<type> <text>" */
        unsigned n_events;
        enum link_circe_state states[LOG_MAX];
        unsigned n_states;
        uint64_t counters[SHM_COUNTER_COUNT];
        unsigned fails;
        char sync[LOG_MAX][32];
        unsigned n_sync;
        int sync_done;                  /* 1: done ok; < 0: error; 0: not yet */
        int send_result;                /* what send returns (0, or an error to inject) */
};

static struct record rec;

static int h_send(void *arg, const struct circe_msg *m)
{
        char pkt[CIRCE_PACKET_MAX];
        int n = circe_encode(m, 0, pkt, sizeof(pkt));
        size_t o = 0;

        (void)arg;
        assert_true(n > 0);
        if (rec.send_result < 0)
                return rec.send_result;
        assert_true(rec.n_sent < LOG_MAX);
        for (int i = 1; i < n - 1 && o < TEXT_MAX - 1; i++)
                rec.sent[rec.n_sent][o++] = pkt[i] == CIRCE_TAB ? '|' : pkt[i];
        rec.sent[rec.n_sent][o] = '\0';
        rec.n_sent++;
        return 0;
}

static void h_fail(void *arg, const char *reason)
{
        (void)arg;
        (void)reason;
        rec.fails++;
}

static void h_state(void *arg, enum link_circe_state s, const char *detail)
{
        (void)arg;
        (void)detail;
        rec.states[rec.n_states++] = s;
}

static void h_event(void *arg, enum shm_event_type type, const char *text)
{
        (void)arg;
        snprintf(rec.events[rec.n_events++], TEXT_MAX, "%s %s", shm_layout_event_name(type), text);
}

static void h_count(void *arg, enum shm_counter c, uint64_t d)
{
        (void)arg;
        rec.counters[c] += d;
}

static void h_sync_result(void *arg, uint32_t addr, bool ok)
{
        (void)arg;
        snprintf(rec.sync[rec.n_sync++], 32, "%06X %s", (unsigned)addr, ok ? "ok" : "timeout");
}

static void h_sync_done(void *arg, int err)
{
        (void)arg;
        rec.sync_done = err < 0 ? err : 1;
}

static const struct link_circe_hooks hooks = {
        .send = h_send, .fail = h_fail, .state = h_state, .event = h_event, .count = h_count,
        .sync_result = h_sync_result, .sync_done = h_sync_done,
};

static int reset(void **state)
{
        (void)state;
        memset(&rec, 0, sizeof(rec));
        return 0;
}

/* Decodes "52|015:E1E1E1|..." (| for TAB) and hands it to a session. */
static void parse(const char *text, struct circe_msg *m)
{
        uint8_t pkt[CIRCE_PACKET_MAX];
        struct circe_result res;
        size_t n = wire_circe_text(pkt, sizeof(pkt), text, WIRE_CS_NONE);

        circe_decode(pkt, n, &res);
        assert_int_equal(res.kind, CIRCE_RESULT_MESSAGE);
        *m = res.msg;
}

static void to_ctl(struct link_circe_controller *c, uint64_t now, const char *text)
{
        struct circe_msg m;

        parse(text, &m);
        link_circe_controller_message(c, now, &m);
}

static void to_med(struct link_circe_mediator *md, uint64_t now, const char *text)
{
        struct circe_msg m;

        parse(text, &m);
        link_circe_mediator_message(md, now, &m);
}

static int event_index(const char *text)
{
        for (unsigned i = 0; i < rec.n_events; i++)
                if (strcmp(rec.events[i], text) == 0)
                        return (int)i;
        return -1;
}

static unsigned sent_count(const char *prefix)
{
        unsigned n = 0;

        for (unsigned i = 0; i < rec.n_sent; i++)
                if (strncmp(rec.sent[i], prefix, strlen(prefix)) == 0)
                        n++;
        return n;
}

static void ctl_init(struct link_circe_controller *c)
{
        struct config_circe cfg = {
                .role = CONFIG_ROLE_CONTROLLER,
                .expect_version = { "0.2", 0, 2, 0 },
                .login_timeout_ms = 1000,
                .idle_timeout_ms = 2000,
        };

        link_circe_controller_init(c, &cfg, &hooks, NULL);
        assert_int_equal(c->state, LINK_CIRCE_DISCONNECTED);
        assert_int_equal(link_circe_controller_deadline(c), LINK_CIRCE_NEVER);
}

#define KA "51|010:0.2.3|012:0|"

/* ---- controller -------------------------------------------------------------------------------- */

static void test_ctl_login_deadline(void **state)
{
        struct link_circe_controller c;

        (void)state;
        ctl_init(&c);
        link_circe_controller_up(&c, T0);
        assert_string_equal(rec.sent[0], "01|");
        assert_int_equal(c.state, LINK_CIRCE_CONNECTING);
        assert_int_equal(link_circe_controller_deadline(&c), T0 + 1000);
        link_circe_controller_tick(&c, T0 + 999);
        assert_int_equal(rec.fails, 0);
        link_circe_controller_tick(&c, T0 + 1000);
        assert_int_equal(rec.fails, 1);
        assert_string_equal(rec.sent[1], "02|");
        assert_int_equal(c.state, LINK_CIRCE_DISCONNECTED);
        assert_int_equal(rec.counters[SHM_COUNTER_TIMEOUTS], 1);
        assert_int_equal(link_circe_controller_deadline(&c), LINK_CIRCE_NEVER);
        /* The next port: Login again, and this time a Keep Alive in time. */
        link_circe_controller_up(&c, T0 + 1200);
        to_ctl(&c, T0 + 2199, KA);
        assert_int_equal(c.state, LINK_CIRCE_CONNECTED);
        assert_true(link_circe_controller_ready(&c));
        link_circe_controller_tick(&c, T0 + 2200);
        assert_int_equal(rec.fails, 1);
}

/* Idle: any valid operation but Log refreshes the deadline. */
static void test_ctl_idle_deadline(void **state)
{
        struct link_circe_controller c;

        (void)state;
        ctl_init(&c);
        link_circe_controller_up(&c, T0);
        to_ctl(&c, T0 + 10, KA);
        assert_int_equal(link_circe_controller_deadline(&c), T0 + 10 + 2000);
        to_ctl(&c, T0 + 1000, "53|015:E1E1E1|025:1|");
        assert_int_equal(link_circe_controller_deadline(&c), T0 + 1000 + 2000);
        to_ctl(&c, T0 + 2500, "54|036:41|");
        assert_int_equal(link_circe_controller_deadline(&c), T0 + 1000 + 2000);
        link_circe_controller_tick(&c, T0 + 2999);
        assert_int_equal(rec.fails, 0);
        link_circe_controller_tick(&c, T0 + 3000);
        assert_int_equal(rec.fails, 1);
        assert_string_equal(rec.sent[rec.n_sent - 1], "02|");
        assert_int_equal(c.state, LINK_CIRCE_DISCONNECTED);
        assert_int_equal(rec.counters[SHM_COUNTER_LOG_MESSAGES], 1);
        /* Nothing is processed on a port given up. */
        to_ctl(&c, T0 + 3001, "53|015:E1E1E1|025:2|");
        assert_int_equal(event_index("action device=E1E1E1 sensor_time=2"), -1);
}

static void test_ctl_version_and_status(void **state)
{
        static const struct {
                const char *ka;
                enum link_circe_state want;
                unsigned fails;
        } cases[] = {
                { "51|010:0.2.0|012:0|", LINK_CIRCE_CONNECTED, 0 },
                { "51|010:0.2.999|012:2|", LINK_CIRCE_CONNECTED, 0 },
                { "51|010:0.2.3|012:1|", LINK_CIRCE_UNCONFIGURED, 0 },
                { "51|010:0.3.0|012:0|", LINK_CIRCE_VERSION_MISMATCH, 1 },
                { "51|010:1.2.0|012:0|", LINK_CIRCE_VERSION_MISMATCH, 1 },
                { "51|010:0.20.0|012:1|", LINK_CIRCE_VERSION_MISMATCH, 1 },
        };

        (void)state;
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                struct link_circe_controller c;

                reset(NULL);
                ctl_init(&c);
                link_circe_controller_up(&c, T0);
                to_ctl(&c, T0 + 1, cases[i].ka);
                assert_int_equal(c.state, cases[i].want);
                assert_int_equal(rec.fails, cases[i].fails);
                assert_int_equal(link_circe_controller_ready(&c), cases[i].fails == 0);
                if (cases[i].fails)
                        assert_string_equal(rec.sent[rec.n_sent - 1], "02|");
        }
}

static void test_ctl_offline_boundary(void **state)
{
        struct link_circe_controller c;

        (void)state;
        ctl_init(&c);
        link_circe_controller_up(&c, T0);
        to_ctl(&c, T0, KA);
        to_ctl(&c, T0 + 100, "52|015:E1E1E1|016:0|019:32|020:0|021:150|");
        assert_true(event_index("device-online device=E1E1E1 capabilities=32 roles=0") >= 0);
        /* Keep the link itself alive; only the device goes quiet. */
        to_ctl(&c, T0 + 1500, KA);
        /* "More than 3 s": still online at exactly 3000 ms, offline at 3001. */
        assert_int_equal(link_circe_controller_deadline(&c), T0 + 100 + 3001);
        link_circe_controller_tick(&c, T0 + 3100);
        assert_true(c.devices[0].online);
        link_circe_controller_tick(&c, T0 + 3101);
        assert_false(c.devices[0].online);
        assert_true(event_index("device-offline device=E1E1E1") >= 0);
        /* Back with the next status: online again, one more event. */
        to_ctl(&c, T0 + 3200, "52|015:E1E1E1|016:0|019:32|020:0|021:150|");
        assert_true(c.devices[0].online);
        assert_int_equal(c.n_devices, 1);
}

/* The 0.2.1 example (027:2 straight away), the 0.2.3 sequence (without 027, then 027:2), a
 * stale 027:2, a silent device, a device appearing during the window; the window ends at
 * exactly 3000 ms. */
static void test_ctl_sync_rules(void **state)
{
        struct link_circe_controller c;

        (void)state;
        ctl_init(&c);
        link_circe_controller_up(&c, T0);
        to_ctl(&c, T0, KA);
        assert_int_equal(link_circe_controller_sync_start(&c, T0), 0);
        assert_int_equal(rec.sync_done, 1);            /* no device online: done at once */
        assert_int_equal(rec.n_sync, 0);
        rec.sync_done = 0;
        to_ctl(&c, T0, "52|015:A00001|016:1|019:32|020:2|021:1|027:1|");
        to_ctl(&c, T0, "52|015:A00002|016:1|019:32|020:2|021:1|");
        to_ctl(&c, T0, "52|015:A00003|016:1|019:32|020:2|021:1|027:2|");
        to_ctl(&c, T0, "52|015:A00004|016:1|019:32|020:2|021:1|");
        assert_int_equal(link_circe_controller_sync_start(&c, T0 + 10), 0);
        assert_string_equal(rec.sent[rec.n_sent - 1], "06|");
        assert_int_equal(link_circe_controller_sync_start(&c, T0 + 11), -EBUSY);
        to_ctl(&c, T0 + 20, "52|015:A00001|016:1|019:32|020:2|021:1|027:2|");
        to_ctl(&c, T0 + 20, "52|015:A00002|016:1|019:32|020:2|021:1|");
        to_ctl(&c, T0 + 30, "52|015:A00002|016:1|019:32|020:2|021:1|027:2|");
        to_ctl(&c, T0 + 30, "52|015:A00003|016:1|019:32|020:2|021:1|027:2|");
        to_ctl(&c, T0 + 30, "52|015:A00005|016:1|019:32|020:2|021:1|");
        to_ctl(&c, T0 + 40, "52|015:A00005|016:1|019:32|020:2|021:1|027:2|");
        assert_int_equal(rec.n_sync, 2);
        assert_string_equal(rec.sync[0], "A00001 ok");
        assert_string_equal(rec.sync[1], "A00002 ok");
        /* The mediator keeps the link alive meanwhile (idle_timeout_ms is 2000). */
        to_ctl(&c, T0 + 1500, KA);
        to_ctl(&c, T0 + 2500, KA);
        link_circe_controller_tick(&c, T0 + 10 + 2999);
        assert_int_equal(rec.sync_done, 0);
        link_circe_controller_tick(&c, T0 + 10 + 3000);
        assert_int_equal(rec.sync_done, 1);
        assert_int_equal(rec.n_sync, 4);
        assert_string_equal(rec.sync[2], "A00003 timeout");
        assert_string_equal(rec.sync[3], "A00004 timeout");
        assert_true(event_index("clock-sync device=A00001 result=succeeded") >= 0);
        assert_true(event_index("clock-sync device=A00004 result=timed-out") >= 0);
        assert_int_equal(event_index("clock-sync device=A00005 result=succeeded"), -1);
        /* A synchronisation cut short by the link: an error, no per-device results. */
        rec.sync_done = 0;
        rec.n_sync = 0;
        to_ctl(&c, T0 + 3500, KA);
        to_ctl(&c, T0 + 4000, "52|015:A00001|016:1|019:32|020:2|021:1|");
        assert_int_equal(link_circe_controller_sync_start(&c, T0 + 4000), 0);
        link_circe_controller_down(&c, T0 + 4001);
        assert_int_equal(rec.sync_done, -ECONNRESET);
        assert_int_equal(rec.n_sync, 0);
        assert_int_equal(link_circe_controller_sync_start(&c, T0 + 4002), -ENOTCONN);
}

static void test_ctl_device_table_bound(void **state)
{
        struct link_circe_controller c;
        char msg[64];

        (void)state;
        ctl_init(&c);
        link_circe_controller_up(&c, T0);
        to_ctl(&c, T0, KA);
        for (unsigned i = 0; i < LINK_CIRCE_DEVICES_MAX + 10; i++) {
                snprintf(msg, sizeof(msg), "53|015:%06X|025:%u|", 0x100000u + i, i);
                to_ctl(&c, T0, msg);
        }
        /* Every action is an event even when the table is full; the table stays bounded. */
        assert_int_equal(c.n_devices, LINK_CIRCE_DEVICES_MAX);
        assert_int_equal(c.stats.action_events, LINK_CIRCE_DEVICES_MAX + 10);
        assert_int_equal(rec.counters[SHM_COUNTER_ADHOC_FULL], 10);
        assert_true(event_index("action device=100049 sensor_time=73") >= 0);
}

/* ---- mediator emulator ------------------------------------------------------------------------- */

static void med_init(struct link_circe_mediator *md, uint32_t keepalive_ms, unsigned n_devices)
{
        struct config_circe cfg = {
                .role = CONFIG_ROLE_MEDIATOR,
                .version = { "0.2.3", 0, 2, 3 },
                .keepalive_ms = keepalive_ms,
                .emulate = {
                        { .address = 0xE1E1E1, .capabilities = 32, .signal = 150 },
                        { .address = 0xAAAAAA, .capabilities = 13, .signal = 200 },
                },
                .n_emulate = n_devices,
        };

        link_circe_mediator_init(md, &cfg, &hooks, NULL, T0);
        link_circe_mediator_up(md, T0);
        assert_int_equal(md->state, LINK_CIRCE_CONNECTING);
}

/* Keep Alive exactly keepalive_ms after the last packet sent; statuses every 1000 ms. */
static void test_med_keepalive_count(void **state)
{
        struct link_circe_mediator md;

        (void)state;
        med_init(&md, 750, 0);
        assert_int_equal(link_circe_mediator_deadline(&md), LINK_CIRCE_NEVER);
        link_circe_mediator_tick(&md, T0 + 5000);
        assert_int_equal(rec.n_sent, 0);                /* nothing before Login */
        to_med(&md, T0 + 5000, "01|");
        assert_string_equal(rec.sent[0], "51|010:0.2.3|012:0|");
        /* Ten seconds of ticks every millisecond: one Keep Alive per 750 ms, no more. */
        for (uint64_t t = T0 + 5000; t <= T0 + 15000; t++)
                link_circe_mediator_tick(&md, t);
        assert_int_equal(sent_count("51|"), 1 + 10000 / 750);
        assert_int_equal(rec.n_sent, sent_count("51|"));
        to_med(&md, T0 + 15001, "02|");
        for (uint64_t t = T0 + 15001; t <= T0 + 20000; t += 7)
                link_circe_mediator_tick(&md, t);
        assert_int_equal(rec.n_sent, 1 + 10000 / 750);
}

static void test_med_status_period(void **state)
{
        struct link_circe_mediator md;

        (void)state;
        med_init(&md, 1500, 2);
        to_med(&md, T0, "01|");
        assert_int_equal(rec.n_sent, 3);                /* Keep Alive + a status per device */
        for (uint64_t t = T0; t <= T0 + 10000; t += 10)
                link_circe_mediator_tick(&md, t);
        /* 10 more rounds, and never a gap of keepalive_ms: no more Keep Alives. */
        assert_int_equal(sent_count("52|015:E1E1E1|"), 11);
        assert_int_equal(sent_count("52|015:AAAAAA|"), 11);
        assert_int_equal(sent_count("51|"), 1);
        /* A stalled loop skips the missed rounds instead of sending a burst. */
        link_circe_mediator_tick(&md, T0 + 60000);
        assert_int_equal(sent_count("52|015:E1E1E1|"), 12);
        link_circe_mediator_tick(&md, T0 + 60001);
        assert_int_equal(sent_count("52|015:E1E1E1|"), 12);
        /* A failed send is an attempt: the next Keep Alive waits a whole period (no spin). */
        rec.send_result = -ENOBUFS;
        link_circe_mediator_tick(&md, T0 + 61000);
        assert_true(link_circe_mediator_deadline(&md) > T0 + 61000);
}

static void test_med_sync_sequence(void **state)
{
        struct link_circe_mediator md;
        unsigned first;

        (void)state;
        med_init(&md, 60000, 1);
        to_med(&md, T0, "01|");
        to_med(&md, T0 + 10, "04|014:E1E1E1|017:1|020:2|");
        link_circe_mediator_tick(&md, T0 + 1000);
        assert_string_equal(rec.sent[rec.n_sent - 1], "52|015:E1E1E1|016:1|019:32|020:2|021:150|027:1|");
        to_med(&md, T0 + 1500, "06|");
        assert_string_equal(rec.sent[rec.n_sent - 1], "52|015:E1E1E1|016:1|019:32|020:2|021:150|");
        first = rec.n_sent;
        for (uint64_t t = T0 + 1500; t <= T0 + 8000; t += 100)
                link_circe_mediator_tick(&md, t);
        /* 027:2 from the next round for 4 s (rounds at 2000..5000 ms), then nothing. */
        assert_string_equal(rec.sent[first], "52|015:E1E1E1|016:1|019:32|020:2|021:150|027:2|");
        assert_int_equal(sent_count("52|015:E1E1E1|016:1|019:32|020:2|021:150|027:2|"), 4);
        assert_string_equal(rec.sent[rec.n_sent - 1], "52|015:E1E1E1|016:1|019:32|020:2|021:150|");
}

static void test_med_action_sensor_time(void **state)
{
        struct link_circe_mediator md;

        (void)state;
        med_init(&md, 60000, 2);
        assert_int_equal(link_circe_mediator_action(&md, T0, 0xE1E1E1, -1, -1), -ENOTCONN);
        to_med(&md, T0, "01|");
        /* The gate's clock started at init (T0); a sync restarts it. */
        assert_int_equal(link_circe_mediator_action(&md, T0 + 1234, 0xE1E1E1, -1, -1), 0);
        assert_string_equal(rec.sent[rec.n_sent - 1], "53|015:E1E1E1|025:1234|");
        to_med(&md, T0 + 2000, "06|");
        assert_int_equal(link_circe_mediator_action(&md, T0 + 2500, 0xE1E1E1, -1, -1), 0);
        assert_string_equal(rec.sent[rec.n_sent - 1], "53|015:E1E1E1|025:500|");
        /* The clock wraps at 999999 ms. */
        assert_int_equal(link_circe_mediator_action(&md, T0 + 2000 + 1000123, 0xE1E1E1, -1, -1),
                         0);
        assert_string_equal(rec.sent[rec.n_sent - 1], "53|015:E1E1E1|025:123|");
        /* AAAAAA (13 = control keypad, start and finish sensor): Pass Start / Pass Finish carry
         * a time, Pass Intermediate (key 2) does not (no intermediate sensor), Ready does not. */
        assert_int_equal(link_circe_mediator_action(&md, T0 + 2600, 0xAAAAAA, 8192, -1), 0);
        assert_string_equal(rec.sent[rec.n_sent - 1], "53|015:AAAAAA|024:8192|025:600|");
        assert_int_equal(link_circe_mediator_action(&md, T0 + 2600, 0xAAAAAA, 4096, -1), 0);
        assert_string_equal(rec.sent[rec.n_sent - 1], "53|015:AAAAAA|024:4096|025:600|");
        assert_int_equal(link_circe_mediator_action(&md, T0 + 2600, 0xAAAAAA, 2, -1), 0);
        assert_string_equal(rec.sent[rec.n_sent - 1], "53|015:AAAAAA|024:2|");
        assert_int_equal(link_circe_mediator_action(&md, T0 + 2600, 0xAAAAAA, 32768, 77), 0);
        assert_string_equal(rec.sent[rec.n_sent - 1], "53|015:AAAAAA|024:32768|025:77|");
        assert_int_equal(link_circe_mediator_action(&md, T0, 0x123456, 1, -1), -ENOENT);
}

static void test_med_device_setup(void **state)
{
        struct config_circe cfg = {
                .role = CONFIG_ROLE_MEDIATOR,
                .version = { "0.2.3", 0, 2, 3 },
                .status = 1,
                .keepalive_ms = 60000,
                .emulate = {
                        { .address = 0x000000, .capabilities = 1, .signal = 9 },
                        { .address = 0xE1E1E1, .capabilities = 32, .signal = 150 },
                },
                .n_emulate = 2,
        };
        struct link_circe_mediator md;

        (void)state;
        link_circe_mediator_init(&md, &cfg, &hooks, NULL, T0);
        link_circe_mediator_up(&md, T0);
        to_med(&md, T0, "01|");
        assert_int_equal(md.state, LINK_CIRCE_UNCONFIGURED);
        assert_string_equal(rec.sent[0], "51|010:0.2.3|012:1|");
        /* Only the configured device reports; 000000 has no address yet. */
        assert_int_equal(rec.n_sent, 2);
        to_med(&md, T0, "05|026:123456|");
        assert_int_equal(md.state, LINK_CIRCE_CONNECTED);
        assert_true(md.has_address);
        assert_int_equal(md.address, 0x123456);
        assert_string_equal(rec.sent[rec.n_sent - 1], "51|010:0.2.3|012:0|");
        /* An address another device has is refused. */
        to_med(&md, T0, "05|026:E1E1E1|019:1|");
        assert_int_equal(md.devices[0].address, 0);
        to_med(&md, T0, "05|026:222222|019:32|");
        assert_int_equal(md.devices[0].address, 0x222222);
        assert_string_equal(rec.sent[rec.n_sent - 1], "52|015:222222|016:0|019:32|020:0|021:9|");
        /* Re-addressing a configured device by its address. */
        to_med(&md, T0, "05|014:E1E1E1|026:E2E2E2|019:32|");
        assert_int_equal(md.devices[1].address, 0xE2E2E2);
        assert_string_equal(rec.sent[rec.n_sent - 1], "52|015:E2E2E2|016:0|019:32|020:0|021:150|");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup(test_ctl_login_deadline, reset),
                cmocka_unit_test_setup(test_ctl_idle_deadline, reset),
                cmocka_unit_test_setup(test_ctl_version_and_status, reset),
                cmocka_unit_test_setup(test_ctl_offline_boundary, reset),
                cmocka_unit_test_setup(test_ctl_sync_rules, reset),
                cmocka_unit_test_setup(test_ctl_device_table_bound, reset),
                cmocka_unit_test_setup(test_med_keepalive_count, reset),
                cmocka_unit_test_setup(test_med_status_period, reset),
                cmocka_unit_test_setup(test_med_sync_sequence, reset),
                cmocka_unit_test_setup(test_med_action_sensor_time, reset),
                cmocka_unit_test_setup(test_med_device_setup, reset),
        };

        return cmocka_run_group_tests_name("link_circe_session", tests, NULL, NULL);
}
