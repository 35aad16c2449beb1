/*
 * libFuzzer target for datagrams into a SharedLink link over UDP: the real path, a loopback UDP
 * socket of the real transport (src/daemon/transport.c) read by the real channel (channel.c) on
 * the real event loop, one datagram per input() call into the real session
 * (link_sharedlink_session.c, and link_sharedlink_pronto4.c for a pronto4 peer), as
 * link_sharedlink.c wires them; only the shm table behind the session's hooks is a fake.
 *
 * The channel, its loop and the fake peer's socket are made once and kept across inputs (a
 * socket per input would cost more than the input); each input gets a new session. The first
 * bytes of the input choose the link: our address, one or two peers, each bulletin or pronto4,
 * a pronto4 peer as host (declares its configured lists) or as vehicle (learns them, learn_max
 * from the input), CR LF or not. The rest is a program; each datagram is sent from the fake
 * peer's socket and the loop runs until the channel has handed it on:
 *
 *   op 0    a raw datagram: a 2-byte length, then that many bytes (garbage, partial frames)
 *   op 1    a valid frame built from the input (bulletin or pronto4 fields), one datagram
 *   op 2    the same frame cut in two datagrams at a point from the input, then sent whole
 *   op 3    two valid frames in one datagram
 *   op 4    the clock moves on and the session ticks
 *
 * Invariants after every datagram (a broken one is a __builtin_trap()):
 *   - a datagram with a byte other than CR or LF is either decoded into frames (frames_in) or
 *     counted under a reason (noise, resync, overlong, checksum, header, address, field);
 *   - a frame cut across two datagrams is never applied (no frame counted, nothing published),
 *     and does not spoil the next datagram: the same frame whole is decoded at once;
 *   - two frames in one datagram are two frames;
 *   - learned names stay within learn_max per peer and list, ad hoc names within
 *     LINK_SHAREDLINK_ADHOC_MAX; batches never nest and are closed;
 *   - every datagram the link sends back is exactly one frame from our address to a configured
 *     peer, ending with CR LF exactly when the link says so.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "daemon/channel.h"
#include "daemon/config.h"
#include "daemon/link_sharedlink_session.h"
#include "proto/sharedlink.h"
#include "svc/evloop.h"
#include "fuzz/fuzz_input.h"

#define PEERS_MAX       2
#define LIST_MAX        4               /* configured positions per list */
#define LEARN_MAX       6               /* learn_max is 1..LEARN_MAX */
#define VARS_MAX        (LINK_SHAREDLINK_ADHOC_MAX + PEERS_MAX * 2 * LIST_MAX)
#define FIELDS_MAX      10              /* fields in a built frame */
#define STEPS_MAX       256             /* ops per input */
#define START_MS        1000000ull
#define ADDR_TEXT_MAX   64

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

struct var {
        char name[SHM_NAME_SIZE];
        bool inbound, learned, live;
        int peer;                       /* learned: index of the peer, else -1 */
        bool outbound;
};

struct bench {
        uint64_t now;
        bool in_batch;
        struct config_link cfg;
        struct config_var lists[PEERS_MAX][2][LIST_MAX];
        struct var vars[VARS_MAX];
        unsigned n_vars, n_adhoc;
        unsigned learned[PEERS_MAX][2];         /* live learned names by peer, list */
        uint64_t counters[SHM_COUNTER_COUNT];
        uint64_t published;
        struct link_sharedlink_session *session;
        struct slp_decoder check;
};

/* What lives across inputs: the loop, the link's channel and the fake peer's socket. */
struct wire {
        struct evloop *loop;
        struct channel *ch;
        int peer_fd;
        uint64_t handed;                /* datagrams the channel handed on */
};

static struct bench b;
static struct wire w;

/* ---- the fake table --------------------------------------------------------------------------- */

static int peer_index(char address)
{
        for (unsigned i = 0; i < b.cfg.sl.n_peers; i++)
                if (b.cfg.sl.peers[i].address == address)
                        return (int)i;
        return -1;
}

static int hook_send(void *arg, const char *buf, size_t len)
{
        (void)arg;
        return channel_send(w.ch, buf, len);
}

static int hook_find(void *arg, const char *name)
{
        (void)arg;
        for (unsigned i = 0; i < b.n_vars; i++)
                if (b.vars[i].live && strcmp(b.vars[i].name, name) == 0)
                        return (int)i;
        return -ENOENT;
}

static int hook_add(void *arg, const char *name, unsigned type, char peer, bool outbound,
                    int32_t position)
{
        int pi = peer_index(peer);
        const struct config_peer *p;
        struct var *v;

        (void)arg;
        CHECK(shm_layout_name_check(name) == 0);
        CHECK(hook_find(NULL, name) < 0);
        CHECK(type < SHM_TYPE_COUNT);
        CHECK(pi >= 0);
        p = &b.cfg.sl.peers[pi];
        /* Any position of a list (a learned list keeps its declared length, issue 21.7);
         * learn_max bounds how many are live, below. */
        if (position != SHM_POSITION_NONE)
                CHECK((outbound ? p->outbound_learn : p->inbound_learn) && position >= 0 &&
                      (uint32_t)position < CONFIG_LIST_MAX);
        else
                CHECK(!outbound);
        if (b.n_vars >= VARS_MAX)
                return -ENOSPC;
        v = &b.vars[b.n_vars];
        memset(v, 0, sizeof(*v));
        memcpy(v->name, name, strlen(name) + 1);
        v->inbound = !outbound;
        v->outbound = outbound;
        v->live = true;
        v->peer = -1;
        if (position != SHM_POSITION_NONE) {
                v->learned = true;
                v->peer = pi;
                CHECK(++b.learned[pi][outbound] <= p->learn_max);
        }
        CHECK(++b.n_adhoc <= LINK_SHAREDLINK_ADHOC_MAX);
        return (int)b.n_vars++;
}

static int hook_retire(void *arg, uint32_t id)
{
        struct var *v = &b.vars[id];

        (void)arg;
        /* A learned name, or an ad hoc one a declaration makes anew (issue 21.1). */
        CHECK(id < b.n_vars && v->live && (v->learned || v->inbound));
        v->live = false;
        CHECK(b.n_adhoc > 0);
        b.n_adhoc--;
        if (v->learned) {
                CHECK(b.learned[v->peer][v->outbound] > 0);
                b.learned[v->peer][v->outbound]--;
        }
        return 0;
}

static int hook_publish(void *arg, uint32_t id, const char *value, size_t len)
{
        (void)arg;
        (void)value;
        CHECK(b.in_batch);
        CHECK(id < b.n_vars && b.vars[id].live && b.vars[id].inbound);
        b.published++;
        return len > SHM_VALUE_MAX ? -EINVAL : 0;
}

static void hook_stale(void *arg, uint32_t id)
{
        (void)arg;
        CHECK(b.in_batch);
        CHECK(id < b.n_vars && b.vars[id].inbound);
}

static void hook_batch(void *arg, bool begin)
{
        (void)arg;
        CHECK(b.in_batch != begin);
        b.in_batch = begin;
}

static void hook_count(void *arg, enum shm_counter c, uint64_t n)
{
        (void)arg;
        CHECK((unsigned)c < SHM_COUNTER_COUNT);
        b.counters[c] += n;
}

static const struct link_sharedlink_hooks hooks = {
        .send = hook_send,
        .find = hook_find,
        .add = hook_add,
        .retire = hook_retire,
        .publish = hook_publish,
        .stale = hook_stale,
        .batch = hook_batch,
        .count = hook_count,
};

/* ---- the wire ----------------------------------------------------------------------------------- */

static void on_input(struct channel *ch, const uint8_t *data, size_t len, void *arg)
{
        (void)ch;
        (void)arg;
        w.handed++;
        if (b.session)
                link_sharedlink_session_input(b.session, b.now, data, len);
}

static int bound_port(int fd)
{
        struct sockaddr_in sa;
        socklen_t n = sizeof(sa);

        if (getsockname(fd, (struct sockaddr *)&sa, &n) < 0)
                return -errno;
        return ntohs(sa.sin_port);
}

/* The fake peer's socket on a loopback port, the link's channel on another, connected both
 * ways (a connected UDP socket takes datagrams from its peer only). */
static void wire_open(void)
{
        static const struct channel_ops ops = { .input = on_input };
        struct sockaddr_in sa = { .sin_family = AF_INET };
        struct transport_params tp;
        char remote[ADDR_TEXT_MAX];
        int port;

        sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        w.peer_fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
        CHECK(w.peer_fd >= 0);
        CHECK(bind(w.peer_fd, (struct sockaddr *)&sa, sizeof(sa)) == 0);
        port = bound_port(w.peer_fd);
        CHECK(port > 0);
        snprintf(remote, sizeof(remote), "127.0.0.1:%d", port);
        transport_params_init(&tp, TRANSPORT_UDP);
        CHECK(transport_params_set_udp(&tp, "127.0.0.1:0", remote) == 0);
        CHECK(evloop_new(&w.loop) == 0);
        CHECK(channel_new(w.loop, &tp, NULL, &ops, NULL, &w.ch) == 0);
        CHECK(channel_datagram(w.ch));
        CHECK(channel_start(w.ch) == 0);
        port = bound_port(transport_fd(channel_transport(w.ch)));
        CHECK(port > 0);
        sa.sin_port = htons((uint16_t)port);
        CHECK(connect(w.peer_fd, (struct sockaddr *)&sa, sizeof(sa)) == 0);
}

/* Every datagram the link sent back: one frame from us to a configured peer. */
static void drain_replies(void)
{
        static uint8_t buf[TRANSPORT_DATAGRAM_MAX];
        struct slp_decode_result r;
        ssize_t n;

        while ((n = recv(w.peer_fd, buf, sizeof(buf), MSG_DONTWAIT)) > 0) {
                size_t used;

                slp_decoder_reset(&b.check);
                used = slp_decoder_feed(&b.check, buf, (size_t)n, &r);
                CHECK(r.kind == SLP_RESULT_FRAME);
                CHECK(r.frame->src == b.cfg.sl.address);
                CHECK(peer_index(r.frame->dst) >= 0);
                if (b.cfg.sl.crlf)
                        CHECK((size_t)n - used == 2 && buf[used] == '\r' && buf[used + 1] == '\n');
                else
                        CHECK(used == (size_t)n);
        }
        CHECK(n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK));
}

static uint64_t rejected(void)
{
        static const enum shm_counter reasons[] = {
                SHM_COUNTER_NOISE_BYTES, SHM_COUNTER_RESYNC, SHM_COUNTER_OVERLONG,
                SHM_COUNTER_BAD_CHECKSUM, SHM_COUNTER_BAD_HEADER, SHM_COUNTER_BAD_ADDRESS,
                SHM_COUNTER_BAD_FIELD,
        };
        uint64_t sum = 0;

        for (size_t i = 0; i < sizeof(reasons) / sizeof(reasons[0]); i++)
                sum += b.counters[reasons[i]];
        return sum;
}

static bool only_line_ends(const uint8_t *data, size_t len)
{
        for (size_t i = 0; i < len; i++)
                if (data[i] != '\r' && data[i] != '\n')
                        return false;
        return true;
}

/* One datagram from the peer, through the kernel, the transport and the channel. */
static void datagram(const uint8_t *data, size_t len)
{
        uint64_t frames = b.counters[SHM_COUNTER_FRAMES_IN], bad = rejected();
        uint64_t handed = w.handed;
        struct pollfd pfd = { .fd = transport_fd(channel_transport(w.ch)), .events = POLLIN };
        struct channel_stats st;
        uint64_t dropped;

        channel_get_stats(w.ch, &st);
        dropped = st.rx_dropped;
        CHECK(send(w.peer_fd, data, len, 0) == (ssize_t)len);
        /* Loopback delivers within send(): the channel's socket is readable now, so the loop
         * does not wait. */
        CHECK(poll(&pfd, 1, 0) == 1);
        while (w.handed == handed && st.rx_dropped == dropped) {
                CHECK(evloop_run_once(w.loop) == 0);
                channel_get_stats(w.ch, &st);
        }
        /* Larger than the transport takes: dropped whole and counted, never cut. */
        if (len > TRANSPORT_DATAGRAM_MAX) {
                CHECK(w.handed == handed && st.rx_dropped == dropped + 1);
                return;
        }
        CHECK(w.handed == handed + 1 && st.rx_dropped == dropped);
        CHECK(channel_state(w.ch) == CHANNEL_STATE_UP);
        CHECK(!b.in_batch);
        if (!only_line_ends(data, len))
                CHECK(b.counters[SHM_COUNTER_FRAMES_IN] > frames || rejected() > bad);
        drain_replies();
}

/* ---- configuration from the input -------------------------------------------------------------- */

static void declare(struct config_var *v, unsigned peer, bool inbound, unsigned k)
{
        struct var *t = &b.vars[b.n_vars++];

        memset(v, 0, sizeof(*v));
        snprintf(v->name, sizeof(v->name), "%c%u%u", inbound ? 'i' : 'o', peer, k);
        memset(t, 0, sizeof(*t));
        snprintf(t->name, sizeof(t->name), "%s", v->name);
        t->inbound = inbound;
        t->live = true;
        t->peer = -1;
}

static const uint32_t max_frames[] = { SLP_FRAME_MIN, 64, 256, SLP_FRAME_DEFAULT };

static void configure(struct input *in)
{
        struct config_sharedlink *sl = &b.cfg.sl;
        uint8_t flags = take(in);
        unsigned offset = 0;

        b.cfg.protocol = CONFIG_PROTOCOL_SHAREDLINK;
        b.cfg.transport = CONFIG_TRANSPORT_UDP;
        memcpy(b.cfg.name, "udp", 4);
        /* A and B most of the time: the Pronto4 vehicle and host addresses. */
        sl->address = (char)('A' + (flags & 8 ? (flags >> 4) % SLP_ADDR_COUNT : (flags >> 4) & 1));
        sl->n_peers = 1 + (flags & 1);
        sl->crlf = flags & 2;
        for (unsigned i = 0; i < sl->n_peers; i++) {
                struct config_peer *p = &sl->peers[i];
                uint8_t a = take(in), c = take(in);

                /* Offsets from our address 1..15: the second peer's follows the first's. */
                offset = i == 0 ? 1u + a % (SLP_ADDR_COUNT - 1u) : offset % (SLP_ADDR_COUNT - 1u) + 1u;
                p->address = (char)('A' + (sl->address - 'A' + offset) % SLP_ADDR_COUNT);
                p->period_ms = (a >> 3) % 2 ? 100 : 0;
                p->refresh_ms = 1000;
                p->stale_ms = (a >> 4) % 2 ? 500 : 0;
                p->max_frame = max_frames[(a >> 5) % 4];
                p->compression = a & 0x80;
                p->n_outbound = c % (LIST_MAX + 1);
                p->n_inbound = (c >> 3) % (LIST_MAX + 1);
                p->outbound = b.lists[i][0];
                p->inbound = b.lists[i][1];
                if (c & 0x40) {
                        p->dialect = CONFIG_DIALECT_PRONTO4;
                        if (c & 0x80) {         /* a vehicle: learns what the host declares */
                                p->outbound_learn = p->inbound_learn = true;
                                p->n_outbound = p->n_inbound = 0;
                                p->learn_max = 1 + (uint32_t)(c >> 3) % LEARN_MAX;
                        } else {                /* a host: declares its lists */
                                p->declare = p->n_outbound + p->n_inbound > 0;
                        }
                }
                for (unsigned k = 0; k < p->n_outbound; k++)
                        declare(&p->outbound[k], i, false, k);
                for (unsigned k = 0; k < p->n_inbound; k++)
                        declare(&p->inbound[k], i, true, k);
        }
}

/* ---- frames ------------------------------------------------------------------------------------- */

/* Names and values that repeat and collide with the configured ones ("o00", "i10"). */
static const char *const names[] = { "v0", "v1", "i00", "o00", "i10", "o10", "x.y", "bad name" };
static const char *const values[] = { "", "0", "-12", "1.5", "1e308", "abc", "9", "0, a, b" };
static const char *const types[] = { "0", "2", "4", "7", "", "22" };
static const char letters[] = "NDQRTLPGEMDDRQ";

static void field(struct slp_field *f, char letter, const char *value)
{
        *f = (struct slp_field){ .letter = letter, .value = value,
                                 .len = (uint16_t)strlen(value) };
}

/* A frame from a peer (or now and then from an address that is none), encoded; its length. */
static size_t build_frame(struct input *in, char *frame, size_t size)
{
        static const char *const heads[] = { "0", "0", "1", "2", "?" };
        struct slp_field fields[FIELDS_MAX];
        uint8_t hdr = take(in), k = take(in);
        char src = b.cfg.sl.peers[hdr % b.cfg.sl.n_peers].address;
        char dst = hdr & 0x40 ? (char)('A' + (hdr >> 2) % SLP_ADDR_COUNT) : b.cfg.sl.address;
        unsigned nf = 0, entries = take(in) % (FIELDS_MAX / 3);
        int n;

        if (hdr & 0x20)
                src = (char)('A' + (hdr >> 1) % SLP_ADDR_COUNT);
        switch (k % 4) {
        case 0:         /* a declaration, self-describing data or an acknowledgement */
                field(&fields[nf++], k & 4 ? 'L' : 'N', heads[(k >> 3) % 5]);
                for (unsigned e = 0; e < entries; e++) {
                        uint8_t x = take(in);

                        if (!(x & 1))
                                field(&fields[nf++], 'T', types[(x >> 1) % 6]);
                        field(&fields[nf++], x & 0x80 ? 'R' : 'Q', names[(x >> 4) % 8]);
                        if (x & 0x40)
                                field(&fields[nf++], 'D', values[take(in) % 8]);
                }
                break;
        case 1:         /* positional data */
                field(&fields[nf++], 'N', heads[(k >> 3) % 5]);
                for (unsigned e = 0; e <= entries * 2 && nf < FIELDS_MAX; e++)
                        field(&fields[nf++], 'D', values[take(in) % 8]);
                break;
        case 2:         /* any letters */
                for (unsigned e = 0; e <= entries * 2 && nf < FIELDS_MAX; e++) {
                        uint8_t x = take(in);
                        char l = letters[x % (sizeof(letters) - 1)];

                        field(&fields[nf++], l, l == 'N' || l == 'L' ? heads[(x >> 4) % 5] :
                                                l == 'T' ? types[(x >> 4) % 6] :
                                                names[(x >> 4) % 8]);
                }
                break;
        default:        /* E, MU, a ping */
                if (k & 4) {
                        field(&fields[nf++], 'E', names[(k >> 3) % 8]);
                        field(&fields[nf++], 'D', values[(k >> 5) % 8]);
                } else {
                        field(&fields[nf++], k & 8 ? 'M' : 'P', k & 8 ? "UI" : "0");
                }
                break;
        }
        n = slp_frame_encode(frame, size, dst, src, fields, nf,
                             hdr & 0x80 ? SLP_ENCODE_CRLF : 0);
        return n > 0 ? (size_t)n : 0;
}

static void op_raw(struct input *in)
{
        static uint8_t buf[TRANSPORT_DATAGRAM_MAX + 1];
        size_t n = (size_t)take(in) << 8 | take(in);

        /* A length past what a datagram may hold sends one byte more (zeros once the input
         * is used up); a shorter one is cut to what the input has left. */
        if (n > TRANSPORT_DATAGRAM_MAX)
                n = sizeof(buf);
        else if (n > in->n)
                n = in->n;
        for (size_t k = 0; k < n; k++)
                buf[k] = take(in);
        datagram(buf, n);
}

static void op_frame(struct input *in)
{
        char frame[SLP_FRAME_MAX + SLP_CRLF_LEN];
        size_t n = build_frame(in, frame, sizeof(frame));

        if (n > 0)
                datagram((const uint8_t *)frame, n);
}

/* Whether k valid frames came through since frames_in and overlong were read: each is counted
 * in frames_in (and, longer than its peer's max_frame, in overlong too), or is longer than the
 * link's longest max_frame and counted in overlong alone. */
static bool decoded(uint64_t frames, uint64_t overlong, uint64_t k)
{
        uint64_t f = b.counters[SHM_COUNTER_FRAMES_IN] - frames;
        uint64_t o = b.counters[SHM_COUNTER_OVERLONG] - overlong;

        return f <= k && f + o >= k;
}

/* A frame cut in two datagrams is two rejects, never a frame; then the frame whole is one. */
static void op_split(struct input *in)
{
        char frame[SLP_FRAME_MAX + SLP_CRLF_LEN];
        size_t n = build_frame(in, frame, sizeof(frame));
        size_t end = n, cut;
        uint64_t frames, published, overlong;

        while (end > 0 && frame[end - 1] != ']')
                end--;
        if (end < 2)
                return;
        cut = 1 + take(in) % (end - 1);         /* inside '[' ... ']' */
        frames = b.counters[SHM_COUNTER_FRAMES_IN];
        published = b.published;
        datagram((const uint8_t *)frame, cut);
        datagram((const uint8_t *)frame + cut, n - cut);
        CHECK(b.counters[SHM_COUNTER_FRAMES_IN] == frames);
        CHECK(b.published == published);
        overlong = b.counters[SHM_COUNTER_OVERLONG];
        datagram((const uint8_t *)frame, n);
        CHECK(decoded(frames, overlong, 1));
}

static void op_two(struct input *in)
{
        char two[2 * (SLP_FRAME_MAX + SLP_CRLF_LEN)];
        size_t n = build_frame(in, two, sizeof(two) / 2);
        size_t m = n ? build_frame(in, two + n, sizeof(two) / 2) : 0;
        uint64_t frames = b.counters[SHM_COUNTER_FRAMES_IN];
        uint64_t overlong = b.counters[SHM_COUNTER_OVERLONG];

        if (m == 0)
                return;
        datagram((const uint8_t *)two, n + m);
        CHECK(decoded(frames, overlong, 2));
}

static void op_clock(struct input *in)
{
        uint8_t j = take(in);

        b.now += j & 0x80 ? (uint64_t)(j & 0x7f) * 100 : j;
        link_sharedlink_session_tick(b.session, b.now);
        CHECK(link_sharedlink_session_deadline(b.session) > b.now);
        CHECK(!b.in_batch);
        drain_replies();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        struct input in = { data, size };

        if (!w.loop)
                wire_open();
        memset(&b, 0, sizeof(b));
        b.now = START_MS;
        configure(&in);
        CHECK(slp_decoder_init(&b.check, SLP_FRAME_MAX) == 0);
        CHECK(link_sharedlink_session_new(&b.cfg, channel_datagram(w.ch), &hooks, NULL,
                                          &b.session) == 0);
        link_sharedlink_session_up(b.session, b.now);
        drain_replies();
        for (unsigned step = 0; step < STEPS_MAX && in.n > 0; step++) {
                switch (take(&in) % 5) {
                case 0:
                        op_raw(&in);
                        break;
                case 1:
                        op_frame(&in);
                        break;
                case 2:
                        op_split(&in);
                        break;
                case 3:
                        op_two(&in);
                        break;
                default:
                        op_clock(&in);
                        break;
                }
        }
        link_sharedlink_session_down(b.session, b.now);
        b.session = link_sharedlink_session_free(b.session);
        return 0;
}
