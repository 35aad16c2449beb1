/*
 * CIRCE sessions: the part the controller and the emulator share (link_circe_session.h).
 */
#include "daemon/link_circe_session.h"

#include <stdio.h>
#include <string.h>

static const char *const state_names[LINK_CIRCE_STATE_COUNT] = {
        [LINK_CIRCE_DISCONNECTED] = "disconnected",
        [LINK_CIRCE_CONNECTING] = "connecting",
        [LINK_CIRCE_CONNECTED] = "connected",
        [LINK_CIRCE_VERSION_MISMATCH] = "version-mismatch",
        [LINK_CIRCE_UNCONFIGURED] = "unconfigured",
};

static const char *const field_names[LINK_CIRCE_F_COUNT] = {
        [LINK_CIRCE_F_ONLINE] = "online",
        [LINK_CIRCE_F_MEMBERSHIP] = "membership",
        [LINK_CIRCE_F_CAPABILITIES] = "capabilities",
        [LINK_CIRCE_F_ROLES] = "roles",
        [LINK_CIRCE_F_SIGNAL] = "signal",
        [LINK_CIRCE_F_BATTERY] = "battery",
        [LINK_CIRCE_F_ALIGNED] = "aligned",
        [LINK_CIRCE_F_CLOCK_SYNC] = "clock_sync",
        [LINK_CIRCE_F_VERSION_MISMATCH] = "version_mismatch",
        [LINK_CIRCE_F_KEYS] = "keys",
        [LINK_CIRCE_F_SENSOR_TIME] = "sensor_time",
        [LINK_CIRCE_F_ALERTS] = "alerts",
        [LINK_CIRCE_F_CURRENT] = "current_competitor",
        [LINK_CIRCE_F_NEXT] = "next_competitor",
        [LINK_CIRCE_F_TIMER_RUNNING] = "timer_running",
        [LINK_CIRCE_F_PRIMARY] = "primary_time",
        [LINK_CIRCE_F_SECONDARY] = "secondary_time",
        [LINK_CIRCE_F_FAULTS] = "faults",
        [LINK_CIRCE_F_REFUSALS] = "refusals",
        [LINK_CIRCE_F_ELIMINATED] = "eliminated",
        [LINK_CIRCE_F_PLACEMENT] = "placement",
};

const char *link_circe_state_name(enum link_circe_state state)
{
        if ((unsigned)state >= LINK_CIRCE_STATE_COUNT)
                return "unknown";
        return state_names[state];
}

const char *link_circe_field_name(enum link_circe_field field)
{
        if ((unsigned)field >= LINK_CIRCE_F_COUNT)
                return NULL;
        return field_names[field];
}

enum shm_counter link_circe_reason_counter(enum circe_reason reason)
{
        switch (reason) {
        case CIRCE_REASON_OVERLONG:
                return SHM_COUNTER_OVERLONG;
        case CIRCE_REASON_CHECKSUM_SYNTAX:
        case CIRCE_REASON_BAD_CHECKSUM:
                return SHM_COUNTER_BAD_CHECKSUM;
        case CIRCE_REASON_BAD_HEADER:
                return SHM_COUNTER_BAD_HEADER;
        case CIRCE_REASON_UNKNOWN_OP:
                return SHM_COUNTER_UNKNOWN_OP;
        case CIRCE_REASON_BAD_PARAM_SYNTAX:
                return SHM_COUNTER_BAD_FIELD;
        case CIRCE_REASON_VALUE_LENGTH:
        case CIRCE_REASON_VALUE_TYPE:
        case CIRCE_REASON_VALUE_RANGE:
                return SHM_COUNTER_BAD_VALUE;
        case CIRCE_REASON_MISSING_PARAM:
                return SHM_COUNTER_MISSING_PARAM;
        case CIRCE_REASON_ABANDONED:
        case CIRCE_REASON_BAD_FRAMING:
        default:
                return SHM_COUNTER_RESYNC;
        }
}

void link_circe_wire_init(struct link_circe_wire *w)
{
        circe_decoder_init(&w->dec);
        w->noise_counted = 0;
}

static void count(const struct link_circe_hooks *h, void *arg, enum shm_counter c, uint64_t n)
{
        if (h->count && n)
                h->count(arg, c, n);
}

size_t link_circe_wire_feed(struct link_circe_wire *w, const uint8_t *buf, size_t len,
                            struct circe_result *ret, const struct link_circe_hooks *h,
                            void *arg)
{
        const struct circe_decoder_stats *st = &w->dec.stats;
        size_t n = circe_decoder_feed(&w->dec, buf, len, ret);
        /* Stray ETX and the tail of an overlong packet are bytes between packets too. */
        uint64_t noise = st->noise + st->stray_etx + st->discarded;

        count(h, arg, SHM_COUNTER_NOISE_BYTES, noise - w->noise_counted);
        w->noise_counted = noise;
        if (ret->kind == CIRCE_RESULT_MESSAGE) {
                count(h, arg, SHM_COUNTER_FRAMES_IN, 1);
                count(h, arg, SHM_COUNTER_SKIPPED_PARAM, ret->skipped);
                count(h, arg, SHM_COUNTER_REPEATED_PARAM, ret->repeated);
        } else if (ret->kind == CIRCE_RESULT_REJECTED) {
                count(h, arg, link_circe_reason_counter(ret->reason), 1);
                if (h->rejected)
                        h->rejected(arg, ret);
        }
        return n;
}

static size_t put_uint(char *buf, size_t size, bool has, unsigned long v)
{
        int n;

        if (!has) {
                buf[0] = '\0';
                return 0;
        }
        n = snprintf(buf, size, "%lu", v);
        return n < 0 ? 0 : (size_t)n;
}

size_t link_circe_device_format(const struct link_circe_device *d, enum link_circe_field f,
                                char *buf, size_t size)
{
        const struct link_circe_display *v = &d->display;
        bool st = d->has_status;

        switch (f) {
        case LINK_CIRCE_F_ONLINE:
                return put_uint(buf, size, true, d->online);
        case LINK_CIRCE_F_MEMBERSHIP:
                return put_uint(buf, size, st, d->membership);
        case LINK_CIRCE_F_CAPABILITIES:
                return put_uint(buf, size, st, d->capabilities);
        case LINK_CIRCE_F_ROLES:
                return put_uint(buf, size, st, d->roles);
        case LINK_CIRCE_F_SIGNAL:
                return put_uint(buf, size, st, d->signal);
        case LINK_CIRCE_F_BATTERY:
                return put_uint(buf, size, d->has_battery, d->battery);
        case LINK_CIRCE_F_ALIGNED:
                return put_uint(buf, size, d->has_aligned, d->aligned);
        case LINK_CIRCE_F_CLOCK_SYNC:
                return put_uint(buf, size, d->has_clock_sync, d->clock_sync);
        case LINK_CIRCE_F_VERSION_MISMATCH:
                return put_uint(buf, size, d->has_version_mismatch, d->version_mismatch);
        case LINK_CIRCE_F_KEYS:
                return put_uint(buf, size, d->has_keys, d->keys);
        case LINK_CIRCE_F_SENSOR_TIME:
                return put_uint(buf, size, d->has_sensor_time, d->sensor_time_ms);
        case LINK_CIRCE_F_ALERTS:
                return put_uint(buf, size, true, d->alerts);
        case LINK_CIRCE_F_CURRENT:
                return put_uint(buf, size, v->has_current, v->current);
        case LINK_CIRCE_F_NEXT:
                return put_uint(buf, size, v->has_next, v->next);
        case LINK_CIRCE_F_TIMER_RUNNING:
                return put_uint(buf, size, v->has_timer, v->timer_running);
        case LINK_CIRCE_F_PRIMARY:
                return put_uint(buf, size, v->has_primary, v->primary_ms);
        case LINK_CIRCE_F_SECONDARY:
                return put_uint(buf, size, v->has_secondary, v->secondary_ms);
        case LINK_CIRCE_F_FAULTS:
                return put_uint(buf, size, v->has_faults, v->faults);
        case LINK_CIRCE_F_REFUSALS:
                return put_uint(buf, size, v->has_refusals, v->refusals);
        case LINK_CIRCE_F_ELIMINATED:
                return put_uint(buf, size, v->has_eliminated, v->eliminated);
        case LINK_CIRCE_F_PLACEMENT:
                return put_uint(buf, size, v->has_placement, v->placement);
        case LINK_CIRCE_F_COUNT:
        default:
                break;
        }
        buf[0] = '\0';
        return 0;
}

bool link_circe_version_compatible(const struct circe_version *v, unsigned major,
                                   unsigned minor)
{
        return v->major == major && v->minor == minor;
}

void link_circe_device_status(const struct link_circe_device *d, struct circe_msg *ret)
{
        struct circe_notify_status *s = &ret->u.notify_status;

        memset(ret, 0, sizeof(*ret));
        ret->op = CIRCE_OP_NOTIFY_STATUS;
        s->origin = d->address;
        s->membership = d->membership;
        s->capabilities = d->capabilities;
        s->roles = d->roles;
        s->signal = d->signal;
        s->has_battery = d->has_battery;
        s->battery = d->battery;
        s->has_aligned = d->has_aligned;
        s->aligned = d->aligned;
        s->has_clock_sync = d->has_clock_sync;
        s->clock_sync = d->clock_sync;
        s->has_version_mismatch = d->has_version_mismatch;
        s->version_mismatch = d->version_mismatch;
}
