/*
 * The Pronto4 dialect of a SharedLink session (link_sharedlink_pronto4.h says where the seam
 * is; docs/pronto4.md is the contract, its Decisions are quoted where they apply).
 *
 *     frame from a pronto4 peer -> sls_p4_frame() -> p4_decode() (src/proto/pronto4.c), by kind:
 *         declaration  -> the list replaced whole (learned: variables made), acknowledgement
 *         acknowledgement -> counted, names compared, nothing stored
 *         self-describing -> each T/Q/D by name (type-checked)
 *         N? / L?      -> our list, one typed frame
 *         E, MU*       -> a command event
 *         data         -> undeclared: counted; else the session's positional walk
 *     up / silence -> sls_p4_connect(): E SetIP, outbound on, inbound on, N0 and L0
 *     a client's value -> sls_p4_outbound_value(): checked against its T, doubles shortened
 */
#include "daemon/link_sharedlink_pronto4.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* Round-trip precision of a double: %.17g always gives back the same double. */
#define P4_DOUBLE_DIGITS_MAX    17

/* ---------------------------------------------------------------------------------------------
 * Types */

enum slp_type sls_p4_type_of(enum config_var_type type)
{
        switch (type) {
        case CONFIG_VAR_LONG:
                return SLP_TYPE_LONG;
        case CONFIG_VAR_DOUBLE:
                return SLP_TYPE_DOUBLE;
        case CONFIG_VAR_STRING:
        default:
                return SLP_TYPE_STRING;
        }
}

static unsigned shm_type_of(enum slp_type type)
{
        switch (type) {
        case SLP_TYPE_LONG:
                return SHM_TYPE_LONG;
        case SLP_TYPE_DOUBLE:
                return SHM_TYPE_DOUBLE;
        case SLP_TYPE_STRING:
        default:
                return SHM_TYPE_STRING;
        }
}

bool sls_p4_value_ok(struct link_sharedlink_session *s, const struct sls_peer *p, size_t pos,
                     const char *value, size_t len)
{
        /* Decision (docs/pronto4.md §3): refused, counted, never stored; the frame goes on. */
        if (slp_value_check(p->in.types[pos], value, len) == 0)
                return true;
        sls_refuse(s, SHM_COUNTER_TYPE_MISMATCH, 1, "peer %c sent \"%.*s\" for %s, declared "
                   "T%c: dropped; check the type the peer declares or we configured",
                   p->cfg->address, (int)len, value, p->in.names[pos],
                   slp_type_digit(p->in.types[pos]));
        return false;
}

/* The shortest text that reads back as the same double (C locale: the daemon sets none). */
static void double_shortest(const char *value, char out[SHM_VALUE_SIZE])
{
        double d = strtod(value, NULL);

        for (int digits = 1; digits <= P4_DOUBLE_DIGITS_MAX; digits++) {
                snprintf(out, SHM_VALUE_SIZE, "%.*g", digits, d);
                if (strtod(out, NULL) == d)
                        return;
        }
}

bool sls_p4_outbound_value(struct link_sharedlink_session *s, const struct sls_peer *p,
                           size_t pos, const char *value, char *out)
{
        enum slp_type type = p->out.types[pos];
        size_t len = strlen(value);

        if (slp_value_check(type, value, len) < 0) {
                sls_refuse(s, SHM_COUNTER_TYPE_MISMATCH, 1, "peer %c: \"%.*s\" is no T%c value "
                           "for %s: not sent; check what the client writes", p->cfg->address,
                           (int)len, value, slp_type_digit(type), p->out.names[pos]);
                return false;
        }
        /* The -n bound of a whole list counts SLP_DOUBLE_TEXT_MAX bytes for a double. */
        if (type == SLP_TYPE_DOUBLE && len > SLP_DOUBLE_TEXT_MAX)
                double_shortest(value, out);
        else
                snprintf(out, SHM_VALUE_SIZE, "%s", value);
        return true;
}

/* ---------------------------------------------------------------------------------------------
 * Sending */

/* Our declaration of list l to p, "N0|T|Q..." (head 'N', what we send) or "L0|T|Q..." (what we
 * receive), in one frame; nothing for an empty list. 0 or -errno. */
static int send_declaration(struct link_sharedlink_session *s, struct sls_peer *p, char head,
                            const struct sls_list *l)
{
        struct slp_named_list nl = {
                .dst = p->cfg->address,
                .src = s->addr,
                .head = head,
                .names = l->name_ptrs,
                .types = l->types,
                .count = l->n,
                .max_frame = p->cfg->max_frame,
                .crlf = s->crlf,
                .one_frame = true,
        };
        size_t cursor = 0;
        int n, r;

        if (l->n == 0)
                return 0;
        n = slp_encode_declaration(&nl, &cursor, s->txbuf, sizeof(s->txbuf));
        if (n < 0) {
                sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
                sls_diagf(s, LOG_PRIO_WARNING, "peer %c: cannot declare the %c list: %s",
                          p->cfg->address, head, strerror(-n));
                return n;
        }
        r = sls_send_frame(s, s->txbuf, (size_t)n);
        if (r == 0)
                sls_count(s, SHM_COUNTER_DECLARATIONS_OUT, 1);
        return r;
}

/* E<module>|D<text> toward p in txbuf: its length, or -EINVAL (a bad module or text, or a
 * frame longer than p's max_frame, which p would drop). */
static int encode_command(struct link_sharedlink_session *s, const struct sls_peer *p,
                          const char *module, const char *text)
{
        int n = slp_encode_command(s->txbuf, sizeof(s->txbuf), p->cfg->address, s->addr, module,
                                   text, sls_encode_flags(s));

        return n < 0 || (size_t)n > p->cfg->max_frame ? -EINVAL : n;
}

static int send_command(struct link_sharedlink_session *s, const struct sls_peer *p,
                        const char *module, const char *text)
{
        int n = encode_command(s, p, module, text);
        int r;

        if (n < 0)
                return n;
        r = sls_send_frame(s, s->txbuf, (size_t)n);
        if (r == 0)
                sls_count(s, SHM_COUNTER_COMMANDS_OUT, 1);
        return r;
}

static void connect_command(struct link_sharedlink_session *s, const struct sls_peer *p,
                            const char *text)
{
        if (send_command(s, p, P4_CONNECT_MODULE, text) == -EINVAL) {
                sls_count(s, SHM_COUNTER_BAD_COMMAND, 1);
                sls_diagf(s, LOG_PRIO_WARNING, "peer %c: \"%s\" does not fit a value or "
                          "max_frame %u", p->cfg->address, text, p->cfg->max_frame);
        }
}

/* ELink SetIP (UDP only: where we listen), outbound on, inbound on: a host's first words. */
static void connect_link(struct link_sharedlink_session *s, const struct sls_peer *p)
{
        char addr[P4_ADDRESS_MAX], text[P4_SETIP_TEXT_MAX];
        unsigned remote_port = 0;

        if (s->h->local_address &&
            s->h->local_address(s->arg, addr, sizeof(addr), &remote_port) > 0 &&
            p4_setip_text(text, sizeof(text), addr, remote_port) > 0)
                connect_command(s, p, text);
        connect_command(s, p, P4_TEXT_OUTBOUND_ON);
        connect_command(s, p, P4_TEXT_INBOUND_ON);
}

void sls_p4_connect(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now)
{
        /* Until the vehicle is heard, the sequence goes again every stale_ms (it may not have
         * been listening yet). */
        p->connect_at = LINK_SHAREDLINK_NEVER;
        if (!s->up)
                return;
        if (p->cfg->stale_ms > 0)
                p->connect_at = now + p->cfg->stale_ms;
        /* Decision (§9): the ELink commands are the host's; a vehicle told to declare only
         * declares. */
        if (p->cfg->role == CONFIG_P4_HOST)
                connect_link(s, p);
        send_declaration(s, p, 'N', &p->out);
        send_declaration(s, p, 'L', &p->in);
}

int sls_p4_command(struct link_sharedlink_session *s, int peer, const char *module,
                   const char *text)
{
        const struct sls_peer *first = NULL;
        int r;

        if (peer < -1 || peer >= (int)s->n_peers)
                return -EINVAL;
        for (unsigned i = 0; i < s->n_peers && !first; i++)
                if ((peer < 0 || (unsigned)peer == i) && s->peers[i].p4)
                        first = &s->peers[i];
        if (!first)
                return -EOPNOTSUPP;
        /* Checked before the link state, so a bad command never waits for the link. */
        if (encode_command(s, first, module, text) < 0)
                return -EINVAL;
        if (!s->up)
                return -ENOTCONN;
        for (unsigned i = 0; i < s->n_peers; i++) {
                if ((peer >= 0 && (unsigned)peer != i) || !s->peers[i].p4)
                        continue;
                r = send_command(s, &s->peers[i], module, text);
                if (r < 0)
                        return r;
        }
        return 0;
}

/* ---------------------------------------------------------------------------------------------
 * Declarations received */

static void name_copy(char dst[SLS_NAME_SIZE], const char *src, size_t len)
{
        if (len >= SLS_NAME_SIZE)
                len = SLS_NAME_SIZE - 1;
        memcpy(dst, src, len);
        dst[len] = '\0';
}

static const struct config_var *cfg_vars(const struct sls_peer *p, const struct sls_list *l)
{
        return l == &p->out ? p->cfg->outbound : p->cfg->inbound;
}

/* The variable of declared position pos: a configured one by name, or learned (found or made);
 * SLS_UNMAPPED when we have none for it. A configured list also gives the type. */
static uint32_t declared_id(struct link_sharedlink_session *s, struct sls_peer *p,
                            const struct sls_list *l, const char *name, enum slp_type *type,
                            size_t pos)
{
        const struct config_var *vars = cfg_vars(p, l);
        int id;

        if (!l->learn) {
                for (size_t j = 0; j < l->n_cfg; j++)
                        if (strcmp(vars[j].name, name) == 0) {
                                *type = sls_p4_type_of(vars[j].type);
                                return l->cfg_ids[j];
                        }
                return SLS_UNMAPPED;
        }
        id = sls_made_id(s, p, name, strlen(name),
                         l == &p->out ? SLS_MADE_LEARNED_OUT : SLS_MADE_LEARNED_IN,
                         shm_type_of(*type), (int32_t)pos, SHM_COUNTER_LEARN_FULL,
                         SHM_COUNTER_LEARN_CONFLICT);
        return id < 0 ? SLS_UNMAPPED : (uint32_t)id;
}

/* Whether the declaration in the scratch (n positions) differs from what it is compared to: a
 * configured list from its configured order, a learned one from its previous declaration. */
static bool declaration_differs(const struct sls_peer *p, const struct sls_list *l,
                                const struct sls_scratch *sc, size_t n)
{
        const struct config_var *vars = cfg_vars(p, l);

        if (l->learn) {
                if (!l->declared)
                        return false;
                if (n != l->n)
                        return true;
                for (size_t k = 0; k < n; k++)
                        if (strcmp(sc->names[k], l->names[k]) != 0 || sc->types[k] != l->types[k])
                                return true;
                return false;
        }
        if (n != l->n_cfg)
                return true;
        for (size_t k = 0; k < n; k++)
                if (strcmp(sc->names[k], vars[k].name) != 0)
                        return true;
        return false;
}

/* The new list replaces the old whole; an outbound position keeps the value its variable had. */
static void list_commit(struct sls_peer *p, struct sls_list *l, struct sls_scratch *sc, size_t n)
{
        bool out = l == &p->out;

        for (size_t k = 0; out && k < n; k++) {
                sc->values[k][0] = '\0';
                for (size_t j = 0; sc->ids[k] != SLS_UNMAPPED && j < l->n; j++)
                        if (l->ids[j] == sc->ids[k]) {
                                memcpy(sc->values[k], p->out_values[j], SHM_VALUE_SIZE);
                                break;
                        }
        }
        memcpy(l->ids, sc->ids, n * sizeof(*l->ids));
        memcpy(l->types, sc->types, n * sizeof(*l->types));
        memcpy(l->names, sc->names, n * sizeof(*l->names));
        l->n = n;
        l->declared = true;
        for (size_t k = 0; out && k < n; k++) {
                memcpy(p->out_values[k], sc->values[k], SHM_VALUE_SIZE);
                p->out_dirty[k] = true;
        }
}

/* Our acknowledgement of p's N declaration: each declared name with its current value (empty
 * before we have one), split into frames if needed. */
static void send_acknowledgement(struct link_sharedlink_session *s, struct sls_peer *p)
{
        struct sls_scratch *sc = &s->scratch;
        struct slp_named_list nl = {
                .dst = p->cfg->address,
                .src = s->addr,
                .head = 'N',
                .names = p->in.name_ptrs,
                .values = sc->ptrs,
                .count = p->in.n,
                .max_frame = p->cfg->max_frame,
                .crlf = s->crlf,
        };
        size_t cursor = 0;

        for (size_t k = 0; k < p->in.n; k++) {
                uint32_t id = p->in.ids[k];

                sc->values[k][0] = '\0';
                if (id != SLS_UNMAPPED && s->h->get &&
                    s->h->get(s->arg, id, sc->values[k], SHM_VALUE_SIZE) < 0)
                        sc->values[k][0] = '\0';
                sc->ptrs[k] = sc->values[k];
        }
        while (cursor < p->in.n) {
                int n = slp_encode_acknowledgement(&nl, &cursor, s->txbuf, sizeof(s->txbuf));

                if (n <= 0) {
                        if (n < 0)
                                sls_count(s, SHM_COUNTER_BAD_VALUE, 1);
                        return;
                }
                if (sls_send_frame(s, s->txbuf, (size_t)n) < 0)
                        return;
        }
}

/* Puts the entries of the declaration m into the scratch from position `n`; returns the count.
 * Decision (§4): a bad entry with a Q keeps its place, unmapped; a stray field takes none. */
static size_t declaration_read(struct link_sharedlink_session *s, const struct sls_peer *p,
                               const struct sls_list *l, const struct p4_message *m, size_t n)
{
        struct sls_scratch *sc = &s->scratch;

        sls_refuse(s, SHM_COUNTER_BAD_TYPE, m->bad_entries, "peer %c declared %zu entries with "
                   "a T other than T0, T2, T4 in its %c list: those positions are not used",
                   p->cfg->address, m->bad_entries, m->head);
        for (size_t k = 0; k < m->n_entries; k++) {
                const struct p4_entry *e = &m->entries[k];

                if (!e->positional) {
                        if (e->status == P4_ENTRY_OK)
                                sls_count(s, SHM_COUNTER_BAD_FIELD, 1);     /* an R in it */
                        continue;
                }
                if (n >= l->cap) {
                        sls_refuse(s, SHM_COUNTER_LEARN_FULL, 1, "peer %c declared more than "
                                   "%zu entries in its %c list: the rest are dropped",
                                   p->cfg->address, l->cap, m->head);
                        continue;
                }
                sc->ids[n] = SLS_UNMAPPED;
                sc->types[n] = e->type;
                sc->named[n] = e->status == P4_ENTRY_OK;
                /* A bad type keeps its (valid) name, so answers and acknowledgements list it. */
                name_copy(sc->names[n], e->name ? e->name : "", e->name_len);
                n++;
        }
        return n;
}

/* Whether the declaration in the scratch (n positions) maps `name`: a good entry, or a kept
 * position that has a variable. A bad entry keeps its name but no variable (declaration_read),
 * so it does not keep a learned one alive: that one would be reached by no position. */
static bool scratch_names(const struct sls_scratch *sc, size_t n, const char *name)
{
        for (size_t k = 0; k < n; k++)
                if ((sc->named[k] || sc->ids[k] != SLS_UNMAPPED) &&
                    strcmp(sc->names[k], name) == 0)
                        return true;
        return false;
}

/*
 * Decision (§4): a learned variable the new declaration of its list no longer names is retired
 * before the new names are made, so a link's learned variables never outnumber its current
 * lists and a peer re-declaring new names never fills the table. Its old position is unmapped:
 * the table may give its id to one of the new names, whose value must not be the old one's.
 */
static void learned_retire(struct link_sharedlink_session *s, struct sls_peer *p,
                           struct sls_list *l, const struct sls_scratch *sc, size_t n)
{
        for (size_t k = 0; k < l->n; k++) {
                if (l->ids[k] == SLS_UNMAPPED || scratch_names(sc, n, l->names[k]))
                        continue;
                sls_retire_learned(s, p, l->ids[k]);
                l->ids[k] = SLS_UNMAPPED;
        }
}

/*
 * Decision (§4, issue 21.7): a learned list maps at most learn_max of its positions, the first
 * ones; the others keep their place and name, unmapped, so what we send still has the declared
 * length (an empty D there) and data for them is dropped. Warned with both counts.
 */
static void learned_bound(struct link_sharedlink_session *s, const struct sls_peer *p,
                          const struct sls_list *l, char head, size_t n)
{
        struct sls_scratch *sc = &s->scratch;
        size_t mapped = 0, over = 0;

        for (size_t k = 0; k < n; k++) {
                if (!sc->named[k] && sc->ids[k] == SLS_UNMAPPED)
                        continue;
                if (mapped < p->cfg->learn_max) {
                        mapped++;
                        continue;
                }
                sc->named[k] = false;
                sc->ids[k] = SLS_UNMAPPED;
                over++;
        }
        sls_refuse(s, SHM_COUNTER_LEARN_FULL, over, "peer %c declared %zu entries in its %c "
                   "list, learn_max is %u: the last %zu %s; raise learn_max", p->cfg->address,
                   mapped + over, head, p->cfg->learn_max, over,
                   l == &p->out ? "go out as an empty D" : "are not stored");
}

/* The variables of the entries read into the scratch from position `from`. */
static void declaration_resolve(struct link_sharedlink_session *s, struct sls_peer *p,
                                const struct sls_list *l, size_t from, size_t n)
{
        struct sls_scratch *sc = &s->scratch;

        for (size_t k = from; k < n; k++)
                if (sc->named[k])
                        sc->ids[k] = declared_id(s, p, l, sc->names[k], &sc->types[k], k);
}

/* N0|T|Q... (what p sends: our inbound list) or L0|T|Q... (what it wants: our outbound list). */
static void declaration_in(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now,
                           const struct p4_message *m)
{
        struct sls_list *l = m->head == 'L' ? &p->out : &p->in;
        struct sls_scratch *sc = &s->scratch;
        size_t n = 0, from;

        sls_count(s, SHM_COUNTER_DECLARATIONS_IN, 1);
        if (m->index > 0) {
                /* N<k>: the declaration goes on at position k (we never send one); what is
                 * before k stays, a gap is unmapped. */
                size_t keep = m->index < l->n ? m->index : l->n;

                n = m->index < l->cap ? m->index : l->cap;
                memcpy(sc->ids, l->ids, keep * sizeof(*sc->ids));
                memcpy(sc->types, l->types, keep * sizeof(*sc->types));
                memcpy(sc->names, l->names, keep * sizeof(*sc->names));
                /* Kept positions are resolved already: their ids say what they map. */
                memset(sc->named, 0, n * sizeof(*sc->named));
                for (size_t k = keep; k < n; k++) {
                        sc->ids[k] = SLS_UNMAPPED;
                        sc->types[k] = SLP_TYPE_DOUBLE;
                        sc->names[k][0] = '\0';
                }
        }
        from = n;
        n = declaration_read(s, p, l, m, n);
        if (l->learn) {
                learned_bound(s, p, l, m->head, n);
                learned_retire(s, p, l, sc, n);
        }
        s->remade = 0;
        declaration_resolve(s, p, l, from, n);
        if (s->remade > 0)
                sls_diagf(s, LOG_PRIO_INFO, "peer %c declared %u names a self-describing frame "
                          "had made first: they are now its %c list's, %s, with the declared "
                          "types", p->cfg->address, s->remade, m->head,
                          l == &p->out ? "outbound" : "inbound");
        /* Decision (§4): a re-declaration replaces the list whole, counted when it differs. */
        if (declaration_differs(p, l, sc, n)) {
                sls_count(s, SHM_COUNTER_REDECLARED, 1);
                sls_diagf(s, LOG_PRIO_INFO, "peer %c declared another %c list (%zu entries)",
                          p->cfg->address, m->head, n);
        }
        list_commit(p, l, sc, n);
        if (l == &p->out) {
                sls_outrefs_build(s);
                if (s->up && n > 0)
                        sls_send_full(s, p, now);
        } else if (!p->cfg->declare) {
                send_acknowledgement(s, p);
        }
}

/* ---------------------------------------------------------------------------------------------
 * Other frames received */

/* N0|R|D...: the answer to our N declaration. Decision (§5): counted, names compared, nothing
 * stored (we own those values). */
static void acknowledgement_in(struct link_sharedlink_session *s, struct sls_peer *p,
                               const struct p4_message *m)
{
        bool same = m->n_entries == p->out.n;

        sls_count(s, SHM_COUNTER_ACKS_IN, 1);
        for (size_t k = 0; same && k < m->n_entries; k++) {
                const struct p4_entry *e = &m->entries[k];

                same = e->status == P4_ENTRY_OK && e->name_len == strlen(p->out.names[k]) &&
                       memcmp(e->name, p->out.names[k], e->name_len) == 0;
        }
        if (same)
                return;
        sls_count(s, SHM_COUNTER_REDECLARED, 1);
        sls_diagf(s, LOG_PRIO_INFO, "peer %c acknowledged %zu names, not the %zu we declared",
                  p->cfg->address, m->n_entries, p->out.n);
}

/* An inbound variable of p called name (its current list, then its configured one), or
 * SLS_UNMAPPED. */
static uint32_t inbound_by_name(const struct sls_peer *p, const char *name, size_t len)
{
        for (size_t k = 0; k < p->in.n; k++)
                if (p->in.ids[k] != SLS_UNMAPPED && strlen(p->in.names[k]) == len &&
                    memcmp(p->in.names[k], name, len) == 0)
                        return p->in.ids[k];
        for (size_t j = 0; j < p->in.n_cfg; j++)
                if (strlen(p->cfg->inbound[j].name) == len &&
                    memcmp(p->cfg->inbound[j].name, name, len) == 0)
                        return p->in.cfg_ids[j];
        return SLS_UNMAPPED;
}

/* Whether name is in p's outbound list (what we send it). */
static bool outbound_names(const struct sls_peer *p, const char *name, size_t len)
{
        for (size_t k = 0; k < p->out.n; k++)
                if (strlen(p->out.names[k]) == len && memcmp(p->out.names[k], name, len) == 0)
                        return true;
        return false;
}

/* N0|T|Q|D...: each triple sets that variable by name (§7); a name we lack is ad hoc. */
static void described_in(struct link_sharedlink_session *s, struct sls_peer *p,
                         const struct p4_message *m)
{
        for (size_t k = 0; k < m->n_entries; k++) {
                const struct p4_entry *e = &m->entries[k];
                uint32_t id;
                int made;

                if (e->status != P4_ENTRY_OK) {
                        sls_refuse(s, SHM_COUNTER_BAD_TYPE, 1, "peer %c sent a self-describing "
                                   "entry with a T other than T0, T2, T4: dropped",
                                   p->cfg->address);
                        continue;
                }
                if (!e->has_value) {
                        sls_count(s, SHM_COUNTER_BAD_FIELD, 1);
                        continue;
                }
                /* Decision (§7): a name of our own outbound list carries a value we own: it
                 * is not the peer's to set, and no ad hoc name either. */
                if (e->value_len == 0 || outbound_names(p, e->name, e->name_len))
                        continue;
                if (slp_value_check(e->type, e->value, e->value_len) < 0) {
                        sls_refuse(s, SHM_COUNTER_TYPE_MISMATCH, 1, "peer %c sent \"%.*s\" "
                                   "for %.*s, declared T%c in the same frame: dropped",
                                   p->cfg->address, (int)e->value_len, e->value,
                                   (int)e->name_len, e->name, slp_type_digit(e->type));
                        continue;
                }
                id = inbound_by_name(p, e->name, e->name_len);
                if (id == SLS_UNMAPPED) {
                        made = sls_made_id(s, p, e->name, e->name_len, SLS_MADE_ADHOC,
                                           shm_type_of(e->type), SHM_POSITION_NONE,
                                           SHM_COUNTER_ADHOC_FULL, SHM_COUNTER_ADHOC_FULL);
                        if (made < 0)
                                continue;
                        id = (uint32_t)made;
                }
                sls_publish(s, id, e->value, e->value_len);
        }
}

/* L? asks for what we send (answered N0|T|Q...), N? for what we receive (L0|T|Q...), §6. */
static void list_query_in(struct link_sharedlink_session *s, struct sls_peer *p,
                          const struct p4_message *m)
{
        const struct sls_list *l = m->head == 'L' ? &p->out : &p->in;

        /* Decision (§6, issue 21.5): a learned list the peer has not declared yet is no list
         * we can answer with; a client that asks and never declares (the ROS 1 adapter) waits
         * for ever, so say what to configure. */
        if (l->learn && !l->declared) {
                sls_refuse(s, SHM_COUNTER_LIST_UNKNOWN, 1, "peer %c asked for our %s list (%c?), "
                           "but it is `%s: learn` and the peer has not declared it (%c0): a "
                           "peer that never declares needs `%s:` configured", p->cfg->address,
                           l == &p->out ? "outbound" : "inbound", m->head,
                           l == &p->out ? "outbound" : "inbound", l == &p->out ? 'L' : 'N',
                           l == &p->out ? "outbound" : "inbound");
                return;
        }
        send_declaration(s, p, m->head == 'L' ? 'N' : 'L', l);
}

/* Text for an event's text="..." value: " and \ escaped. */
static void quote(char *dst, size_t size, const char *src, size_t len)
{
        size_t o = 0;

        for (size_t i = 0; i < len && o + 2 < size; i++) {
                if (src[i] == '"' || src[i] == '\\')
                        dst[o++] = '\\';
                dst[o++] = src[i];
        }
        dst[o] = '\0';
}

/* The next comma-separated word of text[*pos, len), spaces around it dropped. */
static void word_next(const char *text, size_t len, size_t *pos, const char **ret_word,
                      size_t *ret_len)
{
        size_t i = *pos, end;

        while (i < len && text[i] == ' ')
                i++;
        end = i;
        while (end < len && text[end] != ',')
                end++;
        *ret_word = text + i;
        *ret_len = end - i;
        while (*ret_len > 0 && text[i + *ret_len - 1] == ' ')
                (*ret_len)--;
        *pos = end < len ? end + 1 : end;
}

static bool word_is(const char *word, size_t len, const char *want)
{
        return len == strlen(want) && strncasecmp(word, want, len) == 0;
}

/* "0, outbound, off" (§9): which of our lists the host switches, and how; false for any other
 * ELink text (SetIP ...). */
static bool link_switch_parse(const char *text, size_t len, bool *ret_out, bool *ret_on)
{
        const char *w[3];
        size_t wl[3], pos = 0;

        for (int i = 0; i < 3; i++)
                word_next(text, len, &pos, &w[i], &wl[i]);
        if (pos < len)
                return false;
        *ret_out = word_is(w[1], wl[1], "outbound");
        if (!*ret_out && !word_is(w[1], wl[1], "inbound"))
                return false;
        *ret_on = word_is(w[2], wl[2], "on");
        return *ret_on || word_is(w[2], wl[2], "off");
}

/*
 * Decision (§9, issue 21.6): a vehicle obeys the host's ELink outbound/inbound on/off as a
 * Pronto4 does: outbound off, no data to the host (the values wait; on sends the whole list at
 * once); inbound off, the host's data frames are dropped (counted inbound_off). Both start on.
 */
static void link_switch_in(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now,
                           const struct p4_message *m)
{
        bool out, on, *off;

        if (p->cfg->role != CONFIG_P4_VEHICLE || !word_is(m->module, m->module_len,
                                                          P4_CONNECT_MODULE) ||
            !link_switch_parse(m->text, m->text_len, &out, &on))
                return;
        off = out ? &p->out_off : &p->in_off;
        if (*off == !on)
                return;
        *off = !on;
        sls_diagf(s, LOG_PRIO_INFO, "peer %c turned our %s %s", p->cfg->address,
                  out ? "outbound" : "inbound", on ? "on" : "off");
        sls_peer_state_update(s);
        if (out && on && s->up)
                sls_send_full(s, p, now);
}

/* E<module>|D<text> (§9): an event "module=ServoPod text="0,TELEOP START"". */
static void command_in(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now,
                       const struct p4_message *m)
{
        char text[2 * SLP_VALUE_MAX + 1];

        if (!m->command_ok) {
                sls_count(s, SHM_COUNTER_BAD_COMMAND, 1);
                return;
        }
        sls_count(s, SHM_COUNTER_COMMANDS_IN, 1);
        sls_count(s, SHM_COUNTER_UNKNOWN_FIELD, m->extra_fields);
        quote(text, sizeof(text), m->text, m->text_len);
        sls_eventf(s, SHM_EVENT_COMMAND, "module=%.*s text=\"%s\"", (int)m->module_len,
                   m->module, text);
        link_switch_in(s, p, now, m);
}

bool sls_p4_frame(struct link_sharedlink_session *s, struct sls_peer *p, uint64_t now,
                  const struct slp_frame *f)
{
        const struct p4_message *m = &s->p4;

        p4_decode(f, &s->p4);
        switch (m->kind) {
        case SLP_P4_DECLARATION:
                declaration_in(s, p, now, m);
                return true;
        case SLP_P4_ACKNOWLEDGEMENT:
                acknowledgement_in(s, p, m);
                return true;
        case SLP_P4_SELF_DESCRIBING:
                if (p->in_off)
                        sls_count(s, SHM_COUNTER_INBOUND_OFF, 1);
                else
                        described_in(s, p, m);
                return true;
        case SLP_P4_LIST_QUERY:
                list_query_in(s, p, m);
                return true;
        case SLP_P4_COMMAND:
                command_in(s, p, now, m);
                return true;
        case SLP_P4_MU:
                /* MUI, MUO, ML, MW: the same event, no text (§9). */
                sls_count(s, SHM_COUNTER_COMMANDS_IN, 1);
                sls_eventf(s, SHM_EVENT_COMMAND, "module=%c%.*s", m->head, (int)m->module_len,
                           m->module);
                return true;
        case SLP_P4_DATA:
                if (p->in_off) {
                        sls_count(s, SHM_COUNTER_INBOUND_OFF, 1);
                        return true;
                }
                if (p->in.learn && !p->in.declared) {
                        /* Decision (§7): no list to read it against. */
                        sls_refuse(s, SHM_COUNTER_UNDECLARED_DATA, 1, "peer %c sent data before "
                                   "it declared its list (N0): dropped; a peer that never "
                                   "declares needs `inbound:` configured", p->cfg->address);
                        return true;
                }
                return false;
        default:
                return false;           /* ping, pong, bulletin traffic */
        }
}
