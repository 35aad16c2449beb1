/*
 * CIRCE controller session (link_circe_controller.h).
 */
#include "daemon/link_circe_controller.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static void count(struct link_circe_controller *c, enum shm_counter counter)
{
        if (c->hooks->count)
                c->hooks->count(c->arg, counter, 1);
}

static void diag(struct link_circe_controller *c, const char *fmt, ...)
        __attribute__((format(printf, 2, 3)));

static void diag(struct link_circe_controller *c, const char *fmt, ...)
{
        char text[LINK_CIRCE_DIAG_MAX];
        va_list ap;

        if (!c->hooks->diag)
                return;
        va_start(ap, fmt);
        vsnprintf(text, sizeof(text), fmt, ap);
        va_end(ap);
        c->hooks->diag(c->arg, text);
}

static void event(struct link_circe_controller *c, enum shm_event_type type, const char *fmt, ...)
        __attribute__((format(printf, 3, 4)));

static void event(struct link_circe_controller *c, enum shm_event_type type, const char *fmt, ...)
{
        char text[SHM_EVENT_TEXT_SIZE];
        va_list ap;

        if (!c->hooks->event)
                return;
        va_start(ap, fmt);
        vsnprintf(text, sizeof(text), fmt, ap);
        va_end(ap);
        c->hooks->event(c->arg, type, text);
}

static void set_state(struct link_circe_controller *c, enum link_circe_state s, const char *detail)
{
        if (c->state == s)
                return;
        c->state = s;
        if (c->hooks->state)
                c->hooks->state(c->arg, s, detail ? detail : "");
}

static int send_op(struct link_circe_controller *c, enum circe_op op)
{
        struct circe_msg m;

        memset(&m, 0, sizeof(m));
        m.op = op;
        return c->hooks->send(c->arg, &m);
}

static void device_changed(struct link_circe_controller *c, unsigned i, uint32_t fields)
{
        if (fields && c->hooks->device)
                c->hooks->device(c->arg, i, &c->devices[i], fields, c->devices[i].address);
}

void link_circe_controller_init(struct link_circe_controller *c, const struct config_circe *cfg,
                                const struct link_circe_hooks *hooks, void *arg)
{
        memset(c, 0, sizeof(*c));
        c->hooks = hooks;
        c->arg = arg;
        c->expect_major = cfg->expect_version.major;
        c->expect_minor = cfg->expect_version.minor;
        c->login_timeout_ms = cfg->login_timeout_ms;
        c->idle_timeout_ms = cfg->idle_timeout_ms;
        c->state = LINK_CIRCE_DISCONNECTED;
        c->login_deadline = LINK_CIRCE_NEVER;
        c->idle_deadline = LINK_CIRCE_NEVER;
        c->sync_deadline = LINK_CIRCE_NEVER;
}

/* Ends a running synchronisation: every device still waiting timed out (err 0) or the link
 * went away (err < 0: no per-device results, the request fails). */
static void sync_finish(struct link_circe_controller *c, int err)
{
        if (!c->sync_active)
                return;
        c->sync_active = false;
        c->sync_deadline = LINK_CIRCE_NEVER;
        for (unsigned i = 0; i < c->n_devices; i++) {
                uint8_t ph = c->sync_phase[i];

                c->sync_phase[i] = LINK_CIRCE_SYNC_UNTRACKED;
                if (err < 0 || ph == LINK_CIRCE_SYNC_UNTRACKED || ph == LINK_CIRCE_SYNC_DONE)
                        continue;
                char addr[CIRCE_ADDRESS_LEN + 1];

                circe_address_format(c->devices[i].address, addr);
                c->stats.sync_timed_out++;
                event(c, SHM_EVENT_CLOCK_SYNC, "device=%s result=timed-out", addr);
                if (c->hooks->sync_result)
                        c->hooks->sync_result(c->arg, c->devices[i].address, false);
        }
        c->sync_pending = 0;
        if (c->hooks->sync_done)
                c->hooks->sync_done(c->arg, err);
}

/* Leaves the port: Logout (best effort), fail it so the channel moves to the next device. */
static void give_up(struct link_circe_controller *c, enum link_circe_state s, const char *detail,
                    const char *reason)
{
        link_circe_controller_logout(c);
        c->up = false;
        c->answered = false;
        c->login_deadline = LINK_CIRCE_NEVER;
        c->idle_deadline = LINK_CIRCE_NEVER;
        if (c->hooks->fail)
                c->hooks->fail(c->arg, reason);
        sync_finish(c, -ECONNRESET);
        set_state(c, s, detail);
}

void link_circe_controller_logout(struct link_circe_controller *c)
{
        if (send_op(c, CIRCE_OP_LOGOUT) == 0)
                c->stats.logouts++;
}

void link_circe_controller_up(struct link_circe_controller *c, uint64_t now_ms)
{
        c->up = true;
        c->answered = false;
        c->idle_deadline = LINK_CIRCE_NEVER;
        c->login_deadline = now_ms + c->login_timeout_ms;
        set_state(c, LINK_CIRCE_CONNECTING, "");
        /* A failed send leaves the login deadline armed: the port is given up when it passes. */
        if (send_op(c, CIRCE_OP_LOGIN) == 0)
                c->stats.logins++;
}

void link_circe_controller_down(struct link_circe_controller *c, uint64_t now_ms)
{
        (void)now_ms;
        c->up = false;
        c->answered = false;
        c->login_deadline = LINK_CIRCE_NEVER;
        c->idle_deadline = LINK_CIRCE_NEVER;
        sync_finish(c, -ECONNRESET);
        set_state(c, LINK_CIRCE_DISCONNECTED, "");
}

bool link_circe_controller_ready(const struct link_circe_controller *c)
{
        return c->up && c->answered &&
               (c->state == LINK_CIRCE_CONNECTED || c->state == LINK_CIRCE_UNCONFIGURED);
}

static void on_keep_alive(struct link_circe_controller *c, const struct circe_keep_alive *k)
{
        bool changed = !c->has_mediator || c->status != k->status ||
                       memcmp(&c->version, &k->version, sizeof(c->version)) != 0;
        char detail[64];

        c->stats.keep_alives++;
        c->has_mediator = true;
        c->version = k->version;
        c->status = k->status;
        if (changed && c->hooks->mediator)
                c->hooks->mediator(c->arg, &c->version, c->status);
        snprintf(detail, sizeof(detail), "version=%u.%u.%u status=%u", k->version.major,
                 k->version.minor, k->version.patch, k->status);
        if (!link_circe_version_compatible(&k->version, c->expect_major, c->expect_minor)) {
                char d2[96], reason[96];

                c->stats.mismatches++;
                snprintf(d2, sizeof(d2), "%s expected=%u.%u", detail, c->expect_major,
                         c->expect_minor);
                snprintf(reason, sizeof(reason), "mediator speaks CIRCE %u.%u.%u, expected %u.%u",
                         k->version.major, k->version.minor, k->version.patch, c->expect_major,
                         c->expect_minor);
                give_up(c, LINK_CIRCE_VERSION_MISMATCH, d2, reason);
                return;
        }
        c->answered = true;
        c->login_deadline = LINK_CIRCE_NEVER;
        set_state(c, k->status == CIRCE_MEDIATOR_UNCONFIGURED ? LINK_CIRCE_UNCONFIGURED
                                                               : LINK_CIRCE_CONNECTED, detail);
}

/* Index of the device at addr, adding it when new; -1 when the table is full. */
static int device_get(struct link_circe_controller *c, uint32_t addr)
{
        for (unsigned i = 0; i < c->n_devices; i++)
                if (c->devices[i].address == addr)
                        return (int)i;
        if (c->n_devices >= LINK_CIRCE_DEVICES_MAX) {
                c->stats.devices_full++;
                count(c, SHM_COUNTER_ADHOC_FULL);
                diag(c, "device %06X ignored: already tracking %u devices", (unsigned)addr,
                     LINK_CIRCE_DEVICES_MAX);
                return -1;
        }
        memset(&c->devices[c->n_devices], 0, sizeof(c->devices[0]));
        c->devices[c->n_devices].address = addr;
        c->last_status_ms[c->n_devices] = 0;
        c->sync_phase[c->n_devices] = LINK_CIRCE_SYNC_UNTRACKED;
        return (int)c->n_devices++;
}

/* Sets *field to v (and *has), recording bit f in *mask when it changed. */
#define UPDATE(d, mask, f, has, field, present, v) do { \
        if ((present) && (!(d)->has || (d)->field != (v))) { \
                (d)->has = true; \
                (d)->field = (v); \
                *(mask) |= LINK_CIRCE_BIT(f); \
        } \
} while (0)

static uint32_t apply_status(struct link_circe_device *d, const struct circe_notify_status *s)
{
        uint32_t mask = 0;

        if (!d->has_status || d->membership != s->membership)
                mask |= LINK_CIRCE_BIT(LINK_CIRCE_F_MEMBERSHIP);
        if (!d->has_status || d->capabilities != s->capabilities)
                mask |= LINK_CIRCE_BIT(LINK_CIRCE_F_CAPABILITIES);
        if (!d->has_status || d->roles != s->roles)
                mask |= LINK_CIRCE_BIT(LINK_CIRCE_F_ROLES);
        if (!d->has_status || d->signal != s->signal)
                mask |= LINK_CIRCE_BIT(LINK_CIRCE_F_SIGNAL);
        d->has_status = true;
        d->membership = s->membership;
        d->capabilities = s->capabilities;
        d->roles = s->roles;
        d->signal = s->signal;
        UPDATE(d, &mask, LINK_CIRCE_F_BATTERY, has_battery, battery, s->has_battery, s->battery);
        UPDATE(d, &mask, LINK_CIRCE_F_ALIGNED, has_aligned, aligned, s->has_aligned, s->aligned);
        UPDATE(d, &mask, LINK_CIRCE_F_VERSION_MISMATCH, has_version_mismatch, version_mismatch,
               s->has_version_mismatch, s->version_mismatch);
        /* 027 describes the moment: a status without it means "nothing to report", so unlike
         * the other optional parameters it does not keep its last value. */
        if (d->has_clock_sync != s->has_clock_sync ||
            (s->has_clock_sync && d->clock_sync != s->clock_sync))
                mask |= LINK_CIRCE_BIT(LINK_CIRCE_F_CLOCK_SYNC);
        d->has_clock_sync = s->has_clock_sync;
        d->clock_sync = s->has_clock_sync ? s->clock_sync : 0;
        return mask;
}

static void sync_on_status(struct link_circe_controller *c, unsigned i,
                           const struct circe_notify_status *s)
{
        bool succeeded = s->has_clock_sync && s->clock_sync == CIRCE_CLOCK_SYNC_SUCCEEDED;
        char addr[CIRCE_ADDRESS_LEN + 1];

        if (!c->sync_active)
                return;
        switch (c->sync_phase[i]) {
        case LINK_CIRCE_SYNC_WAIT_DROP:
                if (!succeeded)
                        c->sync_phase[i] = LINK_CIRCE_SYNC_ARMED;
                return;
        case LINK_CIRCE_SYNC_ARMED:
                if (!succeeded)
                        return;
                break;
        default:
                return;
        }
        c->sync_phase[i] = LINK_CIRCE_SYNC_DONE;
        c->stats.sync_succeeded++;
        circe_address_format(c->devices[i].address, addr);
        event(c, SHM_EVENT_CLOCK_SYNC, "device=%s result=succeeded", addr);
        if (c->hooks->sync_result)
                c->hooks->sync_result(c->arg, c->devices[i].address, true);
        if (c->sync_pending > 0 && --c->sync_pending == 0)
                sync_finish(c, 0);
}

static void on_status(struct link_circe_controller *c, uint64_t now_ms,
                      const struct circe_notify_status *s)
{
        char addr[CIRCE_ADDRESS_LEN + 1];
        uint32_t mask;
        int i;

        c->stats.statuses++;
        circe_address_format(s->origin, addr);
        if (s->origin == CIRCE_ADDRESS_UNCONFIGURED ||
            !circe_capabilities_compliant(s->capabilities)) {
                c->stats.noncompliant++;
                count(c, SHM_COUNTER_NONCOMPLIANT_STATUS);
                diag(c, "non-compliant Notify Status ignored: address %s capabilities %u", addr,
                     (unsigned)s->capabilities);
                return;
        }
        i = device_get(c, s->origin);
        if (i < 0)
                return;
        mask = apply_status(&c->devices[i], s);
        c->last_status_ms[i] = now_ms;
        if (!c->devices[i].online) {
                c->devices[i].online = true;
                mask |= LINK_CIRCE_BIT(LINK_CIRCE_F_ONLINE);
                c->stats.online_events++;
                event(c, SHM_EVENT_DEVICE_ONLINE, "device=%s capabilities=%u roles=%u", addr,
                      (unsigned)s->capabilities, (unsigned)s->roles);
        }
        device_changed(c, (unsigned)i, mask);
        sync_on_status(c, (unsigned)i, s);
}

static void on_action(struct link_circe_controller *c, const struct circe_notify_action *a)
{
        char addr[CIRCE_ADDRESS_LEN + 1], keys[16] = "", st[24] = "";
        uint32_t mask = 0;
        int i;

        c->stats.actions++;
        circe_address_format(a->origin, addr);
        if (a->has_keys)
                snprintf(keys, sizeof(keys), " keys=%u", (unsigned)a->keys);
        if (a->has_sensor_time)
                snprintf(st, sizeof(st), " sensor_time=%lu", (unsigned long)a->sensor_time_ms);
        /* The event comes first and unconditionally: a gate passage is never lost, not even
         * when the device table is full or the device has not reported a status yet. */
        c->stats.action_events++;
        event(c, SHM_EVENT_ACTION, "device=%s%s%s", addr, keys, st);
        if (a->origin == CIRCE_ADDRESS_UNCONFIGURED)
                return;
        i = device_get(c, a->origin);
        if (i < 0)
                return;
        UPDATE(&c->devices[i], &mask, LINK_CIRCE_F_KEYS, has_keys, keys, a->has_keys, a->keys);
        UPDATE(&c->devices[i], &mask, LINK_CIRCE_F_SENSOR_TIME, has_sensor_time, sensor_time_ms,
               a->has_sensor_time, a->sensor_time_ms);
        /* A new device seen first through an action still gets its variables (online 0). */
        device_changed(c, (unsigned)i, mask | LINK_CIRCE_BIT(LINK_CIRCE_F_ONLINE));
}

void link_circe_controller_message(struct link_circe_controller *c, uint64_t now_ms,
                                   const struct circe_msg *m)
{
        if (!c->up)
                return;
        if (circe_op_from_controller(m->op)) {
                c->stats.unexpected_ops++;
                count(c, SHM_COUNTER_UNKNOWN_OP);
                diag(c, "%s (%02u) is a controller operation; ignored from the mediator",
                     circe_op_str(m->op), (unsigned)m->op);
                return;
        }
        /* Log is diagnostic and may be compiled out of a mediator: it never proves the link
         * alive (PROTOCOLS.md 2.4). */
        if (m->op != CIRCE_OP_LOG)
                c->idle_deadline = now_ms + c->idle_timeout_ms;
        switch (m->op) {
        case CIRCE_OP_KEEP_ALIVE:
                on_keep_alive(c, &m->u.keep_alive);
                break;
        case CIRCE_OP_NOTIFY_STATUS:
                on_status(c, now_ms, &m->u.notify_status);
                break;
        case CIRCE_OP_NOTIFY_ACTION:
                on_action(c, &m->u.notify_action);
                break;
        case CIRCE_OP_LOG:
                c->stats.logs++;
                count(c, SHM_COUNTER_LOG_MESSAGES);
                if (c->hooks->log)
                        c->hooks->log(c->arg, m->u.log.data, m->u.log.len);
                break;
        default:
                break;
        }
}

static void offline_check(struct link_circe_controller *c, uint64_t now_ms)
{
        for (unsigned i = 0; i < c->n_devices; i++) {
                struct link_circe_device *d = &c->devices[i];
                char addr[CIRCE_ADDRESS_LEN + 1];

                /* "More than 3 s": offline from the first millisecond after the 3 s. */
                if (!d->online || now_ms <= c->last_status_ms[i] + LINK_CIRCE_OFFLINE_MS)
                        continue;
                d->online = false;
                c->stats.offline_events++;
                circe_address_format(d->address, addr);
                event(c, SHM_EVENT_DEVICE_OFFLINE, "device=%s", addr);
                device_changed(c, i, LINK_CIRCE_BIT(LINK_CIRCE_F_ONLINE));
        }
}

void link_circe_controller_tick(struct link_circe_controller *c, uint64_t now_ms)
{
        char reason[64];

        if (c->up && !c->answered && now_ms >= c->login_deadline) {
                c->stats.login_timeouts++;
                count(c, SHM_COUNTER_TIMEOUTS);
                snprintf(reason, sizeof(reason), "no Keep Alive within %u ms of Login",
                         (unsigned)c->login_timeout_ms);
                give_up(c, LINK_CIRCE_DISCONNECTED, "reason=login-timeout", reason);
        } else if (c->up && c->answered && now_ms >= c->idle_deadline) {
                c->stats.idle_timeouts++;
                count(c, SHM_COUNTER_TIMEOUTS);
                snprintf(reason, sizeof(reason), "no operation from the mediator for %u ms",
                         (unsigned)c->idle_timeout_ms);
                give_up(c, LINK_CIRCE_DISCONNECTED, "reason=idle-timeout", reason);
        }
        offline_check(c, now_ms);
        if (c->sync_active && now_ms >= c->sync_deadline)
                sync_finish(c, 0);
}

uint64_t link_circe_controller_deadline(const struct link_circe_controller *c)
{
        uint64_t d = LINK_CIRCE_NEVER;

        if (c->up && !c->answered && c->login_deadline < d)
                d = c->login_deadline;
        if (c->up && c->answered && c->idle_deadline < d)
                d = c->idle_deadline;
        for (unsigned i = 0; i < c->n_devices; i++)
                if (c->devices[i].online &&
                    c->last_status_ms[i] + LINK_CIRCE_OFFLINE_MS + 1 < d)
                        d = c->last_status_ms[i] + LINK_CIRCE_OFFLINE_MS + 1;
        if (c->sync_active && c->sync_deadline < d)
                d = c->sync_deadline;
        return d;
}

int link_circe_controller_sync_start(struct link_circe_controller *c, uint64_t now_ms)
{
        int r;

        if (!link_circe_controller_ready(c))
                return -ENOTCONN;
        if (c->sync_active)
                return -EBUSY;
        r = send_op(c, CIRCE_OP_SYNC_CLOCKS);
        if (r < 0)
                return r;
        c->stats.syncs++;
        c->sync_active = true;
        c->sync_deadline = now_ms + LINK_CIRCE_SYNC_WINDOW_MS;
        c->sync_pending = 0;
        for (unsigned i = 0; i < c->n_devices; i++) {
                const struct link_circe_device *d = &c->devices[i];

                if (!d->online) {
                        c->sync_phase[i] = LINK_CIRCE_SYNC_UNTRACKED;
                        continue;
                }
                /* A device may still show 027:2 from an earlier synchronisation (it does for
                 * 4 s): only a 027:2 after a status without it belongs to this one. */
                c->sync_phase[i] = d->has_clock_sync &&
                                   d->clock_sync == CIRCE_CLOCK_SYNC_SUCCEEDED
                                   ? LINK_CIRCE_SYNC_WAIT_DROP : LINK_CIRCE_SYNC_ARMED;
                c->sync_pending++;
        }
        if (c->sync_pending == 0)
                sync_finish(c, 0);
        return 0;
}
