/*
 * Unit tests for sharedlink-mqtt's configuration parser (src/mqtt/bridge_config.c): the shipped
 * example loads with the defaults it documents, every kind of bad file gives its exact
 * "FILE:LINE:COL: message", and the globs match names the way fnmatch does.
 *
 * Run from the source tree root (as `make check` does): the example is read from conf/.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "mqtt/bridge_config.h"

#define EXAMPLE_CONF    "conf/sharedlink-mqtt.yaml"
#define NAME            "b.yaml"

static void parse_ok(const char *yaml, struct bridge_config *cfg)
{
        char err[BRIDGE_ERROR_MAX];
        int r = bridge_config_parse(NAME, yaml, strlen(yaml), cfg, err, sizeof(err));

        if (r < 0)
                fail_msg("unexpected error %d: %s", r, err);
}

static void parse_fails(const char *yaml, const char *want)
{
        struct bridge_config cfg;
        char err[BRIDGE_ERROR_MAX];
        int r = bridge_config_parse(NAME, yaml, strlen(yaml), &cfg, err, sizeof(err));

        if (r != -EINVAL)
                fail_msg("%s: accepted (%d), wanted %s", yaml, r, want);
        if (strcmp(err, want) != 0)
                fail_msg("%s\n  got:    %s\n  wanted: %s", yaml, err, want);
}

/* The shipped example states every default: it must load as an empty file does. */
static void test_example_is_the_defaults(void **state)
{
        struct bridge_config ex, def;
        char err[BRIDGE_ERROR_MAX];

        (void)state;
        if (bridge_config_load(EXAMPLE_CONF, &ex, err, sizeof(err)) < 0)
                fail_msg("%s", err);
        parse_ok("", &def);
        assert_memory_equal(&ex, &def, sizeof(ex));
        assert_string_equal(def.prefix, "sharedlink");
        assert_string_equal(def.host, "localhost");
        assert_int_equal(def.port, 1883);
        assert_int_equal(def.publish.count, 1);
        assert_string_equal(def.publish.glob[0], "*");
        assert_int_equal(def.writable.count, 0);
        assert_int_equal(def.events_qos, 1);
        assert_true(def.retain && def.events && !def.tls);
}

static void test_values(void **state)
{
        struct bridge_config c;

        (void)state;
        parse_ok("instance: car1\n"
                 "prefix: fleet/east\n"
                 "broker:\n"
                 "  host: mqtt.example\n"
                 "  port: 8883\n"
                 "  username: car1\n"
                 "  password: \"s3cret\"\n"
                 "  tls: {ca_file: /etc/ca.pem, insecure: true}\n"
                 "publish: [\"Auto*\", \"agility.device.*.online\"]\n"
                 "writable: [Cmd?hrottle]\n"
                 "qos: 1\nretain: false\nmeta: none\nevents_qos: 2\nevents_window: 2\n"
                 "cursor_file: /tmp/c\ncursor_sync_ms: 0\n", &c);
        assert_string_equal(c.instance, "car1");
        assert_string_equal(c.prefix, "fleet/east");
        assert_string_equal(c.host, "mqtt.example");
        assert_int_equal(c.port, 8883);
        assert_string_equal(c.password, "s3cret");
        assert_true(c.tls && c.tls_insecure);
        assert_string_equal(c.ca_file, "/etc/ca.pem");
        assert_int_equal(c.publish.count, 2);
        assert_int_equal(c.qos, 1);
        assert_false(c.retain);
        assert_int_equal(c.meta, BRIDGE_META_NONE);
        assert_int_equal(c.events_qos, 2);
        assert_int_equal(c.events_window, 2);
        assert_int_equal(c.cursor_sync_ms, 0);
        assert_true(globs_match(&c.publish, "AutoGpsLat"));
        assert_true(globs_match(&c.publish, "agility.device.E1E1E1.online"));
        assert_false(globs_match(&c.publish, "agility.device.E1E1E1.signal"));
        assert_true(globs_match(&c.writable, "CmdThrottle"));
        assert_false(globs_match(&c.writable, "CmdSteer"));
}

static void test_errors(void **state)
{
        (void)state;
        parse_fails("bogus: 1\n", NAME ":1:1: unknown key \"bogus\" at top level");
        parse_fails("qos: 1\nqos: 2\n", NAME ":2:1: duplicate key \"qos\" (first at 1:1)");
        parse_fails("qos: 3\n", NAME ":1:6: qos 3 out of range (0..2)");
        parse_fails("qos: \"1\"\n", NAME ":1:6: qos: expected an integer, got a quoted string");
        parse_fails("qos: 01\n", NAME ":1:6: qos: leading zeros are not allowed in \"01\"");
        parse_fails("qos:\n", NAME ":1:5: qos: missing value");
        parse_fails("broker:\n  port: 0\n", NAME ":2:9: port 0 out of range (1..65535)");
        parse_fails("broker:\n  port: 99999999999999999999999999\n",
                    NAME ":2:9: port 999999999999999999999999... out of range (1..65535)");
        parse_fails("broker: 5\n", NAME ":1:9: broker: expected a mapping, got \"5\"");
        parse_fails("broker:\n  tls: {insecure: true}\n",
                    NAME ":2:8: tls: needs ca_file or ca_path");
        parse_fails("broker:\n  tls: {ca_file: /a, key_file: /k}\n",
                    NAME ":2:8: tls: cert_file and key_file go together");
        parse_fails("broker:\n  reconnect_min_ms: 10\n  reconnect_max_ms: 5\n",
                    NAME ":2:3: broker: reconnect_min_ms (10) is more than reconnect_max_ms (5)");
        parse_fails("broker:\n  password: x\n", NAME ":2:3: broker: a password needs a username");
        parse_fails("retain: yes\n", NAME ":1:9: retain: expected true or false, got \"yes\"");
        parse_fails("meta: xml\n", NAME ":1:7: meta: expected json or none, got \"xml\"");
        parse_fails("events_qos: 0\n", NAME ":1:13: events_qos 0 out of range (1..2)");
        parse_fails("events_window: 1\n", NAME ":1:16: events_window 1 out of range (2..1024)");
        parse_fails("cursor_file: rel/c\n", NAME ":1:14: cursor_file: \"rel/c\" is not an absolute "
                    "path");
        parse_fails("prefix: a/+/b\n", NAME ":1:9: prefix: \"a/+/b\": MQTT wildcards '+' and "
                    "'#' are not allowed in a topic");
        parse_fails("prefix: \"$SYS\"\n", NAME ":1:9: prefix: \"$SYS\": topics starting with "
                    "'$' are reserved to the broker");
        parse_fails("prefix: a//b\n", NAME ":1:9: prefix: \"a//b\": empty topic level");
        parse_fails("prefix: \"a\\tb\"\n", NAME ":1:9: prefix: control character in \"a\\x09b\"");
        parse_fails("instance: a/b\n", NAME ":1:11: instance: \"a/b\": '/', '+' and '#' are not "
                    "allowed");
        parse_fails("writable: [\"a/#\"]\n", NAME ":1:12: writable: \"a/#\": '+', '#' and '/' "
                    "are not allowed (globs match variable names: * ? [...])");
        parse_fails("writable: x\n", NAME ":1:11: writable: expected a list, got \"x\"");
        parse_fails("publish: [[a]]\n", NAME ":1:11: publish: expected a string, got a list");
        parse_fails("qos: &x 1\n", NAME ":1:6: anchors and aliases are not supported");
        parse_fails("qos: !!int 1\n", NAME ":1:6: tags are not supported");
        parse_fails("qos: 1\n---\nqos: 2\n", NAME ":2:1: only one YAML document is allowed");
        parse_fails("[1, 2]\n", NAME ":1:1: configuration: expected a mapping, got a list");
        parse_fails("publish: [a\n", NAME ":2:1: did not find expected ',' or ']' (while "
                    "parsing a flow sequence)");
}

static void test_bad_bytes(void **state)
{
        struct bridge_config c;
        char err[BRIDGE_ERROR_MAX];
        static const char nul[] = "qos: 1\n\0";

        (void)state;
        assert_int_equal(bridge_config_parse(NAME, nul, sizeof(nul) - 1, &c, err, sizeof(err)),
                         -EINVAL);
        assert_string_equal(err, NAME ":2:1: control characters are not allowed (0x00)");
        assert_int_equal(bridge_config_parse(NAME, "prefix: \xff\n", 10, &c, err, sizeof(err)),
                         -EINVAL);
        assert_non_null(strstr(err, NAME ":1:9: invalid"));
        /* A message cut to a small buffer stays NUL-terminated. */
        assert_int_equal(bridge_config_parse(NAME, "bogus: 1\n", 9, &c, err, 8), -EINVAL);
        assert_int_equal(strlen(err), 7);
}

static void test_load_files(void **state)
{
        char dir[] = "/tmp/bcfg.XXXXXX", path[64], pw[64], text[128], err[BRIDGE_ERROR_MAX];
        struct bridge_config c;
        FILE *f;

        (void)state;
        assert_non_null(mkdtemp(dir));
        snprintf(path, sizeof(path), "%s/b.yaml", dir);
        snprintf(pw, sizeof(pw), "%s/pw", dir);
        assert_int_equal(bridge_config_load(path, &c, err, sizeof(err)), -ENOENT);
        assert_non_null(strstr(err, "No such file"));
        f = fopen(pw, "w");
        assert_non_null(f);
        fputs("hunter2\nignored\n", f);
        fclose(f);
        snprintf(text, sizeof(text), "broker: {username: u, password_file: %s}\n", pw);
        f = fopen(path, "w");
        assert_non_null(f);
        fputs(text, f);
        fclose(f);
        assert_int_equal(bridge_config_load(path, &c, err, sizeof(err)), 0);
        assert_string_equal(c.password, "hunter2");
        unlink(pw);
        assert_int_equal(bridge_config_load(path, &c, err, sizeof(err)), -ENOENT);
        assert_non_null(strstr(err, "password_file"));
        unlink(path);
        rmdir(dir);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_example_is_the_defaults),
                cmocka_unit_test(test_values),
                cmocka_unit_test(test_errors),
                cmocka_unit_test(test_bad_bytes),
                cmocka_unit_test(test_load_files),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
