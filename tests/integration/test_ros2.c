/*
 * sharedlink-ros2 end to end, with no ROS installed: the real sharedlinkd (a SharedLink pair
 * back to back over a pty, and a CIRCE controller on the mediator emulator for events), the
 * real bridge, and this test as a DDS peer on Cyclone DDS with its own copy of the ROS types
 * (tests/integration/ros2/ros2_test_msgs.idl, compiled without type information as
 * rmw_cyclonedds_cpp registers them), so that everything matches by type name and plain CDR as
 * with a ROS 2 node:
 *
 *  - topic names, type names, QoS (RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1) and USER_DATA
 *    (typehash per endpoint, enclave per participant) as discovery shows them;
 *  - the CDR bytes of Int64, Float64 and String samples against golden bytes;
 *  - a late joiner gets the last value; a ROS-default subscriber (RELIABLE, VOLATILE,
 *    KEEP_LAST 10) and a BEST_EFFORT one both match and receive;
 *  - writes from <ns>/set/<name> reach the wire (the peer node's inbound variable); a string
 *    over 63 bytes, a value that is not wire text, a NaN, a writer of the wrong type and a
 *    writer on an inbound variable's set topic change nothing and are reported on set_errors;
 *    a flood of writes: every one written, the last one wins, and values changed meanwhile
 *    (published from the bridge's waker thread while its loop takes the writes) go out too;
 *  - /diagnostics: one status per link and one for the bridge; a stopped daemon is STALE, and
 *    its restart is followed; events in ring order on <ns>/events, an overrun as a notice;
 *  - set/ writers there before the bridge planned: judged once it has (no unknown);
 *  - the events' cursor across a bridge restart: after SIGTERM exactly the events missed,
 *    after SIGKILL none lost (some may repeat);
 *  - NavSatFix from two variables; a reader that vanishes (SIGKILL) does not stop the bridge;
 *  - -n: two variables on one topic, an unknown navsatfix variable (FILE:LINE:COL); a DDS
 *    domain that cannot be created fails the start with a clear message;
 *  - a second bridge with wait_spin_us publishes as the default one does.
 *
 * Network rule: every participant (this test's, the bridge's) is configured for unicast on
 * 127.0.0.1 only (AllowMulticast false, a 127.0.0.1 peer, the loopback interface), on a domain
 * id of this test's own.
 */
#define _GNU_SOURCE
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>
#include <sharedlink.h>

#include "common/harness.h"
#include "common/slwait.h"
#include "ros2/ros2_typehash.h"
#include "ros2_test_msgs.h"

#define T_START_MS      15000   /* READY=1 (ASan build) */
#define T_WAIT_MS       15000   /* one awaited sample or discovery */
#define T_STOP_MS       15000
#define CONFIG_MAX      8192
#define PATH_BUF        512
#define TOPIC_MAX       300
#define REPLY_MAX       512
#define DOMAIN_BASE     100     /* domain ids 100..199, by pid: one of this run's own */
#define DOMAIN_SPAN     100
#define FLOOD           500     /* writes in the flood */
#define VALUE_EVERY     50      /* test_values_during_flood: a value change every so many */
#define SPIN_NS         "/spin"
#define SPIN_US         1000    /* test_spin_bridge's wait_spin_us */
#define RING_EVENTS     1024    /* the daemon's event ring (SHM_EVENTS_DEFAULT) */
#define OVERRUN_EVENTS  (RING_EVENTS + 100)
#define FLOOD_MAX       40000   /* gate passages before the change record must have overrun */
#define FLOOD_CHECK     100     /* passages between two looks at the record */
#define VANISH_ARG      "--vanishing-reader"
#define RETRIES         10      /* writes until a volatile reader is matched both ways ... */
#define RETRY_MS        1500    /* ... each awaited this long */
#define MISSED          5       /* events made while the bridge is down */
#define MISSED_BASE     7000    /* their sensor-time: MISSED_BASE + 1 .. + MISSED */

/* Unicast on loopback only (docs/ros2.md, "Tests"). */
#define CYCLONE_XML \
        "<CycloneDDS><Domain id=\"any\"><General>" \
        "<Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces>" \
        "<AllowMulticast>false</AllowMulticast></General>" \
        "<Discovery><ParticipantIndex>auto</ParticipantIndex>" \
        "<MaxAutoParticipantIndex>20</MaxAutoParticipantIndex>" \
        "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain></CycloneDDS>"

struct fx {
        struct harness h;               /* sharedlinkd */
        struct harness r;               /* sharedlink-ros2 */
        struct sl_client *cl;
        unsigned domain;
        dds_entity_t dom, pp;
        char ns[128];
        char conf[PATH_BUF];
        char daemon_conf[PATH_BUF];
        int ctl;
};

static struct fx *F;

static const char *bridge_path(void)
{
        static char path[PATH_BUF];
        const char *b = getenv("SHAREDLINK_BUILD");

        snprintf(path, sizeof(path), "%s/sharedlink-ros2", b ? b : "build");
        return path;
}

static void topic_of(char *out, size_t size, const char *rel)
{
        snprintf(out, size, "rt%s/%s", F->ns, rel);
}

/* ---- the fixture: one daemon, one bridge, one participant for the whole group ------------ */

static const char daemon_links[] =
        "links:\n"
        "  - {name: node_a, protocol: sharedlink, transport: pty, device: %s/a.tty,\n"
        "     address: A, peers: [{address: B, period_ms: 100, on_change: true,\n"
        "       outbound: [{name: a.Lat, type: double}, {name: a.Lon, type: double},\n"
        "                  {name: a.Name, type: string}, {name: a.Count, type: long},\n"
        "                  c.dup-x, c.dup_x],\n"
        "       inbound: [{name: a.Throttle, type: long}]}]}\n"
        "  - {name: node_b, protocol: sharedlink, transport: serial, device: %s/a.tty,\n"
        "     address: B, peers: [{address: A, period_ms: 100, on_change: true,\n"
        "       outbound: [{name: b.Throttle, type: long}],\n"
        "       inbound: [{name: b.Lat, type: double}, {name: b.Lon, type: double},\n"
        "                 {name: b.Name, type: string}, {name: b.Count, type: long},\n"
        "                 d.dup-x, d.dup_x]}]}\n"
        "  - {name: arena, protocol: circe, role: mediator, transport: pty,\n"
        "     device: %s/arena.tty, version: \"0.2.3\", keepalive_ms: 750,\n"
        "     emulate: [{address: E1E1E1, capabilities: 32}]}\n"
        "  - {name: agility, protocol: circe, role: controller, transport: serial,\n"
        "     device: %s/arena.tty, expect_version: \"0.2\"}\n";

static void start_daemon(struct fx *f)
{
        char links[CONFIG_MAX], why[HARNESS_WHY_MAX], sock[PATH_BUF];
        int r;

        snprintf(links, sizeof(links), daemon_links, f->h.dir, f->h.dir, f->h.dir, f->h.dir);
        f->h.capture_log = 1;
        r = harness_start_config(&f->h, "daemon.yaml", links, T_START_MS, why, sizeof(why));
        if (r < 0)
                fail_msg("sharedlinkd did not start: %s", why);
        if (!f->cl)
                assert_int_equal(sl_open(f->h.instance, &f->cl), 0);
        snprintf(sock, sizeof(sock), "%s/%s.sock", f->h.dir, f->h.instance);
        harness_close_fd(&f->ctl);
        f->ctl = harness_connect_unix(sock);
        assert_true(f->ctl >= 0);
}

/* The bridge's configuration; extra: more top-level keys. Returns the line of publish:. */
static void write_conf(struct fx *f, const char *name, const char *extra, char *path)
{
        char text[CONFIG_MAX];

        snprintf(text, sizeof(text),
                 "instance: %s\n"
                 "domain_id: %u\n"
                 "cyclonedds_uri: '%s'\n"
                 "writable: [\"a.*\"]\n"
                 "navsatfix:\n"
                 "  - {topic: gps/fix, latitude: b.Lat, longitude: b.Lon, frame_id: gps_link}\n"
                 "%s",
                 f->h.instance, f->domain, CYCLONE_XML, extra ? extra : "");
        assert_int_equal(harness_write_file(&f->r, name, text, path), 0);
}

static void start_bridge(struct fx *f)
{
        const char *argv[] = { bridge_path(), "-c", f->conf, "-v", NULL };
        int st = 0, r;

        f->r.capture_log = 1;
        r = harness_start_program(&f->r, &f->h, argv, T_START_MS, &st);
        if (r < 0)
                fail_msg("sharedlink-ros2 did not start (%d, status %d); log %s", r, st,
                         f->r.log_path);
}

static int group_setup(void **state)
{
        struct fx *f = calloc(1, sizeof(*f));
        char rel[64];

        if (!f)
                return -1;
        f->ctl = -1;
        F = f;
        *state = f;
        if (harness_init(&f->h, "ros2") < 0 || harness_init(&f->r, "ros2b") < 0)
                return -1;
        print_message("logs: %s (sharedlinkd), %s (sharedlink-ros2)\n", f->h.log_path,
                      f->r.log_path);
        /* The bridge's default namespace: the instance by the variables' rule ('-' -> '_'). */
        snprintf(rel, sizeof(rel), "%s", f->h.instance);
        for (char *p = rel; *p; p++)
                if (*p == '-')
                        *p = '_';
        snprintf(f->ns, sizeof(f->ns), "/sharedlink/%s", rel);
        f->domain = DOMAIN_BASE + (unsigned)getpid() % DOMAIN_SPAN;
        /* Every DDS participant of this process and its children: loopback unicast only. */
        setenv("CYCLONEDDS_URI", CYCLONE_XML, 1);
        unsetenv("ROS_DOMAIN_ID");
        f->dom = dds_create_domain(f->domain, CYCLONE_XML);
        if (f->dom < 0)
                return -1;
        f->pp = dds_create_participant(f->domain, NULL, NULL);
        if (f->pp < 0)
                return -1;
        start_daemon(f);
        write_conf(f, "ros2.yaml", NULL, f->conf);
        start_bridge(f);
        return 0;
}

static int group_teardown(void **state)
{
        struct fx *f = *state;

        if (f->r.pid > 0)
                harness_stop_daemon(&f->r, SIGTERM, T_STOP_MS);
        harness_close_fd(&f->ctl);
        sl_close(f->cl);
        if (f->dom > 0)
                dds_delete(f->dom);
        if (getenv("SHAREDLINK_KEEP_LOGS")) {   /* debugging: keep the directories */
                f->r.dir[0] = '\0';
                f->h.dir[0] = '\0';
        }
        harness_cleanup(&f->r);
        harness_cleanup(&f->h);
        free(f);
        return 0;
}

/* ---- DDS helpers ---------------------------------------------------------------------------- */

enum rqos { RQ_TRANSIENT, RQ_ROS_DEFAULT, RQ_BEST_EFFORT, RQ_KEEP_ALL };

static dds_entity_t reader(const dds_topic_descriptor_t *desc, const char *topic, enum rqos q)
{
        dds_qos_t *qos = dds_create_qos();
        dds_entity_t t = dds_create_topic(F->pp, desc, topic, NULL, NULL), rd;

        assert_true(t > 0);
        switch (q) {
        case RQ_TRANSIENT:
                dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
                dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
                dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 1);
                break;
        case RQ_ROS_DEFAULT:
                dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
                dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
                dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
                break;
        case RQ_KEEP_ALL:       /* events: a burst is not thinned out by our own history */
                dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
                dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
                dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
                break;
        case RQ_BEST_EFFORT:
                dds_qset_reliability(qos, DDS_RELIABILITY_BEST_EFFORT, 0);
                dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
                dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 5);
                break;
        }
        rd = dds_create_reader(F->pp, t, qos, NULL);
        dds_delete_qos(qos);
        assert_true(rd > 0);
        return rd;
}

static dds_entity_t writer(const dds_topic_descriptor_t *desc, const char *topic)
{
        dds_qos_t *qos = dds_create_qos();
        dds_entity_t t = dds_create_topic(F->pp, desc, topic, NULL, NULL), wr;

        assert_true(t > 0);
        /* ros2 topic pub's defaults: RELIABLE, VOLATILE, KEEP_LAST; KEEP_ALL here so that
         * the flood below is not thinned out by our own history. */
        dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(10));
        dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
        dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
        wr = dds_create_writer(F->pp, t, qos, NULL);
        dds_delete_qos(qos);
        assert_true(wr > 0);
        return wr;
}

/* Waits (bounded) until entity e has status s (a match): publication/subscription matched. */
static void wait_matched(dds_entity_t e, bool is_writer)
{
        dds_entity_t ws = dds_create_waitset(F->pp);
        uint64_t deadline = harness_now_ns() + (uint64_t)T_WAIT_MS * 1000000u;

        dds_set_status_mask(e, is_writer ? DDS_PUBLICATION_MATCHED_STATUS :
                                           DDS_SUBSCRIPTION_MATCHED_STATUS);
        dds_waitset_attach(ws, e, e);
        for (;;) {
                uint32_t count;

                if (is_writer) {
                        dds_publication_matched_status_t st;

                        dds_get_publication_matched_status(e, &st);
                        count = st.current_count;
                } else {
                        dds_subscription_matched_status_t st;

                        dds_get_subscription_matched_status(e, &st);
                        count = st.current_count;
                }
                if (count > 0)
                        break;
                if (harness_now_ns() >= deadline)
                        fail_msg("no match on a %s", is_writer ? "writer" : "reader");
                dds_waitset_wait(ws, NULL, 0, DDS_MSECS(200));
        }
        dds_delete(ws);
}

typedef bool sample_fn(const void *sample, void *arg);

/* Takes samples of rd until fn accepts one (true) or ms pass (false). */
static bool wait_sample_ms(dds_entity_t rd, sample_fn *fn, void *arg, int ms)
{
        dds_entity_t ws = dds_create_waitset(F->pp);
        uint64_t deadline = harness_now_ns() + (uint64_t)ms * 1000000u;
        bool found = false;

        dds_set_status_mask(rd, DDS_DATA_AVAILABLE_STATUS);
        dds_waitset_attach(ws, rd, rd);
        while (!found && harness_now_ns() < deadline) {
                void *buf[16] = { NULL };
                dds_sample_info_t si[16];
                int n = dds_take(rd, buf, si, 16, 16);

                for (int i = 0; i < n && !found; i++)
                        if (si[i].valid_data && fn(buf[i], arg))
                                found = true;
                if (n > 0)
                        dds_return_loan(rd, buf, n);
                if (!found && n <= 0)
                        dds_waitset_wait(ws, NULL, 0, DDS_MSECS(200));
        }
        dds_delete(ws);
        return found;
}

static bool wait_sample(dds_entity_t rd, sample_fn *fn, void *arg)
{
        return wait_sample_ms(rd, fn, arg, T_WAIT_MS);
}

static bool is_double(const void *s, void *arg)
{
        return ((const std_msgs_msg_dds__Float64_ *)s)->data == *(const double *)arg;
}

static bool is_long(const void *s, void *arg)
{
        return ((const std_msgs_msg_dds__Int64_ *)s)->data == *(const int64_t *)arg;
}

static bool has_text(const void *s, void *arg)
{
        const char *d = ((const std_msgs_msg_dds__String_ *)s)->data;

        return d && strstr(d, arg);
}

/* Waits for a String sample containing needle. */
static bool wait_text(dds_entity_t rd, const char *needle)
{
        char copy[128];

        snprintf(copy, sizeof(copy), "%s", needle);
        return wait_sample(rd, has_text, copy);
}

static void sl_set(const char *name, const char *value)
{
        int id = sl_find(F->cl, name);

        assert_true(id >= 0);
        assert_int_equal(sl_write(F->cl, id, value), 0);
}

/* Whether variable name reads value within ms (bounded; on the tables' change futex). */
static bool var_becomes(const char *name, const char *value, int ms)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)ms * 1000000u;
        uint32_t cursor = 0;
        char buf[SL_VALUE_SIZE];

        for (;;) {
                int id = sl_find(F->cl, name);

                if (id >= 0 && sl_read(F->cl, id, buf, sizeof(buf), NULL) >= 0 &&
                    !strcmp(buf, value))
                        return true;
                if (harness_now_ns() >= deadline)
                        return false;
                sl_wait(F->cl, &cursor, 100);
        }
}

/* Waits (bounded) until variable name reads value. */
static void wait_var(const char *name, const char *value)
{
        char buf[SL_VALUE_SIZE] = "";
        int id;

        if (var_becomes(name, value, T_WAIT_MS))
                return;
        id = sl_find(F->cl, name);
        if (id >= 0)
                sl_read(F->cl, id, buf, sizeof(buf), NULL);
        fail_msg("%s never read \"%s\" (last \"%s\")", name, value, buf);
}

/* Writes sample with w until variable var reads value: the first write after a match can be
 * lost (docs/ros2.md §4); after one arrived, w and the bridge's reader know each other. */
static void write_until(dds_entity_t w, const void *sample, const char *var, const char *value)
{
        for (int i = 0; ; i++) {
                assert_true(i < RETRIES);
                assert_int_equal(dds_write(w, sample), 0);
                if (var_becomes(var, value, RETRY_MS))
                        return;
        }
}

/* The value of an outbound a.X reached the peer as b.X: the bridge has seen it long before. */
static void wait_published(const char *var)
{
        char peer[SL_NAME_SIZE], value[SL_VALUE_SIZE];
        int id = sl_find(F->cl, var);

        assert_true(id >= 0);
        assert_true(sl_read(F->cl, id, value, sizeof(value), NULL) >= 0);
        snprintf(peer, sizeof(peer), "b%s", var + 1);
        wait_var(peer, value);
}

static void read_var(const char *name, char *buf)
{
        int id = sl_find(F->cl, name);

        assert_true(id >= 0);
        assert_true(sl_read(F->cl, id, buf, SL_VALUE_SIZE, NULL) >= 0);
}

/* ---- discovery: names, types, QoS, USER_DATA ---------------------------------------------- */

struct found_pub {
        const char *topic;
        char type[128];
        dds_reliability_kind_t rel;
        dds_durability_kind_t dur;
        dds_history_kind_t hist;
        int32_t depth;
        char userdata[128];
        dds_guid_t participant;
};

static bool pub_is(const void *s, void *arg)
{
        const dds_builtintopic_endpoint_t *ep = s;
        struct found_pub *fp = arg;
        dds_duration_t blk;
        void *ud = NULL;
        size_t sz = 0;

        if (!ep->topic_name || strcmp(ep->topic_name, fp->topic))
                return false;
        snprintf(fp->type, sizeof(fp->type), "%s", ep->type_name);
        dds_qget_reliability(ep->qos, &fp->rel, &blk);
        dds_qget_durability(ep->qos, &fp->dur);
        dds_qget_history(ep->qos, &fp->hist, &fp->depth);
        if (dds_qget_userdata(ep->qos, &ud, &sz) && ud) {
                snprintf(fp->userdata, sizeof(fp->userdata), "%.*s", (int)sz, (char *)ud);
                dds_free(ud);
        }
        fp->participant = ep->participant_key;
        return true;
}

static void find_pub(const char *topic, struct found_pub *fp)
{
        dds_entity_t rd = dds_create_reader(F->pp, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, NULL, NULL);

        memset(fp, 0, sizeof(*fp));
        fp->topic = topic;
        assert_true(rd > 0);
        if (!wait_sample(rd, pub_is, fp))
                fail_msg("no writer on %s discovered", topic);
        dds_delete(rd);
}

struct found_pp {
        dds_guid_t key;
        char userdata[128];
};

static bool pp_is(const void *s, void *arg)
{
        const dds_builtintopic_participant_t *p = s;
        struct found_pp *fp = arg;
        void *ud = NULL;
        size_t sz = 0;

        if (memcmp(&p->key, &fp->key, sizeof(fp->key)))
                return false;
        if (dds_qget_userdata(p->qos, &ud, &sz) && ud) {
                snprintf(fp->userdata, sizeof(fp->userdata), "%.*s", (int)sz, (char *)ud);
                dds_free(ud);
        }
        return true;
}

/* The hash values are the published ones (ros2_typehash.h, held to them by test_typehash.py). */
static void check_value_pub(const char *rel, const char *type, const char *user_data)
{
        char topic[TOPIC_MAX];
        struct found_pub fp;

        topic_of(topic, sizeof(topic), rel);
        find_pub(topic, &fp);
        assert_string_equal(fp.type, type);
        assert_int_equal(fp.rel, DDS_RELIABILITY_RELIABLE);
        assert_int_equal(fp.dur, DDS_DURABILITY_TRANSIENT_LOCAL);
        assert_int_equal(fp.hist, DDS_HISTORY_KEEP_LAST);
        assert_int_equal(fp.depth, 1);
        assert_string_equal(fp.userdata, user_data);
}

static void test_discovery(void **state)
{
        dds_entity_t rd = dds_create_reader(F->pp, DDS_BUILTIN_TOPIC_DCPSPARTICIPANT, NULL, NULL);
        char topic[TOPIC_MAX];
        struct found_pub fp;
        struct found_pp pp;

        (void)state;
        check_value_pub("a/Lat", "std_msgs::msg::dds_::Float64_",
                        ROS2_TYPEHASH_USER_DATA(ROS2_TYPEHASH_FLOAT64));
        check_value_pub("b/Count", "std_msgs::msg::dds_::Int64_",
                        ROS2_TYPEHASH_USER_DATA(ROS2_TYPEHASH_INT64));
        check_value_pub("a/Name", "std_msgs::msg::dds_::String_",
                        ROS2_TYPEHASH_USER_DATA(ROS2_TYPEHASH_STRING));
        check_value_pub("gps/fix", "sensor_msgs::msg::dds_::NavSatFix_",
                        ROS2_TYPEHASH_USER_DATA(ROS2_TYPEHASH_NAVSATFIX));
        find_pub("rt/diagnostics", &fp);
        assert_string_equal(fp.type, "diagnostic_msgs::msg::dds_::DiagnosticArray_");
        assert_string_equal(fp.userdata, ROS2_TYPEHASH_USER_DATA(ROS2_TYPEHASH_DIAGNOSTIC_ARRAY));
        topic_of(topic, sizeof(topic), "events");
        find_pub(topic, &fp);
        assert_string_equal(fp.type, "std_msgs::msg::dds_::String_");
        assert_int_equal(fp.rel, DDS_RELIABILITY_RELIABLE);
        /* The participant says enclave=/; as a ROS 2 node's does. */
        memset(&pp, 0, sizeof(pp));
        pp.key = fp.participant;
        assert_true(rd > 0);
        assert_true(wait_sample(rd, pp_is, &pp));
        assert_string_equal(pp.userdata, "enclave=/;");
        dds_delete(rd);
}

/* Two variables on one topic: neither is published, and the log says why. */
static void test_collision_refused(void **state)
{
        (void)state;
        assert_int_equal(harness_wait_log(&F->r, "variable c.dup-x: its topic", T_WAIT_MS), 0);
        assert_int_equal(harness_log_contains(&F->r, "variable c.dup_x: its topic"), 1);
}

/* ---- values ---------------------------------------------------------------------------------- */

struct cdr_case {
        const dds_topic_descriptor_t *desc;
        const char *rel, *var, *value;
        const unsigned char *golden;
        size_t len;
};

/* Plain CDR, little endian: the encapsulation header (CDR_LE, options 0), then the data. */
static const unsigned char golden_double[] = {          /* Float64 1.5 */
        0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf8, 0x3f,
};
static const unsigned char golden_long[] = {            /* Int64 -2 */
        0x00, 0x01, 0x00, 0x00, 0xfe, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff,
};
/* String "hi": length with the NUL, then the bytes. Cyclone pads the data to 4 bytes and
 * records the pad count in the encapsulation options (0x0001: one byte), as XTypes 1.3 §7.6.3.1.2
 * allows; readers of every vendor skip the options. */
static const unsigned char golden_string[] = {
        0x00, 0x01, 0x00, 0x01, 0x03, 0x00, 0x00, 0x00, 'h', 'i', 0x00, 0x00,
};

static const char *hex(const unsigned char *b, size_t n)
{
        static char out[200];
        size_t o = 0;

        for (size_t i = 0; i < n && o + 4 < sizeof(out); i++)
                o += (size_t)snprintf(out + o, sizeof(out) - o, "%02x ", b[i]);
        return out;
}

static void cdr_check(const struct cdr_case *c)
{
        char topic[TOPIC_MAX];
        dds_entity_t rd, ws;
        uint64_t deadline = harness_now_ns() + (uint64_t)T_WAIT_MS * 1000000u;
        bool found = false;

        /* Written first, read by a late joiner: the writer has the sample whenever it
         * discovers the reader (a volatile reader could miss a sample written before). */
        topic_of(topic, sizeof(topic), c->rel);
        sl_set(c->var, c->value);
        wait_published(c->var);
        rd = reader(c->desc, topic, RQ_TRANSIENT);
        ws = dds_create_waitset(F->pp);
        dds_set_status_mask(rd, DDS_DATA_AVAILABLE_STATUS);
        dds_waitset_attach(ws, rd, rd);
        while (!found && harness_now_ns() < deadline) {
                struct ddsi_serdata *sd[1] = { NULL };
                dds_sample_info_t si[1];
                int n = dds_takecdr(rd, sd, 1, si, DDS_ANY_STATE);

                if (n <= 0) {
                        dds_waitset_wait(ws, NULL, 0, DDS_MSECS(200));
                        continue;
                }
                if (si[0].valid_data) {
                        unsigned char bytes[64] = { 0 };
                        uint32_t sz = ddsi_serdata_size(sd[0]);

                        assert_true(sz <= sizeof(bytes));
                        ddsi_serdata_to_ser(sd[0], 0, sz, bytes);
                        /* Any padding after the data is not part of the contract. */
                        if (sz >= c->len && !memcmp(bytes, c->golden, c->len))
                                found = true;
                        else if (sz >= c->len)
                                fail_msg("%s: CDR differs from the golden bytes: %s", c->rel,
                                         hex(bytes, sz));
                }
                ddsi_serdata_unref(sd[0]);
        }
        dds_delete(ws);
        dds_delete(dds_get_topic(rd));
        if (!found)
                fail_msg("%s: no sample", c->rel);
}

static void test_cdr_golden(void **state)
{
        static const struct cdr_case cases[] = {
                { &std_msgs_msg_dds__Float64__desc, "a/Lat", "a.Lat", "1.5", golden_double,
                  sizeof(golden_double) },
                { &std_msgs_msg_dds__Int64__desc, "a/Count", "a.Count", "-2", golden_long,
                  sizeof(golden_long) },
                { &std_msgs_msg_dds__String__desc, "a/Name", "a.Name", "hi", golden_string,
                  sizeof(golden_string) },
        };

        (void)state;
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++)
                cdr_check(&cases[i]);
}

/* The value reaches the peer node, and a late joiner on the peer's inbound variable gets it;
 * a ROS-default and a BEST_EFFORT subscriber see the next value. */
static void test_late_joiner_and_profiles(void **state)
{
        char topic[TOPIC_MAX];
        dds_entity_t late, def, be;
        double v = 12.25, w = -7.5;

        (void)state;
        sl_set("a.Lat", "12.25");
        wait_var("b.Lat", "12.25");
        topic_of(topic, sizeof(topic), "b/Lat");
        late = reader(&std_msgs_msg_dds__Float64__desc, topic, RQ_TRANSIENT);
        assert_true(wait_sample(late, is_double, &v));
        def = reader(&std_msgs_msg_dds__Float64__desc, topic, RQ_ROS_DEFAULT);
        be = reader(&std_msgs_msg_dds__Float64__desc, topic, RQ_BEST_EFFORT);
        wait_matched(def, false);
        wait_matched(be, false);
        /* A volatile reader gets what is written once the writer has discovered it too, which
         * the reader's side cannot see: write new values until one arrives (bounded). */
        for (int i = 0; i < RETRIES; i++) {
                char text[32];

                w = -7.5 - i;
                snprintf(text, sizeof(text), "%.1f", w);
                sl_set("a.Lat", text);
                if (wait_sample_ms(def, is_double, &w, RETRY_MS))
                        break;
                assert_true(i + 1 < RETRIES);
        }
        /* Now matched both ways: the next value must reach both, best effort on loopback. */
        w = 1.75;
        sl_set("a.Lat", "1.75");
        assert_true(wait_sample(def, is_double, &w));
        assert_true(wait_sample_ms(be, is_double, &w, T_WAIT_MS));
        dds_delete(late);
        dds_delete(def);
        dds_delete(be);
}

/* ---- writes ---------------------------------------------------------------------------------- */

static dds_entity_t errors_reader(void)
{
        char topic[TOPIC_MAX];
        dds_entity_t rd;

        topic_of(topic, sizeof(topic), "set_errors");
        rd = reader(&std_msgs_msg_dds__String__desc, topic, RQ_ROS_DEFAULT);
        wait_matched(rd, false);
        return rd;
}

static void test_writes_reach_the_wire(void **state)
{
        char topic[TOPIC_MAX];
        dds_entity_t wd, wl, ws;
        std_msgs_msg_dds__Float64_ d = { .data = 3.125 };
        std_msgs_msg_dds__Int64_ l = { .data = -42 };
        std_msgs_msg_dds__String_ s = { .data = (char *)(uintptr_t)"fromros" };

        (void)state;
        topic_of(topic, sizeof(topic), "set/a/Lat");
        wd = writer(&std_msgs_msg_dds__Float64__desc, topic);
        topic_of(topic, sizeof(topic), "set/a/Count");
        wl = writer(&std_msgs_msg_dds__Int64__desc, topic);
        topic_of(topic, sizeof(topic), "set/a/Name");
        ws = writer(&std_msgs_msg_dds__String__desc, topic);
        wait_matched(wd, true);
        wait_matched(wl, true);
        wait_matched(ws, true);
        /* Over the pty to node B: on the wire. */
        write_until(wd, &d, "b.Lat", "3.125");
        write_until(wl, &l, "b.Count", "-42");
        write_until(ws, &s, "b.Name", "fromros");
        dds_delete(wd);
        dds_delete(wl);
        dds_delete(ws);
}

static void test_bad_writes(void **state)
{
        char topic[TOPIC_MAX], before_name[SL_VALUE_SIZE], before_lat[SL_VALUE_SIZE];
        char before_count[SL_VALUE_SIZE], after[SL_VALUE_SIZE], long_text[65];
        dds_entity_t er = errors_reader(), ws, wd, wrong, inb;
        std_msgs_msg_dds__String_ s;
        std_msgs_msg_dds__Float64_ nan_sample = { .data = NAN };
        std_msgs_msg_dds__Int64_ l = { .data = 5 };

        (void)state;
        read_var("a.Name", before_name);
        read_var("a.Lat", before_lat);
        read_var("a.Count", before_count);
        topic_of(topic, sizeof(topic), "set/a/Name");
        ws = writer(&std_msgs_msg_dds__String__desc, topic);
        wait_matched(ws, true);
        memset(long_text, 'x', 64);
        long_text[64] = '\0';
        s.data = long_text;                     /* 64 bytes: one over the wire's limit */
        /* Repeated until the answer arrives: set_errors is volatile (see RETRIES). */
        for (int i = 0; ; i++) {
                char copy[64] = "\"code\":\"too_long\"";

                assert_true(i < RETRIES);
                assert_int_equal(dds_write(ws, &s), 0);
                if (wait_sample_ms(er, has_text, copy, RETRY_MS))
                        break;
        }
        s.data = (char *)(uintptr_t)"a|b";     /* not wire text */
        assert_int_equal(dds_write(ws, &s), 0);
        assert_true(wait_text(er, "\"code\":\"bad_value\""));
        topic_of(topic, sizeof(topic), "set/a/Lat");
        wd = writer(&std_msgs_msg_dds__Float64__desc, topic);
        wait_matched(wd, true);
        for (int i = 0; ; i++) {       /* a new writer: see RETRIES */
                char copy[64] = "\"code\":\"not_finite\"";

                assert_true(i < RETRIES);
                assert_int_equal(dds_write(wd, &nan_sample), 0);
                if (wait_sample_ms(er, has_text, copy, RETRY_MS))
                        break;
        }
        /* An Int64 writer on a Float64 set topic never matches: reported as it appears. */
        topic_of(topic, sizeof(topic), "set/a/Lat");
        wrong = writer(&std_msgs_msg_dds__Int64__desc, topic);
        assert_true(wait_text(er, "\"code\":\"wrong_type\""));
        assert_int_equal(dds_write(wrong, &l), 0);
        /* A set topic of an inbound variable does not exist. */
        topic_of(topic, sizeof(topic), "set/b/Count");
        inb = writer(&std_msgs_msg_dds__Int64__desc, topic);
        assert_true(wait_text(er, "\"code\":\"unknown\""));
        assert_int_equal(dds_write(inb, &l), 0);
        /* Nothing changed: a write that is accepted, behind them all, comes through first. */
        s.data = (char *)(uintptr_t)"after";
        assert_int_equal(dds_write(ws, &s), 0);
        wait_var("a.Name", "after");
        read_var("a.Lat", after);
        assert_string_equal(after, before_lat);
        read_var("a.Count", after);
        assert_string_equal(after, before_count);
        read_var("b.Count", after);
        assert_string_not_equal(after, "5");
        (void)before_name;
        dds_delete(ws);
        dds_delete(wd);
        dds_delete(wrong);
        dds_delete(inb);
        dds_delete(er);
}

/* FLOOD writes as fast as DDS takes them: each is written (the diagnostics count them), the
 * last one is the value. */
struct count_arg {
        const char *key;
        uint64_t at_least;
        const char *hwid;
};

static bool diag_counter(const void *s, void *arg)
{
        const diagnostic_msgs_msg_dds__DiagnosticArray_ *a = s;
        const struct count_arg *c = arg;

        for (uint32_t i = 0; i < a->status._length; i++) {
                const diagnostic_msgs_msg_dds__DiagnosticStatus_ *st = &a->status._buffer[i];

                if (strcmp(st->hardware_id, c->hwid))
                        continue;
                for (uint32_t k = 0; k < st->values._length; k++)
                        if (!strcmp(st->values._buffer[k].key, c->key) &&
                            strtoull(st->values._buffer[k].value, NULL, 10) >= c->at_least)
                                return true;
        }
        return false;
}

static uint64_t diag_value(const char *hwid, const char *key);

static void test_flood(void **state)
{
        char topic[TOPIC_MAX], last[32];
        dds_entity_t wl, dr;
        uint64_t before;
        struct count_arg ca = { "set_written", 0, F->h.instance };

        (void)state;
        topic_of(topic, sizeof(topic), "set/a/Count");
        wl = writer(&std_msgs_msg_dds__Int64__desc, topic);
        wait_matched(wl, true);
        {
                std_msgs_msg_dds__Int64_ hello = { .data = 999 };

                write_until(wl, &hello, "a.Count", "999");
        }
        before = diag_value(F->h.instance, "set_written");
        ca.at_least = before + FLOOD;
        for (int i = 1; i <= FLOOD; i++) {
                std_msgs_msg_dds__Int64_ l = { .data = 1000 + i };

                assert_int_equal(dds_write(wl, &l), 0);
        }
        snprintf(last, sizeof(last), "%d", 1000 + FLOOD);
        wait_var("a.Count", last);
        dr = reader(&diagnostic_msgs_msg_dds__DiagnosticArray__desc, "rt/diagnostics",
                    RQ_ROS_DEFAULT);
        assert_true(wait_sample(dr, diag_counter, &ca));
        dds_delete(dr);
        dds_delete(wl);
}

/* Values go out from the waker's thread while the loop takes a flood of writes from ROS (the
 * bridge's lock keeps the two apart, docs/ros2.md "Latency"): every write lands, the last of
 * each wins, and the last value changed during the flood is published. */
static void test_values_during_flood(void **state)
{
        char topic[TOPIC_MAX], text[32];
        dds_entity_t wl, rd;
        double v = FLOOD + 0.5;

        (void)state;
        topic_of(topic, sizeof(topic), "set/a/Count");
        wl = writer(&std_msgs_msg_dds__Int64__desc, topic);
        wait_matched(wl, true);
        {
                std_msgs_msg_dds__Int64_ hello = { .data = 2999 };

                write_until(wl, &hello, "a.Count", "2999");
        }
        for (int i = 1; i <= FLOOD; i++) {
                std_msgs_msg_dds__Int64_ l = { .data = 3000 + i };

                assert_int_equal(dds_write(wl, &l), 0);
                if (i % VALUE_EVERY == 0) {
                        snprintf(text, sizeof(text), "%d.5", i);
                        sl_set("a.Lat", text);
                }
        }
        snprintf(text, sizeof(text), "%d", 3000 + FLOOD);
        wait_var("a.Count", text);
        snprintf(text, sizeof(text), "%d.5", FLOOD);
        wait_var("b.Lat", text);
        topic_of(topic, sizeof(topic), "b/Lat");
        rd = reader(&std_msgs_msg_dds__Float64__desc, topic, RQ_TRANSIENT);
        assert_true(wait_sample(rd, is_double, &v));
        dds_delete(rd);
        dds_delete(wl);
}

/* wait_spin_us: a second bridge on a namespace of its own, spinning before it sleeps, publishes
 * a change as the default one does. */
static void test_spin_bridge(void **state)
{
        char text[CONFIG_MAX], path[PATH_BUF], topic[TOPIC_MAX];
        const char *argv[] = { bridge_path(), "-c", path, NULL };
        struct harness s;
        dds_entity_t rd;
        double v = 77.5;
        int st = 0;

        (void)state;
        assert_int_equal(harness_init(&s, "ros2s"), 0);
        snprintf(text, sizeof(text), "instance: %s\nnamespace: " SPIN_NS "\ndomain_id: %u\n"
                 "cyclonedds_uri: '%s'\npublish: [\"b.*\"]\nwait_spin_us: %u\n",
                 F->h.instance, F->domain, CYCLONE_XML, SPIN_US);
        assert_int_equal(harness_write_file(&s, "spin.yaml", text, path), 0);
        s.capture_log = 1;
        if (harness_start_program(&s, &F->h, argv, T_START_MS, &st) < 0)
                fail_msg("sharedlink-ros2 with wait_spin_us did not start (status %d); log %s",
                         st, s.log_path);
        sl_set("a.Lat", "77.5");
        wait_var("b.Lat", "77.5");
        snprintf(topic, sizeof(topic), "rt" SPIN_NS "/b/Lat");
        rd = reader(&std_msgs_msg_dds__Float64__desc, topic, RQ_TRANSIENT);
        assert_true(wait_sample(rd, is_double, &v));
        dds_delete(rd);
        harness_cleanup(&s);
}

/* ---- diagnostics, events, navsatfix ------------------------------------------------------- */

struct level_arg {
        const char *hwid;
        int level;
        char message[256];
};

static bool diag_level(const void *s, void *arg)
{
        const diagnostic_msgs_msg_dds__DiagnosticArray_ *a = s;
        struct level_arg *la = arg;

        for (uint32_t i = 0; i < a->status._length; i++) {
                const diagnostic_msgs_msg_dds__DiagnosticStatus_ *st = &a->status._buffer[i];

                if (strcmp(st->hardware_id, la->hwid))
                        continue;
                snprintf(la->message, sizeof(la->message), "level %d: %s", st->level,
                         st->message);
                if (st->level == la->level)
                        return true;
        }
        return false;
}

struct value_arg {
        const char *hwid, *key;
        uint64_t value;
        bool found;
};

static bool diag_get(const void *s, void *arg)
{
        const diagnostic_msgs_msg_dds__DiagnosticArray_ *a = s;
        struct value_arg *va = arg;

        for (uint32_t i = 0; i < a->status._length; i++) {
                const diagnostic_msgs_msg_dds__DiagnosticStatus_ *st = &a->status._buffer[i];

                if (strcmp(st->hardware_id, va->hwid))
                        continue;
                for (uint32_t k = 0; k < st->values._length; k++)
                        if (!strcmp(st->values._buffer[k].key, va->key)) {
                                va->value = strtoull(st->values._buffer[k].value, NULL, 10);
                                va->found = true;
                                return true;
                        }
        }
        return false;
}

static uint64_t diag_value(const char *hwid, const char *key)
{
        dds_entity_t dr = reader(&diagnostic_msgs_msg_dds__DiagnosticArray__desc,
                                 "rt/diagnostics", RQ_ROS_DEFAULT);
        struct value_arg va = { hwid, key, 0, false };

        if (!wait_sample(dr, diag_get, &va))
                fail_msg("no /diagnostics with %s of %s", key, hwid);
        dds_delete(dr);
        return va.value;
}

static void wait_level(const char *hwid, int level)
{
        dds_entity_t dr = reader(&diagnostic_msgs_msg_dds__DiagnosticArray__desc,
                                 "rt/diagnostics", RQ_ROS_DEFAULT);
        struct level_arg la = { hwid, level, "" };

        if (!wait_sample(dr, diag_level, &la))
                fail_msg("%s never at level %d on /diagnostics (last %s)", hwid, level,
                         la.message);
        dds_delete(dr);
}

static void test_diagnostics(void **state)
{
        char hw[128];

        (void)state;
        snprintf(hw, sizeof(hw), "%s/node_a", F->h.instance);
        wait_level(hw, 0);                                      /* OK: up */
        snprintf(hw, sizeof(hw), "%s/agility", F->h.instance);
        wait_level(hw, 0);
        wait_level(F->h.instance, 1);   /* WARN: two variables refused (c.dup-x, c.dup_x) */
}

static void request(const char *line)
{
        char reply[REPLY_MAX];

        if (harness_control_request(F->ctl, line, reply, sizeof(reply), T_WAIT_MS) < 0)
                fail_msg("no reply to \"%s\"", line);
        assert_string_equal(reply, "OK\n");
}

struct seq_arg {
        uint64_t next;                  /* the seq expected next (0: any) */
        unsigned got, want;
        bool overrun;
};

/* Events in order: each seq one more than the last (of any type), an overrun notice where
 * the gap is; true once want actions came. */
static bool event_seq(const void *s, void *arg)
{
        const char *d = ((const std_msgs_msg_dds__String_ *)s)->data, *p;
        struct seq_arg *sa = arg;
        uint64_t seq;

        if (!d || !(p = strstr(d, "\"seq\":")))
                return false;
        seq = strtoull(p + 6, NULL, 10);
        if (strstr(d, "\"type\":\"overrun\"")) {
                sa->overrun = true;
                sa->next = seq;         /* a notice has the seq of the event after it */
                return false;
        }
        if (sa->next && seq != sa->next)
                fail_msg("event %" PRIu64 " after %" PRIu64 " with no overrun", seq,
                         sa->next - 1);
        sa->next = seq + 1;
        return strstr(d, "\"type\":\"action\"") && ++sa->got >= sa->want;
}

/* Passages until one arrives: then the bridge's events writer knows er (see RETRIES). */
static void events_handshake(dds_entity_t er)
{
        for (int i = 0; ; i++) {
                char copy[32] = "\"type\":\"action\"";

                assert_true(i < RETRIES);
                request("circe arena emulate action E1E1E1 sensor-time=1");
                if (wait_sample_ms(er, has_text, copy, RETRY_MS))
                        return;
        }
}

static void test_events(void **state)
{
        char topic[TOPIC_MAX];
        dds_entity_t er;
        struct seq_arg sa = { 0, 0, 3, false };

        (void)state;
        topic_of(topic, sizeof(topic), "events");
        er = reader(&std_msgs_msg_dds__String__desc, topic, RQ_KEEP_ALL);
        wait_matched(er, false);
        events_handshake(er);
        for (int i = 0; i < 3; i++)
                request("circe arena emulate action E1E1E1 sensor-time=5000");
        assert_true(wait_sample(er, event_seq, &sa));
        assert_false(sa.overrun);
        dds_delete(er);
}

/* Waits until the daemon has written more events after cursor than its ring holds: the first
 * event still there after cursor comes with lost > 0. A request's reply says only that the
 * emulator queued its action; the event is in the ring once the controller has read it off the
 * pty, which may be well after the last reply. T_WAIT_MS without any change is a hang. */
static void wait_events_overrun(uint64_t cursor)
{
        uint32_t change = 0;

        for (;;) {
                struct sl_event ev = { .size = sizeof(ev) };
                uint64_t c = cursor;
                int r = sl_events_read(F->cl, &c, &ev, 1);

                assert_true(r >= 0);
                if (r == 1 && ev.lost > 0)
                        return;
                if (sl_wait(F->cl, &change, T_WAIT_MS) <= 0)
                        fail_msg("the ring never overran (first event after the bridge's "
                                 "stop: %d read, %" PRIu64 " lost)", r, ev.lost);
        }
}

/* A bridge that could not read for a while (stopped) finds more events than the ring holds:
 * one overrun notice, then the events in order. It is let go only once the ring has overrun
 * from where it stopped (else, on a busy machine, it kept up with the rest of the actions as
 * the controller read them and rightly reported no overrun). */
static void test_events_overrun(void **state)
{
        char topic[TOPIC_MAX];
        dds_entity_t er;
        struct seq_arg sa = { 0, 0, 5, false };
        uint64_t stopped_at;
        int st;

        (void)state;
        topic_of(topic, sizeof(topic), "events");
        er = reader(&std_msgs_msg_dds__String__desc, topic, RQ_KEEP_ALL);
        wait_matched(er, false);
        events_handshake(er);
        assert_int_equal(kill(F->r.pid, SIGSTOP), 0);
        /* Stopped for sure: it reads nothing after the head taken next. */
        assert_int_equal(waitpid(F->r.pid, &st, WUNTRACED), F->r.pid);
        assert_true(WIFSTOPPED(st));
        assert_int_equal(sl_events_now(F->cl, &stopped_at), 0);
        for (int i = 0; i < OVERRUN_EVENTS; i++)
                request("circe arena emulate action E1E1E1 sensor-time=100");
        wait_events_overrun(stopped_at);
        assert_int_equal(kill(F->r.pid, SIGCONT), 0);
        assert_true(wait_sample(er, event_seq, &sa));
        assert_true(sa.overrun);
        dds_delete(er);
}

struct fix_arg {
        double lat, lon;
        int status;
        char frame[32];
};

static bool fix_is(const void *s, void *arg)
{
        const sensor_msgs_msg_dds__NavSatFix_ *m = s;
        struct fix_arg *fa = arg;

        if (m->latitude != fa->lat || m->longitude != fa->lon)
                return false;
        fa->status = m->status.status;
        snprintf(fa->frame, sizeof(fa->frame), "%s", m->header.frame_id);
        return m->header.stamp.sec > 0 && isnan(m->altitude) && m->status.service == 1;
}

static void test_navsatfix(void **state)
{
        char topic[TOPIC_MAX];
        dds_entity_t rd;
        struct fix_arg fa = { 47.5, -122.25, -2, "" };

        (void)state;
        topic_of(topic, sizeof(topic), "gps/fix");
        sl_set("a.Lon", "-122.25");
        sl_set("a.Lat", "47.5");
        wait_published("a.Lon");
        wait_published("a.Lat");
        rd = reader(&sensor_msgs_msg_dds__NavSatFix__desc, topic, RQ_TRANSIENT);
        assert_true(wait_sample(rd, fix_is, &fa));
        assert_int_equal(fa.status, 0);                 /* STATUS_FIX */
        assert_string_equal(fa.frame, "gps_link");
        dds_delete(rd);
}

/* The child of test_vanished_reader (this binary again, exec'd: DDS does not survive a fork):
 * a participant and a reader on topic in domain, then '1' on stdout, then it waits to die. */
static int vanishing_reader(const char *domain, const char *topic)
{
        dds_entity_t pp = dds_create_participant((dds_domainid_t)atoi(domain), NULL, NULL);
        dds_entity_t t = dds_create_topic(pp, &std_msgs_msg_dds__Int64__desc, topic, NULL, NULL);
        dds_entity_t rd = dds_create_reader(pp, t, NULL, NULL);
        char one = rd > 0 ? '1' : '0';

        if (write(STDOUT_FILENO, &one, 1) != 1)
                return 1;
        pause();
        return 0;
}

/* A reader in another process that is killed: the bridge goes on publishing to the others. */
static void test_vanished_reader(void **state)
{
        char topic[TOPIC_MAX], domain[16], c = 0;
        int p[2], st;
        pid_t pid;
        dds_entity_t rd;
        int64_t v = 77;

        (void)state;
        topic_of(topic, sizeof(topic), "b/Count");
        snprintf(domain, sizeof(domain), "%u", F->domain);
        assert_int_equal(pipe(p), 0);
        pid = fork();
        assert_true(pid >= 0);
        if (pid == 0) {
                prctl(PR_SET_PDEATHSIG, SIGKILL);       /* never outlives a failed test */
                dup2(p[1], STDOUT_FILENO);
                execl("/proc/self/exe", "test_ros2", VANISH_ARG, domain, topic, (char *)NULL);
                _exit(127);
        }
        close(p[1]);
        assert_int_equal(read(p[0], &c, 1), 1);
        assert_int_equal(c, '1');
        close(p[0]);
        kill(pid, SIGKILL);
        assert_int_equal(waitpid(pid, &st, 0), pid);
        sl_set("a.Count", "77");
        wait_published("a.Count");
        rd = reader(&std_msgs_msg_dds__Int64__desc, topic, RQ_TRANSIENT);
        assert_true(wait_sample(rd, is_long, &v));
        assert_int_equal(kill(F->r.pid, 0), 0);
        dds_delete(rd);
}

/* ---- Fast DDS (the library of rmw_fastrtps_cpp) ------------------------------------------ */

#define FASTDDS_PEER    "build/tests/ros2peer/peer_fastdds"     /* tests/ros2peer/README.md */
#define FASTDDS_XML     "tests/ros2peer/fastdds.xml"            /* loopback unicast only */
#define PEER_OUT_MAX    4096

/* Runs the Fast DDS peer with args (then --domain and --config); its exit status, stdout in out. */
static int fastdds(char *out, const char *const *args)
{
        char domain[16], err[PEER_OUT_MAX];
        const char *argv[24];
        size_t n = 0;

        if (access(FASTDDS_PEER, X_OK) != 0 || access(FASTDDS_XML, R_OK) != 0) {
                print_message("%s not built (no Fast DDS): skipped\n", FASTDDS_PEER);
                skip();
        }
        snprintf(domain, sizeof(domain), "%u", F->domain);
        argv[n++] = FASTDDS_PEER;
        for (; *args && n < 18; args++)
                argv[n++] = *args;
        argv[n++] = "--domain";
        argv[n++] = domain;
        argv[n++] = "--config";
        argv[n++] = FASTDDS_XML;
        argv[n++] = "--timeout-ms";
        argv[n++] = "15000";
        argv[n] = NULL;
        return harness_run_capture(&F->h, out, PEER_OUT_MAX, err, sizeof(err), 2 * T_WAIT_MS,
                                   argv);
}

/* A Fast DDS late joiner gets the value with the bridge's type name, QoS, hash and CDR. */
static void test_fastdds_reader(void **state)
{
        char topic[TOPIC_MAX], out[PEER_OUT_MAX];
        const char *args[] = { "sub", topic, "Float64", "--durability", "transient_local",
                               "--count", "1", NULL };

        (void)state;
        topic_of(topic, sizeof(topic), "b/Lat");
        sl_set("a.Lat", "1.5");
        wait_var("b.Lat", "1.5");
        assert_int_equal(fastdds(out, args), 0);
        if (!strstr(out, "type=std_msgs::msg::dds_::Float64_ reliability=reliable "
                         "durability=transient_local user_data="
                         ROS2_TYPEHASH_USER_DATA(ROS2_TYPEHASH_FLOAT64)) ||
            !strstr(out, "cdr=00010000000000000000f83f value=1.5"))
                fail_msg("Fast DDS saw: %s", out);
}

/* A Fast DDS writer's Int64 and String reach the wire. The peer writes once it has matched the
 * bridge's reader; a volatile reader that matches the writer only after that write never gets
 * it (DDS volatile semantics, docs/ros2.md §4), so a write is repeated by a new peer until it
 * arrives (bounded). */
static void fastdds_write(const char *rel, const char *type, const char *value, const char *var)
{
        char topic[TOPIC_MAX], out[PEER_OUT_MAX];
        const char *args[] = { "pub", topic, type, value, "--durability", "volatile", NULL };

        topic_of(topic, sizeof(topic), rel);
        for (int i = 0; ; i++) {
                assert_true(i < RETRIES);
                assert_int_equal(fastdds(out, args), 0);
                if (var_becomes(var, value, RETRY_MS))
                        return;
        }
}

static void test_fastdds_writer(void **state)
{
        (void)state;
        fastdds_write("set/a/Count", "Int64", "4242", "b.Count");
        fastdds_write("set/a/Name", "String", "fastdds", "b.Name");
}

/* The daemon stops: /diagnostics says STALE; it starts again: values flow again. */
/* Gate passages until the daemon made more changes since cursor than its change record holds
 * (bounded by FLOOD_MAX, not by time). */
static void changes_flood(uint64_t cursor)
{
        for (int n = 1;; n++) {
                char line[128], value[16];

                assert_true(n < FLOOD_MAX);
                snprintf(line, sizeof(line), "circe arena emulate action E1E1E1 sensor-time=%d",
                         n);
                request(line);
                if (n % FLOOD_CHECK)
                        continue;
                snprintf(value, sizeof(value), "%d", n);
                assert_true(var_becomes("agility.device.E1E1E1.sensor_time", value, T_WAIT_MS));
                if (slwait_changes_overrun(F->cl, cursor) == 1)
                        return;
        }
}

static void set_published(const char *value)
{
        sl_set("a.Lat", value);
        wait_published("a.Lat");
}

/*
 * Values changed while the bridge is stopped (SIGSTOP: between two of its wake-ups, its cursor
 * kept): one value, then more changes than the daemon's change record holds, which the bridge
 * learns as an overrun and answers by reading everything once, so the value goes out; then only
 * what changes. Then a daemon restart while it is stopped: what the new daemon has goes out, and
 * what changes after. (The bridge reads everything only when the record says so: not on its
 * tick, so a value missed here would stay missed.)
 */
static void test_values_overrun_restart(void **state)
{
        char topic[TOPIC_MAX];
        dds_entity_t rd;
        uint64_t cursor;
        double v;

        (void)state;
        /* a.Lat: outbound, so its value changes only when written (b.Lat, inbound, is set again
         * at every refresh of the peer, which a bridge would publish whatever it missed). */
        topic_of(topic, sizeof(topic), "a/Lat");
        rd = reader(&std_msgs_msg_dds__Float64__desc, topic, RQ_TRANSIENT);
        set_published("31.5");
        v = 31.5;
        assert_true(wait_sample(rd, is_double, &v));

        assert_int_equal(kill(F->r.pid, SIGSTOP), 0);
        assert_int_equal(slwait_changes_now(F->cl, &cursor), 0);
        set_published("32.5");
        changes_flood(cursor);
        assert_int_equal(kill(F->r.pid, SIGCONT), 0);
        v = 32.5;
        assert_true(wait_sample(rd, is_double, &v));
        set_published("33.5");
        v = 33.5;
        assert_true(wait_sample(rd, is_double, &v));

        assert_int_equal(kill(F->r.pid, SIGSTOP), 0);
        assert_true(WIFEXITED(harness_stop_daemon(&F->h, SIGTERM, T_STOP_MS)));
        start_daemon(F);
        set_published("34.5");
        assert_int_equal(kill(F->r.pid, SIGCONT), 0);
        v = 34.5;
        assert_true(wait_sample(rd, is_double, &v));
        set_published("35.5");
        v = 35.5;
        assert_true(wait_sample(rd, is_double, &v));
        dds_delete(rd);
}

static void test_daemon_restart(void **state)
{
        char topic[TOPIC_MAX];
        dds_entity_t rd;
        double v = 99.5;

        (void)state;
        assert_true(WIFEXITED(harness_stop_daemon(&F->h, SIGTERM, T_STOP_MS)));
        wait_level(F->h.instance, 3);                   /* STALE */
        start_daemon(F);
        topic_of(topic, sizeof(topic), "b/Lat");
        sl_set("a.Lat", "99.5");
        wait_published("a.Lat");
        rd = reader(&std_msgs_msg_dds__Float64__desc, topic, RQ_TRANSIENT);
        assert_true(wait_sample(rd, is_double, &v));
        dds_delete(rd);
}

/* ---- set/ writers that were there before the bridge planned --------------------------------- */

#define LOG_TAIL_MAX    65536   /* bytes of the bridge's log read after a mark */

/* The bridge's log from byte since on (NUL-terminated, cut to size). */
static void log_since(off_t since, char *buf, size_t size)
{
        FILE *f = fopen(F->r.log_path, "r");
        size_t n = 0;

        assert_non_null(f);
        if (fseeko(f, since, SEEK_SET) == 0)
                n = fread(buf, 1, size - 1, f);
        buf[n] = '\0';
        fclose(f);
}

/*
 * Writers on set/ topics that the bridge discovers before it planned any variable (it starts
 * while the daemon is down) are kept until the plan, then judged: one of the right type is not
 * reported (and its writes arrive), one of another type is wrong_type; neither is unknown.
 */
static void test_set_writer_before_plan(void **state)
{
        char topic[TOPIC_MAX], *log = malloc(LOG_TAIL_MAX);
        std_msgs_msg_dds__Float64_ d = { .data = 42.5 };
        struct count_arg waiting = { "set_writers_waiting", 2, F->h.instance };
        struct count_arg refused = { "set_refused", 1, F->h.instance };
        dds_entity_t wl, wc, dr;
        struct stat sb;

        (void)state;
        assert_non_null(log);
        assert_true(WIFEXITED(harness_stop_daemon(&F->r, SIGTERM, T_STOP_MS)));
        assert_true(WIFEXITED(harness_stop_daemon(&F->h, SIGTERM, T_STOP_MS)));
        topic_of(topic, sizeof(topic), "set/a/Lat");
        wl = writer(&std_msgs_msg_dds__Float64__desc, topic);
        topic_of(topic, sizeof(topic), "set/a/Count");
        wc = writer(&std_msgs_msg_dds__String__desc, topic);
        assert_int_equal(stat(F->r.log_path, &sb), 0);
        start_bridge(F);
        /* Both seen, with no plan to judge them by (no daemon yet). */
        dr = reader(&diagnostic_msgs_msg_dds__DiagnosticArray__desc, "rt/diagnostics",
                    RQ_ROS_DEFAULT);
        assert_true(wait_sample(dr, diag_counter, &waiting));
        start_daemon(F);
        write_until(wl, &d, "a.Lat", "42.5");
        assert_true(wait_sample(dr, diag_counter, &refused));
        dds_delete(dr);
        log_since(sb.st_size, log, LOG_TAIL_MAX);
        if (strstr(log, "set : refused") || !strstr(log, "set a.Count: refused: a writer of "
                                                         "another type"))
                fail_msg("the bridge said (log %s from %lld): %s", F->r.log_path,
                         (long long)sb.st_size, log);
        assert_int_equal(diag_value(F->h.instance, "set_refused"), 1);
        assert_int_equal(diag_value(F->h.instance, "set_writers_waiting"), 0);
        dds_delete(wl);
        dds_delete(wc);
        free(log);
}

/* ---- the events' cursor across bridge restarts ------------------------------------------- */

struct ev_track {
        uint64_t next;                  /* the seq expected next (0: any) */
        const char *until;              /* text of the event that ends the wait */
        unsigned events, repeats, notices;
};

/* Events in ring order with no gap, repeats (a seq below the next expected) counted apart;
 * true at the event whose text holds until. */
static bool ev_track(const void *s, void *arg)
{
        const char *d = ((const std_msgs_msg_dds__String_ *)s)->data, *p;
        struct ev_track *t = arg;
        uint64_t seq;

        if (!d || !(p = strstr(d, "\"seq\":")))
                return false;
        seq = strtoull(p + 6, NULL, 10);
        if (strstr(d, "\"type\":\"overrun\"") || strstr(d, "\"type\":\"daemon-restarted\"")) {
                t->notices++;
                return false;
        }
        if (t->next && seq < t->next) {
                t->repeats++;
                return false;
        }
        if (t->next && seq != t->next)
                fail_msg("event %" PRIu64 " after %" PRIu64 ": events lost", seq, t->next - 1);
        t->next = seq + 1;
        t->events++;
        return t->until && strstr(d, t->until);
}

/* A reader that has seen the bridge's events up to a marker of its own (t->next set). */
static dds_entity_t events_reader_synced(struct ev_track *t)
{
        char topic[TOPIC_MAX];
        dds_entity_t er;

        topic_of(topic, sizeof(topic), "events");
        er = reader(&std_msgs_msg_dds__String__desc, topic, RQ_KEEP_ALL);
        wait_matched(er, false);
        events_handshake(er);
        request("circe arena emulate action E1E1E1 sensor-time=6999");
        t->until = "sensor_time=6999";
        assert_true(wait_sample(er, ev_track, t));
        return er;
}

/* The bridge stopped with sig, MISSED events made meanwhile, the bridge started again: what
 * the reader (matched throughout) gets up to the last of them. */
static void events_across_restart(int sig, struct ev_track *t)
{
        dds_entity_t er = events_reader_synced(t);
        char line[128], until[32];
        int st;

        st = harness_stop_daemon(&F->r, sig, T_STOP_MS);
        if (sig == SIGTERM)
                assert_true(WIFEXITED(st) && WEXITSTATUS(st) == 0);
        else
                assert_true(WIFSIGNALED(st));
        for (int i = 1; i <= MISSED; i++) {
                snprintf(line, sizeof(line), "circe arena emulate action E1E1E1 sensor-time=%d",
                         MISSED_BASE + i);
                request(line);
        }
        /* The daemon has them (the last one is in the table) before the bridge is back. */
        snprintf(line, sizeof(line), "%d", MISSED_BASE + MISSED);
        wait_var("agility.device.E1E1E1.sensor_time", line);
        t->events = t->repeats = t->notices = 0;
        snprintf(until, sizeof(until), "sensor_time=%d", MISSED_BASE + MISSED);
        t->until = until;
        start_bridge(F);
        assert_true(wait_sample(er, ev_track, t));
        dds_delete(er);
}

/* SIGTERM: the cursor was stored once the reader acknowledged every event, so the restarted
 * bridge sends exactly the events made while it was down: none twice, none lost. */
static void test_events_cursor_term(void **state)
{
        struct ev_track t = { 0 };

        (void)state;
        events_across_restart(SIGTERM, &t);
        assert_int_equal(t.events, MISSED);
        assert_int_equal(t.repeats, 0);
        assert_int_equal(t.notices, 0);
}

/* SIGKILL: the cursor on disk may trail what went out (repeats), never lead it (a loss would
 * fail ev_track on the gap). */
static void test_events_cursor_kill(void **state)
{
        struct ev_track t = { 0 };

        (void)state;
        events_across_restart(SIGKILL, &t);
        assert_int_equal(t.events, MISSED);
        assert_int_equal(t.notices, 0);
        print_message("SIGKILL: %u events repeated\n", t.repeats);
}

/* ---- -n and a failed start -------------------------------------------------------------------- */

static int run_check(const char *conf, char *err, size_t size)
{
        char out[1024];
        const char *argv[] = { bridge_path(), "-n", "-c", conf, NULL };

        return harness_run_capture(&F->h, out, sizeof(out), err, size, T_WAIT_MS, argv);
}

static void test_check(void **state)
{
        char path[PATH_BUF], err[2048], want[PATH_BUF + 128], text[CONFIG_MAX];

        (void)state;
        /* The running daemon has c.dup-x and c.dup_x: one topic. publish: is on line 7. */
        write_conf(F, "dup.yaml", "publish: [\"*\"]\n", path);
        assert_int_equal(run_check(path, err, sizeof(err)), 1);
        snprintf(want, sizeof(want), "%s:7:10: publish: variable ", path);
        if (!strstr(err, want) || !strstr(err, "dup_x"))
                fail_msg("-n said: %s", err);
        /* Only what is published counts: leaving them out is fine. */
        write_conf(F, "nodup.yaml", "publish: [\"a.*\", \"b.*\"]\n", path);
        assert_int_equal(run_check(path, err, sizeof(err)), 0);
        /* navsatfix naming a variable the daemon does not have: the entry's position. */
        snprintf(text, sizeof(text), "instance: %s\nnavsatfix:\n"
                 "  - {topic: fix, latitude: b.Lat, longitude: b.Nope}\n", F->h.instance);
        assert_int_equal(harness_write_file(&F->r, "nav.yaml", text, path), 0);
        assert_int_equal(run_check(path, err, sizeof(err)), 1);
        snprintf(want, sizeof(want), "%s:3:5: navsatfix: longitude: b.Nope: no such variable",
                 path);
        if (!strstr(err, want))
                fail_msg("-n said: %s", err);
}

/* -n and cursor_file: another program's file and a directory that does not exist are refused;
 * a cursor of the bridge's own (the suite's, by now) and a new file are fine. */
static void test_check_cursor(void **state)
{
        char path[PATH_BUF], err[2048], extra[PATH_BUF * 2], file[PATH_BUF];
        static const struct { const char *content, *name, *want; } cases[] = {
                { "sharedlink-mqtt-cursor 1 1 2 3\n", "mqtt.cursor",
                  "not a sharedlink-ros2 cursor" },
                { NULL, "no/such/dir.cursor", "its directory does not exist" },
                { "sharedlink-ros2-cursor 1 1 2 3\n", "own.cursor", NULL },
                { NULL, "new.cursor", NULL },
        };

        (void)state;
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                snprintf(file, sizeof(file), "%s/%s", F->r.dir, cases[i].name);
                if (cases[i].content)
                        assert_int_equal(harness_write_file(&F->r, cases[i].name,
                                                            cases[i].content, file), 0);
                snprintf(extra, sizeof(extra), "publish: [\"a.*\", \"b.*\"]\ncursor_file: %s\n",
                         file);
                write_conf(F, "cur.yaml", extra, path);
                if (!cases[i].want) {
                        if (run_check(path, err, sizeof(err)) != 0)
                                fail_msg("-n refused %s: %s", file, err);
                        continue;
                }
                assert_int_equal(run_check(path, err, sizeof(err)), 1);
                if (!strstr(err, cases[i].want) || !strstr(err, file))
                        fail_msg("-n said: %s", err);
        }
}

/*
 * One bridge per instance, namespace and DDS domain: a second sharedlink-ros2 on the suite's
 * configuration refuses to start (exit 3) before it joins the domain, naming the first by its
 * pid; the suite's bridge, killed with SIGKILL (no cleanup), gets a successor at once, which
 * publishes again.
 */
static void test_second_bridge(void **state)
{
        const char *argv[] = { bridge_path(), "-c", F->conf, NULL };
        char want[2 * PATH_BUF], why[HARNESS_WHY_MAX], topic[TOPIC_MAX];
        int64_t v = 17;
        dds_entity_t rd;

        (void)state;
        snprintf(want, sizeof(want), "another sharedlink-ros2 (pid %ld) already bridges instance "
                 "%s to namespace %s on DDS domain %u (lock %s/", (long)F->r.pid, F->h.instance,
                 F->ns, F->domain, F->h.dir);
        if (harness_start_refused(&F->h, "ros2two", argv, T_START_MS, 3, want, why,
                                  sizeof(why)) < 0)
                fail_msg("%s", why);

        assert_true(harness_stop_daemon(&F->r, SIGKILL, T_STOP_MS) >= 0);
        start_bridge(F);
        sl_set("a.Count", "17");
        wait_published("a.Count");
        topic_of(topic, sizeof(topic), "a/Count");
        rd = reader(&std_msgs_msg_dds__Int64__desc, topic, RQ_TRANSIENT);
        assert_true(wait_sample(rd, is_long, &v));
        dds_delete(rd);
}

/* A domain that cannot be created (Cyclone refuses the configuration): exit 1, said why. */
static void test_bad_domain(void **state)
{
        char text[CONFIG_MAX], path[PATH_BUF];
        const char *argv[] = { bridge_path(), "-c", path, NULL };
        struct harness *h = &F->r;
        int st = 0;

        (void)state;
        /* Another namespace: the suite's bridge holds the lock of its own (test_second_bridge). */
        snprintf(text, sizeof(text), "instance: %s\ndomain_id: %u\nnamespace: /bad\n"
                 "cyclonedds_uri: '<CycloneDDS><Domain><NoSuchElement/></Domain></CycloneDDS>'\n",
                 F->h.instance, F->domain);
        assert_int_equal(harness_write_file(h, "bad.yaml", text, path), 0);
        {
                struct harness tmp;

                assert_int_equal(harness_init(&tmp, "ros2bad"), 0);
                tmp.capture_log = 1;
                assert_int_equal(harness_start_program(&tmp, &F->h, argv, T_START_MS, &st),
                                 -ECHILD);
                tmp.pid = 0;
                assert_true(WIFEXITED(st));
                assert_int_equal(WEXITSTATUS(st), 1);
                assert_int_equal(harness_log_contains(&tmp, "cannot be created"), 1);
                harness_cleanup(&tmp);
        }
}

int main(int argc, char **argv)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_discovery),
                cmocka_unit_test(test_collision_refused),
                cmocka_unit_test(test_cdr_golden),
                cmocka_unit_test(test_late_joiner_and_profiles),
                cmocka_unit_test(test_writes_reach_the_wire),
                cmocka_unit_test(test_bad_writes),
                cmocka_unit_test(test_flood),
                cmocka_unit_test(test_values_during_flood),
                cmocka_unit_test(test_diagnostics),
                cmocka_unit_test(test_events),
                cmocka_unit_test(test_events_overrun),
                cmocka_unit_test(test_navsatfix),
                cmocka_unit_test(test_vanished_reader),
                cmocka_unit_test(test_check),
                cmocka_unit_test(test_spin_bridge),
                cmocka_unit_test(test_fastdds_reader),
                cmocka_unit_test(test_fastdds_writer),
                cmocka_unit_test(test_values_overrun_restart),
                cmocka_unit_test(test_daemon_restart),
                cmocka_unit_test(test_set_writer_before_plan),
                cmocka_unit_test(test_check_cursor),
                cmocka_unit_test(test_events_cursor_term),
                cmocka_unit_test(test_events_cursor_kill),
                cmocka_unit_test(test_second_bridge),
                cmocka_unit_test(test_bad_domain),
        };

        if (argc == 4 && !strcmp(argv[1], VANISH_ARG))
                return vanishing_reader(argv[2], argv[3]);
        return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
