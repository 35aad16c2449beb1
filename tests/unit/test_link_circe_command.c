/*
 * link_circe_command: the CIRCE control words -> typed commands, table-driven.
 *
 * Every accepted command is checked through the codec: the packet it builds must encode to the
 * exact bytes the protocol wants (PROTOCOLS.md 2.2 parameter order), so "only what is given is
 * sent, in the documented order" is tested on the wire form. Every refused one must say why.
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
#include "common/words.h"
#include "daemon/link.h"
#include "daemon/link_circe_command.h"

#define WORDS_MAX 40

/* Renders a packet with <STX>, <TAB>, <ETX> spelled out, no checksum. */
static void render(const struct circe_msg *m, char *out, size_t size)
{
        char pkt[CIRCE_PACKET_MAX];
        int n = circe_encode(m, 0, pkt, sizeof(pkt));

        assert_true(n > 0);
        wire_circe_show((const uint8_t *)pkt, (size_t)n, out, size);
}

struct ok_case {
        const char *line;
        enum link_circe_cmd_kind kind;
        const char *packet;             /* controller operations: the wire form */
        long wait_ms;                   /* -1: no wait= (the core's link_command_wait()) */
};

static const struct ok_case ok_cases[] = {
        { "circe a alert E1E1E1", LINK_CIRCE_CMD_ALERT, "<STX>03<TAB>014:E1E1E1<TAB><ETX>", -1 },
        { "circe a alert e1e1e1", LINK_CIRCE_CMD_ALERT, "<STX>03<TAB>014:E1E1E1<TAB><ETX>", -1 },
        { "circe a alert 000000 wait=500", LINK_CIRCE_CMD_ALERT,
          "<STX>03<TAB>014:000000<TAB><ETX>", 500 },
        { "circe a network-setup AAAAAA join 1", LINK_CIRCE_CMD_NETWORK_SETUP,
          "<STX>04<TAB>014:AAAAAA<TAB>017:1<TAB>020:1<TAB><ETX>", -1 },
        { "circe a network-setup E2E2E2 leave 0", LINK_CIRCE_CMD_NETWORK_SETUP,
          "<STX>04<TAB>014:E2E2E2<TAB>017:0<TAB>020:0<TAB><ETX>", -1 },
        { "circe a network-setup E1E1E1 join 127", LINK_CIRCE_CMD_NETWORK_SETUP,
          "<STX>04<TAB>014:E1E1E1<TAB>017:1<TAB>020:127<TAB><ETX>", -1 },
        { "circe a device-setup 123456", LINK_CIRCE_CMD_DEVICE_SETUP,
          "<STX>05<TAB>026:123456<TAB><ETX>", -1 },
        { "circe a device-setup 222222 - 32", LINK_CIRCE_CMD_DEVICE_SETUP,
          "<STX>05<TAB>026:222222<TAB>019:32<TAB><ETX>", -1 },
        { "circe a device-setup 222222 000001 32", LINK_CIRCE_CMD_DEVICE_SETUP,
          "<STX>05<TAB>014:000001<TAB>026:222222<TAB>019:32<TAB><ETX>", -1 },
        { "circe a device-setup 222222 000001 -", LINK_CIRCE_CMD_DEVICE_SETUP,
          "<STX>05<TAB>014:000001<TAB>026:222222<TAB><ETX>", -1 },
        { "circe a sync-clocks", LINK_CIRCE_CMD_SYNC_CLOCKS, "<STX>06<TAB><ETX>", -1 },
        { "circe a sync-clocks wait=60000", LINK_CIRCE_CMD_SYNC_CLOCKS, "<STX>06<TAB><ETX>",
          60000 },
        { "circe a visualize D15D15 current=12", LINK_CIRCE_CMD_VISUALIZE,
          "<STX>07<TAB>028:12<TAB>014:D15D15<TAB><ETX>", -1 },
        /* Given in any order, sent in the documented one: 034 028 029 030 031 038 032 033 035,
         * then the destinations in the order given. */
        { "circe a visualize D15D15,D25D25 placement=3 refusals=2 faults=1 secondary=999999 "
          "primary=31250 start-timer next=13 current=12 eliminated=1", LINK_CIRCE_CMD_VISUALIZE,
          "<STX>07<TAB>034:1<TAB>028:12<TAB>029:13<TAB>030:1<TAB>031:31250<TAB>038:999999<TAB>"
          "032:1<TAB>033:2<TAB>035:3<TAB>014:D15D15<TAB>014:D25D25<TAB><ETX>", -1 },
        { "circe a visualize d15d15 start-timer wait=1", LINK_CIRCE_CMD_VISUALIZE,
          "<STX>07<TAB>030:1<TAB>014:D15D15<TAB><ETX>", 1 },
        { "circe a visualize D15D15 eliminated=0", LINK_CIRCE_CMD_VISUALIZE,
          "<STX>07<TAB>034:0<TAB>014:D15D15<TAB><ETX>", -1 },
        { "circe a emulate action E1E1E1", LINK_CIRCE_CMD_EMULATE_ACTION, NULL, -1 },
        { "circe a emulate action AAAAAA keys=32768 wait=100", LINK_CIRCE_CMD_EMULATE_ACTION,
          NULL, 100 },
};

static void test_accepted(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(ok_cases) / sizeof(ok_cases[0]); i++) {
                const struct ok_case *k = &ok_cases[i];
                char buf[1024], *argv[WORDS_MAX], err[LINK_CIRCE_CMD_ERR_MAX], wire[1024];
                struct link_circe_cmd cmd;
                unsigned wait_ms;
                int argc;

                snprintf(buf, sizeof(buf), "%s", k->line);
                argc = words_split(buf, argv, WORDS_MAX);
                /* What the core does first: wait=MS comes off the words. */
                assert_int_equal(link_command_wait(&argc, argv, &wait_ms, err, sizeof(err)), 0);
                assert_int_equal(wait_ms, k->wait_ms >= 0 ? k->wait_ms : 0);
                if (link_circe_command_parse(argc, argv, &cmd, err, sizeof(err)) != 0)
                        fail_msg("refused \"%s\": %s", k->line, err);
                assert_int_equal(cmd.kind, k->kind);
                assert_int_equal(link_circe_command_for_controller(cmd.kind),
                                 k->kind != LINK_CIRCE_CMD_EMULATE_ACTION);
                if (!k->packet)
                        continue;
                render(&cmd.msg, wire, sizeof(wire));
                if (strcmp(wire, k->packet) != 0)
                        fail_msg("\"%s\" built %s, expected %s", k->line, wire, k->packet);
        }
}

static void test_emulate_action_fields(void **state)
{
        char buf[] = "circe arena emulate action e1e1e1 sensor-time=5000 keys=0";
        char *argv[WORDS_MAX], err[LINK_CIRCE_CMD_ERR_MAX];
        struct link_circe_cmd cmd;
        int argc = words_split(buf, argv, WORDS_MAX);

        (void)state;
        assert_int_equal(link_circe_command_parse(argc, argv, &cmd, err, sizeof(err)), 0);
        assert_int_equal(cmd.address, 0xE1E1E1);
        assert_int_equal(cmd.keys, 0);
        assert_int_equal(cmd.sensor_time_ms, 5000);

        char buf2[] = "circe arena emulate action AAAAAA";
        argc = words_split(buf2, argv, WORDS_MAX);
        assert_int_equal(link_circe_command_parse(argc, argv, &cmd, err, sizeof(err)), 0);
        assert_int_equal(cmd.keys, -1);
        assert_int_equal(cmd.sensor_time_ms, -1);
}

struct bad_case {
        const char *line;
        const char *message;            /* a part of the error text */
};

static const struct bad_case bad_cases[] = {
        { "circe a", "usage" },
        { "query a B x", "usage" },
        { "circe a dance", "unknown CIRCE operation \"dance\"" },
        { "circe a alert", "missing arguments" },
        { "circe a alert E1E1E1 E2E2E2", "too many arguments" },
        { "circe a alert FFFFFF", "bad address \"FFFFFF\"" },
        { "circe a alert E1E1E", "bad address" },
        { "circe a alert E1E1E1E", "bad address" },
        { "circe a alert G1E1E1", "bad address" },
        { "circe a alert E1E1E1 wait=", "bad wait" },
        { "circe a alert E1E1E1 wait=60001", "bad wait \"60001\": a decimal number 0..60000" },
        { "circe a alert E1E1E1 wait=-5", "bad wait" },
        { "circe a network-setup E1E1E1 join", "missing arguments" },
        { "circe a network-setup E1E1E1 stay 1", "bad membership \"stay\": join or leave" },
        { "circe a network-setup E1E1E1 join 128", "bad roles \"128\": a decimal number 0..127" },
        { "circe a network-setup E1E1E1 join +1", "bad roles" },
        { "circe a network-setup E1E1E1 join 1 2", "too many arguments" },
        { "circe a device-setup", "missing arguments" },
        { "circe a device-setup FFFFFF", "bad address to assign" },
        { "circe a device-setup 123456 XYZ", "bad destination \"XYZ\"" },
        { "circe a device-setup 123456 - 128", "bad capabilities \"128\"" },
        { "circe a device-setup 123456 - 1 2", "too many arguments" },
        { "circe a sync-clocks now", "too many arguments" },
        { "circe a visualize", "missing destination" },
        { "circe a visualize D15D15", "at least one display field" },
        { "circe a visualize D15D15 wait=10", "at least one display field" },
        { "circe a visualize D15D15,", "bad destination \"\"" },
        { "circe a visualize D15D15,,D25D25 current=1", "bad destination" },
        { "circe a visualize D15D15 current=1000", "bad current \"1000\": a decimal number 0..999" },
        { "circe a visualize D15D15 next=abc", "bad next" },
        { "circe a visualize D15D15 primary=1000000", "bad primary" },
        { "circe a visualize D15D15 secondary=", "bad secondary" },
        { "circe a visualize D15D15 faults=100", "bad faults \"100\": a decimal number 0..99" },
        { "circe a visualize D15D15 refusals=100", "bad refusals" },
        { "circe a visualize D15D15 eliminated=2", "bad eliminated \"2\": a decimal number 0..1" },
        { "circe a visualize D15D15 placement=1000", "bad placement" },
        { "circe a visualize D15D15 current=1 current=2", "current given twice" },
        { "circe a visualize D15D15 start-timer=1", "start-timer takes no value" },
        { "circe a visualize D15D15 current", "current needs a value" },
        { "circe a visualize D15D15 colour=red", "unknown field \"colour\"" },
        { "circe a emulate", "usage: emulate action" },
        { "circe a emulate press E1E1E1", "usage: emulate action" },
        { "circe a emulate action", "usage: emulate action" },
        { "circe a emulate action E1E1E1 keys=65536", "bad keys" },
        { "circe a emulate action E1E1E1 sensor-time=1000000", "bad sensor-time" },
        { "circe a emulate action E1E1E1 keys=1 keys=2", "keys given twice" },
        { "circe a emulate action E1E1E1 sensor-time=1 sensor-time=2", "sensor-time given twice" },
        { "circe a emulate action E1E1E1 volume=11", "unknown argument \"volume=11\"" },
        { "circe a emulate action E1E1E1 wait=5 keys=1", "unknown argument \"wait=5\"" },
};

static void test_refused(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(bad_cases) / sizeof(bad_cases[0]); i++) {
                const struct bad_case *k = &bad_cases[i];
                char buf[1024], *argv[WORDS_MAX], err[LINK_CIRCE_CMD_ERR_MAX];
                struct link_circe_cmd cmd;
                unsigned wait_ms;
                int argc, r;

                snprintf(buf, sizeof(buf), "%s", k->line);
                argc = words_split(buf, argv, WORDS_MAX);
                memset(&cmd, 0x5A, sizeof(cmd));
                /* The core's wait=MS check comes first, then the engine's parser. */
                r = link_command_wait(&argc, argv, &wait_ms, err, sizeof(err));
                if (r == 0)
                        r = link_circe_command_parse(argc, argv, &cmd, err, sizeof(err));
                if (r != -EINVAL)
                        fail_msg("\"%s\" accepted (%d)", k->line, r);
                if (!strstr(err, k->message))
                        fail_msg("\"%s\": message \"%s\" lacks \"%s\"", k->line, err, k->message);
                /* ret_* is written only on success. */
                assert_int_equal(((unsigned char *)&cmd)[0], 0x5A);
        }
}

static void test_destination_limit(void **state)
{
        static char buf[(CIRCE_VISUALIZE_DEST_MAX + 1) * 7 + 64];
        char w0[] = "circe", w1[] = "a", w2[] = "visualize", field[] = "current=1";
        char *full[5] = { w0, w1, w2, buf, field };
        char err[LINK_CIRCE_CMD_ERR_MAX];
        struct link_circe_cmd cmd;
        size_t o = 0;

        (void)state;
        for (unsigned i = 0; i < CIRCE_VISUALIZE_DEST_MAX; i++)
                o += (size_t)sprintf(buf + o, "%s%06X", i ? "," : "", 0x100000u + i);
        assert_int_equal(link_circe_command_parse(5, full, &cmd, err, sizeof(err)), 0);
        assert_int_equal(cmd.msg.u.visualize.dest_count, CIRCE_VISUALIZE_DEST_MAX);
        sprintf(buf + o, ",%06X", 0x200000u);
        assert_int_equal(link_circe_command_parse(5, full, &cmd, err, sizeof(err)), -EINVAL);
        assert_non_null(strstr(err, "more than 92 destinations"));
}

static void test_names(void **state)
{
        (void)state;
        assert_string_equal(link_circe_command_name(LINK_CIRCE_CMD_ALERT), "alert");
        assert_string_equal(link_circe_command_name(LINK_CIRCE_CMD_SYNC_CLOCKS), "sync-clocks");
        assert_string_equal(link_circe_command_name(LINK_CIRCE_CMD_EMULATE_ACTION),
                            "emulate action");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_accepted),
                cmocka_unit_test(test_emulate_action_fields),
                cmocka_unit_test(test_refused),
                cmocka_unit_test(test_destination_limit),
                cmocka_unit_test(test_names),
        };

        return cmocka_run_group_tests_name("link_circe_command", tests, NULL, NULL);
}
