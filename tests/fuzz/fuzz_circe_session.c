/*
 * libFuzzer target for the CIRCE sessions (src/daemon/link_circe_{session,controller,mediator}.c):
 * a controller session and a mediator-emulator session wired back to back, as the engine wires
 * them to a channel, and driven by a program read from the input:
 *
 *   op 0/1  raw bytes (garbage, partial packets) into the controller's / the emulator's decoder
 *   op 2/3  a valid packet of a random operation (encoded from input bytes) into either side
 *   op 4    the clock moves forward, both sessions tick, packets in flight are delivered
 *   op 5    a port opens or closes under a session
 *   op 6    a command: sync-clocks on the controller, an injected action on the emulator
 *   op 7    packets in flight are delivered
 *
 * Invariants (a broken one is a __builtin_trap()):
 *   - every packet a session sends encodes (the sessions never build what the codec refuses);
 *   - counters add up: frames_in = decoded packets, drops by reason = the decoder's, noise bytes
 *     = the decoder's noise; every Notify Action fed to an open controller gives exactly one
 *     action event, never lost;
 *   - device-online / device-offline events alternate per device and match the device table;
 *   - a clock synchronisation reports each device at most once and ends exactly once;
 *   - after a tick, no deadline is left in the past (no busy loop), and bounded tables stay
 *     within their bounds.
 */
#include <errno.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "daemon/config.h"
#include "daemon/link_circe_controller.h"
#include "daemon/link_circe_mediator.h"
#include "daemon/link_circe_session.h"
#include "fuzz/fuzz_input.h"

#define QUEUE_MAX       8192            /* bytes in flight per direction, like a channel queue */
#define RAW_MAX         96              /* raw bytes per op */
#define TRACK_MAX       256             /* addresses whose online state the harness follows */
#define STEPS_MAX       4096            /* ops per input */
#define START_MS        1000000ull

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static uint32_t take32(struct input *in, unsigned bytes)
{
        uint32_t v = 0;

        for (unsigned i = 0; i < bytes; i++)
                v = v << 8 | take(in);
        return v;
}

/* One side: a session, its decoder, what it sent, and the harness's view of it. */
struct side {
        bool controller;
        struct link_circe_wire wire;
        uint8_t out[QUEUE_MAX];         /* packets it sent, not yet delivered */
        size_t out_len;
        bool port_up;
        uint64_t counters[SHM_COUNTER_COUNT];
        uint64_t action_events, actions_fed;
        uint64_t events;
        /* What the decoders reported, summed over port reopens (each resets its decoder). */
        uint64_t decoded, rejected[CIRCE_REASON_COUNT], noise;
};

struct bench {
        uint64_t now;
        struct side c, m;
        struct link_circe_controller ctl;
        struct link_circe_mediator med;
        /* Online state of devices, as the controller's events told it. */
        uint32_t track_addr[TRACK_MAX];
        bool track_online[TRACK_MAX];
        unsigned n_track;
        /* Clock synchronisation bookkeeping. */
        bool sync_running;
        unsigned sync_results;
        uint32_t sync_reported[LINK_CIRCE_DEVICES_MAX];
};

static struct bench bench;

/* ---- hooks ----------------------------------------------------------------------------------- */

static int hook_send(void *arg, const struct circe_msg *m)
{
        struct side *s = arg;
        char pkt[CIRCE_PACKET_MAX];
        int n = circe_encode(m, (int)(s->out_len & 1), pkt, sizeof(pkt));

        CHECK(n > 0);
        CHECK(circe_op_from_controller(m->op) == s->controller);
        if (!s->port_up)
                return -ENOTCONN;
        if (s->out_len + (size_t)n > sizeof(s->out))
                return -ENOBUFS;
        memcpy(s->out + s->out_len, pkt, (size_t)n);
        s->out_len += (size_t)n;
        return 0;
}

static void hook_fail(void *arg, const char *reason)
{
        struct side *s = arg;

        CHECK(s->controller);
        CHECK(reason && reason[0]);
        s->port_up = false;
        s->out_len = 0;
        link_circe_wire_init(&s->wire);
}

static void hook_state(void *arg, enum link_circe_state state, const char *detail)
{
        (void)arg;
        CHECK((unsigned)state < LINK_CIRCE_STATE_COUNT);
        CHECK(detail != NULL);
        CHECK(strcmp(link_circe_state_name(state), "unknown") != 0);
}

static void hook_mediator(void *arg, const struct circe_version *v, unsigned status)
{
        (void)arg;
        CHECK(v->major <= CIRCE_VERSION_PART_MAX && v->minor <= CIRCE_VERSION_PART_MAX &&
              v->patch <= CIRCE_VERSION_PART_MAX);
        CHECK(status <= 999);
}

static void hook_device(void *arg, unsigned index, const struct link_circe_device *d,
                        uint32_t fields, uint32_t old_address)
{
        struct side *s = arg;
        char text[32];

        (void)old_address;
        CHECK(fields != 0 && (fields & ~LINK_CIRCE_FIELDS_ALL) == 0);
        if (s->controller) {
                CHECK(index < bench.ctl.n_devices);
                CHECK(&bench.ctl.devices[index] == d);
                CHECK(d->address != CIRCE_ADDRESS_UNCONFIGURED);
        } else {
                CHECK(index < bench.med.n_devices);
                CHECK(&bench.med.devices[index] == d);
        }
        for (unsigned f = 0; f < LINK_CIRCE_F_COUNT; f++)
                CHECK(link_circe_device_format(d, (enum link_circe_field)f, text,
                                               sizeof(text)) < 12);
}

static int track_find(uint32_t addr)
{
        for (unsigned i = 0; i < bench.n_track; i++)
                if (bench.track_addr[i] == addr)
                        return (int)i;
        return -1;
}

/* Reads "device=XXXXXX" at the start of an event text. */
static uint32_t event_device(const char *text)
{
        uint32_t addr;

        CHECK(strncmp(text, "device=", 7) == 0);
        CHECK(circe_address_parse(text + 7, CIRCE_ADDRESS_LEN, &addr) == 0);
        return addr;
}

static void hook_event(void *arg, enum shm_event_type type, const char *text)
{
        struct side *s = arg;
        int t;

        CHECK(strlen(text) < SHM_EVENT_TEXT_SIZE);
        s->events++;
        if (!s->controller)
                return;
        switch (type) {
        case SHM_EVENT_ACTION:
                s->action_events++;
                (void)event_device(text);
                break;
        case SHM_EVENT_DEVICE_ONLINE:
                t = track_find(event_device(text));
                if (t < 0) {
                        CHECK(bench.n_track < TRACK_MAX);
                        t = (int)bench.n_track++;
                        bench.track_addr[t] = event_device(text);
                }
                CHECK(!bench.track_online[t]);
                bench.track_online[t] = true;
                break;
        case SHM_EVENT_DEVICE_OFFLINE:
                t = track_find(event_device(text));
                CHECK(t >= 0 && bench.track_online[t]);
                bench.track_online[t] = false;
                break;
        case SHM_EVENT_CLOCK_SYNC:
                (void)event_device(text);
                break;
        default:
                CHECK(0);
        }
}

static void hook_count(void *arg, enum shm_counter c, uint64_t delta)
{
        struct side *s = arg;

        CHECK((unsigned)c < SHM_COUNTER_COUNT);
        CHECK(delta > 0);
        s->counters[c] += delta;
}

static void hook_rejected(void *arg, const struct circe_result *res)
{
        (void)arg;
        CHECK(res->kind == CIRCE_RESULT_REJECTED);
        CHECK(res->reason > CIRCE_REASON_NONE && res->reason < CIRCE_REASON_COUNT);
}

static void hook_diag(void *arg, const char *text)
{
        (void)arg;
        CHECK(strlen(text) < LINK_CIRCE_DIAG_MAX);
}

static void hook_log(void *arg, const uint8_t *data, size_t len)
{
        struct side *s = arg;

        CHECK(s->controller);
        CHECK(data && len >= 1 && len <= CIRCE_LOG_MAX);
}

static void hook_sync_result(void *arg, uint32_t address, bool succeeded)
{
        (void)arg;
        (void)succeeded;
        CHECK(bench.sync_running);
        for (unsigned i = 0; i < bench.sync_results; i++)
                CHECK(bench.sync_reported[i] != address);
        CHECK(bench.sync_results < LINK_CIRCE_DEVICES_MAX);
        bench.sync_reported[bench.sync_results++] = address;
}

static void hook_sync_done(void *arg, int err)
{
        (void)arg;
        CHECK(bench.sync_running);
        CHECK(err == 0 || err == -ECONNRESET);
        bench.sync_running = false;
}

static const struct link_circe_hooks hooks = {
        .send = hook_send,
        .fail = hook_fail,
        .state = hook_state,
        .mediator = hook_mediator,
        .device = hook_device,
        .event = hook_event,
        .count = hook_count,
        .rejected = hook_rejected,
        .diag = hook_diag,
        .log = hook_log,
        .sync_result = hook_sync_result,
        .sync_done = hook_sync_done,
};

/* ---- setup ----------------------------------------------------------------------------------- */

static const uint32_t pool[] = {
        0xE1E1E1, 0xAAAAAA, 0xD15D15, 0x000000, 0xE2E2E2, 0x123456, 0x7DCB0E, 0xFFFFFE,
};
#define POOL_N (sizeof(pool) / sizeof(pool[0]))

static void setup(uint8_t flags)
{
        static const struct config_emulated_device emu[] = {
                { .address = 0xE1E1E1, .capabilities = 32, .signal = 150, .battery = 200,
                  .has_battery = true },
                { .address = 0xAAAAAA, .capabilities = 31, .roles = 3, .signal = 200 },
                { .address = 0xD15D15, .capabilities = 64, .signal = 90 },
                { .address = 0x000000, .capabilities = 32, .signal = 10 },
                { .address = 0xE2E2E2, .capabilities = 32, .roles = 4, .signal = 130,
                  .membership = true },
        };
        struct config_circe cc, mc;

        memset(&bench, 0, sizeof(bench));
        bench.now = START_MS;
        memset(&cc, 0, sizeof(cc));
        cc.role = CONFIG_ROLE_CONTROLLER;
        cc.expect_version = (struct config_circe_version){ "0.2", 0, 2, 0 };
        cc.login_timeout_ms = CONFIG_TIMEOUT_MS_MIN + (flags & 7) * 300u;
        cc.idle_timeout_ms = CONFIG_TIMEOUT_MS_MIN + ((flags >> 3) & 7) * 500u;
        memset(&mc, 0, sizeof(mc));
        mc.role = CONFIG_ROLE_MEDIATOR;
        /* One input in eight plays a mediator of another version. */
        mc.version = (flags >> 6) == 3 ? (struct config_circe_version){ "1.2.34", 1, 2, 34 }
                                       : (struct config_circe_version){ "0.2.3", 0, 2, 3 };
        mc.status = (flags >> 6) == 2 ? 1 : 0;
        mc.keepalive_ms = CONFIG_KEEPALIVE_MS_MIN + (flags & 0x3F) * 20u;
        memcpy(mc.emulate, emu, sizeof(emu));
        mc.n_emulate = sizeof(emu) / sizeof(emu[0]);
        bench.c.controller = true;
        bench.m.controller = false;
        link_circe_wire_init(&bench.c.wire);
        link_circe_wire_init(&bench.m.wire);
        link_circe_controller_init(&bench.ctl, &cc, &hooks, &bench.c);
        link_circe_mediator_init(&bench.med, &mc, &hooks, &bench.m, bench.now);
}

/* ---- feeding --------------------------------------------------------------------------------- */

static void feed(struct side *s, const uint8_t *buf, size_t len)
{
        while (len > 0) {
                const struct circe_decoder_stats *st = &s->wire.dec.stats;
                uint64_t noise0 = st->noise + st->stray_etx + st->discarded;
                struct circe_result res;
                size_t n = link_circe_wire_feed(&s->wire, buf, len, &res, &hooks, s);

                CHECK(n >= 1 && n <= len);
                s->noise += st->noise + st->stray_etx + st->discarded - noise0;
                buf += n;
                len -= n;
                if (res.kind == CIRCE_RESULT_REJECTED)
                        s->rejected[res.reason]++;
                if (res.kind != CIRCE_RESULT_MESSAGE)
                        continue;
                s->decoded++;
                if (s->controller) {
                        if (res.msg.op == CIRCE_OP_NOTIFY_ACTION && bench.ctl.up)
                                s->actions_fed++;
                        link_circe_controller_message(&bench.ctl, bench.now, &res.msg);
                } else {
                        link_circe_mediator_message(&bench.med, bench.now, &res.msg);
                }
                /* A controller that gave up on its port stops reading the old stream. */
                if (s->controller && !s->port_up)
                        return;
        }
}

/* Delivers what each side sent to the other (only onto an open port). */
static void pump(void)
{
        uint8_t buf[QUEUE_MAX];
        size_t n;

        for (int round = 0; round < 4; round++) {
                n = bench.m.out_len;
                memcpy(buf, bench.m.out, n);
                bench.m.out_len = 0;
                if (bench.c.port_up)
                        feed(&bench.c, buf, n);
                n = bench.c.out_len;
                memcpy(buf, bench.c.out, n);
                bench.c.out_len = 0;
                if (bench.m.port_up)
                        feed(&bench.m, buf, n);
        }
}

/* A controller -> mediator (to_mediator) or mediator -> controller packet from input bytes. */
static void make_msg(struct input *in, bool to_mediator, struct circe_msg *m)
{
        static const enum circe_op c_ops[] = {
                CIRCE_OP_LOGIN, CIRCE_OP_LOGOUT, CIRCE_OP_ALERT, CIRCE_OP_NETWORK_SETUP,
                CIRCE_OP_DEVICE_SETUP, CIRCE_OP_SYNC_CLOCKS, CIRCE_OP_VISUALIZE,
        };
        static const enum circe_op m_ops[] = {
                CIRCE_OP_KEEP_ALIVE, CIRCE_OP_NOTIFY_STATUS, CIRCE_OP_NOTIFY_ACTION, CIRCE_OP_LOG,
        };
        uint8_t sel = take(in);
        uint32_t addr = (sel & 0x80) ? take32(in, 3) % 0xFFFFFF : pool[take(in) % POOL_N];

        if (addr == CIRCE_ADDRESS_RESERVED)
                addr = 0;
        memset(m, 0, sizeof(*m));
        m->op = to_mediator ? c_ops[sel % 7] : m_ops[sel % 4];
        switch (m->op) {
        case CIRCE_OP_ALERT:
                m->u.alert.dest = addr;
                break;
        case CIRCE_OP_NETWORK_SETUP:
                m->u.network_setup.dest = addr;
                m->u.network_setup.set_membership = take(in) & 1;
                m->u.network_setup.roles = take(in) & 0x7F;
                break;
        case CIRCE_OP_DEVICE_SETUP: {
                uint8_t f = take(in);

                m->u.device_setup.has_dest = f & 1;
                m->u.device_setup.dest = addr;
                m->u.device_setup.assign = pool[(f >> 1) % POOL_N];
                if (m->u.device_setup.assign == CIRCE_ADDRESS_RESERVED)
                        m->u.device_setup.assign = 0x010203;
                m->u.device_setup.has_capabilities = f & 0x10;
                m->u.device_setup.capabilities = take(in) & 0x7F;
                break;
        }
        case CIRCE_OP_VISUALIZE: {
                struct circe_visualize *v = &m->u.visualize;
                uint8_t f = take(in);

                v->dest_count = 1 + take(in) % 3;
                for (unsigned i = 0; i < v->dest_count; i++)
                        v->dests[i] = i == 0 ? addr : pool[take(in) % (POOL_N - 1)];
                v->has_current = f & 1;
                v->current = (uint16_t)(take32(in, 2) % 1000);
                v->has_next = f & 2;
                v->next = (uint16_t)(take32(in, 2) % 1000);
                v->start_timer = f & 4;
                v->has_primary = f & 8;
                v->primary_ms = take32(in, 3) % 1000000;
                v->has_secondary = f & 16;
                v->secondary_ms = take32(in, 3) % 1000000;
                v->has_faults = f & 32;
                v->faults = take(in) % 100;
                v->has_refusals = f & 64;
                v->refusals = take(in) % 100;
                v->has_eliminated = f & 128;
                v->eliminated = take(in) & 1;
                if (!(f & 0x7F) && !v->has_eliminated) {
                        v->has_placement = true;
                        v->placement = (uint16_t)(take32(in, 2) % 1000);
                }
                break;
        }
        case CIRCE_OP_KEEP_ALIVE:
                m->u.keep_alive.version.major = take(in) % 3;
                m->u.keep_alive.version.minor = (uint16_t)(take(in) % 4);
                m->u.keep_alive.version.patch = take(in);
                m->u.keep_alive.status = take(in) % 4;
                break;
        case CIRCE_OP_NOTIFY_STATUS: {
                struct circe_notify_status *s = &m->u.notify_status;
                uint8_t f = take(in);

                s->origin = addr;
                s->membership = f & 1;
                s->capabilities = take(in) & 0x7F;
                s->roles = take(in) & 0x7F;
                s->signal = take(in);
                s->has_battery = f & 2;
                s->battery = take(in);
                s->has_aligned = f & 4;
                s->aligned = f & 8;
                s->has_clock_sync = f & 16;
                s->clock_sync = (f & 32) ? 2 : 1;
                s->has_version_mismatch = f & 64;
                s->version_mismatch = f & 128;
                break;
        }
        case CIRCE_OP_NOTIFY_ACTION: {
                uint8_t f = take(in);

                m->u.notify_action.origin = addr;
                m->u.notify_action.has_keys = f & 1;
                m->u.notify_action.keys = (uint16_t)take32(in, 2);
                m->u.notify_action.has_sensor_time = f & 2;
                m->u.notify_action.sensor_time_ms = take32(in, 3) % 1000000;
                break;
        }
        case CIRCE_OP_LOG:
                m->u.log.len = 1 + take(in) % 64;
                for (unsigned i = 0; i < m->u.log.len; i++)
                        m->u.log.data[i] = take(in);
                break;
        default:
                break;
        }
}

static void inject_msg(struct input *in, bool to_mediator)
{
        struct circe_msg m;
        char pkt[CIRCE_PACKET_MAX];
        int n;

        make_msg(in, to_mediator, &m);
        n = circe_encode(&m, take(in) & 1, pkt, sizeof(pkt));
        CHECK(n > 0);
        feed(to_mediator ? &bench.m : &bench.c, (const uint8_t *)pkt, (size_t)n);
}

static void inject_raw(struct input *in, struct side *s)
{
        uint8_t raw[RAW_MAX];
        size_t n = take(in) % RAW_MAX;

        for (size_t i = 0; i < n; i++)
                raw[i] = take(in);
        feed(s, raw, n);
}

static void tick(void)
{
        link_circe_controller_tick(&bench.ctl, bench.now);
        link_circe_mediator_tick(&bench.med, bench.now);
        /* Nothing overdue may be left behind: the engine would spin on its timer. */
        CHECK(link_circe_controller_deadline(&bench.ctl) > bench.now);
        CHECK(link_circe_mediator_deadline(&bench.med) > bench.now);
}

static void advance(struct input *in)
{
        uint32_t step = take32(in, 2);
        uint64_t target = bench.now + (step & 0x8000 ? (step & 0x7FFF) : (step & 0xFF));

        /* Deadlines in between fire in order, as the event loop would make them. */
        for (int guard = 0; guard < 64; guard++) {
                uint64_t d = link_circe_controller_deadline(&bench.ctl);
                uint64_t e = link_circe_mediator_deadline(&bench.med);

                if (e < d)
                        d = e;
                if (d > target)
                        break;
                bench.now = d > bench.now ? d : bench.now;
                tick();
                pump();
        }
        bench.now = target;
        tick();
        pump();
}

static void port(struct input *in)
{
        switch (take(in) % 4) {
        case 0:
                if (!bench.c.port_up) {
                        bench.c.port_up = true;
                        link_circe_wire_init(&bench.c.wire);
                        link_circe_controller_up(&bench.ctl, bench.now);
                }
                break;
        case 1:
                if (bench.c.port_up) {
                        bench.c.port_up = false;
                        bench.c.out_len = 0;
                        link_circe_controller_down(&bench.ctl, bench.now);
                }
                break;
        case 2:
                if (!bench.m.port_up) {
                        bench.m.port_up = true;
                        link_circe_wire_init(&bench.m.wire);
                        link_circe_mediator_up(&bench.med, bench.now);
                }
                break;
        default:
                if (bench.m.port_up) {
                        bench.m.port_up = false;
                        bench.m.out_len = 0;
                        link_circe_mediator_down(&bench.med, bench.now);
                }
                break;
        }
}

static void command(struct input *in)
{
        uint8_t f = take(in);

        if (f & 1) {
                bool was_running = bench.sync_running;
                int r;

                if (!bench.sync_running) {
                        bench.sync_running = true;
                        bench.sync_results = 0;
                }
                r = link_circe_controller_sync_start(&bench.ctl, bench.now);
                if (r < 0) {
                        CHECK(r == -ENOTCONN || r == -EBUSY || r == -ENOBUFS);
                        CHECK((r == -EBUSY) == was_running);
                        bench.sync_running = was_running;
                }
        } else {
                uint32_t addr = pool[take(in) % POOL_N];
                long keys = (f & 2) ? (long)take32(in, 2) : -1;
                long st = (f & 4) ? (long)(take32(in, 3) % 1000000) : -1;
                int r = link_circe_mediator_action(&bench.med, bench.now, addr, keys, st);

                CHECK(r == 0 || r == -ENOTCONN || r == -ENOENT || r == -ENOBUFS);
        }
}

/* ---- invariants ------------------------------------------------------------------------------ */

static void check_side(const struct side *s, uint64_t unexpected_ops)
{
        uint64_t by_counter[SHM_COUNTER_COUNT] = { 0 };

        CHECK(s->out_len <= QUEUE_MAX);
        CHECK(s->action_events == (s->controller ? s->actions_fed : 0));
        CHECK(s->counters[SHM_COUNTER_FRAMES_IN] == s->decoded);
        CHECK(s->counters[SHM_COUNTER_NOISE_BYTES] == s->noise);
        for (unsigned r = 1; r < CIRCE_REASON_COUNT; r++)
                by_counter[link_circe_reason_counter((enum circe_reason)r)] += s->rejected[r];
        by_counter[SHM_COUNTER_UNKNOWN_OP] += unexpected_ops;
        for (unsigned c = 0; c < SHM_COUNTER_COUNT; c++) {
                switch (c) {
                case SHM_COUNTER_OVERLONG:
                case SHM_COUNTER_BAD_CHECKSUM:
                case SHM_COUNTER_BAD_HEADER:
                case SHM_COUNTER_BAD_FIELD:
                case SHM_COUNTER_BAD_VALUE:
                case SHM_COUNTER_MISSING_PARAM:
                case SHM_COUNTER_RESYNC:
                case SHM_COUNTER_UNKNOWN_OP:
                        CHECK(s->counters[c] == by_counter[c]);
                        break;
                default:
                        break;
                }
        }
}

static void check_all(void)
{
        const struct link_circe_controller *c = &bench.ctl;

        check_side(&bench.c, bench.ctl.stats.unexpected_ops);
        check_side(&bench.m, bench.med.stats.unexpected_ops);
        CHECK(bench.c.counters[SHM_COUNTER_NONCOMPLIANT_STATUS] == bench.ctl.stats.noncompliant);
        CHECK(bench.c.counters[SHM_COUNTER_LOG_MESSAGES] == bench.ctl.stats.logs);
        CHECK(c->n_devices <= LINK_CIRCE_DEVICES_MAX);
        CHECK(bench.med.n_devices <= CONFIG_EMULATE_MAX);
        CHECK(c->sync_active == bench.sync_running);
        for (unsigned i = 0; i < c->n_devices; i++) {
                int t = track_find(c->devices[i].address);

                CHECK(c->devices[i].online == (t >= 0 && bench.track_online[t]));
        }
        if (link_circe_controller_ready(c))
                CHECK(c->state == LINK_CIRCE_CONNECTED || c->state == LINK_CIRCE_UNCONFIGURED);
        if (!bench.c.port_up)
                CHECK(!c->up);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        struct input in = { data, size };

        setup(take(&in));
        for (unsigned step = 0; step < STEPS_MAX && in.n > 0; step++) {
                switch (take(&in) % 8) {
                case 0:
                        inject_raw(&in, &bench.c);
                        break;
                case 1:
                        inject_raw(&in, &bench.m);
                        break;
                case 2:
                        inject_msg(&in, false);
                        break;
                case 3:
                        inject_msg(&in, true);
                        break;
                case 4:
                        advance(&in);
                        break;
                case 5:
                        port(&in);
                        break;
                case 6:
                        command(&in);
                        break;
                default:
                        pump();
                        break;
                }
                check_all();
        }
        /* Run everything out: a long quiet time ends every synchronisation and takes every
         * device offline. */
        bench.now += 10 * LINK_CIRCE_OFFLINE_MS;
        tick();
        CHECK(!bench.sync_running);
        for (unsigned i = 0; i < bench.ctl.n_devices; i++)
                CHECK(!bench.ctl.devices[i].online);
        check_all();
        return 0;
}
