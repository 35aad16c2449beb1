/*
 * link_circe: the CIRCE engine with real components around it: the event loop, a real shm table
 * (a unique instance per test), real pty pairs, the real control socket, configurations from
 * config_parse() on YAML text. Values and events are checked through the client library
 * (sl_open, sl_read, sl_events_read, sl_link_info).
 *
 * The test plays the other side on the master of a pty pair: the mediator toward our controller,
 * the controller toward our emulator, and finally both engines back to back. Every wait runs the
 * event loop until the awaited thing happened, under a guard timer; nothing asserts wall-clock
 * durations (timers are driven by running the loop, and timing rules are checked as counts and
 * orders of events).
 *
 * Spec sessions ("Example sessions" of the CIRCE specification) are replayed byte for byte, from
 * tests/common/circe_sessions.h (tests/integration/test_circe.c replays them against the real
 * daemon). They use protocol version 1.2.34, so those tests expect "1.2".
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cmocka.h>

#include <sharedlink.h>

#include "common/circe_garbage.h"
#include "common/circe_sessions.h"
#include "common/harness.h"
#include "common/testdata.h"
#include "common/wire.h"
#include "daemon/config.h"
#include "daemon/control.h"
#include "daemon/evloop.h"
#include "daemon/link_circe.h"
#include "svc/log.h"
#include "proto/circe.h"
#include "proto/request.h"
#include "shm/table.h"

#define WAIT_MS         5000    /* guard for one awaited thing */
#define SYNC_WAIT_MS    8000    /* a clock synchronisation that times out takes 3 s */
#define PTYS            2       /* pty pairs a test may use: dev0, dev1 */
#define LINKS_MAX       2
#define RX_MAX          65536
#define REPLY_MAX       8192
#define EVENTS_MAX      512
#define VARS_MAX        1024
#define NAMES_SIZE      65536
#define YAML_MAX        4096

/* ---- fixture --------------------------------------------------------------------------------- */

struct seen_event {
        char type[SL_TYPE_NAME_SIZE];
        char link[SL_LINK_NAME_SIZE];
        char text[SL_EVENT_TEXT_SIZE];
};

struct fx {
        char dir[64];
        char instance[64];
        char sock_path[96];
        char log_path[128];
        int log_fd;
        struct evloop *loop;
        struct evloop_timer guard;
        bool guard_fired;
        struct config *cfg;
        struct shm_table *table;
        void *engine[LINKS_MAX];
        unsigned n_links;
        struct control *ctl;
        struct sl_client *cl;

        /* The test's side of each pty pair. */
        int master[PTYS], slave[PTYS];
        char dev[PTYS][128];
        uint8_t rx[PTYS][RX_MAX];
        size_t rx_len[PTYS];

        /* One control client. */
        int cfd;
        char reply[REPLY_MAX];
        size_t reply_len;
        /* A second one, for a request while the first waits (requests on one connection are
         * answered in order). */
        int cfd2;
        char reply2[REPLY_MAX];
        size_t reply2_len;

        uint64_t ev_cursor;
        struct seen_event events[EVENTS_MAX];
        unsigned n_events;
};

static struct fx *F;

static void on_guard(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        (void)loop;
        (void)timer;
        ((struct fx *)arg)->guard_fired = true;
}

static void on_master(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct fx *f = arg;

        (void)loop;
        (void)revents;
        for (unsigned i = 0; i < PTYS; i++) {
                ssize_t n;

                if (f->master[i] != fd)
                        continue;
                n = read(fd, f->rx[i] + f->rx_len[i], RX_MAX - f->rx_len[i]);
                if (n > 0)
                        f->rx_len[i] += (size_t)n;
        }
}

static void on_reply(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct fx *f = arg;
        char *buf = fd == f->cfd ? f->reply : f->reply2;
        size_t *len = fd == f->cfd ? &f->reply_len : &f->reply2_len;
        ssize_t n;

        (void)loop;
        (void)revents;
        n = read(fd, buf + *len, REPLY_MAX - 1 - *len);
        if (n > 0) {
                *len += (size_t)n;
                buf[*len] = '\0';
        } else if (n == 0) {
                evloop_del_fd(f->loop, fd);
        }
}

/* The core's routing, reduced to what this test needs: "circe LINK ..." to LINK's engine. */
static void on_request(struct control_request *req, int argc, char **argv, void *arg)
{
        struct fx *f = arg;
        struct reqp_request r;
        char err[REQP_ERR_MAX];

        if (argc < 2 || !link_ops_has_word(&link_circe_ops, argv[0])) {
                control_reply_error(req, EINVAL, "test: only circe requests");
                return;
        }
        /* The core's part: the request is decoded whole before the engine sees it. */
        if (reqp_decode(argc, argv, &r, err, sizeof(err)) < 0) {
                control_reply_error(req, EINVAL, "%s", err);
                return;
        }
        for (unsigned i = 0; i < f->n_links; i++)
                if (strcmp(f->cfg->links[i].name, r.link) == 0 && f->engine[i]) {
                        link_circe_ops.command(f->engine[i], req, &r);
                        return;
                }
        control_reply_error(req, ENOENT, "no link %s", r.link);
}

static int setup(void **state)
{
        static unsigned seq;
        struct fx *f = calloc(1, sizeof(*f));

        if (!f)
                return -1;
        snprintf(f->dir, sizeof(f->dir), "/tmp/sltlc.XXXXXX");  /* short: the socket path must fit sun_path */
        if (!mkdtemp(f->dir))
                return -1;
        snprintf(f->instance, sizeof(f->instance), "tlc%d_%u", (int)getpid(), seq++);
        snprintf(f->sock_path, sizeof(f->sock_path), "%s/ctl.sock", f->dir);
        snprintf(f->log_path, sizeof(f->log_path), "%s/daemon.log", f->dir);
        f->log_fd = open(f->log_path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
        if (f->log_fd < 0)
                return -1;
        log_init(0, f->log_fd);
        if (evloop_new(&f->loop) < 0)
                return -1;
        evloop_timer_init(&f->guard, f->loop, on_guard, f);
        f->cfd = -1;
        f->cfd2 = -1;
        for (unsigned i = 0; i < PTYS; i++) {
                char slave_path[128];

                if (harness_openpty(&f->master[i], &f->slave[i], slave_path) < 0)
                        return -1;
                snprintf(f->dev[i], sizeof(f->dev[i]), "%s/dev%u", f->dir, i);
                if (symlink(slave_path, f->dev[i]) < 0)
                        return -1;
                if (evloop_add_fd(f->loop, f->master[i], POLLIN, on_master, f) < 0)
                        return -1;
        }
        if (control_new(f->loop, f->sock_path, 0, 0, on_request, f, &f->ctl) < 0)
                return -1;
        F = f;
        *state = f;
        return 0;
}

static void engines_stop(struct fx *f)
{
        for (unsigned i = 0; i < f->n_links; i++) {
                link_circe_ops.destroy(f->engine[i]);
                f->engine[i] = NULL;
        }
}

static int teardown(void **state)
{
        struct fx *f = *state;
        char cmd[128];

        engines_stop(f);
        sl_close(f->cl);
        for (int *fd = &f->cfd; fd; fd = fd == &f->cfd ? &f->cfd2 : NULL)
                if (*fd >= 0) {
                        evloop_del_fd(f->loop, *fd);
                        close(*fd);
                }
        control_free(f->ctl);
        shm_table_destroy(f->table);
        config_free(f->cfg);
        for (unsigned i = 0; i < PTYS; i++) {
                evloop_del_fd(f->loop, f->master[i]);
                close(f->master[i]);
                close(f->slave[i]);
        }
        evloop_timer_cancel(&f->guard);
        evloop_free(f->loop);
        log_init(0, -1);
        close(f->log_fd);
        snprintf(cmd, sizeof(cmd), "rm -rf '%s'", f->dir);
        free(f);
        F = NULL;
        return system(cmd) == 0 ? 0 : -1;
}

/*
 * Parses tests/data/<file> (where "@DEV0@", "@DEV1@" and "@DIR@" stand for the test's paths),
 * declares every link's variables, creates the table and the engines, opens the client.
 */
static void start(struct fx *f, const char *file)
{
        static struct shm_var vars[VARS_MAX];
        static char names[NAMES_SIZE];
        const char *const subst[] = { "@DEV0@", f->dev[0], "@DEV1@", f->dev[1], "@DIR@", f->dir,
                                      NULL };
        struct shm_link_def defs[LINKS_MAX];
        char yaml[YAML_MAX];
        struct config_error err;
        size_t n = 0, used = 0;
        ssize_t o = testdata_load(file, subst, yaml, sizeof(yaml));

        assert_true(o > 0);
        if (config_parse(yaml, (size_t)o, file, &f->cfg, &err) != 0)
                fail_msg("config: %s", err.message);
        f->n_links = f->cfg->n_links;
        assert_true(f->n_links >= 1 && f->n_links <= LINKS_MAX);
        for (unsigned i = 0; i < f->n_links; i++) {
                assert_int_equal(link_circe_ops.declare(&f->cfg->links[i], i, vars, &n, VARS_MAX,
                                                        names, sizeof(names), &used), 0);
                defs[i] = (struct shm_link_def){ .name = f->cfg->links[i].name,
                                                 .protocol = "circe" };
        }
        struct shm_table_config tc = {
                .instance = f->instance, .vars = vars, .nvars = (uint32_t)n, .links = defs,
                .nlinks = f->n_links, .adhoc_capacity = 2048, .event_capacity = 4096,
        };
        assert_int_equal(shm_table_create(&tc, &f->table), 0);
        for (unsigned i = 0; i < f->n_links; i++) {
                struct link_env env = {
                        .loop = f->loop, .table = f->table, .shm_link = i, .config = f->cfg,
                        .cfg = &f->cfg->links[i],
                };

                assert_int_equal(link_circe_ops.create(&env, &f->engine[i]), 0);
        }
        assert_int_equal(sl_open(f->instance, &f->cl), 0);
}

/* ---- running the loop ------------------------------------------------------------------------ */

typedef bool (*pred_fn)(struct fx *f, const void *arg);

/* Runs the loop until pred holds; false when the guard (ms) fired first. */
static bool run_until(struct fx *f, pred_fn pred, const void *arg, unsigned ms)
{
        f->guard_fired = false;
        evloop_timer_arm(&f->guard, ms, 0);
        while (!pred(f, arg)) {
                if (f->guard_fired)
                        return false;
                assert_int_equal(evloop_run_once(f->loop), 0);
        }
        evloop_timer_cancel(&f->guard);
        return true;
}

static bool never(struct fx *f, const void *arg)
{
        (void)f;
        (void)arg;
        return false;
}

/* Runs the loop for ms (for checking that something does NOT happen). */
static void run_for(struct fx *f, unsigned ms)
{
        assert_false(run_until(f, never, NULL, ms));
}

/* ---- packets --------------------------------------------------------------------------------- */

static void put_raw(struct fx *f, unsigned side, const void *data, size_t len)
{
        assert_int_equal(harness_write_all(f->master[side], data, len, WAIT_MS), 0);
}

/* Sends one packet (with checksum) to the engine on pty side. */
static void put(struct fx *f, unsigned side, const char *body)
{
        uint8_t pkt[CIRCE_PACKET_MAX + 8];

        put_raw(f, side, pkt, wire_circe_str(pkt, sizeof(pkt), body, WIRE_CS_UPPER));
}

static bool has_packet(struct fx *f, const void *arg)
{
        unsigned side = *(const unsigned *)arg;

        return memchr(f->rx[side], CIRCE_ETX, f->rx_len[side]) != NULL;
}

/* Pops the next packet the engine sent on side (noise before STX dropped); its length. */
static size_t next_packet(struct fx *f, unsigned side, uint8_t *out, unsigned ms)
{
        uint8_t *etx, *stx;
        size_t len;

        if (!run_until(f, has_packet, &side, ms))
                return 0;
        etx = memchr(f->rx[side], CIRCE_ETX, f->rx_len[side]);
        len = (size_t)(etx - f->rx[side]) + 1;
        stx = memchr(f->rx[side], CIRCE_STX, len);
        assert_non_null(stx);
        memcpy(out, stx, len - (size_t)(stx - f->rx[side]));
        memmove(f->rx[side], f->rx[side] + len, f->rx_len[side] - len);
        f->rx_len[side] -= len;
        return len - (size_t)(stx - f->rx[side]);
}

/*
 * Expects the next packet on side to be exactly body (+ checksum). With skip_status, Notify
 * Status packets in between are skipped: the emulator's periodic statuses may interleave with
 * an answer, and are checked by the tests that want them.
 */
static void expect_ex(struct fx *f, unsigned side, const char *body, bool skip_status)
{
        uint8_t want[CIRCE_PACKET_MAX + 8], got[CIRCE_PACKET_MAX + 8];
        size_t wn = wire_circe_str(want, sizeof(want), body, WIRE_CS_UPPER), gn;
        char a[2048], b[2048];

        for (;;) {
                gn = next_packet(f, side, got, WAIT_MS);
                wire_circe_show(want, wn, a, sizeof(a));
                if (gn == 0)
                        fail_msg("no packet on dev%u; expected %s", side, a);
                if (skip_status && gn > 3 && memcmp(got + 1, "52\t", 3) == 0 &&
                    !(wn > 3 && memcmp(want + 1, "52\t", 3) == 0 && gn == wn &&
                      memcmp(got, want, gn) == 0))
                        continue;
                break;
        }
        wire_circe_show(got, gn, b, sizeof(b));
        if (gn != wn || memcmp(got, want, wn) != 0)
                fail_msg("dev%u: got %s, expected %s", side, b, a);
}

static void expect(struct fx *f, unsigned side, const char *body)
{
        expect_ex(f, side, body, false);
}

static void expect_skip(struct fx *f, unsigned side, const char *body)
{
        expect_ex(f, side, body, true);
}

/* Decodes the next packet on side (skipping nothing) into res. */
static void next_msg(struct fx *f, unsigned side, struct circe_result *res, uint8_t *buf)
{
        size_t n = next_packet(f, side, buf, WAIT_MS);

        assert_true(n > 0);
        circe_decode(buf, n, res);
        assert_int_equal(res->kind, CIRCE_RESULT_MESSAGE);
}

/* ---- values, events, counters ---------------------------------------------------------------- */

static const char *value(struct fx *f, const char *name)
{
        static char buf[SL_VALUE_SIZE];
        int id = sl_find(f->cl, name);

        if (id < 0)
                return NULL;
        if (sl_read(f->cl, id, buf, sizeof(buf), NULL) < 0)
                return NULL;
        return buf;
}

struct name_value {
        const char *name, *value;
};

static bool value_is(struct fx *f, const void *arg)
{
        const struct name_value *nv = arg;
        const char *v = value(f, nv->name);

        return v && strcmp(v, nv->value) == 0;
}

static void wait_value(struct fx *f, const char *name, const char *want)
{
        struct name_value nv = { name, want };

        if (!run_until(f, value_is, &nv, WAIT_MS))
                fail_msg("%s is \"%s\", expected \"%s\"", name,
                         value(f, name) ? value(f, name) : "(none)", want);
}

static void assert_value(struct fx *f, const char *name, const char *want)
{
        const char *v = value(f, name);

        if (!v || strcmp(v, want) != 0)
                fail_msg("%s is \"%s\", expected \"%s\"", name, v ? v : "(none)", want);
}

static void events_pull(struct fx *f)
{
        struct sl_event ev[16];
        int n;

        for (size_t i = 0; i < 16; i++)
                ev[i].size = sizeof(ev[i]);
        while ((n = sl_events_read(f->cl, &f->ev_cursor, ev, 16)) > 0)
                for (int i = 0; i < n; i++) {
                        struct seen_event *s = &f->events[f->n_events];

                        assert_int_equal(ev[i].lost, 0);
                        assert_true(f->n_events < EVENTS_MAX);
                        snprintf(s->type, sizeof(s->type), "%s", ev[i].type_name);
                        snprintf(s->link, sizeof(s->link), "%s", ev[i].link_name);
                        snprintf(s->text, sizeof(s->text), "%s", ev[i].text);
                        f->n_events++;
                }
}

/* Index of the first event at or after from of that type whose text contains needle; -1. */
static int event_find(struct fx *f, unsigned from, const char *type, const char *needle)
{
        events_pull(f);
        for (unsigned i = from; i < f->n_events; i++)
                if (strcmp(f->events[i].type, type) == 0 && strstr(f->events[i].text, needle))
                        return (int)i;
        return -1;
}

struct event_want {
        unsigned from;
        const char *type, *needle;
};

static bool event_seen(struct fx *f, const void *arg)
{
        const struct event_want *w = arg;

        return event_find(f, w->from, w->type, w->needle) >= 0;
}

/* Waits for the event; returns its index (events are kept in order). */
static unsigned wait_event_from(struct fx *f, unsigned from, const char *type, const char *needle,
                                unsigned ms)
{
        struct event_want w = { from, type, needle };

        if (!run_until(f, event_seen, &w, ms)) {
                for (unsigned i = 0; i < f->n_events; i++)
                        print_message("  event %u: %s %s %s\n", i, f->events[i].link,
                                      f->events[i].type, f->events[i].text);
                fail_msg("no %s event with \"%s\" after #%u", type, needle, from);
        }
        return (unsigned)event_find(f, from, type, needle);
}

static unsigned wait_event(struct fx *f, const char *type, const char *needle)
{
        return wait_event_from(f, 0, type, needle, WAIT_MS);
}

static unsigned count_events(struct fx *f, const char *type, const char *needle)
{
        unsigned n = 0;

        events_pull(f);
        for (unsigned i = 0; i < f->n_events; i++)
                if (strcmp(f->events[i].type, type) == 0 && strstr(f->events[i].text, needle))
                        n++;
        return n;
}

static uint64_t counter(struct fx *f, unsigned link, const char *name)
{
        struct sl_link_info li = { .size = sizeof(li) };

        assert_int_equal(sl_link_info(f->cl, (int)link, &li), 0);
        for (unsigned i = 0; i < li.counter_count; i++)
                if (strcmp(li.counters[i].name, name) == 0)
                        return li.counters[i].value;
        fail_msg("no counter %s", name);
        return 0;
}

static const char *link_state(struct fx *f, unsigned link)
{
        static struct sl_link_info li;

        li.size = sizeof(li);
        assert_int_equal(sl_link_info(f->cl, (int)link, &li), 0);
        return li.state_name;
}

/* ---- control requests ------------------------------------------------------------------------ */

static int control_connect(struct fx *f)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };
        int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);

        assert_true(fd >= 0);
        snprintf(sa.sun_path, sizeof(sa.sun_path), "%s", f->sock_path);
        assert_int_equal(connect(fd, (struct sockaddr *)&sa, sizeof(sa)), 0);
        fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
        assert_int_equal(evloop_add_fd(f->loop, fd, POLLIN, on_reply, f), 0);
        return fd;
}

static void request_send(struct fx *f, int fd, const char *line)
{
        char buf[CTLP_LINE_MAX];
        int n = snprintf(buf, sizeof(buf), "%s\n", line);

        (void)f;
        assert_int_equal(harness_write_all(fd, buf, (size_t)n, WAIT_MS), 0);
}

static void request_start(struct fx *f, const char *line)
{
        if (f->cfd < 0)
                f->cfd = control_connect(f);
        f->reply_len = 0;
        f->reply[0] = '\0';
        request_send(f, f->cfd, line);
}

/* Whether a reply holds its final line (OK or ERR). */
static bool final_line(const char *p)
{
        while (*p) {
                const char *nl = strchr(p, '\n');

                if (!nl)
                        return false;
                if (strncmp(p, "OK", 2) == 0 || strncmp(p, "ERR", 3) == 0)
                        return true;
                p = nl + 1;
        }
        return false;
}

static bool reply_done(struct fx *f, const void *arg)
{
        (void)arg;
        return final_line(f->reply);
}

static bool reply2_done(struct fx *f, const void *arg)
{
        (void)arg;
        return final_line(f->reply2);
}

/* A request on the second connection, answered while the first one still waits. */
static const char *request_other(struct fx *f, const char *line)
{
        if (f->cfd2 < 0)
                f->cfd2 = control_connect(f);
        f->reply2_len = 0;
        f->reply2[0] = '\0';
        request_send(f, f->cfd2, line);
        if (!run_until(f, reply2_done, NULL, WAIT_MS))
                fail_msg("no reply on the second connection; got \"%s\"", f->reply2);
        return f->reply2;
}

static const char *request_wait(struct fx *f, unsigned ms)
{
        if (!run_until(f, reply_done, NULL, ms))
                fail_msg("no reply; got so far: \"%s\"", f->reply);
        return f->reply;
}

static const char *request(struct fx *f, const char *line)
{
        request_start(f, line);
        return request_wait(f, WAIT_MS);
}

/* ---- controller start (configurations in tests/data/link_circe_*.yaml) ---------------------- */

/* Starts a controller and answers its Login on dev0. */
static void ctl_logged_in(struct fx *f, const char *file, const char *keep_alive)
{
        start(f, file);
        expect(f, 0, CIRCE_S_LOGIN);
        wait_value(f, "agility.state", "connecting");
        put(f, 0, keep_alive);
}

/* ---- controller: the spec's example sessions ------------------------------------------------- */

/* "Assigning unique network addresses": an unconfigured mediator gets its address, then a new
 * gate gets one and the time-sensor capability; the session ends with Logout. */
static void test_ctl_example_assigning_addresses(void **state)
{
        struct fx *f = *state;

        ctl_logged_in(f, "link_circe_ctl_spec.yaml", CIRCE_S_KA_UNCONF);
        wait_value(f, "agility.state", "unconfigured");
        assert_string_equal(link_state(f, 0), "unconfigured");
        assert_value(f, "agility.mediator.version", "1.2.34");
        assert_value(f, "agility.mediator.status", "1");
        wait_event(f, "link-state", "state=unconfigured");

        /* Operations work on an unconfigured mediator: that is how it gets configured. */
        assert_string_equal(request(f, "circe agility device-setup 123456"), "OK\n");
        expect(f, 0, CIRCE_S_ASSIGN_MEDIATOR);
        put(f, 0, CIRCE_S_KA);
        wait_value(f, "agility.state", "connected");
        assert_value(f, "agility.mediator.status", "0");

        assert_string_equal(request(f, "circe agility device-setup 222222 - 32"), "OK\n");
        expect(f, 0, CIRCE_S_ASSIGN_GATE);
        put(f, 0, CIRCE_S_ASSIGN_GATE_STATUS);
        wait_value(f, "agility.device.222222.online", "1");
        assert_value(f, "agility.device.222222.membership", "0");
        assert_value(f, "agility.device.222222.capabilities", "32");
        assert_value(f, "agility.device.222222.roles", "0");
        assert_value(f, "agility.device.222222.signal", "150");
        /* Optional parameters never received read as empty values (DESIGN.md 2.8). */
        assert_value(f, "agility.device.222222.battery", "");
        assert_value(f, "agility.device.222222.aligned", "");
        assert_value(f, "agility.device.222222.clock_sync", "");
        assert_value(f, "agility.device.222222.keys", "");
        wait_event(f, "device-online", "device=222222 capabilities=32 roles=0");

        /* Stopping the link ends the session the spec's way. */
        engines_stop(f);
        expect(f, 0, CIRCE_S_LOGOUT);
}

/* "Forming a logical network": devices appear, the controller alerts one and builds the
 * network. */
static void test_ctl_example_forming_network(void **state)
{
        struct fx *f = *state;

        ctl_logged_in(f, "link_circe_ctl_spec.yaml", CIRCE_S_KA);
        wait_value(f, "agility.state", "connected");
        put(f, 0, CIRCE_S_NET_STATUS_AAAAAA);
        put(f, 0, CIRCE_S_NET_STATUS_E1E1E1);
        put(f, 0, CIRCE_S_NET_STATUS_E2E2E2);
        wait_event(f, "device-online", "device=E2E2E2");
        assert_int_equal(count_events(f, "device-online", "device="), 3);
        assert_value(f, "agility.device.AAAAAA.capabilities", "1");
        assert_value(f, "agility.device.AAAAAA.signal", "200");
        assert_value(f, "agility.device.E1E1E1.signal", "150");
        assert_value(f, "agility.device.E2E2E2.signal", "130");

        assert_string_equal(request(f, "circe agility alert E1E1E1"), "OK\n");
        expect(f, 0, CIRCE_S_NET_ALERT_E1E1E1);
        assert_string_equal(request(f, "circe agility network-setup AAAAAA join 1"), "OK\n");
        expect(f, 0, CIRCE_S_NET_JOIN_AAAAAA);
        assert_string_equal(request(f, "circe agility network-setup E1E1E1 join 2"), "OK\n");
        expect(f, 0, CIRCE_S_NET_JOIN_E1E1E1);
        assert_string_equal(request(f, "circe agility network-setup E2E2E2 join 4"), "OK\n");
        expect(f, 0, CIRCE_S_NET_JOIN_E2E2E2);
        assert_int_equal(counter(f, 0, "frames_out"), 5);
}

/* "Synchronizing hardware clocks": a remote and a gate (asking for sync) report 027:2 after
 * Synchronize Clocks; the reply lists both as succeeded. */
static void test_ctl_example_clock_sync(void **state)
{
        struct fx *f = *state;
        const char *r;

        ctl_logged_in(f, "link_circe_ctl_spec.yaml", CIRCE_S_KA);
        put(f, 0, CIRCE_S_SYNC_STATUS_AAAAAA);
        put(f, 0, CIRCE_S_SYNC_STATUS_E1E1E1);
        wait_value(f, "agility.device.E1E1E1.clock_sync", "1");
        request_start(f, "circe agility sync-clocks");
        expect(f, 0, CIRCE_S_SYNC_CLOCKS);
        put(f, 0, CIRCE_S_SYNC_DONE_AAAAAA);
        put(f, 0, CIRCE_S_SYNC_DONE_E1E1E1);
        r = request_wait(f, WAIT_MS);
        assert_string_equal(r, "DATA AAAAAA succeeded\nDATA E1E1E1 succeeded\nOK\n");
        assert_value(f, "agility.device.E1E1E1.clock_sync", "2");
        wait_event(f, "clock-sync", "device=AAAAAA result=succeeded");
        wait_event(f, "clock-sync", "device=E1E1E1 result=succeeded");
}

/* "Race events during a competition run": every Notify Action is an event with the device,
 * keys and sensor time, in order. */
static void test_ctl_example_race(void **state)
{
        struct fx *f = *state;
        unsigned a, b, c, d;

        ctl_logged_in(f, "link_circe_ctl_spec.yaml", CIRCE_S_KA);
        put(f, 0, CIRCE_S_RACE_READY_DOWN);
        put(f, 0, CIRCE_S_RACE_READY_UP);
        put(f, 0, CIRCE_S_RACE_START);
        put(f, 0, CIRCE_S_RACE_FINISH);
        a = wait_event(f, "action", "device=AAAAAA keys=32768");
        b = wait_event(f, "action", "device=AAAAAA keys=0");
        c = wait_event(f, "action", "device=E1E1E1 sensor_time=5000");
        d = wait_event(f, "action", "device=E2E2E2 sensor_time=32000");
        assert_true(a < b && b < c && c < d);
        assert_string_equal(f->events[c].text, "device=E1E1E1 sensor_time=5000");
        assert_string_equal(f->events[c].link, "agility");
        assert_value(f, "agility.device.AAAAAA.keys", "0");
        assert_value(f, "agility.device.E1E1E1.sensor_time", "5000");
        assert_value(f, "agility.device.E2E2E2.sensor_time", "32000");
        /* Seen through actions only: the variables exist, the device is not online. */
        assert_value(f, "agility.device.E2E2E2.online", "0");
        assert_value(f, "agility.device.E2E2E2.signal", "");
}

/* ---- controller: timing and session rules ----------------------------------------------------- */

/* PROTOCOLS.md 2.4: a synchronisation follows the devices online when it starts; 027:2 counts
 * only after a status without it (a device still showing an earlier 027:2 must drop it first);
 * devices that do not make it within 3 s are reported timed-out. */
static void test_ctl_sync_sequence_and_timeout(void **state)
{
        struct fx *f = *state;
        const char *r;

        ctl_logged_in(f, "link_circe_ctl_spec.yaml", CIRCE_S_KA);
        put(f, 0, "52\t015:AAAAAA\t016:1\t019:1\t020:1\t021:200\t");
        put(f, 0, "52\t015:E1E1E1\t016:1\t019:32\t020:2\t021:150\t027:2\t");
        put(f, 0, "52\t015:E2E2E2\t016:1\t019:32\t020:4\t021:150\t027:1\t");
        wait_value(f, "agility.device.E2E2E2.online", "1");
        request_start(f, "circe agility sync-clocks");
        expect(f, 0, CIRCE_S_SYNC_CLOCKS);
        /* PROTOCOLS.md 2.4 sequence: a status without 027, then 027:2. */
        put(f, 0, "52\t015:E2E2E2\t016:1\t019:32\t020:4\t021:150\t");
        put(f, 0, "52\t015:E2E2E2\t016:1\t019:32\t020:4\t021:150\t027:2\t");
        /* Stale 027:2 from an earlier synchronisation: not this one's. */
        put(f, 0, "52\t015:E1E1E1\t016:1\t019:32\t020:2\t021:150\t027:2\t");
        /* AAAAAA says nothing more. A device that appears during the window is not followed. */
        put(f, 0, "52\t015:E3E3E3\t016:1\t019:32\t020:4\t021:150\t027:2\t");
        r = request_wait(f, SYNC_WAIT_MS);
        assert_string_equal(r, "DATA E2E2E2 succeeded\nDATA AAAAAA timed-out\n"
                               "DATA E1E1E1 timed-out\nOK\n");
        /* One at a time. */
        /* Every device went offline during those 3 s: one reports again. */
        put(f, 0, "52\t015:E2E2E2\t016:1\t019:32\t020:4\t021:150\t");
        wait_value(f, "agility.device.E2E2E2.online", "1");
        request_start(f, "circe agility sync-clocks");
        expect(f, 0, CIRCE_S_SYNC_CLOCKS);
        assert_string_equal(request_other(f, "circe agility sync-clocks"),
                            "ERR 16 a clock synchronisation is running on link agility\n");
}

/* No Keep Alive within login_timeout_ms: Logout, next port, Login again. */
static void test_ctl_login_timeout_next_port(void **state)
{
        struct fx *f = *state;
        unsigned i;

        start(f, "link_circe_ctl_fast.yaml");
        expect(f, 0, CIRCE_S_LOGIN);
        expect(f, 0, CIRCE_S_LOGOUT);
        expect(f, 1, CIRCE_S_LOGIN);
        i = wait_event(f, "link-state", "state=disconnected reason=login-timeout");
        wait_event_from(f, i, "link-state", "state=connecting", WAIT_MS);
        assert_int_equal(counter(f, 0, "timeouts"), 1);
        /* Answered in time on the second port: connected there. */
        put(f, 1, CIRCE_S_KA_023);
        wait_value(f, "agility.state", "connected");
        assert_value(f, "agility.mediator.version", "0.2.3");
        assert_int_equal(f->rx_len[0], 0);
}

/* Connected, then nothing valid for idle_timeout_ms (a Log does not count): Logout, close, next
 * port, Login again. Packets that keep arriving keep it alive. */
static void test_ctl_idle_timeout_reconnect(void **state)
{
        struct fx *f = *state;
        unsigned i;

        start(f, "link_circe_ctl_fast.yaml");
        expect(f, 0, CIRCE_S_LOGIN);
        put(f, 0, CIRCE_S_KA_023);
        wait_value(f, "agility.state", "connected");
        i = wait_event(f, "link-state", "state=connected");
        /* Keep it alive for a while with Keep Alives, each answered before the timeout. */
        for (int k = 0; k < 5; k++) {
                run_for(f, 100);
                put(f, 0, CIRCE_S_KA_023);
        }
        assert_int_equal(count_events(f, "link-state", "reason=idle-timeout"), 0);
        assert_int_equal(f->rx_len[0], 0);
        /* Only Logs now: diagnostic, never "alive" (PROTOCOLS.md 2.4). */
        put(f, 0, CIRCE_S_LOG_ALIVE);
        expect(f, 0, CIRCE_S_LOGOUT);
        put(f, 0, CIRCE_S_LOG_ALIVE);
        expect(f, 1, CIRCE_S_LOGIN);
        i = wait_event_from(f, i, "link-state", "state=disconnected reason=idle-timeout", WAIT_MS);
        wait_event_from(f, i, "link-state", "state=connecting", WAIT_MS);
        assert_int_equal(counter(f, 0, "timeouts"), 1);
        assert_true(counter(f, 0, "log_messages") >= 1);
        put(f, 1, CIRCE_S_KA_023);
        wait_value(f, "agility.state", "connected");
}

/* A mediator speaking another major.minor: reported, Logout, next port. */
static void test_ctl_version_mismatch(void **state)
{
        struct fx *f = *state;

        start(f, "link_circe_ctl_fast.yaml");
        expect(f, 0, CIRCE_S_LOGIN);
        put(f, 0, CIRCE_S_KA);
        expect(f, 0, CIRCE_S_LOGOUT);
        wait_event(f, "link-state", "state=version-mismatch version=1.2.34 status=0 expected=0.2");
        assert_value(f, "agility.mediator.version", "1.2.34");
        assert_string_equal(request(f, "circe agility alert E1E1E1"),
                            "ERR 107 link agility is not connected (state version-mismatch)\n");
        expect(f, 1, CIRCE_S_LOGIN);
        /* Patch levels may differ: 0.2.9 is fine for "0.2". */
        put(f, 1, CIRCE_S_KA_029);
        wait_value(f, "agility.state", "connected");
        assert_value(f, "agility.mediator.version", "0.2.9");
}

/* A device is offline when more than 3 s passed since its last status; it comes back with the
 * next one. */
static void test_ctl_device_offline(void **state)
{
        struct fx *f = *state;
        unsigned on, off;

        ctl_logged_in(f, "link_circe_ctl_spec.yaml", CIRCE_S_KA);
        put(f, 0, "52\t015:E1E1E1\t016:1\t019:32\t020:2\t021:150\t022:200\t023:1\t037:0\t");
        on = wait_event(f, "device-online", "device=E1E1E1");
        wait_value(f, "agility.device.E1E1E1.online", "1");
        assert_value(f, "agility.device.E1E1E1.battery", "200");
        assert_value(f, "agility.device.E1E1E1.aligned", "1");
        assert_value(f, "agility.device.E1E1E1.version_mismatch", "0");
        off = wait_event_from(f, on, "device-offline", "device=E1E1E1", WAIT_MS);
        assert_value(f, "agility.device.E1E1E1.online", "0");
        /* The last values stay readable while it is offline. */
        assert_value(f, "agility.device.E1E1E1.signal", "150");
        put(f, 0, "52\t015:E1E1E1\t016:1\t019:32\t020:2\t021:140\t");
        wait_event_from(f, off, "device-online", "device=E1E1E1", WAIT_MS);
        wait_value(f, "agility.device.E1E1E1.signal", "140");
        assert_int_equal(count_events(f, "device-online", "E1E1E1"), 2);
        assert_int_equal(count_events(f, "device-offline", "E1E1E1"), 1);
}

/* Bad input of every kind between valid packets: each dropped or skipped as PROTOCOLS.md 2.3
 * says, counted by reason, and the valid packets around it all land. */
static void test_ctl_bad_input(void **state)
{
        struct fx *f = *state;
        uint8_t pkt[CIRCE_PACKET_MAX * 2];

        ctl_logged_in(f, "link_circe_ctl_spec.yaml", CIRCE_S_KA);
        wait_value(f, "agility.state", "connected");

        for (unsigned k = 0; k < CIRCE_GARBAGE_STEPS; k++)
                put_raw(f, 0, pkt, circe_garbage_bytes(k, pkt, sizeof(pkt)));

        wait_value(f, "agility.device.A00008.online", "1");
        for (unsigned k = 1; k <= 6; k++) {
                char needle[32];

                snprintf(needle, sizeof(needle), "device=A0000%u", k);
                assert_true(event_find(f, 0, "action", needle) >= 0);
        }
        assert_true(event_find(f, 0, "action", "device=A0000A sensor_time=3") >= 0);
        assert_true(event_find(f, 0, "action", "device=A0000B sensor_time=4") >= 0);
        assert_true(event_find(f, 0, "action", "device=A00003 sensor_time=7") >= 0);
        assert_true(event_find(f, 0, "action", "device=A00004 sensor_time=9") >= 0);
        assert_int_equal(event_find(f, 0, "action", "device=B"), -1);
        assert_int_equal(event_find(f, 0, "device-online", "device=C"), -1);
        assert_int_equal(event_find(f, 0, "device-online", "device=000000"), -1);
        assert_int_equal(event_find(f, 0, "device-online", "device=A00007"), -1);
        assert_null(value(f, "agility.device.C00001.online"));

        for (unsigned k = 0; k < CIRCE_GARBAGE_COUNTERS; k++) {
                const struct circe_garbage_count *c = &circe_garbage_counts[k];

                if (counter(f, 0, c->counter) != c->value)
                        fail_msg("%s: %llu, expected %llu", c->counter,
                                 (unsigned long long)counter(f, 0, c->counter),
                                 (unsigned long long)c->value);
        }
}

/* Log (54): the daemon's log (rate-limited) and an event; counted. */
static void test_ctl_log(void **state)
{
        struct fx *f = *state;
        char text[4096];
        ssize_t n;
        int fd;

        ctl_logged_in(f, "link_circe_ctl_spec.yaml", CIRCE_S_KA);
        put(f, 0, "54\t036:48656C6C6F0A\t");
        wait_event(f, "log", "bytes=6 data=48656C6C6F0A");
        for (int k = 0; k < 30; k++)
                put(f, 0, "54\t036:4E4F495359\t");
        wait_value(f, "agility.state", "connected");
        run_until(f, never, NULL, 200);
        assert_int_equal(counter(f, 0, "log_messages"), 31);
        assert_int_equal(count_events(f, "log", "data=4E4F495359"), 30);
        fd = open(f->log_path, O_RDONLY | O_CLOEXEC);
        assert_true(fd >= 0);
        n = read(fd, text, sizeof(text) - 1);
        close(fd);
        assert_true(n > 0);
        text[n] = '\0';
        assert_non_null(strstr(text, "link agility: mediator log: Hello\\x0A"));
        /* Rate-limited: far fewer than 31 lines of it. */
        unsigned lines = 0;

        for (char *p = text; (p = strstr(p, "mediator log: NOISY")); p++)
                lines++;
        assert_true(lines >= 1 && lines < 30);
}

/* Commands: validated before anything is sent, refused while disconnected unless they wait,
 * and the wrong role's commands refused. */
static void test_ctl_commands(void **state)
{
        struct fx *f = *state;

        start(f, "link_circe_ctl_spec.yaml");
        expect(f, 0, CIRCE_S_LOGIN);
        assert_string_equal(request(f, "circe agility alert E1E1E1"),
                            "ERR 107 link agility is not connected (state connecting)\n");
        assert_string_equal(request(f, "circe agility alert E1E1E1 wait=100"),
                            "ERR 110 link agility not connected within 100 ms (state connecting)\n");
        assert_string_equal(request(f, "circe agility alert XYZ"),
                            "ERR 22 bad address \"XYZ\": six uppercase hex digits expected\n");
        assert_string_equal(request(f, "circe agility emulate action E1E1E1"),
                            "ERR 95 link agility is a controller: emulate action is for mediator "
                            "emulator links\n");
        /* A waiting request goes out as soon as the mediator answers. */
        request_start(f, "circe agility visualize D15D15 current=7 wait=5000");
        run_for(f, 50);
        assert_int_equal(f->reply_len, 0);
        put(f, 0, CIRCE_S_KA);
        assert_string_equal(request_wait(f, WAIT_MS), "OK\n");
        expect(f, 0, "07\t028:7\t014:D15D15\t");
        /* Nothing was sent for the refused ones. */
        assert_int_equal(f->rx_len[0], 0);
        assert_int_equal(counter(f, 0, "frames_out"), 2);
}

/* ---- emulator: the spec's sessions from the other side ----------------------------------------- */

static void test_emu_example_assigning_addresses(void **state)
{
        struct fx *f = *state;

        start(f, "link_circe_emu_assign.yaml");
        wait_value(f, "arena.state", "connecting");
        assert_value(f, "arena.mediator.status", "1");
        assert_value(f, "arena.mediator.address", "");
        put(f, 0, CIRCE_S_LOGIN);
        expect(f, 0, CIRCE_S_KA_UNCONF);
        wait_value(f, "arena.state", "unconfigured");
        put(f, 0, CIRCE_S_ASSIGN_MEDIATOR);
        expect(f, 0, CIRCE_S_KA);
        wait_value(f, "arena.mediator.address", "123456");
        assert_value(f, "arena.mediator.status", "0");
        wait_value(f, "arena.state", "connected");
        put(f, 0, CIRCE_S_ASSIGN_GATE);
        expect(f, 0, CIRCE_S_ASSIGN_GATE_STATUS);
        wait_value(f, "arena.device.222222.capabilities", "32");
        assert_value(f, "arena.device.222222.online", "1");
        assert_value(f, "arena.device.000000.online", "0");
        put(f, 0, CIRCE_S_LOGOUT);
        wait_value(f, "arena.state", "connecting");
        /* After Logout the mediator says nothing until the next Login (status period passes). */
        f->rx_len[0] = 0;
        run_for(f, 1500);
        assert_int_equal(f->rx_len[0], 0);
}

static void test_emu_example_forming_network(void **state)
{
        struct fx *f = *state;

        start(f, "link_circe_emu_network.yaml");
        put(f, 0, CIRCE_S_LOGIN);
        expect(f, 0, CIRCE_S_KA);
        expect(f, 0, CIRCE_S_NET_STATUS_AAAAAA);
        expect(f, 0, CIRCE_S_NET_STATUS_E1E1E1);
        expect(f, 0, CIRCE_S_NET_STATUS_E2E2E2);
        put(f, 0, CIRCE_S_NET_ALERT_E1E1E1);
        wait_value(f, "arena.device.E1E1E1.alerts", "1");
        put(f, 0, CIRCE_S_NET_JOIN_AAAAAA);
        put(f, 0, CIRCE_S_NET_JOIN_E1E1E1);
        put(f, 0, CIRCE_S_NET_JOIN_E2E2E2);
        wait_value(f, "arena.device.E2E2E2.roles", "4");
        assert_value(f, "arena.device.E2E2E2.membership", "1");
        assert_value(f, "arena.device.AAAAAA.roles", "1");
        /* Members that joined need their clocks synchronised: 027:1 in the next statuses. */
        assert_value(f, "arena.device.E1E1E1.clock_sync", "1");
        expect(f, 0, "52\t015:AAAAAA\t016:1\t019:1\t020:1\t021:200\t027:1\t");
        expect(f, 0, "52\t015:E1E1E1\t016:1\t019:32\t020:2\t021:150\t027:1\t");
        expect(f, 0, "52\t015:E2E2E2\t016:1\t019:32\t020:4\t021:130\t027:1\t");
        /* Leaving keeps the roles (the spec: a leave must not alter another network). */
        put(f, 0, "04\t014:E2E2E2\t017:0\t020:0\t");
        wait_value(f, "arena.device.E2E2E2.membership", "0");
        assert_value(f, "arena.device.E2E2E2.roles", "4");
        /* Unknown destinations change nothing. */
        put(f, 0, "03\t014:999999\t");
        run_for(f, 50);
        assert_null(value(f, "arena.device.999999.alerts"));
}

/* The spec's gate asks for sync while a member (our model: members power up needing sync). */
static void test_emu_example_clock_sync(void **state)
{
        struct fx *f = *state;

        start(f, "link_circe_emu_sync.yaml");
        put(f, 0, CIRCE_S_LOGIN);
        expect(f, 0, CIRCE_S_KA);
        expect(f, 0, CIRCE_S_SYNC_STATUS_AAAAAA);
        expect(f, 0, "52\t015:E1E1E1\t016:1\t019:32\t020:4\t021:150\t027:1\t");
        put(f, 0, CIRCE_S_SYNC_CLOCKS);
        /* PROTOCOLS.md 2.4: one status without 027 at once, then 027:2. */
        expect(f, 0, CIRCE_S_SYNC_STATUS_AAAAAA);
        expect(f, 0, "52\t015:E1E1E1\t016:1\t019:32\t020:4\t021:150\t");
        expect(f, 0, CIRCE_S_SYNC_DONE_AAAAAA);
        expect(f, 0, "52\t015:E1E1E1\t016:1\t019:32\t020:4\t021:150\t027:2\t");
        assert_value(f, "arena.device.E1E1E1.clock_sync", "2");
}

static void test_emu_example_race(void **state)
{
        struct fx *f = *state;
        struct circe_result res;
        uint8_t buf[CIRCE_PACKET_MAX];

        start(f, "link_circe_emu_race.yaml");
        assert_string_equal(request(f, "circe arena emulate action AAAAAA keys=32768"),
                            "ERR 107 link arena is not connected (state connecting)\n");
        put(f, 0, CIRCE_S_LOGIN);
        expect(f, 0, CIRCE_S_KA);
        assert_string_equal(request(f, "circe arena emulate action AAAAAA keys=32768"), "OK\n");
        expect_skip(f, 0, CIRCE_S_RACE_READY_DOWN);
        assert_string_equal(request(f, "circe arena emulate action AAAAAA keys=0"), "OK\n");
        expect_skip(f, 0, CIRCE_S_RACE_READY_UP);
        assert_string_equal(request(f, "circe arena emulate action E1E1E1 sensor-time=5000"),
                            "OK\n");
        expect_skip(f, 0, CIRCE_S_RACE_START);
        assert_string_equal(request(f, "circe arena emulate action E2E2E2 sensor-time=32000"),
                            "OK\n");
        expect_skip(f, 0, CIRCE_S_RACE_FINISH);
        wait_value(f, "arena.device.E2E2E2.sensor_time", "32000");
        assert_value(f, "arena.device.AAAAAA.keys", "0");

        /* A gate passage with no time given carries the gate's own clock. */
        assert_string_equal(request(f, "circe arena emulate action E1E1E1"), "OK\n");
        do
                next_msg(f, 0, &res, buf);
        while (res.msg.op == CIRCE_OP_NOTIFY_STATUS);
        assert_int_equal(res.msg.op, CIRCE_OP_NOTIFY_ACTION);
        assert_int_equal(res.msg.u.notify_action.origin, 0xE1E1E1);
        assert_true(res.msg.u.notify_action.has_sensor_time);
        assert_false(res.msg.u.notify_action.has_keys);
        /* A remote with a start sensor pressing Pass Start reports a time too; Ready does not. */
        assert_string_equal(request(f, "circe arena emulate action AAAAAA keys=8192"), "OK\n");
        do
                next_msg(f, 0, &res, buf);
        while (res.msg.op == CIRCE_OP_NOTIFY_STATUS);
        assert_true(res.msg.u.notify_action.has_keys && res.msg.u.notify_action.keys == 8192);
        assert_true(res.msg.u.notify_action.has_sensor_time);

        assert_string_equal(request(f, "circe arena emulate action 123123"),
                            "ERR 2 link arena emulates no device 123123\n");
        assert_string_equal(request(f, "circe arena alert E1E1E1"),
                            "ERR 95 link arena is a mediator emulator: alert is for controller "
                            "links\n");
}

/* Visualize: the emulated display's state in the table, fields in precedence order. */
static void test_emu_visualize(void **state)
{
        struct fx *f = *state;

        start(f, "link_circe_emu_race.yaml");
        put(f, 0, CIRCE_S_LOGIN);
        expect(f, 0, CIRCE_S_KA);
        assert_value(f, "arena.device.D15D15.current_competitor", "");
        assert_null(value(f, "arena.device.E1E1E1.current_competitor"));
        put(f, 0, "07\t034:0\t028:12\t029:13\t030:1\t014:D15D15\t");
        wait_value(f, "arena.device.D15D15.current_competitor", "12");
        assert_value(f, "arena.device.D15D15.next_competitor", "13");
        assert_value(f, "arena.device.D15D15.timer_running", "1");
        assert_value(f, "arena.device.D15D15.primary_time", "0");
        assert_value(f, "arena.device.D15D15.eliminated", "0");
        assert_value(f, "arena.device.D15D15.faults", "");
        put(f, 0, "07\t031:31250\t038:999999\t032:1\t033:2\t035:3\t034:1\t014:D15D15\t"
                  "014:E1E1E1\t");
        wait_value(f, "arena.device.D15D15.primary_time", "31250");
        assert_value(f, "arena.device.D15D15.timer_running", "0");
        assert_value(f, "arena.device.D15D15.secondary_time", "999999");
        assert_value(f, "arena.device.D15D15.faults", "1");
        assert_value(f, "arena.device.D15D15.refusals", "2");
        assert_value(f, "arena.device.D15D15.placement", "3");
        assert_value(f, "arena.device.D15D15.eliminated", "1");
        assert_value(f, "arena.device.D15D15.current_competitor", "12");
}

/* Keep Alive: answers Login, then whenever nothing was sent for keepalive_ms; silent before
 * Login. Checked as counts of packets, never as durations. */
static void test_emu_keepalive(void **state)
{
        struct fx *f = *state;
        uint8_t want[64], got[64];
        size_t wn;

        start(f, "link_circe_emu_keepalive.yaml");
        run_for(f, 300);
        assert_int_equal(f->rx_len[0], 0);
        put(f, 0, CIRCE_S_LOGIN);
        wn = wire_circe_str(want, sizeof(want), CIRCE_S_KA_023, WIRE_CS_NONE);
        for (int k = 0; k < 6; k++) {
                size_t gn = next_packet(f, 0, got, WAIT_MS);

                assert_int_equal(gn, wn);
                assert_memory_equal(got, want, wn);
        }
        put(f, 0, CIRCE_S_LOGOUT);
        wait_value(f, "arena.state", "connecting");
        assert_true(counter(f, 0, "frames_out") >= 6);
}

/* With a device, statuses go every second; with keepalive_ms above a second no Keep Alive is
 * ever needed after the one that answers Login. */
static void test_emu_status_period(void **state)
{
        struct fx *f = *state;

        start(f, "link_circe_emu_status_period.yaml");
        put(f, 0, CIRCE_S_LOGIN);
        expect(f, 0, CIRCE_S_KA_023);
        for (int k = 0; k < 3; k++)
                expect(f, 0, "52\t015:E1E1E1\t016:0\t019:32\t020:0\t021:150\t022:200\t");
}

/* Garbage from the controller side is counted and never disturbs valid packets. */
static void test_emu_bad_input(void **state)
{
        struct fx *f = *state;

        start(f, "link_circe_emu_network.yaml");
        put_raw(f, 0, "\x03noise\x02" "01\tZZ\x03", 13);
        put(f, 0, CIRCE_S_KA_023);            /* a mediator operation */
        put(f, 0, "04\t014:AAAAAA\t017:1\t");           /* 020 missing */
        put(f, 0, CIRCE_S_NET_ALERT_E1E1E1);                  /* before Login: ignored */
        put(f, 0, CIRCE_S_LOGIN);
        expect_skip(f, 0, CIRCE_S_KA);
        put(f, 0, CIRCE_S_NET_ALERT_E1E1E1);
        wait_value(f, "arena.device.E1E1E1.alerts", "1");
        assert_int_equal(counter(f, 0, "noise_bytes"), 6);
        assert_int_equal(counter(f, 0, "bad_checksum"), 1);
        assert_int_equal(counter(f, 0, "unknown_op"), 1);
        assert_int_equal(counter(f, 0, "missing_param"), 1);
}

/* ---- both engines back to back over one pty (the `make demo` pair) --------------------------- */

static void test_back_to_back(void **state)
{
        struct fx *f = *state;
        const char *r;
        unsigned i;

        start(f, "link_circe_pair.yaml");
        wait_value(f, "agility.state", "connected");
        assert_value(f, "arena.state", "connected");
        assert_value(f, "agility.mediator.version", "0.2.3");
        wait_value(f, "agility.device.D15D15.online", "1");
        assert_value(f, "agility.device.E1E1E1.battery", "200");
        assert_value(f, "agility.device.AAAAAA.capabilities", "31");

        assert_string_equal(request(f, "circe arena emulate action E1E1E1 sensor-time=5000"),
                            "OK\n");
        i = wait_event(f, "action", "device=E1E1E1 sensor_time=5000");
        assert_string_equal(f->events[i].link, "agility");
        assert_value(f, "agility.device.E1E1E1.sensor_time", "5000");

        assert_string_equal(request(f, "circe agility visualize D15D15 current=42 start-timer"),
                            "OK\n");
        wait_value(f, "arena.device.D15D15.current_competitor", "42");
        assert_value(f, "arena.device.D15D15.timer_running", "1");

        assert_string_equal(request(f, "circe agility network-setup E1E1E1 join 2"), "OK\n");
        wait_value(f, "agility.device.E1E1E1.clock_sync", "1");
        assert_value(f, "agility.device.E1E1E1.roles", "2");
        request_start(f, "circe agility sync-clocks");
        r = request_wait(f, SYNC_WAIT_MS);
        assert_non_null(strstr(r, "DATA E1E1E1 succeeded\n"));
        assert_non_null(strstr(r, "DATA AAAAAA succeeded\n"));
        assert_non_null(strstr(r, "DATA D15D15 succeeded\n"));
        assert_non_null(strstr(r, "\nOK\n"));
        wait_value(f, "agility.device.E1E1E1.clock_sync", "2");
        assert_int_equal(counter(f, 1, "bad_checksum"), 0);
        assert_int_equal(counter(f, 0, "bad_checksum"), 0);
        assert_string_equal(link_state(f, 1), "connected");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_ctl_example_assigning_addresses, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_ctl_example_forming_network, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_ctl_example_clock_sync, setup, teardown),
                cmocka_unit_test_setup_teardown(test_ctl_example_race, setup, teardown),
                cmocka_unit_test_setup_teardown(test_ctl_sync_sequence_and_timeout, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_ctl_login_timeout_next_port, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_ctl_idle_timeout_reconnect, setup, teardown),
                cmocka_unit_test_setup_teardown(test_ctl_version_mismatch, setup, teardown),
                cmocka_unit_test_setup_teardown(test_ctl_device_offline, setup, teardown),
                cmocka_unit_test_setup_teardown(test_ctl_bad_input, setup, teardown),
                cmocka_unit_test_setup_teardown(test_ctl_log, setup, teardown),
                cmocka_unit_test_setup_teardown(test_ctl_commands, setup, teardown),
                cmocka_unit_test_setup_teardown(test_emu_example_assigning_addresses, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_emu_example_forming_network, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_emu_example_clock_sync, setup, teardown),
                cmocka_unit_test_setup_teardown(test_emu_example_race, setup, teardown),
                cmocka_unit_test_setup_teardown(test_emu_visualize, setup, teardown),
                cmocka_unit_test_setup_teardown(test_emu_keepalive, setup, teardown),
                cmocka_unit_test_setup_teardown(test_emu_status_period, setup, teardown),
                cmocka_unit_test_setup_teardown(test_emu_bad_input, setup, teardown),
                cmocka_unit_test_setup_teardown(test_back_to_back, setup, teardown),
        };

        return cmocka_run_group_tests_name("link_circe", tests, NULL, NULL);
}
