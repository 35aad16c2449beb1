/*
 * CIRCE mediator emulator session (link_circe_mediator.h).
 */
#include "daemon/link_circe_mediator.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* Keys that make a remote report a passage, and the capability each one needs (the spec: a
 * remote with Start/Intermediate/Finish buttons sends a Sensor Time when one is pressed). */
static const struct {
        unsigned key;
        unsigned capability;
} timing_keys[] = {
        { CIRCE_KEY_PASS_START, CIRCE_CAP_START_SENSOR },
        { CIRCE_KEY_2, CIRCE_CAP_INTERMEDIATE_SENSOR },         /* key 2 = pass intermediate */
        { CIRCE_KEY_PASS_FINISH, CIRCE_CAP_FINISH_SENSOR },
};

static void diag(struct link_circe_mediator *m, const char *fmt, ...)
        __attribute__((format(printf, 2, 3)));

static void diag(struct link_circe_mediator *m, const char *fmt, ...)
{
        char text[LINK_CIRCE_DIAG_MAX];
        va_list ap;

        if (!m->hooks->diag)
                return;
        va_start(ap, fmt);
        vsnprintf(text, sizeof(text), fmt, ap);
        va_end(ap);
        m->hooks->diag(m->arg, text);
}

static void set_state(struct link_circe_mediator *m, enum link_circe_state s)
{
        if (m->state == s)
                return;
        m->state = s;
        if (m->hooks->state)
                m->hooks->state(m->arg, s, "");
}

static void logged_in_state(struct link_circe_mediator *m)
{
        set_state(m, m->status == CIRCE_MEDIATOR_UNCONFIGURED ? LINK_CIRCE_UNCONFIGURED
                                                               : LINK_CIRCE_CONNECTED);
}

static void device_changed(struct link_circe_mediator *m, unsigned i, uint32_t fields,
                           uint32_t old_address)
{
        if (fields && m->hooks->device)
                m->hooks->device(m->arg, i, &m->devices[i], fields, old_address);
}

static void mediator_changed(struct link_circe_mediator *m)
{
        if (m->hooks->mediator)
                m->hooks->mediator(m->arg, &m->version, m->status);
}

static int send_msg(struct link_circe_mediator *m, uint64_t now_ms, const struct circe_msg *msg)
{
        int r = m->hooks->send(m->arg, msg);

        /* A failed send (queue full) counts as an attempt: the next Keep Alive is due a whole
         * period later, not at once, so a stuck port never makes the timer spin. */
        m->last_sent_ms = now_ms;
        if (r < 0) {
                m->stats.send_errors++;
                return r;
        }
        return 0;
}

static void send_keep_alive(struct link_circe_mediator *m, uint64_t now_ms)
{
        struct circe_msg msg;

        memset(&msg, 0, sizeof(msg));
        msg.op = CIRCE_OP_KEEP_ALIVE;
        msg.u.keep_alive.version = m->version;
        msg.u.keep_alive.status = (uint16_t)m->status;
        if (send_msg(m, now_ms, &msg) == 0)
                m->stats.keep_alives++;
}

static void send_status(struct link_circe_mediator *m, uint64_t now_ms, unsigned i)
{
        struct circe_msg msg;

        link_circe_device_status(&m->devices[i], &msg);
        if (send_msg(m, now_ms, &msg) == 0)
                m->stats.statuses++;
}

/* The fields an emulated device publishes. */
static uint32_t device_fields(const struct link_circe_device *d)
{
        uint32_t f = LINK_CIRCE_FIELDS_CONTROLLER | LINK_CIRCE_BIT(LINK_CIRCE_F_ALERTS);

        if (d->capabilities & CIRCE_CAP_DISPLAY)
                f |= LINK_CIRCE_FIELDS_DISPLAY;
        return f;
}

void link_circe_mediator_init(struct link_circe_mediator *m, const struct config_circe *cfg,
                              const struct link_circe_hooks *hooks, void *arg, uint64_t now_ms)
{
        memset(m, 0, sizeof(*m));
        m->hooks = hooks;
        m->arg = arg;
        m->version.major = cfg->version.major;
        m->version.minor = cfg->version.minor;
        m->version.patch = cfg->version.patch;
        m->status = cfg->status;
        m->has_address = cfg->has_address;
        m->address = cfg->address;
        m->keepalive_ms = cfg->keepalive_ms;
        m->state = LINK_CIRCE_DISCONNECTED;
        m->next_status_ms = LINK_CIRCE_NEVER;
        for (unsigned i = 0; i < cfg->n_emulate && i < CONFIG_EMULATE_MAX; i++) {
                const struct config_emulated_device *e = &cfg->emulate[i];
                struct link_circe_device *d = &m->devices[i];

                d->address = e->address;
                d->online = e->address != CIRCE_ADDRESS_UNCONFIGURED;
                d->has_status = true;
                d->membership = e->membership;
                d->capabilities = e->capabilities;
                d->roles = e->roles;
                d->signal = e->signal;
                d->has_battery = e->has_battery;
                d->battery = e->battery;
                /* A member that powers up needs its clock synchronised (027:1). */
                d->has_clock_sync = e->membership;
                d->clock_sync = e->membership ? CIRCE_CLOCK_SYNC_REQUIRED : 0;
                m->clock_zero_ms[i] = now_ms;
                m->n_devices++;
        }
}

void link_circe_mediator_up(struct link_circe_mediator *m, uint64_t now_ms)
{
        (void)now_ms;
        m->up = true;
        m->logged_in = false;
        m->next_status_ms = LINK_CIRCE_NEVER;
        set_state(m, LINK_CIRCE_CONNECTING);
}

void link_circe_mediator_down(struct link_circe_mediator *m, uint64_t now_ms)
{
        (void)now_ms;
        m->up = false;
        m->logged_in = false;
        m->next_status_ms = LINK_CIRCE_NEVER;
        set_state(m, LINK_CIRCE_DISCONNECTED);
}

bool link_circe_mediator_ready(const struct link_circe_mediator *m)
{
        return m->up && m->logged_in;
}

int link_circe_mediator_find(const struct link_circe_mediator *m, uint32_t addr)
{
        for (unsigned i = 0; i < m->n_devices; i++)
                if (m->devices[i].address == addr)
                        return (int)i;
        return -ENOENT;
}

/* A Notify Status for every device that has an address. */
static void status_round(struct link_circe_mediator *m, uint64_t now_ms)
{
        for (unsigned i = 0; i < m->n_devices; i++) {
                struct link_circe_device *d = &m->devices[i];

                if (d->address == CIRCE_ADDRESS_UNCONFIGURED)
                        continue;
                if (m->sync[i] == LINK_CIRCE_EMU_SYNC_SHOWING && now_ms >= m->sync_until_ms[i]) {
                        m->sync[i] = LINK_CIRCE_EMU_SYNC_NONE;
                        d->has_clock_sync = false;
                        d->clock_sync = 0;
                        device_changed(m, i, LINK_CIRCE_BIT(LINK_CIRCE_F_CLOCK_SYNC),
                                       d->address);
                }
                send_status(m, now_ms, i);
        }
}

static void on_login(struct link_circe_mediator *m, uint64_t now_ms)
{
        m->stats.logins++;
        m->logged_in = true;
        logged_in_state(m);
        send_keep_alive(m, now_ms);
        status_round(m, now_ms);
        m->next_status_ms = now_ms + LINK_CIRCE_STATUS_PERIOD_MS;
}

static int device_or_ignore(struct link_circe_mediator *m, uint32_t addr, const char *op)
{
        int i = link_circe_mediator_find(m, addr);

        if (i < 0) {
                m->stats.ignored++;
                diag(m, "%s for %06X: no such emulated device", op, (unsigned)addr);
        }
        return i;
}

static void on_alert(struct link_circe_mediator *m, const struct circe_alert *a)
{
        int i = device_or_ignore(m, a->dest, "Alert");

        m->stats.alerts++;
        if (i < 0)
                return;
        m->devices[i].alerts++;
        device_changed(m, (unsigned)i, LINK_CIRCE_BIT(LINK_CIRCE_F_ALERTS),
                       m->devices[i].address);
}

static void on_network_setup(struct link_circe_mediator *m, const struct circe_network_setup *n)
{
        int i = device_or_ignore(m, n->dest, "Network Setup");
        struct link_circe_device *d;
        uint32_t mask = LINK_CIRCE_BIT(LINK_CIRCE_F_MEMBERSHIP);

        m->stats.network_setups++;
        if (i < 0)
                return;
        d = &m->devices[i];
        d->membership = n->set_membership;
        if (n->set_membership) {
                d->roles = n->roles;
                /* A device that joins needs its clock synchronised (027:1) until it is. */
                d->has_clock_sync = true;
                d->clock_sync = CIRCE_CLOCK_SYNC_REQUIRED;
                m->sync[i] = LINK_CIRCE_EMU_SYNC_NONE;
                mask |= LINK_CIRCE_BIT(LINK_CIRCE_F_ROLES) | LINK_CIRCE_BIT(LINK_CIRCE_F_CLOCK_SYNC);
        }
        device_changed(m, (unsigned)i, mask, d->address);
}

static void on_device_setup(struct link_circe_mediator *m, uint64_t now_ms,
                            const struct circe_device_setup *s)
{
        uint32_t dest = s->has_dest ? s->dest : CIRCE_ADDRESS_UNCONFIGURED;
        struct link_circe_device *d;
        uint32_t old;
        int i, other;

        m->stats.device_setups++;
        if (!s->has_capabilities) {
                /* No capabilities: the mediator itself takes the address. */
                m->has_address = true;
                m->address = s->assign;
                if (m->status == CIRCE_MEDIATOR_UNCONFIGURED)
                        m->status = CIRCE_MEDIATOR_NORMAL;
                mediator_changed(m);
                logged_in_state(m);
                send_keep_alive(m, now_ms);
                return;
        }
        i = device_or_ignore(m, dest, "Device Setup");
        if (i < 0)
                return;
        other = link_circe_mediator_find(m, s->assign);
        if (other >= 0 && other != i) {
                m->stats.ignored++;
                diag(m, "Device Setup: address %06X already belongs to another emulated device",
                     (unsigned)s->assign);
                return;
        }
        d = &m->devices[i];
        old = d->address;
        d->address = s->assign;
        d->capabilities = s->capabilities;
        d->online = s->assign != CIRCE_ADDRESS_UNCONFIGURED;
        device_changed(m, (unsigned)i, device_fields(d), old);
        if (d->online)
                send_status(m, now_ms, (unsigned)i);
}

static void on_sync(struct link_circe_mediator *m, uint64_t now_ms)
{
        m->stats.syncs++;
        for (unsigned i = 0; i < m->n_devices; i++) {
                struct link_circe_device *d = &m->devices[i];

                if (d->address == CIRCE_ADDRESS_UNCONFIGURED)
                        continue;
                m->clock_zero_ms[i] = now_ms;
                /* PROTOCOLS.md 2.4: one status without 027 now, then 027:2 in the periodic
                 * ones for LINK_CIRCE_SYNC_SHOWN_MS. */
                d->has_clock_sync = false;
                d->clock_sync = 0;
                send_status(m, now_ms, i);
                d->has_clock_sync = true;
                d->clock_sync = CIRCE_CLOCK_SYNC_SUCCEEDED;
                m->sync[i] = LINK_CIRCE_EMU_SYNC_SHOWING;
                m->sync_until_ms[i] = now_ms + LINK_CIRCE_SYNC_SHOWN_MS;
                device_changed(m, i, LINK_CIRCE_BIT(LINK_CIRCE_F_CLOCK_SYNC), d->address);
        }
}

#define SHOW(v, mask, f, hasf, field, present, val) do { \
        if (present) { \
                (v)->hasf = true; \
                (v)->field = (val); \
                *(mask) |= LINK_CIRCE_BIT(f); \
        } \
} while (0)

/* Applies a Visualize to one display, lowest precedence first (PROTOCOLS.md 2.2 order). */
static uint32_t apply_visualize(struct link_circe_display *v, const struct circe_visualize *z)
{
        uint32_t mask = 0;

        SHOW(v, &mask, LINK_CIRCE_F_ELIMINATED, has_eliminated, eliminated, z->has_eliminated,
             z->eliminated);
        SHOW(v, &mask, LINK_CIRCE_F_CURRENT, has_current, current, z->has_current, z->current);
        SHOW(v, &mask, LINK_CIRCE_F_NEXT, has_next, next, z->has_next, z->next);
        if (z->start_timer) {
                /* Start Timer resets the timer to zero and starts it. */
                SHOW(v, &mask, LINK_CIRCE_F_TIMER_RUNNING, has_timer, timer_running, true, true);
                SHOW(v, &mask, LINK_CIRCE_F_PRIMARY, has_primary, primary_ms, true, 0);
        }
        if (z->has_primary) {
                /* A Primary Timer Value implicitly stops a running timer. */
                SHOW(v, &mask, LINK_CIRCE_F_TIMER_RUNNING, has_timer, timer_running, true, false);
                SHOW(v, &mask, LINK_CIRCE_F_PRIMARY, has_primary, primary_ms, true, z->primary_ms);
        }
        SHOW(v, &mask, LINK_CIRCE_F_SECONDARY, has_secondary, secondary_ms, z->has_secondary,
             z->secondary_ms);
        SHOW(v, &mask, LINK_CIRCE_F_FAULTS, has_faults, faults, z->has_faults, z->faults);
        SHOW(v, &mask, LINK_CIRCE_F_REFUSALS, has_refusals, refusals, z->has_refusals,
             z->refusals);
        SHOW(v, &mask, LINK_CIRCE_F_PLACEMENT, has_placement, placement, z->has_placement,
             z->placement);
        return mask;
}

static void on_visualize(struct link_circe_mediator *m, const struct circe_visualize *z)
{
        m->stats.visualizes++;
        for (unsigned k = 0; k < z->dest_count && k < CIRCE_VISUALIZE_DEST_MAX; k++) {
                int i = device_or_ignore(m, z->dests[k], "Visualize");

                if (i < 0)
                        continue;
                if (!(m->devices[i].capabilities & CIRCE_CAP_DISPLAY)) {
                        m->stats.ignored++;
                        diag(m, "Visualize for %06X: not a display", (unsigned)z->dests[k]);
                        continue;
                }
                device_changed(m, (unsigned)i, apply_visualize(&m->devices[i].display, z),
                               m->devices[i].address);
        }
}

void link_circe_mediator_message(struct link_circe_mediator *m, uint64_t now_ms,
                                 const struct circe_msg *msg)
{
        if (!m->up)
                return;
        if (!circe_op_from_controller(msg->op)) {
                m->stats.unexpected_ops++;
                if (m->hooks->count)
                        m->hooks->count(m->arg, SHM_COUNTER_UNKNOWN_OP, 1);
                diag(m, "%s (%02u) is a mediator operation; ignored from the controller",
                     circe_op_str(msg->op) ? circe_op_str(msg->op) : "?", (unsigned)msg->op);
                return;
        }
        if (msg->op == CIRCE_OP_LOGIN) {
                on_login(m, now_ms);
                return;
        }
        if (!m->logged_in) {
                /* The spec: Login comes before any operation. */
                m->stats.ignored++;
                diag(m, "%s before Login ignored", circe_op_str(msg->op));
                return;
        }
        switch (msg->op) {
        case CIRCE_OP_LOGOUT:
                m->stats.logouts++;
                m->logged_in = false;
                m->next_status_ms = LINK_CIRCE_NEVER;
                set_state(m, LINK_CIRCE_CONNECTING);
                break;
        case CIRCE_OP_ALERT:
                on_alert(m, &msg->u.alert);
                break;
        case CIRCE_OP_NETWORK_SETUP:
                on_network_setup(m, &msg->u.network_setup);
                break;
        case CIRCE_OP_DEVICE_SETUP:
                on_device_setup(m, now_ms, &msg->u.device_setup);
                break;
        case CIRCE_OP_SYNC_CLOCKS:
                on_sync(m, now_ms);
                break;
        case CIRCE_OP_VISUALIZE:
                on_visualize(m, &msg->u.visualize);
                break;
        default:
                break;
        }
}

void link_circe_mediator_tick(struct link_circe_mediator *m, uint64_t now_ms)
{
        if (!m->up || !m->logged_in)
                return;
        if (now_ms >= m->next_status_ms) {
                status_round(m, now_ms);
                m->next_status_ms += LINK_CIRCE_STATUS_PERIOD_MS;
                /* Fell behind (a stalled loop): skip the missed rounds, no burst. */
                if (m->next_status_ms <= now_ms)
                        m->next_status_ms = now_ms + LINK_CIRCE_STATUS_PERIOD_MS;
        }
        if (now_ms >= m->last_sent_ms + m->keepalive_ms)
                send_keep_alive(m, now_ms);
}

uint64_t link_circe_mediator_deadline(const struct link_circe_mediator *m)
{
        uint64_t d;

        if (!m->up || !m->logged_in)
                return LINK_CIRCE_NEVER;
        d = m->last_sent_ms + m->keepalive_ms;
        return m->next_status_ms < d ? m->next_status_ms : d;
}

/* Whether a Notify Action of device d with these keys carries a Sensor Time by itself. */
static bool needs_sensor_time(const struct link_circe_device *d, long keys)
{
        if (d->capabilities & CIRCE_CAP_TIME_SENSOR)
                return true;
        if (keys <= 0)
                return false;
        for (size_t k = 0; k < sizeof(timing_keys) / sizeof(timing_keys[0]); k++)
                if (((unsigned long)keys & timing_keys[k].key) &&
                    (d->capabilities & timing_keys[k].capability))
                        return true;
        return false;
}

int link_circe_mediator_action(struct link_circe_mediator *m, uint64_t now_ms, uint32_t addr,
                               long keys, long sensor_time_ms)
{
        struct circe_notify_action *a;
        struct link_circe_device *d;
        struct circe_msg msg;
        uint32_t mask = 0;
        int i, r;

        if (!link_circe_mediator_ready(m))
                return -ENOTCONN;
        i = link_circe_mediator_find(m, addr);
        if (i < 0 || addr == CIRCE_ADDRESS_UNCONFIGURED)
                return -ENOENT;
        d = &m->devices[i];
        memset(&msg, 0, sizeof(msg));
        msg.op = CIRCE_OP_NOTIFY_ACTION;
        a = &msg.u.notify_action;
        a->origin = addr;
        if (keys >= 0) {
                a->has_keys = true;
                a->keys = (uint16_t)keys;
        }
        if (sensor_time_ms >= 0) {
                a->has_sensor_time = true;
                a->sensor_time_ms = (uint32_t)sensor_time_ms;
        } else if (needs_sensor_time(d, keys)) {
                a->has_sensor_time = true;
                a->sensor_time_ms = (uint32_t)((now_ms - m->clock_zero_ms[i]) %
                                               LINK_CIRCE_SENSOR_CLOCK_MOD);
        }
        r = send_msg(m, now_ms, &msg);
        if (r < 0)
                return r;
        m->stats.actions++;
        if (a->has_keys) {
                d->has_keys = true;
                d->keys = a->keys;
                mask |= LINK_CIRCE_BIT(LINK_CIRCE_F_KEYS);
        }
        if (a->has_sensor_time) {
                d->has_sensor_time = true;
                d->sensor_time_ms = a->sensor_time_ms;
                mask |= LINK_CIRCE_BIT(LINK_CIRCE_F_SENSOR_TIME);
        }
        device_changed(m, (unsigned)i, mask, addr);
        return 0;
}

uint32_t link_circe_mediator_fields(const struct link_circe_device *d)
{
        return device_fields(d);
}
