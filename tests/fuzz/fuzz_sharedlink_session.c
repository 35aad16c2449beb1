/*
 * libFuzzer target for the SharedLink session (src/daemon/link_sharedlink_session.c): one link
 * whose configuration (our address, up to PEERS_MAX peers with their lists and schedules, byte
 * stream or datagram) comes from the first bytes of the input, wired to a fake table, and driven
 * by a program read from the rest:
 *
 *   op 0    raw bytes (garbage, partial frames) as channel input
 *   op 1    a valid frame built from the input (any letters, values, addresses) as input
 *   op 2    the clock jumps forward (a little or a lot), the session ticks
 *   op 3    a client writes one outbound variable
 *   op 4    the channel goes up or down
 *   op 5    a control query (any peer index, any name, any timeout; its client may leave)
 *   op 6    the channel's queue fills or drains (send refused with -ENOBUFS)
 *   op 7    a Pronto4 frame built to be nearly right: a declaration (N0/L0, T digits 0-9,
 *           names from a small set, some untyped), an acknowledgement, a self-describing
 *           frame, typed data, E, MU, N?/L? (pronto4 peers: host or vehicle, learned lists)
 *   op 8    a command sent (link_sharedlink_session_command(), any peer, module, text)
 *
 * Invariants (a broken one is a __builtin_trap()):
 *   - every hook id names a variable of the fake table; publish and stale only ever touch
 *     inbound variables (a configured inbound one of the right link, or an ad hoc one), and only
 *     inside a batch; batches never nest; values published are within SHM_VALUE_MAX;
 *   - every frame sent decodes as one valid frame, from our address to a configured peer, no
 *     longer than that peer's max_frame; nothing is sent while down;
 *   - sends per operation are bounded; frames_out counts exactly the frames accepted;
 *   - every accepted query is answered exactly once, nothing else is, and nothing stays
 *     pending after free();
 *   - after a tick, no deadline is left in the past (no busy loop); ad hoc variables stay under
 *     LINK_SHAREDLINK_ADHOC_MAX;
 *   - Pronto4: a variable is learned only for a peer that learns that list, at a position of a
 *     list (below CONFIG_LIST_MAX), outbound only when it learns its outbound list (and never published);
 *     every frame toward a pronto4 peer is one whole list starting N0 (only D fields after it,
 *     as many as the list before, unless a frame came in since) or a declaration (N0/L0, then
 *     typed T/Q pairs), an acknowledgement (N0, then R/D pairs), a command (E, D), a reply
 *     (G, R/D pairs) or a query; it ends with CR LF exactly when the link says so; a command
 *     succeeds only while up and only toward a pronto4 peer.
 */
#include <errno.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "daemon/config.h"
#include "daemon/link_sharedlink_session.h"
#include "proto/sharedlink.h"
#include "fuzz/fuzz_input.h"

#define PEERS_MAX       3
#define LIST_MAX        6               /* positions per list */
#define VARS_MAX        (PEERS_MAX * 2 * LIST_MAX + 64)        /* room for ad hoc, learned */
#define RAW_MAX         200             /* raw bytes per op */
#define FIELDS_MAX      12              /* fields in a built frame */
#define STEPS_MAX       2048            /* ops per input */
#define TOKENS_MAX      64              /* queries per input */
/* Per op: a full list per peer, replies to one frame, query timeouts: far below this. */
#define SENDS_PER_OP_MAX 256
#define START_MS        1000000ull

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

struct var {
        char name[SHM_NAME_SIZE];
        bool inbound, adhoc, valid;
        char value[SHM_VALUE_SIZE];
};

/* What the harness knows of a pronto4 peer's whole list: its length, once one went out. */
#define LIST_LEN_UNKNOWN        SIZE_MAX

struct token {
        bool pending;
        bool alive;
        unsigned answers;
};

struct bench {
        uint64_t now;
        bool up;
        bool queue_full;
        bool in_batch;
        struct config_link cfg;
        struct config_var lists[PEERS_MAX][2][LIST_MAX];
        struct var vars[VARS_MAX];
        unsigned n_vars, n_adhoc;
        unsigned out_ids[PEERS_MAX][LIST_MAX];
        struct token tokens[TOKENS_MAX];
        unsigned n_tokens;
        unsigned sends_this_op;
        uint64_t sent, frames_out;
        bool no_local_address;
        size_t list_len[SLP_ADDR_COUNT];        /* by peer address */
        unsigned learned_out[VARS_MAX];         /* ids of learned outbound variables */
        unsigned n_learned_out;
        struct slp_decoder check;
};

static struct bench b;

/* ---- hooks ----------------------------------------------------------------------------------- */

static const struct config_peer *peer_of(char address)
{
        for (unsigned i = 0; i < b.cfg.sl.n_peers; i++)
                if (b.cfg.sl.peers[i].address == address)
                        return &b.cfg.sl.peers[i];
        return NULL;
}

static bool fields_are(const struct slp_frame *f, size_t from, const char *pattern)
{
        size_t k = strlen(pattern);

        if ((f->nfields - from) % k != 0)
                return false;
        for (size_t i = from; i < f->nfields; i++)
                if (f->fields[i].letter != pattern[(i - from) % k])
                        return false;
        return true;
}

/* A reply to one frame: pongs and R|D answers, packed. */
static bool is_reply(const struct slp_frame *f)
{
        for (size_t i = 0; i < f->nfields; i++) {
                if (f->fields[i].letter == 'G')
                        continue;
                if (f->fields[i].letter != 'R' || i + 1 >= f->nfields ||
                    f->fields[i + 1].letter != 'D')
                        return false;
                i++;
        }
        return true;
}

static void check_p4_frame(const struct slp_frame *f)
{
        const struct slp_field *h = &f->fields[0];
        size_t *known = &b.list_len[f->dst_index];
        bool head0 = (h->letter == 'N' || h->letter == 'L') && h->index == 0;

        if (head0 && fields_are(f, 1, "TQ")) {
                for (size_t i = 1; i < f->nfields; i += 2)
                        CHECK(f->fields[i].len == 1 && strchr("024", f->fields[i].value[0]));
                return;                                         /* a declaration */
        }
        /* An acknowledgement, split at N<k> when it does not fit one frame. */
        if (h->letter == 'N' && h->index != SLP_INDEX_QUERY && f->nfields > 1 &&
            fields_are(f, 1, "RD"))
                return;
        if (head0 && h->letter == 'N' && fields_are(f, 1, "D")) {
                /* One whole list: the same length till a frame came in (an L0 may rebind). */
                CHECK(*known == LIST_LEN_UNKNOWN || *known == f->nfields - 1);
                *known = f->nfields - 1;
                return;
        }
        if (h->letter == 'E') {
                CHECK(f->nfields == 2 && f->fields[1].letter == 'D');
                return;
        }
        CHECK(is_reply(f) || (f->nfields == 1 && h->letter == 'Q'));
}

static int hook_send(void *arg, const char *buf, size_t len)
{
        struct slp_decode_result r;
        const struct config_peer *p;
        size_t used;

        (void)arg;
        CHECK(b.up);
        CHECK(++b.sends_this_op <= SENDS_PER_OP_MAX);
        CHECK(len > 0 && len <= SLP_FRAME_MAX + 2);
        slp_decoder_reset(&b.check);
        used = slp_decoder_feed(&b.check, (const uint8_t *)buf, len, &r);
        CHECK(r.kind == SLP_RESULT_FRAME);
        CHECK(r.frame->src == b.cfg.sl.address);
        p = peer_of(r.frame->dst);
        CHECK(p != NULL);
        /* Every frame fits the peer's max_frame, queries included (-EMSGSIZE otherwise). */
        CHECK(len <= p->max_frame);
        /* Only the CR LF of a byte stream (or of a link with crlf) may follow the frame. */
        if (b.cfg.transport != CONFIG_TRANSPORT_UDP || b.cfg.sl.crlf)
                CHECK(len - used == 2 && buf[used] == '\r' && buf[used + 1] == '\n');
        else
                CHECK(used == len);
        if (p->dialect == CONFIG_DIALECT_PRONTO4)
                check_p4_frame(r.frame);
        if (b.queue_full)
                return -ENOBUFS;
        b.sent++;
        return 0;
}

static int hook_find(void *arg, const char *name)
{
        (void)arg;
        CHECK(name && strlen(name) <= SLP_VALUE_MAX + SHM_LINK_NAME_SIZE);
        for (unsigned i = 0; i < b.n_vars; i++)
                if (strcmp(b.vars[i].name, name) == 0)
                        return (int)i;
        return -ENOENT;
}

static int hook_add(void *arg, const char *name, unsigned type, char peer, bool outbound,
                    int32_t position)
{
        struct var *v;

        const struct config_peer *p = peer_of(peer);

        (void)arg;
        CHECK(shm_layout_name_check(name) == 0);
        CHECK(hook_find(NULL, name) < 0);
        CHECK(type < SHM_TYPE_COUNT);
        CHECK(p != NULL);
        /* Learned: only by a peer that learns that list, at a position of a list. (A list keeps
         * its declared length, issue 21.7: learn_max bounds how many positions are mapped, not
         * where they are; tests/unit/test_link_sharedlink_session.c checks the bound.) */
        CHECK(!outbound || (p->outbound_learn && position != SHM_POSITION_NONE));
        if (position != SHM_POSITION_NONE)
                CHECK((outbound ? p->outbound_learn : p->inbound_learn) && position >= 0 &&
                      (uint32_t)position < CONFIG_LIST_MAX);
        if (b.n_vars >= VARS_MAX)
                return -ENOSPC;
        v = &b.vars[b.n_vars];
        memset(v, 0, sizeof(*v));
        memcpy(v->name, name, strlen(name) + 1);
        v->inbound = !outbound;
        v->adhoc = true;
        if (outbound)
                b.learned_out[b.n_learned_out++] = b.n_vars;
        b.n_adhoc++;
        CHECK(b.n_adhoc <= LINK_SHAREDLINK_ADHOC_MAX);
        return (int)b.n_vars++;
}

static int hook_get(void *arg, uint32_t id, char *buf, size_t size)
{
        size_t n;

        (void)arg;
        CHECK(id < b.n_vars);
        CHECK(size >= SHM_VALUE_SIZE);
        if (!b.vars[id].valid)
                return -ENODATA;
        n = strlen(b.vars[id].value);
        memcpy(buf, b.vars[id].value, n + 1);
        return (int)n;
}

static int hook_publish(void *arg, uint32_t id, const char *value, size_t len)
{
        (void)arg;
        CHECK(b.in_batch);
        CHECK(id < b.n_vars);
        CHECK(b.vars[id].inbound);
        CHECK(len > 0);
        /* The table refuses what does not fit a slot, as shm_table_set() does. */
        if (len > SHM_VALUE_MAX)
                return -EINVAL;
        memcpy(b.vars[id].value, value, len);
        b.vars[id].value[len] = '\0';
        b.vars[id].valid = true;
        return 0;
}

static void hook_stale(void *arg, uint32_t id)
{
        (void)arg;
        CHECK(b.in_batch);
        CHECK(id < b.n_vars);
        CHECK(b.vars[id].inbound);
}

static void hook_batch(void *arg, bool begin)
{
        (void)arg;
        CHECK(b.in_batch != begin);
        b.in_batch = begin;
}

static void hook_event(void *arg, enum shm_event_type type, const char *text)
{
        (void)arg;
        CHECK(type == SHM_EVENT_QUERY_ANSWER || type == SHM_EVENT_ADHOC_VARIABLE ||
              type == SHM_EVENT_COMMAND);
        CHECK(text && text[0] && strlen(text) < SHM_EVENT_TEXT_SIZE);
}

static void hook_count(void *arg, enum shm_counter c, uint64_t n)
{
        (void)arg;
        CHECK((unsigned)c < SHM_COUNTER_COUNT);
        CHECK(n > 0);
        if (c == SHM_COUNTER_FRAMES_OUT)
                b.frames_out += n;
}

static void hook_answer(void *arg, void *token, int err, const char *text)
{
        struct token *t = token;

        (void)arg;
        CHECK(t >= b.tokens && t < b.tokens + b.n_tokens);
        CHECK(t->pending);
        CHECK(err >= 0 && text != NULL);
        CHECK(err == 0 ? strlen(text) <= SHM_VALUE_MAX : text[0] != '\0');
        t->pending = false;
        t->answers++;
}

static bool hook_alive(void *arg, void *token)
{
        struct token *t = token;

        (void)arg;
        CHECK(t >= b.tokens && t < b.tokens + b.n_tokens && t->pending);
        return t->alive;
}

static void hook_diag(void *arg, enum log_prio prio, const char *text)
{
        (void)arg;
        (void)prio;
        CHECK(text && strlen(text) < LINK_SHAREDLINK_DIAG_MAX);
}

static int hook_local_address(void *arg, char *buf, size_t size, unsigned *ret_remote_port)
{
        (void)arg;
        if (b.no_local_address)
                return -ENOTSUP;
        *ret_remote_port = 4000;
        return snprintf(buf, size, "127.0.0.1:4220");
}

static const struct link_sharedlink_hooks hooks = {
        .send = hook_send,
        .find = hook_find,
        .add = hook_add,
        .get = hook_get,
        .publish = hook_publish,
        .stale = hook_stale,
        .batch = hook_batch,
        .event = hook_event,
        .count = hook_count,
        .answer = hook_answer,
        .alive = hook_alive,
        .diag = hook_diag,
        .local_address = hook_local_address,
};

/* ---- configuration from the input ------------------------------------------------------------ */

/* Names the harness declares: short, so ad hoc names and queries can hit them. */
static void declare(struct config_var *v, unsigned peer, bool inbound, unsigned k)
{
        struct var *t = &b.vars[b.n_vars++];

        memset(v, 0, sizeof(*v));
        snprintf(v->name, sizeof(v->name), "%c%u%u", inbound ? 'i' : 'o', peer, k);
        memset(t, 0, sizeof(*t));
        snprintf(t->name, sizeof(t->name), "%s", v->name);
        t->inbound = inbound;
}

static const uint32_t periods[] = { 0, 0, 10, 50, 100, 1000 };
static const uint32_t max_frames[] = { SLP_FRAME_MIN, 40, 64, 128, 1024, SLP_FRAME_MAX };

/* Pronto4 from one byte, as config.c allows it: a list learned is not configured, a host
 * (declare) has a configured list and learns nothing. */
static void configure_p4(struct config_peer *p, uint8_t e)
{
        if (!(e & 1))
                return;
        p->dialect = CONFIG_DIALECT_PRONTO4;
        p->outbound_learn = e & 4;
        p->inbound_learn = e & 8;
        if (p->outbound_learn)
                p->n_outbound = 0;
        if (p->inbound_learn)
                p->n_inbound = 0;
        p->declare = (e & 2) && !p->outbound_learn && !p->inbound_learn &&
                     p->n_outbound + p->n_inbound > 0;
        if (p->outbound_learn || p->inbound_learn)
                p->learn_max = 1 + (uint32_t)(e >> 4) % LIST_MAX;
        b.cfg.sl.crlf |= (e & 0x80) != 0;
        b.no_local_address = e & 0x40;
}

static void configure(struct input *in)
{
        struct config_sharedlink *sl = &b.cfg.sl;
        uint8_t flags = take(in);

        b.cfg.protocol = CONFIG_PROTOCOL_SHAREDLINK;
        b.cfg.transport = flags & 1 ? CONFIG_TRANSPORT_UDP : CONFIG_TRANSPORT_PTY;
        memcpy(b.cfg.name, "fz", 3);
        sl->address = (char)('A' + (flags >> 1) % SLP_ADDR_COUNT);
        sl->n_peers = 1 + (flags >> 5) % PEERS_MAX;
        for (unsigned i = 0; i < sl->n_peers; i++) {
                struct config_peer *p = &sl->peers[i];
                uint8_t a = take(in), c = take(in), d = take(in);

                /* Distinct peer addresses (offsets 1..5, 6..10, 11..15), none of them ours. */
                p->address = (char)('A' + (sl->address - 'A' + 1 + i * 5 + a % 5) %
                                    SLP_ADDR_COUNT);
                p->period_ms = periods[(a >> 3) % 6];
                p->refresh_ms = (uint32_t)(c % 8) * 50;
                p->min_interval_ms = (uint32_t)(c >> 3) * 3;
                p->stale_ms = (uint32_t)(d % 4) * 200;
                p->max_frame = max_frames[(d >> 2) % 6];
                p->compression = d & 0x40;
                p->on_change = d & 0x80;
                p->n_outbound = take(in) % (LIST_MAX + 1);
                p->n_inbound = take(in) % (LIST_MAX + 1);
                p->outbound = b.lists[i][0];
                p->inbound = b.lists[i][1];
                for (unsigned k = 0; k < p->n_outbound; k++) {
                        b.out_ids[i][k] = b.n_vars;
                        declare(&p->outbound[k], i, false, k);
                }
                for (unsigned k = 0; k < p->n_inbound; k++)
                        declare(&p->inbound[k], i, true, k);
                configure_p4(p, take(in));
        }
}

/* ---- ops ------------------------------------------------------------------------------------- */

/* Bytes the encoder takes in a value, plus a few names the harness declared. */
static void take_text(struct input *in, char *buf, size_t max, size_t *ret_len)
{
        static const char alphabet[] = "io0123456789 .-_xyzAB";
        size_t n = take(in) % (max + 1);

        for (size_t k = 0; k < n; k++)
                buf[k] = alphabet[take(in) % (sizeof(alphabet) - 1)];
        buf[n] = '\0';
        *ret_len = n;
}

/* Input that may hold a declaration: the whole lists may change length. */
static void input_frame(struct link_sharedlink_session *s, const uint8_t *data, size_t len)
{
        for (unsigned i = 0; i < SLP_ADDR_COUNT; i++)
                b.list_len[i] = LIST_LEN_UNKNOWN;
        link_sharedlink_session_input(s, b.now, data, len);
}

static void op_frame(struct link_sharedlink_session *s, struct input *in)
{
        static const char letters[] = "NDQRTLPGEDDDRQXZ";
        struct slp_field fields[FIELDS_MAX];
        char text[FIELDS_MAX][SLP_VALUE_MAX + 1];
        char frame[SLP_FRAME_MAX + 2];
        uint8_t hdr = take(in);
        unsigned nf = 1 + take(in) % FIELDS_MAX;
        char dst = hdr & 1 ? (char)('A' + (hdr >> 4)) : b.cfg.sl.address;
        char src = b.cfg.sl.peers[(hdr >> 1) % b.cfg.sl.n_peers].address;
        int n;

        if (hdr & 8)
                src = (char)('A' + (hdr >> 4));
        for (unsigned i = 0; i < nf; i++) {
                size_t len;
                uint8_t t = take(in);

                fields[i].letter = letters[t % (sizeof(letters) - 1)];
                if (fields[i].letter == 'N' || fields[i].letter == 'L') {
                        len = (size_t)snprintf(text[i], sizeof(text[i]), t & 0x80 ? "?" : "%u",
                                               (unsigned)take(in) % (LIST_MAX + 3));
                } else {
                        take_text(in, text[i], t & 0x40 ? SLP_VALUE_MAX : 8, &len);
                }
                fields[i].value = text[i];
                fields[i].len = (uint16_t)len;
        }
        n = slp_frame_encode(frame, sizeof(frame), dst, src, fields, nf,
                             b.cfg.transport == CONFIG_TRANSPORT_UDP ? 0 : SLP_ENCODE_CRLF);
        if (n > 0)
                input_frame(s, (const uint8_t *)frame, (size_t)n);
}

static void op_clock(struct link_sharedlink_session *s, struct input *in)
{
        uint8_t j = take(in);

        b.now += j & 0x80 ? (uint64_t)(j & 0x7f) * 1000 : j;
        link_sharedlink_session_tick(s, b.now);
        CHECK(link_sharedlink_session_deadline(s) > b.now);
}

static void op_write(struct link_sharedlink_session *s, struct input *in)
{
        unsigned pi = take(in) % b.cfg.sl.n_peers;
        const struct config_peer *p = &b.cfg.sl.peers[pi];
        char value[SHM_VALUE_SIZE];
        unsigned id;
        size_t len;

        take_text(in, value, SHM_VALUE_MAX, &len);
        if (b.n_learned_out > 0 && (take(in) & 1)) {
                id = b.learned_out[take(in) % b.n_learned_out];
                link_sharedlink_session_outbound(s, b.now, id, value);
                return;
        }
        if (p->n_outbound == 0) {
                /* Not one of the link's ids: ignored. */
                link_sharedlink_session_outbound(s, b.now, VARS_MAX + take(in), value);
                return;
        }
        id = b.out_ids[pi][take(in) % p->n_outbound];
        /* What the table holds after the client's write, as Q answers read it. */
        memcpy(b.vars[id].value, value, len + 1);
        b.vars[id].valid = true;
        link_sharedlink_session_outbound(s, b.now, id, value);
}

static void op_updown(struct link_sharedlink_session *s)
{
        b.up = !b.up;
        if (b.up)
                link_sharedlink_session_up(s, b.now);
        else
                link_sharedlink_session_down(s, b.now);
        CHECK(link_sharedlink_session_is_up(s) == b.up);
}

static void op_query(struct link_sharedlink_session *s, struct input *in)
{
        uint8_t a = take(in);
        char name[SHM_NAME_SIZE + 4];
        size_t len;
        struct token *t;
        int r;

        if (a & 1) {
                /* A client that sent a query earlier leaves. */
                if (b.n_tokens)
                        b.tokens[take(in) % b.n_tokens].alive = false;
                return;
        }
        if (b.n_tokens >= TOKENS_MAX)
                return;
        t = &b.tokens[b.n_tokens++];
        take_text(in, name, (a & 2) ? SHM_NAME_SIZE + 2 : 4, &len);
        t->alive = true;
        t->pending = true;
        r = link_sharedlink_session_query(s, b.now, t, (int)(a >> 4) - 2, name,
                                          1 + (unsigned)take(in) * 20);
        if (r < 0)
                t->pending = false;
        CHECK(r == 0 || r == -EINVAL || r == -ENOTCONN || r == -EBUSY || r == -ENOBUFS ||
              r == -EMSGSIZE);
        CHECK(r != 0 || b.up);
}

/* Names declarations, acknowledgements and self-describing frames use: few, so they repeat,
 * collide with the configured "o01"/"i10" ones and with each other across lists. */
static const char *const p4_names[] = { "v0", "v1", "v2", "i00", "o00", "i10", "x.y", "bad name" };
static const char *const p4_values[] = { "", "0", "-12", "1.5", "1e308", "2e308", "abc", "9" };

static void p4_field(struct slp_field *f, char letter, const char *value)
{
        *f = (struct slp_field){ .letter = letter, .value = value,
                                 .len = (uint16_t)strlen(value) };
}

static void op_p4(struct link_sharedlink_session *s, struct input *in)
{
        static const char *const digits[] = { "0", "2", "4", "4", "0", "7", "", "22" };
        static const char *const heads[] = { "0", "0", "0", "1", "5" };
        static const char *const mu[] = { "UI", "UO", "L", "W", "X" };
        struct slp_field fields[FIELDS_MAX + 2];
        char frame[SLP_FRAME_MAX + 2];
        uint8_t k = take(in), hdr = take(in);
        char src = b.cfg.sl.peers[hdr % b.cfg.sl.n_peers].address;
        unsigned nf = 0, entries = take(in) % (LIST_MAX + 3);
        int n;

        switch (k % 8) {
        case 0:         /* declaration */
        case 1:         /* self-describing */
        case 2:         /* acknowledgement */
                p4_field(&fields[nf++], (k % 8 == 0 && (k & 8)) ? 'L' : 'N', heads[(k >> 4) % 5]);
                for (unsigned e = 0; e < entries && nf + 3 <= FIELDS_MAX; e++) {
                        uint8_t x = take(in);

                        if (k % 8 != 2 && !(x & 1))
                                p4_field(&fields[nf++], 'T', digits[(x >> 1) % 8]);
                        p4_field(&fields[nf++], k % 8 == 2 ? 'R' : 'Q', p4_names[(x >> 4) % 8]);
                        if (k % 8 != 0 && !(x & 8))
                                p4_field(&fields[nf++], 'D', p4_values[take(in) % 8]);
                }
                break;
        case 3:         /* data */
                p4_field(&fields[nf++], 'N', heads[(k >> 4) % 5]);
                for (unsigned e = 0; e < entries; e++)
                        p4_field(&fields[nf++], 'D', p4_values[take(in) % 8]);
                break;
        case 4:
                p4_field(&fields[nf++], 'E', p4_names[(k >> 4) % 8]);
                if (k & 8)
                        p4_field(&fields[nf++], 'D', p4_values[take(in) % 8]);
                break;
        case 5:
                p4_field(&fields[nf++], 'M', mu[(k >> 4) % 5]);
                break;
        case 6:
                p4_field(&fields[nf++], k & 8 ? 'L' : 'N', "?");
                break;
        default:
                p4_field(&fields[nf++], 'P', "0");
                break;
        }
        n = slp_frame_encode(frame, sizeof(frame), b.cfg.sl.address, src, fields, nf,
                             hdr & 0x80 ? SLP_ENCODE_CRLF : 0);
        if (n > 0)
                input_frame(s, (const uint8_t *)frame, (size_t)n);
}

static void op_command(struct link_sharedlink_session *s, struct input *in)
{
        uint8_t a = take(in);
        int peer = (int)(a % (b.cfg.sl.n_peers + 2)) - 1;
        char text[SLP_VALUE_MAX + 4];
        bool p4 = false;
        size_t len;
        int r;

        take_text(in, text, a & 0x80 ? SLP_VALUE_MAX + 2 : 8, &len);
        for (unsigned i = 0; i < b.cfg.sl.n_peers; i++)
                if ((peer < 0 || (unsigned)peer == i) &&
                    b.cfg.sl.peers[i].dialect == CONFIG_DIALECT_PRONTO4)
                        p4 = true;
        r = link_sharedlink_session_command(s, b.now, peer, p4_names[(a >> 4) % 8], text);
        CHECK(r == 0 || r == -EINVAL || r == -ENOTCONN || r == -EOPNOTSUPP || r == -ENOBUFS);
        CHECK(r != 0 || (b.up && p4));
        CHECK(r != -EOPNOTSUPP || !p4);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        struct input in = { data, size };
        struct link_sharedlink_session *s = NULL;
        uint8_t raw[RAW_MAX];

        memset(&b, 0, sizeof(b));
        b.now = START_MS;
        for (unsigned i = 0; i < SLP_ADDR_COUNT; i++)
                b.list_len[i] = LIST_LEN_UNKNOWN;
        configure(&in);
        if (slp_decoder_init(&b.check, SLP_FRAME_MAX) < 0)
                __builtin_trap();
        CHECK(link_sharedlink_session_new(&b.cfg, b.cfg.transport == CONFIG_TRANSPORT_UDP,
                                          &hooks, NULL, &s) == 0);
        for (unsigned step = 0; step < STEPS_MAX && in.n > 0; step++) {
                uint8_t op = take(&in);

                b.sends_this_op = 0;
                switch (op % 9) {
                case 0: {
                        size_t n = take(&in) % RAW_MAX;

                        for (size_t k = 0; k < n; k++)
                                raw[k] = take(&in);
                        input_frame(s, raw, n);
                        break;
                }
                case 1:
                        op_frame(s, &in);
                        break;
                case 2:
                        op_clock(s, &in);
                        break;
                case 3:
                        op_write(s, &in);
                        break;
                case 4:
                        op_updown(s);
                        break;
                case 5:
                        op_query(s, &in);
                        break;
                case 7:
                        op_p4(s, &in);
                        break;
                case 8:
                        op_command(s, &in);
                        break;
                default:
                        b.queue_full = !b.queue_full;
                        break;
                }
                CHECK(!b.in_batch);
                CHECK(b.frames_out == b.sent);
        }
        link_sharedlink_session_free(s);
        for (unsigned i = 0; i < b.n_tokens; i++)
                CHECK(!b.tokens[i].pending && b.tokens[i].answers <= 1);
        return 0;
}
