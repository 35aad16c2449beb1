/*
 * SharedLink link session (link_sharedlink_session.h; the behaviour is in link_sharedlink.h).
 *
 * Data flows one way through each path:
 *     bytes -> slp_decoder -> frame_apply() -> publish/stale/event/count hooks, reply frames
 *     client write -> outbound() -> slp_encode_list -> send hook
 *     query() -> Q frame ... R|D frame -> answer hook
 *
 * Schedules are deadlines, one per peer and kind, LINK_SHAREDLINK_NEVER while they have nothing
 * to do, so an idle link with no periodic send asks for no wake-up: the period (while up and the
 * list is not empty), the on-change rate limit (while a write waits for its interval), the stale
 * watch (while values are fresh), and each sent query's timeout.
 */
#include "daemon/link_sharedlink_session.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "daemon/link_sharedlink_peers.h"
#include "daemon/link_sharedlink_pronto4.h"
#include "proto/sharedlink.h"


/* ---------------------------------------------------------------------------------------------
 * Hooks */

static void batch(struct link_sharedlink_session *s, bool begin)
{
        if (s->h->batch)
                s->h->batch(s->arg, begin);
}

static void stale(struct link_sharedlink_session *s, uint32_t id)
{
        if (s->h->stale)
                s->h->stale(s->arg, id);
}

static uint64_t min_deadline(uint64_t a, uint64_t b)
{
        return a < b ? a : b;
}

/* Copies src into dst[size], cut to fit. */
static void copy_cut(char *dst, size_t size, const char *src)
{
        size_t n = strnlen(src, size - 1);

        memcpy(dst, src, n);
        dst[n] = '\0';
}

/* ---------------------------------------------------------------------------------------------
 * Sending */

/* The on-change frame: the written positions, first to last. */
static void peer_send_changes(struct link_sharedlink_session *s, struct sls_peer *p,
                              uint64_t now)
{
        size_t first = p->out.n, last = 0;
        int r;

        p->change_at = LINK_SHAREDLINK_NEVER;
        if (!s->up)
                return;
        for (size_t k = 0; k < p->out.n; k++)
                if (p->out_dirty[k]) {
                        if (first == p->out.n)
                                first = k;
                        last = k;
                }
        if (first == p->out.n)
                return;         /* a periodic frame took them already */
        r = sls_send_range(s, p, first, last + 1, false);
        p->change_sent = true;
        p->last_change_ms = now;
        if (r == -ENOBUFS || r == -EAGAIN) {
                /* The channel's queue is full: the values wait, they are never dropped. */
                uint32_t ms = p->cfg->min_interval_ms;

                p->change_at = now + (ms > LINK_SHAREDLINK_RETRY_MS ? ms
                                                                    : LINK_SHAREDLINK_RETRY_MS);
        }
}

/* A client wrote one of this peer's positions: send now, or when the interval ends. */
static void peer_change_request(struct link_sharedlink_session *s, struct sls_peer *p,
                                uint64_t now)
{
        uint64_t min_ms = p->cfg->min_interval_ms;

        if (!p->cfg->on_change || !s->up || p->change_at != LINK_SHAREDLINK_NEVER)
                return;
        if (!p->change_sent || now - p->last_change_ms >= min_ms)
                peer_send_changes(s, p, now);
        else
                p->change_at = p->last_change_ms + min_ms;
}

/* One period: the list, full every refresh_every periods (always without compression). The
 * cadence counts periods, not wall time; a late tick does not send twice. */
static void peer_period(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now)
{
        uint64_t period = p->cfg->period_ms;
        bool full;

        p->period_at += period;
        if (p->period_at <= now)
                p->period_at = now + period;
        p->since_full++;
        full = !p->cfg->compression || p->since_full >= p->refresh_every;
        if (sls_send_range(s, p, 0, p->out.n, full) == 0 && full)
                p->since_full = 0;
}

/* ---------------------------------------------------------------------------------------------
 * Staleness */

static void peer_mark_stale(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now)
{
        p->stale_at = LINK_SHAREDLINK_NEVER;
        batch(s, true);
        for (size_t k = 0; k < p->in.n; k++)
                if (p->in.ids[k] != SLS_UNMAPPED)
                        stale(s, p->in.ids[k]);
        for (size_t i = 0; i < s->n_adhoc; i++)
                if (s->adhoc[i].peer == p->index && s->adhoc[i].made != SLS_MADE_LEARNED_OUT)
                        stale(s, s->adhoc[i].id);
        batch(s, false);
        if (p->p4 && p->cfg->declare) {
                /* A vehicle that went silent may have restarted and forgotten our lists: the
                 * connect sequence goes again when it is heard, and every stale_ms till then. */
                p->went_stale = true;
                p->connect_at = now + p->cfg->stale_ms;
        }
}

static void peer_heard(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now)
{
        if (p->cfg->stale_ms > 0)
                p->stale_at = now + p->cfg->stale_ms;
        if (!p->p4 || !p->cfg->declare)
                return;
        p->connect_at = LINK_SHAREDLINK_NEVER;
        if (p->went_stale) {
                p->went_stale = false;
                sls_p4_connect(s, p, now);
        }
}

/* ---------------------------------------------------------------------------------------------
 * Replies (answers to Q, pongs to P) */

static void reply_begin(struct link_sharedlink_session *s, struct sls_peer *p)
{
        s->reply.peer = p;
        s->reply.nfields = 0;
        s->reply.text_used = 0;
        s->reply.frame_len = SLP_FRAME_OVERHEAD + (s->crlf ? SLP_CRLF_LEN : 0);
}

static void reply_flush(struct link_sharedlink_session *s)
{
        struct sls_reply *rp = &s->reply;
        int n;

        if (rp->nfields == 0)
                return;
        n = slp_frame_encode(s->txbuf, sizeof(s->txbuf), rp->peer->cfg->address, s->addr,
                             rp->fields, rp->nfields, sls_encode_flags(s));
        if (n > 0)
                sls_send_frame(s, s->txbuf, (size_t)n);
        else
                sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
        reply_begin(s, rp->peer);
}

/* Adds fields that must travel in one frame (R and its D); false if they can never fit. */
static bool reply_add(struct link_sharedlink_session *s, const struct slp_field *fields, size_t n)
{
        struct sls_reply *rp = &s->reply;
        size_t max = rp->peer->cfg->max_frame;
        size_t base = SLP_FRAME_OVERHEAD + (s->crlf ? SLP_CRLF_LEN : 0);
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
        if (rp->frame_len + need > max || rp->nfields + n > SLS_REPLY_FIELDS_MAX)
                reply_flush(s);
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
 * Queries */

static void query_end(struct link_sharedlink_session *s, struct sls_query *q, int err,
                      const char *text)
{
        void *token = q->token;

        q->token = NULL;
        if (s->h->answer)
                s->h->answer(s->arg, token, err, text);
}

static void query_timeout(struct link_sharedlink_session *s, struct sls_query *q)
{
        char why[LINK_SHAREDLINK_WHY_MAX];

        sls_count(s, SHM_COUNTER_TIMEOUTS, 1);
        snprintf(why, sizeof(why), "no answer from peer %c within %u ms",
                 s->peers[q->peer].cfg->address, q->timeout_ms);
        query_end(s, q, ETIMEDOUT, why);
}

/* An answer arrived from p: every query of p waiting for that name gets it. */
static void queries_answer(struct link_sharedlink_session *s, struct sls_peer *p,
                           const char *name, const char *value)
{
        for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++) {
                struct sls_query *q = &s->queries[i];

                if (!q->token || q->peer != p->index || strcmp(q->name, name) != 0)
                        continue;
                sls_eventf(s, SHM_EVENT_QUERY_ANSWER, "peer=%c name=%s value=%s", p->cfg->address,
                       name, value);
                query_end(s, q, 0, value);
        }
}

static void queries_end_all(struct link_sharedlink_session *s, int err, const char *why)
{
        for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++)
                if (s->queries[i].token)
                        query_end(s, &s->queries[i], err, why);
}

/* A free query slot; when all are taken, those whose client left are ended first. */
static struct sls_query *query_slot(struct link_sharedlink_session *s)
{
        for (int pass = 0; pass < 2; pass++)
                for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++) {
                        struct sls_query *q = &s->queries[i];

                        if (!q->token)
                                return q;
                        if (pass == 1 && s->h->alive && !s->h->alive(s->arg, q->token)) {
                                query_end(s, q, ECANCELED, "client gone");
                                return q;
                        }
                }
        return NULL;
}

int link_sharedlink_session_query(struct link_sharedlink_session *s, uint64_t now_ms,
                                  void *token, int peer, const char *name, unsigned timeout_ms)
{
        struct sls_query *q;
        int n, r;

        if (!token || peer < 0 || (unsigned)peer >= s->n_peers ||
            shm_layout_name_check(name) < 0)
                return -EINVAL;
        if (!s->up)
                return -ENOTCONN;
        q = query_slot(s);
        if (!q)
                return -EBUSY;
        n = slp_encode_query(s->txbuf, sizeof(s->txbuf), s->peers[peer].cfg->address, s->addr,
                             name, sls_encode_flags(s));
        /* The peer drops a frame over its max_frame as overlong: never send one it cannot take. */
        if (n > 0 && (size_t)n > s->peers[peer].cfg->max_frame)
                n = -EMSGSIZE;
        r = n < 0 ? n : sls_send_frame(s, s->txbuf, (size_t)n);
        if (r < 0)
                return r;
        sls_count(s, SHM_COUNTER_QUERIES_OUT, 1);
        q->token = token;
        q->peer = (unsigned)peer;
        q->timeout_ms = timeout_ms;
        q->deadline = now_ms + timeout_ms;
        copy_cut(q->name, sizeof(q->name), name);
        return 0;
}

int link_sharedlink_session_command(struct link_sharedlink_session *s, uint64_t now_ms, int peer,
                                    const char *module, const char *text)
{
        s->now = now_ms;
        return sls_p4_command(s, peer, module, text);
}

int link_sharedlink_session_ping(struct link_sharedlink_session *s, int peer)
{
        static const struct slp_field ping = { .letter = 'P', .value = "0", .len = 1 };
        int n;

        if (peer < 0 || peer >= (int)s->n_peers)
                return -EINVAL;
        if (!s->up)
                return -ENOTCONN;
        n = slp_frame_encode(s->txbuf, sizeof(s->txbuf), s->peers[peer].cfg->address, s->addr,
                             &ping, 1, sls_encode_flags(s));
        return n < 0 ? n : sls_send_frame(s, s->txbuf, (size_t)n);
}

int link_sharedlink_session_peer(const struct link_sharedlink_session *s, const char *address)
{
        if (!slp_address_text_valid(address, strnlen(address, 2)))
                return -1;
        return s->peer_of_addr[slp_address_index(address[0])];
}

/* ---------------------------------------------------------------------------------------------
 * Receiving */

static bool peer_has_inbound(const struct sls_peer *p, uint32_t id)
{
        for (size_t k = 0; k < p->in.n; k++)
                if (p->in.ids[k] == id)
                        return true;
        return false;
}

/* The ad hoc variable "<link>.<peer>.<name>" of p: its id (created if needed), or -1. */
static int adhoc_id(struct link_sharedlink_session *s, struct sls_peer *p, const char *name)
{
        return sls_made_id(s, p, name, strlen(name), SLS_MADE_ADHOC, SHM_TYPE_STRING,
                           SHM_POSITION_NONE, SHM_COUNTER_ADHOC_FULL, SHM_COUNTER_ADHOC_FULL);
}

/* R<name>|D<value> from p. */
static void answer_in(struct link_sharedlink_session *s, struct sls_peer *p,
                      const struct slp_field *r, const struct slp_field *d)
{
        char name[SLP_VALUE_MAX + 1], value[SLP_VALUE_MAX + 1];
        int id;

        sls_count(s, SHM_COUNTER_ANSWERS_IN, 1);
        if (r->len > SLP_VALUE_MAX || d->len > SLP_VALUE_MAX) {
                sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
                return;
        }
        memcpy(name, r->value, r->len);
        name[r->len] = '\0';
        memcpy(value, d->value, d->len);
        value[d->len] = '\0';
        queries_answer(s, p, name, value);
        /* An empty answer means "unknown name" (PROTOCOLS.md 1.2): nothing to store. */
        if (d->len == 0)
                return;
        id = s->h->find(s->arg, name);
        if (id < 0 || !peer_has_inbound(p, (uint32_t)id))
                id = adhoc_id(s, p, name);
        if (id >= 0)
                sls_publish(s, (uint32_t)id, value, d->len);
}

/* Q<name> from p: answer R<name>|D<value>. */
static void query_in(struct link_sharedlink_session *s, const struct slp_field *q)
{
        char name[SLP_VALUE_MAX + 1], value[SHM_VALUE_SIZE];
        struct slp_field pair[2];
        int id, n = -ENOENT;

        sls_count(s, SHM_COUNTER_QUERIES_IN, 1);
        if (q->len > SLP_VALUE_MAX) {
                sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
                return;
        }
        memcpy(name, q->value, q->len);
        name[q->len] = '\0';
        id = s->h->find(s->arg, name);
        if (id >= 0 && s->h->get)
                n = s->h->get(s->arg, (uint32_t)id, value, sizeof(value));
        if (n < 0 || (size_t)n > SHM_VALUE_MAX)
                n = 0;
        value[n] = '\0';
        pair[0] = (struct slp_field){ .letter = 'R', .value = q->value, .len = q->len };
        pair[1] = (struct slp_field){ .letter = 'D', .value = value, .len = (uint16_t)n };
        if (reply_add(s, pair, 2))
                sls_count(s, SHM_COUNTER_ANSWERS_OUT, 1);
        else
                sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
}

/* A positional D for position pos of p's list. */
static void data_in(struct link_sharedlink_session *s, struct sls_peer *p, uint32_t pos,
                    const struct slp_field *d)
{
        if (pos >= p->in.n || (p->in.ids[pos] == SLS_UNMAPPED && d->len > 0)) {
                /* Decision: dropped and counted; the rest of the frame still applies. */
                sls_count(s, SHM_COUNTER_LIST_MISMATCH, 1);
                return;
        }
        if (d->len == 0)
                return;         /* compression: unchanged since the last transmission */
        if (p->p4 && !sls_p4_value_ok(s, p, pos, d->value, d->len))
                return;
        sls_publish(s, p->in.ids[pos], d->value, d->len);
}

/* What the next D field belongs to. */
enum next_data {
        NEXT_POSITION,          /* the list position (if known) */
        NEXT_ANSWER,            /* the R just before it */
        NEXT_SKIP,              /* a skipped field (E, a declaration's Q) */
};

/* Walks the fields of a frame from p (see link_sharedlink.h for the meaning of each). */
static void fields_apply(struct link_sharedlink_session *s, struct sls_peer *p,
                         const struct slp_frame *f)
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
                                answer_in(s, p, answer, fl);
                        } else if (next == NEXT_POSITION) {
                                if (pos_valid) {
                                        data_in(s, p, pos, fl);
                                        if (pos < SLP_INDEX_MAX)
                                                pos++;
                                } else {
                                        sls_count(s, SHM_COUNTER_UNKNOWN_FIELD, 1);
                                }
                        }
                        next = NEXT_POSITION;
                        decl = false;
                        continue;
                }
                if (next == NEXT_ANSWER)
                        sls_count(s, SHM_COUNTER_BAD_FIELD, 1);     /* an R without its D */
                next = NEXT_POSITION;
                decl = false;
                switch (fl->type) {
                case SLP_FIELD_N:
                        /* Decision: several N fields are accepted; each resets the position. */
                        pos_valid = fl->index != SLP_INDEX_QUERY;
                        if (pos_valid)
                                pos = fl->index;
                        else
                                sls_count(s, SHM_COUNTER_UNKNOWN_FIELD, 1);         /* "N?" */
                        break;
                case SLP_FIELD_Q:
                        if (after_type) {
                                /* Pronto4 declaration "T<n>|Q<name>[|D<v>]": not a query. */
                                sls_count(s, SHM_COUNTER_UNKNOWN_FIELD, 1);
                                next = NEXT_SKIP;
                        } else {
                                query_in(s, fl);
                        }
                        break;
                case SLP_FIELD_R:
                        next = NEXT_ANSWER;
                        answer = fl;
                        break;
                case SLP_FIELD_P: {
                        /* Ping: pong with the same value ("P0" -> "G0"). */
                        struct slp_field pong = { .letter = 'G', .value = fl->value,
                                                  .len = fl->len };

                        if (!reply_add(s, &pong, 1))
                                sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
                        break;
                }
                case SLP_FIELD_G:
                        /* A pong: the frame itself shows the peer is alive; a ping may wait. */
                        if (s->h->pong)
                                s->h->pong(s->arg, p->cfg->address, fl->value, fl->len);
                        break;
                case SLP_FIELD_T:
                        sls_count(s, SHM_COUNTER_UNKNOWN_FIELD, 1);
                        decl = true;
                        break;
                case SLP_FIELD_L:
                        sls_count(s, SHM_COUNTER_UNKNOWN_FIELD, 1);
                        pos_valid = false;
                        break;
                case SLP_FIELD_E:
                        sls_count(s, SHM_COUNTER_UNKNOWN_FIELD, 1);
                        next = NEXT_SKIP;
                        break;
                default:
                        /* Decision: unknown field types are skipped and counted. */
                        sls_count(s, SHM_COUNTER_UNKNOWN_FIELD, 1);
                        break;
                }
        }
        if (next == NEXT_ANSWER)
                sls_count(s, SHM_COUNTER_BAD_FIELD, 1);
}

static void frame_apply(struct link_sharedlink_session *s, uint64_t now,
                        const struct slp_frame *f)
{
        struct sls_peer *p;
        int pi;

        sls_count(s, SHM_COUNTER_FRAMES_IN, 1);
        if (f->dst != s->addr) {
                /* Traffic between two other nodes of a shared bus is no mistake of ours: only
                 * counted. A peer talking to someone else, or a node using our own address,
                 * is a swapped or wrong address: warned (issue 21.3). */
                if (f->src != s->addr && s->peer_of_addr[f->src_index] < 0)
                        sls_count(s, SHM_COUNTER_NOT_FOR_US, 1);
                else
                        sls_refuse(s, SHM_COUNTER_NOT_FOR_US, 1, "frames for %c from %c, but "
                                   "this link is %c: check `address:` (ours, and the peer's)",
                                   f->dst, f->src, s->addr);
                return;
        }
        pi = s->peer_of_addr[f->src_index];
        if (pi < 0) {
                sls_refuse(s, SHM_COUNTER_UNKNOWN_PEER, 1, "frames from %c, which is not a peer "
                           "of this link: check the peers' `address:`", f->src);
                return;
        }
        p = &s->peers[pi];
        if (f->raw_len > p->cfg->max_frame) {
                sls_refuse(s, SHM_COUNTER_OVERLONG, 1, "a frame of %zu bytes from peer %c, "
                           "longer than its max_frame %u: dropped; check `max_frame:`",
                           (size_t)f->raw_len, p->cfg->address, p->cfg->max_frame);
                return;
        }
        sls_count(s, SHM_COUNTER_EMPTY_FIELD, f->empty_fields);
        peer_heard(s, p, now);
        reply_begin(s, p);
        /* One batch per frame: clients see the whole frame at once, one change-word bump. */
        batch(s, true);
        if (!p->p4 || !sls_p4_frame(s, p, now, f))
                fields_apply(s, p, f);
        batch(s, false);
        reply_flush(s);
}

static enum shm_counter reason_counter(enum slp_decode_reason reason)
{
        switch (reason) {
        case SLP_REASON_NOISE:
                return SHM_COUNTER_NOISE_BYTES;
        case SLP_REASON_RESYNC:
        case SLP_REASON_TRUNCATED:
                return SHM_COUNTER_RESYNC;
        case SLP_REASON_OVERLONG:
                return SHM_COUNTER_OVERLONG;
        case SLP_REASON_NO_CHECKSUM:
        case SLP_REASON_BAD_CHECKSUM_SYNTAX:
        case SLP_REASON_BAD_CHECKSUM:
                return SHM_COUNTER_BAD_CHECKSUM;
        case SLP_REASON_BAD_HEADER:
                return SHM_COUNTER_BAD_HEADER;
        case SLP_REASON_BAD_ADDRESS:
                return SHM_COUNTER_BAD_ADDRESS;
        case SLP_REASON_BAD_FIELD:
        case SLP_REASON_NO_FIELDS:
        default:
                return SHM_COUNTER_BAD_FIELD;
        }
}

static void result_count(struct link_sharedlink_session *s, const struct slp_decode_result *r)
{
        /* Noise counts bytes; every other rejection counts once. */
        if (r->reason == SLP_REASON_OVERLONG) {
                sls_refuse(s, SHM_COUNTER_OVERLONG, 1, "%zu bytes without a frame end, more "
                           "than the link's largest max_frame: dropped; check `max_frame:`",
                           r->bytes);
                return;
        }
        sls_count(s, reason_counter(r->reason), r->reason == SLP_REASON_NOISE ? r->bytes : 1);
        if (r->reason != SLP_REASON_NOISE)
                sls_diagf(s, LOG_PRIO_DEBUG, "dropped %zu bytes: %s", r->bytes,
                      slp_decode_reason_str(r->reason));
}

static void handle_result(struct link_sharedlink_session *s, uint64_t now,
                          const struct slp_decode_result *r)
{
        if (r->kind == SLP_RESULT_FRAME)
                frame_apply(s, now, r->frame);
        else if (r->kind == SLP_RESULT_REJECT)
                result_count(s, r);
}

void link_sharedlink_session_input(struct link_sharedlink_session *s, uint64_t now_ms,
                                   const uint8_t *data, size_t len)
{
        struct slp_decode_result r;

        s->now = now_ms;
        /* The channel delivers nothing while down; what would come then has no one to answer. */
        if (!s->up)
                return;
        while (len > 0) {
                size_t n = slp_decoder_feed(&s->dec, data, len, &r);

                data += n;
                len -= n;
                handle_result(s, now_ms, &r);
        }
        /* A datagram carries whole frames: a partial one at its end is dropped (PROTOCOLS 1.4). */
        if (s->datagram && slp_decoder_end(&s->dec, &r))
                handle_result(s, now_ms, &r);
}

/* ---------------------------------------------------------------------------------------------
 * Up, down, time */

void link_sharedlink_session_up(struct link_sharedlink_session *s, uint64_t now_ms)
{
        slp_decoder_reset(&s->dec);
        s->up = true;
        s->now = now_ms;
        for (unsigned i = 0; i < s->n_peers; i++) {
                struct sls_peer *p = &s->peers[i];

                /* Decision (§9): a link that comes up sends and takes data at once, as both
                 * public clients expect (the ROS 1 adapter never sends ELink ... on). */
                p->out_off = p->in_off = false;
                if (p->p4 && p->cfg->declare)
                        sls_p4_connect(s, p, now_ms);
                if (p->out.n == 0)
                        continue;
                /* The peer may have restarted: it gets everything at once. */
                p->period_at = LINK_SHAREDLINK_NEVER;
                sls_send_full(s, p, now_ms);
        }
        sls_peer_state_update(s);
}

void link_sharedlink_session_down(struct link_sharedlink_session *s, uint64_t now_ms)
{
        (void)now_ms;
        s->up = false;
        for (unsigned i = 0; i < s->n_peers; i++) {
                s->peers[i].period_at = LINK_SHAREDLINK_NEVER;
                s->peers[i].change_at = LINK_SHAREDLINK_NEVER;
                s->peers[i].stale_at = LINK_SHAREDLINK_NEVER;
                s->peers[i].connect_at = LINK_SHAREDLINK_NEVER;
        }
        queries_end_all(s, ENOTCONN, "link went down");
}

bool link_sharedlink_session_is_up(const struct link_sharedlink_session *s)
{
        return s->up;
}

void link_sharedlink_session_tick(struct link_sharedlink_session *s, uint64_t now_ms)
{
        s->now = now_ms;
        if (now_ms >= s->refusals.summary_at)
                sls_refusals_summary(s);
        for (unsigned i = 0; i < s->n_peers; i++) {
                struct sls_peer *p = &s->peers[i];

                if (now_ms >= p->stale_at)
                        peer_mark_stale(s, p, now_ms);
                if (now_ms >= p->change_at)
                        peer_send_changes(s, p, now_ms);
                if (now_ms >= p->period_at)
                        peer_period(s, p, now_ms);
                if (now_ms >= p->connect_at)
                        sls_p4_connect(s, p, now_ms);
        }
        for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++) {
                struct sls_query *q = &s->queries[i];

                if (q->token && now_ms >= q->deadline)
                        query_timeout(s, q);
        }
}

uint64_t link_sharedlink_session_deadline(const struct link_sharedlink_session *s)
{
        uint64_t d = s->refusals.summary_at;

        for (unsigned i = 0; i < s->n_peers; i++) {
                const struct sls_peer *p = &s->peers[i];

                d = min_deadline(d, min_deadline(p->stale_at,
                                                 min_deadline(p->change_at, p->period_at)));
                d = min_deadline(d, p->connect_at);
        }
        for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++)
                if (s->queries[i].token)
                        d = min_deadline(d, s->queries[i].deadline);
        return d;
}

/* ---------------------------------------------------------------------------------------------
 * Set-up and tear-down */

void link_sharedlink_session_outbound(struct link_sharedlink_session *s, uint64_t now_ms,
                                      uint32_t id, const char *value)
{
        struct sls_outref key = { .id = id };
        const struct sls_outref *ref;
        struct sls_peer *p;

        ref = bsearch(&key, s->outrefs, s->n_outrefs, sizeof(*s->outrefs), sls_outref_cmp);
        if (!ref)
                return;
        s->now = now_ms;
        p = &s->peers[ref->peer];
        if (p->p4) {
                char checked[SHM_VALUE_SIZE];

                /* A value the peer would refuse is never sent: the last good one stays. */
                if (!sls_p4_outbound_value(s, p, ref->pos, value, checked))
                        return;
                copy_cut(p->out_values[ref->pos], SHM_VALUE_SIZE, checked);
        } else {
                copy_cut(p->out_values[ref->pos], SHM_VALUE_SIZE, value);
        }
        p->out_dirty[ref->pos] = true;
        peer_change_request(s, p, now_ms);
}

/* Resolves the ids of one configured list. */
static int find_ids(struct link_sharedlink_session *s, const struct config_var *vars, size_t n,
                    uint32_t *ids)
{
        for (size_t k = 0; k < n; k++) {
                int id = s->h->find(s->arg, vars[k].name);

                if (id < 0) {
                        sls_diagf(s, LOG_PRIO_WARNING, "variable %s is not in the table",
                                  vars[k].name);
                        return -ENOENT;
                }
                ids[k] = (uint32_t)id;
        }
        return 0;
}

/*
 * One list of a peer: the configured one (positions in config order until a pronto4 peer
 * declares another order) or, learned, empty until the peer declares it. A pronto4 list has room
 * for a declaration of any length it may bind (learn_max, or every configured length).
 */
static int list_init(struct link_sharedlink_session *s, const struct config_peer *c,
                     struct sls_list *l, const struct config_var *vars, size_t n, bool learn)
{
        bool p4 = c->dialect == CONFIG_DIALECT_PRONTO4;

        l->learn = learn;
        l->n = l->n_cfg = learn ? 0 : n;
        /* A learned list has room for any declaration's positions; learn_max bounds the
         * variables it makes (docs/pronto4.md §4). */
        l->cap = !p4 ? n : SLS_LIST_MAX;
        if (l->cap < n)
                l->cap = n;
        l->ids = calloc(l->cap + 1, sizeof(*l->ids));
        l->cfg_ids = calloc(l->n_cfg + 1, sizeof(*l->cfg_ids));
        l->types = calloc(l->cap + 1, sizeof(*l->types));
        l->names = calloc(p4 ? l->cap + 1 : 1, sizeof(*l->names));
        l->name_ptrs = calloc(l->cap + 1, sizeof(*l->name_ptrs));
        if (!l->ids || !l->cfg_ids || !l->types || !l->names || !l->name_ptrs)
                return -ENOMEM;
        for (size_t k = 0; k < l->n_cfg; k++) {
                l->types[k] = sls_p4_type_of(vars[k].type);
                if (p4)
                        copy_cut(l->names[k], SLS_NAME_SIZE, vars[k].name);
        }
        for (size_t k = 0; p4 && k < l->cap; k++)
                l->name_ptrs[k] = l->names[k];
        if (find_ids(s, vars, l->n_cfg, l->cfg_ids) < 0)
                return -ENOENT;
        memcpy(l->ids, l->cfg_ids, l->n_cfg * sizeof(*l->ids));
        return 0;
}

static void list_release(struct sls_list *l)
{
        free(l->ids);
        free(l->cfg_ids);
        free(l->types);
        free(l->names);
        free(l->name_ptrs);
}

static int peer_init(struct link_sharedlink_session *s, unsigned index)
{
        struct sls_peer *p = &s->peers[index];
        const struct config_peer *c = &s->cfg->sl.peers[index];
        size_t cap;
        int r;

        p->cfg = c;
        p->index = index;
        p->p4 = c->dialect == CONFIG_DIALECT_PRONTO4;
        p->period_at = p->change_at = p->stale_at = p->connect_at = LINK_SHAREDLINK_NEVER;
        r = list_init(s, c, &p->out, c->outbound, c->n_outbound, c->outbound_learn);
        if (r == 0)
                r = list_init(s, c, &p->in, c->inbound, c->n_inbound, c->inbound_learn);
        if (r < 0)
                return r;
        cap = p->out.cap;
        p->out_values = calloc(cap + 1, sizeof(*p->out_values));
        p->out_ptrs = calloc(cap + 1, sizeof(*p->out_ptrs));
        p->out_dirty = calloc(cap + 1, sizeof(*p->out_dirty));
        if (!p->out_values || !p->out_ptrs || !p->out_dirty)
                return -ENOMEM;
        for (size_t k = 0; k < cap; k++) {
                p->out_ptrs[k] = p->out_values[k];
                p->out_dirty[k] = true;         /* never sent */
        }
        s->cap_outrefs += cap;
        /* At least every refresh_ms: the largest whole number of periods that fits. */
        p->refresh_every = c->period_ms > 0 ? c->refresh_ms / c->period_ms : 1;
        if (p->refresh_every == 0)
                p->refresh_every = 1;
        s->peer_of_addr[slp_address_index(c->address)] = (int)index;
        return 0;
}

static int outrefs_init(struct link_sharedlink_session *s)
{
        s->outrefs = calloc(s->cap_outrefs + 1, sizeof(*s->outrefs));
        if (!s->outrefs)
                return -ENOMEM;
        sls_outrefs_build(s);
        return 0;
}

static void session_release(struct link_sharedlink_session *s)
{
        for (unsigned i = 0; i < CONFIG_PEERS_MAX; i++) {
                struct sls_peer *p = &s->peers[i];

                list_release(&p->out);
                list_release(&p->in);
                free(p->out_values);
                free(p->out_ptrs);
                free(p->out_dirty);
        }
        free(s->outrefs);
        free(s->adhoc);
        free(s);
}

static bool config_valid(const struct config_link *cfg)
{
        if (cfg->protocol != CONFIG_PROTOCOL_SHAREDLINK || cfg->sl.n_peers > CONFIG_PEERS_MAX)
                return false;
        for (unsigned i = 0; i < cfg->sl.n_peers; i++)
                if (!slp_address_valid(cfg->sl.peers[i].address))
                        return false;
        return true;
}

int link_sharedlink_session_new(const struct config_link *cfg, bool datagram,
                                const struct link_sharedlink_hooks *hooks, void *arg,
                                struct link_sharedlink_session **ret_session)
{
        size_t max_frame = SLP_FRAME_MIN;
        struct link_sharedlink_session *s;
        int r;

        if (!config_valid(cfg) || !hooks->send || !hooks->find || !hooks->publish)
                return -EINVAL;
        s = calloc(1, sizeof(*s));
        if (!s)
                return -ENOMEM;
        s->h = hooks;
        s->arg = arg;
        s->cfg = cfg;
        s->addr = cfg->sl.address;
        s->datagram = datagram;
        /* A byte stream always ends frames with CR LF; a datagram when the link says so (the
         * default with a pronto4 peer, whose C++ client aborts without it). */
        s->crlf = !datagram || cfg->sl.crlf;
        s->n_peers = cfg->sl.n_peers;
        s->refusals.summary_at = LINK_SHAREDLINK_NEVER;
        for (unsigned i = 0; i < SLP_ADDR_COUNT; i++)
                s->peer_of_addr[i] = -1;
        for (unsigned i = 0; i < s->n_peers; i++) {
                r = peer_init(s, i);
                if (r < 0)
                        goto fail;
                if (cfg->sl.peers[i].max_frame > max_frame)
                        max_frame = cfg->sl.peers[i].max_frame;
        }
        if (max_frame > SLP_FRAME_MAX)
                max_frame = SLP_FRAME_MAX;
        r = outrefs_init(s);
        if (r == 0)
                r = slp_decoder_init(&s->dec, max_frame);
        if (r < 0)
                goto fail;
        *ret_session = s;
        return 0;
fail:
        session_release(s);
        return r;
}

struct link_sharedlink_session *link_sharedlink_session_free(struct link_sharedlink_session *s)
{
        if (!s)
                return NULL;
        queries_end_all(s, ECANCELED, "link stopped");
        session_release(s);
        return NULL;
}
