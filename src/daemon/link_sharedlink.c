/*
 * SharedLink link engine (see link_sharedlink.h for the behaviour it promises).
 *
 * Data flows one way through each path (DESIGN.md §1):
 *     channel bytes -> slp_decoder -> frame_apply() -> shm_table_begin/set/commit, events, counters
 *     client write -> core's outbound scan -> lsl_outbound() -> slp_encode_list -> channel_send
 *     control "query" -> lsl_command() -> Q frame ... R|D frame -> control_reply_ok()
 *
 * Timers, all per peer and armed only while they have something to do, so an idle link with no
 * periodic send never wakes the daemon: the period (while up and the list is not empty), the
 * on-change rate limit (while a write waits for its interval), the stale watch (while values
 * are fresh; re-armed lazily from the last frame's time stamp, not on every frame). Each pending
 * control query has its own timer.
 */
#include "daemon/link_sharedlink.h"

#include <assert.h>
#include <errno.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "daemon/control.h"
#include "daemon/log.h"
#include "proto/sharedlink.h"
#include "shm/table.h"

#define NS_PER_MS               1000000ull
#define CRLF_LEN                2
/* "[:AB" + "|C" + two hex digits + "]": a frame without fields. */
#define FRAME_OVERHEAD          9
#define REPLY_FIELDS_MAX        (SLP_FRAME_MAX / 2)
#define STATUS_MAX              (CHANNEL_REASON_MAX + 16)
#define ADHOC_NAME_SIZE         (SLP_VALUE_MAX + SHM_LINK_NAME_SIZE + 8)
/* A value the codec emits must fit a slot, and a slot's value must be sendable. */
static_assert(SLP_VALUE_MAX == SHM_VALUE_MAX, "codec and shm agree on the longest value");

#define WAIT_PREFIX             "wait="
#define QUERY_ARGC_MIN          4       /* query LINK PEER NAME */
#define QUERY_ARGC_MAX          5       /* ... TIMEOUT_MS */

/* Node address letters as strings, for the directory's peer field (must outlive the config). */
static const char *const addr_names[SLP_ADDR_COUNT] = {
        "A", "B", "C", "D", "E", "F", "G", "H", "I", "J", "K", "L", "M", "N", "O", "P",
};

struct lsl;

/* One peer of the link: its outbound list (what we send) and inbound list (what it sends). */
struct lsl_peer {
        struct lsl *link;
        const struct config_peer *cfg;
        unsigned index;

        size_t n_out;
        uint32_t *out_ids;
        char (*out_values)[SHM_VALUE_SIZE];     /* last value a client wrote, "" before */
        const char **out_ptrs;                  /* out_values[k], for struct slp_list */
        bool *out_dirty;                        /* written (or never sent) since last sent */

        size_t n_in;
        uint32_t *in_ids;

        unsigned refresh_every;                 /* periods between full lists (>= 1) */
        unsigned since_full;                    /* periods since the last full list */
        bool change_sent;                       /* an on-change frame went out already */
        uint64_t last_change_ns;                /* when (evloop_clock_ns) */
        uint64_t last_rx_ns;                    /* last frame from this peer (evloop_now_ns) */

        struct evloop_timer period_timer;
        struct evloop_timer change_timer;
        struct evloop_timer stale_timer;
};

/* Where an outbound variable id lives, for lsl_outbound(); sorted by id. */
struct lsl_outref {
        uint32_t id;
        uint16_t peer;
        uint16_t pos;
};

/* An ad hoc inbound variable this link created. */
struct lsl_adhoc {
        uint32_t id;
        unsigned peer;
};

/* A control query waiting for the link (not sent) or for its answer (sent). */
struct lsl_query {
        struct lsl *link;
        struct control_request *req;            /* NULL: free slot */
        struct lsl_peer *peer;
        char name[SHM_NAME_SIZE];
        unsigned timeout_ms;
        bool sent;
        struct evloop_timer timer;
};

/* Answers and pongs to one received frame, packed into frames of the peer's max_frame. */
struct lsl_reply {
        struct lsl_peer *peer;
        struct slp_field fields[REPLY_FIELDS_MAX];
        size_t nfields;
        char text[SLP_FRAME_MAX];               /* copies of the field values */
        size_t text_used;
        size_t frame_len;                       /* encoded length of fields[0..nfields) */
};

struct lsl {
        struct link_env env;
        const struct config_link *cfg;
        char addr;
        bool crlf;                              /* byte stream: end frames with CR LF */
        bool datagram;
        struct channel *ch;

        enum link_sharedlink_state state;
        char status[STATUS_MAX];

        struct lsl_peer peers[CONFIG_PEERS_MAX];
        unsigned n_peers;
        int peer_of_addr[SLP_ADDR_COUNT];       /* peer index, -1 when not a peer */

        struct lsl_outref *outrefs;
        size_t n_outrefs;

        struct lsl_adhoc *adhoc;
        size_t n_adhoc, cap_adhoc;

        struct lsl_query queries[LINK_SHAREDLINK_QUERIES_MAX];

        struct log_ratelimit rl;
        struct lsl_reply reply;
        char txbuf[SLP_FRAME_MAX];
        struct slp_decoder dec;                 /* about 40 KiB: the engine lives on the heap */
};

static void count(struct lsl *l, enum shm_counter c, uint64_t n)
{
        shm_table_counter_add(l->env.table, l->env.shm_link, c, n);
}

static uint64_t ms_to_ns(uint64_t ms)
{
        return ms * NS_PER_MS;
}

/* Delay in whole milliseconds until deadline (rounded up), 0 if passed. */
static uint64_t ms_until(uint64_t deadline_ns, uint64_t now_ns)
{
        if (deadline_ns <= now_ns)
                return 0;
        return (deadline_ns - now_ns + NS_PER_MS - 1) / NS_PER_MS;
}

/* Copies src into dst[size], cut to fit. */
static void copy_cut(char *dst, size_t size, const char *src)
{
        size_t n = strnlen(src, size - 1);

        memcpy(dst, src, n);
        dst[n] = '\0';
}

static void timer_arm(struct lsl *l, struct evloop_timer *t, uint64_t delay_ms,
                      uint64_t interval_ms)
{
        int r = evloop_timer_arm(t, delay_ms, interval_ms);

        if (r < 0)
                log_warnx("link %s: cannot arm a timer: %s", l->cfg->name, strerror(-r));
}

/* ---------------------------------------------------------------------------------------------
 * State */

static const char *state_word(enum link_sharedlink_state s)
{
        switch (s) {
        case LINK_SHAREDLINK_STATE_UP:
                return "up";
        case LINK_SHAREDLINK_STATE_DOWN:
                return "down";
        case LINK_SHAREDLINK_STATE_STOPPED:
                return "stopped";
        case LINK_SHAREDLINK_STATE_CONNECTING:
        default:
                return "connecting";
        }
}

/* Publishes the state (and an event when its number changes); reason only for DOWN. */
static void state_set(struct lsl *l, enum link_sharedlink_state s, const char *reason)
{
        char name[SHM_STATE_NAME_SIZE];
        char status[STATUS_MAX];
        bool changed = s != l->state;

        if (s == LINK_SHAREDLINK_STATE_DOWN)
                snprintf(status, sizeof(status), "down: %s", reason && *reason ? reason : "?");
        else
                snprintf(status, sizeof(status), "%s", state_word(s));
        if (!changed && strcmp(status, l->status) == 0)
                return;
        snprintf(l->status, sizeof(l->status), "%s", status);
        /* The shm field holds 31 bytes: the reason is cut there, the log line has it all. */
        copy_cut(name, sizeof(name), status);
        shm_table_link_state(l->env.table, l->env.shm_link, (uint32_t)s, name);
        if (!changed)
                return;
        l->state = s;
        if (s == LINK_SHAREDLINK_STATE_DOWN)
                shm_table_eventf(l->env.table, SHM_EVENT_LINK_STATE, l->env.shm_link,
                                 "state=down reason=%s", reason && *reason ? reason : "?");
        else
                shm_table_eventf(l->env.table, SHM_EVENT_LINK_STATE, l->env.shm_link, "state=%s",
                                 state_word(s));
}

/* ---------------------------------------------------------------------------------------------
 * Sending */

static int send_frame(struct lsl *l, const char *buf, size_t len)
{
        int r = channel_send(l->ch, buf, len);

        if (r == 0)
                count(l, SHM_COUNTER_FRAMES_OUT, 1);
        return r;
}

/*
 * Sends positions [first, end) of a peer's outbound list (full: every value; else written ones,
 * the others empty when compressing), split into frames. Positions of frames that went out are
 * no longer dirty. Returns 0, or the first error (positions not sent stay dirty).
 */
static int peer_send_range(struct lsl *l, struct lsl_peer *p, size_t first, size_t end,
                           bool full)
{
        struct slp_list list = {
                .dst = p->cfg->address,
                .src = l->addr,
                .values = p->out_ptrs,
                .changed = p->out_dirty,
                .count = end,
                .max_frame = p->cfg->max_frame,
                .compress = p->cfg->compression,
                .full = full,
                .crlf = l->crlf,
        };
        size_t cursor = first;
        int err = 0;

        while (cursor < end) {
                size_t start = cursor;
                int n = slp_encode_list(&list, &cursor, l->txbuf, sizeof(l->txbuf));

                if (n == 0)
                        break;
                if (n < 0) {
                        /* Only a value too long for max_frame can fail (the table validated the
                         * rest): it can never go to this peer. Counted, then skipped. */
                        count(l, SHM_COUNTER_BAD_VALUE, 1);
                        log_ratelimited(&l->rl, LOG_PRIO_WARNING,
                                        "link %s: peer %c: position %zu does not fit max_frame %u",
                                        l->cfg->name, p->cfg->address, start, p->cfg->max_frame);
                        p->out_dirty[start] = false;
                        cursor = start + 1;
                        err = n;
                        continue;
                }
                int r = send_frame(l, l->txbuf, (size_t)n);
                if (r < 0)
                        return r;
                for (size_t k = start; k < cursor; k++)
                        p->out_dirty[k] = false;
        }
        return err;
}

static int peer_send_full(struct lsl *l, struct lsl_peer *p)
{
        int r = peer_send_range(l, p, 0, p->n_out, true);

        if (r == 0)
                p->since_full = 0;
        return r;
}

/* The on-change frame: the written positions, first to last. */
static void peer_send_changes(struct lsl *l, struct lsl_peer *p)
{
        size_t first = p->n_out, last = 0;
        int r;

        if (l->state != LINK_SHAREDLINK_STATE_UP)
                return;
        for (size_t k = 0; k < p->n_out; k++)
                if (p->out_dirty[k]) {
                        if (first == p->n_out)
                                first = k;
                        last = k;
                }
        if (first == p->n_out)
                return;         /* a periodic frame took them already */
        r = peer_send_range(l, p, first, last + 1, false);
        p->change_sent = true;
        p->last_change_ns = evloop_clock_ns();
        if (r == -ENOBUFS || r == -EAGAIN) {
                /* The channel's queue is full: the values wait, they are never dropped. */
                uint32_t ms = p->cfg->min_interval_ms;

                timer_arm(l, &p->change_timer,
                          ms > LINK_SHAREDLINK_RETRY_MS ? ms : LINK_SHAREDLINK_RETRY_MS, 0);
        }
}

/* A client wrote one of this peer's positions: send now, or when the interval ends. */
static void peer_change_request(struct lsl *l, struct lsl_peer *p)
{
        uint64_t now, min_ns;

        if (!p->cfg->on_change || l->state != LINK_SHAREDLINK_STATE_UP ||
            evloop_timer_armed(&p->change_timer))
                return;
        now = evloop_clock_ns();
        min_ns = ms_to_ns(p->cfg->min_interval_ms);
        if (!p->change_sent || now - p->last_change_ns >= min_ns)
                peer_send_changes(l, p);
        else
                timer_arm(l, &p->change_timer, ms_until(p->last_change_ns + min_ns, now), 0);
}

static void on_change_timer(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        struct lsl_peer *p = arg;

        (void)loop;
        (void)timer;
        peer_send_changes(p->link, p);
}

static void on_period(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        struct lsl_peer *p = arg;
        struct lsl *l = p->link;
        bool full;

        (void)loop;
        (void)timer;
        p->since_full++;
        full = !p->cfg->compression || p->since_full >= p->refresh_every;
        if (peer_send_range(l, p, 0, p->n_out, full) == 0 && full)
                p->since_full = 0;
}

/* ---------------------------------------------------------------------------------------------
 * Staleness */

static void peer_mark_stale(struct lsl *l, struct lsl_peer *p)
{
        shm_table_begin(l->env.table);
        for (size_t k = 0; k < p->n_in; k++)
                shm_table_set_stale(l->env.table, p->in_ids[k], 1);
        for (size_t i = 0; i < l->n_adhoc; i++)
                if (l->adhoc[i].peer == p->index)
                        shm_table_set_stale(l->env.table, l->adhoc[i].id, 1);
        shm_table_commit(l->env.table);
}

static void on_stale_timer(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        struct lsl_peer *p = arg;
        struct lsl *l = p->link;
        uint64_t now = evloop_now_ns(loop);
        uint64_t deadline = p->last_rx_ns + ms_to_ns(p->cfg->stale_ms);

        /* Armed at the first frame after a quiet spell and not moved by later frames: catch up. */
        if (now < deadline) {
                timer_arm(l, timer, ms_until(deadline, now), 0);
                return;
        }
        peer_mark_stale(l, p);
}

static void peer_heard(struct lsl *l, struct lsl_peer *p)
{
        p->last_rx_ns = evloop_now_ns(l->env.loop);
        if (p->cfg->stale_ms > 0 && !evloop_timer_armed(&p->stale_timer))
                timer_arm(l, &p->stale_timer, p->cfg->stale_ms, 0);
}

/* ---------------------------------------------------------------------------------------------
 * Replies (answers to Q, pongs to P) */

static void reply_begin(struct lsl *l, struct lsl_peer *p)
{
        l->reply.peer = p;
        l->reply.nfields = 0;
        l->reply.text_used = 0;
        l->reply.frame_len = FRAME_OVERHEAD + (l->crlf ? CRLF_LEN : 0);
}

static void reply_flush(struct lsl *l)
{
        struct lsl_reply *rp = &l->reply;
        int n;

        if (rp->nfields == 0)
                return;
        n = slp_frame_encode(l->txbuf, sizeof(l->txbuf), rp->peer->cfg->address, l->addr,
                             rp->fields, rp->nfields, l->crlf ? SLP_ENCODE_CRLF : 0);
        if (n > 0)
                send_frame(l, l->txbuf, (size_t)n);
        else
                count(l, SHM_COUNTER_BAD_VALUE, 1);
        reply_begin(l, rp->peer);
}

/* Adds fields that must travel in one frame (R and its D); false if they can never fit. */
static bool reply_add(struct lsl *l, const struct slp_field *fields, size_t n)
{
        struct lsl_reply *rp = &l->reply;
        size_t max = rp->peer->cfg->max_frame;
        size_t base = FRAME_OVERHEAD + (l->crlf ? CRLF_LEN : 0);
        size_t need = 0;

        /* The decoder passes values over SLP_VALUE_MAX (a ping's) that the encoder refuses:
         * taken in, one would make the whole reply frame fail, answers before it included. */
        for (size_t i = 0; i < n; i++) {
                if (fields[i].len > SLP_VALUE_MAX)
                        return false;
                need += 2u + fields[i].len;
        }
        if (base + need > max)
                return false;
        if (rp->frame_len + need > max || rp->nfields + n > REPLY_FIELDS_MAX)
                reply_flush(l);
        for (size_t i = 0; i < n; i++) {
                struct slp_field *f = &rp->fields[rp->nfields++];

                /* text_used <= frame_len <= max_frame <= sizeof(text): the copies fit. */
                memcpy(rp->text + rp->text_used, fields[i].value, fields[i].len);
                f->letter = fields[i].letter;
                f->value = rp->text + rp->text_used;
                f->len = fields[i].len;
                rp->text_used += fields[i].len;
        }
        rp->frame_len += need;
        return true;
}

/* ---------------------------------------------------------------------------------------------
 * Queries from the control socket */

static void query_free(struct lsl_query *q)
{
        evloop_timer_cancel(&q->timer);
        q->req = NULL;
        q->peer = NULL;
        q->sent = false;
}

static void query_fail(struct lsl_query *q, int err, const char *why)
{
        control_reply_error(q->req, err, "%s", why);
        query_free(q);
}

/* Sends Q<name> and starts the answer timeout; fails the query on a send error. */
static void query_send(struct lsl *l, struct lsl_query *q)
{
        char why[64];
        int n, r;

        n = slp_encode_query(l->txbuf, sizeof(l->txbuf), q->peer->cfg->address, l->addr, q->name,
                             l->crlf ? SLP_ENCODE_CRLF : 0);
        r = n < 0 ? n : send_frame(l, l->txbuf, (size_t)n);
        if (r < 0) {
                snprintf(why, sizeof(why), "cannot send the query: %s", strerror(-r));
                query_fail(q, r, why);
                return;
        }
        count(l, SHM_COUNTER_QUERIES_OUT, 1);
        q->sent = true;
        timer_arm(l, &q->timer, q->timeout_ms, 0);
}

static void on_query_timer(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        struct lsl_query *q = arg;
        char why[96];

        (void)loop;
        (void)timer;
        if (!q->req)
                return;
        if (!q->sent) {
                query_fail(q, ENOTCONN, "link down");
                return;
        }
        count(q->link, SHM_COUNTER_TIMEOUTS, 1);
        snprintf(why, sizeof(why), "no answer from peer %c within %u ms", q->peer->cfg->address,
                 q->timeout_ms);
        query_fail(q, ETIMEDOUT, why);
}

/* An answer arrived from p: every query of p waiting for that name gets it. */
static void queries_answer(struct lsl *l, struct lsl_peer *p, const char *name,
                           const char *value)
{
        for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++) {
                struct lsl_query *q = &l->queries[i];

                if (!q->req || !q->sent || q->peer != p || strcmp(q->name, name) != 0)
                        continue;
                shm_table_eventf(l->env.table, SHM_EVENT_QUERY_ANSWER, l->env.shm_link,
                                 "peer=%c name=%s value=%s", p->cfg->address, name, value);
                control_reply_ok(q->req, "%s", value);
                query_free(q);
        }
}

/* The link went down: sent queries cannot be answered; waiting ones keep waiting. */
static void queries_link_down(struct lsl *l)
{
        for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++)
                if (l->queries[i].req && l->queries[i].sent)
                        query_fail(&l->queries[i], ENOTCONN, "link went down");
}

static void queries_link_up(struct lsl *l)
{
        for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++)
                if (l->queries[i].req && !l->queries[i].sent) {
                        evloop_timer_cancel(&l->queries[i].timer);
                        query_send(l, &l->queries[i]);
                }
}

/* A free query slot; when all are taken, those whose client left are ended first. */
static struct lsl_query *query_slot(struct lsl *l)
{
        for (int pass = 0; pass < 2; pass++)
                for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++) {
                        struct lsl_query *q = &l->queries[i];

                        if (!q->req)
                                return q;
                        if (pass == 1 && !control_request_alive(q->req)) {
                                query_fail(q, ECANCELED, "client gone");
                                return q;
                        }
                }
        return NULL;
}

/* Decimal min..max, digits only. */
static bool parse_ms(const char *s, unsigned min, unsigned max, unsigned *ret)
{
        unsigned long v = 0;

        if (!*s)
                return false;
        for (; *s; s++) {
                if (*s < '0' || *s > '9')
                        return false;
                v = v * 10 + (unsigned long)(*s - '0');
                if (v > max)
                        return false;
        }
        if (v < min)
                return false;
        *ret = (unsigned)v;
        return true;
}

static void lsl_command(void *engine, struct control_request *req, int argc, char **argv)
{
        struct lsl *l = engine;
        unsigned timeout = LINK_SHAREDLINK_QUERY_TIMEOUT_MS, wait = 0;
        bool has_wait = false;
        struct lsl_query *q;
        int pi;

        if (argc < 1 || strcmp(argv[0], "query") != 0) {
                control_reply_error(req, EINVAL, "link %s speaks sharedlink: only query",
                                    l->cfg->name);
                return;
        }
        if (argc > QUERY_ARGC_MIN && strncmp(argv[argc - 1], WAIT_PREFIX,
                                             strlen(WAIT_PREFIX)) == 0) {
                if (!parse_ms(argv[argc - 1] + strlen(WAIT_PREFIX), 0,
                              LINK_SHAREDLINK_QUERY_TIMEOUT_MAX_MS, &wait)) {
                        control_reply_error(req, EINVAL, "bad %s", argv[argc - 1]);
                        return;
                }
                has_wait = true;
                argc--;
        }
        if (argc < QUERY_ARGC_MIN || argc > QUERY_ARGC_MAX) {
                control_reply_error(req, EINVAL,
                                    "usage: query LINK PEER NAME [TIMEOUT_MS] [wait=MS]");
                return;
        }
        pi = strlen(argv[2]) == 1 && argv[2][0] >= 'A' && argv[2][0] < 'A' + SLP_ADDR_COUNT ?
             l->peer_of_addr[argv[2][0] - 'A'] : -1;
        if (pi < 0) {
                control_reply_error(req, EINVAL, "%s is not a peer of link %s", argv[2],
                                    l->cfg->name);
                return;
        }
        if (shm_layout_name_check(argv[3]) < 0) {
                control_reply_error(req, EINVAL, "bad variable name");
                return;
        }
        if (argc == QUERY_ARGC_MAX && !parse_ms(argv[4], 1, LINK_SHAREDLINK_QUERY_TIMEOUT_MAX_MS,
                                                &timeout)) {
                control_reply_error(req, EINVAL, "bad timeout %s (1..%u ms)", argv[4],
                                    LINK_SHAREDLINK_QUERY_TIMEOUT_MAX_MS);
                return;
        }
        if (l->state != LINK_SHAREDLINK_STATE_UP && (!has_wait || wait == 0)) {
                control_reply_error(req, ENOTCONN, "link %s is %s", l->cfg->name, l->status);
                return;
        }
        q = query_slot(l);
        if (!q) {
                control_reply_error(req, EBUSY, "%u queries pending on link %s",
                                    LINK_SHAREDLINK_QUERIES_MAX, l->cfg->name);
                return;
        }
        q->req = req;
        q->peer = &l->peers[pi];
        q->timeout_ms = timeout;
        q->sent = false;
        copy_cut(q->name, sizeof(q->name), argv[3]);
        if (l->state == LINK_SHAREDLINK_STATE_UP)
                query_send(l, q);
        else
                timer_arm(l, &q->timer, wait, 0);
}

/* ---------------------------------------------------------------------------------------------
 * Receiving */

static bool peer_has_inbound(const struct lsl_peer *p, uint32_t id)
{
        for (size_t k = 0; k < p->n_in; k++)
                if (p->in_ids[k] == id)
                        return true;
        return false;
}

/* The ad hoc variable "<link>.<peer>.<name>" of p: its id (created if needed), or -1. */
static int adhoc_id(struct lsl *l, struct lsl_peer *p, const char *name)
{
        char full[ADHOC_NAME_SIZE];
        struct shm_var v;
        int id;

        snprintf(full, sizeof(full), "%s.%c.%s", l->cfg->name, p->cfg->address, name);
        if (shm_layout_name_check(full) < 0) {
                count(l, SHM_COUNTER_BAD_VALUE, 1);
                return -1;
        }
        id = shm_table_find(l->env.table, full);
        if (id >= 0) {
                for (size_t i = 0; i < l->n_adhoc; i++)
                        if (l->adhoc[i].id == (uint32_t)id && l->adhoc[i].peer == p->index)
                                return id;
                /* Taken by a configured variable (or another link's): never overwrite it. */
                count(l, SHM_COUNTER_ADHOC_FULL, 1);
                return -1;
        }
        if (l->n_adhoc >= LINK_SHAREDLINK_ADHOC_MAX) {
                count(l, SHM_COUNTER_ADHOC_FULL, 1);
                return -1;
        }
        if (l->n_adhoc == l->cap_adhoc) {
                size_t cap = l->cap_adhoc ? 2 * l->cap_adhoc : 16;
                struct lsl_adhoc *a = realloc(l->adhoc, cap * sizeof(*a));

                if (!a) {
                        count(l, SHM_COUNTER_ADHOC_FULL, 1);
                        return -1;
                }
                l->adhoc = a;
                l->cap_adhoc = cap;
        }
        v = (struct shm_var){
                .name = full,
                .direction = SHM_DIR_IN,
                .type = SHM_TYPE_STRING,
                .link = l->env.shm_link,
                .peer = addr_names[p->cfg->address - 'A'],
                .position = SHM_POSITION_NONE,
        };
        id = shm_table_add(l->env.table, &v);
        if (id < 0) {
                count(l, id == -ENOSPC ? SHM_COUNTER_ADHOC_FULL : SHM_COUNTER_BAD_VALUE, 1);
                return -1;
        }
        l->adhoc[l->n_adhoc++] = (struct lsl_adhoc){ .id = (uint32_t)id, .peer = p->index };
        shm_table_eventf(l->env.table, SHM_EVENT_ADHOC_VARIABLE, l->env.shm_link,
                         "name=%s peer=%c", full, p->cfg->address);
        return id;
}

/* R<name>|D<value> from p. */
static void answer_in(struct lsl *l, struct lsl_peer *p, const struct slp_field *r,
                      const struct slp_field *d)
{
        char name[SLP_VALUE_MAX + 1], value[SLP_VALUE_MAX + 1];
        int id;

        count(l, SHM_COUNTER_ANSWERS_IN, 1);
        if (r->len > SLP_VALUE_MAX || d->len > SLP_VALUE_MAX) {
                count(l, SHM_COUNTER_BAD_VALUE, 1);
                return;
        }
        memcpy(name, r->value, r->len);
        name[r->len] = '\0';
        memcpy(value, d->value, d->len);
        value[d->len] = '\0';
        queries_answer(l, p, name, value);
        /* An empty answer means "unknown name" (PROTOCOLS.md 1.2): nothing to store. */
        if (d->len == 0)
                return;
        id = shm_table_find(l->env.table, name);
        if (id < 0 || !peer_has_inbound(p, (uint32_t)id))
                id = adhoc_id(l, p, name);
        if (id >= 0 && shm_table_set(l->env.table, (uint32_t)id, value, d->len) < 0)
                count(l, SHM_COUNTER_BAD_VALUE, 1);
}

/* Q<name> from p: answer R<name>|D<value>. */
static void query_in(struct lsl *l, const struct slp_field *q)
{
        char name[SLP_VALUE_MAX + 1], value[SHM_VALUE_SIZE];
        struct slp_field pair[2];
        uint32_t flags = 0;
        int id, n = 0;

        count(l, SHM_COUNTER_QUERIES_IN, 1);
        if (q->len > SLP_VALUE_MAX) {
                count(l, SHM_COUNTER_BAD_VALUE, 1);
                return;
        }
        memcpy(name, q->value, q->len);
        name[q->len] = '\0';
        id = shm_table_find(l->env.table, name);
        if (id >= 0)
                n = shm_table_get(l->env.table, (uint32_t)id, value, sizeof(value), &flags);
        if (n < 0 || !(flags & SHM_SLOT_VALID))
                n = 0;
        value[n] = '\0';
        pair[0] = (struct slp_field){ .letter = 'R', .value = q->value, .len = q->len };
        pair[1] = (struct slp_field){ .letter = 'D', .value = value, .len = (uint16_t)n };
        if (reply_add(l, pair, 2))
                count(l, SHM_COUNTER_ANSWERS_OUT, 1);
        else
                count(l, SHM_COUNTER_BAD_VALUE, 1);
}

/* A positional D for position pos of p's list. */
static void data_in(struct lsl *l, struct lsl_peer *p, uint32_t pos, const struct slp_field *d)
{
        if (pos >= p->n_in) {
                /* Decision: dropped and counted; the rest of the frame still applies. */
                count(l, SHM_COUNTER_LIST_MISMATCH, 1);
                return;
        }
        if (d->len == 0)
                return;         /* compression: unchanged since the last transmission */
        if (shm_table_set(l->env.table, p->in_ids[pos], d->value, d->len) < 0)
                count(l, SHM_COUNTER_BAD_VALUE, 1);
}

/* What the next D field belongs to. */
enum next_data {
        NEXT_POSITION,          /* the list position (if known) */
        NEXT_ANSWER,            /* the R just before it */
        NEXT_SKIP,              /* a skipped field (E, a declaration's Q) */
};

/* Walks the fields of a frame from p (see link_sharedlink.h for the meaning of each). */
static void fields_apply(struct lsl *l, struct lsl_peer *p, const struct slp_frame *f)
{
        enum next_data next = NEXT_POSITION;
        const struct slp_field *answer = NULL;
        bool pos_valid = true, decl = false;
        uint32_t pos = 0;      /* Decision: a D with no preceding N starts at position 0 */

        for (size_t i = 0; i < f->nfields; i++) {
                const struct slp_field *fl = &f->fields[i];
                bool after_type = decl;

                if (fl->type == SLP_FIELD_D) {
                        if (next == NEXT_ANSWER) {
                                answer_in(l, p, answer, fl);
                        } else if (next == NEXT_POSITION) {
                                if (pos_valid) {
                                        data_in(l, p, pos, fl);
                                        if (pos < SLP_INDEX_MAX)
                                                pos++;
                                } else {
                                        count(l, SHM_COUNTER_UNKNOWN_FIELD, 1);
                                }
                        }
                        next = NEXT_POSITION;
                        decl = false;
                        continue;
                }
                if (next == NEXT_ANSWER)
                        count(l, SHM_COUNTER_BAD_FIELD, 1);     /* an R without its D */
                next = NEXT_POSITION;
                decl = false;
                switch (fl->type) {
                case SLP_FIELD_N:
                        /* Decision: several N fields are accepted; each resets the position. */
                        pos_valid = fl->index != SLP_INDEX_QUERY;
                        if (pos_valid)
                                pos = fl->index;
                        else
                                count(l, SHM_COUNTER_UNKNOWN_FIELD, 1);         /* "N?" */
                        break;
                case SLP_FIELD_Q:
                        if (after_type) {
                                /* Pronto4 declaration "T<n>|Q<name>[|D<v>]": not a query. */
                                count(l, SHM_COUNTER_UNKNOWN_FIELD, 1);
                                next = NEXT_SKIP;
                        } else {
                                query_in(l, fl);
                        }
                        break;
                case SLP_FIELD_R:
                        next = NEXT_ANSWER;
                        answer = fl;
                        break;
                case SLP_FIELD_P:
                        /* Ping: pong with the same value ("P0" -> "G0"). */
                        if (!reply_add(l, &(struct slp_field){ .letter = 'G', .value = fl->value,
                                                              .len = fl->len }, 1))
                                count(l, SHM_COUNTER_BAD_VALUE, 1);
                        break;
                case SLP_FIELD_G:
                        break;          /* a pong: the frame itself shows the peer is alive */
                case SLP_FIELD_T:
                        count(l, SHM_COUNTER_UNKNOWN_FIELD, 1);
                        decl = true;
                        break;
                case SLP_FIELD_L:
                        count(l, SHM_COUNTER_UNKNOWN_FIELD, 1);
                        pos_valid = false;
                        break;
                case SLP_FIELD_E:
                        count(l, SHM_COUNTER_UNKNOWN_FIELD, 1);
                        next = NEXT_SKIP;
                        break;
                default:
                        /* Decision: unknown field types are skipped and counted. */
                        count(l, SHM_COUNTER_UNKNOWN_FIELD, 1);
                        break;
                }
        }
        if (next == NEXT_ANSWER)
                count(l, SHM_COUNTER_BAD_FIELD, 1);
}

static void frame_apply(struct lsl *l, const struct slp_frame *f)
{
        struct lsl_peer *p;
        int pi;

        count(l, SHM_COUNTER_FRAMES_IN, 1);
        if (f->dst != l->addr) {
                count(l, SHM_COUNTER_NOT_FOR_US, 1);
                return;
        }
        pi = l->peer_of_addr[f->src_index];
        if (pi < 0) {
                count(l, SHM_COUNTER_UNKNOWN_PEER, 1);
                return;
        }
        p = &l->peers[pi];
        if (f->raw_len > p->cfg->max_frame) {
                count(l, SHM_COUNTER_OVERLONG, 1);
                return;
        }
        if (f->empty_fields > 0)
                count(l, SHM_COUNTER_EMPTY_FIELD, f->empty_fields);
        peer_heard(l, p);
        reply_begin(l, p);
        /* One batch per frame: clients see the whole frame at once, one change-word bump. */
        shm_table_begin(l->env.table);
        fields_apply(l, p, f);
        shm_table_commit(l->env.table);
        reply_flush(l);
}

static void result_count(struct lsl *l, const struct slp_decode_result *r)
{
        enum shm_counter c;
        uint64_t n = 1;

        switch (r->reason) {
        case SLP_REASON_NOISE:
                c = SHM_COUNTER_NOISE_BYTES;
                n = r->bytes;
                break;
        case SLP_REASON_RESYNC:
        case SLP_REASON_TRUNCATED:
                c = SHM_COUNTER_RESYNC;
                break;
        case SLP_REASON_OVERLONG:
                c = SHM_COUNTER_OVERLONG;
                break;
        case SLP_REASON_NO_CHECKSUM:
        case SLP_REASON_BAD_CHECKSUM_SYNTAX:
        case SLP_REASON_BAD_CHECKSUM:
                c = SHM_COUNTER_BAD_CHECKSUM;
                break;
        case SLP_REASON_BAD_HEADER:
                c = SHM_COUNTER_BAD_HEADER;
                break;
        case SLP_REASON_BAD_ADDRESS:
                c = SHM_COUNTER_BAD_ADDRESS;
                break;
        case SLP_REASON_BAD_FIELD:
        case SLP_REASON_NO_FIELDS:
        default:
                c = SHM_COUNTER_BAD_FIELD;
                break;
        }
        count(l, c, n);
        if (r->reason != SLP_REASON_NOISE)
                log_ratelimited(&l->rl, LOG_PRIO_DEBUG, "link %s: dropped %zu bytes: %s",
                                l->cfg->name, r->bytes, slp_decode_reason_str(r->reason));
}

static void handle_result(struct lsl *l, const struct slp_decode_result *r)
{
        if (r->kind == SLP_RESULT_FRAME)
                frame_apply(l, r->frame);
        else if (r->kind == SLP_RESULT_REJECT)
                result_count(l, r);
}

static void on_input(struct channel *ch, const uint8_t *data, size_t len, void *arg)
{
        struct lsl *l = arg;
        struct slp_decode_result r;

        (void)ch;
        while (len > 0) {
                size_t n = slp_decoder_feed(&l->dec, data, len, &r);

                data += n;
                len -= n;
                handle_result(l, &r);
        }
        /* A datagram carries whole frames: a partial one at its end is dropped (PROTOCOLS 1.4). */
        if (l->datagram && slp_decoder_end(&l->dec, &r))
                handle_result(l, &r);
        link_publish_channel_stats(&l->env, l->ch);
}

/* ---------------------------------------------------------------------------------------------
 * Channel up and down */

static void peers_stop_timers(struct lsl *l)
{
        for (unsigned i = 0; i < l->n_peers; i++) {
                evloop_timer_cancel(&l->peers[i].period_timer);
                evloop_timer_cancel(&l->peers[i].change_timer);
                evloop_timer_cancel(&l->peers[i].stale_timer);
        }
}

static void link_up(struct lsl *l)
{
        log_info("link %s: up (%s)", l->cfg->name, channel_device(l->ch));
        slp_decoder_reset(&l->dec);
        state_set(l, LINK_SHAREDLINK_STATE_UP, NULL);
        for (unsigned i = 0; i < l->n_peers; i++) {
                struct lsl_peer *p = &l->peers[i];

                if (p->n_out == 0)
                        continue;
                /* The peer may have restarted: it gets everything at once. */
                peer_send_full(l, p);
                p->change_sent = false;
                if (p->cfg->period_ms > 0)
                        timer_arm(l, &p->period_timer, p->cfg->period_ms, p->cfg->period_ms);
        }
        queries_link_up(l);
        link_publish_channel_stats(&l->env, l->ch);
}

static void link_down(struct lsl *l, const char *reason, unsigned retry_ms)
{
        if (l->state == LINK_SHAREDLINK_STATE_UP || l->state == LINK_SHAREDLINK_STATE_CONNECTING)
                log_warnx("link %s: down: %s (retry in %u ms)", l->cfg->name, reason, retry_ms);
        peers_stop_timers(l);
        shm_table_set_link_stale(l->env.table, l->env.shm_link, 1);
        queries_link_down(l);
        state_set(l, LINK_SHAREDLINK_STATE_DOWN, reason);
        link_publish_channel_stats(&l->env, l->ch);
}

static void on_channel_up(struct channel *ch, void *arg)
{
        (void)ch;
        link_up(arg);
}

static void on_channel_down(struct channel *ch, const char *reason, unsigned retry_ms, void *arg)
{
        (void)ch;
        link_down(arg, reason, retry_ms);
}

/* ---------------------------------------------------------------------------------------------
 * Set-up and tear-down */

static unsigned shm_type_of(enum config_var_type t)
{
        switch (t) {
        case CONFIG_VAR_LONG:
                return SHM_TYPE_LONG;
        case CONFIG_VAR_DOUBLE:
                return SHM_TYPE_DOUBLE;
        case CONFIG_VAR_STRING:
        default:
                return SHM_TYPE_STRING;
        }
}

static int lsl_declare(const struct config_link *cfg, uint32_t link_index, struct shm_var *vars,
                      size_t *n, size_t max, char *names_buf, size_t names_size,
                      size_t *names_used)
{
        const struct config_sharedlink *sl = &cfg->sl;
        size_t need = 0, at = *n;

        /* Names point into cfg and peers into addr_names: nothing goes to names_buf. */
        (void)names_buf;
        (void)names_size;
        (void)names_used;
        if (cfg->protocol != CONFIG_PROTOCOL_SHAREDLINK)
                return -EINVAL;
        for (unsigned i = 0; i < sl->n_peers; i++) {
                char a = sl->peers[i].address;

                if (a < 'A' || a >= 'A' + SLP_ADDR_COUNT)
                        return -EINVAL;
                need += (size_t)sl->peers[i].n_outbound + sl->peers[i].n_inbound;
        }
        if (at > max || need > max - at)
                return -ENOSPC;
        for (unsigned i = 0; i < sl->n_peers; i++) {
                const struct config_peer *p = &sl->peers[i];
                const char *peer = addr_names[p->address - 'A'];

                for (unsigned k = 0; k < p->n_outbound; k++)
                        vars[at++] = (struct shm_var){
                                .name = p->outbound[k].name,
                                .direction = SHM_DIR_OUT,
                                .type = shm_type_of(p->outbound[k].type),
                                .link = link_index,
                                .peer = peer,
                                .position = (int32_t)k,
                        };
                for (unsigned k = 0; k < p->n_inbound; k++)
                        vars[at++] = (struct shm_var){
                                .name = p->inbound[k].name,
                                .direction = SHM_DIR_IN,
                                .type = shm_type_of(p->inbound[k].type),
                                .link = link_index,
                                .peer = peer,
                                .position = (int32_t)k,
                        };
        }
        *n = at;
        return 0;
}

static int outref_cmp(const void *a, const void *b)
{
        const struct lsl_outref *x = a, *y = b;

        return (x->id > y->id) - (x->id < y->id);
}

/* Resolves the ids of one list (declared by lsl_declare before the table was made). */
static int find_ids(struct lsl *l, const struct config_var *vars, size_t n, uint32_t *ids)
{
        for (size_t k = 0; k < n; k++) {
                int id = shm_table_find(l->env.table, vars[k].name);

                if (id < 0) {
                        log_warnx("link %s: variable %s is not in the table", l->cfg->name,
                                  vars[k].name);
                        return -ENOENT;
                }
                ids[k] = (uint32_t)id;
        }
        return 0;
}

static int peer_init(struct lsl *l, unsigned index)
{
        struct lsl_peer *p = &l->peers[index];
        const struct config_peer *c = &l->cfg->sl.peers[index];
        int r;

        p->link = l;
        p->cfg = c;
        p->index = index;
        p->n_out = c->n_outbound;
        p->n_in = c->n_inbound;
        evloop_timer_init(&p->period_timer, l->env.loop, on_period, p);
        evloop_timer_init(&p->change_timer, l->env.loop, on_change_timer, p);
        evloop_timer_init(&p->stale_timer, l->env.loop, on_stale_timer, p);
        p->out_ids = calloc(p->n_out + 1, sizeof(*p->out_ids));
        p->out_values = calloc(p->n_out + 1, sizeof(*p->out_values));
        p->out_ptrs = calloc(p->n_out + 1, sizeof(*p->out_ptrs));
        p->out_dirty = calloc(p->n_out + 1, sizeof(*p->out_dirty));
        p->in_ids = calloc(p->n_in + 1, sizeof(*p->in_ids));
        if (!p->out_ids || !p->out_values || !p->out_ptrs || !p->out_dirty || !p->in_ids)
                return -ENOMEM;
        for (size_t k = 0; k < p->n_out; k++) {
                p->out_ptrs[k] = p->out_values[k];
                p->out_dirty[k] = true;         /* never sent */
        }
        r = find_ids(l, c->outbound, p->n_out, p->out_ids);
        if (r == 0)
                r = find_ids(l, c->inbound, p->n_in, p->in_ids);
        if (r < 0)
                return r;
        /* At least every refresh_ms: the largest whole number of periods that fits. */
        p->refresh_every = c->period_ms > 0 ? c->refresh_ms / c->period_ms : 1;
        if (p->refresh_every == 0)
                p->refresh_every = 1;
        l->peer_of_addr[c->address - 'A'] = (int)index;
        return 0;
}

static int outrefs_init(struct lsl *l)
{
        size_t n = 0;

        for (unsigned i = 0; i < l->n_peers; i++)
                n += l->peers[i].n_out;
        l->outrefs = calloc(n + 1, sizeof(*l->outrefs));
        if (!l->outrefs)
                return -ENOMEM;
        for (unsigned i = 0; i < l->n_peers; i++)
                for (size_t k = 0; k < l->peers[i].n_out; k++)
                        l->outrefs[l->n_outrefs++] = (struct lsl_outref){
                                .id = l->peers[i].out_ids[k],
                                .peer = (uint16_t)i,
                                .pos = (uint16_t)k,
                        };
        qsort(l->outrefs, l->n_outrefs, sizeof(*l->outrefs), outref_cmp);
        return 0;
}

static void engine_free(struct lsl *l)
{
        for (unsigned i = 0; i < CONFIG_PEERS_MAX; i++) {
                struct lsl_peer *p = &l->peers[i];

                free(p->out_ids);
                free(p->out_values);
                free(p->out_ptrs);
                free(p->out_dirty);
                free(p->in_ids);
        }
        free(l->outrefs);
        free(l->adhoc);
        free(l);
}

static int lsl_create(const struct link_env *env, void **ret_engine)
{
        static const struct channel_ops ch_ops = {
                .up = on_channel_up,
                .down = on_channel_down,
                .input = on_input,
        };
        const struct config_link *cfg = env->cfg;
        size_t max_frame = SLP_FRAME_MIN;
        struct lsl *l;
        int r;

        if (cfg->protocol != CONFIG_PROTOCOL_SHAREDLINK || cfg->sl.n_peers > CONFIG_PEERS_MAX)
                return -EINVAL;
        l = calloc(1, sizeof(*l));
        if (!l)
                return -ENOMEM;
        l->env = *env;
        l->cfg = cfg;
        l->addr = cfg->sl.address;
        l->datagram = cfg->transport == CONFIG_TRANSPORT_UDP;
        l->crlf = !l->datagram;
        l->n_peers = cfg->sl.n_peers;
        l->state = LINK_SHAREDLINK_STATE_CONNECTING;
        snprintf(l->status, sizeof(l->status), "%s", state_word(l->state));
        log_ratelimit_init(&l->rl, cfg->name, LOG_RATELIMIT_INTERVAL_MS, LOG_RATELIMIT_BURST);
        for (unsigned i = 0; i < SLP_ADDR_COUNT; i++)
                l->peer_of_addr[i] = -1;
        for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++) {
                l->queries[i].link = l;
                evloop_timer_init(&l->queries[i].timer, env->loop, on_query_timer,
                                  &l->queries[i]);
        }
        for (unsigned i = 0; i < l->n_peers; i++) {
                r = peer_init(l, i);
                if (r < 0)
                        goto fail;
                if (cfg->sl.peers[i].max_frame > max_frame)
                        max_frame = cfg->sl.peers[i].max_frame;
        }
        if (max_frame > SLP_FRAME_MAX)
                max_frame = SLP_FRAME_MAX;
        r = outrefs_init(l);
        if (r < 0)
                goto fail;
        r = slp_decoder_init(&l->dec, max_frame);
        if (r < 0)
                goto fail;
        r = link_channel_new(env, &ch_ops, l, &l->ch);
        if (r < 0)
                goto fail;

        /* Nothing heard yet: what the table holds is not current. */
        shm_table_set_link_stale(env->table, env->shm_link, 1);
        shm_table_link_state(env->table, env->shm_link, (uint32_t)l->state, l->status);
        r = channel_start(l->ch);
        /* channel_start() calls no callback: report its outcome the way the loop would. */
        if (r == 0)
                link_up(l);
        else
                link_down(l, channel_reason(l->ch), channel_retry_ms(l->ch));
        *ret_engine = l;
        return 0;
fail:
        /* No timer is armed before the channel starts. */
        engine_free(l);
        return r;
}

static void lsl_destroy(void *engine)
{
        struct lsl *l = engine;

        if (!l)
                return;
        peers_stop_timers(l);
        for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++)
                if (l->queries[i].req)
                        query_fail(&l->queries[i], ECANCELED, "link stopped");
        l->ch = channel_free(l->ch);
        shm_table_set_link_stale(l->env.table, l->env.shm_link, 1);
        state_set(l, LINK_SHAREDLINK_STATE_STOPPED, NULL);
        engine_free(l);
}

static void lsl_outbound(void *engine, const struct shm_out_change *change)
{
        struct lsl *l = engine;
        struct lsl_outref key = { .id = change->id };
        const struct lsl_outref *ref;
        struct lsl_peer *p;

        /* Invalid writes never reach the wire; a repaired slot keeps the last good value. */
        if (change->status != SHM_OUT_CHANGED)
                return;
        ref = bsearch(&key, l->outrefs, l->n_outrefs, sizeof(*l->outrefs), outref_cmp);
        if (!ref)
                return;
        p = &l->peers[ref->peer];
        copy_cut(p->out_values[ref->pos], SHM_VALUE_SIZE, change->value);
        p->out_dirty[ref->pos] = true;
        peer_change_request(l, p);
}

/* The core's heartbeat: channel counters move while down too (reopen attempts). */
static void lsl_heartbeat(void *engine)
{
        struct lsl *l = engine;

        link_publish_channel_stats(&l->env, l->ch);
}

static const char *lsl_status(void *engine)
{
        struct lsl *l = engine;

        return l->status;
}

const struct link_ops link_sharedlink_ops = {
        .declare = lsl_declare,
        .create = lsl_create,
        .destroy = lsl_destroy,
        .outbound = lsl_outbound,
        .command = lsl_command,
        .status = lsl_status,
        .heartbeat = lsl_heartbeat,
};
