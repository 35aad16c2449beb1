/*
 * What the parts of a SharedLink session share (link_sharedlink_peers.h): the hooks with their
 * counters, the variables a link makes and retires, and the frames of an outbound list.
 */
#include "daemon/link_sharedlink_peers.h"

#include <errno.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define ADHOC_NAME_SIZE         (SLP_VALUE_MAX + SHM_LINK_NAME_SIZE + 8)
#define EVENT_TEXT_MAX          SHM_EVENT_TEXT_SIZE
/* A value the codec emits must fit a slot, and a slot's value must be sendable. */
static_assert(SLP_VALUE_MAX == SHM_VALUE_MAX, "codec and shm agree on the longest value");

/* ---------------------------------------------------------------------------------------------
 * Hooks */

void sls_count(struct link_sharedlink_session *s, enum shm_counter c, uint64_t n)
{
        if (s->h->count && n)
                s->h->count(s->arg, c, n);
}

void sls_eventf(struct link_sharedlink_session *s, enum shm_event_type type, const char *fmt, ...)
{
        char text[EVENT_TEXT_MAX];
        va_list ap;

        if (!s->h->event)
                return;
        va_start(ap, fmt);
        vsnprintf(text, sizeof(text), fmt, ap);
        va_end(ap);
        s->h->event(s->arg, type, text);
}

void sls_diagf(struct link_sharedlink_session *s, enum log_prio prio, const char *fmt, ...)
{
        char text[LINK_SHAREDLINK_DIAG_MAX];
        va_list ap;

        if (!s->h->diag)
                return;
        va_start(ap, fmt);
        vsnprintf(text, sizeof(text), fmt, ap);
        va_end(ap);
        s->h->diag(s->arg, prio, text);
}

void sls_refuse(struct link_sharedlink_session *s, enum shm_counter c, uint64_t n,
                const char *fmt, ...)
{
        struct sls_refusals *r = &s->refusals;
        char text[LINK_SHAREDLINK_DIAG_MAX];
        va_list ap;

        if (n == 0 || (unsigned)c >= SHM_COUNTER_COUNT)
                return;
        sls_count(s, c, n);
        if (r->warned[c]) {
                r->pending[c] += n;
                if (r->summary_at == LINK_SHAREDLINK_NEVER)
                        r->summary_at = s->now + LINK_SHAREDLINK_REFUSAL_SUMMARY_MS;
                return;
        }
        r->warned[c] = true;
        va_start(ap, fmt);
        vsnprintf(text, sizeof(text), fmt, ap);
        va_end(ap);
        sls_diagf(s, LOG_PRIO_WARNING, "%s: %s", shm_layout_counter_name(c), text);
}

void sls_refusals_summary(struct link_sharedlink_session *s)
{
        struct sls_refusals *r = &s->refusals;
        char text[LINK_SHAREDLINK_DIAG_MAX];
        size_t used = 0;

        r->summary_at = LINK_SHAREDLINK_NEVER;
        for (unsigned c = 0; c < SHM_COUNTER_COUNT; c++) {
                int n;

                if (r->pending[c] == 0)
                        continue;
                n = snprintf(text + used, sizeof(text) - used, "%s%s %" PRIu64,
                             used ? ", " : "", shm_layout_counter_name(c), r->pending[c]);
                r->pending[c] = 0;
                if (n > 0 && (size_t)n < sizeof(text) - used)
                        used += (size_t)n;
        }
        if (used > 0)
                sls_diagf(s, LOG_PRIO_WARNING, "refused in the last %u s: %s (slctl stats has "
                          "the totals)", LINK_SHAREDLINK_REFUSAL_SUMMARY_MS / 1000u, text);
}

void sls_peer_state_update(struct link_sharedlink_session *s)
{
        char text[LINK_SHAREDLINK_PEER_STATE_MAX];
        size_t used = 0;

        if (!s->h->peer_state)
                return;
        text[0] = '\0';
        for (unsigned i = 0; i < s->n_peers; i++) {
                const struct sls_peer *p = &s->peers[i];
                int n;

                /* Only what differs from a link's normal state ("up" stays "up"). */
                if (!p->out_off && !p->in_off)
                        continue;
                n = snprintf(text + used, sizeof(text) - used, "%speer %c: %s%s%s",
                             used ? "; " : "", p->cfg->address,
                             p->out_off ? "outbound off" : "",
                             p->out_off && p->in_off ? ", " : "",
                             p->in_off ? "inbound off" : "");
                if (n < 0 || (size_t)n >= sizeof(text) - used)
                        break;
                used += (size_t)n;
        }
        s->h->peer_state(s->arg, text);
}

int sls_send_frame(struct link_sharedlink_session *s, const char *buf, size_t len)
{
        int r = s->h->send(s->arg, buf, len);

        if (r == 0)
                sls_count(s, SHM_COUNTER_FRAMES_OUT, 1);
        return r;
}

unsigned sls_encode_flags(const struct link_sharedlink_session *s)
{
        return s->crlf ? SLP_ENCODE_CRLF : 0;
}

/* ---------------------------------------------------------------------------------------------
 * Sending */

/* The whole outbound list of pronto4 peer p in one N0 frame (slp_encode_list_whole()). */
static int send_list_whole(struct link_sharedlink_session *s, struct sls_peer *p, bool full)
{
        struct slp_list list = {
                .dst = p->cfg->address,
                .src = s->addr,
                .values = p->out_ptrs,
                .changed = p->out_dirty,
                .count = p->out.n,
                .max_frame = p->cfg->max_frame,
                .compress = p->cfg->compression,
                .full = full,
                .crlf = s->crlf,
        };
        int n, r;

        if (p->out.n == 0)
                return 0;
        n = slp_encode_list_whole(&list, s->txbuf, sizeof(s->txbuf));
        if (n < 0) {
                /* Only a learned list can be too long (-n checks a configured one). */
                sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
                sls_diagf(s, LOG_PRIO_WARNING, "peer %c: the list of %zu values does not fit "
                          "max_frame %u", p->cfg->address, p->out.n, p->cfg->max_frame);
                memset(p->out_dirty, 0, p->out.n * sizeof(*p->out_dirty));
                return n;
        }
        r = sls_send_frame(s, s->txbuf, (size_t)n);
        if (r == 0)
                memset(p->out_dirty, 0, p->out.n * sizeof(*p->out_dirty));
        return r;
}

int sls_send_range(struct link_sharedlink_session *s, struct sls_peer *p, size_t first,
                   size_t end, bool full)
{
        struct slp_list list = {
                .dst = p->cfg->address,
                .src = s->addr,
                .values = p->out_ptrs,
                .changed = p->out_dirty,
                .count = end,
                .max_frame = p->cfg->max_frame,
                .compress = p->cfg->compression,
                .full = full,
                .crlf = s->crlf,
        };
        size_t cursor = first;
        int err = 0;

        /* Pronto4: every data frame is the whole list, starting N0 (docs/pronto4.md §7); none
         * while the host has turned our outbound off (§9), the values wait, dirty. */
        if (p->p4)
                return p->out_off ? 0 : send_list_whole(s, p, full);
        while (cursor < end) {
                size_t start = cursor;
                int n = slp_encode_list(&list, &cursor, s->txbuf, sizeof(s->txbuf));

                if (n == 0)
                        break;
                if (n < 0) {
                        /* Only a value too long for max_frame can fail (the table validated the
                         * rest): it can never go to this peer. Counted, then skipped. */
                        sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
                        sls_diagf(s, LOG_PRIO_WARNING, "peer %c: position %zu does not fit "
                              "max_frame %u", p->cfg->address, start, p->cfg->max_frame);
                        p->out_dirty[start] = false;
                        cursor = start + 1;
                        err = n;
                        continue;
                }
                int r = sls_send_frame(s, s->txbuf, (size_t)n);
                if (r < 0)
                        return r;
                for (size_t k = start; k < cursor; k++)
                        p->out_dirty[k] = false;
        }
        return err;
}

int sls_send_full(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now)
{
        int r = sls_send_range(s, p, 0, p->out.n, true);

        if (r == 0)
                p->since_full = 0;
        p->change_sent = false;
        if (p->cfg->period_ms > 0 && p->period_at == LINK_SHAREDLINK_NEVER)
                p->period_at = now + p->cfg->period_ms;
        return r;
}

/* ---------------------------------------------------------------------------------------------
 * Variables a link makes */

static bool adhoc_reserve(struct link_sharedlink_session *s)
{
        size_t cap;
        struct sls_adhoc *a;

        if (s->n_adhoc < s->cap_adhoc)
                return true;
        cap = s->cap_adhoc ? 2 * s->cap_adhoc : 16;
        a = realloc(s->adhoc, cap * sizeof(*a));
        if (!a)
                return false;
        s->adhoc = a;
        s->cap_adhoc = cap;
        return true;
}

static const char *made_word(enum sls_made made)
{
        switch (made) {
        case SLS_MADE_LEARNED_IN:
                return " learned=inbound";
        case SLS_MADE_LEARNED_OUT:
                return " learned=outbound";
        case SLS_MADE_ADHOC:
        default:
                return "";
        }
}

/* Whether a variable made as `had` serves as `want`: an ad hoc name may become a learned inbound
 * position and back (both are values the peer sends); an outbound one never changes side. */
static bool made_compatible(enum sls_made had, enum sls_made want)
{
        return (had == SLS_MADE_LEARNED_OUT) == (want == SLS_MADE_LEARNED_OUT);
}

/* The entry of s->adhoc for variable id of peer p, or NULL. */
static struct sls_adhoc *made_entry(struct link_sharedlink_session *s, const struct sls_peer *p,
                                    uint32_t id)
{
        for (size_t i = 0; i < s->n_adhoc; i++)
                if (s->adhoc[i].id == id && s->adhoc[i].peer == p->index)
                        return &s->adhoc[i];
        return NULL;
}

/* Forgets entry a of s->adhoc (its variable retired). */
static void made_forget(struct link_sharedlink_session *s, struct sls_adhoc *a)
{
        *a = s->adhoc[--s->n_adhoc];
}

/*
 * Decision (docs/pronto4.md §4): a declaration is the authority on a name, whatever came first.
 * A variable a self-describing frame (or an R|D answer) made ad hoc for p, which a declaration
 * now names, is retired and made anew as the declaration says: its direction, its type, its
 * position. An inbound one keeps its value when the declared type takes it (the outcome is the
 * same as when the declaration came first and the value after); an outbound one starts empty
 * (we own what we send). Returns false when the table would not retire it.
 */
static bool made_remake(struct link_sharedlink_session *s, struct sls_adhoc *a, enum sls_made made,
                        char *value, size_t size, int *ret_len)
{
        *ret_len = -1;
        if (made == SLS_MADE_LEARNED_IN && s->h->get)
                *ret_len = s->h->get(s->arg, a->id, value, size);
        if (!s->h->retire || s->h->retire(s->arg, a->id) < 0)
                return false;
        made_forget(s, a);
        s->remade++;
        return true;
}

int sls_made_id(struct link_sharedlink_session *s, struct sls_peer *p, const char *name,
                size_t len, enum sls_made made, unsigned type, int32_t pos,
                enum shm_counter full_counter, enum shm_counter conflict_counter)
{
        char full[ADHOC_NAME_SIZE], value[SHM_VALUE_SIZE];
        int id, value_len = -1;

        snprintf(full, sizeof(full), "%s.%c.%.*s", s->cfg->name, p->cfg->address, (int)len,
                 name);
        if (len > SLP_VALUE_MAX || shm_layout_name_check(full) < 0) {
                sls_refuse(s, SHM_COUNTER_BAD_VALUE, 1, "peer %c named \"%.*s\", which does "
                           "not fit a variable name (47 bytes with the link and peer)",
                           p->cfg->address, (int)len, name);
                return -1;
        }
        id = s->h->find(s->arg, full);
        if (id >= 0) {
                struct sls_adhoc *a = made_entry(s, p, (uint32_t)id);

                if (a && a->made != SLS_MADE_ADHOC && made_compatible(a->made, made))
                        return id;
                if (a && a->made == SLS_MADE_ADHOC && made == SLS_MADE_ADHOC)
                        return id;
                if (!a || a->made != SLS_MADE_ADHOC ||
                    !made_remake(s, a, made, value, sizeof(value), &value_len)) {
                        /* Taken by a configured variable, another link's, or our other list:
                         * never overwritten. */
                        sls_refuse(s, conflict_counter, 1, "peer %c named %.*s, but %s is "
                                   "a configured variable, another link's or in our other "
                                   "list: not used; rename one of them", p->cfg->address,
                                   (int)len, name, full);
                        return -1;
                }
        }
        if (!s->h->add || s->n_adhoc >= LINK_SHAREDLINK_ADHOC_MAX || !adhoc_reserve(s)) {
                sls_refuse(s, full_counter, 1, "no room for %s (this link makes at most %u names "
                           "of its peers): not used", full, LINK_SHAREDLINK_ADHOC_MAX);
                return -1;
        }
        id = s->h->add(s->arg, full, type, p->cfg->address, made == SLS_MADE_LEARNED_OUT, pos);
        if (id < 0) {
                if (id == -ENOSPC)
                        sls_refuse(s, full_counter, 1, "the table has no room for %s: not used; "
                                   "check the learned lists and learn_max", full);
                else
                        sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
                return -1;
        }
        s->adhoc[s->n_adhoc++] = (struct sls_adhoc){ .id = (uint32_t)id, .peer = p->index,
                                                     .made = made };
        sls_eventf(s, SHM_EVENT_ADHOC_VARIABLE, "name=%s peer=%c%s", full, p->cfg->address,
                   made_word(made));
        if (value_len > 0 && s->h->publish(s->arg, (uint32_t)id, value, (size_t)value_len) < 0)
                sls_count(s, SHM_COUNTER_TYPE_MISMATCH, 1);
        return id;
}

void sls_retire_learned(struct link_sharedlink_session *s, const struct sls_peer *p, uint32_t id)
{
        for (size_t i = 0; i < s->n_adhoc; i++) {
                const struct sls_adhoc *a = &s->adhoc[i];

                if (a->id != id || a->peer != p->index || a->made == SLS_MADE_ADHOC)
                        continue;
                if (!s->h->retire || s->h->retire(s->arg, id) < 0)
                        return;
                s->adhoc[i] = s->adhoc[--s->n_adhoc];
                return;
        }
}

void sls_publish(struct link_sharedlink_session *s, uint32_t id, const char *value, size_t len)
{
        if (s->h->publish(s->arg, id, value, len) < 0)
                sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
}

/* ---------------------------------------------------------------------------------------------
 * Outbound ids */

int sls_outref_cmp(const void *a, const void *b)
{
        const struct sls_outref *x = a, *y = b;

        return (x->id > y->id) - (x->id < y->id);
}

void sls_outrefs_build(struct link_sharedlink_session *s)
{
        s->n_outrefs = 0;
        for (unsigned i = 0; i < s->n_peers; i++)
                for (size_t k = 0; k < s->peers[i].out.n; k++)
                        if (s->peers[i].out.ids[k] != SLS_UNMAPPED &&
                            s->n_outrefs < s->cap_outrefs)
                                s->outrefs[s->n_outrefs++] = (struct sls_outref){
                                        .id = s->peers[i].out.ids[k],
                                        .peer = (uint16_t)i,
                                        .pos = (uint16_t)k,
                                };
        qsort(s->outrefs, s->n_outrefs, sizeof(*s->outrefs), sls_outref_cmp);
}
