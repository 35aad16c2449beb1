/*
 * SharedLink link engine (see link_sharedlink.h for the behaviour it promises): the wiring of a
 * link_sharedlink_session (link_sharedlink_session.h, all of the protocol logic) to the channel,
 * the shm table, the control socket and one evloop timer.
 *
 *     channel bytes -> lsl_input() -> session -> hooks: shm_table_*, channel_send
 *     client write -> core's outbound scan -> lsl_outbound() -> session -> channel_send
 *     control "query" -> lsl_command() -> session query (or the wait queue first) -> answer hook
 *     control "ping-peer" -> lsl_command() -> session ping P0 -> pong hook (G0): the round trip
 *
 * One timer, armed for the earliest of the session's deadline and the wait queue's, after
 * every call into the session ("settle"), so an idle link never wakes the daemon.
 */
#include "daemon/link_sharedlink.h"

#include <arpa/inet.h>
#include <assert.h>
#include <errno.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <stddef.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "daemon/control.h"
#include "svc/log.h"
#include "proto/sharedlink.h"
#include "shm/table.h"

#define NS_PER_MS               1000000ull
#define STATUS_MAX              (CHANNEL_REASON_MAX + 16)

/* A query, a command or a ping waiting for the link to come up. */
struct lsl_wait {
        bool command;
        bool ping;
        int peer;
        unsigned timeout_ms;
        char name[SHM_NAME_SIZE];               /* query: the variable */
        char module[SLP_VALUE_MAX + 1];         /* command */
        char text[SLP_VALUE_MAX + 1];
};

/* A ping sent, until its pong, its deadline, the link going down or its client leaving. */
struct lsl_ping {
        struct control_request *req;            /* NULL: a free slot */
        char peer;                              /* the address pinged */
        unsigned timeout_ms;
        uint64_t sent_ns;
        uint64_t deadline_ms;
};

struct lsl {
        struct link_env env;
        const struct config_link *cfg;
        struct channel *ch;
        struct link_sharedlink_session *session;
        struct evloop_timer timer;
        struct link_waitq waitq;
        struct lsl_ping pings[LINK_SHAREDLINK_PINGS_MAX];

        enum link_sharedlink_state state;
        char status[STATUS_MAX];
        char peer_state[LINK_SHAREDLINK_PEER_STATE_MAX];   /* the session's, after "up; " */
        struct log_ratelimit rl;
};
static_assert(offsetof(struct lsl, env) == 0, "link_hook_*() take the engine as its link_env");

static uint64_t now_ms(void)
{
        return evloop_clock_ns() / NS_PER_MS;
}

/* Copies src into dst[size], cut to fit. */
static void copy_cut(char *dst, size_t size, const char *src)
{
        size_t n = strnlen(src, size - 1);

        memcpy(dst, src, n);
        dst[n] = '\0';
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
        char status[STATUS_MAX];
        bool changed = s != l->state;

        if (s == LINK_SHAREDLINK_STATE_DOWN)
                snprintf(status, sizeof(status), "down: %s", reason && *reason ? reason : "?");
        else if (s == LINK_SHAREDLINK_STATE_UP && l->peer_state[0])
                snprintf(status, sizeof(status), "up; %s", l->peer_state);
        else
                snprintf(status, sizeof(status), "%s", state_word(s));
        if (!changed && strcmp(status, l->status) == 0)
                return;
        snprintf(l->status, sizeof(l->status), "%s", status);
        /* Whole (up to SHM_LINK_TEXT_SIZE - 1 bytes): a broken recording's FILE:LINE: message. */
        shm_table_link_state(l->env.table, l->env.shm_link, (uint32_t)s, status);
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
 * Session hooks */

static int hook_send(void *arg, const char *buf, size_t len)
{
        struct lsl *l = arg;

        return channel_send(l->ch, buf, len);
}

static int hook_find(void *arg, const char *name)
{
        struct lsl *l = arg;

        return shm_table_find(l->env.table, name);
}

static int hook_add(void *arg, const char *name, unsigned type, char peer, bool outbound,
                    int32_t position)
{
        struct lsl *l = arg;
        struct shm_var v = {
                .name = name,
                .direction = outbound ? SHM_DIR_OUT : SHM_DIR_IN,
                .type = type,
                .link = l->env.shm_link,
                .peer = slp_address_text(peer),
                .position = position,
        };

        return shm_table_add(l->env.table, &v);
}

static int hook_retire(void *arg, uint32_t id)
{
        struct lsl *l = arg;

        return shm_table_retire(l->env.table, id);
}

static int hook_get(void *arg, uint32_t id, char *buf, size_t size)
{
        struct lsl *l = arg;
        uint32_t flags = 0;
        int n = shm_table_get(l->env.table, id, buf, size, &flags);

        return n >= 0 && !(flags & SHM_SLOT_VALID) ? -ENODATA : n;
}

static int hook_publish(void *arg, uint32_t id, const char *value, size_t len)
{
        struct lsl *l = arg;

        return shm_table_set(l->env.table, id, value, len);
}

static void hook_stale(void *arg, uint32_t id)
{
        struct lsl *l = arg;

        shm_table_set_stale(l->env.table, id, 1);
}

static void hook_batch(void *arg, bool begin)
{
        struct lsl *l = arg;

        if (begin)
                shm_table_begin(l->env.table);
        else
                shm_table_commit(l->env.table);
}

static void hook_answer(void *arg, void *token, int err, const char *text)
{
        (void)arg;
        if (err)
                control_reply_error(token, err, "%s", text);
        else
                control_reply_ok(token, "%s", text);
}

/* Ends ping slot k with err (0: the pong, rtt_ns its round trip) and frees it. */
static void ping_end(struct lsl *l, unsigned k, int err, uint64_t rtt_ns)
{
        struct lsl_ping *pg = &l->pings[k];
        struct control_request *req = pg->req;

        pg->req = NULL;
        if (err == 0)
                control_reply_ok(req, "%llu", (unsigned long long)rtt_ns);
        else if (err == ETIMEDOUT)
                control_reply_error(req, ETIMEDOUT, "no pong from peer %c within %u ms",
                                    pg->peer, pg->timeout_ms);
        else if (err == ENOTCONN)
                control_reply_error(req, ENOTCONN, "link %s is %s", l->cfg->name, l->status);
        else
                control_reply_error(req, err, "ping to peer %c abandoned: %s", pg->peer,
                                    strerror(err));
}

/* G0 answers the oldest ping pending to that peer (a peer answers in order; a pong that
 * answers nothing, or a G<n> we did not send, only shows the peer alive). */
static void hook_pong(void *arg, char peer, const char *value, size_t len)
{
        struct lsl *l = arg;
        uint64_t now = evloop_clock_ns();
        int oldest = -1;

        if (len != 1 || value[0] != '0')
                return;
        for (unsigned k = 0; k < LINK_SHAREDLINK_PINGS_MAX; k++)
                if (l->pings[k].req && l->pings[k].peer == peer &&
                    (oldest < 0 || l->pings[k].sent_ns < l->pings[oldest].sent_ns))
                        oldest = (int)k;
        if (oldest >= 0)
                ping_end(l, (unsigned)oldest, 0, now - l->pings[oldest].sent_ns);
}

static bool hook_alive(void *arg, void *token)
{
        (void)arg;
        return control_request_alive(token);
}

static void hook_diag(void *arg, enum log_prio prio, const char *text)
{
        struct lsl *l = arg;

        log_ratelimited(&l->rl, prio, "link %s: %s", l->cfg->name, text);
}

/* What the pronto4 peers asked of the link (outbound/inbound off), shown while it is up. */
static void hook_peer_state(void *arg, const char *text)
{
        struct lsl *l = arg;

        copy_cut(l->peer_state, sizeof(l->peer_state), text);
        if (l->state == LINK_SHAREDLINK_STATE_UP)
                state_set(l, LINK_SHAREDLINK_STATE_UP, NULL);
}

/* "<ip>:<port>" the peer reaches us at: the socket's own address, which for a socket connected
 * toward remote: is the source the kernel picked even when local: is a wildcard. */
static int hook_local_address(void *arg, char *buf, size_t size, unsigned *ret_remote_port)
{
        struct lsl *l = arg;
        struct transport *t = channel_transport(l->ch);
        struct sockaddr_storage ss;
        socklen_t len = sizeof(ss);
        char ip[INET6_ADDRSTRLEN];
        const void *a;
        unsigned port;
        int n;

        if (l->cfg->transport != CONFIG_TRANSPORT_UDP || !l->cfg->has_remote || !t)
                return -ENOTSUP;
        if (getsockname(transport_fd(t), (struct sockaddr *)&ss, &len) < 0)
                return -errno;
        if (ss.ss_family == AF_INET) {
                const struct sockaddr_in *in = (const struct sockaddr_in *)&ss;

                if (in->sin_addr.s_addr == htonl(INADDR_ANY))
                        return -EADDRNOTAVAIL;
                a = &in->sin_addr;
                port = ntohs(in->sin_port);
        } else if (ss.ss_family == AF_INET6) {
                const struct sockaddr_in6 *in6 = (const struct sockaddr_in6 *)&ss;

                if (IN6_IS_ADDR_UNSPECIFIED(&in6->sin6_addr))
                        return -EADDRNOTAVAIL;
                a = &in6->sin6_addr;
                port = ntohs(in6->sin6_port);
        } else {
                return -EAFNOSUPPORT;
        }
        if (!inet_ntop(ss.ss_family, a, ip, sizeof(ip)))
                return -errno;
        *ret_remote_port = ntohs(l->cfg->remote.addr.ss_family == AF_INET6
                ? ((const struct sockaddr_in6 *)&l->cfg->remote.addr)->sin6_port
                : ((const struct sockaddr_in *)&l->cfg->remote.addr)->sin_port);
        n = snprintf(buf, size, ss.ss_family == AF_INET6 ? "[%s]:%u" : "%s:%u", ip, port);
        return n > 0 && (size_t)n < size ? n : -ENAMETOOLONG;
}

static const struct link_sharedlink_hooks session_hooks = {
        .send = hook_send,
        .find = hook_find,
        .add = hook_add,
        .retire = hook_retire,
        .get = hook_get,
        .publish = hook_publish,
        .stale = hook_stale,
        .batch = hook_batch,
        .event = link_hook_event,
        .count = link_hook_count,
        .answer = hook_answer,
        .alive = hook_alive,
        .diag = hook_diag,
        .local_address = hook_local_address,
        .peer_state = hook_peer_state,
        .pong = hook_pong,
};

/* ---------------------------------------------------------------------------------------------
 * Queries from the control socket */

/* Sends a command: OK once the frame is queued, or why not. */
static void command_start(struct lsl *l, struct control_request *req, const struct lsl_wait *w)
{
        int r = link_sharedlink_session_command(l->session, now_ms(), -1, w->module, w->text);

        if (r == 0)
                control_reply_ok(req, NULL);
        else if (r == -EOPNOTSUPP)
                control_reply_error(req, EOPNOTSUPP, "link %s has no pronto4 peer",
                                    l->cfg->name);
        else if (r == -ENOTCONN)
                control_reply_error(req, ENOTCONN, "link %s is %s", l->cfg->name, l->status);
        else if (r == -EINVAL)
                control_reply_error(req, EINVAL, "bad command: module a name of at most %u "
                                    "bytes (letters, digits, _ . -), text at most %u bytes of "
                                    "0x20-0x7E without | [ ]", SLP_VALUE_MAX, SLP_VALUE_MAX);
        else
                control_reply_error(req, -r, "cannot send the command: %s", strerror(-r));
}

/* Sends P0 to the peer and holds req until its G0, or answers req with why not. */
static void ping_start(struct lsl *l, struct control_request *req, const struct lsl_wait *w)
{
        struct lsl_ping *pg = NULL;
        uint64_t sent_ns;
        int r;

        for (unsigned k = 0; k < LINK_SHAREDLINK_PINGS_MAX; k++) {
                /* A ping whose client left answers nobody: its slot is free again. */
                if (l->pings[k].req && !control_request_alive(l->pings[k].req))
                        ping_end(l, k, ECANCELED, 0);
                if (!l->pings[k].req && !pg)
                        pg = &l->pings[k];
        }
        if (!pg) {
                control_reply_error(req, EBUSY, "%u pings pending on link %s",
                                    LINK_SHAREDLINK_PINGS_MAX, l->cfg->name);
                return;
        }
        sent_ns = evloop_clock_ns();    /* before the send: the round trip includes it */
        r = link_sharedlink_session_ping(l->session, w->peer);
        if (r == -ENOTCONN) {
                control_reply_error(req, ENOTCONN, "link %s is %s", l->cfg->name, l->status);
                return;
        }
        if (r < 0) {
                control_reply_error(req, -r, "cannot send the ping: %s", strerror(-r));
                return;
        }
        *pg = (struct lsl_ping){
                .req = req,
                .peer = w->name[0],
                .timeout_ms = w->timeout_ms,
                .sent_ns = sent_ns,
                .deadline_ms = now_ms() + w->timeout_ms,
        };
}

/* The pings past their deadline end ETIMEDOUT; returns the earliest deadline left. */
static uint64_t pings_tick(struct lsl *l, uint64_t now)
{
        uint64_t d = LINK_SHAREDLINK_NEVER;

        for (unsigned k = 0; k < LINK_SHAREDLINK_PINGS_MAX; k++) {
                if (!l->pings[k].req)
                        continue;
                if (l->pings[k].deadline_ms <= now)
                        ping_end(l, k, ETIMEDOUT, 0);
                else if (l->pings[k].deadline_ms < d)
                        d = l->pings[k].deadline_ms;
        }
        return d;
}

/* Ends every pending ping with err (the link went down, or is stopped). */
static void pings_fail(struct lsl *l, int err)
{
        for (unsigned k = 0; k < LINK_SHAREDLINK_PINGS_MAX; k++)
                if (l->pings[k].req)
                        ping_end(l, k, err, 0);
}

/* Starts a query on the session, or answers req with why it cannot start. */
static void query_start(struct lsl *l, struct control_request *req, const struct lsl_wait *w)
{
        int r;

        if (w->command) {
                command_start(l, req, w);
                return;
        }
        if (w->ping) {
                ping_start(l, req, w);
                return;
        }
        r = link_sharedlink_session_query(l->session, now_ms(), req, w->peer, w->name,
                                          w->timeout_ms);

        if (r == -EBUSY)
                control_reply_error(req, EBUSY, "%u queries pending on link %s",
                                    LINK_SHAREDLINK_QUERIES_MAX, l->cfg->name);
        else if (r == -ENOTCONN)
                control_reply_error(req, ENOTCONN, "link %s is %s", l->cfg->name, l->status);
        else if (r == -EMSGSIZE)
                control_reply_error(req, EMSGSIZE, "a query for %s does not fit the peer's "
                                    "max_frame", w->name);
        else if (r < 0)
                control_reply_error(req, r, "cannot send the query: %s", strerror(-r));
}

static bool wait_ready(void *engine)
{
        struct lsl *l = engine;

        return link_sharedlink_session_is_up(l->session);
}

static void wait_run(void *engine, struct control_request *req, const void *data)
{
        query_start(engine, req, data);
}

static void wait_expire(void *engine, struct control_request *req, const void *data,
                        unsigned wait_ms)
{
        (void)engine;
        (void)data;
        (void)wait_ms;
        control_reply_error(req, ENOTCONN, "link down");
}

static const struct link_waitq_ops wait_ops = {
        .ready = wait_ready,
        .run = wait_run,
        .expire = wait_expire,
};

/* After the session ran: waiting queries, then the one timer. */
static void settle(struct lsl *l)
{
        uint64_t now = now_ms();
        uint64_t d;

        uint64_t pd;

        link_waitq_run(&l->waitq, now, &wait_ops, l);
        pd = pings_tick(l, now);
        d = link_sharedlink_session_deadline(l->session);
        if (link_waitq_deadline(&l->waitq) < d)
                d = link_waitq_deadline(&l->waitq);
        if (pd < d)
                d = pd;
        if (d == LINK_SHAREDLINK_NEVER) {
                evloop_timer_cancel(&l->timer);
                return;
        }
        if (evloop_timer_arm(&l->timer, d > now ? d - now : 0, 0) < 0)
                log_warnx("link %s: cannot arm its timer", l->cfg->name);
}

static void on_timer(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        struct lsl *l = arg;

        (void)loop;
        (void)timer;
        link_sharedlink_session_tick(l->session, now_ms());
        settle(l);
}

/* Runs w now, or holds it while the link is down and the request said wait=MS. */
static void request_run(struct lsl *l, struct control_request *req, const struct lsl_wait *w,
                        unsigned wait_ms)
{
        if (link_sharedlink_session_is_up(l->session) || wait_ms == 0) {
                query_start(l, req, w);
        } else if (link_waitq_add(&l->waitq, req, now_ms(), wait_ms, w, sizeof(*w)) < 0) {
                control_reply_error(req, EBUSY, "%u requests wait for link %s",
                                    LINK_WAITQ_MAX, l->cfg->name);
                return;
        }
        settle(l);
}

/* The core decodes requests with the vocabulary; what it lets through fits struct lsl_wait. */
static_assert(LINK_SHAREDLINK_QUERY_TIMEOUT_MAX_MS == REQP_QUERY_TIMEOUT_MAX_MS, "query timeout");
static_assert(REQP_MODULE_SIZE <= sizeof(((struct lsl_wait *)0)->module) &&
              REQP_TEXT_SIZE <= sizeof(((struct lsl_wait *)0)->text) &&
              REQP_NAME_SIZE <= sizeof(((struct lsl_wait *)0)->name), "request words fit");

/* "query LINK PEER NAME [TIMEOUT_MS]", "command LINK MODULE [TEXT...]" or "ping-peer LINK PEER
 * [TIMEOUT_MS]", decoded by the core: only which peers this link has is left to check. */
static void lsl_command(void *engine, struct control_request *req, const struct reqp_request *r)
{
        struct lsl *l = engine;
        struct lsl_wait w = { .timeout_ms = LINK_SHAREDLINK_QUERY_TIMEOUT_MS };

        if (r->kind == REQP_PEER_PING) {
                w.ping = true;
                w.peer = link_sharedlink_session_peer(l->session, r->u.ping.peer);
                if (w.peer < 0) {
                        control_reply_error(req, EINVAL, "%s is not a peer of link %s",
                                            r->u.ping.peer, l->cfg->name);
                        return;
                }
                if (r->u.ping.has_timeout)
                        w.timeout_ms = r->u.ping.timeout_ms;
                w.name[0] = r->u.ping.peer[0];          /* the address, for the messages */
                request_run(l, req, &w, r->wait_ms);
                return;
        }

        if (r->kind == REQP_COMMAND) {
                w.command = true;
                copy_cut(w.module, sizeof(w.module), r->u.command.module);
                copy_cut(w.text, sizeof(w.text), r->u.command.text);
                request_run(l, req, &w, r->wait_ms);
                return;
        }
        if (r->kind != REQP_QUERY) {
                control_reply_error(req, EINVAL, "link %s speaks sharedlink: query, command "
                                    "or ping-peer", l->cfg->name);
                return;
        }
        w.peer = link_sharedlink_session_peer(l->session, r->u.query.peer);
        if (w.peer < 0) {
                control_reply_error(req, EINVAL, "%s is not a peer of link %s", r->u.query.peer,
                                    l->cfg->name);
                return;
        }
        if (r->u.query.has_timeout)
                w.timeout_ms = r->u.query.timeout_ms;
        copy_cut(w.name, sizeof(w.name), r->u.query.name);
        request_run(l, req, &w, r->wait_ms);
}

/* ---------------------------------------------------------------------------------------------
 * Channel up and down */

static void on_input(struct channel *ch, const uint8_t *data, size_t len, void *arg)
{
        struct lsl *l = arg;

        (void)ch;
        link_sharedlink_session_input(l->session, now_ms(), data, len);
        settle(l);
        link_publish_channel_stats(&l->env, l->ch);
}

static void link_up(struct lsl *l)
{
        log_info("link %s: up (%s)", l->cfg->name, channel_device(l->ch));
        state_set(l, LINK_SHAREDLINK_STATE_UP, NULL);
        link_sharedlink_session_up(l->session, now_ms());
        settle(l);
        link_publish_channel_stats(&l->env, l->ch);
}

static void link_down(struct lsl *l, const char *reason, unsigned retry_ms)
{
        if (l->state == LINK_SHAREDLINK_STATE_UP || l->state == LINK_SHAREDLINK_STATE_CONNECTING)
                log_warnx("link %s: down: %s (retry in %u ms)", l->cfg->name, reason, retry_ms);
        shm_table_set_link_stale(l->env.table, l->env.shm_link, 1);
        link_sharedlink_session_down(l->session, now_ms());
        state_set(l, LINK_SHAREDLINK_STATE_DOWN, reason);
        pings_fail(l, ENOTCONN);        /* after state_set: the message says why */
        settle(l);
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

        /* Names point into cfg and peers to slp_address_text(): nothing goes to names_buf. */
        (void)names_buf;
        (void)names_size;
        (void)names_used;
        if (cfg->protocol != CONFIG_PROTOCOL_SHAREDLINK)
                return -EINVAL;
        for (unsigned i = 0; i < sl->n_peers; i++) {
                if (!slp_address_valid(sl->peers[i].address))
                        return -EINVAL;
                need += (size_t)sl->peers[i].n_outbound + sl->peers[i].n_inbound;
        }
        if (at > max || need > max - at)
                return -ENOSPC;
        for (unsigned i = 0; i < sl->n_peers; i++) {
                const struct config_peer *p = &sl->peers[i];
                const char *peer = slp_address_text(p->address);

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

static int lsl_create(const struct link_env *env, void **ret_engine)
{
        static const struct channel_ops ch_ops = {
                .up = on_channel_up,
                .down = on_channel_down,
                .input = on_input,
        };
        const struct config_link *cfg = env->cfg;
        struct lsl *l;
        int r;

        if (cfg->protocol != CONFIG_PROTOCOL_SHAREDLINK)
                return -EINVAL;
        l = calloc(1, sizeof(*l));
        if (!l)
                return -ENOMEM;
        l->env = *env;
        l->cfg = cfg;
        l->state = LINK_SHAREDLINK_STATE_CONNECTING;
        snprintf(l->status, sizeof(l->status), "%s", state_word(l->state));
        log_ratelimit_init(&l->rl, cfg->name, LOG_RATELIMIT_INTERVAL_MS, LOG_RATELIMIT_BURST);
        evloop_timer_init(&l->timer, env->loop, on_timer, l);
        /* The channel first: it knows whether reads are datagrams (udp, or a replay of udp). */
        r = link_channel_new(env, &ch_ops, l, &l->ch);
        if (r < 0)
                goto fail;
        r = link_sharedlink_session_new(cfg, channel_datagram(l->ch), &session_hooks, l,
                                        &l->session);
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
        /* Nothing is armed or pending before the channel starts. */
        link_sharedlink_session_free(l->session);
        channel_free(l->ch);
        free(l);
        return r;
}

static void lsl_destroy(void *engine)
{
        struct lsl *l = engine;

        if (!l)
                return;
        evloop_timer_cancel(&l->timer);
        link_waitq_cancel(&l->waitq, ECANCELED, "link stopped");
        pings_fail(l, ECANCELED);
        l->session = link_sharedlink_session_free(l->session);
        l->ch = channel_free(l->ch);
        shm_table_set_link_stale(l->env.table, l->env.shm_link, 1);
        state_set(l, LINK_SHAREDLINK_STATE_STOPPED, NULL);
        free(l);
}

static void lsl_outbound(void *engine, const struct shm_out_change *change)
{
        struct lsl *l = engine;

        /* Invalid writes never reach the wire; a repaired slot keeps the last good value. */
        if (change->status != SHM_OUT_CHANGED)
                return;
        link_sharedlink_session_outbound(l->session, now_ms(), change->id, change->value);
        settle(l);
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

/* A Pronto4 peer's learned list holds up to learn_max names; each learned outbound list as many
 * spare .out slots. */
static void lsl_learning(const struct config_link *cfg, struct link_learning *ret)
{
        for (unsigned k = 0; k < cfg->sl.n_peers; k++) {
                const struct config_peer *p = &cfg->sl.peers[k];

                if (p->outbound_learn)
                        ret->outbound = true;
                if (p->dialect != CONFIG_DIALECT_PRONTO4)
                        continue;
                ret->adhoc += (p->outbound_learn + p->inbound_learn) * p->learn_max;
                ret->out_spare += p->outbound_learn * p->learn_max;
        }
}

static const char *const sharedlink_words[] = { "query", "command", "ping-peer", NULL };

const struct link_ops link_sharedlink_ops = {
        .command_words = sharedlink_words,
        .declare = lsl_declare,
        .create = lsl_create,
        .destroy = lsl_destroy,
        .outbound = lsl_outbound,
        .command = lsl_command,
        .status = lsl_status,
        .heartbeat = lsl_heartbeat,
        .learning = lsl_learning,
};
