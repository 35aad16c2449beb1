/*
 * link_sharedlink: the SharedLink engine with real components only. A real event loop, a real
 * shm table (unique instance per test), configs parsed by config_parse() from the YAML below, and
 * the engine over a `serial` transport on a real pty pair: the test holds the master and plays
 * the peer (or a loopback UDP socket for `udp`). Values are checked through the real client
 * library (sl_open/sl_read on the same instance); every frame the engine sends is decoded with
 * the codec, so a frame with a bad grammar or checksum fails the test.
 *
 * The test does what the daemon core does for client writes: it watches the table's wake fd,
 * runs shm_table_out_scan() and hands each change to the owning engine's ops->outbound().
 *
 * No timed assertions: the loop is stepped until an awaited event (a frame, a value, a state),
 * with a guard timer that fails the test instead of hanging it. Periods are counted as timer
 * fires of the loop, never as wall time. A ping "P<n>" answered by "G<n>" marks the point where
 * the engine has processed everything sent before it.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cmocka.h>
#include <sharedlink.h>

#include "common/harness.h"
#include "common/testdata.h"
#include "common/wire.h"
#include "daemon/config.h"
#include "daemon/control.h"
#include "svc/evloop.h"
#include "daemon/link.h"
#include "daemon/link_sharedlink.h"
#include "proto/request.h"
#include "proto/sharedlink.h"
#include "shm/table.h"

#define WAIT_MS         20000           /* guard: an awaited event that never comes fails */
#define LINKS_MAX       3
#define VARS_MAX        (CONFIG_VARS_MAX)
#define RX_MAX          4096            /* frames kept per peer end */
#define TEXT_MAX        (SLP_FRAME_MAX + 16)
#define YAML_MAX        8192
#define READ_CHUNK      65536
#define EVENTS_MAX      64

struct fx;

struct rx_frame {
        char text[TEXT_MAX];            /* '[' through ']', NUL-terminated */
        size_t len;
};

/* The test's side of one link: a pty master or a UDP socket. */
struct peer_end {
        struct fx *fx;
        int fd;                         /* -1: none */
        int slave;                      /* our own slave fd (pty), kept open: no hang-up */
        bool datagram;
        char pts[HARNESS_PATH_MAX];
        uint16_t port;                  /* udp: our port */
        struct sockaddr_in engine;      /* udp: where the engine's datagrams come from */
        bool engine_known;
        struct slp_decoder dec;
        struct rx_frame *rx;
        size_t nrx;
        uint64_t rx_bytes;              /* bytes read */
        uint64_t rx_frame_bytes;        /* bytes of the frames in them */
        uint64_t datagrams;
        uint8_t *tx;
        size_t tx_len, tx_off, tx_cap;
};

struct fx {
        struct evloop *loop;
        struct config *cfg;
        struct shm_table *table;
        struct sl_client *client;
        char dir[64];
        char instance[48];
        unsigned nlinks;
        void *engines[LINKS_MAX];
        struct peer_end peers[LINKS_MAX];
        uint32_t var_link[VARS_MAX];
        uint32_t nvars;
        uint32_t adhoc_capacity;
        uint32_t out_spare;             /* .out slots for learned outbound lists */
        int wake_fd;
        struct evloop_timer guard;
        bool guard_fired;
        unsigned dispatched;            /* outbound() calls made */
        uint64_t frames_out_at_dispatch;        /* FRAMES_OUT of link 0 at the last one */
        struct control *ctl;            /* the real control socket, routing like the core */
        char sock[HARNESS_PATH_MAX];
        unsigned ping;                  /* sync counter */
};

static const struct link_ops *ops = &link_sharedlink_ops;

/* ---------------------------------------------------------------------------------------------
 * Peer ends */

static void peer_record(struct peer_end *pe, const struct slp_frame *f)
{
        struct rx_frame *r;

        if (pe->nrx >= RX_MAX)
                fail_msg("more than %d frames from the engine", RX_MAX);
        r = &pe->rx[pe->nrx++];
        assert_true(f->raw_len < sizeof(r->text));
        memcpy(r->text, f->raw, f->raw_len);
        r->text[f->raw_len] = '\0';
        r->len = f->raw_len;
        pe->rx_frame_bytes += f->raw_len;
}

static void peer_feed(struct peer_end *pe, const uint8_t *p, size_t n)
{
        struct slp_decode_result r;

        while (n > 0) {
                size_t used = slp_decoder_feed(&pe->dec, p, n, &r);

                p += used;
                n -= used;
                if (r.kind == SLP_RESULT_FRAME)
                        peer_record(pe, r.frame);
                else if (r.kind == SLP_RESULT_REJECT)
                        fail_msg("the engine sent bytes the codec rejects: %s (%zu bytes)",
                                 slp_decode_reason_str(r.reason), r.bytes);
        }
        if (pe->datagram && slp_decoder_end(&pe->dec, &r))
                fail_msg("datagram from the engine with a partial frame or noise: %s",
                         slp_decode_reason_str(r.reason));
}

static void peer_events(struct peer_end *pe)
{
        unsigned ev = POLLIN | (pe->tx_len > pe->tx_off ? POLLOUT : 0);

        evloop_mod_fd(pe->fx->loop, pe->fd, ev);
}

static void peer_flush(struct peer_end *pe)
{
        while (pe->tx_off < pe->tx_len) {
                ssize_t n = write(pe->fd, pe->tx + pe->tx_off, pe->tx_len - pe->tx_off);

                if (n < 0 && (errno == EAGAIN || errno == EINTR))
                        break;
                assert_true(n > 0);
                pe->tx_off += (size_t)n;
        }
        if (pe->tx_off == pe->tx_len)
                pe->tx_off = pe->tx_len = 0;
        peer_events(pe);
}

static void peer_read(struct peer_end *pe)
{
        static uint8_t buf[READ_CHUNK];

        for (;;) {
                struct sockaddr_in from;
                socklen_t flen = sizeof(from);
                ssize_t n;

                if (pe->datagram)
                        n = recvfrom(pe->fd, buf, sizeof(buf), 0, (struct sockaddr *)&from, &flen);
                else
                        n = read(pe->fd, buf, sizeof(buf));
                if (n < 0 && (errno == EAGAIN || errno == EINTR))
                        return;
                if (n < 0 && errno == EIO) {
                        /* Master of a pty whose slaves are all closed: stop polling it. */
                        evloop_mod_fd(pe->fx->loop, pe->fd, 0);
                        return;
                }
                assert_true(n >= 0);
                if (pe->datagram) {
                        pe->engine = from;
                        pe->engine_known = true;
                        pe->datagrams++;
                } else if (n == 0) {
                        return;
                }
                pe->rx_bytes += (uint64_t)n;
                peer_feed(pe, buf, (size_t)n);
        }
}

static void peer_on_io(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct peer_end *pe = arg;

        (void)loop;
        (void)fd;
        if (revents & POLLOUT)
                peer_flush(pe);
        if (revents & (POLLIN | POLLHUP | POLLERR))
                peer_read(pe);
}

/* Queues bytes to the engine (one datagram per call for udp). */
static void peer_send(struct peer_end *pe, const void *data, size_t len)
{
        if (pe->datagram) {
                assert_true(pe->engine_known);
                assert_int_equal(sendto(pe->fd, data, len, 0, (const struct sockaddr *)&pe->engine,
                                        sizeof(pe->engine)), (ssize_t)len);
                return;
        }
        if (pe->tx_len + len > pe->tx_cap) {
                size_t cap = pe->tx_cap ? pe->tx_cap : 4096;

                while (cap < pe->tx_len + len)
                        cap *= 2;
                pe->tx = realloc(pe->tx, cap);
                assert_non_null(pe->tx);
                pe->tx_cap = cap;
        }
        memcpy(pe->tx + pe->tx_len, data, len);
        pe->tx_len += len;
        peer_flush(pe);
}

static void peer_send_str(struct peer_end *pe, const char *s)
{
        peer_send(pe, s, strlen(s));
}

/* Sends one frame "[" text "|Chh]" (with CR LF on a byte stream). */
static void peer_frame(struct peer_end *pe, const char *text)
{
        char buf[TEXT_MAX];
        size_t n = wire_slp_raw(buf, sizeof(buf), text, !pe->datagram);

        peer_send(pe, buf, n);
}

static void peer_init(struct fx *fx, unsigned i)
{
        struct peer_end *pe = &fx->peers[i];

        pe->fx = fx;
        pe->rx = calloc(RX_MAX, sizeof(*pe->rx));
        assert_non_null(pe->rx);
        assert_int_equal(slp_decoder_init(&pe->dec, SLP_FRAME_MAX), 0);
}

static void device_path(const struct fx *fx, unsigned i, char *buf, size_t size)
{
        snprintf(buf, size, "%s/tty%u", fx->dir, i);
}

/* Points <dir>/tty<i> at target, atomically. */
static void repoint(struct fx *fx, unsigned i, const char *target)
{
        char dev[HARNESS_PATH_MAX], tmp[HARNESS_PATH_MAX + 8];

        device_path(fx, i, dev, sizeof(dev));
        snprintf(tmp, sizeof(tmp), "%s.new", dev);
        unlink(tmp);
        assert_int_equal(symlink(target, tmp), 0);
        assert_int_equal(rename(tmp, dev), 0);
}

/* A new pty pair behind <dir>/tty<i>; the engine's serial link opens the symlink. */
static void fx_pty(struct fx *fx, unsigned i)
{
        struct peer_end *pe = &fx->peers[i];

        if (!pe->rx)
                peer_init(fx, i);
        assert_int_equal(harness_openpty(&pe->fd, &pe->slave, pe->pts), 0);
        repoint(fx, i, pe->pts);
        slp_decoder_reset(&pe->dec);
        pe->datagram = false;
        pe->tx_len = pe->tx_off = 0;
        assert_int_equal(evloop_add_fd(fx->loop, pe->fd, POLLIN, peer_on_io, pe), 0);
}

/* Pulls the plug: the symlink names nothing, the pair is closed (the engine's tty hangs up). */
static void fx_unplug(struct fx *fx, unsigned i)
{
        struct peer_end *pe = &fx->peers[i];
        char absent[HARNESS_PATH_MAX];

        snprintf(absent, sizeof(absent), "%s/absent", fx->dir);
        repoint(fx, i, absent);
        evloop_del_fd(fx->loop, pe->fd);
        close(pe->fd);
        close(pe->slave);
        pe->fd = pe->slave = -1;
}

/* A loopback UDP socket for link i; its port replaces @P<i>@ in the YAML. */
static void fx_udp(struct fx *fx, unsigned i)
{
        struct peer_end *pe = &fx->peers[i];
        struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
        socklen_t alen = sizeof(a);

        peer_init(fx, i);
        pe->datagram = true;
        pe->fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
        assert_true(pe->fd >= 0);
        assert_int_equal(bind(pe->fd, (struct sockaddr *)&a, sizeof(a)), 0);
        assert_int_equal(getsockname(pe->fd, (struct sockaddr *)&a, &alen), 0);
        pe->port = ntohs(a.sin_port);
        assert_int_equal(evloop_add_fd(fx->loop, pe->fd, POLLIN, peer_on_io, pe), 0);
}

/* ---------------------------------------------------------------------------------------------
 * Fixture */

static void on_guard(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        struct fx *fx = arg;

        (void)loop;
        (void)timer;
        fx->guard_fired = true;
}

static int setup(void **state)
{
        static unsigned seq;
        struct fx *fx = calloc(1, sizeof(*fx));

        if (!fx)
                return -1;
        snprintf(fx->dir, sizeof(fx->dir), "/tmp/tlsl.XXXXXX");
        if (!mkdtemp(fx->dir) || evloop_new(&fx->loop) < 0)
                return -1;
        snprintf(fx->instance, sizeof(fx->instance), "tlsl%d_%u", (int)getpid(), seq++);
        for (unsigned i = 0; i < LINKS_MAX; i++)
                fx->peers[i].fd = fx->peers[i].slave = -1;
        fx->wake_fd = -1;
        fx->adhoc_capacity = 16;
        evloop_timer_init(&fx->guard, fx->loop, on_guard, fx);
        *state = fx;
        return 0;
}

static int teardown(void **state)
{
        struct fx *fx = *state;
        char cmd[128];

        for (unsigned i = 0; i < fx->nlinks; i++)
                ops->destroy(fx->engines[i]);
        control_free(fx->ctl);
        sl_close(fx->client);
        if (fx->wake_fd >= 0)
                evloop_del_fd(fx->loop, fx->wake_fd);
        shm_table_destroy(fx->table);
        config_free(fx->cfg);
        for (unsigned i = 0; i < LINKS_MAX; i++) {
                struct peer_end *pe = &fx->peers[i];

                if (pe->fd >= 0) {
                        evloop_del_fd(fx->loop, pe->fd);
                        close(pe->fd);
                }
                if (pe->slave >= 0)
                        close(pe->slave);
                free(pe->rx);
                free(pe->tx);
        }
        evloop_timer_cancel(&fx->guard);
        evloop_free(fx->loop);
        snprintf(cmd, sizeof(cmd), "rm -rf '%s'", fx->dir);
        free(fx);
        return system(cmd) == 0 ? 0 : -1;
}

/* What the daemon core does when clients wrote: scan, hand each change to its link's engine. */
static void on_out_change(void *arg, const struct shm_out_change *ch)
{
        struct fx *fx = arg;
        uint32_t link;

        if (ch->id >= fx->nvars) {
                /* Learned at run time: as the core does, every engine may own it. */
                for (unsigned i = 0; i < fx->nlinks; i++)
                        ops->outbound(fx->engines[i], ch);
                fx->dispatched++;
                return;
        }
        link = fx->var_link[ch->id];
        assert_true(link < fx->nlinks);
        fx->frames_out_at_dispatch = shm_table_counter_get(fx->table, 0, SHM_COUNTER_FRAMES_OUT);
        ops->outbound(fx->engines[link], ch);
        fx->dispatched++;
}

static void on_wake(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct fx *fx = arg;

        (void)loop;
        (void)fd;
        (void)revents;
        shm_table_out_wake_ack(fx->table);
        assert_true(shm_table_out_scan(fx->table, on_out_change, fx) >= 0);
}

/*
 * Parses tests/data/<file> (with @DIR@ and @P<i>@ = the udp port of peer end i replaced), builds
 * the table the way the core does (each link's declare(), in link order), creates the engines,
 * opens the client library on the instance.
 */
static void fx_start(struct fx *fx, const char *file)
{
        static struct shm_var vars[VARS_MAX];
        struct shm_link_def links[LINKS_MAX];
        struct shm_table_config tc;
        struct config_error err;
        char yaml[YAML_MAX], text[YAML_MAX + 128], key[LINKS_MAX][16], port[LINKS_MAX][16];
        const char *subst[2 * LINKS_MAX + 3] = { "@DIR@", fx->dir };
        size_t n = 0, used = 0;
        int r;

        for (unsigned i = 0; i < LINKS_MAX; i++) {
                snprintf(key[i], sizeof(key[i]), "@P%u@", i);
                snprintf(port[i], sizeof(port[i]), "%u", fx->peers[i].port);
                subst[2 + 2 * i] = key[i];
                subst[3 + 2 * i] = port[i];
        }
        assert_true(testdata_load(file, subst, yaml, sizeof(yaml)) > 0);
        snprintf(text, sizeof(text), "instance: %s\n%s", fx->instance, yaml);
        r = config_parse(text, strlen(text), "test.yaml", &fx->cfg, &err);
        if (r < 0)
                fail_msg("config: %s", err.message);
        assert_true(fx->cfg->n_links <= LINKS_MAX);
        fx->nlinks = fx->cfg->n_links;
        for (unsigned i = 0; i < fx->nlinks; i++) {
                size_t before = n;

                assert_int_equal(ops->declare(&fx->cfg->links[i], i, vars, &n, VARS_MAX, NULL, 0,
                                              &used), 0);
                for (size_t k = before; k < n; k++)
                        fx->var_link[k] = i;
                links[i] = (struct shm_link_def){ .name = fx->cfg->links[i].name,
                                                  .protocol = "sharedlink" };
        }
        fx->nvars = (uint32_t)n;
        tc = (struct shm_table_config){
                .instance = fx->instance,
                .vars = vars,
                .nvars = (uint32_t)n,
                .links = links,
                .nlinks = fx->nlinks,
                .adhoc_capacity = fx->adhoc_capacity,
                .out_spare = fx->out_spare,
        };
        assert_int_equal(shm_table_create(&tc, &fx->table), 0);
        for (unsigned i = 0; i < fx->nlinks; i++) {
                struct link_env env = {
                        .loop = fx->loop,
                        .table = fx->table,
                        .shm_link = i,
                        .config = fx->cfg,
                        .cfg = &fx->cfg->links[i],
                };

                assert_int_equal(ops->create(&env, &fx->engines[i]), 0);
        }
        assert_int_equal(sl_open(fx->instance, &fx->client), 0);
        fx->wake_fd = shm_table_out_wake_fd(fx->table);
        assert_true(fx->wake_fd >= 0);
        assert_int_equal(evloop_add_fd(fx->loop, fx->wake_fd, POLLIN, on_wake, fx), 0);
}

/* ---------------------------------------------------------------------------------------------
 * Waiting */

typedef bool (*pred_fn)(struct fx *fx, const void *arg);

static void run_until(struct fx *fx, pred_fn pred, const void *arg, const char *what)
{
        fx->guard_fired = false;
        assert_int_equal(evloop_timer_arm(&fx->guard, WAIT_MS, 0), 0);
        while (!pred(fx, arg)) {
                if (fx->guard_fired)
                        fail_msg("timed out waiting for %s", what);
                assert_int_equal(evloop_run_once(fx->loop), 0);
        }
        evloop_timer_cancel(&fx->guard);
}

struct want_frames {
        unsigned peer;
        size_t n;
};

static bool pred_frames(struct fx *fx, const void *arg)
{
        const struct want_frames *w = arg;

        return fx->peers[w->peer].nrx >= w->n;
}

/* Waits until peer end `peer` has received n frames in all; returns the n-th (1-based). */
static const char *wait_frames(struct fx *fx, unsigned peer, size_t n)
{
        struct want_frames w = { peer, n };

        run_until(fx, pred_frames, &w, "frames from the engine");
        return fx->peers[peer].rx[n - 1].text;
}

static bool pred_dispatched(struct fx *fx, const void *arg)
{
        return fx->dispatched >= *(const unsigned *)arg;
}

static int var_id(struct fx *fx, const char *name)
{
        int id = sl_find(fx->client, name);

        if (id < 0)
                fail_msg("no variable %s", name);
        return id;
}

/* A client writes; returns once the engine was told (the core's dispatch ran). */
static void client_write(struct fx *fx, const char *name, const char *value)
{
        unsigned want = fx->dispatched + 1;

        assert_int_equal(sl_write(fx->client, var_id(fx, name), value), 0);
        run_until(fx, pred_dispatched, &want, "the outbound dispatch");
}

/* Reads a value; returns its flags. */
static uint32_t client_read(struct fx *fx, const char *name, char *buf)
{
        struct sl_meta meta = { .size = sizeof(meta) };

        assert_true(sl_read(fx->client, var_id(fx, name), buf, SL_VALUE_SIZE, &meta) >= 0);
        return meta.flags;
}

struct want_value {
        const char *name, *value;
};

static bool pred_value(struct fx *fx, const void *arg)
{
        const struct want_value *w = arg;
        char buf[SL_VALUE_SIZE];

        /* An ad hoc variable may not exist yet. */
        if (sl_find(fx->client, w->name) < 0)
                return false;
        return (client_read(fx, w->name, buf) & SL_FLAG_VALID) && strcmp(buf, w->value) == 0;
}

static void wait_value(struct fx *fx, const char *name, const char *value)
{
        struct want_value w = { name, value };

        run_until(fx, pred_value, &w, value);
}

static void check_value(struct fx *fx, const char *name, const char *value, bool stale)
{
        char buf[SL_VALUE_SIZE];
        uint32_t flags = client_read(fx, name, buf);

        assert_true(flags & SL_FLAG_VALID);
        assert_string_equal(buf, value);
        assert_int_equal(!!(flags & SL_FLAG_STALE), stale);
}

struct want_flag {
        const char *name;
        uint32_t flag;
        bool set;
};

static bool pred_flag(struct fx *fx, const void *arg)
{
        const struct want_flag *w = arg;
        char buf[SL_VALUE_SIZE];

        return !!(client_read(fx, w->name, buf) & w->flag) == w->set;
}

static void wait_stale(struct fx *fx, const char *name, bool stale)
{
        struct want_flag w = { name, SL_FLAG_STALE, stale };

        run_until(fx, pred_flag, &w, stale ? "stale" : "fresh");
}

struct want_state {
        int link;
        const char *prefix;
};

static bool pred_state(struct fx *fx, const void *arg)
{
        const struct want_state *w = arg;
        struct sl_link_info li = { .size = sizeof(li) };

        assert_int_equal(sl_link_info(fx->client, w->link, &li), 0);
        return strncmp(li.state_name, w->prefix, strlen(w->prefix)) == 0;
}

static void wait_state(struct fx *fx, int link, const char *prefix)
{
        struct want_state w = { link, prefix };

        run_until(fx, pred_state, &w, prefix);
}

static uint64_t ctr(struct fx *fx, unsigned link, enum shm_counter c)
{
        return shm_table_counter_get(fx->table, link, c);
}

/* Sends a ping and waits for its pong: the engine has processed everything sent before it.
 * Returns the index of the pong frame. */
static size_t sync_peer(struct fx *fx, unsigned peer, char self, char engine)
{
        struct peer_end *pe = &fx->peers[peer];
        char text[64], want[64];
        unsigned n = ++fx->ping;

        snprintf(text, sizeof(text), ":%c%c|P%u", engine, self, n);
        peer_frame(pe, text);
        snprintf(text, sizeof(text), ":%c%c|G%u", self, engine, n);
        wire_slp_raw(want, sizeof(want), text, false);
        for (size_t i = pe->nrx;; i++) {
                const char *f = wait_frames(fx, peer, i + 1);

                if (strcmp(f, want) == 0)
                        return i;
        }
}

static uint32_t change_word(struct fx *fx)
{
        uint32_t cursor = 0;

        /* A cursor that differs from the word makes sl_wait return it at once. */
        sl_wait(fx->client, &cursor, 0);
        if (cursor == 0) {
                cursor = 1;
                sl_wait(fx->client, &cursor, 0);
        }
        return cursor;
}

/* Reads the events after *cursor into ev; returns how many. */
static int read_events(struct fx *fx, uint64_t *cursor, struct sl_event *ev, size_t max)
{
        for (size_t i = 0; i < max; i++)
                ev[i].size = sizeof(ev[i]);
        return sl_events_read(fx->client, cursor, ev, max);
}

/* Whether an event of that type with text containing needle is among the events after *cursor. */
static bool has_event(struct fx *fx, uint64_t cursor, const char *type, const char *needle)
{
        struct sl_event ev[EVENTS_MAX];
        int n;

        while ((n = read_events(fx, &cursor, ev, EVENTS_MAX)) > 0)
                for (int i = 0; i < n; i++)
                        if (strcmp(ev[i].type_name, type) == 0 && strstr(ev[i].text, needle))
                                return true;
        return false;
}

/* ---------------------------------------------------------------------------------------------
 * Tests */

static void test_declare(void **state)
{
        static const char yaml[] =
                "instance: decl\n"
                "links:\n"
                "  - name: veh\n"
                "    protocol: sharedlink\n"
                "    transport: serial\n"
                "    device: /tmp/none\n"
                "    address: B\n"
                "    peers:\n"
                "      - address: A\n"
                "        outbound: [{name: O1, type: double}, O2]\n"
                "        inbound: [{name: I1, type: long}]\n"
                "      - address: P\n"
                "        inbound: [I2]\n"
                "  - name: ag\n"
                "    protocol: circe\n"
                "    role: controller\n"
                "    transport: serial\n"
                "    device: /tmp/none2\n";
        struct shm_var vars[8];
        struct config *c = NULL;
        struct config_error e;
        size_t n = 1, used = 0;

        (void)state;
        assert_int_equal(config_parse(yaml, strlen(yaml), "t.yaml", &c, &e), 0);
        assert_int_equal(ops->declare(&c->links[0], 3, vars, &n, 8, NULL, 0, &used), 0);
        assert_int_equal(n, 5);
        assert_string_equal(vars[1].name, "O1");
        assert_int_equal(vars[1].direction, SHM_DIR_OUT);
        assert_int_equal(vars[1].type, SHM_TYPE_DOUBLE);
        assert_int_equal(vars[1].link, 3);
        assert_string_equal(vars[1].peer, "A");
        assert_int_equal(vars[1].position, 0);
        assert_string_equal(vars[2].name, "O2");
        assert_int_equal(vars[2].type, SHM_TYPE_STRING);
        assert_int_equal(vars[2].position, 1);
        assert_string_equal(vars[3].name, "I1");
        assert_int_equal(vars[3].direction, SHM_DIR_IN);
        assert_int_equal(vars[3].type, SHM_TYPE_LONG);
        assert_int_equal(vars[3].position, 0);
        assert_string_equal(vars[4].name, "I2");
        assert_string_equal(vars[4].peer, "P");
        assert_int_equal(vars[4].position, 0);
        /* No room: nothing appended. */
        n = 5;
        assert_int_equal(ops->declare(&c->links[0], 3, vars, &n, 8, NULL, 0, &used), -ENOSPC);
        assert_int_equal(n, 5);
        /* Not a SharedLink link. */
        n = 0;
        assert_int_equal(ops->declare(&c->links[1], 4, vars, &n, 8, NULL, 0, &used), -EINVAL);
        assert_int_equal(n, 0);
        config_free(c);
}

/* Counters whose delta every inbound row checks exactly (the rest of the row's list is 0). */
static const enum shm_counter checked[] = {
        SHM_COUNTER_NOISE_BYTES, SHM_COUNTER_BAD_CHECKSUM, SHM_COUNTER_RESYNC,
        SHM_COUNTER_OVERLONG, SHM_COUNTER_BAD_ADDRESS, SHM_COUNTER_BAD_HEADER,
        SHM_COUNTER_BAD_FIELD, SHM_COUNTER_UNKNOWN_FIELD, SHM_COUNTER_EMPTY_FIELD,
        SHM_COUNTER_LIST_MISMATCH, SHM_COUNTER_UNKNOWN_PEER, SHM_COUNTER_NOT_FOR_US,
        SHM_COUNTER_BAD_VALUE, SHM_COUNTER_ADHOC_FULL, SHM_COUNTER_QUERIES_IN,
        SHM_COUNTER_ANSWERS_IN,
};
#define NCHECKED (sizeof(checked) / sizeof(checked[0]))
#define ROW_COUNTS 3

struct inbound_row {
        const char *what;
        const char *raw;                /* sent first, as is (may be NULL) */
        const char *text;               /* then framed by wire_slp_raw (may be NULL) */
        const char *values[4];          /* AutoGpsLat, Lon, Head, Vel afterwards; NULL: same */
        uint32_t bumps;                 /* change-word bumps */
        struct {
                enum shm_counter c;
                uint64_t n;
        } counts[ROW_COUNTS];
};

static const char *const gps_names[4] = { "AutoGpsLat", "AutoGpsLon", "AutoGpsHead",
                                          "AutoGpsVel" };

static char overlong_a[400], overlong_decoder[700], long_value[128];

static const struct inbound_row inbound_rows[] = {
        { "spec example (addresses swapped: same checksum)",
          "[:BA|N0|D40.12345678|D-113.12345678|D85.6|D22.1|CD4]\r\n", NULL,
          { "40.12345678", "-113.12345678", "85.6", "22.1" }, 1, { { 0, 0 } } },
        { "spec compressed example", "[:BA|N0|D|D|D85.7|D|C48]\r\n", NULL,
          { NULL, NULL, "85.7", NULL }, 1, { { 0, 0 } } },
        { "N offset", NULL, ":BA|N2|D1|D2", { NULL, NULL, "1", "2" }, 1, { { 0, 0 } } },
        { "D without N starts at 0", NULL, ":BA|D7", { "7", NULL, NULL, NULL }, 1,
          { { 0, 0 } } },
        { "several N reset the position", NULL, ":BA|N3|D9|N0|D8", { "8", NULL, NULL, "9" }, 1,
          { { 0, 0 } } },
        { "beyond the list: mismatch, the rest applies", NULL, ":BA|N3|D10|D11|D12",
          { NULL, NULL, NULL, "10" }, 1, { { SHM_COUNTER_LIST_MISMATCH, 2 } } },
        { "empty field skipped", NULL, ":BA|N0|D1||D2", { "1", "2", NULL, NULL }, 1,
          { { SHM_COUNTER_EMPTY_FIELD, 1 } } },
        { "unknown field skipped", NULL, ":BA|N0|D3|Xfoo|D4", { "3", "4", NULL, NULL }, 1,
          { { SHM_COUNTER_UNKNOWN_FIELD, 1 } } },
        { "declaration T|Q|D is skipped whole", NULL, ":BA|N0|D5|T2|QAutoGpsLon|D6|D7",
          { "5", "7", NULL, NULL }, 1, { { SHM_COUNTER_UNKNOWN_FIELD, 2 } } },
        { "E and its D skipped", NULL, ":BA|N0|D1|ELink|D0, outbound, on|D2",
          { "1", "2", NULL, NULL }, 1, { { SHM_COUNTER_UNKNOWN_FIELD, 1 } } },
        { "L list skipped until N", NULL, ":BA|L0|D5|N1|D6", { NULL, "6", NULL, NULL }, 1,
          { { SHM_COUNTER_UNKNOWN_FIELD, 2 } } },
        { "N? and its D skipped", NULL, ":BA|N?|D5", { NULL }, 0,
          { { SHM_COUNTER_UNKNOWN_FIELD, 2 } } },
        { "value longer than 63 bytes", NULL, long_value, { NULL }, 0,
          { { SHM_COUNTER_BAD_VALUE, 1 } } },
        { "huge position", NULL, ":BA|N99999999999|D1", { NULL }, 0,
          { { SHM_COUNTER_LIST_MISMATCH, 1 } } },
        { "not for us", NULL, ":CA|N0|D1", { NULL }, 0, { { SHM_COUNTER_NOT_FOR_US, 1 } } },
        { "unknown peer", NULL, ":BD|N0|D1", { NULL }, 0, { { SHM_COUNTER_UNKNOWN_PEER, 1 } } },
        { "bad checksum", "[:BA|N0|D1|C00]\r\n", NULL, { NULL }, 0,
          { { SHM_COUNTER_BAD_CHECKSUM, 1 } } },
        { "no checksum", "[:BA|N0|D1]\r\n", NULL, { NULL }, 0,
          { { SHM_COUNTER_BAD_CHECKSUM, 1 } } },
        { "noise before a frame", "xyz", ":BA|N0|D2", { "2", NULL, NULL, NULL }, 1,
          { { SHM_COUNTER_NOISE_BYTES, 3 } } },
        { "partial frame, then a whole one", "[:BA|N0|D1", ":BA|N0|D3",
          { "3", NULL, NULL, NULL }, 1, { { SHM_COUNTER_RESYNC, 1 } } },
        { "longer than the peer's max_frame", NULL, overlong_a, { NULL }, 0,
          { { SHM_COUNTER_OVERLONG, 1 } } },
        { "longer than any max_frame: the rest is noise", NULL, overlong_decoder, { NULL }, 0,
          { { SHM_COUNTER_OVERLONG, 1 }, { SHM_COUNTER_NOISE_BYTES, 610 - 512 } } },
        { "bad address", NULL, ":BZ|N0|D1", { NULL }, 0, { { SHM_COUNTER_BAD_ADDRESS, 1 } } },
        { "bad header", NULL, ";BA|N0|D1", { NULL }, 0, { { SHM_COUNTER_BAD_HEADER, 1 } } },
        { "bad field letter", NULL, ":BA|N0|d1", { NULL }, 0, { { SHM_COUNTER_BAD_FIELD, 1 } } },
        { "no field", NULL, ":BA", { NULL }, 0, { { SHM_COUNTER_BAD_FIELD, 1 } } },
        { "R without its D", NULL, ":BA|RAutoGpsLat|N0", { NULL }, 0,
          { { SHM_COUNTER_BAD_FIELD, 1 } } },
        { "spec answer (R|D) for an inbound variable",
          "[:BA|RAutoGpsLat|D40.12345678|C24]\r\n", NULL,
          { "40.12345678", NULL, NULL, NULL }, 1, { { SHM_COUNTER_ANSWERS_IN, 1 } } },
        { "other peer's list", NULL, ":BC|N0|Dc1|D2", { NULL }, 1,
          { { SHM_COUNTER_LIST_MISMATCH, 1 } } },
};

static void build_row_texts(void)
{
        size_t n;

        /* 306 bytes of text: a 312-byte frame, over peer A's 256, under the decoder's 512. */
        n = (size_t)snprintf(overlong_a, sizeof(overlong_a), ":BA|N0");
        for (int i = 0; i < 100; i++)
                n += (size_t)snprintf(overlong_a + n, sizeof(overlong_a) - n, "|D1");
        assert_int_equal(n, 306);
        /* 604 bytes of text: a 610-byte frame; the decoder gives up at 512 (max over peers). */
        n = (size_t)snprintf(overlong_decoder, sizeof(overlong_decoder), ":BA|N0");
        for (int i = 0; i < 166; i++)
                n += (size_t)snprintf(overlong_decoder + n, sizeof(overlong_decoder) - n, "|D1");
        assert_int_equal(n, 504);
        for (int i = 0; i < 20; i++)
                n += (size_t)snprintf(overlong_decoder + n, sizeof(overlong_decoder) - n, "|D2  ");
        assert_int_equal(n, 604);
        n = (size_t)snprintf(long_value, sizeof(long_value), ":BA|N0|D");
        memset(long_value + n, 'x', 64);
        long_value[n + 64] = '\0';
}

static void test_inbound_rows(void **state)
{
        struct fx *fx = *state;
        const char *cur[4] = { NULL };
        char buf[SL_VALUE_SIZE];

        build_row_texts();
        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_inbound.yaml");
        /* Nothing heard yet: never set, and stale. */
        assert_true(client_read(fx, "AutoGpsLat", buf) & SL_FLAG_STALE);
        assert_false(client_read(fx, "AutoGpsLat", buf) & SL_FLAG_VALID);
        sync_peer(fx, 0, 'A', 'B');

        for (size_t r = 0; r < sizeof(inbound_rows) / sizeof(inbound_rows[0]); r++) {
                const struct inbound_row *row = &inbound_rows[r];
                uint64_t before[NCHECKED];
                uint32_t word;

                print_message("row %zu: %s\n", r, row->what);
                for (size_t i = 0; i < NCHECKED; i++)
                        before[i] = ctr(fx, 0, checked[i]);
                word = change_word(fx);
                if (row->raw)
                        peer_send_str(&fx->peers[0], row->raw);
                if (row->text)
                        peer_frame(&fx->peers[0], row->text);
                sync_peer(fx, 0, 'A', 'B');

                assert_int_equal(change_word(fx) - word, row->bumps);
                for (size_t i = 0; i < NCHECKED; i++) {
                        uint64_t want = 0;

                        for (unsigned k = 0; k < ROW_COUNTS; k++)
                                if (row->counts[k].n && row->counts[k].c == checked[i])
                                        want = row->counts[k].n;
                        if (ctr(fx, 0, checked[i]) - before[i] != want)
                                fail_msg("row %zu (%s): counter %s: +%llu, want +%llu", r,
                                         row->what, shm_layout_counter_name(checked[i]),
                                         (unsigned long long)(ctr(fx, 0, checked[i]) - before[i]),
                                         (unsigned long long)want);
                }
                for (unsigned k = 0; k < 4; k++) {
                        if (row->values[k])
                                cur[k] = row->values[k];
                        if (cur[k])
                                check_value(fx, gps_names[k], cur[k], false);
                }
        }
        assert_true(client_read(fx, "FromC", buf) & SL_FLAG_VALID);
        assert_string_equal(buf, "c1");
        /* The same counters through the client library. */
        {
                struct sl_link_info li = { .size = sizeof(li) };
                bool found = false;

                assert_int_equal(sl_link_info(fx->client, 0, &li), 0);
                assert_string_equal(li.name, "veh");
                assert_string_equal(li.state_name, "up");
                assert_int_equal(li.state, LINK_SHAREDLINK_STATE_UP);
                for (unsigned i = 0; i < li.counter_count; i++)
                        if (strcmp(li.counters[i].name, "list_mismatch") == 0) {
                                assert_int_equal(li.counters[i].value, 4);
                                found = true;
                        }
                assert_true(found);
        }
}

#define GARBAGE_CHUNK   32768
#define CLEAN_CHUNKS    32      /* 1 MiB of noise without frame bytes */
#define RANDOM_CHUNKS   64      /* 2 MiB of random bytes */

static uint64_t rejects(struct fx *fx)
{
        uint64_t sum = 0;

        for (size_t i = 0; i < NCHECKED; i++)
                sum += ctr(fx, 0, checked[i]);
        return sum;
}

/* Megabytes of garbage around valid frames: every valid frame is applied, counts add up. */
static void test_garbage_megabytes(void **state)
{
        struct fx *fx = *state;
        static uint8_t chunk[GARBAGE_CHUNK];
        uint64_t before[NCHECKED], noise = 0, rej;
        char text[64];
        uint32_t word;

        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_inbound.yaml");
        sync_peer(fx, 0, 'A', 'B');

        /* Noise only (no '[', ']', CR, LF): each byte counts exactly once. */
        for (size_t i = 0; i < NCHECKED; i++)
                before[i] = ctr(fx, 0, checked[i]);
        word = change_word(fx);
        for (int c = 0; c < CLEAN_CHUNKS; c++) {
                assert_int_equal(getrandom(chunk, sizeof(chunk), 0), (ssize_t)sizeof(chunk));
                for (size_t i = 0; i < sizeof(chunk); i++)
                        if (chunk[i] == '[' || chunk[i] == ']' || chunk[i] == '\r' ||
                            chunk[i] == '\n')
                                chunk[i] = 'x';
                peer_send(&fx->peers[0], chunk, sizeof(chunk));
                noise += sizeof(chunk);
                snprintf(text, sizeof(text), ":BA|N0|D%d", c);
                peer_frame(&fx->peers[0], text);
        }
        sync_peer(fx, 0, 'A', 'B');
        assert_int_equal(change_word(fx) - word, CLEAN_CHUNKS);        /* one per frame */
        snprintf(text, sizeof(text), "%d", CLEAN_CHUNKS - 1);
        check_value(fx, "AutoGpsLat", text, false);
        for (size_t i = 0; i < NCHECKED; i++)
                assert_int_equal(ctr(fx, 0, checked[i]) - before[i],
                                 checked[i] == SHM_COUNTER_NOISE_BYTES ? noise : 0);

        /* Any byte at all: the decoder resyncs on each frame start, every frame applies. */
        rej = rejects(fx);
        word = change_word(fx);
        for (int c = 0; c < RANDOM_CHUNKS; c++) {
                assert_int_equal(getrandom(chunk, sizeof(chunk), 0), (ssize_t)sizeof(chunk));
                peer_send(&fx->peers[0], chunk, sizeof(chunk));
                snprintf(text, sizeof(text), ":BA|N1|D%d", c);
                peer_frame(&fx->peers[0], text);
        }
        sync_peer(fx, 0, 'A', 'B');
        /* A random frame passing the checksum could add a bump, never take one away. */
        assert_true(change_word(fx) - word >= RANDOM_CHUNKS);
        snprintf(text, sizeof(text), "%d", RANDOM_CHUNKS - 1);
        check_value(fx, "AutoGpsLon", text, false);
        assert_true(rejects(fx) > rej);
        assert_true(ops->status(fx->engines[0]) && strcmp(ops->status(fx->engines[0]), "up") == 0);
}

static bool frame_is(const char *f, const char *text)
{
        char want[TEXT_MAX];

        wire_slp_raw(want, sizeof(want), text, false);
        return strcmp(f, want) == 0;
}

static void expect_frame(const char *f, const char *text)
{
        char want[TEXT_MAX];

        wire_slp_raw(want, sizeof(want), text, false);
        assert_string_equal(f, want);
}

static uint64_t timer_fires(struct fx *fx)
{
        struct evloop_stats st;

        evloop_get_stats(fx->loop, &st);
        return st.timer_fires;
}

#define REFRESH_EVERY   5       /* refresh_ms / period_ms in link_sharedlink_periodic.yaml */
#define OBSERVE         15

/* Periodic send, compression, full refresh cadence (PROTOCOLS.md 1.5 and its examples). */
static void test_outbound_periodic(void **state)
{
        static const char full_text[] = ":AB|N0|D40.12345678|D-113.12345678|D85.6|D22.1";
        static const char empty_text[] = ":AB|N0|D|D|D|D";
        struct fx *fx = *state;
        struct peer_end *pe = &fx->peers[0];
        uint64_t fires, out;
        size_t k, m;
        int phase = -1;

        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_periodic.yaml");
        /* Up: the full list at once (nothing written yet: empty values). */
        expect_frame(wait_frames(fx, 0, 1), empty_text);

        /* Four writes before the loop runs: one scan hands all four to the engine. */
        assert_int_equal(sl_write(fx->client, var_id(fx, "AutoGpsLat"), "40.12345678"), 0);
        assert_int_equal(sl_write(fx->client, var_id(fx, "AutoGpsLon"), "-113.12345678"), 0);
        assert_int_equal(sl_write(fx->client, var_id(fx, "AutoGpsHead"), "85.6"), 0);
        assert_int_equal(sl_write(fx->client, var_id(fx, "AutoGpsVel"), "22.1"), 0);
        {
                unsigned want = 4;

                run_until(fx, pred_dispatched, &want, "four dispatches");
        }
        k = fx->frames_out_at_dispatch;
        /* The first frame after the writes is the spec's own example, full or compressed. */
        assert_string_equal(wait_frames(fx, 0, k + 1),
                            "[:AB|N0|D40.12345678|D-113.12345678|D85.6|D22.1|CD4]");

        /* One frame per period; all empty D but every REFRESH_EVERY-th, which is full. */
        fires = timer_fires(fx);
        out = ctr(fx, 0, SHM_COUNTER_FRAMES_OUT);
        wait_frames(fx, 0, k + 1 + OBSERVE);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_FRAMES_OUT) - out, timer_fires(fx) - fires);
        for (size_t j = k + 1; j <= k + OBSERVE; j++) {
                const char *f = pe->rx[j].text;

                if (frame_is(f, full_text)) {
                        if (phase < 0)
                                phase = (int)(j % REFRESH_EVERY);
                        assert_int_equal(j % REFRESH_EVERY, phase);
                } else {
                        expect_frame(f, empty_text);
                        assert_true(phase < 0 || (int)(j % REFRESH_EVERY) != phase);
                }
        }
        assert_true(phase >= 0);

        /* One change: the spec's compressed example, unless that period is a full one. */
        for (int attempt = 0;; attempt++) {
                assert_true(attempt < REFRESH_EVERY);
                client_write(fx, "AutoGpsHead", "85.7");
                m = fx->frames_out_at_dispatch;
                wait_frames(fx, 0, m + 1);
                if ((int)(m % REFRESH_EVERY) != phase) {
                        assert_string_equal(pe->rx[m].text, "[:AB|N0|D|D|D85.7|D|C48]");
                        break;
                }
                expect_frame(pe->rx[m].text, ":AB|N0|D40.12345678|D-113.12345678|D85.7|D22.1");
        }
        /* Byte stream: every frame ended with CR LF, nothing else on the wire. */
        assert_int_equal(pe->rx_bytes, pe->rx_frame_bytes + 2 * pe->nrx);
}

/* A list split over frames of max_frame bytes with the right N offsets. */
static void test_outbound_split(void **state)
{
        struct fx *fx = *state;
        struct peer_end *pe = &fx->peers[0];
        char name[16], value[24], text[128];
        uint64_t fires, out, bad;
        unsigned want;
        size_t m;

        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_split.yaml");
        for (int i = 0; i < 10; i++) {
                snprintf(name, sizeof(name), "V%d", i);
                snprintf(value, sizeof(value), "value-%d", i);
                assert_int_equal(sl_write(fx->client, var_id(fx, name), value), 0);
        }
        want = 10;
        run_until(fx, pred_dispatched, &want, "ten dispatches");
        m = fx->frames_out_at_dispatch;         /* the first frame of the next period */
        fires = timer_fires(fx);
        out = ctr(fx, 0, SHM_COUNTER_FRAMES_OUT);
        wait_frames(fx, 0, m + 10);
        for (size_t j = m; j < m + 10; j++) {
                int first = (int)(j - m) % 5 * 2;

                snprintf(text, sizeof(text), ":AB|N%d|Dvalue-%d|Dvalue-%d", first, first,
                         first + 1);
                expect_frame(pe->rx[j].text, text);
                assert_true(pe->rx[j].len + 2 <= 40);   /* max_frame counts the CR LF */
        }
        /* Five frames per period (count periods as timer fires, frames as sent). */
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_FRAMES_OUT) - out, 5 * (timer_fires(fx) - fires));

        /* A value that can never fit max_frame: counted and skipped, the rest still goes. */
        bad = ctr(fx, 0, SHM_COUNTER_BAD_VALUE);
        client_write(fx, "V3", "a value far too long for forty");
        m = fx->frames_out_at_dispatch;
        wait_frames(fx, 0, m + 5);
        expect_frame(pe->rx[m].text, ":AB|N0|Dvalue-0|Dvalue-1");
        expect_frame(pe->rx[m + 1].text, ":AB|N2|Dvalue-2");
        expect_frame(pe->rx[m + 2].text, ":AB|N4|Dvalue-4|Dvalue-5");
        expect_frame(pe->rx[m + 3].text, ":AB|N6|Dvalue-6|Dvalue-7");
        expect_frame(pe->rx[m + 4].text, ":AB|N8|Dvalue-8|Dvalue-9");
        assert_true(ctr(fx, 0, SHM_COUNTER_BAD_VALUE) > bad);
}

/* on_change: a write goes at once; writes inside min_interval coalesce; the last one goes. */
static void test_outbound_on_change(void **state)
{
        struct fx *fx = *state;

        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_on_change.yaml");
        expect_frame(wait_frames(fx, 0, 1), ":AB|N0|D|D|D|D");          /* up: full list */

        client_write(fx, "AutoGpsHead", "85.7");
        expect_frame(wait_frames(fx, 0, 2), ":AB|N2|D85.7");
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_FRAMES_OUT), 2);

        /* Within the 1000 ms interval (these steps take microseconds): held back... */
        client_write(fx, "AutoGpsLat", "1");
        client_write(fx, "AutoGpsVel", "2");
        client_write(fx, "AutoGpsLat", "3");
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_FRAMES_OUT), 2);
        /* ... and sent together when it ends, last values, unwritten positions empty. */
        expect_frame(wait_frames(fx, 0, 3), ":AB|N0|D3|D|D|D2");
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_FRAMES_OUT), 3);

        /* Rate-limited, never dropped. */
        client_write(fx, "AutoGpsHead", "9");
        expect_frame(wait_frames(fx, 0, 4), ":AB|N2|D9");
}

/* Sends a frame from peer A to B and returns the next frame the engine sends back. */
static const char *ask(struct fx *fx, const char *text)
{
        size_t n = fx->peers[0].nrx;

        peer_frame(&fx->peers[0], text);
        return wait_frames(fx, 0, n + 1);
}

/* Q from the peer: answered R|D with the instance's value of that name; P answered G. */
static void test_query_answers(void **state)
{
        struct fx *fx = *state;
        struct peer_end *pe = &fx->peers[0];
        char longname[80], text[128];
        uint64_t qin, aout, bad, over;
        size_t n;

        fx_pty(fx, 0);
        fx_pty(fx, 1);
        fx_start(fx, "link_sharedlink_query.yaml");
        wait_frames(fx, 0, 2);          /* up: one full list to A, one to C */
        assert_int_equal(fx->peers[0].rx[0].text[2], 'A');      /* "[:AB|..." */
        assert_int_equal(fx->peers[0].rx[1].text[2], 'C');
        client_write(fx, "CmdThrottle", "55");
        client_write(fx, "AuxValue", "7");
        client_write(fx, "ToC", "x y");
        peer_frame(pe, ":BA|N0|D40.12345678");
        wait_value(fx, "AutoGpsLat", "40.12345678");
        qin = ctr(fx, 0, SHM_COUNTER_QUERIES_IN);
        aout = ctr(fx, 0, SHM_COUNTER_ANSWERS_OUT);

        expect_frame(ask(fx, ":BA|QCmdThrottle"), ":AB|RCmdThrottle|D55");     /* ours, to A */
        assert_string_equal(ask(fx, ":BA|QAutoGpsLat"), "[:AB|RAutoGpsLat|D40.12345678|C24]");
        expect_frame(ask(fx, ":BA|QAuxValue"), ":AB|RAuxValue|D7");     /* another link's */
        expect_frame(ask(fx, ":BA|QToC"), ":AB|RToC|Dx y");             /* another peer's */
        expect_frame(ask(fx, ":BA|QCmdSteer"), ":AB|RCmdSteer|D");      /* never written */
        expect_frame(ask(fx, ":BA|QNope"), ":AB|RNope|D");              /* Decision: unknown */
        expect_frame(ask(fx, ":BA|P0"), ":AB|G0");
        assert_string_equal(pe->rx[pe->nrx - 1].text, "[:AB|G0|C6F]");
        /* Several in one frame: one answer frame, in order. */
        expect_frame(ask(fx, ":BA|QCmdThrottle|QNope|P0"), ":AB|RCmdThrottle|D55|RNope|D|G0");
        /* More than max_frame (64) allows: split between pairs, never inside one. */
        n = pe->nrx;
        peer_frame(pe, ":BA|QCmdThrottle|QAutoGpsLat|QAuxValue");
        wait_frames(fx, 0, n + 2);
        expect_frame(pe->rx[n].text, ":AB|RCmdThrottle|D55|RAutoGpsLat|D40.12345678");
        expect_frame(pe->rx[n + 1].text, ":AB|RAuxValue|D7");
        assert_true(pe->rx[n].len + 2 <= 64);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_QUERIES_IN) - qin, 11);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_ANSWERS_OUT) - aout, 11);

        /* A name too long to answer within max_frame (64); a frame over it is not taken. */
        bad = ctr(fx, 0, SHM_COUNTER_BAD_VALUE);
        over = ctr(fx, 0, SHM_COUNTER_OVERLONG);
        memset(longname, 'q', 50);
        longname[50] = '\0';
        snprintf(text, sizeof(text), ":BA|Q%s", longname);
        peer_frame(pe, text);
        memset(longname, 'q', 70);
        longname[70] = '\0';
        snprintf(text, sizeof(text), ":BA|Q%s", longname);
        n = pe->nrx;
        peer_frame(pe, text);
        assert_int_equal(sync_peer(fx, 0, 'A', 'B'), n);        /* no answer came first */
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_BAD_VALUE) - bad, 1);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_OVERLONG) - over, 1);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_ANSWERS_OUT) - aout, 11);

        /* The second link answers on its own wire, from its own address. */
        peer_frame(&fx->peers[1], ":AB|QCmdThrottle");
        expect_frame(wait_frames(fx, 1, 2), ":BA|RCmdThrottle|D55");

        /* A ping value over SLP_VALUE_MAX (the decoder passes it) cannot be echoed: counted,
         * and the answers in the same frame still go out. */
        bad = ctr(fx, 1, SHM_COUNTER_BAD_VALUE);
        memset(longname, 'p', SLP_VALUE_MAX + 1);
        longname[SLP_VALUE_MAX + 1] = '\0';
        snprintf(text, sizeof(text), ":AB|P%s|QCmdThrottle", longname);
        n = fx->peers[1].nrx;
        peer_frame(&fx->peers[1], text);
        assert_int_equal(sync_peer(fx, 1, 'B', 'A'), n + 1);
        expect_frame(fx->peers[1].rx[n].text, ":BA|RCmdThrottle|D55");
        assert_int_equal(ctr(fx, 1, SHM_COUNTER_BAD_VALUE) - bad, 1);
}

/* R|D from the peer: into the inbound variable, else an ad hoc one, bounded. */
static void test_answers_adhoc(void **state)
{
        struct fx *fx = *state;
        struct sl_var_info info = { .size = sizeof(info) };
        char name[80], text[128];
        uint64_t full, bad, cursor = 0;
        int count, id;
        size_t n;

        fx->adhoc_capacity = 2;
        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_adhoc.yaml");
        assert_int_equal(sl_events_now(fx->client, &cursor), 0);
        count = sl_count(fx->client);

        peer_send_str(&fx->peers[0], "[:BA|RAutoGpsLat|D40.12345678|C24]\r\n");
        wait_value(fx, "AutoGpsLat", "40.12345678");
        assert_int_equal(sl_count(fx->client), count);

        peer_frame(&fx->peers[0], ":BA|RFoo|D12");
        wait_value(fx, "veh.A.Foo", "12");
        id = var_id(fx, "veh.A.Foo");
        assert_int_equal(sl_info(fx->client, id, &info), 0);
        assert_true(info.flags & SL_VAR_ADHOC);
        assert_int_equal(info.direction, SL_DIR_IN);
        assert_int_equal(info.link, 0);
        assert_string_equal(info.peer, "A");
        assert_true(has_event(fx, cursor, "adhoc-variable", "name=veh.A.Foo peer=A"));
        peer_frame(&fx->peers[0], ":BA|RFoo|D13");
        wait_value(fx, "veh.A.Foo", "13");
        assert_int_equal(sl_count(fx->client), count + 1);

        /* An empty answer stores nothing. */
        peer_frame(&fx->peers[0], ":BA|RBar|D");
        sync_peer(fx, 0, 'A', 'B');
        assert_int_equal(sl_find(fx->client, "veh.A.Bar"), -ENOENT);

        /* The ad hoc name is taken by a configured variable: dropped, counted. */
        full = ctr(fx, 0, SHM_COUNTER_ADHOC_FULL);
        peer_frame(&fx->peers[0], ":BA|RTaken|D1");
        sync_peer(fx, 0, 'A', 'B');
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_ADHOC_FULL) - full, 1);
        assert_false(client_read(fx, "veh.A.Taken", text) & SL_FLAG_VALID);

        /* The table's ad hoc room (2) runs out. */
        peer_frame(&fx->peers[0], ":BA|RBar|D1");
        wait_value(fx, "veh.A.Bar", "1");
        peer_frame(&fx->peers[0], ":BA|RBaz|D1");
        sync_peer(fx, 0, 'A', 'B');
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_ADHOC_FULL) - full, 2);
        assert_int_equal(sl_find(fx->client, "veh.A.Baz"), -ENOENT);
        /* Existing ad hoc variables still take values. */
        peer_frame(&fx->peers[0], ":BA|RFoo|D14");
        wait_value(fx, "veh.A.Foo", "14");

        /* Names that cannot make a variable name: a space, too long once prefixed; and a
         * query for a name longer than any value, which cannot be answered. */
        bad = ctr(fx, 0, SHM_COUNTER_BAD_VALUE);
        peer_frame(&fx->peers[0], ":BA|Ra b|D1");
        memset(name, 'n', 45);
        name[45] = '\0';
        snprintf(text, sizeof(text), ":BA|R%s|D1", name);
        peer_frame(&fx->peers[0], text);
        memset(name, 'q', 70);
        name[70] = '\0';
        snprintf(text, sizeof(text), ":BA|Q%s", name);
        peer_frame(&fx->peers[0], text);
        n = fx->peers[0].nrx;
        assert_int_equal(sync_peer(fx, 0, 'A', 'B'), n);        /* no answer came first */
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_BAD_VALUE) - bad, 3);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_ANSWERS_IN), 10);
}

/* Stale after stale_ms of silence, fresh again when a frame sets the value. */
static void test_stale(void **state)
{
        struct fx *fx = *state;
        char buf[SL_VALUE_SIZE];

        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_stale.yaml");
        assert_true(client_read(fx, "AutoGpsLat", buf) & SL_FLAG_STALE);
        peer_frame(&fx->peers[0], ":BA|N0|D1|D2|RFoo|D3");
        wait_value(fx, "veh.A.Foo", "3");
        check_value(fx, "AutoGpsLat", "1", false);
        check_value(fx, "AutoGpsLon", "2", false);
        check_value(fx, "veh.A.Foo", "3", false);

        /* Silence: all of the peer's values go stale in one batch, ad hoc ones included. */
        wait_stale(fx, "AutoGpsLat", true);
        check_value(fx, "AutoGpsLon", "2", true);
        check_value(fx, "veh.A.Foo", "3", true);

        /* A frame that sets Lat makes it fresh; Lon stays stale, an empty D is no news. */
        peer_frame(&fx->peers[0], ":BA|N0|D5|D");
        wait_value(fx, "AutoGpsLat", "5");
        check_value(fx, "AutoGpsLat", "5", false);
        check_value(fx, "AutoGpsLon", "2", true);
}

/* Unplug: down, stale, events; plug back: up, the full list at once, values again. */
static void test_unplug_recovery(void **state)
{
        struct fx *fx = *state;
        struct sl_link_info li = { .size = sizeof(li) };
        uint64_t cursor = 0;
        size_t n;

        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_unplug.yaml");
        expect_frame(wait_frames(fx, 0, 1), ":AB|N0|D|D");
        assert_string_equal(ops->status(fx->engines[0]), "up");
        assert_true(has_event(fx, 0, "link-state", "state=up"));
        assert_int_equal(sl_events_now(fx->client, &cursor), 0);
        client_write(fx, "CmdThrottle", "10");          /* no period, no on_change: kept */
        peer_frame(&fx->peers[0], ":BA|N0|D1");
        wait_value(fx, "AutoGpsLat", "1");
        check_value(fx, "AutoGpsLat", "1", false);

        fx_unplug(fx, 0);
        wait_state(fx, 0, "down");
        assert_int_equal(sl_link_info(fx->client, 0, &li), 0);
        assert_string_equal(li.state_name, "down: hang-up");
        assert_int_equal(li.state, LINK_SHAREDLINK_STATE_DOWN);
        assert_string_equal(ops->status(fx->engines[0]), "down: hang-up");
        check_value(fx, "AutoGpsLat", "1", true);
        assert_true(has_event(fx, cursor, "link-state", "state=down reason=hang-up"));

        n = fx->peers[0].nrx;
        fx_pty(fx, 0);
        wait_state(fx, 0, "up");
        /* The peer may have restarted: everything at once, with the values kept. */
        expect_frame(wait_frames(fx, 0, n + 1), ":AB|N0|D10|D");
        assert_true(has_event(fx, cursor, "link-state", "state=up"));
        check_value(fx, "AutoGpsLat", "1", true);
        peer_frame(&fx->peers[0], ":BA|N0|D2");
        wait_value(fx, "AutoGpsLat", "2");
        check_value(fx, "AutoGpsLat", "2", false);
        assert_true(ctr(fx, 0, SHM_COUNTER_REOPENS) >= 1);

        /* destroy(): stopped, stale. */
        ops->destroy(fx->engines[0]);
        fx->engines[0] = NULL;
        assert_int_equal(sl_link_info(fx->client, 0, &li), 0);
        assert_string_equal(li.state_name, "stopped");
        check_value(fx, "AutoGpsLat", "2", true);
}

/* UDP on loopback: one datagram per frame, no CR LF, whole frames only. */
static void test_udp(void **state)
{
        struct fx *fx = *state;
        struct peer_end *pe = &fx->peers[0];
        char buf[256];
        size_t n;

        fx_udp(fx, 0);
        fx_start(fx, "link_sharedlink_udp.yaml");
        expect_frame(wait_frames(fx, 0, 1), ":AB|N0|D");
        assert_int_equal(pe->datagrams, 1);
        assert_int_equal(pe->rx_bytes, pe->rx_frame_bytes);     /* no CR LF on UDP */

        /* Two frames in one datagram. */
        n = wire_slp_raw(buf, sizeof(buf), ":BA|N0|D1", false);
        n += wire_slp_raw(buf + n, sizeof(buf) - n, ":BA|N1|D2", false);
        peer_send(pe, buf, n);
        wait_value(fx, "AutoGpsLon", "2");
        check_value(fx, "AutoGpsLat", "1", false);

        /* A trailing partial frame is dropped with its datagram's end. */
        n = wire_slp_raw(buf, sizeof(buf), ":BA|N0|D3", false);
        n += (size_t)snprintf(buf + n, sizeof(buf) - n, "[:BA|N0|D4");
        peer_send(pe, buf, n);
        peer_send(pe, "xyz", 3);
        sync_peer(fx, 0, 'A', 'B');
        check_value(fx, "AutoGpsLat", "3", false);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_RESYNC), 1);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_NOISE_BYTES), 3);

        /* Queries over UDP, answered to the sender. */
        client_write(fx, "CmdThrottle", "5");
        expect_frame(ask(fx, ":BA|QCmdThrottle"), ":AB|RCmdThrottle|D5");
        assert_int_equal(pe->datagrams, pe->nrx);
        assert_int_equal(pe->rx_bytes, pe->rx_frame_bytes);
}

/* ---------------------------------------------------------------------------------------------
 * Control queries (the real control socket; requests routed to the engine as the core does) */

#define CLIENT_LINE_MAX 1024

struct client {
        int fd;
        char buf[CLIENT_LINE_MAX];
        size_t len;
};

static void on_request(struct control_request *req, int argc, char **argv, void *arg)
{
        struct fx *fx = arg;
        struct reqp_request r;
        char err[REQP_ERR_MAX];

        /* The core's part: the request is decoded whole before the engine sees it. */
        if (reqp_decode(argc, argv, &r, err, sizeof(err)) < 0) {
                control_reply_error(req, EINVAL, "%s", err);
                return;
        }
        if (reqp_has_link(r.kind) && link_ops_has_word(ops, reqp_verb(r.kind)))
                for (unsigned i = 0; i < fx->nlinks; i++)
                        if (fx->engines[i] && strcmp(fx->cfg->links[i].name, r.link) == 0) {
                                ops->command(fx->engines[i], req, &r);
                                return;
                        }
        control_reply_error(req, ENOENT, "no such link");
}

static void fx_control(struct fx *fx)
{
        snprintf(fx->sock, sizeof(fx->sock), "%s/ctl.sock", fx->dir);
        assert_int_equal(control_new(fx->loop, fx->sock, 0, 0, on_request, fx, &fx->ctl), 0);
}

/* Connects and sends one request line. */
static void client_request(struct fx *fx, struct client *c, const char *line)
{
        struct sockaddr_un sa = { .sun_family = AF_UNIX };

        assert_true(strlen(fx->sock) < sizeof(sa.sun_path));
        memcpy(sa.sun_path, fx->sock, strlen(fx->sock) + 1);
        c->len = 0;
        c->fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
        assert_true(c->fd >= 0);
        assert_int_equal(connect(c->fd, (struct sockaddr *)&sa, sizeof(sa)), 0);
        assert_int_equal(write(c->fd, line, strlen(line)), (ssize_t)strlen(line));
}

/* Whether the final reply line is there (reads what has arrived, never blocks). */
static bool client_has_reply(struct client *c)
{
        for (;;) {
                ssize_t n = recv(c->fd, c->buf + c->len, sizeof(c->buf) - 1 - c->len,
                                 MSG_DONTWAIT);

                if (n <= 0)
                        break;
                c->len += (size_t)n;
        }
        c->buf[c->len] = '\0';
        return strchr(c->buf, '\n') != NULL;
}

static bool pred_reply(struct fx *fx, const void *arg)
{
        (void)fx;
        return client_has_reply((struct client *)(uintptr_t)arg);
}

/* Waits for the reply line; returns it without the '\n' and closes the connection. */
static const char *client_reply(struct fx *fx, struct client *c)
{
        run_until(fx, pred_reply, c, "a control reply");
        c->buf[strcspn(c->buf, "\n")] = '\0';
        close(c->fd);
        c->fd = -1;
        return c->buf;
}

static void expect_error(const char *reply, int err)
{
        char want[16];

        snprintf(want, sizeof(want), "ERR %d ", err);
        if (strncmp(reply, want, strlen(want)) != 0)
                fail_msg("reply \"%s\", want \"%s...\"", reply, want);
}

/* One request whose reply comes without any wire traffic. */
static const char *request(struct fx *fx, struct client *c, const char *line)
{
        client_request(fx, c, line);
        return client_reply(fx, c);
}

static void test_query_command(void **state)
{
        struct fx *fx = *state;
        struct client c[5];
        uint64_t cursor = 0, timeouts;
        size_t n;

        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_inbound.yaml");
        fx_control(fx);
        sync_peer(fx, 0, 'A', 'B');
        assert_int_equal(sl_events_now(fx->client, &cursor), 0);

        /* The round trip with PROTOCOLS.md's own frames. */
        n = fx->peers[0].nrx;
        client_request(fx, &c[0], "query veh A AutoGpsLat 2000\n");
        assert_string_equal(wait_frames(fx, 0, n + 1), "[:AB|QAutoGpsLat|C2D]");
        peer_send_str(&fx->peers[0], "[:BA|RAutoGpsLat|D40.12345678|C24]\r\n");
        assert_string_equal(client_reply(fx, &c[0]), "OK 40.12345678");
        check_value(fx, "AutoGpsLat", "40.12345678", false);    /* and stored */
        assert_true(has_event(fx, cursor, "query-answer",
                              "peer=A name=AutoGpsLat value=40.12345678"));
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_QUERIES_OUT), 1);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_ANSWERS_IN), 1);

        /* The empty answer (an unknown name at the peer) is "OK " and nothing. */
        n = fx->peers[0].nrx;
        client_request(fx, &c[0], "query veh A Nope\n");
        expect_frame(wait_frames(fx, 0, n + 1), ":AB|QNope");
        peer_frame(&fx->peers[0], ":BA|RNope|D");
        assert_string_equal(client_reply(fx, &c[0]), "OK ");

        /* Several at once, to two peers; an answer counts only from the peer asked. */
        n = fx->peers[0].nrx;
        client_request(fx, &c[0], "query veh A Q1\n");
        client_request(fx, &c[1], "query veh C Q2\n");
        client_request(fx, &c[2], "query veh A Q3\n");
        client_request(fx, &c[3], "query veh A Same\n");
        client_request(fx, &c[4], "query veh A Same\n");
        wait_frames(fx, 0, n + 5);
        peer_frame(&fx->peers[0], ":BA|RQ3|D3");
        assert_string_equal(client_reply(fx, &c[2]), "OK 3");
        peer_frame(&fx->peers[0], ":BA|RQ2|Dfrom A");
        sync_peer(fx, 0, 'A', 'B');
        assert_false(client_has_reply(&c[1]));
        peer_frame(&fx->peers[0], ":BC|RQ2|Dfrom C|RSame|Dnot A");
        assert_string_equal(client_reply(fx, &c[1]), "OK from C");
        peer_frame(&fx->peers[0], ":BA|RSame|Ds|RQ1|D1");
        assert_string_equal(client_reply(fx, &c[0]), "OK 1");
        assert_string_equal(client_reply(fx, &c[3]), "OK s");
        assert_string_equal(client_reply(fx, &c[4]), "OK s");

        /* No answer in time; a late answer is only stored. */
        timeouts = ctr(fx, 0, SHM_COUNTER_TIMEOUTS);
        n = fx->peers[0].nrx;
        client_request(fx, &c[0], "query veh A Slow 100\n");
        expect_frame(wait_frames(fx, 0, n + 1), ":AB|QSlow");
        assert_string_equal(client_reply(fx, &c[0]), "ERR 110 no answer from peer A within 100 ms");
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_TIMEOUTS) - timeouts, 1);
        peer_frame(&fx->peers[0], ":BA|RSlow|D1");
        wait_value(fx, "veh.A.Slow", "1");

        /* Bad requests: nothing goes on the wire. */
        n = fx->peers[0].nrx;
        expect_error(request(fx, &c[0], "query veh Z X\n"), EINVAL);
        expect_error(request(fx, &c[0], "query veh D X\n"), EINVAL);    /* not a peer */
        expect_error(request(fx, &c[0], "query veh AB X\n"), EINVAL);
        expect_error(request(fx, &c[0], "query veh A\n"), EINVAL);
        expect_error(request(fx, &c[0], "query veh A x|y\n"), EINVAL);
        expect_error(request(fx, &c[0], "query veh A X 0\n"), EINVAL);
        expect_error(request(fx, &c[0], "query veh A X 60001\n"), EINVAL);
        expect_error(request(fx, &c[0], "query veh A X 12ms\n"), EINVAL);
        expect_error(request(fx, &c[0], "query veh A X 5 6\n"), EINVAL);
        expect_error(request(fx, &c[0], "query veh A X 5 wait=x\n"), EINVAL);
        assert_int_equal(sync_peer(fx, 0, 'A', 'B'), n);
}

/* At most LINK_SHAREDLINK_QUERIES_MAX pending; clients that left make room. */
static void test_query_bounds(void **state)
{
        struct fx *fx = *state;
        struct client c[LINK_SHAREDLINK_QUERIES_MAX + 1];
        char line[64], text[512];
        size_t n, len;

        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_inbound.yaml");
        fx_control(fx);
        sync_peer(fx, 0, 'A', 'B');

        n = fx->peers[0].nrx;
        for (int i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++) {
                snprintf(line, sizeof(line), "query veh A B%d 60000\n", i);
                client_request(fx, &c[i], line);
        }
        wait_frames(fx, 0, n + LINK_SHAREDLINK_QUERIES_MAX);
        expect_error(request(fx, &c[LINK_SHAREDLINK_QUERIES_MAX], "query veh A One\n"), EBUSY);
        /* One frame answers them all. */
        len = (size_t)snprintf(text, sizeof(text), ":BA");
        for (int i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++)
                len += (size_t)snprintf(text + len, sizeof(text) - len, "|RB%d|D%d", i, i);
        peer_frame(&fx->peers[0], text);
        for (int i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++) {
                snprintf(line, sizeof(line), "OK %d", i);
                assert_string_equal(client_reply(fx, &c[i]), line);
        }

        /* Clients that leave: their queries are still answered (to nobody), and when every
         * slot is taken they are ended first to make room. */
        n = fx->peers[0].nrx;
        for (int i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++) {
                snprintf(line, sizeof(line), "query veh A G%d 60000\n", i);
                client_request(fx, &c[i], line);
        }
        wait_frames(fx, 0, n + LINK_SHAREDLINK_QUERIES_MAX);
        for (int i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++)
                close(c[i].fd);
        sync_peer(fx, 0, 'A', 'B');     /* a round trip: the loop saw the hang-ups */
        n = fx->peers[0].nrx;
        client_request(fx, &c[0], "query veh A Live\n");
        expect_frame(wait_frames(fx, 0, n + 1), ":AB|QLive");
        peer_frame(&fx->peers[0], ":BA|RLive|Dyes");
        assert_string_equal(client_reply(fx, &c[0]), "OK yes");
}

/* A link that is down: ENOTCONN, or wait=MS for it; going down fails what was sent; destroy()
 * ends what is pending with ECANCELED. */
static void test_query_link_down(void **state)
{
        struct fx *fx = *state;
        struct client c[3];
        size_t n;

        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_inbound.yaml");
        fx_control(fx);
        sync_peer(fx, 0, 'A', 'B');

        /* Sent, then the link goes down under it. */
        n = fx->peers[0].nrx;
        client_request(fx, &c[0], "query veh A Gone 60000\n");
        expect_frame(wait_frames(fx, 0, n + 1), ":AB|QGone");
        fx_unplug(fx, 0);
        expect_error(client_reply(fx, &c[0]), ENOTCONN);
        wait_state(fx, 0, "down");
        expect_error(request(fx, &c[0], "query veh A X\n"), ENOTCONN);
        expect_error(request(fx, &c[0], "query veh A X 1000 wait=0\n"), ENOTCONN);
        expect_error(request(fx, &c[0], "query veh A X 1000 wait=20\n"), ENOTCONN);

        /* wait=MS: sent once the link is back. */
        client_request(fx, &c[1], "query veh A Later 5000 wait=20000\n");
        n = fx->peers[0].nrx;
        fx_pty(fx, 0);
        wait_state(fx, 0, "up");
        expect_frame(wait_frames(fx, 0, n + 2), ":AB|QLater");  /* after the full list */
        peer_frame(&fx->peers[0], ":BA|RLater|Dback");
        assert_string_equal(client_reply(fx, &c[1]), "OK back");

        /* destroy() with one pending. */
        n = fx->peers[0].nrx;
        client_request(fx, &c[2], "query veh A Pending 60000\n");
        expect_frame(wait_frames(fx, 0, n + 1), ":AB|QPending");
        ops->destroy(fx->engines[0]);
        fx->engines[0] = NULL;
        expect_error(client_reply(fx, &c[2]), ECANCELED);
}

/* "OK <digits>": a ping's round trip in nanoseconds. */
static void expect_rtt(const char *reply)
{
        size_t digits = strspn(reply + 3, "0123456789");

        if (strncmp(reply, "OK ", 3) != 0 || digits == 0 || reply[3 + digits] != '\0')
                fail_msg("reply \"%s\", want \"OK <nanoseconds>\"", reply);
}

/* ping-peer: P0 to the peer, OK with the round trip at its G0; only G0 from that peer answers,
 * the oldest first; no pong in time, a peer the link lacks, too many pending, the link down
 * (at once, under it, wait=MS) and destroy() each say so. */
static void test_ping_peer(void **state)
{
        struct fx *fx = *state;
        struct client c[LINK_SHAREDLINK_PINGS_MAX + 1];
        char line[64];
        size_t n;

        fx_pty(fx, 0);
        fx_start(fx, "link_sharedlink_inbound.yaml");
        fx_control(fx);
        sync_peer(fx, 0, 'A', 'B');

        n = fx->peers[0].nrx;
        client_request(fx, &c[0], "ping-peer veh A 60000\n");
        expect_frame(wait_frames(fx, 0, n + 1), ":AB|P0");
        peer_frame(&fx->peers[0], ":BC|G0");                    /* another peer's */
        peer_frame(&fx->peers[0], ":BA|G7");                    /* not our ping's */
        sync_peer(fx, 0, 'A', 'B');
        assert_false(client_has_reply(&c[0]));
        peer_frame(&fx->peers[0], ":BA|G0");
        expect_rtt(client_reply(fx, &c[0]));

        /* Two pending to A, one to C: each G0 ends one, the oldest to that peer first. */
        n = fx->peers[0].nrx;
        client_request(fx, &c[0], "ping-peer veh A\n");
        wait_frames(fx, 0, n + 1);
        client_request(fx, &c[1], "ping-peer veh C\n");
        wait_frames(fx, 0, n + 2);
        client_request(fx, &c[2], "ping-peer veh A 60000\n");
        expect_frame(wait_frames(fx, 0, n + 3), ":AB|P0");
        peer_frame(&fx->peers[0], ":BA|G0");
        expect_rtt(client_reply(fx, &c[0]));
        assert_false(client_has_reply(&c[2]));
        peer_frame(&fx->peers[0], ":BC|G0");
        expect_rtt(client_reply(fx, &c[1]));
        peer_frame(&fx->peers[0], ":BA|G0");
        expect_rtt(client_reply(fx, &c[2]));

        /* No pong in time; a late one answers nothing. */
        n = fx->peers[0].nrx;
        client_request(fx, &c[0], "ping-peer veh A 100\n");
        expect_frame(wait_frames(fx, 0, n + 1), ":AB|P0");
        assert_string_equal(client_reply(fx, &c[0]), "ERR 110 no pong from peer A within 100 ms");
        peer_frame(&fx->peers[0], ":BA|G0");

        /* Bad requests: nothing on the wire. */
        n = fx->peers[0].nrx;
        expect_error(request(fx, &c[0], "ping-peer veh D\n"), EINVAL);  /* not a peer */
        expect_error(request(fx, &c[0], "ping-peer veh\n"), EINVAL);
        expect_error(request(fx, &c[0], "ping-peer veh A 0\n"), EINVAL);
        assert_int_equal(sync_peer(fx, 0, 'A', 'B'), n);

        /* Bounded: one more than LINK_SHAREDLINK_PINGS_MAX is EBUSY; a client that left frees
         * its slot. */
        n = fx->peers[0].nrx;
        for (int i = 0; i < LINK_SHAREDLINK_PINGS_MAX; i++)
                client_request(fx, &c[i], "ping-peer veh A 60000\n");
        wait_frames(fx, 0, n + LINK_SHAREDLINK_PINGS_MAX);
        expect_error(request(fx, &c[LINK_SHAREDLINK_PINGS_MAX], "ping-peer veh A\n"), EBUSY);
        close(c[0].fd);
        sync_peer(fx, 0, 'A', 'B');     /* a round trip: the loop saw the hang-up */
        n = fx->peers[0].nrx;
        client_request(fx, &c[0], "ping-peer veh C 60000\n");
        expect_frame(wait_frames(fx, 0, n + 1), ":CB|P0");

        /* The link goes down under them: ENOTCONN for each; while down, at once; wait=MS sends
         * it once the link is back. */
        fx_unplug(fx, 0);
        for (int i = 0; i < LINK_SHAREDLINK_PINGS_MAX; i++)
                expect_error(client_reply(fx, &c[i]), ENOTCONN);
        wait_state(fx, 0, "down");
        expect_error(request(fx, &c[0], "ping-peer veh A\n"), ENOTCONN);
        client_request(fx, &c[1], "ping-peer veh A 60000 wait=20000\n");
        n = fx->peers[0].nrx;
        fx_pty(fx, 0);
        wait_state(fx, 0, "up");
        for (size_t i = n + 1;; i++) {
                const char *f = wait_frames(fx, 0, i);
                char want[TEXT_MAX];

                wire_slp_raw(want, sizeof(want), ":AB|P0", false);
                if (strcmp(f, want) == 0)
                        break;
        }
        peer_frame(&fx->peers[0], ":BA|G0");
        expect_rtt(client_reply(fx, &c[1]));

        /* destroy() with one pending. */
        n = fx->peers[0].nrx;
        snprintf(line, sizeof(line), "ping-peer veh A 60000\n");
        client_request(fx, &c[2], line);
        expect_frame(wait_frames(fx, 0, n + 1), ":AB|P0");
        ops->destroy(fx->engines[0]);
        fx->engines[0] = NULL;
        expect_error(client_reply(fx, &c[2]), ECANCELED);
}

/* ---------------------------------------------------------------------------------------------
 * Pronto4 over UDP (docs/pronto4.md) */

/* A host link (A) toward a Pronto4 (B), and a bulletin link beside it. */
/* The host: the connect sequence at up, each frame its own datagram ending CR LF, SetIP naming
 * the address the engine's socket really has; data typed; commands from the control socket. */
static void test_p4_udp_host(void **state)
{
        struct fx *fx = *state;
        struct peer_end *pe = &fx->peers[0];
        struct client c;
        char text[128];
        size_t n;

        fx_udp(fx, 0);
        fx_udp(fx, 1);
        fx_start(fx, "link_sharedlink_p4_host.yaml");
        fx_control(fx);
        wait_frames(fx, 0, 6);
        snprintf(text, sizeof(text), ":BA|ELink|D0, SetIP, 127.0.0.1:%u, %u",
                 ntohs(pe->engine.sin_port), pe->port);
        expect_frame(pe->rx[0].text, text);
        expect_frame(pe->rx[1].text, ":BA|ELink|D0, outbound, on");
        expect_frame(pe->rx[2].text, ":BA|ELink|D0, inbound, on");
        assert_string_equal(pe->rx[3].text, "[:BA|N0|T0|Qveh_start|T2|Qjoy_steer|CB6]");
        assert_string_equal(pe->rx[4].text, "[:BA|L0|T2|QAutoGpsLat|T4|QVehicleName|C39]");
        expect_frame(pe->rx[5].text, ":BA|N0|D|D");
        assert_int_equal(pe->datagrams, 6);
        assert_int_equal(pe->rx_bytes, pe->rx_frame_bytes + 2 * pe->datagrams);  /* CR LF */
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_COMMANDS_OUT), 3);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_DECLARATIONS_OUT), 2);

        /* The acknowledgement stores nothing; data is type-checked, the rest applied. */
        peer_send_str(pe, "[:AB|N0|Rveh_start|D0|Rjoy_steer|D0|C96]\r\n");
        peer_send_str(pe, "[:AB|N0|D40.5|DVEH_1|C30]\r\n");
        wait_value(fx, "VehicleName", "VEH_1");
        check_value(fx, "AutoGpsLat", "40.5", false);
        peer_frame(pe, ":AB|N0|Dnorth|DVEH_2");
        wait_value(fx, "VehicleName", "VEH_2");
        check_value(fx, "AutoGpsLat", "40.5", false);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_TYPE_MISMATCH), 1);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_ACKS_IN), 1);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_ANSWERS_IN), 0);

        /* A client write goes as the whole list, in its declared types. */
        client_write(fx, "veh_start", "1");
        client_write(fx, "joy_steer", "0");
        sync_peer(fx, 0, 'B', 'A');
        client_request(fx, &c, "command p4h ServoPod 0,TELEOP START\n");
        assert_string_equal(client_reply(fx, &c), "OK");
        n = sync_peer(fx, 0, 'B', 'A');
        assert_string_equal(pe->rx[n - 1].text, "[:BA|EServoPod|D0,TELEOP START|C02]");
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_COMMANDS_OUT), 4);
        /* A bare module request goes out bare, as the clients send it (docs/pronto4.md §9). */
        client_request(fx, &c, "command p4h MUI\n");
        assert_string_equal(client_reply(fx, &c), "OK");
        n = sync_peer(fx, 0, 'B', 'A');
        assert_string_equal(pe->rx[n - 1].text, "[:BA|MUI|CE3]");
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_COMMANDS_OUT), 5);
        expect_error(request(fx, &c, "command p4h MUI x\n"), EINVAL);

        /* Bad commands, and a link with no pronto4 peer: nothing on the wire. */
        expect_error(request(fx, &c, "command p4h\n"), EINVAL);
        expect_error(request(fx, &c, "command p4h Servo!Pod x\n"), EINVAL);
        expect_error(request(fx, &c, "command p4h Link 0123456789 0123456789 0123456789 "
                             "0123456789 0123456789 0123456789\n"), EINVAL);
        expect_error(request(fx, &c, "command bul Link x\n"), EOPNOTSUPP);
        assert_int_equal(sync_peer(fx, 0, 'B', 'A'), n + 1);
}

/* The vehicle side: learns the host's lists into the table; a client writes a learned outbound
 * variable through the table and it goes out as the whole list. */
static void test_p4_udp_vehicle(void **state)
{
        struct fx *fx = *state;
        struct peer_end *pe = &fx->peers[0];
        struct client c;
        size_t n;

        fx->out_spare = 4;
        fx_udp(fx, 0);
        fx_start(fx, "link_sharedlink_p4_vehicle.yaml");
        fx_control(fx);
        /* A learning vehicle says nothing first: a query tells us where it is. */
        client_request(fx, &c, "query p4v A Hello 100\n");
        expect_frame(wait_frames(fx, 0, 1), ":AB|QHello");
        expect_error(client_reply(fx, &c), ETIMEDOUT);

        peer_frame(pe, ":BA|N0|D1|D0");
        peer_send_str(pe, "[:BA|N0|T0|Qveh_start|T2|Qjoy_steer|CB6]\r\n");
        assert_string_equal(wait_frames(fx, 0, 2), "[:AB|N0|Rveh_start|D|Rjoy_steer|D|C36]");
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_UNDECLARED_DATA), 1);
        peer_send_str(pe, "[:BA|L0|T2|QAutoGpsLat|T4|QVehicleName|C39]\r\n");
        assert_string_equal(wait_frames(fx, 0, 3), "[:AB|N0|D|D|CF6]");
        assert_int_equal(pe->rx_bytes, pe->rx_frame_bytes + 2 * pe->datagrams);  /* CR LF */

        /* Learned inbound: the host's data lands in the table. */
        peer_send_str(pe, "[:BA|N0|D1|D0|C57]\r\n");
        wait_value(fx, "p4v.A.veh_start", "1");
        check_value(fx, "p4v.A.joy_steer", "0", false);

        /* Learned outbound: written through the table, sent whole. */
        client_write(fx, "p4v.A.AutoGpsLat", "40.5");
        assert_string_equal(wait_frames(fx, 0, 4), "[:AB|N0|D40.5|D|CBD]");
        client_write(fx, "p4v.A.VehicleName", "VEH_1");
        assert_string_equal(wait_frames(fx, 0, 5), "[:AB|N0|D40.5|DVEH_1|C30]");
        n = sync_peer(fx, 0, 'A', 'B');
        assert_int_equal(n, 5);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_DECLARATIONS_IN), 2);
        assert_int_equal(ctr(fx, 0, SHM_COUNTER_LEARN_FULL), 0);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_declare),
                cmocka_unit_test_setup_teardown(test_inbound_rows, setup, teardown),
                cmocka_unit_test_setup_teardown(test_garbage_megabytes, setup, teardown),
                cmocka_unit_test_setup_teardown(test_outbound_periodic, setup, teardown),
                cmocka_unit_test_setup_teardown(test_outbound_split, setup, teardown),
                cmocka_unit_test_setup_teardown(test_outbound_on_change, setup, teardown),
                cmocka_unit_test_setup_teardown(test_query_answers, setup, teardown),
                cmocka_unit_test_setup_teardown(test_answers_adhoc, setup, teardown),
                cmocka_unit_test_setup_teardown(test_stale, setup, teardown),
                cmocka_unit_test_setup_teardown(test_unplug_recovery, setup, teardown),
                cmocka_unit_test_setup_teardown(test_udp, setup, teardown),
                cmocka_unit_test_setup_teardown(test_p4_udp_host, setup, teardown),
                cmocka_unit_test_setup_teardown(test_p4_udp_vehicle, setup, teardown),
                cmocka_unit_test_setup_teardown(test_query_command, setup, teardown),
                cmocka_unit_test_setup_teardown(test_query_bounds, setup, teardown),
                cmocka_unit_test_setup_teardown(test_query_link_down, setup, teardown),
                cmocka_unit_test_setup_teardown(test_ping_peer, setup, teardown),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
