/*
 * CIRCE link engine (link_circe.h): channel, decoder, session, table and control socket.
 */
#include "daemon/link_circe.h"

#include <assert.h>
#include <errno.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "daemon/control.h"
#include "daemon/link_circe_controller.h"
#include "daemon/link_circe_mediator.h"
#include "daemon/link_circe_session.h"
#include "svc/log.h"
#include "shm/table.h"

#define NS_PER_MS               1000000ull
#define ID_NONE                 (-1)            /* no variable (the table was full) */
#define ID_UNRESOLVED           (-2)            /* not looked up yet */
#define STATUS_LINE_MAX         (CHANNEL_REASON_MAX + 32)
#define VALUE_TEXT_MAX          24              /* a number or an address, NUL included */
#define LOG_HEX_MAX             ((SHM_EVENT_TEXT_SIZE - 32) / 2)        /* Log bytes in an event */
#define LOG_TEXT_MAX            256             /* Log bytes shown in the daemon's log */
#define RL_NAME_MAX             (CONFIG_LINK_NAME_MAX + 16)

/* Per-link variables besides the devices'. */
enum link_var {
        LV_STATE,
        LV_VERSION,
        LV_STATUS,
        LV_ADDRESS,                     /* emulator only */
        LV_COUNT
};

static const char *const link_var_suffix[LV_COUNT] = {
        [LV_STATE] = "state",
        [LV_VERSION] = "mediator.version",
        [LV_STATUS] = "mediator.status",
        [LV_ADDRESS] = "mediator.address",
};

/* Table ids of one device's variables. */
struct device_vars {
        bool bound;                     /* address below is the one the ids belong to */
        uint32_t address;
        int ids[LINK_CIRCE_F_COUNT];
};

struct link_circe {
        struct link_env env;
        bool controller;
        struct channel *ch;
        struct link_circe_wire wire;
        struct evloop_timer timer;
        unsigned batch_depth;

        struct link_circe_controller ctl;
        struct link_circe_mediator med;

        int link_ids[LV_COUNT];
        struct device_vars dev[LINK_CIRCE_DEVICES_MAX];

        struct link_waitq waitq;        /* requests waiting for the link ("wait=MS") */
        struct control_request *sync_req;

        struct log_ratelimit rl_wire, rl_log, rl_state;
        char rl_wire_name[RL_NAME_MAX], rl_log_name[RL_NAME_MAX], rl_state_name[RL_NAME_MAX];
        char status_line[STATUS_LINE_MAX];
};
static_assert(offsetof(struct link_circe, env) == 0,
              "link_hook_*() take the engine as its link_env");

static const char *link_name(const struct link_circe *e)
{
        return e->env.cfg->name;
}

static uint64_t now_ms(void)
{
        return evloop_clock_ns() / NS_PER_MS;
}

static enum link_circe_state session_state(const struct link_circe *e)
{
        return e->controller ? e->ctl.state : e->med.state;
}

static bool session_ready(const struct link_circe *e)
{
        return e->controller ? link_circe_controller_ready(&e->ctl)
                             : link_circe_mediator_ready(&e->med);
}

/* ---- table batches: one per packet or timer run, nested calls join the outer one ----------- */

static void batch_begin(struct link_circe *e)
{
        if (e->batch_depth++ == 0)
                shm_table_begin(e->env.table);
}

static void batch_end(struct link_circe *e)
{
        if (e->batch_depth > 0 && --e->batch_depth == 0)
                shm_table_commit(e->env.table);
}

/* ---- variables ------------------------------------------------------------------------------ */

static int var_name(char *buf, size_t size, const char *link, const char *suffix)
{
        int n = snprintf(buf, size, "%s.%s", link, suffix);

        return n < 0 || (size_t)n >= size ? -ENAMETOOLONG : n;
}

static int device_var_name(char *buf, size_t size, const char *link, uint32_t addr,
                           enum link_circe_field f)
{
        int n = snprintf(buf, size, "%s.device.%06X.%s", link, (unsigned)addr,
                         link_circe_field_name(f));

        return n < 0 || (size_t)n >= size ? -ENAMETOOLONG : n;
}

static unsigned var_type_of(enum link_circe_field f)
{
        (void)f;
        return SHM_TYPE_LONG;           /* every device field is a decimal number */
}

/* Fields the device at index publishes in this role. */
static uint32_t role_fields(const struct link_circe *e, const struct link_circe_device *d)
{
        return e->controller ? LINK_CIRCE_FIELDS_CONTROLLER : link_circe_mediator_fields(d);
}

static void set_value(struct link_circe *e, int id, const char *text)
{
        if (id >= 0)
                shm_table_set_str(e->env.table, (uint32_t)id, text);
}

/* Id of a variable by name, adding it when it is not in the table yet; ID_NONE when full. */
static int var_get(struct link_circe *e, const char *name, const char *peer, unsigned type)
{
        struct shm_var v = {
                .name = name, .direction = SHM_DIR_IN, .type = type,
                .link = e->env.shm_link, .peer = peer, .position = SHM_POSITION_NONE,
        };
        int id = shm_table_find(e->env.table, name);

        if (id >= 0)
                return id;
        id = shm_table_add(e->env.table, &v);
        if (id == -EEXIST)
                id = shm_table_find(e->env.table, name);
        if (id < 0) {
                shm_table_counter_add(e->env.table, e->env.shm_link, SHM_COUNTER_ADHOC_FULL, 1);
                log_ratelimited(&e->rl_state, LOG_PRIO_WARNING,
                                "link %s: no room for variable %s in the table (%s)",
                                link_name(e), name, strerror(-id));
                return ID_NONE;
        }
        return id;
}

/* Makes every variable of device slot i exist for address d->address. */
static void device_bind(struct link_circe *e, unsigned i, const struct link_circe_device *d)
{
        struct device_vars *dv = &e->dev[i];
        char peer[CIRCE_ADDRESS_LEN + 1];
        uint32_t fields = role_fields(e, d);

        circe_address_format(d->address, peer);
        for (unsigned f = 0; f < LINK_CIRCE_F_COUNT; f++) {
                char name[SHM_NAME_SIZE];

                if (!(fields & LINK_CIRCE_BIT(f)) || dv->ids[f] != ID_UNRESOLVED)
                        continue;
                if (device_var_name(name, sizeof(name), link_name(e), d->address,
                                    (enum link_circe_field)f) < 0) {
                        dv->ids[f] = ID_NONE;
                        continue;
                }
                dv->ids[f] = var_get(e, name, peer, var_type_of((enum link_circe_field)f));
        }
}

static void device_unbind(struct device_vars *dv)
{
        dv->bound = false;
        for (unsigned f = 0; f < LINK_CIRCE_F_COUNT; f++)
                dv->ids[f] = ID_UNRESOLVED;
}

static void publish_device(struct link_circe *e, unsigned i, const struct link_circe_device *d,
                           uint32_t fields)
{
        struct device_vars *dv = &e->dev[i];

        if (dv->bound && dv->address != d->address) {
                /* Re-addressed (emulator Device Setup): the old name says the device left. */
                set_value(e, dv->ids[LINK_CIRCE_F_ONLINE], "0");
                device_unbind(dv);
        }
        if (!dv->bound) {
                dv->bound = true;
                dv->address = d->address;
                fields = LINK_CIRCE_FIELDS_ALL;
        }
        device_bind(e, i, d);
        fields &= role_fields(e, d);
        for (unsigned f = 0; f < LINK_CIRCE_F_COUNT; f++) {
                char text[VALUE_TEXT_MAX];

                if (!(fields & LINK_CIRCE_BIT(f)) || dv->ids[f] < 0)
                        continue;
                link_circe_device_format(d, (enum link_circe_field)f, text, sizeof(text));
                set_value(e, dv->ids[f], text);
        }
}

/*
 * The `STATUS=` line: the core counts a link as up when its first word is "up". A controller is
 * up once logged in; the emulator while its port is open (it serves whoever logs in).
 */
static void status_update(struct link_circe *e, enum link_circe_state s)
{
        const char *line;

        switch (s) {
        case LINK_CIRCE_CONNECTED:
                line = e->controller ? "up" : "up (controller logged in)";
                break;
        case LINK_CIRCE_UNCONFIGURED:
                line = e->controller ? "up (unconfigured mediator)"
                                     : "up (controller logged in, unconfigured)";
                break;
        case LINK_CIRCE_CONNECTING:
                line = e->controller ? "connecting (Login sent)" : "up (waiting for Login)";
                break;
        case LINK_CIRCE_VERSION_MISMATCH:
                if (strncmp(e->status_line, "down: ", 6) == 0) {
                        /* hook_fail() just wrote why: keep it under the state's name. */
                        char why[STATUS_LINE_MAX];

                        snprintf(why, sizeof(why), "%s", e->status_line + 6);
                        snprintf(e->status_line, sizeof(e->status_line), "version-mismatch: %.*s",
                                 (int)(sizeof(e->status_line) - sizeof("version-mismatch: ")),
                                 why);
                        return;
                }
                line = "version-mismatch";
                break;
        case LINK_CIRCE_DISCONNECTED:
        default:
                /* Keep the "down: <reason>" the channel or the session gave. */
                if (strncmp(e->status_line, "down", 4) == 0)
                        return;
                line = "down";
                break;
        }
        snprintf(e->status_line, sizeof(e->status_line), "%s", line);
}

/* ---- hooks ----------------------------------------------------------------------------------- */

static int hook_send(void *arg, const struct circe_msg *m)
{
        struct link_circe *e = arg;
        char pkt[CIRCE_PACKET_MAX];
        int n, r;

        n = circe_encode(m, e->env.cfg->circe.checksum, pkt, sizeof(pkt));
        if (n < 0) {
                log_ratelimited(&e->rl_wire, LOG_PRIO_WARNING, "link %s: cannot encode %s: %s",
                                link_name(e), circe_op_str(m->op) ? circe_op_str(m->op) : "?",
                                strerror(-n));
                return n;
        }
        r = channel_send(e->ch, pkt, (size_t)n);
        if (r < 0)
                return r;
        shm_table_counter_add(e->env.table, e->env.shm_link, SHM_COUNTER_FRAMES_OUT, 1);
        return 0;
}

static void hook_fail(void *arg, const char *reason)
{
        struct link_circe *e = arg;

        log_ratelimited(&e->rl_state, LOG_PRIO_WARNING, "link %s: %s on %s; trying again",
                        link_name(e), reason, channel_device(e->ch));
        channel_fail(e->ch, reason);
        /* The next port starts a new byte stream: drop what the old one left half-read. */
        link_circe_wire_init(&e->wire);
        snprintf(e->status_line, sizeof(e->status_line), "down: %s", reason);
}

static void hook_state(void *arg, enum link_circe_state s, const char *detail)
{
        struct link_circe *e = arg;
        const char *name = link_circe_state_name(s);

        set_value(e, e->link_ids[LV_STATE], name);
        shm_table_link_state(e->env.table, e->env.shm_link, (uint32_t)s, name);
        shm_table_eventf(e->env.table, SHM_EVENT_LINK_STATE, e->env.shm_link, "state=%s%s%s",
                         name, detail[0] ? " " : "", detail);
        status_update(e, s);
        log_ratelimited(&e->rl_state, LOG_PRIO_INFO, "link %s: %s%s%s", link_name(e), name,
                        detail[0] ? " " : "", detail);
}

static void hook_mediator(void *arg, const struct circe_version *v, unsigned status)
{
        struct link_circe *e = arg;
        char text[VALUE_TEXT_MAX];

        snprintf(text, sizeof(text), "%u.%u.%u", v->major, v->minor, v->patch);
        set_value(e, e->link_ids[LV_VERSION], text);
        snprintf(text, sizeof(text), "%u", status);
        set_value(e, e->link_ids[LV_STATUS], text);
        if (!e->controller && e->med.has_address) {
                circe_address_format(e->med.address, text);
                set_value(e, e->link_ids[LV_ADDRESS], text);
        }
}

static void hook_device(void *arg, unsigned index, const struct link_circe_device *d,
                        uint32_t fields, uint32_t old_address)
{
        struct link_circe *e = arg;

        (void)old_address;
        if (index < LINK_CIRCE_DEVICES_MAX)
                publish_device(e, index, d, fields);
}

static void hook_rejected(void *arg, const struct circe_result *res)
{
        struct link_circe *e = arg;

        if (res->param)
                log_ratelimited(&e->rl_wire, LOG_PRIO_WARNING,
                                "link %s: packet dropped: %s (parameter %03u)", link_name(e),
                                circe_reason_str(res->reason), res->param);
        else
                log_ratelimited(&e->rl_wire, LOG_PRIO_WARNING, "link %s: packet dropped: %s",
                                link_name(e), circe_reason_str(res->reason));
}

static void hook_diag(void *arg, const char *text)
{
        struct link_circe *e = arg;

        log_ratelimited(&e->rl_wire, LOG_PRIO_NOTICE, "link %s: %s", link_name(e), text);
}

static void hook_log(void *arg, const uint8_t *data, size_t len)
{
        static const char hex[] = "0123456789ABCDEF";
        struct link_circe *e = arg;
        char text[LOG_TEXT_MAX * 4 + 1], ev[LOG_HEX_MAX * 2 + 1];
        size_t t = 0, h = 0;

        /* The log escapes control bytes itself; bytes above 0x7E get the same treatment here
         * so one mediator log is always one readable line. */
        for (size_t i = 0; i < len && i < LOG_TEXT_MAX; i++) {
                uint8_t c = data[i];

                if (c >= 0x20 && c <= 0x7E && c != '\\') {
                        text[t++] = (char)c;
                } else {
                        text[t++] = '\\';
                        text[t++] = 'x';
                        text[t++] = hex[c >> 4];
                        text[t++] = hex[c & 0xF];
                }
        }
        text[t] = '\0';
        for (size_t i = 0; i < len && i < LOG_HEX_MAX; i++) {
                ev[h++] = hex[data[i] >> 4];
                ev[h++] = hex[data[i] & 0xF];
        }
        ev[h] = '\0';
        log_ratelimited(&e->rl_log, LOG_PRIO_INFO, "link %s: mediator log: %s%s", link_name(e),
                        text, len > LOG_TEXT_MAX ? "..." : "");
        shm_table_eventf(e->env.table, SHM_EVENT_LOG, e->env.shm_link, "bytes=%zu data=%s%s",
                         len, ev, len > LOG_HEX_MAX ? " truncated=1" : "");
}

static void hook_sync_result(void *arg, uint32_t address, bool succeeded)
{
        struct link_circe *e = arg;
        char line[REQP_SYNC_RESULT_SIZE];

        if (!e->sync_req)
                return;
        reqp_sync_result_format(line, sizeof(line), address, succeeded);
        control_reply_data(e->sync_req, "%s", line);
}

static void hook_sync_done(void *arg, int err)
{
        struct link_circe *e = arg;
        struct control_request *req = e->sync_req;

        if (!req)
                return;
        e->sync_req = NULL;
        if (err < 0)
                control_reply_error(req, err, "link %s lost during the clock synchronisation",
                                    link_name(e));
        else
                control_reply_ok(req, NULL);
}

static const struct link_circe_hooks hooks = {
        .send = hook_send,
        .fail = hook_fail,
        .state = hook_state,
        .mediator = hook_mediator,
        .device = hook_device,
        .event = link_hook_event,
        .count = link_hook_count,
        .rejected = hook_rejected,
        .diag = hook_diag,
        .log = hook_log,
        .sync_result = hook_sync_result,
        .sync_done = hook_sync_done,
};

/* ---- commands -------------------------------------------------------------------------------- */

static void execute(struct link_circe *e, struct control_request *req,
                    const struct reqp_request *cmd)
{
        const struct circe_notify_action *act = &cmd->u.circe.u.notify_action;
        char addr[CIRCE_ADDRESS_LEN + 1];
        int r;

        batch_begin(e);
        switch (cmd->kind) {
        case REQP_CIRCE_SYNC_CLOCKS:
                if (e->sync_req) {
                        control_reply_error(req, EBUSY, "a clock synchronisation is running on "
                                            "link %s", link_name(e));
                        break;
                }
                /* Set first: with no device online the session ends it right away. */
                e->sync_req = req;
                r = link_circe_controller_sync_start(&e->ctl, now_ms());
                if (r < 0) {
                        e->sync_req = NULL;
                        control_reply_error(req, r, "sync-clocks on link %s: %s", link_name(e),
                                            strerror(-r));
                }
                break;
        case REQP_CIRCE_EMULATE_ACTION:
                r = link_circe_mediator_action(&e->med, now_ms(), act->origin,
                                               act->has_keys ? (long)act->keys : -1,
                                               act->has_sensor_time ?
                                               (long)act->sensor_time_ms : -1);
                circe_address_format(act->origin, addr);
                if (r == -ENOENT)
                        control_reply_error(req, r, "link %s emulates no device %s",
                                            link_name(e), addr);
                else if (r < 0)
                        control_reply_error(req, r, "emulate action on link %s: %s",
                                            link_name(e), strerror(-r));
                else
                        control_reply_ok(req, NULL);
                break;
        default:
                r = hook_send(e, &cmd->u.circe);
                if (r < 0)
                        control_reply_error(req, r, "%s on link %s: %s",
                                            reqp_name(cmd->kind), link_name(e),
                                            strerror(-r));
                else
                        control_reply_ok(req, NULL);
                break;
        }
        batch_end(e);
}

static bool wait_ready(void *engine)
{
        return session_ready(engine);
}

static void wait_run(void *engine, struct control_request *req, const void *data)
{
        execute(engine, req, data);
}

static void wait_expire(void *engine, struct control_request *req, const void *data,
                        unsigned wait_ms)
{
        struct link_circe *e = engine;

        (void)data;
        control_reply_error(req, ETIMEDOUT, "link %s not connected within %u ms (state %s)",
                            link_name(e), wait_ms, link_circe_state_name(session_state(e)));
}

/* Waiting requests run once the link is ready, in order; the others expire. */
static const struct link_waitq_ops wait_ops = {
        .ready = wait_ready,
        .run = wait_run,
        .expire = wait_expire,
};

static_assert(sizeof(struct reqp_request) <= LINK_WAITQ_DATA_MAX,
              "a parsed command fits a wait queue entry");

static void rearm(struct link_circe *e);

static void op_command(void *engine, struct control_request *req, const struct reqp_request *cmd)
{
        struct link_circe *e = engine;

        if (reqp_circe_for_controller(cmd->kind) != e->controller) {
                control_reply_error(req, EOPNOTSUPP, "link %s is a %s: %s is for %s links",
                                    link_name(e), e->controller ? "controller" :
                                    "mediator emulator", reqp_name(cmd->kind),
                                    e->controller ? "mediator emulator" : "controller");
                return;
        }
        if (session_ready(e)) {
                execute(e, req, cmd);
                /* A synchronisation brings a deadline, an action moves the Keep Alive one. */
                rearm(e);
                return;
        }
        if (cmd->wait_ms == 0) {
                control_reply_error(req, ENOTCONN, "link %s is not connected (state %s)",
                                    link_name(e), link_circe_state_name(session_state(e)));
                return;
        }
        if (link_waitq_add(&e->waitq, req, now_ms(), cmd->wait_ms, cmd, sizeof(*cmd)) < 0) {
                control_reply_error(req, EBUSY, "link %s: %u requests already wait for it",
                                    link_name(e), LINK_CIRCE_PENDING_MAX);
                return;
        }
        rearm(e);
}

/* ---- timer and channel ----------------------------------------------------------------------- */

static void rearm(struct link_circe *e)
{
        uint64_t d = e->controller ? link_circe_controller_deadline(&e->ctl)
                                   : link_circe_mediator_deadline(&e->med);
        uint64_t now = now_ms();

        if (link_waitq_deadline(&e->waitq) < d)
                d = link_waitq_deadline(&e->waitq);
        if (d == LINK_CIRCE_NEVER) {
                evloop_timer_cancel(&e->timer);
                return;
        }
        if (evloop_timer_arm(&e->timer, d > now ? d - now : 0, 0) < 0)
                log_warnx("link %s: cannot arm its timer", link_name(e));
}

/* After the session ran: waiting requests, counters, timer. */
static void settle(struct link_circe *e, uint64_t now)
{
        link_waitq_run(&e->waitq, now, &wait_ops, e);
        link_publish_channel_stats(&e->env, e->ch);
        rearm(e);
}

static void on_timer(struct evloop *loop, struct evloop_timer *timer, void *arg)
{
        struct link_circe *e = arg;
        uint64_t now = now_ms();

        (void)loop;
        (void)timer;
        batch_begin(e);
        if (e->controller)
                link_circe_controller_tick(&e->ctl, now);
        else
                link_circe_mediator_tick(&e->med, now);
        batch_end(e);
        settle(e, now);
}

static void session_up(struct link_circe *e)
{
        uint64_t now = now_ms();

        link_circe_wire_init(&e->wire);
        batch_begin(e);
        if (e->controller)
                link_circe_controller_up(&e->ctl, now);
        else
                link_circe_mediator_up(&e->med, now);
        batch_end(e);
        settle(e, now);
}

static void on_up(struct channel *ch, void *arg)
{
        struct link_circe *e = arg;

        log_ratelimited(&e->rl_state, LOG_PRIO_INFO, "link %s: %s open", link_name(e),
                        channel_device(ch));
        session_up(e);
}

static void on_down(struct channel *ch, const char *reason, unsigned retry_ms, void *arg)
{
        struct link_circe *e = arg;
        uint64_t now = now_ms();

        (void)ch;
        log_ratelimited(&e->rl_state, LOG_PRIO_WARNING, "link %s: down (%s), retry in %u ms",
                        link_name(e), reason, retry_ms);
        snprintf(e->status_line, sizeof(e->status_line), "down: %s", reason);
        batch_begin(e);
        shm_table_set_link_stale(e->env.table, e->env.shm_link, 1);
        if (e->controller)
                link_circe_controller_down(&e->ctl, now);
        else
                link_circe_mediator_down(&e->med, now);
        batch_end(e);
        settle(e, now);
}

static void on_input(struct channel *ch, const uint8_t *data, size_t len, void *arg)
{
        struct link_circe *e = arg;
        uint64_t now = now_ms();

        (void)ch;
        while (len > 0) {
                struct circe_result res;
                size_t n = link_circe_wire_feed(&e->wire, data, len, &res, &hooks, e);

                data += n;
                len -= n;
                if (res.kind != CIRCE_RESULT_MESSAGE)
                        continue;
                batch_begin(e);
                if (e->controller)
                        link_circe_controller_message(&e->ctl, now, &res.msg);
                else
                        link_circe_mediator_message(&e->med, now, &res.msg);
                batch_end(e);
                /* The controller may have failed the port (version mismatch): the rest of this
                 * read belongs to a stream we no longer listen to. */
                if (channel_state(e->ch) != CHANNEL_STATE_UP)
                        break;
        }
        settle(e, now);
}

static const struct channel_ops channel_callbacks = {
        .up = on_up,
        .down = on_down,
        .input = on_input,
};

/* ---- link_ops -------------------------------------------------------------------------------- */

static int declare_one(struct shm_var *vars, size_t *n, size_t max, char *names_buf,
                       size_t names_size, size_t *names_used, const char *name, const char *peer,
                       unsigned type, uint32_t link_index)
{
        size_t nlen = strlen(name) + 1, plen = peer ? strlen(peer) + 1 : 0;
        char *np, *pp = NULL;

        if (*n >= max || *names_used + nlen + plen > names_size)
                return -ENOSPC;
        np = names_buf + *names_used;
        memcpy(np, name, nlen);
        *names_used += nlen;
        if (peer) {
                pp = names_buf + *names_used;
                memcpy(pp, peer, plen);
                *names_used += plen;
        }
        vars[(*n)++] = (struct shm_var){
                .name = np, .direction = SHM_DIR_IN, .type = type, .link = link_index,
                .peer = pp, .position = SHM_POSITION_NONE,
        };
        return 0;
}

static int op_declare(const struct config_link *cfg, uint32_t link_index, struct shm_var *vars,
                      size_t *n, size_t max, char *names_buf, size_t names_size,
                      size_t *names_used)
{
        bool emulator = cfg->circe.role == CONFIG_ROLE_MEDIATOR;
        char name[SHM_NAME_SIZE];
        int r;

        if (cfg->protocol != CONFIG_PROTOCOL_CIRCE)
                return -EINVAL;
        for (unsigned v = 0; v < LV_COUNT; v++) {
                if (v == LV_ADDRESS && !emulator)
                        continue;
                if (var_name(name, sizeof(name), cfg->name, link_var_suffix[v]) < 0)
                        return -EINVAL;
                r = declare_one(vars, n, max, names_buf, names_size, names_used, name, NULL,
                                v == LV_STATUS ? SHM_TYPE_LONG : SHM_TYPE_STRING, link_index);
                if (r < 0)
                        return r;
        }
        if (!emulator)
                return 0;
        /* The emulated devices are known now: declare theirs, so they never wait for ad hoc
         * room. Only a Device Setup that assigns a new address adds names at run time. */
        for (unsigned i = 0; i < cfg->circe.n_emulate; i++) {
                struct link_circe_device d = {
                        .address = cfg->circe.emulate[i].address,
                        .capabilities = cfg->circe.emulate[i].capabilities,
                };
                char peer[CIRCE_ADDRESS_LEN + 1];
                uint32_t fields = link_circe_mediator_fields(&d);

                circe_address_format(d.address, peer);
                for (unsigned f = 0; f < LINK_CIRCE_F_COUNT; f++) {
                        if (!(fields & LINK_CIRCE_BIT(f)))
                                continue;
                        if (device_var_name(name, sizeof(name), cfg->name, d.address,
                                            (enum link_circe_field)f) < 0)
                                return -EINVAL;
                        r = declare_one(vars, n, max, names_buf, names_size, names_used, name,
                                        peer, var_type_of((enum link_circe_field)f), link_index);
                        if (r < 0)
                                return r;
                }
        }
        return 0;
}

static void ratelimit_init(struct log_ratelimit *rl, char *name, const char *link,
                           const char *what)
{
        snprintf(name, RL_NAME_MAX, "%s %s", link, what);
        log_ratelimit_init(rl, name, LOG_RATELIMIT_INTERVAL_MS, LOG_RATELIMIT_BURST);
}

static void publish_initial(struct link_circe *e)
{
        batch_begin(e);
        set_value(e, e->link_ids[LV_STATE], link_circe_state_name(session_state(e)));
        shm_table_link_state(e->env.table, e->env.shm_link, (uint32_t)session_state(e),
                             link_circe_state_name(session_state(e)));
        if (!e->controller) {
                hook_mediator(e, &e->med.version, e->med.status);
                for (unsigned i = 0; i < e->med.n_devices; i++)
                        publish_device(e, i, &e->med.devices[i], LINK_CIRCE_FIELDS_ALL);
        }
        batch_end(e);
}

static int op_create(const struct link_env *env, void **ret_engine)
{
        struct link_circe *e;
        char name[SHM_NAME_SIZE];
        int r;

        if (env->cfg->protocol != CONFIG_PROTOCOL_CIRCE)
                return -EINVAL;
        e = calloc(1, sizeof(*e));
        if (!e)
                return -ENOMEM;
        e->env = *env;
        e->controller = env->cfg->circe.role != CONFIG_ROLE_MEDIATOR;
        ratelimit_init(&e->rl_wire, e->rl_wire_name, env->cfg->name, "wire");
        ratelimit_init(&e->rl_log, e->rl_log_name, env->cfg->name, "mediator log");
        ratelimit_init(&e->rl_state, e->rl_state_name, env->cfg->name, "state");
        for (unsigned v = 0; v < LV_COUNT; v++) {
                e->link_ids[v] = ID_NONE;
                if (v == LV_ADDRESS && e->controller)
                        continue;
                if (var_name(name, sizeof(name), env->cfg->name, link_var_suffix[v]) >= 0)
                        e->link_ids[v] = shm_table_find(env->table, name);
        }
        for (unsigned i = 0; i < LINK_CIRCE_DEVICES_MAX; i++)
                device_unbind(&e->dev[i]);
        link_circe_wire_init(&e->wire);
        evloop_timer_init(&e->timer, env->loop, on_timer, e);
        if (e->controller)
                link_circe_controller_init(&e->ctl, &env->cfg->circe, &hooks, e);
        else
                link_circe_mediator_init(&e->med, &env->cfg->circe, &hooks, e, now_ms());
        snprintf(e->status_line, sizeof(e->status_line), "down");
        publish_initial(e);
        r = link_channel_new(env, &channel_callbacks, e, &e->ch);
        if (r < 0) {
                free(e);
                return r;
        }
        r = channel_start(e->ch);
        if (r == 0) {
                session_up(e);
        } else {
                /* Not fatal: the channel retries by itself and calls up() when it opens. */
                snprintf(e->status_line, sizeof(e->status_line), "down: %s",
                         channel_reason(e->ch));
                log_ratelimited(&e->rl_state, LOG_PRIO_WARNING, "link %s: %s; retrying",
                                link_name(e), channel_reason(e->ch));
                shm_table_set_link_stale(env->table, env->shm_link, 1);
                set_value(e, e->link_ids[LV_STATE], link_circe_state_name(session_state(e)));
        }
        *ret_engine = e;
        return 0;
}

static void op_destroy(void *engine)
{
        struct link_circe *e = engine;
        char why[CONFIG_LINK_NAME_MAX + 16];

        if (!e)
                return;
        /* The spec's way to end a session; best effort, the port closes right after. */
        if (e->controller && e->ctl.up)
                link_circe_controller_logout(&e->ctl);
        snprintf(why, sizeof(why), "link %s stopped", link_name(e));
        link_waitq_cancel(&e->waitq, ECANCELED, why);
        if (e->sync_req) {
                struct control_request *req = e->sync_req;

                e->sync_req = NULL;
                control_reply_error(req, ECANCELED, "link %s stopped", link_name(e));
        }
        evloop_timer_cancel(&e->timer);
        channel_free(e->ch);
        log_ratelimit_flush(&e->rl_wire);
        log_ratelimit_flush(&e->rl_log);
        log_ratelimit_flush(&e->rl_state);
        shm_table_set_link_stale(e->env.table, e->env.shm_link, 1);
        free(e);
}

static void op_outbound(void *engine, const struct shm_out_change *change)
{
        (void)engine;
        (void)change;           /* a CIRCE link declares no outbound variables */
}

static void op_heartbeat(void *engine)
{
        struct link_circe *e = engine;

        /* Reopen attempts while down change the channel's counters with no I/O of ours. */
        link_publish_channel_stats(&e->env, e->ch);
        log_ratelimit_flush(&e->rl_wire);
        log_ratelimit_flush(&e->rl_log);
        log_ratelimit_flush(&e->rl_state);
}

static const char *op_status(void *engine)
{
        const struct link_circe *e = engine;

        return e->status_line;
}

static const char *const circe_words[] = { "circe", NULL };

const struct link_ops link_circe_ops = {
        .command_words = circe_words,
        .declare = op_declare,
        .create = op_create,
        .destroy = op_destroy,
        .outbound = op_outbound,
        .command = op_command,
        .status = op_status,
        .heartbeat = op_heartbeat,
};
