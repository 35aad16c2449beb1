/*
 * Link helpers shared by every engine: the configuration-to-transport mapping, the channel
 * counters in the link's shm area and the requests waiting for a link (see link.h).
 */
#include "daemon/link.h"

#include <errno.h>
#include <string.h>

#include "daemon/control.h"

#include "svc/log.h"
#include "daemon/recorder.h"
#include "daemon/replay.h"
#include "daemon/transport.h"
#include "shm/table.h"

static enum transport_kind transport_kind_of(enum config_transport t)
{
        switch (t) {
        case CONFIG_TRANSPORT_UDP:
                return TRANSPORT_UDP;
        case CONFIG_TRANSPORT_PTY:
                return TRANSPORT_PTY;
        case CONFIG_TRANSPORT_REPLAY:
                return TRANSPORT_REPLAY;
        case CONFIG_TRANSPORT_SERIAL:
        default:
                return TRANSPORT_SERIAL;
        }
}

static enum serial_parity parity_of(enum config_parity p)
{
        switch (p) {
        case CONFIG_PARITY_EVEN:
                return SERIAL_PARITY_EVEN;
        case CONFIG_PARITY_ODD:
                return SERIAL_PARITY_ODD;
        case CONFIG_PARITY_NONE:
        default:
                return SERIAL_PARITY_NONE;
        }
}

static enum serial_flow flow_of(enum config_flow f)
{
        switch (f) {
        case CONFIG_FLOW_RTSCTS:
                return SERIAL_FLOW_RTSCTS;
        case CONFIG_FLOW_XONXOFF:
                return SERIAL_FLOW_XONXOFF;
        case CONFIG_FLOW_NONE:
        default:
                return SERIAL_FLOW_NONE;
        }
}

/* Fills params from a link's configuration; 0 or -EINVAL with the reason logged. */
static int link_transport_params(const struct config_link *cfg, struct transport_params *params)
{
        const char *why;

        transport_params_init(params, transport_kind_of(cfg->transport));
        params->serial.baud = cfg->serial.baud;
        params->serial.parity = parity_of(cfg->serial.parity);
        params->serial.data_bits = cfg->serial.data_bits;
        params->serial.stop_bits = cfg->serial.stop_bits;
        params->serial.flow = flow_of(cfg->serial.flow_control);
        if (cfg->transport == CONFIG_TRANSPORT_REPLAY &&
            transport_params_add_device(params, cfg->replay_file) < 0) {
                log_warnx("link %s: file %s: path too long", cfg->name, cfg->replay_file);
                return -EINVAL;
        }
        /* Decided once, here: the engine asks the channel (channel_datagram()). */
        if (cfg->transport == CONFIG_TRANSPORT_REPLAY)
                params->replay_datagram = replay_file_datagram(cfg->replay_file);
        params->replay_speed = cfg->replay_speed;
        params->replay_loop = cfg->replay_loop;
        for (unsigned i = 0; i < cfg->n_devices; i++)
                if (transport_params_add_device(params, cfg->devices[i]) < 0) {
                        log_warnx("link %s: device %s: path too long or too many devices",
                                  cfg->name, cfg->devices[i]);
                        return -EINVAL;
                }
        if (cfg->transport == CONFIG_TRANSPORT_UDP &&
            transport_params_set_udp(params, cfg->local.text,
                                     cfg->has_remote ? cfg->remote.text : "") < 0) {
                log_warnx("link %s: udp address too long", cfg->name);
                return -EINVAL;
        }
        why = transport_params_check(params);
        if (why) {
                log_warnx("link %s: %s", cfg->name, why);
                return -EINVAL;
        }
        return 0;
}

int link_channel_new(const struct link_env *env, const struct channel_ops *ops, void *arg,
                     struct channel **ret_channel)
{
        struct transport_params params;
        int r;

        r = link_transport_params(env->cfg, &params);
        if (r < 0)
                return r;
        r = channel_new(env->loop, &params, NULL, ops, arg, ret_channel);
        if (r == 0 && env->tap) {
                channel_set_tap(*ret_channel, recorder_chunk, env->tap);
                recorder_tap_set_datagram(env->tap, channel_datagram(*ret_channel));
        }
        return r;
}

void link_publish_channel_stats(const struct link_env *env, const struct channel *ch)
{
        struct channel_stats st;

        if (!ch || !env->table)
                return;
        channel_get_stats(ch, &st);
        shm_table_counter_set(env->table, env->shm_link, SHM_COUNTER_BYTES_IN, st.bytes_in);
        shm_table_counter_set(env->table, env->shm_link, SHM_COUNTER_BYTES_OUT, st.bytes_out);
        shm_table_counter_set(env->table, env->shm_link, SHM_COUNTER_REOPENS, st.reopens);
        shm_table_counter_set(env->table, env->shm_link, SHM_COUNTER_IO_ERRORS, st.io_errors);
        shm_table_counter_set(env->table, env->shm_link, SHM_COUNTER_TX_DROPPED, st.tx_dropped);
        shm_table_counter_set(env->table, env->shm_link, SHM_COUNTER_UDP_REFUSED, st.refused);
}

void link_hook_event(void *arg, enum shm_event_type type, const char *text)
{
        const struct link_env *env = arg;

        shm_table_event(env->table, type, env->shm_link, text);
}

void link_hook_count(void *arg, enum shm_counter counter, uint64_t n)
{
        const struct link_env *env = arg;

        shm_table_counter_add(env->table, env->shm_link, counter, n);
}

int link_waitq_add(struct link_waitq *q, struct control_request *req, uint64_t now_ms,
                   unsigned wait_ms, const void *data, size_t size)
{
        struct link_waiting *w;

        if (size > LINK_WAITQ_DATA_MAX)
                return -EINVAL;
        if (q->n >= LINK_WAITQ_MAX)
                return -EBUSY;
        w = &q->q[q->n++];
        w->req = req;
        w->deadline_ms = now_ms + wait_ms;
        w->wait_ms = wait_ms;
        memcpy(w->data, data, size);
        return 0;
}

void link_waitq_run(struct link_waitq *q, uint64_t now_ms, const struct link_waitq_ops *ops,
                    void *engine)
{
        unsigned i = 0;

        while (i < q->n) {
                /* A copy: run() or expire() may add requests behind it. */
                struct link_waiting w = q->q[i];
                bool ready = ops->ready(engine);

                if (!ready && now_ms < w.deadline_ms && control_request_alive(w.req)) {
                        i++;
                        continue;
                }
                memmove(&q->q[i], &q->q[i + 1], (q->n - i - 1) * sizeof(q->q[0]));
                q->n--;
                if (ready)
                        ops->run(engine, w.req, w.data);
                else
                        ops->expire(engine, w.req, w.data, w.wait_ms);
        }
}

uint64_t link_waitq_deadline(const struct link_waitq *q)
{
        uint64_t d = UINT64_MAX;

        for (unsigned i = 0; i < q->n; i++)
                if (q->q[i].deadline_ms < d)
                        d = q->q[i].deadline_ms;
        return d;
}

void link_waitq_cancel(struct link_waitq *q, int err, const char *why)
{
        for (unsigned i = 0; i < q->n; i++)
                control_reply_error(q->q[i].req, err, "%s", why);
        q->n = 0;
}
