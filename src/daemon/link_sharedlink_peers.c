/*
 * What the parts of a SharedLink session share (link_sharedlink_peers.h): the hooks with their
 * counters, the variables a link makes and retires, and the frames of an outbound list.
 */
#include "daemon/link_sharedlink_peers.h"

#include <errno.h>
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

        /* Pronto4: every data frame is the whole list, starting N0 (docs/pronto4.md §7). */
        if (p->p4)
                return send_list_whole(s, p, full);
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

int sls_made_id(struct link_sharedlink_session *s, struct sls_peer *p, const char *name,
                size_t len, enum sls_made made, unsigned type, int32_t pos,
                enum shm_counter full_counter, enum shm_counter conflict_counter)
{
        char full[ADHOC_NAME_SIZE];
        int id;

        snprintf(full, sizeof(full), "%s.%c.%.*s", s->cfg->name, p->cfg->address, (int)len,
                 name);
        if (len > SLP_VALUE_MAX || shm_layout_name_check(full) < 0) {
                sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
                return -1;
        }
        id = s->h->find(s->arg, full);
        if (id >= 0) {
                for (size_t i = 0; i < s->n_adhoc; i++)
                        if (s->adhoc[i].id == (uint32_t)id && s->adhoc[i].peer == p->index &&
                            made_compatible(s->adhoc[i].made, made))
                                return id;
                /* Taken by a configured variable (or another link's): never overwrite it. */
                sls_count(s, conflict_counter, 1);
                return -1;
        }
        if (!s->h->add || s->n_adhoc >= LINK_SHAREDLINK_ADHOC_MAX || !adhoc_reserve(s)) {
                sls_count(s, full_counter, 1);
                return -1;
        }
        id = s->h->add(s->arg, full, type, p->cfg->address, made == SLS_MADE_LEARNED_OUT, pos);
        if (id < 0) {
                sls_count(s, id == -ENOSPC ? full_counter : SHM_COUNTER_BAD_VALUE, 1);
                return -1;
        }
        s->adhoc[s->n_adhoc++] = (struct sls_adhoc){ .id = (uint32_t)id, .peer = p->index,
                                                     .made = made };
        sls_eventf(s, SHM_EVENT_ADHOC_VARIABLE, "name=%s peer=%c%s", full, p->cfg->address,
                   made_word(made));
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
