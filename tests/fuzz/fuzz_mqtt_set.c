/*
 * libFuzzer target for what the MQTT bridge does with a set/ message (bridge_set() in
 * src/mqtt/bridge.c: the topic split, the checks of the payload, the write through libsharedlink,
 * the refusal and its JSON reply), on real tables made by the daemon-side module and a sink that
 * records what the bridge publishes; no broker, no daemon.
 *
 * Input: byte 0 says how the message came (its low two bits: live, retained, queued) and whether
 * the topic is put under "<base>/set/" (bit 2) or taken as it is; byte 1 the topic's length;
 * then the topic's bytes (cut at a NUL: MQTT hands topics over as C strings) and the payload.
 *
 * What must hold for every input, beyond "no crash, no leak" (the sanitizers):
 *  - the result is 1 (written), 0 (ignored) or -EPERM / -EINVAL (refused), and the counters
 *    move by exactly one for a write or a refusal, not at all for an ignored message;
 *  - only a live message is ever written, and then the variable reads back as the payload;
 *    a message that is not written changes no variable;
 *  - the bridge publishes at most one message, a refusal: not retained, QoS set_qos, on
 *    "<base>/set/<name>/error" for a name the topic split accepts, a JSON object without raw
 *    control bytes;
 *  - bridge_format_set_topic hands back a name that can be a topic level.
 * Corpus: tests/fuzz/corpus/mqtt_set/.
 */
#include <errno.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sharedlink.h>

#include "common/shmtest.h"
#include "fuzz/fuzz_input.h"
#include "mqtt/bridge.h"
#include "mqtt/bridge_config.h"
#include "mqtt/bridge_format.h"

#define VIA_MASK        0x03u
#define VIA_COUNT       3u
#define UNDER_SET       0x04u
#define MSGS_MAX        4       /* more than one reply would already be a finding */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static const struct shm_var vars[] = {
        { "AutoGpsLat", SHM_DIR_IN, SHM_TYPE_DOUBLE, 0, "A", 0 },
        { "CmdThrottle", SHM_DIR_OUT, SHM_TYPE_DOUBLE, 0, "A", 0 },
        { "CmdSteer", SHM_DIR_OUT, SHM_TYPE_LONG, 0, "A", 1 },
        { "Note", SHM_DIR_OUT, SHM_TYPE_STRING, SHM_LINK_NONE, NULL, SHM_POSITION_NONE },
        { "Hidden", SHM_DIR_OUT, SHM_TYPE_STRING, SHM_LINK_NONE, NULL, SHM_POSITION_NONE },
};

#define NVARS   (sizeof(vars) / sizeof(vars[0]))

struct captured {
        char topic[BRIDGE_TOPIC_MAX];
        char payload[BRIDGE_JSON_MAX];
        size_t len;
        int qos;
        bool retain;
};

static struct {
        struct shmtest_table tb;
        struct bridge_config cfg;
        struct bridge *b;
        struct sl_client *c;
        struct captured msg[MSGS_MAX];
        unsigned n;
        bool ready;
} fx;

static int capture(void *arg, const char *topic, const void *payload, size_t len, int qos,
                   bool retain, int *ret_mid)
{
        struct captured *m;

        (void)arg;
        CHECK(fx.n < MSGS_MAX);
        m = &fx.msg[fx.n++];
        CHECK(strlen(topic) < sizeof(m->topic) && len < sizeof(m->payload));
        strcpy(m->topic, topic);
        memcpy(m->payload, payload, len);
        m->payload[len] = '\0';
        m->len = len;
        m->qos = qos;
        m->retain = retain;
        *ret_mid = (int)fx.n;
        return 0;
}

static const struct bridge_sink sink = { .publish = capture };

static void cleanup(void)
{
        fx.b = bridge_free(fx.b);
        sl_close(fx.c);
        shmtest_table_destroy(&fx.tb);
}

/* Once per process: the tables, a bridge on them that may write Cmd* and Note, a reader. */
static void init(void)
{
        shmtest_table_init(&fx.tb, "fuzzmqtt");
        shmtest_table_config(&fx.tb, vars, NVARS, 0);
        CHECK(shmtest_table_create(&fx.tb) == 0);
        atexit(cleanup);
        CHECK(sl_open(fx.tb.instance, &fx.c) == 0);
        bridge_config_defaults(&fx.cfg);
        snprintf(fx.cfg.instance, sizeof(fx.cfg.instance), "%s", fx.tb.instance);
        fx.cfg.events = false;
        fx.cfg.writable.count = 2;
        snprintf(fx.cfg.writable.glob[0], sizeof(fx.cfg.writable.glob[0]), "Cmd*");
        snprintf(fx.cfg.writable.glob[1], sizeof(fx.cfg.writable.glob[1]), "Note");
        CHECK(bridge_new(&fx.cfg, &fx.b) == 0);
        CHECK(bridge_attach(fx.b) == 0);
        fx.ready = true;
}

static void read_all(char values[NVARS][SL_VALUE_SIZE])
{
        for (unsigned id = 0; id < NVARS; id++) {
                struct sl_meta meta = { .size = sizeof(meta) };

                if (sl_read(fx.c, (int)id, values[id], SL_VALUE_SIZE, &meta) < 0)
                        values[id][0] = '\0';
        }
}

/* A JSON object as bridge_format_error writes it: braces around, no raw control byte. */
static void check_json(const struct captured *m)
{
        CHECK(m->len >= 2 && m->payload[0] == '{' && m->payload[m->len - 1] == '}');
        for (size_t i = 0; i < m->len; i++)
                CHECK((unsigned char)m->payload[i] >= 0x20 && m->payload[i] != 0x7f);
        CHECK(strstr(m->payload, "\"code\":\"") != NULL);
}

static void check_reply(const struct captured *m, const char *base)
{
        char name[SL_NAME_SIZE], set[BRIDGE_TOPIC_MAX];
        size_t bl;

        CHECK(!m->retain && m->qos == fx.cfg.set_qos);
        /* base/set/<name>/error: the split takes it as one of the bridge's own replies. */
        CHECK(bridge_format_set_topic(base, m->topic, name) == 0);
        snprintf(set, sizeof(set), "%s/" BRIDGE_TOPIC_SET "/", base);
        bl = strlen(set);
        CHECK(strncmp(m->topic, set, bl) == 0);
        check_json(m);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        struct input in = { data, size };
        char before[NVARS][SL_VALUE_SIZE], after[NVARS][SL_VALUE_SIZE];
        char topic[BRIDGE_TOPIC_MAX], name[SL_NAME_SIZE] = "";
        const char *base;
        uint8_t mode = take(&in), tlen = take(&in);
        enum bridge_set_via via = (enum bridge_set_via)((mode & VIA_MASK) % VIA_COUNT);
        struct bridge_counters c0;
        size_t n = 0;
        int r, split;

        if (!fx.ready)
                init();
        base = bridge_base(fx.b);
        if (mode & UNDER_SET)
                n = (size_t)snprintf(topic, sizeof(topic), "%s/" BRIDGE_TOPIC_SET "/", base);
        while (tlen-- > 0 && in.n > 0 && n + 1 < sizeof(topic)) {
                uint8_t ch = take(&in);

                if (ch == 0)
                        break;
                topic[n++] = (char)ch;
        }
        topic[n] = '\0';

        split = bridge_format_set_topic(base, topic, name);
        CHECK(split == 1 || split == 0 || split == -EINVAL);
        if (split == 1)
                CHECK(strlen(name) < SL_NAME_SIZE && bridge_format_name_ok(name));

        read_all(before);
        c0 = *bridge_counters(fx.b);
        fx.n = 0;
        r = bridge_set(fx.b, &sink, topic, in.p, in.n, via);
        read_all(after);

        CHECK(r == 1 || r == 0 || r == -EPERM || r == -EINVAL);
        CHECK(fx.n <= 1);
        for (unsigned i = 0; i < fx.n; i++)
                check_reply(&fx.msg[i], base);
        if (r == 0) {
                CHECK(fx.n == 0);
                CHECK(bridge_counters(fx.b)->set_written == c0.set_written);
                CHECK(bridge_counters(fx.b)->set_refused == c0.set_refused);
        } else if (r == 1) {
                int id = sl_find(fx.c, name);

                CHECK(via == BRIDGE_SET_LIVE && split == 1 && fx.n == 0);
                CHECK(bridge_format_check_value(in.p, in.n) == BRIDGE_REFUSE_NONE);
                CHECK(id >= 0 && strlen(after[id]) == in.n &&
                      memcmp(after[id], in.p, in.n) == 0);
                CHECK(bridge_counters(fx.b)->set_written == c0.set_written + 1);
        } else {
                CHECK(bridge_counters(fx.b)->set_refused == c0.set_refused + 1);
                /* A name to answer on gets its reply; a bad topic has none. */
                CHECK(fx.n == (split == 1 ? 1u : 0u));
        }
        if (r != 1)
                CHECK(memcmp(before, after, sizeof(before)) == 0);
        return 0;
}
