/*
 * The control-command vocabulary (src/proto/request.h), table-driven: every request and every
 * option decoded from the words the daemon splits, re-encoded to the canonical line (and, for a
 * CIRCE operation a controller sends, to the exact packet of PROTOCOLS.md 2.2); every refusal
 * with its reason (unknown request, usage, missing and extra arguments, every range one past
 * its end, lower-case addresses, bad wait); the encoder refusing what the decoder would; the
 * setters checking a number before it is narrowed into its field; the wait=MS escape; the
 * sync-clocks reply line.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "common/wire.h"
#include "proto/request.h"

#define ARR(a) (sizeof(a) / sizeof((a)[0]))

/* Splits line as the daemon does and decodes it; the words live in buf. */
static int decode_line(const char *line, char *buf, struct reqp_request *r, char *err,
                       size_t errsz)
{
        char *argv[CTLP_WORDS_MAX + 1];
        int argc = 0;

        snprintf(buf, CTLP_LINE_MAX, "%s", line);
        if (ctlp_request_split(buf, strlen(buf), argv, &argc) != CTLP_REASON_NONE)
                return -EBADMSG;
        return reqp_decode(argc, argv, r, err, errsz);
}

/* Renders a packet with <STX>, <TAB>, <ETX> spelled out, no checksum. */
static void render(const struct circe_msg *m, char *out, size_t size)
{
        char pkt[CIRCE_PACKET_MAX];
        int n = circe_encode(m, 0, pkt, sizeof(pkt));

        assert_true(n > 0);
        wire_circe_show((const uint8_t *)pkt, (size_t)n, out, size);
}

/* ---- accepted ---------------------------------------------------------------------------------- */

struct ok_case {
        const char *line;
        enum reqp_kind kind;
        const char *canonical;          /* what the encoder makes of it; NULL: the line itself */
        const char *packet;             /* a controller's CIRCE operation: the wire form */
        unsigned wait_ms;
};

static const struct ok_case ok_cases[] = {
        { "ping", REQP_PING, NULL, NULL, 0 },
        { "stats", REQP_STATS, NULL, NULL, 0 },
        { "record veh", REQP_RECORD, NULL, NULL, 0 },
        { "query veh A AutoGpsLat", REQP_QUERY, NULL, NULL, 0 },
        { "query veh P Name.x 60000", REQP_QUERY, NULL, NULL, 0 },
        { "query veh B X 1 wait=250", REQP_QUERY, NULL, NULL, 250 },
        { "query veh A X wait=0", REQP_QUERY, "query veh A X", NULL, 0 },
        { "command v ServoPod 0,TELEOP START", REQP_COMMAND, NULL, NULL, 0 },
        { "command v MUI", REQP_COMMAND, NULL, NULL, 0 },
        { "command v Link 0, SetIP, 1.2.3.4:4220, 4000 wait=5", REQP_COMMAND, NULL, NULL, 5 },
        { "ping-peer veh A", REQP_PEER_PING, NULL, NULL, 0 },
        { "ping-peer veh P 60000 wait=20", REQP_PEER_PING, NULL, NULL, 20 },
        { "circe a alert E1E1E1", REQP_CIRCE_ALERT, NULL, "<STX>03<TAB>014:E1E1E1<TAB><ETX>", 0 },
        { "circe a alert 000000 wait=500", REQP_CIRCE_ALERT, NULL,
          "<STX>03<TAB>014:000000<TAB><ETX>", 500 },
        { "circe a alert FFFFFE", REQP_CIRCE_ALERT, NULL, "<STX>03<TAB>014:FFFFFE<TAB><ETX>", 0 },
        { "circe a network-setup AAAAAA join 1", REQP_CIRCE_NETWORK_SETUP, NULL,
          "<STX>04<TAB>014:AAAAAA<TAB>017:1<TAB>020:1<TAB><ETX>", 0 },
        { "circe a network-setup E2E2E2 leave 0", REQP_CIRCE_NETWORK_SETUP, NULL,
          "<STX>04<TAB>014:E2E2E2<TAB>017:0<TAB>020:0<TAB><ETX>", 0 },
        { "circe a network-setup E1E1E1 join 127", REQP_CIRCE_NETWORK_SETUP, NULL,
          "<STX>04<TAB>014:E1E1E1<TAB>017:1<TAB>020:127<TAB><ETX>", 0 },
        { "circe a network-setup E1E1E1 join 007", REQP_CIRCE_NETWORK_SETUP,
          "circe a network-setup E1E1E1 join 7",
          "<STX>04<TAB>014:E1E1E1<TAB>017:1<TAB>020:7<TAB><ETX>", 0 },
        { "circe a device-setup 123456", REQP_CIRCE_DEVICE_SETUP, NULL,
          "<STX>05<TAB>026:123456<TAB><ETX>", 0 },
        { "circe a device-setup 222222 - 32", REQP_CIRCE_DEVICE_SETUP, NULL,
          "<STX>05<TAB>026:222222<TAB>019:32<TAB><ETX>", 0 },
        { "circe a device-setup 222222 000001 32", REQP_CIRCE_DEVICE_SETUP, NULL,
          "<STX>05<TAB>014:000001<TAB>026:222222<TAB>019:32<TAB><ETX>", 0 },
        { "circe a device-setup 222222 000001 -", REQP_CIRCE_DEVICE_SETUP,
          "circe a device-setup 222222 000001",
          "<STX>05<TAB>014:000001<TAB>026:222222<TAB><ETX>", 0 },
        { "circe a device-setup 222222 - -", REQP_CIRCE_DEVICE_SETUP,
          "circe a device-setup 222222", "<STX>05<TAB>026:222222<TAB><ETX>", 0 },
        { "circe a device-setup 222222 - 127", REQP_CIRCE_DEVICE_SETUP, NULL,
          "<STX>05<TAB>026:222222<TAB>019:127<TAB><ETX>", 0 },
        { "circe a sync-clocks", REQP_CIRCE_SYNC_CLOCKS, NULL, "<STX>06<TAB><ETX>", 0 },
        { "circe a sync-clocks wait=60000", REQP_CIRCE_SYNC_CLOCKS, NULL, "<STX>06<TAB><ETX>",
          60000 },
        { "circe a visualize D15D15 current=12", REQP_CIRCE_VISUALIZE, NULL,
          "<STX>07<TAB>028:12<TAB>014:D15D15<TAB><ETX>", 0 },
        /* Given in any order, sent in the documented one: on the line the table's, on the wire
         * 034 028 029 030 031 038 032 033 035, then the destinations in the order given. */
        { "circe a visualize D15D15,D25D25 placement=3 refusals=2 faults=1 secondary=999999 "
          "primary=31250 start-timer next=13 current=12 eliminated=1", REQP_CIRCE_VISUALIZE,
          "circe a visualize D15D15,D25D25 current=12 next=13 start-timer primary=31250 "
          "secondary=999999 faults=1 refusals=2 eliminated=1 placement=3",
          "<STX>07<TAB>034:1<TAB>028:12<TAB>029:13<TAB>030:1<TAB>031:31250<TAB>038:999999<TAB>"
          "032:1<TAB>033:2<TAB>035:3<TAB>014:D15D15<TAB>014:D25D25<TAB><ETX>", 0 },
        { "circe a visualize D15D15 start-timer wait=1", REQP_CIRCE_VISUALIZE, NULL,
          "<STX>07<TAB>030:1<TAB>014:D15D15<TAB><ETX>", 1 },
        { "circe a visualize D15D15 eliminated=0", REQP_CIRCE_VISUALIZE, NULL,
          "<STX>07<TAB>034:0<TAB>014:D15D15<TAB><ETX>", 0 },
        { "circe a visualize D15D15 next=999 faults=99 refusals=0 placement=999",
          REQP_CIRCE_VISUALIZE, NULL,
          "<STX>07<TAB>029:999<TAB>032:99<TAB>033:0<TAB>035:999<TAB>014:D15D15<TAB><ETX>", 0 },
        { "circe a emulate action E1E1E1", REQP_CIRCE_EMULATE_ACTION, NULL, NULL, 0 },
        { "circe a emulate action AAAAAA keys=32768 wait=100", REQP_CIRCE_EMULATE_ACTION, NULL,
          NULL, 100 },
        { "circe a emulate action AAAAAA sensor-time=999999 keys=65535",
          REQP_CIRCE_EMULATE_ACTION, "circe a emulate action AAAAAA keys=65535 sensor-time=999999",
          NULL, 0 },
        /* The daemon's split takes runs of spaces. */
        { "  circe   a  alert   E1E1E1 ", REQP_CIRCE_ALERT, "circe a alert E1E1E1",
          "<STX>03<TAB>014:E1E1E1<TAB><ETX>", 0 },
};

static void test_accepted(void **state)
{
        (void)state;
        for (size_t i = 0; i < ARR(ok_cases); i++) {
                const struct ok_case *k = &ok_cases[i];
                const char *want = k->canonical ? k->canonical : k->line;
                char buf[CTLP_LINE_MAX], line[CTLP_LINE_MAX], again[CTLP_LINE_MAX];
                char err[REQP_ERR_MAX] = "", wire[CTLP_LINE_MAX];
                struct reqp_request r, r2;
                int n;

                if (decode_line(k->line, buf, &r, err, sizeof(err)) != 0)
                        fail_msg("refused \"%s\": %s", k->line, err);
                assert_int_equal(r.kind, k->kind);
                assert_int_equal(r.wait_ms, k->wait_ms);
                n = reqp_encode(&r, line, sizeof(line), err, sizeof(err));
                if (n < 0)
                        fail_msg("\"%s\" decoded but does not encode: %s", k->line, err);
                assert_int_equal((size_t)n, strlen(line));
                if (strcmp(line, want) != 0)
                        fail_msg("\"%s\" encoded as \"%s\", expected \"%s\"", k->line, line, want);
                /* And back: the same request, the same line. */
                assert_int_equal(decode_line(line, buf, &r2, err, sizeof(err)), 0);
                assert_memory_equal(&r, &r2, sizeof(r));
                assert_int_equal(reqp_encode(&r2, again, sizeof(again), err, sizeof(err)), n);
                assert_string_equal(again, line);
                if (!k->packet)
                        continue;
                assert_true(reqp_circe_for_controller(r.kind));
                render(&r.u.circe, wire, sizeof(wire));
                if (strcmp(wire, k->packet) != 0)
                        fail_msg("\"%s\" built %s, expected %s", k->line, wire, k->packet);
        }
}

static void test_decoded_fields(void **state)
{
        char buf[CTLP_LINE_MAX], err[REQP_ERR_MAX];
        struct reqp_request r;

        (void)state;
        assert_int_equal(decode_line("circe arena emulate action E1E1E1 sensor-time=5000 keys=0",
                                     buf, &r, err, sizeof(err)), 0);
        assert_string_equal(r.link, "arena");
        assert_int_equal(r.u.circe.op, CIRCE_OP_NOTIFY_ACTION);
        assert_int_equal(r.u.circe.u.notify_action.origin, 0xE1E1E1);
        assert_true(r.u.circe.u.notify_action.has_keys);
        assert_int_equal(r.u.circe.u.notify_action.keys, 0);
        assert_true(r.u.circe.u.notify_action.has_sensor_time);
        assert_int_equal(r.u.circe.u.notify_action.sensor_time_ms, 5000);
        assert_false(reqp_circe_for_controller(r.kind));

        assert_int_equal(decode_line("circe arena emulate action AAAAAA", buf, &r, err,
                                     sizeof(err)), 0);
        assert_false(r.u.circe.u.notify_action.has_keys);
        assert_false(r.u.circe.u.notify_action.has_sensor_time);

        assert_int_equal(decode_line("query veh B Name.x 250 wait=10", buf, &r, err,
                                     sizeof(err)), 0);
        assert_string_equal(r.u.query.peer, "B");
        assert_string_equal(r.u.query.name, "Name.x");
        assert_true(r.u.query.has_timeout);
        assert_int_equal(r.u.query.timeout_ms, 250);
        assert_int_equal(r.wait_ms, 10);

        assert_int_equal(decode_line("command p4 ServoPod 0,TELEOP   START", buf, &r, err,
                                     sizeof(err)), 0);
        assert_string_equal(r.u.command.module, "ServoPod");
        assert_string_equal(r.u.command.text, "0,TELEOP START");

        assert_int_equal(decode_line("circe a network-setup E1E1E1 leave 2", buf, &r, err,
                                     sizeof(err)), 0);
        assert_false(r.u.circe.u.network_setup.set_membership);
        assert_int_equal(r.u.circe.u.network_setup.roles, 2);
}

/* ---- refused ------------------------------------------------------------------------------------ */

struct bad_case {
        const char *line;
        const char *message;            /* a part of the reason */
};

static const struct bad_case bad_cases[] = {
        /* Requests and their heads. */
        { "frobnicate now", "unknown request \"frobnicate\"" },
        { "ping extra", "usage: ping (too many arguments)" },
        { "stats x", "usage: stats" },
        { "record", "usage: record LINK (missing arguments)" },
        { "record veh extra", "too many arguments" },
        { "record veh wait=5", "too many arguments" },
        { "record abcdefghijklmnopqrstuvwxyz012345", "bad link name: 1..31 bytes" },
        { "query", "usage: query LINK" },
        { "query veh", "usage: query LINK PEER NAME [TIMEOUT_MS] [wait=MS] (missing" },
        { "query wait=5", "usage: query LINK" },
        { "circe", "usage: circe LINK OPERATION" },
        { "circe a", "usage: circe LINK OPERATION" },
        { "circe a wait=5", "usage: circe LINK OPERATION" },
        { "circe a dance", "unknown CIRCE operation \"dance\" (alert, network-setup, "
                           "device-setup, sync-clocks, visualize, emulate)" },
        /* wait=MS: the last word only, 0..60000. */
        { "circe a alert E1E1E1 wait=", "bad wait \"\"" },
        { "circe a alert E1E1E1 wait=60001", "bad wait \"60001\": a decimal number 0..60000" },
        { "circe a alert E1E1E1 wait=-5", "bad wait" },
        { "query veh A X wait=12ms", "bad wait" },
        { "query veh A X wait=99999999999999999999", "bad wait" },
        { "ping wait=5", "usage: ping" },
        /* query */
        { "query veh A", "missing arguments" },
        { "query veh A X 1 2", "too many arguments" },
        { "query veh Q X", "bad peer \"Q\": a node address A..P" },
        { "query veh a X", "bad peer \"a\"" },
        { "query veh AB X", "bad peer" },
        { "query veh A Auto|Lat", "bad variable name" },
        { "query veh A abcdefghijklmnopqrstuvwxyz0123456789abcdefghijkl", "bad variable name" },
        { "query veh A X 0", "bad timeout \"0\": a decimal number 1..60000" },
        { "query veh A X 60001", "bad timeout \"60001\"" },
        { "query veh A X -", "bad timeout" },
        /* ping-peer */
        { "ping-peer veh", "usage: ping-peer LINK PEER [TIMEOUT_MS] [wait=MS]" },
        { "ping-peer veh Q", "bad peer \"Q\": a node address A..P" },
        { "ping-peer veh A 0", "bad timeout \"0\": a decimal number 1..60000" },
        { "ping-peer veh A 5 6", "too many arguments" },
        /* command */
        { "command veh", "usage: command LINK MODULE" },
        { "command veh Servo,Pod x", "bad module \"Servo,Pod\"" },
        { "command veh ServoPod 0|x", "command text has a byte outside 0x20-0x7E, or | [ ]" },
        { "command veh ServoPod 0123456789 0123456789 0123456789 0123456789 0123456789 "
          "0123456789", "command text longer than 63 bytes" },
        { "command veh M a b c d e f g h i j k l m n o p q r s t u v w x y z 0 1 2",
          "command text has more than 28 words" },
        { "command veh MUI x", "MUI is a bare module request: it takes no text" },
        { "command veh MW 0 wait=5", "MW is a bare module request: it takes no text" },
        /* alert */
        { "circe a alert", "usage: circe LINK alert ADDR [wait=MS] (missing arguments)" },
        { "circe a alert E1E1E1 E2E2E2", "too many arguments" },
        { "circe a alert e1e1e1", "bad address \"e1e1e1\": six uppercase hex digits expected" },
        { "circe a alert E1e1E1", "bad address \"E1e1E1\"" },
        { "circe a alert FFFFFF", "bad address FFFFFF: the address is reserved" },
        { "circe a alert E1E1E", "bad address \"E1E1E\"" },
        { "circe a alert E1E1E1E", "bad address" },
        { "circe a alert G1E1E1", "bad address" },
        { "circe a alert +12345", "bad address" },
        /* network-setup */
        { "circe a network-setup E1E1E1 join", "missing arguments" },
        { "circe a network-setup XYZ join", "missing arguments" },
        { "circe a network-setup e1e1e1 join 1", "bad address \"e1e1e1\"" },
        { "circe a network-setup E1E1E1 stay 1", "bad membership \"stay\": join or leave" },
        { "circe a network-setup E1E1E1 join 128", "bad roles \"128\": a decimal number 0..127" },
        { "circe a network-setup E1E1E1 join +1", "bad roles" },
        { "circe a network-setup E1E1E1 join 1 2", "too many arguments" },
        /* device-setup */
        { "circe a device-setup", "missing arguments" },
        { "circe a device-setup FFFFFF", "bad address to assign FFFFFF" },
        { "circe a device-setup 12345a", "bad address to assign \"12345a\"" },
        { "circe a device-setup 123456 XYZ", "bad destination \"XYZ\"" },
        { "circe a device-setup 123456 abcdef", "bad destination \"abcdef\"" },
        { "circe a device-setup 123456 - 128", "bad capabilities \"128\"" },
        { "circe a device-setup 123456 - 1 2", "too many arguments" },
        /* sync-clocks */
        { "circe a sync-clocks now", "too many arguments" },
        /* visualize */
        { "circe a visualize", "missing arguments" },
        { "circe a visualize D15D15", "visualize needs at least one display field" },
        { "circe a visualize D15D15 wait=10", "visualize needs at least one display field" },
        { "circe a visualize D15D15,", "bad destination \"\"" },
        { "circe a visualize D15D15,,D25D25 current=1", "bad destination" },
        { "circe a visualize D15D15,d25d25 current=1", "bad destination \"d25d25\"" },
        { "circe a visualize current=1", "bad destination \"current=1\"" },
        { "circe a visualize D15D15 current=1000", "bad current \"1000\": a decimal number 0..999" },
        { "circe a visualize D15D15 next=1000", "bad next \"1000\"" },
        { "circe a visualize D15D15 next=abc", "bad next" },
        { "circe a visualize D15D15 primary=1000000", "bad primary" },
        { "circe a visualize D15D15 secondary=", "bad secondary" },
        { "circe a visualize D15D15 faults=100", "bad faults \"100\": a decimal number 0..99" },
        { "circe a visualize D15D15 refusals=100", "bad refusals" },
        { "circe a visualize D15D15 eliminated=2", "bad eliminated \"2\": a decimal number 0..1" },
        { "circe a visualize D15D15 placement=1000", "bad placement" },
        { "circe a visualize D15D15 current=1 current=2", "visualize: current given twice" },
        { "circe a visualize D15D15 start-timer start-timer", "start-timer given twice" },
        { "circe a visualize D15D15 start-timer=1", "start-timer takes no value" },
        { "circe a visualize D15D15 current", "current needs a value (current=N)" },
        { "circe a visualize D15D15 colour=red", "unknown argument \"colour=red\" (current=N, "
                                                 "next=N, start-timer, primary=N" },
        { "circe a visualize D15D15 destination=E1E1E1", "unknown argument" },
        /* emulate action */
        { "circe a emulate", "usage: circe LINK emulate action" },
        { "circe a emulate press E1E1E1", "usage: circe LINK emulate action" },
        { "circe a emulate action", "missing arguments" },
        { "circe a emulate action e1e1e1", "bad device \"e1e1e1\"" },
        { "circe a emulate action E1E1E1 keys=65536", "bad keys" },
        { "circe a emulate action E1E1E1 sensor-time=1000000", "bad sensor-time" },
        { "circe a emulate action E1E1E1 keys=1 keys=2", "emulate action: keys given twice" },
        { "circe a emulate action E1E1E1 sensor-time=1 sensor-time=2", "sensor-time given twice" },
        { "circe a emulate action E1E1E1 volume=11", "unknown argument \"volume=11\" (keys=N, "
                                                     "sensor-time=N)" },
        { "circe a emulate action E1E1E1 wait=5 keys=1", "unknown argument \"wait=5\"" },
};

static void test_refused(void **state)
{
        (void)state;
        for (size_t i = 0; i < ARR(bad_cases); i++) {
                const struct bad_case *k = &bad_cases[i];
                char buf[CTLP_LINE_MAX], err[REQP_ERR_MAX] = "";
                struct reqp_request r;
                int rc;

                memset(&r, 0x5A, sizeof(r));
                rc = decode_line(k->line, buf, &r, err, sizeof(err));
                if (rc != -EINVAL)
                        fail_msg("\"%s\" accepted (%d)", k->line, rc);
                if (!strstr(err, k->message))
                        fail_msg("\"%s\": message \"%s\" lacks \"%s\"", k->line, err, k->message);
                /* ret_* is written only on success. */
                assert_int_equal(((unsigned char *)&r)[0], 0x5A);
        }
        /* No words at all, and no room for a message. */
        assert_int_equal(reqp_decode(0, NULL, &(struct reqp_request){ 0 }, NULL, 0), -EINVAL);
}

static void test_destination_limit(void **state)
{
        char line[CTLP_LINE_MAX], buf[CTLP_LINE_MAX], out[CTLP_LINE_MAX], err[REQP_ERR_MAX];
        struct reqp_request r;
        size_t o;

        (void)state;
        o = (size_t)snprintf(line, sizeof(line), "circe a visualize ");
        for (unsigned i = 0; i < CIRCE_VISUALIZE_DEST_MAX; i++)
                o += (size_t)snprintf(line + o, sizeof(line) - o, "%s%06X", i ? "," : "",
                                      0x100000u + i);
        snprintf(line + o, sizeof(line) - o, " current=1");
        assert_int_equal(decode_line(line, buf, &r, err, sizeof(err)), 0);
        assert_int_equal(r.u.circe.u.visualize.dest_count, CIRCE_VISUALIZE_DEST_MAX);
        assert_true(reqp_encode(&r, out, sizeof(out), err, sizeof(err)) > 0);
        assert_string_equal(out, line);
        snprintf(line + o, sizeof(line) - o, ",%06X current=1", 0x200000u);
        assert_int_equal(decode_line(line, buf, &r, err, sizeof(err)), -EINVAL);
        assert_non_null(strstr(err, "visualize: more than 92 destinations"));
}

/* ---- the library's side --------------------------------------------------------------------- */

static void test_setters(void **state)
{
        char err[REQP_ERR_MAX], line[CTLP_LINE_MAX];
        struct reqp_request r, before;

        (void)state;
        reqp_init(&r, REQP_CIRCE_NETWORK_SETUP);
        assert_int_equal(reqp_set_link(&r, "agility", err, sizeof(err)), 0);
        assert_int_equal(reqp_set_text(&r, "address", "AAAAAA", err, sizeof(err)), 0);
        assert_int_equal(reqp_set_number(&r, "membership", 1, err, sizeof(err)), 0);
        /* Checked before it is narrowed: 300 would be 44 in a uint8_t. */
        before = r;
        assert_int_equal(reqp_set_number(&r, "roles", 300, err, sizeof(err)), -EINVAL);
        assert_string_equal(err, "bad roles 300: 0..127 expected");
        assert_int_equal(reqp_set_number(&r, "roles", -1, err, sizeof(err)), -EINVAL);
        assert_int_equal(reqp_set_number(&r, "membership", 2, err, sizeof(err)), -EINVAL);
        assert_string_equal(err, "bad membership 2: 0..1 expected");
        assert_memory_equal(&r, &before, sizeof(r));
        assert_int_equal(reqp_set_number(&r, "roles", 127, err, sizeof(err)), 0);
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)),
                         (int)strlen("circe agility network-setup AAAAAA join 127"));
        assert_string_equal(line, "circe agility network-setup AAAAAA join 127");

        /* Keys the request does not have, and numbers that are not numbers. */
        assert_int_equal(reqp_set_number(&r, "keys", 1, err, sizeof(err)), -EINVAL);
        assert_non_null(strstr(err, "network-setup takes no argument \"keys\""));
        assert_int_equal(reqp_set_number(&r, "address", 1, err, sizeof(err)), -EINVAL);
        assert_int_equal(reqp_set_text(&r, NULL, "x", err, sizeof(err)), -EINVAL);

        /* Addresses: upper case only, FFFFFF reserved, NULL is empty. */
        reqp_init(&r, REQP_CIRCE_ALERT);
        assert_int_equal(reqp_set_text(&r, "address", "e1e1e1", err, sizeof(err)), -EINVAL);
        assert_string_equal(err, "bad address \"e1e1e1\": six uppercase hex digits expected");
        assert_int_equal(reqp_set_text(&r, "address", "FFFFFF", err, sizeof(err)), -EINVAL);
        assert_string_equal(err, "bad address FFFFFF: the address is reserved");
        assert_int_equal(reqp_set_text(&r, "address", NULL, err, sizeof(err)), -EINVAL);

        /* Links. */
        assert_int_equal(reqp_set_link(&r, NULL, err, sizeof(err)), -EINVAL);
        assert_string_equal(err, "no link name");
        assert_int_equal(reqp_set_link(&r, "", err, sizeof(err)), -EINVAL);
        assert_int_equal(reqp_set_link(&r, "abcdefghijklmnopqrstuvwxyz012345", err,
                                       sizeof(err)), -EINVAL);
        assert_string_equal(err, "bad link name: 1..31 bytes expected");
        assert_int_equal(reqp_set_link(&r, "a b", err, sizeof(err)), -EINVAL);
        assert_int_equal(reqp_set_link(&r, "abcdefghijklmnopqrstuvwxyz01234", err, sizeof(err)),
                         0);

        /* A destination list grows one address a call, up to its end. */
        reqp_init(&r, REQP_CIRCE_VISUALIZE);
        assert_int_equal(reqp_set_link(&r, "a", err, sizeof(err)), 0);
        for (unsigned i = 0; i < CIRCE_VISUALIZE_DEST_MAX; i++)
                assert_int_equal(reqp_set_text(&r, "destination", "123456", err, sizeof(err)),
                                 0);
        before = r;
        assert_int_equal(reqp_set_text(&r, "destination", "123456", err, sizeof(err)),
                         -EINVAL);
        assert_memory_equal(&r, &before, sizeof(r));
        /* No display field: the encoder says so, in the library's words. */
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        assert_string_equal(err, "visualize needs at least one display field");
        assert_int_equal(reqp_set_number(&r, "start-timer", 2, err, sizeof(err)), -EINVAL);
        assert_string_equal(err, "bad start-timer 2: 0..1 expected");
        assert_int_equal(reqp_set_number(&r, "start-timer", 1, err, sizeof(err)), 0);
        assert_true(reqp_encode(&r, line, sizeof(line), err, sizeof(err)) > 0);
        assert_non_null(strstr(line, ",123456 start-timer"));
}

/* What the encoder refuses of a struct filled by hand, each with the decoder's rule. */
static void test_encode_refused(void **state)
{
        char err[REQP_ERR_MAX], line[CTLP_LINE_MAX];
        struct reqp_request r;

        (void)state;
        reqp_init(&r, REQP_CIRCE_VISUALIZE);
        strcpy(r.link, "a");
        r.u.circe.u.visualize.has_current = true;
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        assert_string_equal(err, "bad destination count 0: 1..92 expected");
        r.u.circe.u.visualize.dest_count = 1;
        r.u.circe.u.visualize.dests[0] = CIRCE_ADDRESS_RESERVED;
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        r.u.circe.u.visualize.dests[0] = 0xD15D15;
        r.u.circe.u.visualize.current = 1000;
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        assert_string_equal(err, "bad current 1000: 0..999 expected");
        r.u.circe.u.visualize.current = 999;
        r.u.circe.u.visualize.has_faults = true;
        r.u.circe.u.visualize.faults = 100;
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        r.u.circe.u.visualize.faults = 99;
        assert_int_equal(reqp_encode(&r, line, 8, err, sizeof(err)), -ENOBUFS);
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)),
                         (int)strlen("circe a visualize D15D15 current=999 faults=99"));

        /* The link: none, unterminated, a space. */
        r.link[0] = '\0';
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        memset(r.link, 'x', sizeof(r.link));
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        strcpy(r.link, "a b");
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        strcpy(r.link, "a");

        /* wait=MS: only on a link request, at most CTLP_WAIT_MAX_MS. */
        r.wait_ms = CTLP_WAIT_MAX_MS + 1u;
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        reqp_init(&r, REQP_PING);
        r.wait_ms = 1;
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);

        /* Addresses past 24 bits; a query without its words; a kind that does not exist. */
        reqp_init(&r, REQP_CIRCE_ALERT);
        strcpy(r.link, "a");
        r.u.circe.u.alert.dest = 0x1000000;
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        reqp_init(&r, REQP_QUERY);
        strcpy(r.link, "a");
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        assert_non_null(strstr(err, "bad peer"));
        strcpy(r.u.query.peer, "A");
        memset(r.u.query.name, 'n', sizeof(r.u.query.name));
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        reqp_init(&r, REQP_KIND_COUNT);
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        assert_int_equal(reqp_encode(NULL, line, sizeof(line), NULL, 0), -EINVAL);
}

/*
 * A last word that reads as wait=MS is followed by an explicit one, so that the daemon takes
 * the argument as the argument: a command text ending so. A variable name never reads so (it is
 * letters, digits, _ . -: slp_name_byte()), so a query of "wait=5" is refused.
 */
static void test_wait_escape(void **state)
{
        char err[REQP_ERR_MAX], line[CTLP_LINE_MAX], buf[CTLP_LINE_MAX];
        struct reqp_request r, back;

        (void)state;
        reqp_init(&r, REQP_QUERY);
        assert_int_equal(reqp_set_link(&r, "veh", err, sizeof(err)), 0);
        assert_int_equal(reqp_set_text(&r, "peer", "A", err, sizeof(err)), 0);
        assert_int_equal(reqp_set_text(&r, "variable name", "wait=5", err, sizeof(err)),
                         -EINVAL);

        reqp_init(&r, REQP_COMMAND);
        assert_int_equal(reqp_set_link(&r, "v", err, sizeof(err)), 0);
        assert_int_equal(reqp_set_text(&r, "module", "Link", err, sizeof(err)), 0);
        assert_int_equal(reqp_set_text(&r, "command text", "a wait=x", err, sizeof(err)), 0);
        assert_true(reqp_encode(&r, line, sizeof(line), err, sizeof(err)) > 0);
        assert_string_equal(line, "command v Link a wait=x wait=0");
        assert_int_equal(decode_line(line, buf, &back, err, sizeof(err)), 0);
        assert_string_equal(back.u.command.text, "a wait=x");
        /* The encoder holds a bare module request to the decoder's rule: no text. */
        assert_int_equal(reqp_set_text(&r, "module", "MUO", err, sizeof(err)), 0);
        assert_int_equal(reqp_encode(&r, line, sizeof(line), err, sizeof(err)), -EINVAL);
        assert_string_equal(err, "MUO is a bare module request: it takes no text");
        assert_int_equal(reqp_set_text(&r, "command text", "", err, sizeof(err)), 0);
        assert_true(reqp_encode(&r, line, sizeof(line), err, sizeof(err)) > 0);
        assert_string_equal(line, "command v MUO");
}

/* The longest of each fits a line, with the handle's wait. */
static void test_limits_fit(void **state)
{
        char err[REQP_ERR_MAX], line[CTLP_LINE_MAX];
        struct reqp_request r;

        (void)state;
        reqp_init(&r, REQP_COMMAND);
        assert_int_equal(reqp_set_link(&r, "abcdefghijklmnopqrstuvwxyz01234", err, sizeof(err)),
                         0);
        assert_int_equal(reqp_set_text(&r, "module", "M", err, sizeof(err)), 0);
        assert_int_equal(reqp_set_text(&r, "command text",
                                       "a b c d e f g h i j k l m n o p q r s t u v w x y z 0 1",
                                       err, sizeof(err)), 0);
        r.wait_ms = CTLP_WAIT_MAX_MS;
        assert_true(reqp_encode(&r, line, sizeof(line), err, sizeof(err)) > 0);
        assert_int_equal(reqp_set_text(&r, "command text",
                                       "a b c d e f g h i j k l m n o p q r s t u v w x y z 0 1 2",
                                       err, sizeof(err)), -EINVAL);
        assert_string_equal(err, "command text has more than 28 words");
}

/* ---- what each request is --------------------------------------------------------------------- */

static void test_table(void **state)
{
        static const struct {
                enum reqp_kind kind;
                const char *name, *verb;
                bool link, controller;
                enum reqp_reply reply;
        } cases[] = {
                { REQP_PING, "ping", "ping", false, false, REQP_REPLY_PING },
                { REQP_STATS, "stats", "stats", false, false, REQP_REPLY_LINES },
                { REQP_RECORD, "record", "record", true, false, REQP_REPLY_RECORDING },
                { REQP_QUERY, "query", "query", true, false, REQP_REPLY_VALUE },
                { REQP_COMMAND, "command", "command", true, false, REQP_REPLY_OK },
                { REQP_PEER_PING, "ping-peer", "ping-peer", true, false, REQP_REPLY_RTT },
                { REQP_CIRCE_ALERT, "alert", "circe", true, true, REQP_REPLY_OK },
                { REQP_CIRCE_NETWORK_SETUP, "network-setup", "circe", true, true, REQP_REPLY_OK },
                { REQP_CIRCE_DEVICE_SETUP, "device-setup", "circe", true, true, REQP_REPLY_OK },
                { REQP_CIRCE_SYNC_CLOCKS, "sync-clocks", "circe", true, true, REQP_REPLY_SYNC },
                { REQP_CIRCE_VISUALIZE, "visualize", "circe", true, true, REQP_REPLY_OK },
                { REQP_CIRCE_EMULATE_ACTION, "emulate action", "circe", true, false,
                  REQP_REPLY_OK },
        };

        (void)state;
        assert_int_equal(ARR(cases), REQP_KIND_COUNT);
        for (size_t i = 0; i < ARR(cases); i++) {
                assert_string_equal(reqp_name(cases[i].kind), cases[i].name);
                assert_string_equal(reqp_verb(cases[i].kind), cases[i].verb);
                assert_int_equal(reqp_has_link(cases[i].kind), cases[i].link);
                assert_int_equal(reqp_circe_for_controller(cases[i].kind), cases[i].controller);
                assert_int_equal(reqp_reply_shape(cases[i].kind), cases[i].reply);
        }
        assert_string_equal(reqp_name(REQP_KIND_COUNT), "?");
        assert_false(reqp_has_link(REQP_KIND_COUNT));
}

static void test_sync_result(void **state)
{
        char line[REQP_SYNC_RESULT_SIZE];
        uint32_t a = 0;
        bool ok = true;

        (void)state;
        reqp_sync_result_format(line, sizeof(line), 0xE1E1E1, true);
        assert_string_equal(line, "E1E1E1 succeeded");
        assert_int_equal(reqp_sync_result_parse(line, &a, &ok), 0);
        assert_int_equal(a, 0xE1E1E1);
        assert_true(ok);
        reqp_sync_result_format(line, sizeof(line), 0xAAAAAA, false);
        assert_string_equal(line, "AAAAAA timed-out");
        assert_int_equal(reqp_sync_result_parse(line, &a, &ok), 0);
        assert_false(ok);
        a = 7;
        assert_int_equal(reqp_sync_result_parse("e1e1e1 succeeded", &a, &ok), -EPROTO);
        assert_int_equal(reqp_sync_result_parse("E1E1E1  succeeded", &a, &ok), -EPROTO);
        assert_int_equal(reqp_sync_result_parse("E1E1E1 done", &a, &ok), -EPROTO);
        assert_int_equal(reqp_sync_result_parse("E1E1E1", &a, &ok), -EPROTO);
        assert_int_equal(reqp_sync_result_parse("", &a, &ok), -EPROTO);
        assert_int_equal(reqp_sync_result_parse("FFFFFF succeeded", &a, &ok), -EPROTO);
        assert_int_equal(a, 7);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_accepted),
                cmocka_unit_test(test_decoded_fields),
                cmocka_unit_test(test_refused),
                cmocka_unit_test(test_destination_limit),
                cmocka_unit_test(test_setters),
                cmocka_unit_test(test_encode_refused),
                cmocka_unit_test(test_wait_escape),
                cmocka_unit_test(test_limits_fit),
                cmocka_unit_test(test_table),
                cmocka_unit_test(test_sync_result),
        };

        return cmocka_run_group_tests_name("request_proto", tests, NULL, NULL);
}
