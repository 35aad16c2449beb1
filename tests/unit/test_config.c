/*
 * Unit tests for the configuration parser (src/daemon/config.c): the shipped configs load with
 * the expected values, every kind of bad config gives its exact "FILE:LINE:COL: message", and
 * config_link_equal() tells changed links from unchanged ones.
 *
 * Run from the source tree root (as `make check` does): the shipped configs are read from conf/.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <fcntl.h>
#include <limits.h>
#include <regex.h>
#include <unistd.h>

#include <arpa/inet.h>
#include <cmocka.h>

#include "daemon/config.h"

#define REFERENCE_CONF  "conf/sharedlinkd.yaml"
#define DEMO_CONF       "conf/demo.yaml"
#define TEST_FILENAME   "t.yaml"

/* Parses a NUL-terminated YAML text; fails the test with the parser's message on error. */
static struct config *parse_ok(const char *yaml)
{
        struct config *c = NULL;
        struct config_error e;
        int r = config_parse(yaml, strlen(yaml), TEST_FILENAME, &c, &e);

        if (r < 0)
                fail_msg("unexpected error %d: %s", r, e.message);
        assert_non_null(c);
        return c;
}

static struct config *load_ok(const char *path)
{
        struct config *c = NULL;
        struct config_error e;
        int r = config_load_file(path, &c, &e);

        if (r < 0)
                fail_msg("%s: unexpected error %d: %s (run from the source tree root)", path, r,
                         e.message);
        return c;
}

static const struct config_link *link_named(const struct config *c, const char *name)
{
        const struct config_link *l = config_link_find(c, name);

        if (!l)
                fail_msg("no link \"%s\"", name);
        return l;
}

/* ---------------------------------------------------------------------------------------------
 * The shipped configs */

static void test_reference(void **state)
{
        struct config *c = load_ok(REFERENCE_CONF);
        const struct config_link *l;
        const struct config_peer *p;
        const struct sockaddr_in *in4;

        (void)state;
        assert_string_equal(c->instance, "vehicle");
        assert_string_equal(c->runtime_dir, "/run/sharedlink");
        assert_true(c->runtime_dir_set);
        assert_string_equal(c->group, "sharedlink");
        assert_int_equal(c->n_links, 4);
        assert_int_equal(c->n_vars, 23);

        l = link_named(c, "vehicle");
        assert_ptr_equal(l, &c->links[0]);
        assert_int_equal(l->protocol, CONFIG_PROTOCOL_SHAREDLINK);
        assert_int_equal(l->transport, CONFIG_TRANSPORT_SERIAL);
        assert_int_equal(l->n_devices, 1);
        assert_string_equal(l->devices[0], "/dev/ttyUSB0");
        assert_int_equal(l->serial.baud, 115200);
        assert_int_equal(l->serial.parity, CONFIG_PARITY_NONE);
        assert_int_equal(l->serial.data_bits, 8);
        assert_int_equal(l->serial.stop_bits, 1);
        assert_int_equal(l->serial.flow_control, CONFIG_FLOW_NONE);
        assert_int_equal(l->sl.address, 'B');
        assert_int_equal(l->sl.n_peers, 1);
        p = &l->sl.peers[0];
        assert_int_equal(p->address, 'A');
        assert_int_equal(p->period_ms, 100);
        assert_int_equal(p->refresh_ms, 1000);
        assert_int_equal(p->min_interval_ms, 10);
        assert_int_equal(p->stale_ms, 3000);
        assert_int_equal(p->max_frame, 256);
        assert_true(p->compression);
        assert_true(p->on_change);
        assert_int_equal(p->n_outbound, 5);
        assert_string_equal(p->outbound[0].name, "AutoGpsLat");
        assert_int_equal(p->outbound[0].type, CONFIG_VAR_DOUBLE);
        assert_string_equal(p->outbound[3].name, "AutoGpsVel");
        assert_string_equal(p->outbound[4].name, "VehicleName");
        assert_int_equal(p->outbound[4].type, CONFIG_VAR_STRING);
        assert_int_equal(p->n_inbound, 3);
        assert_string_equal(p->inbound[1].name, "CmdSteer");
        assert_int_equal(p->inbound[1].type, CONFIG_VAR_LONG);
        assert_string_equal(p->inbound[2].name, "CmdMode");
        assert_int_equal(p->inbound[2].type, CONFIG_VAR_STRING);

        l = link_named(c, "pronto");
        assert_int_equal(l->transport, CONFIG_TRANSPORT_UDP);
        assert_int_equal(l->n_devices, 0);
        assert_string_equal(l->local.text, "0.0.0.0:4220");
        in4 = (const struct sockaddr_in *)&l->local.addr;
        assert_int_equal(in4->sin_family, AF_INET);
        assert_int_equal(ntohs(in4->sin_port), 4220);
        assert_int_equal(ntohl(in4->sin_addr.s_addr), INADDR_ANY);
        assert_int_equal(l->local.addr_len, sizeof(struct sockaddr_in));
        assert_true(l->has_remote);
        in4 = (const struct sockaddr_in *)&l->remote.addr;
        assert_int_equal(ntohs(in4->sin_port), 4000);
        assert_int_equal(ntohl(in4->sin_addr.s_addr), INADDR_LOOPBACK);
        /* The Pronto4 host: node A, the vehicle is peer B (issue 13.1). */
        assert_int_equal(l->sl.address, 'A');
        assert_true(l->sl.crlf);
        p = &l->sl.peers[0];
        assert_int_equal(p->address, 'B');
        assert_int_equal(p->dialect, CONFIG_DIALECT_PRONTO4);
        assert_true(p->declare);
        assert_false(p->outbound_learn);
        assert_false(p->inbound_learn);
        assert_int_equal(p->learn_max, 0);
        assert_int_equal(p->n_outbound, 10);
        assert_string_equal(p->outbound[0].name, "video_mux1");
        assert_int_equal(p->outbound[1].type, CONFIG_VAR_LONG);
        assert_int_equal(p->outbound[4].type, CONFIG_VAR_DOUBLE);
        assert_int_equal(p->n_inbound, 5);
        assert_int_equal(p->inbound[4].type, CONFIG_VAR_STRING);
        assert_int_equal(p->compression, true);      /* default */
        assert_int_equal(p->on_change, false);       /* default */
        /* The serial link is bulletin, without the pronto4 settings. */
        p = &link_named(c, "vehicle")->sl.peers[0];
        assert_int_equal(p->dialect, CONFIG_DIALECT_BULLETIN);
        assert_false(p->declare);
        assert_false(link_named(c, "vehicle")->sl.crlf);

        l = link_named(c, "agility");
        assert_int_equal(l->protocol, CONFIG_PROTOCOL_CIRCE);
        assert_int_equal(l->circe.role, CONFIG_ROLE_CONTROLLER);
        assert_int_equal(l->n_devices, 2);
        assert_string_equal(l->devices[1], "/dev/ttyUSB2");
        assert_true(l->circe.checksum);
        assert_string_equal(l->circe.expect_version.text, "0.2");
        assert_int_equal(l->circe.expect_version.major, 0);
        assert_int_equal(l->circe.expect_version.minor, 2);
        assert_int_equal(l->circe.login_timeout_ms, 1000);
        assert_int_equal(l->circe.idle_timeout_ms, 2000);

        l = link_named(c, "arena");
        assert_int_equal(l->circe.role, CONFIG_ROLE_MEDIATOR);
        assert_int_equal(l->transport, CONFIG_TRANSPORT_PTY);
        assert_string_equal(l->devices[0], "/run/sharedlink/arena.tty");
        assert_string_equal(l->circe.version.text, "0.2.3");
        assert_int_equal(l->circe.version.patch, 3);
        assert_int_equal(l->circe.status, 0);
        assert_true(l->circe.has_address);
        assert_int_equal(l->circe.address, 0x123456);
        assert_int_equal(l->circe.keepalive_ms, 750);
        assert_int_equal(l->circe.n_emulate, 3);
        assert_int_equal(l->circe.emulate[0].address, 0xE1E1E1);
        assert_int_equal(l->circe.emulate[0].capabilities, 32);
        assert_int_equal(l->circe.emulate[0].signal, 150);
        assert_true(l->circe.emulate[0].has_battery);
        assert_int_equal(l->circe.emulate[0].battery, 200);
        assert_false(l->circe.emulate[0].membership);
        assert_int_equal(l->circe.emulate[1].roles, 1);
        assert_true(l->circe.emulate[1].membership);
        assert_int_equal(l->circe.emulate[1].signal, CONFIG_CIRCE_SIGNAL_DEFAULT);
        assert_false(l->circe.emulate[1].has_battery);
        assert_int_equal(l->circe.emulate[2].address, 0xD15D15);
        assert_int_equal(l->circe.emulate[2].capabilities, 64);
        config_free(c);
}

static void test_demo(void **state)
{
        struct config *c = load_ok(DEMO_CONF);
        const struct config_link *a, *b, *med, *ctl, *host, *veh;

        (void)state;
        assert_string_equal(c->instance, "demo");
        assert_string_equal(c->runtime_dir, "/tmp/sharedlink-demo");
        assert_string_equal(c->group, "");
        assert_int_equal(c->n_links, 6);
        assert_int_equal(c->n_vars, 16);

        a = link_named(c, "node_a");
        b = link_named(c, "node_b");
        assert_int_equal(a->transport, CONFIG_TRANSPORT_PTY);
        assert_int_equal(b->transport, CONFIG_TRANSPORT_SERIAL);
        assert_string_equal(a->devices[0], b->devices[0]);      /* back to back */
        assert_int_equal(a->sl.address, 'A');
        assert_int_equal(a->sl.peers[0].address, 'B');
        assert_int_equal(b->sl.address, 'B');
        assert_int_equal(b->sl.peers[0].address, 'A');
        /* A's outbound list is B's inbound list, position by position, and the other way. */
        assert_int_equal(a->sl.peers[0].n_outbound, 4);
        assert_int_equal(b->sl.peers[0].n_inbound, 4);
        for (unsigned i = 0; i < 4; i++) {
                assert_string_equal(a->sl.peers[0].outbound[i].name + 2,
                                    b->sl.peers[0].inbound[i].name + 2);
                assert_int_equal(a->sl.peers[0].outbound[i].type,
                                 b->sl.peers[0].inbound[i].type);
        }
        assert_string_equal(a->sl.peers[0].outbound[0].name, "a.AutoGpsLat");
        assert_string_equal(b->sl.peers[0].inbound[0].name, "b.AutoGpsLat");
        assert_int_equal(a->sl.peers[0].n_inbound, 2);
        assert_int_equal(b->sl.peers[0].n_outbound, 2);
        assert_string_equal(a->sl.peers[0].inbound[1].name, "a.CmdSteer");
        assert_string_equal(b->sl.peers[0].outbound[1].name, "b.CmdSteer");
        assert_true(a->sl.peers[0].on_change);
        assert_int_equal(a->sl.peers[0].stale_ms, 3000);         /* default: 3 x refresh_ms */
        assert_int_equal(a->sl.peers[0].max_frame, CONFIG_MAX_FRAME_DEFAULT);

        med = link_named(c, "arena");
        ctl = link_named(c, "agility");
        assert_int_equal(med->circe.role, CONFIG_ROLE_MEDIATOR);
        assert_int_equal(med->transport, CONFIG_TRANSPORT_PTY);
        assert_int_equal(ctl->circe.role, CONFIG_ROLE_CONTROLLER);
        assert_int_equal(ctl->transport, CONFIG_TRANSPORT_SERIAL);
        assert_string_equal(med->devices[0], ctl->devices[0]);
        assert_false(med->circe.has_address);
        assert_int_equal(med->circe.status, 0);
        assert_int_equal(med->circe.n_emulate, 3);
        assert_int_equal(med->circe.emulate[0].capabilities, 32);
        assert_int_equal(med->circe.emulate[1].address, 0xAAAAAA);
        assert_int_equal(med->circe.emulate[1].capabilities, 31);
        assert_int_equal(med->circe.emulate[2].capabilities, 64);
        assert_true(ctl->circe.checksum);

        /* Pronto4: the host declares its configured lists, the vehicle learns both; each
         * link's remote is the demo's relay, not the other link. */
        host = link_named(c, "pronto_host");
        veh = link_named(c, "pronto");
        assert_int_equal(host->transport, CONFIG_TRANSPORT_UDP);
        assert_int_equal(veh->transport, CONFIG_TRANSPORT_UDP);
        assert_int_equal(host->sl.address, 'A');
        assert_int_equal(veh->sl.address, 'B');
        assert_int_equal(host->sl.peers[0].dialect, CONFIG_DIALECT_PRONTO4);
        assert_int_equal(veh->sl.peers[0].dialect, CONFIG_DIALECT_PRONTO4);
        assert_true(host->sl.peers[0].declare);
        assert_false(veh->sl.peers[0].declare);
        assert_true(veh->sl.peers[0].outbound_learn && veh->sl.peers[0].inbound_learn);
        assert_int_equal(host->sl.peers[0].n_outbound, 2);
        assert_int_equal(host->sl.peers[0].outbound[0].type, CONFIG_VAR_LONG);
        assert_int_equal(host->sl.peers[0].inbound[1].type, CONFIG_VAR_STRING);
        assert_true(host->sl.crlf && veh->sl.crlf);
        config_free(c);
}

/* Every default, from a config that gives only what is required. */
static void test_defaults(void **state)
{
        struct config *c = parse_ok("links:\n"
                                    "  - name: sl\n"
                                    "    protocol: sharedlink\n"
                                    "    transport: serial\n"
                                    "    device: /dev/ttyS0\n"
                                    "    address: A\n"
                                    "    peers: [{address: B}]\n"
                                    "  - name: ctl\n"
                                    "    protocol: circe\n"
                                    "    role: controller\n"
                                    "    transport: udp\n"
                                    "    local: localhost:0\n"
                                    "  - name: med\n"
                                    "    protocol: circe\n"
                                    "    role: mediator\n"
                                    "    transport: pty\n"
                                    "    device: /tmp/med.tty\n"
                                    "    emulate: [{address: '000000', capabilities: 1}]\n");
        const struct config_link *l = &c->links[0];
        const struct config_peer *p = &l->sl.peers[0];
        const struct config_circe *ci;

        (void)state;
        assert_string_equal(c->instance, CONFIG_INSTANCE_DEFAULT);
        assert_string_equal(c->runtime_dir, CONFIG_RUNTIME_DIR_DEFAULT);
        assert_false(c->runtime_dir_set);
        assert_string_equal(c->group, "");
        assert_int_equal(c->n_vars, 0);
        assert_int_equal(l->serial.baud, CONFIG_BAUD_DEFAULT);
        assert_int_equal(l->serial.parity, CONFIG_PARITY_NONE);
        assert_int_equal(l->serial.data_bits, 8);
        assert_int_equal(l->serial.stop_bits, 1);
        assert_int_equal(l->serial.flow_control, CONFIG_FLOW_NONE);
        assert_int_equal(l->circe.role, CONFIG_ROLE_NONE);
        assert_int_equal(p->period_ms, 100);
        assert_int_equal(p->refresh_ms, 1000);
        assert_int_equal(p->min_interval_ms, 10);
        assert_int_equal(p->stale_ms, 3000);
        assert_int_equal(p->max_frame, 1024);
        assert_true(p->compression);
        assert_false(p->on_change);
        assert_int_equal(p->n_outbound, 0);
        assert_null(p->outbound);
        assert_int_equal(p->n_inbound, 0);

        ci = &c->links[1].circe;
        assert_int_equal(ci->role, CONFIG_ROLE_CONTROLLER);
        assert_true(ci->checksum);
        assert_string_equal(ci->expect_version.text, "0.2");
        assert_int_equal(ci->expect_version.minor, 2);
        assert_int_equal(ci->login_timeout_ms, 1000);
        assert_int_equal(ci->idle_timeout_ms, 2000);
        assert_false(c->links[1].has_remote);
        assert_int_equal(ntohl(((const struct sockaddr_in *)&c->links[1].local.addr)
                               ->sin_addr.s_addr), INADDR_LOOPBACK);

        ci = &c->links[2].circe;
        assert_true(ci->checksum);
        assert_string_equal(ci->version.text, "0.2.3");
        assert_int_equal(ci->status, 0);
        assert_false(ci->has_address);
        assert_int_equal(ci->keepalive_ms, 750);
        assert_int_equal(ci->n_emulate, 1);
        assert_int_equal(ci->emulate[0].address, 0);
        assert_int_equal(ci->emulate[0].signal, 255);
        assert_false(ci->emulate[0].has_battery);
        assert_int_equal(ci->emulate[0].roles, 0);
        assert_false(ci->emulate[0].membership);
        config_free(c);
}

/* Accepted spellings that are easy to get wrong in either direction. */
static void test_accepted_forms(void **state)
{
        struct config *c = parse_ok("\xEF\xBB\xBF# a BOM, then comments\n"
                                    "instance: \"cell-7_b\"\n"
                                    "runtime_dir: '/run/x y'\n"
                                    "group: _sl.grp-1$\n"
                                    "links:\n"
                                    "- name: '0'\n"
                                    "  protocol: sharedlink\n"
                                    "  transport: udp\n"
                                    "  local: \"[::]:4220\"\n"
                                    "  remote: '[::1]:65535'\n"
                                    "  address: P\n"
                                    "  peers:\n"
                                    "  - address: A\n"
                                    "    compression: False\n"
                                    "    on_change: TRUE\n"
                                    "    period_ms: 0\n"
                                    "    stale_ms: 0\n"
                                    "    refresh_ms: 5000\n"
                                    "    max_frame: 4096\n"
                                    "    min_interval_ms: +0\n"
                                    "    outbound: []\n"
                                    "    inbound: [x, 'y.z', {name: \"w-1\", type: long},\n"
                                    "              {type: double, name: v}]\n"
                                    "- {name: c, protocol: circe, role: mediator, transport: "
                                    "serial, devices: [/dev/a, /dev/b], baud: 1200, parity: odd, "
                                    "data_bits: 7, stop_bits: 2, flow_control: xonxoff, "
                                    "version: 999.0.10, status: 999, address: FFFFFE, "
                                    "keepalive_ms: 60000, checksum: false}\n");
        const struct config_link *l = &c->links[0];
        const struct config_peer *p = &l->sl.peers[0];
        const struct sockaddr_in6 *in6 = (const struct sockaddr_in6 *)&l->remote.addr;

        (void)state;
        assert_string_equal(c->instance, "cell-7_b");
        assert_string_equal(c->runtime_dir, "/run/x y");
        assert_string_equal(c->group, "_sl.grp-1$");
        assert_string_equal(l->name, "0");
        assert_int_equal(l->sl.address, 'P');
        assert_int_equal(in6->sin6_family, AF_INET6);
        assert_int_equal(ntohs(in6->sin6_port), 65535);
        assert_true(IN6_IS_ADDR_LOOPBACK(&in6->sin6_addr));
        assert_int_equal(l->remote.addr_len, sizeof(struct sockaddr_in6));
        assert_false(p->compression);
        assert_true(p->on_change);
        assert_int_equal(p->period_ms, 0);
        assert_int_equal(p->stale_ms, 0);              /* given, so not 3 x refresh_ms */
        assert_int_equal(p->max_frame, 4096);
        assert_int_equal(p->min_interval_ms, 0);
        assert_int_equal(p->n_outbound, 0);
        assert_int_equal(p->n_inbound, 4);
        assert_string_equal(p->inbound[1].name, "y.z");
        assert_int_equal(p->inbound[2].type, CONFIG_VAR_LONG);
        assert_string_equal(p->inbound[3].name, "v");
        assert_int_equal(p->inbound[3].type, CONFIG_VAR_DOUBLE);

        l = &c->links[1];
        assert_int_equal(l->n_devices, 2);
        assert_int_equal(l->serial.baud, 1200);
        assert_int_equal(l->serial.parity, CONFIG_PARITY_ODD);
        assert_int_equal(l->serial.data_bits, 7);
        assert_int_equal(l->serial.stop_bits, 2);
        assert_int_equal(l->serial.flow_control, CONFIG_FLOW_XONXOFF);
        assert_int_equal(l->circe.version.major, 999);
        assert_int_equal(l->circe.version.patch, 10);
        assert_int_equal(l->circe.status, 999);
        assert_int_equal(l->circe.address, 0xFFFFFE);
        assert_int_equal(l->circe.keepalive_ms, 60000);
        assert_false(l->circe.checksum);
        assert_int_equal(c->n_vars, 4);
        config_free(c);
}

/* ---------------------------------------------------------------------------------------------
 * Bad configs: each gives exactly this message. */

/* A valid SharedLink link on lines 1..7; cases append lines from 8 on. */
#define SL_LINK "links:\n" /* 1 */ \
        "  - name: sl\n" /* 2 */ \
        "    protocol: sharedlink\n" /* 3 */ \
        "    transport: serial\n" /* 4 */ \
        "    device: /dev/ttyS0\n" /* 5 */ \
        "    address: A\n" /* 6 */ \
        "    peers:\n" /* 7 */
/* A valid first peer on lines 8..9. */
#define SL_PEER "      - address: B\n" /* 8 */ \
        "        outbound: [x1, x2]\n" /* 9 */
/* A CIRCE link header on lines 1..4 (role and transport follow). */
#define CIRCE_LINK "links:\n" /* 1 */ \
        "  - name: ci\n" /* 2 */ \
        "    protocol: circe\n" /* 3 */ \
        "    device: /dev/ttyS1\n" /* 4 */

struct bad_case {
        const char *name;
        const char *yaml;
        const char *message;
};

/* Not const: cmocka's initial_state is a plain void pointer. */
static struct bad_case bad_cases[] = {
        /* YAML itself */
        { "syntax_unclosed_flow", "links: [a, b\n",
          "t.yaml:2:1: did not find expected ',' or ']' (while parsing a flow sequence)" },
        { "syntax_tab_indent", "links:\n\t- a\n",
          "t.yaml:2:1: found character that cannot start any token (while scanning for the next "
          "token)" },
        { "syntax_bad_indent", "links:\n  - name: a\n   protocol: x\n",
          "t.yaml:3:4: did not find expected '-' indicator (while parsing a block "
          "collection)" },
        { "syntax_mapping_in_value", "instance: a: b\n",
          "t.yaml:1:12: mapping values are not allowed in this context" },
        { "syntax_unclosed_quote", "instance: x\ngroup: \"a\n",
          "t.yaml:3:1: found unexpected end of stream (while scanning a quoted scalar)" },
        { "not_utf8_line2", "links: 5\r\ninstance: d\xC3(\n",
          "t.yaml:2:13: invalid trailing UTF-8 octet (0x28)" },
        { "not_utf8", "instance: d\xFFmo\n",
          "t.yaml:1:12: invalid leading UTF-8 octet (0xFF)" },
        { "utf16_bom", "\xFF\xFEi",
          "t.yaml:1:1: invalid leading UTF-8 octet (0xFF)" },
        { "control_character", "instance: a\x01\n",
          "t.yaml:1:12: control characters are not allowed (0x01)" },
        { "empty_file", "", "t.yaml:1:1: empty configuration" },
        { "only_comments", "# nothing\n\n# here\n", "t.yaml:1:1: empty configuration" },
        { "empty_document", "---\n...\n", "t.yaml:1:1: empty configuration" },
        { "root_is_list", "- a\n- b\n",
          "t.yaml:1:1: the configuration must be a mapping, not a list" },
        { "root_is_scalar", "\n  hello\n",
          "t.yaml:2:3: the configuration must be a mapping, not \"hello\"" },
        { "two_documents", "links: []\n---\nlinks: []\n",
          "t.yaml:2:1: only one YAML document is allowed" },
        { "anchor", "instance: &i demo\n",
          "t.yaml:1:11: anchors and aliases are not supported" },
        { "alias", "instance: x\ngroup: *i\n",
          "t.yaml:2:8: anchors and aliases are not supported" },
        { "merge_key", SL_LINK "      - <<: {address: B}\n",
          "t.yaml:8:9: merge keys (\"<<\") are not supported" },
        { "tag", "instance: !!str demo\n", "t.yaml:1:11: tags are not supported" },
        { "complex_key", "? [a]\n: b\n", "t.yaml:1:3: a key must be a string, not a list" },
        { "too_deep", "links: [[[[[[[[[[[[[[[[[[]]]]]]]]]]]]]]]]]]\n",
          "t.yaml:1:23: nested deeper than 16 levels" },

        /* Keys */
        { "unknown_top_key", "instance: x\nlinkz: []\n",
          "t.yaml:2:1: unknown key \"linkz\" at top level" },
        { "unknown_peer_key", SL_LINK SL_PEER "        perod_ms: 50\n",
          "t.yaml:10:9: unknown key \"perod_ms\" in peer" },
        { "unknown_link_key", SL_LINK SL_PEER "    sped: 9600\n",
          "t.yaml:10:5: unknown key \"sped\" in link" },
        { "replay_key_on_serial", SL_LINK SL_PEER "    speed: max\n",
          "t.yaml:10:5: key \"speed\" is not valid for transport serial" },
        { "unknown_variable_key", SL_LINK "      - {address: B, inbound: [{name: v, typ: long}]}\n",
          "t.yaml:8:42: unknown key \"typ\" in variable" },
        { "unknown_emulate_key", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate: [{address: E1E1E1, capabilities: 32, colour: red}]\n",
          "t.yaml:7:51: unknown key \"colour\" in emulated device" },
        { "duplicate_key", SL_LINK SL_PEER "    device: /dev/ttyS9\n",
          "t.yaml:10:5: duplicate key \"device\" (first at 5:5)" },
        { "missing_links", "instance: x\n", "t.yaml:1:1: missing key \"links\"" },
        { "links_empty", "links: []\n", "t.yaml:1:8: links: at least one link is needed" },
        { "links_null", "links:\n", "t.yaml:1:7: links: missing value" },
        { "links_mapping", "links: {a: 1}\n",
          "t.yaml:1:8: links: expected a list, got a mapping" },
        { "link_not_mapping", "links: [vehicle]\n",
          "t.yaml:1:9: link: expected a mapping, got \"vehicle\"" },
        { "missing_name", "links:\n  - protocol: sharedlink\n",
          "t.yaml:2:5: missing key \"name\" in link" },
        { "missing_protocol", "links:\n  - name: x\n",
          "t.yaml:2:5: missing key \"protocol\" in link" },
        { "missing_transport", "links:\n  - name: x\n    protocol: circe\n",
          "t.yaml:2:5: missing key \"transport\" in link" },
        { "missing_role", CIRCE_LINK "    transport: serial\n",
          "t.yaml:2:5: missing key \"role\" in link" },
        { "missing_device", "links:\n  - {name: x, protocol: sharedlink, transport: serial}\n",
          "t.yaml:2:5: missing key \"device\" (or \"devices\") in link" },
        { "missing_device_pty", "links:\n  - {name: x, protocol: sharedlink, transport: pty}\n",
          "t.yaml:2:5: missing key \"device\" in link" },
        { "devices_on_pty", CIRCE_LINK "    role: controller\n    transport: pty\n"
          "    devices: [/dev/a]\n",
          "t.yaml:7:5: key \"devices\" is not valid for transport pty" },
        { "device_and_devices", SL_LINK SL_PEER "    devices: [/dev/ttyS1]\n",
          "t.yaml:10:5: keys \"device\" and \"devices\" are exclusive" },
        { "devices_empty", "links:\n  - {name: x, protocol: sharedlink, transport: serial, "
          "devices: []}\n",
          "t.yaml:2:65: devices: at least one device is needed" },
        { "missing_address", "links:\n  - {name: x, protocol: sharedlink, transport: serial, "
          "device: /dev/a}\n",
          "t.yaml:2:5: missing key \"address\" in link" },
        { "missing_peers", "links:\n  - {name: x, protocol: sharedlink, transport: serial, "
          "device: /dev/a, address: A}\n",
          "t.yaml:2:5: missing key \"peers\" in link" },
        { "peers_empty", SL_LINK "      []\n", "t.yaml:8:7: peers: at least one peer is needed" },
        { "peer_missing_address", SL_LINK "      - period_ms: 10\n",
          "t.yaml:8:9: missing key \"address\" in peer" },
        { "udp_without_local", "links:\n  - name: u\n    protocol: sharedlink\n"
          "    transport: udp\n    remote: 127.0.0.1:4000\n",
          "t.yaml:2:5: missing key \"local\" in link" },
        { "variable_missing_name", SL_LINK "      - {address: B, outbound: [{type: long}]}\n",
          "t.yaml:8:33: missing key \"name\" in variable" },
        { "emulate_missing_capabilities", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate: [{address: E1E1E1}]\n",
          "t.yaml:7:15: missing key \"capabilities\" in emulated device" },

        /* Protocol, role and transport combinations */
        { "role_on_sharedlink", SL_LINK SL_PEER "    role: controller\n",
          "t.yaml:10:5: key \"role\" is not valid for protocol sharedlink" },
        { "peers_on_circe", CIRCE_LINK "    role: controller\n    transport: serial\n"
          "    peers: []\n",
          "t.yaml:7:5: key \"peers\" is not valid for protocol circe" },
        { "emulate_on_controller", CIRCE_LINK "    role: controller\n    transport: serial\n"
          "    emulate: []\n",
          "t.yaml:7:5: key \"emulate\" is not valid for role controller" },
        { "address_on_controller", CIRCE_LINK "    address: \"123456\"\n"
          "    role: controller\n    transport: serial\n",
          "t.yaml:5:5: key \"address\" is not valid for role controller" },
        { "expect_version_on_mediator", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    expect_version: \"0.2\"\n",
          "t.yaml:7:5: key \"expect_version\" is not valid for role mediator" },
        { "baud_on_udp", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: '127.0.0.1:1', baud: 9600}\n",
          "t.yaml:2:88: key \"baud\" is not valid for transport udp" },
        { "local_on_serial", SL_LINK SL_PEER "    local: 127.0.0.1:1\n",
          "t.yaml:10:5: key \"local\" is not valid for transport serial" },
        { "protocol_unknown", "links:\n  - {name: x, protocol: kermit}\n",
          "t.yaml:2:25: protocol: expected sharedlink or circe, got \"kermit\"" },
        { "transport_unknown", "links:\n  - {name: x, protocol: circe, transport: usb}\n",
          "t.yaml:2:43: transport: expected serial, udp, pty or replay, got \"usb\"" },
        { "role_unknown", CIRCE_LINK "    transport: serial\n    role: gateway\n",
          "t.yaml:6:11: role: expected controller or mediator, got \"gateway\"" },

        /* Types and ranges */
        { "baud_low", SL_LINK SL_PEER "    baud: 300\n",
          "t.yaml:10:11: baud 300 out of range (1200..4000000)" },
        { "baud_high", SL_LINK SL_PEER "    baud: 4000001\n",
          "t.yaml:10:11: baud 4000001 out of range (1200..4000000)" },
        { "baud_overflow", SL_LINK SL_PEER "    baud: 99999999999999999999999999999\n",
          "t.yaml:10:11: baud 999999999999999999999999... out of range (1200..4000000)" },
        { "baud_word", SL_LINK SL_PEER "    baud: fast\n",
          "t.yaml:10:11: baud: expected an integer, got \"fast\"" },
        { "baud_trailing_garbage", SL_LINK SL_PEER "    baud: 115200x\n",
          "t.yaml:10:11: baud: expected an integer, got \"115200x\"" },
        { "baud_float", SL_LINK SL_PEER "    baud: 9600.0\n",
          "t.yaml:10:11: baud: expected an integer, got \"9600.0\"" },
        { "baud_sign_only", SL_LINK SL_PEER "    baud: +\n",
          "t.yaml:10:11: baud: expected an integer, got \"+\"" },
        { "baud_hex", SL_LINK SL_PEER "    baud: 0x2580\n",
          "t.yaml:10:11: baud: expected an integer, got \"0x2580\"" },
        { "baud_leading_zero", SL_LINK SL_PEER "    baud: 09600\n",
          "t.yaml:10:11: baud: leading zeros are not allowed in \"09600\"" },
        { "baud_quoted", SL_LINK SL_PEER "    baud: \"115200\"\n",
          "t.yaml:10:11: baud: expected an integer, got a quoted string" },
        { "baud_list", SL_LINK SL_PEER "    baud: [115200]\n",
          "t.yaml:10:11: baud: expected an integer, got a list" },
        { "baud_missing_value", SL_LINK SL_PEER "    baud:\n    parity: none\n",
          "t.yaml:10:10: baud: missing value" },
        { "period_negative", SL_LINK "      - {address: B, period_ms: -5}\n",
          "t.yaml:8:33: period_ms -5 out of range (0..60000)" },
        { "period_high", SL_LINK "      - {address: B, period_ms: 60001}\n",
          "t.yaml:8:33: period_ms 60001 out of range (0..60000)" },
        { "refresh_low", SL_LINK "      - {address: B, refresh_ms: 9}\n",
          "t.yaml:8:34: refresh_ms 9 out of range (10..3600000)" },
        { "stale_high", SL_LINK "      - {address: B, stale_ms: 3600001}\n",
          "t.yaml:8:32: stale_ms 3600001 out of range (0..3600000)" },
        { "min_interval_high", SL_LINK "      - {address: B, min_interval_ms: 60001}\n",
          "t.yaml:8:39: min_interval_ms 60001 out of range (0..60000)" },
        { "max_frame_low", SL_LINK "      - {address: B, max_frame: 31}\n",
          "t.yaml:8:33: max_frame 31 out of range (32..4096)" },
        { "max_frame_high", SL_LINK "      - {address: B, max_frame: 4097}\n",
          "t.yaml:8:33: max_frame 4097 out of range (32..4096)" },
        { "bool_yes", SL_LINK "      - {address: B, compression: yes}\n",
          "t.yaml:8:35: compression: expected true or false, got \"yes\"" },
        { "bool_number", SL_LINK "      - {address: B, on_change: 1}\n",
          "t.yaml:8:33: on_change: expected true or false, got \"1\"" },
        { "bool_quoted", SL_LINK "      - {address: B, on_change: 'true'}\n",
          "t.yaml:8:33: on_change: expected true or false, got a quoted string" },
        { "parity_unknown", SL_LINK SL_PEER "    parity: mark\n",
          "t.yaml:10:13: parity: expected none, even or odd, got \"mark\"" },
        { "data_bits", SL_LINK SL_PEER "    data_bits: 6\n",
          "t.yaml:10:16: data_bits 6 out of range (7..8)" },
        { "stop_bits", SL_LINK SL_PEER "    stop_bits: 3\n",
          "t.yaml:10:16: stop_bits 3 out of range (1..2)" },
        { "flow_unknown", SL_LINK SL_PEER "    flow_control: hardware\n",
          "t.yaml:10:19: flow_control: expected none, rtscts or xonxoff, got \"hardware\"" },
        { "login_timeout_low", CIRCE_LINK "    role: controller\n    transport: serial\n"
          "    login_timeout_ms: 99\n",
          "t.yaml:7:23: login_timeout_ms 99 out of range (100..60000)" },
        { "idle_timeout_high", CIRCE_LINK "    role: controller\n    transport: serial\n"
          "    idle_timeout_ms: 60001\n",
          "t.yaml:7:22: idle_timeout_ms 60001 out of range (100..60000)" },
        { "keepalive_zero", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    keepalive_ms: 0\n",
          "t.yaml:7:19: keepalive_ms 0 out of range (10..60000)" },
        { "status_high", CIRCE_LINK "    role: mediator\n    transport: pty\n    status: 1000\n",
          "t.yaml:7:13: status 1000 out of range (0..999)" },

        /* SharedLink addresses */
        { "address_letter", SL_LINK "      - address: Q\n",
          "t.yaml:8:18: address \"Q\" is not a SharedLink node address (A..P)" },
        { "address_lowercase", SL_LINK "      - address: b\n",
          "t.yaml:8:18: address \"b\" is not a SharedLink node address (A..P)" },
        { "address_long", "links:\n  - {name: x, protocol: sharedlink, transport: serial, "
          "device: /dev/a, address: AB}\n",
          "t.yaml:2:81: address \"AB\" is not a SharedLink node address (A..P)" },
        { "peer_is_self", SL_LINK "      - address: A\n",
          "t.yaml:8:18: peer address A is the link's own address" },
        { "peer_duplicate", SL_LINK SL_PEER "      - address: B\n",
          "t.yaml:10:18: duplicate peer address B (first at 8:18)" },

        /* UDP endpoints */
        { "endpoint_no_port", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: 127.0.0.1}\n",
          "t.yaml:2:73: local: bad address \"127.0.0.1\" (expected IPV4:PORT, [IPV6]:PORT or "
          "localhost:PORT)" },
        { "endpoint_hostname", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: 'gateway:4000'}\n",
          "t.yaml:2:73: local: bad address \"gateway:4000\" (expected IPV4:PORT, [IPV6]:PORT or "
          "localhost:PORT)" },
        { "endpoint_v6_unbracketed", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: '::1:4000'}\n",
          "t.yaml:2:73: local: bad address \"::1:4000\" (expected IPV4:PORT, [IPV6]:PORT or "
          "localhost:PORT)" },
        { "endpoint_short_v4", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: '10.1:4000'}\n",
          "t.yaml:2:73: local: bad address \"10.1:4000\" (expected IPV4:PORT, [IPV6]:PORT or "
          "localhost:PORT)" },
        { "endpoint_v6_no_port", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: '[::1]'}\n",
          "t.yaml:2:73: local: bad address \"[::1]\" (expected IPV4:PORT, [IPV6]:PORT or "
          "localhost:PORT)" },
        { "endpoint_v6_bad", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: '[::g]:1'}\n",
          "t.yaml:2:73: local: bad address \"[::g]:1\" (expected IPV4:PORT, [IPV6]:PORT or "
          "localhost:PORT)" },
        { "endpoint_empty_port", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: '127.0.0.1:'}\n",
          "t.yaml:2:73: local: bad address \"127.0.0.1:\" (expected IPV4:PORT, [IPV6]:PORT or "
          "localhost:PORT)" },
        { "endpoint_port_garbage", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: '127.0.0.1:80x'}\n",
          "t.yaml:2:73: local: bad address \"127.0.0.1:80x\" (expected IPV4:PORT, [IPV6]:PORT or "
          "localhost:PORT)" },
        { "endpoint_port_huge", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: '127.0.0.1:99999999999999999999'}\n",
          "t.yaml:2:73: local: port 99999999999999999999 out of range (0..65535)" },
        { "endpoint_port_range", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: '[::1]:70000'}\n",
          "t.yaml:2:73: local: port 70000 out of range (0..65535)" },
        { "endpoint_remote_port_zero", "links:\n  - {name: u, protocol: circe, role: controller, "
          "transport: udp, local: 'localhost:1', remote: 'localhost:0'}\n",
          "t.yaml:2:96: remote: port 0 out of range (1..65535)" },

        /* CIRCE values */
        { "circe_address_lowercase", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate: [{address: e1e1e1, capabilities: 32}]\n",
          "t.yaml:7:25: address \"e1e1e1\": expected six uppercase hex digits" },
        { "circe_address_short", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    address: 12345\n",
          "t.yaml:7:14: address \"12345\": expected six uppercase hex digits" },
        { "circe_address_empty", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    address: ''\n",
          "t.yaml:7:14: address \"\": expected six uppercase hex digits" },
        { "circe_address_reserved", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate: [{address: FFFFFF, capabilities: 32}]\n",
          "t.yaml:7:25: address FFFFFF is reserved" },
        { "circe_emulate_duplicate", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate:\n      - {address: E1E1E1, capabilities: 32}\n"
          "      - {address: E1E1E1, capabilities: 64}\n",
          "t.yaml:9:19: duplicate emulated device E1E1E1 (first at 8:19)" },
        { "emulate_missing_address", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate:\n      - capabilities: 32\n",
          "t.yaml:8:9: missing key \"address\" in emulated device" },
        { "emulate_not_list", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate: {address: E1E1E1, capabilities: 32}\n",
          "t.yaml:7:14: emulate: expected a list, got a mapping" },
        { "capabilities_zero", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate: [{address: E1E1E1, capabilities: 0}]\n",
          "t.yaml:7:47: capabilities 0 out of range (1..127)" },
        { "capabilities_high", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate: [{address: E1E1E1, capabilities: 128}]\n",
          "t.yaml:7:47: capabilities 128 out of range (1..127)" },
        { "signal_high", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate: [{address: E1E1E1, capabilities: 1, signal: 256}]\n",
          "t.yaml:7:58: signal 256 out of range (0..255)" },
        { "battery_negative", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate: [{address: E1E1E1, capabilities: 1, battery: -1}]\n",
          "t.yaml:7:59: battery -1 out of range (0..255)" },
        { "roles_high", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    emulate: [{address: E1E1E1, capabilities: 1, roles: 128}]\n",
          "t.yaml:7:57: roles 128 out of range (0..127)" },
        { "expect_version_three_parts", CIRCE_LINK "    role: controller\n"
          "    transport: serial\n    expect_version: 0.2.3\n",
          "t.yaml:7:21: expect_version: expected MAJOR.MINOR (e.g. \"0.2\"), got \"0.2.3\"" },
        { "version_two_parts", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    version: \"0.2\"\n",
          "t.yaml:7:14: version: expected MAJOR.MINOR.PATCH (e.g. \"0.2.3\"), got \"0.2\"" },
        { "version_four_digits", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    version: 1000.2.3\n",
          "t.yaml:7:14: version: expected MAJOR.MINOR.PATCH (e.g. \"0.2.3\"), got \"1000.2.3\"" },
        { "version_letters", CIRCE_LINK "    role: mediator\n    transport: pty\n"
          "    version: v0.2.3\n",
          "t.yaml:7:14: version: expected MAJOR.MINOR.PATCH (e.g. \"0.2.3\"), got \"v0.2.3\"" },

        /* Names */
        { "variable_bad_char", SL_LINK "      - {address: B, outbound: [\"a|b\"]}\n",
          "t.yaml:8:33: variable name \"a|b\": invalid character \"|\" (allowed: letters, digits, "
          "_ . -)" },
        { "variable_space", SL_LINK "      - {address: B, outbound: [\"a b\"]}\n",
          "t.yaml:8:33: variable name \"a b\": invalid character \" \" (allowed: letters, digits, "
          "_ . -)" },
        { "variable_bracket", SL_LINK "      - {address: B, inbound: [\"x[1]\"]}\n",
          "t.yaml:8:32: variable name \"x[1]\": invalid character \"[\" (allowed: letters, digits, "
          "_ . -)" },
        { "variable_too_long", SL_LINK "      - address: B\n        outbound:\n"
          "          - abcdefghijabcdefghijabcdefghijabcdefghijabcdefgh\n",
          "t.yaml:10:13: variable name: \"abcdefghijabcdefghijabcdefghijabcdefghij\"... too long "
          "(48 bytes, at most 47)" },
        { "variable_empty", SL_LINK "      - {address: B, outbound: [\"\"]}\n",
          "t.yaml:8:33: variable name: empty string" },
        { "variable_null", SL_LINK "      - address: B\n        outbound:\n          -\n",
          "t.yaml:10:12: variable name: missing value" },
        { "variable_is_list", SL_LINK "      - {address: B, outbound: [[a]]}\n",
          "t.yaml:8:33: variable: expected a name or {name, type}, got a list" },
        { "variable_type", SL_LINK "      - {address: B, outbound: [{name: v, type: float}]}\n",
          "t.yaml:8:49: type: expected string, long or double, got \"float\"" },
        { "variable_list_not_list", SL_LINK "      - {address: B, outbound: AutoGpsLat}\n",
          "t.yaml:8:32: outbound: expected a list, got \"AutoGpsLat\"" },
        { "duplicate_variable_in_list", SL_LINK "      - {address: B, outbound: [v, w, v]}\n",
          "t.yaml:8:39: duplicate variable name \"v\" (first at 8:33)" },
        { "duplicate_variable_across_links", SL_LINK SL_PEER
          "  - name: sl2\n    protocol: sharedlink\n    transport: serial\n"
          "    device: /dev/ttyS2\n    address: C\n"
          "    peers: [{address: D, inbound: [y, x2]}]\n",
          "t.yaml:15:39: duplicate variable name \"x2\" (first at 9:24)" },
        { "variable_in_circe_namespace", SL_LINK "      - {address: B, inbound: [agility.state]}\n"
          "  - {name: agility, protocol: circe, role: controller, transport: serial, "
          "device: /dev/ttyS1}\n",
          "t.yaml:8:32: variable name \"agility.state\" is in the namespace of circe link "
          "\"agility\"" },
        { "duplicate_link_name", SL_LINK SL_PEER "  - {name: sl, protocol: circe}\n",
          "t.yaml:10:12: duplicate link name \"sl\" (first at 2:11)" },
        { "link_name_dot", "links:\n  - name: a.b\n",
          "t.yaml:2:11: link name \"a.b\": invalid character '.' (allowed: letters, digits, _ -)" },
        { "link_name_dash", "links:\n  - name: -x\n",
          "t.yaml:2:11: link name \"-x\" must not start with '-'" },
        { "link_name_too_long", "links:\n  - name: fifteen_chars_x\n",
          "t.yaml:2:11: link name: \"fifteen_chars_x\" too long (15 bytes, at most 14)" },
        { "instance_space", "instance: my demo\nlinks: []\n",
          "t.yaml:1:11: instance \"my demo\": invalid character ' ' (allowed: letters, digits, _ "
          "-)" },
        { "instance_slash", "instance: a/b\nlinks: []\n",
          "t.yaml:1:11: instance \"a/b\": invalid character '/' (allowed: letters, digits, _ -)" },
        { "instance_too_long", "instance: abcdefghijabcdefghijabcdefghijabc\n",
          "t.yaml:1:11: instance: \"abcdefghijabcdefghijabcdefghijabc\" too long (33 bytes, at "
          "most 32)" },
        { "group_digit", "group: 1abc\n",
          "t.yaml:1:8: group \"1abc\" is not a valid group name" },
        { "group_colon", "group: 'a:b'\n",
          "t.yaml:1:8: group \"a:b\" is not a valid group name" },
        { "runtime_dir_relative", "runtime_dir: run/sl\n",
          "t.yaml:1:14: runtime_dir: \"run/sl\" is not an absolute path" },
        { "devices_relative", "links:\n  - {name: x, protocol: sharedlink, transport: serial, "
          "devices: [/dev/a, ttyS0]}\n",
          "t.yaml:2:74: devices: \"ttyS0\" is not an absolute path" },
        { "device_relative_single", "links:\n  - {name: x, protocol: sharedlink, transport: pty, "
          "device: x.tty}\n",
          "t.yaml:2:61: device: \"x.tty\" is not an absolute path" },
        { "device_nul_escape", "links:\n  - {name: x, protocol: sharedlink, transport: pty, "
          "device: \"/dev/x\\0y\"}\n",
          "t.yaml:2:61: device: control character in \"/dev/x\\x00y\"" },
        { "device_newline_escape", "links:\n  - {name: x, protocol: sharedlink, transport: pty, "
          "device: \"/dev/x\\ny\"}\n",
          "t.yaml:2:61: device: control character in \"/dev/x\\x0Ay\"" },
        { "too_many_devices", "links:\n  - {name: c, protocol: circe, role: controller, "
          "transport: serial, devices: [/dev/1, /dev/2, /dev/3, /dev/4, /dev/5, /dev/6, /dev/7, "
          "/dev/8, /dev/9]}\n",
          "t.yaml:2:143: too many devices (at most 8)" },
        { "device_used_twice", SL_LINK SL_PEER
          "  - {name: c, protocol: circe, role: controller, transport: serial, "
          "devices: [/dev/ttyS1, /dev/ttyS0]}\n",
          "t.yaml:10:91: device \"/dev/ttyS0\" is already used by link \"sl\" (5:13)" },
        { "device_twice_in_list", "links:\n  - {name: c, protocol: circe, role: controller, "
          "transport: serial, devices: [/dev/a, /dev/a]}\n",
          "t.yaml:2:87: device \"/dev/a\" is already used by link \"c\" (2:79)" },
        { "socket_path_too_long", "runtime_dir: /aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"
          "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\ninstance: demo\n" SL_LINK
          "      - address: B\n",
          "t.yaml:1:14: runtime_dir \"/aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa\"... too long: the "
          "control socket path would be 108 bytes (at most 107)" },
};

static void test_bad(void **state)
{
        const struct bad_case *t = *state;
        static struct config sentinel;  /* *ret_config must stay untouched on failure */
        struct config *c = &sentinel;
        struct config_error e;
        char prefix[64];
        int r;

        memset(&e, 0x5a, sizeof(e));
        /* Exactly the bytes of the case, in their own allocation, so ASan sees any overread. */
        size_t len = strlen(t->yaml);
        char *copy = malloc(len ? len : 1);

        assert_non_null(copy);
        memcpy(copy, t->yaml, len);
        r = config_parse(copy, len, TEST_FILENAME, &c, &e);
        free(copy);
        assert_int_equal(r, -EINVAL);
        assert_ptr_equal(c, &sentinel);
        assert_string_equal(e.message, t->message);
        /* The position fields agree with the message. */
        snprintf(prefix, sizeof(prefix), TEST_FILENAME ":%u:%u: ", e.line, e.column);
        assert_true(e.line > 0 && e.column > 0);
        assert_memory_equal(e.message, prefix, strlen(prefix));
}

/* ---------------------------------------------------------------------------------------------
 * Bounds, built programmatically */

struct text {
        char *buf;
        size_t len, cap;
};

static void text_add(struct text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static void text_add(struct text *t, const char *fmt, ...)
{
        va_list ap;
        int n;

        for (;;) {
                va_start(ap, fmt);
                n = vsnprintf(t->buf + t->len, t->cap - t->len, fmt, ap);
                va_end(ap);
                assert_true(n >= 0);
                if ((size_t)n < t->cap - t->len)
                        break;
                t->cap = t->cap ? t->cap * 2 + (size_t)n : 4096;
                t->buf = realloc(t->buf, t->cap);
                assert_non_null(t->buf);
        }
        t->len += (size_t)n;
}

static void expect_error(const struct text *t, int code, const char *message)
{
        struct config *c = NULL;
        struct config_error e;
        int r = config_parse(t->buf, t->len, TEST_FILENAME, &c, &e);

        assert_int_equal(r, code);
        assert_null(c);
        assert_string_equal(e.message, message);
}

static void add_sl_link(struct text *t, unsigned i)
{
        text_add(t, "  - {name: l%u, protocol: sharedlink, transport: serial, device: /dev/t%u, "
                 "address: A, peers: [{address: B}]}\n", i, i);
}

static void test_too_many_links(void **state)
{
        struct text t = { 0 };

        (void)state;
        text_add(&t, "links:\n");
        for (unsigned i = 0; i < CONFIG_LINKS_MAX; i++)
                add_sl_link(&t, i);
        {
                struct config *c = NULL;
                struct config_error e;

                assert_int_equal(config_parse(t.buf, t.len, TEST_FILENAME, &c, &e), 0);
                assert_int_equal(c->n_links, CONFIG_LINKS_MAX);
                config_free(c);
        }
        add_sl_link(&t, CONFIG_LINKS_MAX);
        expect_error(&t, -EINVAL, "t.yaml:18:5: too many links (at most 16)");
        free(t.buf);
}

static void test_too_many_peers(void **state)
{
        struct text t = { 0 };

        (void)state;
        text_add(&t, "links:\n  - {name: x, protocol: sharedlink, transport: serial, "
                 "device: /dev/a, address: A, peers: [");
        for (char a = 'B'; a <= 'P'; a++)
                text_add(&t, "{address: %c}, ", a);
        text_add(&t, "{address: B}]}\n");
        expect_error(&t, -EINVAL, "t.yaml:2:302: too many peers (at most 15)");
        free(t.buf);
}

/* An instance at its cap: links of one peer with both lists full, the names v0, v1, ... in
 * order, three lines a link (the last ends with the last name, then "]}]}\n"). */
static void text_at_cap(struct text *t)
{
        unsigned n = 0;

        text_add(t, "links:\n");
        for (unsigned l = 0; l < CONFIG_VARS_MAX / (2 * CONFIG_LIST_MAX); l++) {
                text_add(t, "  - {name: l%u, protocol: sharedlink, transport: serial, "
                         "device: /dev/t%u, address: A, peers: [{address: B,\n", l, l);
                for (unsigned dir = 0; dir < 2; dir++) {
                        text_add(t, "      %s: [", dir ? "inbound" : "outbound");
                        for (unsigned i = 0; i < CONFIG_LIST_MAX; i++)
                                text_add(t, "%sv%u", i ? "," : "", n++);
                        text_add(t, "]%s\n", dir ? "}]}" : ",");
                }
        }
}

/*
 * Lists up to their bound load, and an instance up to its cap: 4,096 variables (issue 23: the
 * cap was 1,024 while a quadratic check of unique names held it). One more variable is refused,
 * per list and per instance.
 */
static void test_too_many_variables(void **state)
{
        struct text t = { 0 };
        struct config *c = NULL;
        struct config_error e;

        (void)state;
        text_at_cap(&t);
        assert_int_equal(config_parse(t.buf, t.len, TEST_FILENAME, &c, &e), 0);
        assert_int_equal(c->n_vars, 4096);
        assert_int_equal(c->n_links, 8);
        assert_string_equal(c->links[0].sl.peers[0].outbound[0].name, "v0");
        assert_string_equal(c->links[7].sl.peers[0].inbound[255].name, "v4095");
        config_free(c);

        text_add(&t, "  - {name: x, protocol: sharedlink, transport: serial, device: /dev/x, "
                 "address: A, peers: [{address: B, inbound: [one_more]}]}\n");
        expect_error(&t, -EINVAL,
                     "t.yaml:26:115: too many variables (at most 4096 per instance)");

        t.len = 0;
        text_add(&t, "links:\n  - {name: x, protocol: sharedlink, transport: serial, "
                 "device: /dev/x, address: A, peers: [{address: B, inbound: [");
        for (unsigned i = 0; i <= CONFIG_LIST_MAX; i++)
                text_add(&t, "%sv%u", i ? "," : "", i);
        text_add(&t, "]}]}\n");
        expect_error(&t, -EINVAL,
                     "t.yaml:2:114: inbound: too many variables (257, at most 256 per list)");
        free(t.buf);
}

/* A text that states a cap: a number (commas allowed, "4,096") before "per instance" or "per
 * list", e.g. "4096 configured variables per instance", "256 variables per list". */
#define CAP_PATTERN     "([0-9][0-9,]*) (configured )?(variables )?per (instance|list)"
#define CAP_FILE_MAX    (256u * 1024u)

/* Every cap stated in the file at path is the one the parser enforces; the number of statements
 * found is added to *found. */
static void caps_stated_in(const char *path, const regex_t *re, unsigned *found)
{
        char *text = malloc(CAP_FILE_MAX + 1), number[16];
        regmatch_t m[5];
        size_t len, n = 0;
        FILE *f = fopen(path, "rb");

        assert_non_null(text);
        if (!f)
                fail_msg("%s: %s (run from the source tree root)", path, strerror(errno));
        len = fread(text, 1, CAP_FILE_MAX, f);
        fclose(f);
        for (size_t i = 0; i < len; i++)        /* fuzz inputs may hold NULs */
                if (text[i] == '\0')
                        text[i] = ' ';
        text[len] = '\0';
        for (const char *p = text; regexec(re, p, 5, m, 0) == 0; p += m[0].rm_eo) {
                unsigned long want = p[m[4].rm_so] == 'i' ? CONFIG_VARS_MAX : CONFIG_LIST_MAX;

                n = 0;
                for (regoff_t i = m[1].rm_so; i < m[1].rm_eo && n + 1 < sizeof(number); i++)
                        if (p[i] != ',')
                                number[n++] = p[i];
                number[n] = '\0';
                if (strtoul(number, NULL, 10) != want)
                        fail_msg("%s: \"%.*s\" says %s, the cap is %lu", path,
                                 (int)(m[0].rm_eo - m[0].rm_so), p + m[0].rm_so, number, want);
                (*found)++;
        }
        free(text);
}

/*
 * The caps as the reference configuration, its copies in the fuzz corpus, the man page and the
 * docs state them are the parser's (CONFIG_VARS_MAX, CONFIG_LIST_MAX): the corpus's copies of
 * sharedlinkd.yaml kept saying 1,024 per instance after the cap was raised to 4,096.
 */
static void test_caps_stated(void **state)
{
        static const char *const files[] = {
                REFERENCE_CONF, "man/sharedlinkd.yaml.5", "README.md", "docs/running.md",
                "docs/testing.md",
        };
        static const char *const dirs[] = { "tests/fuzz/corpus/config" };
        char path[PATH_MAX];
        unsigned found = 0, reference = 0;
        struct dirent *de;
        regex_t re;
        DIR *dir;

        (void)state;
        assert_int_equal(regcomp(&re, CAP_PATTERN, REG_EXTENDED), 0);
        caps_stated_in(REFERENCE_CONF, &re, &reference);
        assert_int_equal(reference, 2);         /* the test reads what it should */
        for (size_t i = 0; i < sizeof(files) / sizeof(files[0]); i++)
                caps_stated_in(files[i], &re, &found);
        for (size_t i = 0; i < sizeof(dirs) / sizeof(dirs[0]); i++) {
                dir = opendir(dirs[i]);
                if (!dir)
                        fail_msg("%s: %s (run from the source tree root)", dirs[i],
                                 strerror(errno));
                while ((de = readdir(dir)) != NULL) {
                        if (de->d_name[0] == '.')
                                continue;
                        snprintf(path, sizeof(path), "%s/%s", dirs[i], de->d_name);
                        caps_stated_in(path, &re, &found);
                }
                closedir(dir);
        }
        assert_true(found > reference);
        regfree(&re);
}

/* At the cap, the last name repeats an earlier one: refused at the repeat, naming the first. */
static void test_duplicate_at_cap(void **state)
{
        static const char *const repeats[][2] = {
                /* the name, where it first is (line:column) */
                { "v0", "3:18" },       /* the first of all */
                { "v2048", "15:18" },   /* the first of the fifth link */
                { "v4094", "25:1541" }, /* the one just before it */
        };
        struct text t = { 0 };
        char expected[CONFIG_ERROR_MAX];

        (void)state;
        for (size_t k = 0; k < sizeof(repeats) / sizeof(repeats[0]); k++) {
                const char *tail = "v4095]}]}\n";
                size_t line = 0, column;

                t.len = 0;
                text_at_cap(&t);
                assert_true(t.len > strlen(tail));
                t.len -= strlen(tail);
                for (size_t i = 0; i < t.len; i++)
                        if (t.buf[i] == '\n')
                                line = i + 1;   /* where the last line begins */
                column = t.len - line + 1;      /* where the repeat goes */
                text_add(&t, "%s]}]}\n", repeats[k][0]);
                snprintf(expected, sizeof(expected),
                         "t.yaml:25:%zu: duplicate variable name \"%s\" (first at %s)", column,
                         repeats[k][0], repeats[k][1]);
                expect_error(&t, -EINVAL, expected);
        }
        free(t.buf);
}

static void test_too_many_emulated(void **state)
{
        struct text t = { 0 };

        (void)state;
        text_add(&t, "links:\n  - name: m\n    protocol: circe\n    role: mediator\n"
                 "    transport: pty\n    device: /tmp/m\n    emulate:\n");
        for (unsigned i = 0; i <= CONFIG_EMULATE_MAX; i++)
                text_add(&t, "      - {address: %06X, capabilities: 1}\n", i);
        expect_error(&t, -EINVAL, "t.yaml:40:9: too many emulated devices (at most 32)");
        free(t.buf);
}

static void test_too_many_nodes(void **state)
{
        struct text t = { 0 };

        (void)state;
        text_add(&t, "links: [");
        for (unsigned i = 0; i < CONFIG_NODES_MAX; i++)
                text_add(&t, "%s0", i ? "," : "");
        text_add(&t, "]\n");
        /* links, "links" and the list are 3 nodes, so element 65534 (column 9 + 2 x 65533). */
        expect_error(&t, -EINVAL, "t.yaml:1:131075: too many YAML nodes (at most 65536)");
        free(t.buf);
}

static void test_too_large(void **state)
{
        struct text t = { 0 };

        (void)state;
        text_add(&t, "links: []\n");
        while (t.len <= CONFIG_INPUT_MAX)
                text_add(&t, "# padding padding padding padding padding padding padding\n");
        {
                char message[128];

                snprintf(message, sizeof(message), "t.yaml: too large (%zu bytes, at most %u)",
                         t.len, CONFIG_INPUT_MAX);
                expect_error(&t, -EFBIG, message);
        }
        free(t.buf);
}

/* A long scalar is echoed truncated and escaped, never in full. */
static void test_long_scalar(void **state)
{
        struct text t = { 0 };

        (void)state;
        text_add(&t, "instance: \"");
        for (unsigned i = 0; i < 100000; i++)
                text_add(&t, "\\x%02x", 1 + i % 200);
        text_add(&t, "\"\n");
        expect_error(&t, -EINVAL,
                     "t.yaml:1:11: instance: control character in \"\\x01\\x02\\x03\\x04\\x05\\x06"
                     "\\x07\\x08\\x09\\x0A\\x0B\\x0C\\x0D\\x0E\\x0F\\x10\\x11\\x12\\x13\\x14\\x15"
                     "\\x16\\x17\\x18\\x19\\x1A\\x1B\\x1C\\x1D\\x1E\\x1F !\\\"#$%&'(\"...");
        free(t.buf);
}

/* ---------------------------------------------------------------------------------------------
 * Files */

static void test_load_file_errors(void **state)
{
        char path[] = "/tmp/test_config.XXXXXX";
        struct config *c = NULL;
        struct config_error e;
        int fd;

        (void)state;
        assert_int_equal(config_load_file("/nonexistent/sharedlinkd.yaml", &c, &e), -ENOENT);
        assert_null(c);
        assert_string_equal(e.message,
                            "/nonexistent/sharedlinkd.yaml: No such file or directory");
        assert_int_equal(e.line, 0);
        assert_int_equal(config_load_file("/", &c, &e), -EISDIR);
        assert_string_equal(e.message, "/: Is a directory");

        /* A file one byte over the limit. */
        fd = mkstemp(path);
        assert_true(fd >= 0);
        assert_int_equal(ftruncate(fd, CONFIG_INPUT_MAX + 1), 0);
        close(fd);
        assert_int_equal(config_load_file(path, &c, &e), -EFBIG);
        assert_null(c);
        {
                char message[128];

                snprintf(message, sizeof(message), "%s: too large (%u bytes, at most %u)", path,
                         CONFIG_INPUT_MAX + 1, CONFIG_INPUT_MAX);
                assert_string_equal(e.message, message);
        }

        /* A bad file names itself in the message. */
        fd = open(path, O_WRONLY | O_TRUNC);
        assert_true(fd >= 0);
        assert_int_equal(write(fd, "links: 5\n", 9), 9);
        close(fd);
        assert_int_equal(config_load_file(path, &c, &e), -EINVAL);
        {
                char message[128];

                snprintf(message, sizeof(message), "%s:1:8: links: expected a list, got \"5\"",
                         path);
                assert_string_equal(e.message, message);
        }
        unlink(path);

        /* The error struct is optional. */
        assert_int_equal(config_load_file("/nonexistent", &c, NULL), -ENOENT);
        assert_int_equal(config_parse("x", 1, NULL, &c, NULL), -EINVAL);
        assert_null(c);
        assert_null(config_free(NULL));
}

static void test_filename_default(void **state)
{
        struct config *c = NULL;
        struct config_error e;

        (void)state;
        assert_int_equal(config_parse("links: 5", 8, NULL, &c, &e), -EINVAL);
        assert_string_equal(e.message, "<config>:1:8: links: expected a list, got \"5\"");
        assert_int_equal(config_parse(NULL, 0, "n.yaml", &c, &e), -EINVAL);
        assert_string_equal(e.message, "n.yaml:1:1: empty configuration");
        assert_int_equal(config_parse(NULL, 10, "n.yaml", &c, &e), -EINVAL);
        assert_string_equal(e.message, "n.yaml: no input");
        assert_null(c);
}

/* ---------------------------------------------------------------------------------------------
 * config_link_equal() */

/* Two links; the mediator is last, so appended lines change it. */
#define EQ_HEAD \
        "links:\n" \
        "  - name: sl\n" \
        "    protocol: sharedlink\n" \
        "    transport: serial\n" \
        "    device: /dev/ttyS0\n" \
        "    address: A\n" \
        "    peers:\n" \
        "      - address: B\n" \
        "        outbound: [x1, {name: x2, type: long}]\n" \
        "        inbound: [y1]\n" \
        "  - name: med\n" \
        "    protocol: circe\n" \
        "    role: mediator\n" \
        "    transport: pty\n" \
        "    device: /tmp/m.tty\n"
#define EQ_BASE EQ_HEAD "    emulate: [{address: E1E1E1, capabilities: 32}]\n"

struct equal_case {
        const char *name;
        const char *yaml;       /* compared with EQ_BASE */
        bool sl_equal, med_equal;
};

static const struct equal_case equal_cases[] = {
        { "identical", EQ_BASE, true, true },
        { "layout_and_comments",
          "# same settings, other layout\n"
          "links:\n"
          "- {name: med, protocol: circe, role: mediator, transport: pty, device: /tmp/m.tty,\n"
          "   emulate: [{capabilities: 32, address: E1E1E1}]}\n"
          "- name: sl\n"
          "  address: A\n"
          "  device: /dev/ttyS0\n"
          "  transport: serial\n"
          "  protocol: sharedlink\n"
          "  peers: [{address: B, outbound: [{name: x1}, {name: x2, type: long}],\n"
          "           inbound: [{name: y1, type: string}]}]\n", true, true },
        { "explicit_defaults",
          "links:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, device: /dev/ttyS0, "
          "baud: 115200, parity: none, data_bits: 8, stop_bits: 1, flow_control: none, "
          "address: A, peers: [{address: B, period_ms: 100, refresh_ms: 1000, stale_ms: 3000, "
          "compression: true, on_change: false, min_interval_ms: 10, max_frame: 1024, "
          "outbound: [x1, {name: x2, type: long}], inbound: [y1]}]}\n"
          "  - {name: med, protocol: circe, role: mediator, transport: pty, device: /tmp/m.tty, "
          "checksum: true, version: 0.2.3, status: 0, keepalive_ms: 750, "
          "emulate: [{address: E1E1E1, capabilities: 32, signal: 255, roles: 0, "
          "membership: false}]}\n", true, true },
        { "baud", EQ_BASE "    baud: 9600\n", true, false },
        { "parity", EQ_BASE "    parity: even\n", true, false },
        { "checksum", EQ_BASE "    checksum: false\n", true, false },
        { "keepalive", EQ_BASE "    keepalive_ms: 500\n", true, false },
        { "mediator_address", EQ_BASE "    address: '000001'\n", true, false },
        { "emulate_signal", EQ_HEAD "    emulate: [{address: E1E1E1, capabilities: 32, "
          "signal: 1}]\n", true, false },
        { "emulate_battery", EQ_HEAD "    emulate: [{address: E1E1E1, capabilities: 32, "
          "battery: 255}]\n", true, false },
        { "emulate_more", EQ_HEAD "    emulate: [{address: E1E1E1, capabilities: 32}, "
          "{address: AAAAAA, capabilities: 1}]\n", true, false },
        { "device_path",
          "links:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, device: /dev/ttyS1, "
          "address: A, peers: [{address: B, outbound: [x1, {name: x2, type: long}], "
          "inbound: [y1]}]}\n"
          "  - {name: med, protocol: circe, role: mediator, transport: pty, device: /tmp/m.tty, "
          "emulate: [{address: E1E1E1, capabilities: 32}]}\n", false, true },
        { "var_type",
          "links:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, device: /dev/ttyS0, "
          "address: A, peers: [{address: B, outbound: [x1, {name: x2, type: double}], "
          "inbound: [y1]}]}\n"
          "  - {name: med, protocol: circe, role: mediator, transport: pty, device: /tmp/m.tty, "
          "emulate: [{address: E1E1E1, capabilities: 32}]}\n", false, true },
        { "var_order",
          "links:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, device: /dev/ttyS0, "
          "address: A, peers: [{address: B, outbound: [{name: x2, type: long}, x1], "
          "inbound: [y1]}]}\n"
          "  - {name: med, protocol: circe, role: mediator, transport: pty, device: /tmp/m.tty, "
          "emulate: [{address: E1E1E1, capabilities: 32}]}\n", false, true },
        { "var_added",
          "links:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, device: /dev/ttyS0, "
          "address: A, peers: [{address: B, outbound: [x1, {name: x2, type: long}], "
          "inbound: [y1, y2]}]}\n"
          "  - {name: med, protocol: circe, role: mediator, transport: pty, device: /tmp/m.tty, "
          "emulate: [{address: E1E1E1, capabilities: 32}]}\n", false, true },
        { "var_renamed",
          "links:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, device: /dev/ttyS0, "
          "address: A, peers: [{address: B, outbound: [x1, {name: x2, type: long}], "
          "inbound: [y2]}]}\n"
          "  - {name: med, protocol: circe, role: mediator, transport: pty, device: /tmp/m.tty, "
          "emulate: [{address: E1E1E1, capabilities: 32}]}\n", false, true },
        { "peer_period",
          "links:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, device: /dev/ttyS0, "
          "address: A, peers: [{address: B, period_ms: 50, outbound: [x1, {name: x2, "
          "type: long}], inbound: [y1]}]}\n"
          "  - {name: med, protocol: circe, role: mediator, transport: pty, device: /tmp/m.tty, "
          "emulate: [{address: E1E1E1, capabilities: 32}]}\n", false, true },
        { "peer_added",
          "links:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, device: /dev/ttyS0, "
          "address: A, peers: [{address: B, outbound: [x1, {name: x2, type: long}], "
          "inbound: [y1]}, {address: C}]}\n"
          "  - {name: med, protocol: circe, role: mediator, transport: pty, device: /tmp/m.tty, "
          "emulate: [{address: E1E1E1, capabilities: 32}]}\n", false, true },
        { "own_address",
          "links:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, device: /dev/ttyS0, "
          "address: C, peers: [{address: B, outbound: [x1, {name: x2, type: long}], "
          "inbound: [y1]}]}\n"
          "  - {name: med, protocol: circe, role: mediator, transport: pty, device: /tmp/m.tty, "
          "emulate: [{address: E1E1E1, capabilities: 32}]}\n", false, true },
        { "transport_changed",
          "links:\n"
          "  - {name: sl, protocol: sharedlink, transport: pty, device: /dev/ttyS0, "
          "address: A, peers: [{address: B, outbound: [x1, {name: x2, type: long}], "
          "inbound: [y1]}]}\n"
          "  - {name: med, protocol: circe, role: mediator, transport: pty, device: /tmp/m.tty, "
          "emulate: [{address: E1E1E1, capabilities: 32}]}\n", false, true },
        { "role_changed",
          "links:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, device: /dev/ttyS0, "
          "address: A, peers: [{address: B, outbound: [x1, {name: x2, type: long}], "
          "inbound: [y1]}]}\n"
          "  - {name: med, protocol: circe, role: controller, transport: pty, "
          "device: /tmp/m.tty}\n", true, false },
};

static void test_link_equal(void **state)
{
        struct config *base = parse_ok(EQ_BASE);

        (void)state;
        for (size_t i = 0; i < sizeof(equal_cases) / sizeof(equal_cases[0]); i++) {
                const struct equal_case *t = &equal_cases[i];
                struct config *other = parse_ok(t->yaml);
                const struct config_link *sl = link_named(other, "sl");
                const struct config_link *med = link_named(other, "med");

                if (config_link_equal(link_named(base, "sl"), sl) != t->sl_equal ||
                    config_link_equal(sl, link_named(base, "sl")) != t->sl_equal)
                        fail_msg("case %s: link sl should be %s", t->name,
                                 t->sl_equal ? "equal" : "different");
                if (config_link_equal(link_named(base, "med"), med) != t->med_equal ||
                    config_link_equal(med, link_named(base, "med")) != t->med_equal)
                        fail_msg("case %s: link med should be %s", t->name,
                                 t->med_equal ? "equal" : "different");
                config_free(other);
        }
        /* Different links are different. */
        assert_false(config_link_equal(&base->links[0], &base->links[1]));
        config_free(base);
}

/* UDP endpoints compare as written. */
static void test_link_equal_udp(void **state)
{
        struct config *a = parse_ok("links:\n  - {name: u, protocol: circe, role: controller, "
                                    "transport: udp, local: '127.0.0.1:1'}\n");
        struct config *b = parse_ok("links:\n  - {name: u, protocol: circe, role: controller, "
                                    "transport: udp, local: '127.0.0.1:1', "
                                    "remote: '127.0.0.1:2'}\n");
        struct config *c = parse_ok("links:\n  - {name: u, protocol: circe, role: controller, "
                                    "transport: udp, local: '127.0.0.1:3'}\n");
        struct config *d = parse_ok("links:\n  - {name: u, protocol: circe, role: controller, "
                                    "transport: udp, local: '127.0.0.1:1'}\n");

        (void)state;
        assert_false(config_link_equal(&a->links[0], &b->links[0]));
        assert_false(config_link_equal(&a->links[0], &c->links[0]));
        assert_true(config_link_equal(&a->links[0], &d->links[0]));
        config_free(a);
        config_free(b);
        config_free(c);
        config_free(d);
}

static void test_names(void **state)
{
        struct config *c = load_ok(DEMO_CONF);

        (void)state;
        assert_null(config_link_find(c, "nope"));
        assert_null(config_link_find(c, "node"));
        assert_string_equal(config_link_find(c, "arena")->name, "arena");
        assert_string_equal(config_protocol_name(CONFIG_PROTOCOL_SHAREDLINK), "sharedlink");
        assert_string_equal(config_protocol_name(CONFIG_PROTOCOL_CIRCE), "circe");
        assert_string_equal(config_transport_name(CONFIG_TRANSPORT_PTY), "pty");
        assert_string_equal(config_transport_name(CONFIG_TRANSPORT_UDP), "udp");
        assert_string_equal(config_role_name(CONFIG_ROLE_MEDIATOR), "mediator");
        assert_string_equal(config_role_name(CONFIG_ROLE_NONE), "none");
        assert_string_equal(config_var_type_name(CONFIG_VAR_DOUBLE), "double");
        assert_string_equal(config_var_type_name(CONFIG_VAR_STRING), "string");
        config_free(c);
}

/* ---------------------------------------------------------------------------------------------
 * SharedLink peers of the Pronto4 dialect (docs/pronto4.md) */

#define P4_LINK(extra) \
        "links:\n" \
        "  - name: p4\n" \
        "    protocol: sharedlink\n" \
        "    transport: udp\n" \
        "    local: '127.0.0.1:4220'\n" \
        "    remote: '127.0.0.1:4000'\n" \
        extra \
        "    address: A\n" \
        "    peers:\n" \
        "      - address: B\n"

/* A replay of the same link: crlf as on udp (the recording may be of udp). */
#define P4_REPLAY_LINK(extra) \
        "links:\n" \
        "  - name: p4\n" \
        "    protocol: sharedlink\n" \
        "    transport: replay\n" \
        "    file: /nonexistent/p4.rec\n" \
        extra \
        "    address: A\n" \
        "    peers:\n" \
        "      - address: B\n"

struct pronto4_case {
        const char *name, *yaml;
        enum config_dialect dialect;
        bool declare, outbound_learn, inbound_learn, crlf;
        uint32_t learn_max;
        unsigned n_outbound, n_inbound;
};

static const struct pronto4_case pronto4_cases[] = {
        { "host: configured lists, so it declares; crlf follows the dialect",
          P4_LINK("") "        dialect: pronto4\n"
          "        outbound: [{name: a, type: long}]\n        inbound: [{name: b, type: string}]\n",
          CONFIG_DIALECT_PRONTO4, true, false, false, true, 0, 1, 1 },
        { "vehicle: learns both lists, does not declare, learn_max defaults",
          P4_LINK("") "        dialect: pronto4\n        outbound: learn\n        inbound: learn\n",
          CONFIG_DIALECT_PRONTO4, false, true, true, true, CONFIG_LEARN_MAX_DEFAULT, 0, 0 },
        { "one list learned (quoted), the other configured, learn_max the most max_frame 1024 "
          "answers (L0|T|Q of one-letter names: 6 bytes an entry, 14 around them)",
          P4_LINK("") "        dialect: pronto4\n"
          "        outbound: [{name: x, type: string}]\n        inbound: 'learn'\n"
          "        learn_max: 168\n",
          CONFIG_DIALECT_PRONTO4, false, false, true, true, 168, 1, 0 },
        { "learn_max at its top, with crlf: false and the room for it",
          P4_LINK("    crlf: false\n") "        dialect: pronto4\n        max_frame: 1024\n"
          "        outbound: learn\n        learn_max: 168\n",
          CONFIG_DIALECT_PRONTO4, false, true, false, false, 168, 0, 0 },
        { "learn_max at its bottom",
          P4_LINK("") "        dialect: pronto4\n        inbound: learn\n        learn_max: 1\n",
          CONFIG_DIALECT_PRONTO4, false, false, true, true, 1, 0, 0 },
        { "explicit declare: false and crlf: false",
          P4_LINK("    crlf: false\n") "        dialect: pronto4\n"
          "        declare: false\n        outbound: [{name: x, type: string}]\n",
          CONFIG_DIALECT_PRONTO4, false, false, false, false, 0, 1, 0 },
        { "a bulletin peer is as before: no crlf unless asked",
          P4_LINK("") "        outbound: [x]\n",
          CONFIG_DIALECT_BULLETIN, false, false, false, false, 0, 1, 0 },
        { "crlf asked on a bulletin link",
          P4_LINK("    crlf: true\n") "        dialect: bulletin\n",
          CONFIG_DIALECT_BULLETIN, false, false, false, true, 0, 0, 0 },
        { "one pronto4 peer among bulletin ones turns the link's crlf on",
          P4_LINK("") "      - {address: C, dialect: pronto4, inbound: learn}\n",
          CONFIG_DIALECT_BULLETIN, false, false, false, true, 0, 0, 0 },
        { "a replay's crlf follows the dialect as on udp",
          P4_REPLAY_LINK("") "        dialect: pronto4\n        inbound: learn\n",
          CONFIG_DIALECT_PRONTO4, false, false, true, true, CONFIG_LEARN_MAX_DEFAULT, 0, 0 },
        { "a replay with crlf: false",
          P4_REPLAY_LINK("    crlf: false\n") "        dialect: pronto4\n        inbound: learn\n",
          CONFIG_DIALECT_PRONTO4, false, false, true, false, CONFIG_LEARN_MAX_DEFAULT, 0, 0 },
};

static void test_pronto4(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(pronto4_cases) / sizeof(pronto4_cases[0]); i++) {
                const struct pronto4_case *t = &pronto4_cases[i];
                struct config *c = parse_ok(t->yaml);
                const struct config_peer *p = &c->links[0].sl.peers[0];

                print_message("case: %s\n", t->name);
                assert_int_equal(p->dialect, t->dialect);
                assert_int_equal(p->declare, t->declare);
                assert_int_equal(p->outbound_learn, t->outbound_learn);
                assert_int_equal(p->inbound_learn, t->inbound_learn);
                assert_int_equal(p->learn_max, t->learn_max);
                assert_int_equal(p->n_outbound, t->n_outbound);
                assert_int_equal(p->n_inbound, t->n_inbound);
                assert_int_equal(c->n_vars, t->n_outbound + t->n_inbound);
                assert_int_equal(c->links[0].sl.crlf, t->crlf);
                config_free(c);
        }
        assert_string_equal(config_dialect_name(CONFIG_DIALECT_BULLETIN), "bulletin");
        assert_string_equal(config_dialect_name(CONFIG_DIALECT_PRONTO4), "pronto4");
}

/*
 * The whole outbound list at its longest, as one frame: "[:BA|N0", 22 bytes per long ("|D" and
 * 20), "|C" hh "]", CR LF. 45 longs take 1004 bytes, 46 take 1026: one too many for 1024, unless
 * crlf: false (1024 exactly).
 */
static void test_pronto4_one_frame(void **state)
{
        struct text t = { 0 };
        struct config *c;

        (void)state;
        for (unsigned n = 45; n <= 46; n++) {
                free(t.buf);
                t = (struct text){ 0 };
                text_add(&t, P4_LINK("") "        dialect: pronto4\n        outbound:\n");
                for (unsigned i = 0; i < n; i++)
                        text_add(&t, "          - {name: v%02u, type: long}\n", i);
                if (n == 45) {
                        c = parse_ok(t.buf);
                        assert_int_equal(c->links[0].sl.peers[0].n_outbound, 45);
                        config_free(c);
                } else {
                        expect_error(&t, -EINVAL, "t.yaml:12:11: outbound: 46 variables take up to "
                                     "1026 bytes as one frame, more than max_frame 1024 (a "
                                     "pronto4 peer gets every data frame as one full N0 list)");
                }
        }
        free(t.buf);
        t = (struct text){ 0 };
        text_add(&t, P4_LINK("    crlf: false\n") "        dialect: pronto4\n        outbound:\n");
        for (unsigned i = 0; i < 46; i++)
                text_add(&t, "          - {name: v%02u, type: long}\n", i);
        c = parse_ok(t.buf);
        config_free(c);
        free(t.buf);
}

static struct bad_case pronto4_bad_cases[] = {
        { "p4_dialect_unknown", P4_LINK("") "        dialect: kairos\n",
          "t.yaml:10:18: dialect: expected bulletin or pronto4, got \"kairos\"" },
        { "p4_learn_on_bulletin", P4_LINK("") "        inbound: learn\n",
          "t.yaml:10:18: inbound: learn needs dialect: pronto4 (a bulletin peer never declares "
          "its lists)" },
        { "p4_outbound_learn_on_bulletin", P4_LINK("") "        dialect: bulletin\n"
          "        outbound: learn\n",
          "t.yaml:11:19: outbound: learn needs dialect: pronto4 (a bulletin peer never declares "
          "its lists)" },
        { "p4_declare_on_bulletin", P4_LINK("") "        declare: true\n        outbound: [x]\n",
          "t.yaml:10:9: key \"declare\" needs dialect: pronto4" },
        { "p4_learn_max_on_bulletin", P4_LINK("") "        learn_max: 5\n",
          "t.yaml:10:9: key \"learn_max\" needs dialect: pronto4" },
        { "p4_declare_with_learn", P4_LINK("") "        dialect: pronto4\n"
          "        declare: true\n        inbound: learn\n        outbound: [x]\n",
          "t.yaml:11:18: declare: true with a learned list (the side that learns answers "
          "declarations, it does not send them)" },
        { "p4_declare_nothing", P4_LINK("") "        dialect: pronto4\n        declare: true\n",
          "t.yaml:11:18: declare: true, but the peer has no outbound or inbound variables to "
          "declare" },
        { "p4_learn_max_without_learn", P4_LINK("") "        dialect: pronto4\n"
          "        learn_max: 5\n        outbound: [x]\n",
          "t.yaml:11:9: learn_max needs outbound: learn or inbound: learn" },
        { "p4_learn_max_zero", P4_LINK("") "        dialect: pronto4\n        inbound: learn\n"
          "        learn_max: 0\n",
          "t.yaml:12:20: learn_max 0 out of range (1..256)" },
        { "p4_learn_max_too_big", P4_LINK("") "        dialect: pronto4\n        inbound: learn\n"
          "        learn_max: 257\n",
          "t.yaml:12:20: learn_max 257 out of range (1..256)" },
        { "p4_learn_misspelt", P4_LINK("") "        dialect: pronto4\n        inbound: learned\n",
          "t.yaml:11:18: inbound: expected a list, got \"learned\"" },
        { "p4_declare_not_bool", P4_LINK("") "        dialect: pronto4\n        declare: yes\n",
          "t.yaml:11:18: declare: expected true or false, got \"yes\"" },
        { "p4_crlf_on_serial",
          "links:\n  - {name: s, protocol: sharedlink, transport: serial, device: /dev/ttyS0, "
          "crlf: true, address: A, peers: [{address: B}]}\n",
          "t.yaml:2:76: key \"crlf\" is not valid for transport serial" },
        { "p4_crlf_on_circe",
          "links:\n  - {name: u, protocol: circe, role: controller, transport: udp, "
          "local: '127.0.0.1:1', crlf: true}\n",
          "t.yaml:2:88: key \"crlf\" is not valid for protocol circe" },
        { "p4_crlf_not_bool", P4_LINK("    crlf: 1\n") "        dialect: pronto4\n",
          "t.yaml:7:11: crlf: expected true or false, got \"1\"" },
        { "p4_string_list_too_long", P4_LINK("") "        dialect: pronto4\n"
          "        max_frame: 200\n        outbound: [{name: a, type: string}, "
          "{name: b, type: string}, {name: c, type: string}]\n",
          "t.yaml:12:19: outbound: 3 variables take up to 209 bytes as one frame, more than "
          "max_frame 200 (a pronto4 peer gets every data frame as one full N0 list)" },
        { "p4_declaration_too_long", P4_LINK("") "        dialect: pronto4\n"
          "        max_frame: 48\n        outbound: [{name: a_rather_long_variable_name_here, "
          "type: long}]\n",
          "t.yaml:12:19: outbound: its declaration N0|T|Q... takes 51 bytes, more than max_frame "
          "48 (a pronto4 peer wants it in one frame)" },
        /* issue 21.9: what -n let through */
        { "p4_max_frame_over_clients", P4_LINK("") "        dialect: pronto4\n"
          "        max_frame: 1025\n        outbound: [{name: x, type: long}]\n",
          "t.yaml:11:20: max_frame 1025 is more than a pronto4 peer reads: both Pronto4 clients "
          "read a datagram into 1024 bytes" },
        { "p4_learn_room_max_frame", P4_LINK("") "        dialect: pronto4\n"
          "        max_frame: 256\n        inbound: learn\n",
          "t.yaml:11:20: max_frame 256 is too small for what this peer can learn: learn_max 128 "
          "entries take at least 782 bytes as one frame (the answer to N? or L?, |T<t>|Q<name> "
          "each); lower learn_max to 40 or raise max_frame" },
        { "p4_learn_room_learn_max", P4_LINK("") "        dialect: pronto4\n"
          "        outbound: learn\n        learn_max: 169\n",
          "t.yaml:11:19: max_frame 1024 is too small for what this peer can learn: learn_max 169 "
          "entries take at least 1028 bytes as one frame (the answer to N? or L?, |T<t>|Q<name> "
          "each); lower learn_max to 168 or raise max_frame" },
        { "p4_bare_name", P4_LINK("") "        dialect: pronto4\n"
          "        outbound: [{name: x, type: long}, joy_steer]\n",
          "t.yaml:11:43: outbound: \"joy_steer\" has no type: a pronto4 list gives each entry's "
          "(e.g. {name: joy_steer, type: double}; a bare name is a string here but a double on "
          "the Pronto4 wire)" },
        { "p4_bare_name_inbound", P4_LINK("") "        dialect: pronto4\n"
          "        inbound:\n          - VehicleName\n",
          "t.yaml:12:13: inbound: \"VehicleName\" has no type: a pronto4 list gives each "
          "entry's (e.g. {name: VehicleName, type: double}; a bare name is a string here but a "
          "double on the Pronto4 wire)" },
        { "p4_list_of_learn", P4_LINK("") "        dialect: pronto4\n        outbound: [learn]\n",
          "t.yaml:11:20: outbound: the entry learn is a variable named \"learn\": did you "
          "mean `outbound: learn` (the list the peer declares)? A variable of that name is "
          "{name: learn}" },
        { "list_of_learn_bulletin", P4_LINK("") "        inbound: [x, learn]\n",
          "t.yaml:10:22: inbound: the entry learn is a variable named \"learn\": did you "
          "mean `inbound: learn` (the list the peer declares)? A variable of that name is "
          "{name: learn}" },
        { "p4_crlf_under_peer", P4_LINK("") "        dialect: pronto4\n        crlf: true\n"
          "        inbound: learn\n",
          "t.yaml:11:9: key \"crlf\" is a link key: it goes in the link, beside \"peers\", not "
          "under a peer" },
        { "remote_under_peer", P4_LINK("") "        remote: '127.0.0.1:4001'\n",
          "t.yaml:10:9: key \"remote\" is a link key: it goes in the link, beside \"peers\", not "
          "under a peer" },
        { "p4_inbound_declaration_too_long", P4_LINK("") "        dialect: pronto4\n"
          "        max_frame: 40\n        inbound: [{name: abcdefghijklmnopqrstuvwxyz0123, "
          "type: string}]\n",
          "t.yaml:12:18: inbound: its declaration L0|T|Q... takes 49 bytes, more than max_frame "
          "40 (a pronto4 peer wants it in one frame)" },
};

static void test_pronto4_bad(void **state)
{
        (void)state;
        for (size_t i = 0; i < sizeof(pronto4_bad_cases) / sizeof(pronto4_bad_cases[0]); i++) {
                void *one = &pronto4_bad_cases[i];

                print_message("case %s\n", pronto4_bad_cases[i].name);
                test_bad(&one);
        }
}

/* Reload: every dialect setting is part of the link's identity. */
static void test_pronto4_equal(void **state)
{
        static const char *const variants[] = {
                P4_LINK("") "        dialect: pronto4\n        outbound: [{name: x, type: string}]\n",
                P4_LINK("") "        dialect: pronto4\n        outbound: [{name: x, type: string}]\n"
                "        declare: false\n",
                P4_LINK("    crlf: false\n") "        dialect: pronto4\n        outbound: [{name: x, type: string}]\n",
                P4_LINK("") "        outbound: [x]\n",
                P4_LINK("") "        dialect: pronto4\n        outbound: [{name: x, type: string}]\n"
                "        inbound: learn\n        declare: false\n",
                P4_LINK("") "        dialect: pronto4\n        outbound: [{name: x, type: string}]\n"
                "        inbound: learn\n        declare: false\n        learn_max: 7\n",
                P4_LINK("") "        dialect: pronto4\n        outbound: learn\n",
        };
        struct config *cfg[sizeof(variants) / sizeof(variants[0])];
        size_t n = sizeof(variants) / sizeof(variants[0]);

        (void)state;
        for (size_t i = 0; i < n; i++)
                cfg[i] = parse_ok(variants[i]);
        for (size_t i = 0; i < n; i++) {
                struct config *again = parse_ok(variants[i]);

                assert_true(config_link_equal(&cfg[i]->links[0], &again->links[0]));
                config_free(again);
                for (size_t j = 0; j < n; j++)
                        if (i != j && config_link_equal(&cfg[i]->links[0], &cfg[j]->links[0]))
                                fail_msg("variants %zu and %zu compare equal", i, j);
        }
        for (size_t i = 0; i < n; i++)
                config_free(cfg[i]);
}

/* Issue 21.4: a pronto4 peer's role (docs/pronto4.md §1): host on node A, vehicle on node B,
 * else from the lists; declare follows it (only a host with configured lists declares). */
#define P4_ROLE_LINK(own, peer) \
        "links:\n" \
        "  - name: p4\n" \
        "    protocol: sharedlink\n" \
        "    transport: udp\n" \
        "    local: '127.0.0.1:4220'\n" \
        "    remote: '127.0.0.1:4000'\n" \
        "    address: " own "\n" \
        "    peers:\n" \
        "      - address: " peer "\n" \
        "        dialect: pronto4\n"

static void test_pronto4_role(void **state)
{
        static const struct {
                const char *name, *yaml;
                enum config_p4_role role;
                bool declare;
        } cases[] = {
                { "node A with configured lists: the host, declaring",
                  P4_ROLE_LINK("A", "B") "        outbound: [{name: x, type: long}]\n", CONFIG_P4_HOST, true },
                { "node B with configured lists: the vehicle, not declaring",
                  P4_ROLE_LINK("B", "A") "        outbound: [{name: x, type: long}]\n        inbound: [{name: y, type: long}]\n",
                  CONFIG_P4_VEHICLE, false },
                { "node B told it is the host",
                  P4_ROLE_LINK("B", "A") "        role: host\n        outbound: [{name: x, type: long}]\n",
                  CONFIG_P4_HOST, true },
                { "node A told it is the vehicle",
                  P4_ROLE_LINK("A", "B") "        role: vehicle\n        outbound: [{name: x, type: long}]\n",
                  CONFIG_P4_VEHICLE, false },
                { "a vehicle that declares all the same",
                  P4_ROLE_LINK("B", "A") "        declare: true\n        outbound: [{name: x, type: long}]\n",
                  CONFIG_P4_VEHICLE, true },
                { "node C with configured lists: the host",
                  P4_ROLE_LINK("C", "D") "        outbound: [{name: x, type: long}]\n", CONFIG_P4_HOST, true },
                { "node C that learns: the vehicle",
                  P4_ROLE_LINK("C", "D") "        inbound: learn\n", CONFIG_P4_VEHICLE, false },
        };
        static struct bad_case bad[] = {
                { "p4_role_unknown", P4_ROLE_LINK("A", "B") "        role: captain\n",
                  "t.yaml:11:15: role: expected host or vehicle, got \"captain\"" },
                { "p4_role_on_bulletin", P4_LINK("") "        role: host\n",
                  "t.yaml:10:9: key \"role\" needs dialect: pronto4" },
        };
        struct config *host, *vehicle;

        (void)state;
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                struct config *c = parse_ok(cases[i].yaml);

                print_message("case: %s\n", cases[i].name);
                assert_int_equal(c->links[0].sl.peers[0].role, cases[i].role);
                assert_int_equal(c->links[0].sl.peers[0].declare, cases[i].declare);
                config_free(c);
        }
        for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
                void *one = &bad[i];

                print_message("case %s\n", bad[i].name);
                test_bad(&one);
        }
        /* Part of the link's identity on reload. */
        host = parse_ok(P4_ROLE_LINK("C", "D") "        role: host\n        inbound: learn\n");
        vehicle = parse_ok(P4_ROLE_LINK("C", "D") "        inbound: learn\n");
        assert_false(config_link_equal(&host->links[0], &vehicle->links[0]));
        config_free(host);
        config_free(vehicle);
        assert_string_equal(config_p4_role_name(CONFIG_P4_VEHICLE), "vehicle");
}

int main(void)
{
        static const struct CMUnitTest fixed[] = {
                cmocka_unit_test(test_reference),
                cmocka_unit_test(test_caps_stated),
                cmocka_unit_test(test_demo),
                cmocka_unit_test(test_defaults),
                cmocka_unit_test(test_accepted_forms),
                cmocka_unit_test(test_too_many_links),
                cmocka_unit_test(test_too_many_peers),
                cmocka_unit_test(test_too_many_variables),
        cmocka_unit_test(test_duplicate_at_cap),
                cmocka_unit_test(test_too_many_emulated),
                cmocka_unit_test(test_too_many_nodes),
                cmocka_unit_test(test_too_large),
                cmocka_unit_test(test_long_scalar),
                cmocka_unit_test(test_load_file_errors),
                cmocka_unit_test(test_filename_default),
                cmocka_unit_test(test_link_equal),
                cmocka_unit_test(test_link_equal_udp),
                cmocka_unit_test(test_names),
                cmocka_unit_test(test_pronto4),
                cmocka_unit_test(test_pronto4_one_frame),
                cmocka_unit_test(test_pronto4_bad),
                cmocka_unit_test(test_pronto4_equal),
                cmocka_unit_test(test_pronto4_role),
        };
        size_t n_fixed = sizeof(fixed) / sizeof(fixed[0]);
        size_t n_bad = sizeof(bad_cases) / sizeof(bad_cases[0]);
        struct CMUnitTest *tests = calloc(n_fixed + n_bad, sizeof(*tests));
        int failed;

        if (!tests)
                return 1;
        memcpy(tests, fixed, sizeof(fixed));
        /* One cmocka test per bad config, named after it, so a failure says which. */
        for (size_t i = 0; i < n_bad; i++) {
                tests[n_fixed + i].name = bad_cases[i].name;
                tests[n_fixed + i].test_func = test_bad;
                tests[n_fixed + i].initial_state = &bad_cases[i];
        }
        failed = _cmocka_run_group_tests("config", tests, n_fixed + n_bad, NULL, NULL);
        free(tests);
        return failed;
}
