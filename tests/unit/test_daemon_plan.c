/*
 * Unit tests for the plan (src/daemon/daemon_plan.c): a configuration becomes engines, a group,
 * paths and a declaration without anything being created; the refusals name the link or the
 * path; the reload's comparisons tell which changes need new tables or a new socket. And what
 * the engines say their links learn at run time (link_ops.learning), which sizes the tables.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "daemon/config.h"
#include "daemon/daemon_plan.h"
#include "daemon/link.h"
#include "daemon/link_circe.h"
#include "daemon/link_sharedlink.h"
#include "shm/table.h"

#define TEST_FILENAME   "t.yaml"
#define RUNTIME_DIR     "/tmp/sharedlink-plan-test"

/* A SharedLink link with two outbound and one inbound variable, and an emulated CIRCE mediator. */
#define SL_LINK         "  - {name: sl, protocol: sharedlink, transport: serial, " \
                        "device: /dev/ttyS0, address: A, peers: [{address: B, " \
                        "outbound: [x1, {name: x2, type: long}], inbound: [y1]}]}\n"
#define MED_LINK        "  - {name: med, protocol: circe, role: mediator, transport: pty, " \
                        "device: /tmp/m.tty, emulate: [{address: E1E1E1, capabilities: 32}]}\n"
#define BASE            "instance: plan\nruntime_dir: " RUNTIME_DIR "\nlinks:\n" SL_LINK MED_LINK

/* yaml parsed; a configuration the parser refuses fails the test with its message. */
static struct config *parse_ok(const char *yaml)
{
        struct config_error e = { 0 };
        struct config *c = NULL;

        if (config_parse(yaml, strlen(yaml), TEST_FILENAME, &c, &e) < 0)
                fail_msg("the parser refuses it: %s\n%s", e.message, yaml);
        return c;
}

/* The plan of yaml; fails the test with the plan's message on error. */
static void plan_ok(const char *yaml, struct daemon_plan *plan)
{
        struct config *c = parse_ok(yaml);
        char err[DAEMON_ERROR_MAX] = "";
        int r = daemon_plan_make(c, plan, err, sizeof(err));

        /* The declaration is the plan's own: nothing may point into the configuration. */
        config_free(c);
        if (r < 0)
                fail_msg("unexpected error %d: %s", r, err);
}

/* The error of yaml's plan and its message in err. */
static int plan_error(const char *yaml, char *err, size_t errsz)
{
        struct config *c = parse_ok(yaml);
        struct daemon_plan plan;
        int r = daemon_plan_make(c, &plan, err, errsz);

        daemon_plan_clear(&plan);
        config_free(c);
        assert_true(r < 0);
        return r;
}

static const struct shm_var *decl_var(const struct daemon_plan *plan, const char *name)
{
        for (uint32_t i = 0; i < plan->decl->nvars; i++)
                if (strcmp(plan->decl->vars[i].name, name) == 0)
                        return &plan->decl->vars[i];
        fail_msg("no variable %s in the declaration", name);
        return NULL;
}

static void test_declaration(void **state)
{
        struct daemon_plan plan;
        const struct shm_var *v;
        unsigned med_vars = 0;

        (void)state;
        plan_ok(BASE, &plan);
        assert_ptr_equal(plan.ops[0], &link_sharedlink_ops);
        assert_ptr_equal(plan.ops[1], &link_circe_ops);
        assert_false(plan.has_group);
        assert_string_equal(plan.runtime_dir, RUNTIME_DIR);
        assert_string_equal(plan.socket_path, RUNTIME_DIR "/plan.sock");
        assert_string_equal(plan.decl->instance, "plan");
        assert_int_equal(plan.decl->nlinks, 2);
        assert_string_equal(plan.decl->link_names[0], "sl");
        assert_string_equal(plan.decl->link_names[1], "med");
        assert_int_equal(plan.decl->protocols[1], CONFIG_PROTOCOL_CIRCE);

        v = decl_var(&plan, "x2");
        assert_int_equal(v->direction, SHM_DIR_OUT);
        assert_int_equal(v->type, SHM_TYPE_LONG);
        assert_int_equal(v->link, 0);
        assert_int_equal(v->position, 1);
        assert_string_equal(v->peer, "B");
        v = decl_var(&plan, "y1");
        assert_int_equal(v->direction, SHM_DIR_IN);
        assert_int_equal(v->position, 0);
        /* In link order: the SharedLink link's three, then the mediator's own. */
        for (uint32_t i = 0; i < plan.decl->nvars; i++) {
                assert_int_equal(plan.decl->vars[i].link, i < 3 ? 0 : 1);
                med_vars += plan.decl->vars[i].link == 1;
        }
        assert_true(med_vars > 0);
        daemon_plan_clear(&plan);
        daemon_plan_clear(&plan);       /* twice is harmless */
}

static void test_runtime_dir_env(void **state)
{
        static const char no_dir[] = "instance: env\nlinks:\n" SL_LINK;
        char err[DAEMON_ERROR_MAX], long_dir[CONFIG_SOCKET_PATH_MAX + 2];
        struct daemon_plan plan;

        (void)state;
        assert_int_equal(setenv(DAEMON_RUNTIME_DIR_ENV, "/run/elsewhere", 1), 0);
        plan_ok(no_dir, &plan);
        assert_string_equal(plan.socket_path, "/run/elsewhere/env.sock");
        daemon_plan_clear(&plan);
        /* The file's runtime_dir wins over the variable. */
        plan_ok(BASE, &plan);
        assert_string_equal(plan.socket_path, RUNTIME_DIR "/plan.sock");
        daemon_plan_clear(&plan);

        assert_int_equal(setenv(DAEMON_RUNTIME_DIR_ENV, "relative/dir", 1), 0);
        assert_int_equal(plan_error(no_dir, err, sizeof(err)), -EINVAL);
        assert_non_null(strstr(err, "relative/dir is not an absolute path"));

        memset(long_dir, 'd', sizeof(long_dir) - 1);
        long_dir[0] = '/';
        long_dir[sizeof(long_dir) - 1] = '\0';
        assert_int_equal(setenv(DAEMON_RUNTIME_DIR_ENV, long_dir, 1), 0);
        assert_int_equal(plan_error(no_dir, err, sizeof(err)), -ENAMETOOLONG);
        assert_non_null(strstr(err, "control socket path"));
        assert_int_equal(unsetenv(DAEMON_RUNTIME_DIR_ENV), 0);
}

static void test_group(void **state)
{
        char err[DAEMON_ERROR_MAX];
        struct daemon_plan plan;

        (void)state;
        plan_ok("group: root\nruntime_dir: " RUNTIME_DIR "\nlinks:\n" SL_LINK, &plan);
        assert_true(plan.has_group);
        assert_int_equal(plan.gid, 0);
        assert_true(plan.decl->has_group);
        daemon_plan_clear(&plan);
        assert_int_equal(plan_error("group: no-such-group-here\nlinks:\n" SL_LINK, err,
                                    sizeof(err)), -ENOENT);
        assert_string_equal(err, "group \"no-such-group-here\" does not exist: create it "
                            "(groupadd --system no-such-group-here; for \"sharedlink\", "
                            "systemd-sysusers once make install has put its sysusers.d file in "
                            "place), or leave out group:");
}

struct same_case {
        const char *name;
        const char *yaml;       /* compared with BASE */
        bool same_tables, same_socket;
};

static const struct same_case same_cases[] = {
        { "identical", BASE, true, true },
        /* A link's settings: the link restarts, the tables stay. */
        { "baud", "instance: plan\nruntime_dir: " RUNTIME_DIR "\nlinks:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, baud: 9600, "
          "device: /dev/ttyS0, address: A, peers: [{address: B, "
          "outbound: [x1, {name: x2, type: long}], inbound: [y1]}]}\n" MED_LINK, true, true },
        { "variable_type", "instance: plan\nruntime_dir: " RUNTIME_DIR "\nlinks:\n"
          "  - {name: sl, protocol: sharedlink, transport: serial, "
          "device: /dev/ttyS0, address: A, peers: [{address: B, "
          "outbound: [x1, {name: x2, type: double}], inbound: [y1]}]}\n" MED_LINK, false, true },
        { "link_order", "instance: plan\nruntime_dir: " RUNTIME_DIR "\nlinks:\n"
          MED_LINK SL_LINK, false, true },
        { "link_removed", "instance: plan\nruntime_dir: " RUNTIME_DIR "\nlinks:\n" SL_LINK,
          false, true },
        { "instance", "instance: other\nruntime_dir: " RUNTIME_DIR "\nlinks:\n"
          SL_LINK MED_LINK, false, false },
        /* The header publishes the socket path: moving it takes new tables too. */
        { "runtime_dir", "instance: plan\nruntime_dir: " RUNTIME_DIR "-2\nlinks:\n"
          SL_LINK MED_LINK, false, false },
        { "group", "group: root\ninstance: plan\nruntime_dir: " RUNTIME_DIR "\nlinks:\n"
          SL_LINK MED_LINK, false, false },
};

static void test_same(void **state)
{
        struct daemon_plan base;

        (void)state;
        plan_ok(BASE, &base);
        for (size_t i = 0; i < sizeof(same_cases) / sizeof(same_cases[0]); i++) {
                const struct same_case *t = &same_cases[i];
                struct daemon_plan other;

                plan_ok(t->yaml, &other);
                if (daemon_plan_same_tables(&base, &other) != t->same_tables ||
                    daemon_plan_same_tables(&other, &base) != t->same_tables)
                        fail_msg("case %s: tables should be %s", t->name,
                                 t->same_tables ? "kept" : "new");
                if (daemon_plan_same_socket(&base, &other) != t->same_socket ||
                    daemon_plan_same_socket(&other, &base) != t->same_socket)
                        fail_msg("case %s: socket should be %s", t->name,
                                 t->same_socket ? "kept" : "new");
                daemon_plan_clear(&other);
        }
        daemon_plan_clear(&base);
}

/* What the link of yaml's first link learns, as its engine says. */
static struct link_learning learning_of(const char *yaml)
{
        struct config *c = parse_ok(yaml);
        const struct link_ops *ops = link_ops_for(c->links[0].protocol);
        struct link_learning learning = { 0 };

        assert_non_null(ops);
        if (ops->learning)
                ops->learning(&c->links[0], &learning);
        config_free(c);
        return learning;
}

#define P4_LINK(lists)  "links:\n  - {name: p4, protocol: sharedlink, transport: udp, " \
                        "local: '127.0.0.1:0', remote: '127.0.0.1:9', address: B, " \
                        "peers: [{address: A, dialect: pronto4, " lists "}]}\n"

static void test_learning(void **state)
{
        struct link_learning l;

        (void)state;
        /* Each learned list may add learn_max names; a learned outbound one as many spare
         * .out slots, and the link then gets client writes to names added at run time. */
        l = learning_of(P4_LINK("outbound: learn, inbound: learn, learn_max: 4"));
        assert_int_equal(l.adhoc, 8);
        assert_int_equal(l.out_spare, 4);
        assert_true(l.outbound);
        l = learning_of(P4_LINK("outbound: [{name: a1, type: long}], inbound: learn, "
                                "learn_max: 5"));
        assert_int_equal(l.adhoc, 5);
        assert_int_equal(l.out_spare, 0);
        assert_false(l.outbound);
        /* Configured lists learn nothing; neither does a CIRCE link. */
        l = learning_of(P4_LINK("outbound: [{name: a1, type: long}], inbound: [{name: b1, "
                                "type: long}]"));
        assert_int_equal(l.adhoc, 0);
        assert_int_equal(l.out_spare, 0);
        assert_false(l.outbound);
        l = learning_of("links:\n" SL_LINK);
        assert_int_equal(l.adhoc + l.out_spare, 0);
        assert_false(l.outbound);
        assert_null(link_circe_ops.learning);
}

/* YAML of `links` UDP links of `peers` Pronto4 peers each, both lists learned, learn_max 168
 * (the most a 1024-byte answer holds). */
static char *learning_links(unsigned links, unsigned peers)
{
        static const char peer_addr[] = "ACDEFGHIJKLMNOP";       /* every node but B */
        size_t size = 256 + (size_t)links * (160 + peers * 120), len;
        char *y = malloc(size);

        assert_non_null(y);
        assert_true(peers <= sizeof(peer_addr) - 1);
        len = (size_t)snprintf(y, size, "instance: plan\nruntime_dir: " RUNTIME_DIR "\nlinks:\n");
        for (unsigned i = 0; i < links; i++) {
                len += (size_t)snprintf(y + len, size - len, "  - {name: p%u, protocol: "
                                        "sharedlink, transport: udp, local: '127.0.0.1:0', "
                                        "remote: '127.0.0.1:9', address: B, peers: [", i);
                for (unsigned k = 0; k < peers; k++)
                        len += (size_t)snprintf(y + len, size - len, "%s{address: %c, dialect: "
                                                "pronto4, max_frame: 1024, outbound: learn, "
                                                "inbound: learn, learn_max: 168}",
                                                k ? ", " : "", peer_addr[k]);
                len += (size_t)snprintf(y + len, size - len, "]}\n");
        }
        assert_true(len < size);
        return y;
}

/* The tables hold the configured names, the ad hoc room and what the links may learn, at most
 * SHM_CAPACITY_MAX entries: a plan that needs more is refused (so `-n` says so), where before
 * it passed `-n` and the daemon failed to create its tables ("Invalid argument"). */
static void test_learned_room(void **state)
{
        struct daemon_plan plan;
        char err[DAEMON_ERROR_MAX] = "";
        char *y;

        (void)state;
        y = learning_links(16, 5);              /* 16 x 5 x 336 = 26,880 names */
        plan_ok(y, &plan);
        assert_int_equal(plan.adhoc_capacity, DAEMON_ADHOC_CAPACITY + 16 * 5 * 2 * 168);
        assert_int_equal(plan.out_spare, 16 * 5 * 168);
        daemon_plan_clear(&plan);
        free(y);
        y = learning_links(16, 15);             /* 80,640 names: more than the tables hold */
        assert_int_equal(plan_error(y, err, sizeof(err)), -E2BIG);
        assert_non_null(strstr(err, "the links may learn 80640 names at run time"));
        assert_non_null(strstr(err, "lower learn_max"));
        free(y);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_declaration),
                cmocka_unit_test(test_runtime_dir_env),
                cmocka_unit_test(test_group),
                cmocka_unit_test(test_same),
                cmocka_unit_test(test_learning),
                cmocka_unit_test(test_learned_room),
        };

        unsetenv(DAEMON_RUNTIME_DIR_ENV);
        return cmocka_run_group_tests(tests, NULL, NULL);
}
