/*
 * link_sharedlink_session: the pure SharedLink session on a clock the test sets, so every
 * schedule (period, refresh under compression, on-change min interval and retry, stale after
 * silence, query timeouts) is checked at its exact millisecond boundary. The engine test
 * (test_link_sharedlink.c) checks the same behaviour through the real channel and table.
 *
 * The hooks are a small fake table and a record of what the session did: the frames it sent
 * (as text, checksum cut off), the values it published, stale marks, events, counters, answers.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "daemon/config.h"
#include "daemon/link_sharedlink_session.h"
#include "proto/sharedlink.h"

#define T0              100000u         /* the clock starts here (ms) */
#define SENT_MAX        64
#define TEXT_MAX        256
#define VARS_MAX        (LINK_SHAREDLINK_ADHOC_MAX + 16)
#define EVENTS_MAX      16

struct fvar {
        char name[SHM_NAME_SIZE];
        char value[SHM_VALUE_SIZE];
        bool valid, stale;
        char peer;                      /* ad hoc: its peer */
        unsigned type;                  /* added at run time: its shm type, direction, place */
        bool outbound;
        int32_t position;
        bool retired;                   /* retire()d: its name is gone */
};

struct answer {
        int err;
        char text[TEXT_MAX];
        unsigned calls;
        bool alive;
};

struct record {
        char sent[SENT_MAX][TEXT_MAX];  /* "[:AB|N0|D1" (no checksum, no ']') */
        char raw[SENT_MAX][TEXT_MAX];   /* the same, every byte ("[:AB|N0|D1|C0B]\r\n") */
        int local_result;               /* local_address(): 0 gives LOCAL_ADDR, else this */
        unsigned n_sent;
        int send_result;                /* 0, or an error to inject */
        struct fvar vars[VARS_MAX];
        unsigned n_vars;
        unsigned add_room;              /* how many more the fake table takes */
        unsigned batches, stale_marks;
        bool in_batch;
        char events[EVENTS_MAX][TEXT_MAX];
        unsigned n_events;
        uint64_t counters[SHM_COUNTER_COUNT];
        char diags[EVENTS_MAX][LINK_SHAREDLINK_DIAG_MAX];       /* what diag() was given */
        unsigned n_diags;
};

static struct record rec;

static void h_diag(void *arg, enum log_prio prio, const char *text)
{
        (void)arg;
        (void)prio;
        if (rec.n_diags < EVENTS_MAX)
                snprintf(rec.diags[rec.n_diags], LINK_SHAREDLINK_DIAG_MAX, "%s", text);
        rec.n_diags++;
}

static int h_send(void *arg, const char *buf, size_t len)
{
        const char *c;

        (void)arg;
        if (rec.send_result < 0)
                return rec.send_result;
        assert_true(rec.n_sent < SENT_MAX);
        assert_true(len < TEXT_MAX);
        memcpy(rec.sent[rec.n_sent], buf, len);
        rec.sent[rec.n_sent][len] = '\0';
        memcpy(rec.raw[rec.n_sent], buf, len);
        rec.raw[rec.n_sent][len] = '\0';
        c = strstr(rec.sent[rec.n_sent], "|C");
        assert_non_null(c);
        rec.sent[rec.n_sent][c - rec.sent[rec.n_sent]] = '\0';
        rec.n_sent++;
        return 0;
}

static int h_find(void *arg, const char *name)
{
        (void)arg;
        for (unsigned i = 0; i < rec.n_vars; i++)
                if (!rec.vars[i].retired && strcmp(rec.vars[i].name, name) == 0)
                        return (int)i;
        return -ENOENT;
}

static int h_add(void *arg, const char *name, unsigned type, char peer, bool outbound,
                 int32_t position)
{
        (void)arg;
        if (rec.add_room == 0 || rec.n_vars == VARS_MAX)
                return -ENOSPC;
        rec.add_room--;
        snprintf(rec.vars[rec.n_vars].name, SHM_NAME_SIZE, "%s", name);
        rec.vars[rec.n_vars].peer = peer;
        rec.vars[rec.n_vars].type = type;
        rec.vars[rec.n_vars].outbound = outbound;
        rec.vars[rec.n_vars].position = position;
        return (int)rec.n_vars++;
}

static int h_retire(void *arg, uint32_t id)
{
        (void)arg;
        assert_true(id < rec.n_vars);
        assert_false(rec.vars[id].retired);
        rec.vars[id].retired = true;
        return 0;
}

static int h_get(void *arg, uint32_t id, char *buf, size_t size)
{
        (void)arg;
        assert_true(id < rec.n_vars);
        if (!rec.vars[id].valid)
                return -ENODATA;
        return snprintf(buf, size, "%s", rec.vars[id].value);
}

static int h_publish(void *arg, uint32_t id, const char *value, size_t len)
{
        (void)arg;
        assert_true(rec.in_batch);
        assert_true(id < rec.n_vars);
        if (len > SHM_VALUE_MAX)
                return -EINVAL;
        memcpy(rec.vars[id].value, value, len);
        rec.vars[id].value[len] = '\0';
        rec.vars[id].valid = true;
        rec.vars[id].stale = false;
        return 0;
}

static void h_stale(void *arg, uint32_t id)
{
        (void)arg;
        assert_true(rec.in_batch);
        assert_true(id < rec.n_vars);
        rec.vars[id].stale = true;
        rec.stale_marks++;
}

static void h_batch(void *arg, bool begin)
{
        (void)arg;
        assert_int_not_equal(rec.in_batch, begin);
        rec.in_batch = begin;
        rec.batches += begin;
}

static void h_event(void *arg, enum shm_event_type type, const char *text)
{
        (void)arg;
        /* The first EVENTS_MAX are kept, all are counted. */
        if (rec.n_events < EVENTS_MAX)
                snprintf(rec.events[rec.n_events], TEXT_MAX, "%s %s",
                         shm_layout_event_name(type), text);
        rec.n_events++;
}

static void h_count(void *arg, enum shm_counter c, uint64_t n)
{
        (void)arg;
        rec.counters[c] += n;
}

static void h_answer(void *arg, void *token, int err, const char *text)
{
        struct answer *a = token;

        (void)arg;
        a->err = err;
        snprintf(a->text, sizeof(a->text), "%s", text);
        a->calls++;
}

static bool h_alive(void *arg, void *token)
{
        const struct answer *a = token;

        (void)arg;
        return a->alive;
}

#define LOCAL_ADDR      "127.0.0.1:47002"       /* docs/pronto4.md §10 */
#define REMOTE_PORT     4000u

static int h_local_address(void *arg, char *buf, size_t size, unsigned *ret_remote_port)
{
        (void)arg;
        if (rec.local_result < 0)
                return rec.local_result;
        *ret_remote_port = REMOTE_PORT;
        return snprintf(buf, size, "%s", LOCAL_ADDR);
}

static const struct link_sharedlink_hooks hooks = {
        .send = h_send, .find = h_find, .add = h_add, .retire = h_retire, .get = h_get,
        .publish = h_publish,
        .stale = h_stale, .batch = h_batch, .event = h_event, .count = h_count,
        .answer = h_answer, .alive = h_alive, .local_address = h_local_address,
        .diag = h_diag,
};

/* ---- fixture: link "veh", we are B, peer A (2 out, 2 in), peer C (1 in) -------------------- */

static struct config_link cfg;
static struct config_var a_out[2], a_in[2], c_in[1];

static void var_add(struct config_var *v, const char *name)
{
        snprintf(v->name, sizeof(v->name), "%s", name);
        snprintf(rec.vars[rec.n_vars++].name, SHM_NAME_SIZE, "%s", name);
}

static int setup(void **state)
{
        struct config_peer *a = &cfg.sl.peers[0], *c = &cfg.sl.peers[1];

        (void)state;
        memset(&rec, 0, sizeof(rec));
        memset(&cfg, 0, sizeof(cfg));
        rec.add_room = VARS_MAX;
        snprintf(cfg.name, sizeof(cfg.name), "veh");
        cfg.protocol = CONFIG_PROTOCOL_SHAREDLINK;
        cfg.transport = CONFIG_TRANSPORT_UDP;
        cfg.sl.address = 'B';
        cfg.sl.n_peers = 2;
        *a = (struct config_peer){
                .address = 'A', .max_frame = SLP_FRAME_DEFAULT,
                .outbound = a_out, .n_outbound = 2, .inbound = a_in, .n_inbound = 2,
        };
        *c = (struct config_peer){
                .address = 'C', .max_frame = SLP_FRAME_DEFAULT, .inbound = c_in, .n_inbound = 1,
        };
        var_add(&a_out[0], "Speed");            /* id 0 */
        var_add(&a_out[1], "Gear");             /* id 1 */
        var_add(&a_in[0], "Rpm");               /* id 2 */
        var_add(&a_in[1], "Temp");              /* id 3 */
        var_add(&c_in[0], "Fuel");              /* id 4 */
        return 0;
}

static struct link_sharedlink_session *start(uint64_t now)
{
        struct link_sharedlink_session *s;

        assert_int_equal(link_sharedlink_session_new(&cfg, true, &hooks, NULL, &s), 0);
        link_sharedlink_session_up(s, now);
        return s;
}

/* Encodes ":<dst><src>|F..|F.." (e.g. ":BA|N0|D1", A to us) with its checksum, feeds it. */
static void feed(struct link_sharedlink_session *s, uint64_t now, const char *text)
{
        struct slp_field fields[32];
        char copy[TEXT_MAX], frame[SLP_FRAME_MAX];
        size_t n = 0;
        char *save = NULL, *f;
        int len;

        assert_true(strlen(text) < sizeof(copy) && text[0] == ':');
        snprintf(copy, sizeof(copy), "%s", text + 4);
        for (f = strtok_r(copy, "|", &save); f; f = strtok_r(NULL, "|", &save)) {
                assert_true(n < 32);
                fields[n++] = (struct slp_field){ .letter = f[0], .value = f + 1,
                                                  .len = (uint16_t)strlen(f + 1) };
        }
        len = slp_frame_encode(frame, sizeof(frame), text[1], text[2], fields, n, 0);
        assert_true(len > 0);
        link_sharedlink_session_input(s, now, (const uint8_t *)frame, (size_t)len);
}

static void expect_sent(unsigned from, const char *const *frames, unsigned n)
{
        assert_int_equal(rec.n_sent - from, n);
        for (unsigned i = 0; i < n; i++)
                assert_string_equal(rec.sent[from + i], frames[i]);
}

#define EXPECT_SENT(from, ...)                                                                 \
        do {                                                                                   \
                static const char *const want_[] = { __VA_ARGS__ };                            \
                expect_sent(from, want_, sizeof(want_) / sizeof(want_[0]));                    \
        } while (0)

/* ---- sending --------------------------------------------------------------------------------- */

/* Up: the full list at once; then one list per period, on the period's grid, one per late tick. */
static void test_periods(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        cfg.sl.peers[0].period_ms = 100;
        s = start(T0);
        EXPECT_SENT(0, "[:AB|N0|D|D");
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 100);
        link_sharedlink_session_tick(s, T0 + 99);
        assert_int_equal(rec.n_sent, 1);
        link_sharedlink_session_outbound(s, T0 + 99, 0, "42");
        link_sharedlink_session_tick(s, T0 + 100);
        EXPECT_SENT(1, "[:AB|N0|D42|D");
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 200);
        /* Three periods late: one list, and the grid starts again from now. */
        link_sharedlink_session_tick(s, T0 + 450);
        EXPECT_SENT(2, "[:AB|N0|D42|D");
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 550);
        /* Exactly one period late: the next one is a whole period away, never now. */
        link_sharedlink_session_tick(s, T0 + 650);
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 750);
        assert_int_equal(rec.counters[SHM_COUNTER_FRAMES_OUT], 4);

        /* Down: no deadline, nothing sent; up again: the full list at once. */
        link_sharedlink_session_down(s, T0 + 660);
        assert_int_equal(link_sharedlink_session_deadline(s), LINK_SHAREDLINK_NEVER);
        link_sharedlink_session_outbound(s, T0 + 670, 1, "3");
        assert_int_equal(rec.n_sent, 4);
        link_sharedlink_session_up(s, T0 + 680);
        EXPECT_SENT(4, "[:AB|N0|D42|D3");
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 780);
        link_sharedlink_session_free(s);
}

/* Compression: written positions only, full every refresh_ms / period_ms periods. */
static void test_refresh_compression(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        cfg.sl.peers[0].period_ms = 100;
        cfg.sl.peers[0].refresh_ms = 300;
        cfg.sl.peers[0].compression = true;
        s = start(T0);
        EXPECT_SENT(0, "[:AB|N0|D|D");
        link_sharedlink_session_outbound(s, T0 + 10, 1, "7");
        link_sharedlink_session_tick(s, T0 + 100);          /* period 1: the write */
        link_sharedlink_session_tick(s, T0 + 200);          /* period 2: nothing new */
        link_sharedlink_session_outbound(s, T0 + 250, 0, "9");
        link_sharedlink_session_tick(s, T0 + 300);          /* period 3: full */
        link_sharedlink_session_tick(s, T0 + 400);
        EXPECT_SENT(1, "[:AB|N0|D|D7", "[:AB|N0|D|D", "[:AB|N0|D9|D7", "[:AB|N0|D|D");
        link_sharedlink_session_free(s);
}

/* on_change: at once, then at most one frame per min_interval_ms with the last values; a
 * refused frame is retried, never dropped. */
static void test_on_change(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        cfg.sl.peers[0].on_change = true;
        cfg.sl.peers[0].min_interval_ms = 50;
        s = start(T0);
        assert_int_equal(link_sharedlink_session_deadline(s), LINK_SHAREDLINK_NEVER);
        link_sharedlink_session_outbound(s, T0 + 10, 1, "1");
        EXPECT_SENT(1, "[:AB|N1|D1");
        link_sharedlink_session_outbound(s, T0 + 20, 0, "a");
        link_sharedlink_session_outbound(s, T0 + 30, 0, "b");
        assert_int_equal(rec.n_sent, 2);
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 60);
        link_sharedlink_session_tick(s, T0 + 59);
        assert_int_equal(rec.n_sent, 2);
        link_sharedlink_session_tick(s, T0 + 60);
        EXPECT_SENT(2, "[:AB|N0|Db");
        assert_int_equal(link_sharedlink_session_deadline(s), LINK_SHAREDLINK_NEVER);

        /* Past the interval: at once again. The queue is full: retried at the interval. */
        rec.send_result = -ENOBUFS;
        link_sharedlink_session_outbound(s, T0 + 200, 1, "2");
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 250);
        rec.send_result = 0;
        link_sharedlink_session_tick(s, T0 + 250);
        EXPECT_SENT(3, "[:AB|N1|D2");

        /* The shortest retry is LINK_SHAREDLINK_RETRY_MS, whatever min_interval_ms. */
        cfg.sl.peers[0].min_interval_ms = 0;
        rec.send_result = -EAGAIN;
        link_sharedlink_session_outbound(s, T0 + 400, 0, "c");
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 400 + LINK_SHAREDLINK_RETRY_MS);
        rec.send_result = 0;
        link_sharedlink_session_tick(s, T0 + 400 + LINK_SHAREDLINK_RETRY_MS);
        EXPECT_SENT(4, "[:AB|N0|Dc");
        link_sharedlink_session_free(s);
}

/* ---- receiving ------------------------------------------------------------------------------- */

/* Positions: N sets the start, D beyond the list is counted, empty D changes nothing. */
static void test_positions(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        s = start(T0);
        feed(s, T0, ":BA|D10|D20");
        assert_string_equal(rec.vars[2].value, "10");
        assert_string_equal(rec.vars[3].value, "20");
        feed(s, T0, ":BA|N1|D21|D99|D98");
        assert_string_equal(rec.vars[3].value, "21");
        assert_int_equal(rec.counters[SHM_COUNTER_LIST_MISMATCH], 2);
        feed(s, T0, ":BA|N0|D|D22");
        assert_string_equal(rec.vars[2].value, "10");
        assert_string_equal(rec.vars[3].value, "22");
        feed(s, T0, ":BA|N4000000000|D5");
        assert_int_equal(rec.counters[SHM_COUNTER_LIST_MISMATCH], 3);
        /* Peer C's own list; a frame for someone else or from a stranger changes nothing. */
        feed(s, T0, ":BC|D7");
        assert_string_equal(rec.vars[4].value, "7");
        feed(s, T0, ":AC|D8");
        feed(s, T0, ":BD|D8");
        assert_string_equal(rec.vars[4].value, "7");
        assert_int_equal(rec.counters[SHM_COUNTER_NOT_FOR_US], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_UNKNOWN_PEER], 1);
        /* Pronto4 fields are skipped and counted, with what belongs to them. */
        feed(s, T0, ":BA|N?|D1|T4|QName|D2|L0|D3|E1|D4|X");
        assert_string_equal(rec.vars[2].value, "10");
        assert_int_equal(rec.counters[SHM_COUNTER_UNKNOWN_FIELD], 8);
        assert_int_equal(rec.counters[SHM_COUNTER_FRAMES_IN], 8);
        assert_int_equal(rec.batches, 6);       /* one per frame applied */
        link_sharedlink_session_free(s);
}

/* Stale after stale_ms of silence, the deadline moving with each frame; ad hoc ones too. */
static void test_stale(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        cfg.sl.peers[0].stale_ms = 200;
        s = start(T0);
        assert_int_equal(link_sharedlink_session_deadline(s), LINK_SHAREDLINK_NEVER);
        feed(s, T0, ":BA|D1|D2|RExtra|Dx");
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 200);
        feed(s, T0 + 150, ":BA|N0|D3");
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 350);
        link_sharedlink_session_tick(s, T0 + 349);
        assert_int_equal(rec.stale_marks, 0);
        link_sharedlink_session_tick(s, T0 + 350);
        assert_true(rec.vars[2].stale && rec.vars[3].stale && rec.vars[5].stale);
        assert_false(rec.vars[4].stale);        /* peer C's */
        assert_int_equal(rec.stale_marks, 3);
        assert_int_equal(link_sharedlink_session_deadline(s), LINK_SHAREDLINK_NEVER);
        /* Down: no stale watch (the engine marks the whole link). */
        feed(s, T0 + 400, ":BA|D4");
        link_sharedlink_session_down(s, T0 + 410);
        assert_int_equal(link_sharedlink_session_deadline(s), LINK_SHAREDLINK_NEVER);
        link_sharedlink_session_free(s);
}

/* Q answered from the table (empty for unknown or never written), P ponged, all in one frame
 * while max_frame allows, more frames after. */
static void test_replies(void **state)
{
        struct answer a = { .alive = true };
        char name[SHM_NAME_SIZE];
        struct link_sharedlink_session *s;

        (void)state;
        cfg.sl.peers[0].max_frame = 40;
        s = start(T0);
        link_sharedlink_session_outbound(s, T0, 0, "55");
        snprintf(rec.vars[0].value, SHM_VALUE_SIZE, "55");
        rec.vars[0].valid = true;
        feed(s, T0, ":BA|QSpeed|QGear|P7");
        feed(s, T0, ":BA|QNone|QSpeed|QSpeed|QGear");
        EXPECT_SENT(1, "[:AB|RSpeed|D55|RGear|D|G7", "[:AB|RNone|D|RSpeed|D55|RSpeed|D55",
                    "[:AB|RGear|D");
        assert_int_equal(rec.counters[SHM_COUNTER_QUERIES_IN], 6);
        assert_int_equal(rec.counters[SHM_COUNTER_ANSWERS_OUT], 6);

        /* A query of ours must fit the peer's max_frame too: 40 takes a 29-byte name
         * ("[:AB|Q" + name + "|Chh]", a datagram), not a 30-byte one. */
        memset(name, 'n', 30);
        name[30] = '\0';
        assert_int_equal(link_sharedlink_session_query(s, T0, &a, 0, name, 100), -EMSGSIZE);
        assert_int_equal(rec.counters[SHM_COUNTER_QUERIES_OUT], 0);
        name[29] = '\0';
        assert_int_equal(link_sharedlink_session_query(s, T0, &a, 0, name, 100), 0);
        assert_int_equal(rec.counters[SHM_COUNTER_QUERIES_OUT], 1);
        link_sharedlink_session_free(s);
        assert_int_equal(a.err, ECANCELED);
}

/* R|D: to this peer's configured variable of that name, else its ad hoc variable, created
 * once; never over another variable; bounded by the table and LINK_SHAREDLINK_ADHOC_MAX. */
static void test_adhoc(void **state)
{
        struct link_sharedlink_session *s;
        char frame[64];

        (void)state;
        s = start(T0);
        feed(s, T0, ":BA|RTemp|D30|RFoo|D1|RFoo|D2|RFuel|D3|Rveh.A.Foo|D4");
        assert_string_equal(rec.vars[3].value, "30");
        assert_string_equal(rec.vars[5].name, "veh.A.Foo");
        assert_string_equal(rec.vars[5].value, "2");
        assert_string_equal(rec.vars[6].name, "veh.A.Fuel");   /* Fuel is peer C's */
        assert_false(rec.vars[4].valid);
        assert_string_equal(rec.vars[7].name, "veh.A.veh.A.Foo");
        assert_int_equal(rec.vars[5].type, SHM_TYPE_STRING);
        assert_false(rec.vars[5].outbound);
        assert_int_equal(rec.vars[5].position, SHM_POSITION_NONE);
        assert_int_equal(rec.n_events, 3);
        assert_string_equal(rec.events[0], "adhoc-variable name=veh.A.Foo peer=A");
        /* A name taken by a configured variable: dropped and counted. */
        var_add(&(struct config_var){ 0 }, "veh.C.Bar");
        feed(s, T0, ":BC|RBar|D5");
        assert_int_equal(rec.counters[SHM_COUNTER_ADHOC_FULL], 1);
        /* Empty answer: unknown name at the peer, nothing stored. A bad name: bad_value. */
        feed(s, T0, ":BC|RNew|D|Rx y|D1");
        assert_int_equal(h_find(NULL, "veh.C.New"), -ENOENT);
        assert_int_equal(rec.counters[SHM_COUNTER_BAD_VALUE], 1);
        /* The table is full. */
        rec.add_room = 0;
        feed(s, T0, ":BC|RFull|D1");
        assert_int_equal(rec.counters[SHM_COUNTER_ADHOC_FULL], 2);
        /* The link's own bound. */
        rec.add_room = VARS_MAX;
        for (unsigned i = 3; i < LINK_SHAREDLINK_ADHOC_MAX; i++) {
                snprintf(frame, sizeof(frame), ":BC|RV%u|D1", i);
                feed(s, T0, frame);
        }
        assert_int_equal(rec.counters[SHM_COUNTER_ADHOC_FULL], 2);
        feed(s, T0, ":BC|ROneTooMany|D1");
        assert_int_equal(rec.counters[SHM_COUNTER_ADHOC_FULL], 3);
        assert_int_equal(h_find(NULL, "veh.C.OneTooMany"), -ENOENT);
        link_sharedlink_session_free(s);
}

/* ---- queries --------------------------------------------------------------------------------- */

static void test_queries(void **state)
{
        struct answer a[LINK_SHAREDLINK_QUERIES_MAX + 2];
        struct link_sharedlink_session *s;
        char name[16];
        int pa;

        (void)state;
        memset(a, 0, sizeof(a));
        for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX + 2; i++)
                a[i].alive = true;
        assert_int_equal(link_sharedlink_session_new(&cfg, true, &hooks, NULL, &s), 0);
        pa = link_sharedlink_session_peer(s, "A");
        assert_int_equal(pa, 0);
        assert_int_equal(link_sharedlink_session_peer(s, "C"), 1);
        assert_int_equal(link_sharedlink_session_peer(s, "D"), -1);
        assert_int_equal(link_sharedlink_session_peer(s, "AB"), -1);
        assert_int_equal(link_sharedlink_session_query(s, T0, &a[0], pa, "X", 100), -ENOTCONN);
        link_sharedlink_session_up(s, T0);

        /* Answered; the answer is also stored and an event. */
        assert_int_equal(link_sharedlink_session_query(s, T0, &a[0], pa, "X", 100), 0);
        EXPECT_SENT(1, "[:AB|QX");
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 100);
        feed(s, T0 + 5, ":BC|RX|D0");                  /* another peer's X */
        assert_int_equal(a[0].calls, 0);
        feed(s, T0 + 10, ":BA|RX|Dhello world");
        assert_int_equal(a[0].calls, 1);
        assert_int_equal(a[0].err, 0);
        assert_string_equal(a[0].text, "hello world");
        assert_int_equal(rec.n_events, 3);
        assert_string_equal(rec.events[0], "adhoc-variable name=veh.C.X peer=C");
        assert_string_equal(rec.events[1], "query-answer peer=A name=X value=hello world");
        assert_string_equal(rec.events[2], "adhoc-variable name=veh.A.X peer=A");

        /* Timeout at the exact millisecond. */
        assert_int_equal(link_sharedlink_session_query(s, T0 + 20, &a[1], pa, "Slow", 100), 0);
        link_sharedlink_session_tick(s, T0 + 119);
        assert_int_equal(a[1].calls, 0);
        link_sharedlink_session_tick(s, T0 + 120);
        assert_int_equal(a[1].calls, 1);
        assert_int_equal(a[1].err, ETIMEDOUT);
        assert_string_equal(a[1].text, "no answer from peer A within 100 ms");
        assert_int_equal(rec.counters[SHM_COUNTER_TIMEOUTS], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_QUERIES_OUT], 2);

        /* Bad input refused with nothing pending. */
        assert_int_equal(link_sharedlink_session_query(s, T0, &a[2], 2, "X", 100), -EINVAL);
        assert_int_equal(link_sharedlink_session_query(s, T0, &a[2], -1, "X", 100), -EINVAL);
        assert_int_equal(link_sharedlink_session_query(s, T0, &a[2], pa, "x|y", 100), -EINVAL);
        rec.send_result = -ENOBUFS;
        assert_int_equal(link_sharedlink_session_query(s, T0, &a[2], pa, "X", 100), -ENOBUFS);
        rec.send_result = 0;

        /* Bounded; a client that left makes room. */
        for (unsigned i = 0; i < LINK_SHAREDLINK_QUERIES_MAX; i++) {
                snprintf(name, sizeof(name), "B%u", i);
                assert_int_equal(link_sharedlink_session_query(s, T0 + 200, &a[2 + i], pa, name,
                                                               1000), 0);
        }
        assert_int_equal(link_sharedlink_session_query(s, T0 + 200, &a[0], pa, "One", 1000),
                         -EBUSY);
        a[5].alive = false;
        assert_int_equal(link_sharedlink_session_query(s, T0 + 200, &a[0], pa, "One", 1000), 0);
        assert_int_equal(a[5].calls, 1);
        assert_int_equal(a[5].err, ECANCELED);

        /* Down ends what was sent; free() ends the rest. */
        link_sharedlink_session_down(s, T0 + 300);
        for (unsigned i = 2; i < LINK_SHAREDLINK_QUERIES_MAX + 2; i++) {
                assert_int_equal(a[i].calls, 1);
                if (i != 5)
                        assert_int_equal(a[i].err, ENOTCONN);
        }
        assert_int_equal(a[0].calls, 2);
        link_sharedlink_session_up(s, T0 + 400);
        assert_int_equal(link_sharedlink_session_query(s, T0 + 400, &a[1], pa, "Y", 1000), 0);
        link_sharedlink_session_free(s);
        assert_int_equal(a[1].calls, 2);
        assert_int_equal(a[1].err, ECANCELED);
}

/* Garbage is counted by reason and never applied; a datagram's partial frame is dropped. */
static void test_rejects(void **state)
{
        static const char junk[] = "xyz[:AB|D1|C00][:AB|D1";
        struct link_sharedlink_session *s;

        (void)state;
        s = start(T0);
        link_sharedlink_session_input(s, T0, (const uint8_t *)junk, strlen(junk));
        assert_int_equal(rec.counters[SHM_COUNTER_NOISE_BYTES], 3);
        assert_int_equal(rec.counters[SHM_COUNTER_BAD_CHECKSUM], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_RESYNC], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_FRAMES_IN], 0);
        assert_false(rec.vars[2].valid);
        /* Down: input is ignored (the channel delivers none then). */
        link_sharedlink_session_down(s, T0);
        feed(s, T0, ":BA|D1");
        assert_false(rec.vars[2].valid);
        link_sharedlink_session_free(s);
}

/* A configured variable the table does not know: new() fails. */
static void test_unknown_variable(void **state)
{
        struct link_sharedlink_session *s = NULL;

        (void)state;
        snprintf(rec.vars[4].name, SHM_NAME_SIZE, "Other");
        assert_int_equal(link_sharedlink_session_new(&cfg, true, &hooks, NULL, &s), -ENOENT);
        assert_null(s);
        cfg.protocol = CONFIG_PROTOCOL_CIRCE;
        assert_int_equal(link_sharedlink_session_new(&cfg, true, &hooks, NULL, &s), -EINVAL);
        assert_null(link_sharedlink_session_free(NULL));
}

/* ---- Pronto4 (docs/pronto4.md) --------------------------------------------------------------- */

static struct config_var p4_out[10], p4_in[4];

/* Feeds one literal frame, every byte as a Pronto4 sends it (checksum, line end included). */
static void feed_raw(struct link_sharedlink_session *s, uint64_t now, const char *bytes)
{
        link_sharedlink_session_input(s, now, (const uint8_t *)bytes, strlen(bytes));
}

static void expect_raw(unsigned from, const char *const *frames, unsigned n)
{
        assert_int_equal(rec.n_sent - from, n);
        for (unsigned i = 0; i < n; i++)
                assert_string_equal(rec.raw[from + i], frames[i]);
}

#define EXPECT_RAW(from, ...)                                                                  \
        do {                                                                                   \
                static const char *const want_[] = { __VA_ARGS__ };                            \
                expect_raw(from, want_, sizeof(want_) / sizeof(want_[0]));                     \
        } while (0)

static void typed_add(struct config_var *v, const char *name, enum config_var_type type)
{
        var_add(v, name);
        v->type = type;
}

/* The vehicle side of docs/pronto4.md §10: link "veh", we are B, peer A learns both lists. */
static int setup_vehicle(void **state)
{
        struct config_peer *a = &cfg.sl.peers[0];

        setup(state);
        rec.n_vars = 0;
        cfg.sl.n_peers = 1;
        cfg.sl.crlf = true;
        *a = (struct config_peer){
                .address = 'A', .max_frame = SLP_FRAME_DEFAULT, .period_ms = 100,
                .dialect = CONFIG_DIALECT_PRONTO4, .outbound_learn = true, .inbound_learn = true,
                .learn_max = 8,
        };
        return 0;
}

/* The host side of §10: we are A, peer B (the vehicle) gets our declarations. */
static int setup_host(void **state)
{
        struct config_peer *b = &cfg.sl.peers[0];

        setup(state);
        rec.n_vars = 0;
        cfg.sl.address = 'A';
        cfg.sl.n_peers = 1;
        cfg.sl.crlf = true;
        *b = (struct config_peer){
                .address = 'B', .max_frame = SLP_FRAME_DEFAULT, .period_ms = 100,
                .stale_ms = 300, .dialect = CONFIG_DIALECT_PRONTO4, .declare = true,
                .outbound = p4_out, .n_outbound = 2, .inbound = p4_in, .n_inbound = 2,
        };
        typed_add(&p4_out[0], "veh_start", CONFIG_VAR_LONG);            /* id 0 */
        typed_add(&p4_out[1], "joy_steer", CONFIG_VAR_DOUBLE);          /* id 1 */
        typed_add(&p4_in[0], "AutoGpsLat", CONFIG_VAR_DOUBLE);          /* id 2 */
        typed_add(&p4_in[1], "VehicleName", CONFIG_VAR_STRING);         /* id 3 */
        return 0;
}

/* The vehicle: data before any declaration is counted, not applied; the host's declarations
 * are learned into typed variables; N0 acknowledged, L0 starts the whole list every period;
 * L?, N?, P0, data, E and MU answered or raised exactly as the public clients expect. */
static void test_p4_vehicle(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        s = start(T0);
        assert_int_equal(rec.n_sent, 0);
        assert_int_equal(link_sharedlink_session_deadline(s), LINK_SHAREDLINK_NEVER);
        feed_raw(s, T0, "[:BA|N0|D1|D0|C57]\r\n");
        assert_int_equal(rec.counters[SHM_COUNTER_UNDECLARED_DATA], 1);
        assert_int_equal(rec.n_vars, 0);
        feed_raw(s, T0, "[:BA|ELink|D0, SetIP, 127.0.0.1:47002, 4000|C14]\r\n");
        feed_raw(s, T0, "[:BA|ELink|D0, outbound, on|CA0]\r\n");
        feed_raw(s, T0, "[:BA|ELink|D0, inbound, on|C1F]\r\n");
        assert_int_equal(rec.counters[SHM_COUNTER_COMMANDS_IN], 3);
        assert_string_equal(rec.events[0],
                            "command module=Link text=\"0, SetIP, 127.0.0.1:47002, 4000\"");

        /* N0: what the host sends, learned (long, double), acknowledged with empty values. */
        feed_raw(s, T0, "[:BA|N0|T0|Qveh_start|T2|Qjoy_steer|CB6]\r\n");
        assert_int_equal(rec.counters[SHM_COUNTER_DECLARATIONS_IN], 1);
        assert_int_equal(rec.n_vars, 2);
        assert_string_equal(rec.vars[0].name, "veh.A.veh_start");
        assert_int_equal(rec.vars[0].type, SHM_TYPE_LONG);
        assert_false(rec.vars[0].outbound);
        assert_int_equal(rec.vars[0].position, 0);
        assert_string_equal(rec.vars[1].name, "veh.A.joy_steer");
        assert_int_equal(rec.vars[1].type, SHM_TYPE_DOUBLE);
        assert_int_equal(rec.vars[1].position, 1);
        EXPECT_RAW(0, "[:AB|N0|Rveh_start|D|Rjoy_steer|D|C36]\r\n");

        /* L0: what the host wants, learned as outbound variables; the whole list at once. */
        feed_raw(s, T0, "[:BA|L0|T2|QAutoGpsLat|T4|QVehicleName|C39]\r\n");
        assert_int_equal(rec.counters[SHM_COUNTER_DECLARATIONS_IN], 2);
        assert_int_equal(rec.n_vars, 4);
        assert_string_equal(rec.vars[2].name, "veh.A.AutoGpsLat");
        assert_true(rec.vars[2].outbound);
        assert_int_equal(rec.vars[2].type, SHM_TYPE_DOUBLE);
        assert_string_equal(rec.vars[3].name, "veh.A.VehicleName");
        assert_int_equal(rec.vars[3].type, SHM_TYPE_STRING);
        EXPECT_RAW(1, "[:AB|N0|D|D|CF6]\r\n");
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 100);
        link_sharedlink_session_outbound(s, T0 + 10, 2, "40.5");
        link_sharedlink_session_outbound(s, T0 + 10, 3, "0");
        link_sharedlink_session_tick(s, T0 + 100);
        EXPECT_RAW(2, "[:AB|N0|D40.5|D0|CED]\r\n");

        /* The list queries, each answered by its own typed frame; the ping. */
        feed_raw(s, T0 + 110, "[:BA|L?|C83]\r\n");
        EXPECT_RAW(3, "[:AB|N0|T2|QAutoGpsLat|T4|QVehicleName|C3B]\r\n");
        feed_raw(s, T0 + 110, "[:BA|N?|C85]\r\n");
        EXPECT_RAW(4, "[:AB|L0|T0|Qveh_start|T2|Qjoy_steer|CB4]\r\n");
        feed_raw(s, T0 + 110, "[:BA|P0|C78]\r\n");
        EXPECT_RAW(5, "[:AB|G0|C6F]\r\n");
        assert_int_equal(rec.counters[SHM_COUNTER_DECLARATIONS_OUT], 2);

        /* Data against the declaration: veh_start = 1. */
        feed_raw(s, T0 + 120, "[:BA|N0|D1|D0|C57]\r\n");
        assert_string_equal(rec.vars[0].value, "1");
        assert_string_equal(rec.vars[1].value, "0");
        assert_int_equal(rec.counters[SHM_COUNTER_UNDECLARED_DATA], 1);

        /* Commands, with the one-digit checksum of some senders; MU. */
        feed_raw(s, T0 + 130, "[:BA|EServoPod|D0,TELEOP START|C02]\r\n");
        feed_raw(s, T0 + 130, "[:BA|EServoPod|D0,TELEOP START|C2]");
        feed_raw(s, T0 + 130, "[:BA|MUI|CE3]\r\n");
        assert_int_equal(rec.counters[SHM_COUNTER_COMMANDS_IN], 6);
        assert_int_equal(rec.n_events, 10);     /* 3 E, 4 learned, 3 more */
        assert_string_equal(rec.events[7], "command module=ServoPod text=\"0,TELEOP START\"");
        assert_string_equal(rec.events[8], rec.events[7]);
        assert_string_equal(rec.events[9], "command module=MUI");
        assert_string_equal(rec.events[3], "adhoc-variable name=veh.A.veh_start peer=A "
                                           "learned=inbound");
        assert_string_equal(rec.events[5], "adhoc-variable name=veh.A.AutoGpsLat peer=A "
                                           "learned=outbound");
        assert_int_equal(rec.counters[SHM_COUNTER_UNKNOWN_FIELD], 0);
        assert_int_equal(rec.counters[SHM_COUNTER_BAD_FIELD], 0);
        assert_int_equal(rec.n_sent, 6);
        link_sharedlink_session_free(s);
}

/* The host: at up, SetIP, outbound on, inbound on, the typed N0 and L0 declarations, each its
 * own datagram, then the whole list; the vehicle's acknowledgement counted, never stored. */
static void test_p4_host_connect(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        s = start(T0);
        EXPECT_RAW(0, "[:BA|ELink|D0, SetIP, 127.0.0.1:47002, 4000|C14]\r\n",
                   "[:BA|ELink|D0, outbound, on|CA0]\r\n", "[:BA|ELink|D0, inbound, on|C1F]\r\n",
                   "[:BA|N0|T0|Qveh_start|T2|Qjoy_steer|CB6]\r\n",
                   "[:BA|L0|T2|QAutoGpsLat|T4|QVehicleName|C39]\r\n", "[:BA|N0|D|D|CF6]\r\n");
        assert_int_equal(rec.counters[SHM_COUNTER_COMMANDS_OUT], 3);
        assert_int_equal(rec.counters[SHM_COUNTER_DECLARATIONS_OUT], 2);
        feed_raw(s, T0 + 5, "[:AB|N0|Rveh_start|D0|Rjoy_steer|D0|C96]\r\n");
        assert_int_equal(rec.counters[SHM_COUNTER_ACKS_IN], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_REDECLARED], 0);
        assert_int_equal(rec.n_vars, 4);
        assert_false(rec.vars[0].valid);
        assert_int_equal(rec.n_events, 0);
        /* An acknowledgement of other names: counted. */
        feed(s, T0 + 5, ":AB|N0|Rveh_start|D0|Rother|D0");
        assert_int_equal(rec.counters[SHM_COUNTER_REDECLARED], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_ACKS_IN], 2);

        /* Data from the vehicle, a value of the wrong type refused, the rest applied. */
        feed_raw(s, T0 + 10, "[:AB|N0|D40.5|DVEH_1|C30]\r\n");
        assert_string_equal(rec.vars[2].value, "40.5");
        assert_string_equal(rec.vars[3].value, "VEH_1");
        feed_raw(s, T0 + 20, "[:AB|N0|Dabc|DVEH_2|C90]\r\n");
        assert_int_equal(rec.counters[SHM_COUNTER_TYPE_MISMATCH], 1);
        assert_string_equal(rec.vars[2].value, "40.5");
        assert_string_equal(rec.vars[3].value, "VEH_2");

        /* veh_start = 1: the whole list, every period. */
        link_sharedlink_session_outbound(s, T0 + 30, 0, "1");
        link_sharedlink_session_outbound(s, T0 + 30, 1, "0");
        link_sharedlink_session_tick(s, T0 + 100);
        EXPECT_RAW(6, "[:BA|N0|D1|D0|C57]\r\n");

        /* Silent for stale_ms: stale, the connect sequence every stale_ms until heard, and
         * again when the vehicle is heard after it went stale. */
        link_sharedlink_session_tick(s, T0 + 320);
        assert_true(rec.vars[2].stale);
        /* The late tick sent one list and restarted the period's grid at 320. */
        assert_int_equal(link_sharedlink_session_deadline(s), T0 + 420);
        link_sharedlink_session_tick(s, T0 + 400);
        link_sharedlink_session_tick(s, T0 + 500);
        link_sharedlink_session_tick(s, T0 + 600);
        assert_int_equal(rec.n_sent, 10);       /* lists at 320, 500, 600; no sequence yet */
        link_sharedlink_session_tick(s, T0 + 620);
        assert_int_equal(rec.n_sent, 16);       /* list at 600 + 5 frames of the sequence */
        assert_string_equal(rec.raw[11], "[:BA|ELink|D0, SetIP, 127.0.0.1:47002, 4000|C14]\r\n");
        feed_raw(s, T0 + 650, "[:AB|G0|C6F]\r\n");
        assert_int_equal(rec.n_sent, 21);
        assert_string_equal(rec.raw[16], "[:BA|ELink|D0, SetIP, 127.0.0.1:47002, 4000|C14]\r\n");
        assert_string_equal(rec.raw[20], "[:BA|L0|T2|QAutoGpsLat|T4|QVehicleName|C39]\r\n");
        assert_int_equal(rec.counters[SHM_COUNTER_DECLARATIONS_OUT], 6);
        /* Heard again: no more sequences; down: no deadline at all. */
        feed_raw(s, T0 + 660, "[:AB|G0|C6F]\r\n");
        assert_int_equal(rec.n_sent, 21);
        link_sharedlink_session_down(s, T0 + 670);
        assert_int_equal(link_sharedlink_session_deadline(s), LINK_SHAREDLINK_NEVER);

        /* Without a local address (not UDP), no SetIP. */
        rec.local_result = -ENOTSUP;
        link_sharedlink_session_up(s, T0 + 700);
        assert_int_equal(rec.n_sent, 26);
        assert_string_equal(rec.raw[21], "[:BA|ELink|D0, outbound, on|CA0]\r\n");
        link_sharedlink_session_free(s);
}

/* The C92 frame of issue 8, against the 10-entry host list of the public clients. */
static void test_p4_acknowledgement(void **state)
{
        static const char *const names[10] = {
                "video_mux1", "veh_start", "veh_enable", "veh_motion", "joy_steer", "veh_steer",
                "veh_brake", "veh_throttle", "veh_shift", "veh_clutch",
        };
        struct link_sharedlink_session *s;

        (void)state;
        rec.n_vars = 0;
        for (unsigned k = 0; k < 10; k++)
                typed_add(&p4_out[k], names[k], k == 4 ? CONFIG_VAR_DOUBLE : CONFIG_VAR_LONG);
        cfg.sl.peers[0].n_outbound = 10;
        cfg.sl.peers[0].n_inbound = 0;
        s = start(T0);
        assert_string_equal(rec.raw[3], "[:BA|N0|T0|Qvideo_mux1|T0|Qveh_start|T0|Qveh_enable|"
                            "T0|Qveh_motion|T2|Qjoy_steer|T0|Qveh_steer|T0|Qveh_brake|"
                            "T0|Qveh_throttle|T0|Qveh_shift|T0|Qveh_clutch|CC9]\r\n");
        assert_int_equal(rec.n_sent, 5);        /* no L0: an empty list is not declared */
        feed_raw(s, T0, "[:AB|N0|Rvideo_mux1|D0|Rveh_start|D0|Rveh_enable|D0|Rveh_motion|D0|"
                 "Rjoy_steer|D0|Rveh_steer|D0|Rveh_brake|D100|Rveh_throttle|D0|Rveh_shift|D0|"
                 "Rveh_clutch|D0|C92]");
        assert_int_equal(rec.counters[SHM_COUNTER_ACKS_IN], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_REDECLARED], 0);
        assert_int_equal(rec.counters[SHM_COUNTER_ANSWERS_IN], 0);
        assert_int_equal(rec.n_vars, 10);       /* no ad hoc variable */
        for (unsigned k = 0; k < 10; k++)
                assert_false(rec.vars[k].valid);
        /* N? from the vehicle: our (empty) inbound list, no answer; L?: our N list. */
        feed_raw(s, T0, "[:AB|N?|C85]");
        assert_int_equal(rec.n_sent, 5);
        feed_raw(s, T0, "[:AB|L?|C83]");
        assert_int_equal(rec.n_sent, 6);
        assert_string_equal(rec.raw[5], rec.raw[3]);
        link_sharedlink_session_free(s);
}

/* Self-describing frames (the beacon): by name, typed; a name we lack becomes ad hoc with the
 * declared type; a Q without its D, a bad T, a value of the wrong type: counted, the rest set. */
static void test_p4_self_describing(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        s = start(T0);
        feed_raw(s, T0, "[:AB|N0|T4|QVehicleName|DVEH_1|T2|QAutoGpsLat|D0|C5E]");
        assert_string_equal(rec.vars[3].value, "VEH_1");
        assert_string_equal(rec.vars[2].value, "0");
        assert_int_equal(rec.n_vars, 4);
        feed(s, T0, ":AB|N0|T0|QHealth_total|D7|T0|Qrpm|Dfast|T9|Qx|D1|T2|QAutoGpsLat|D1.5|"
             "T4|QVehicleName|D|T2|QAutoGpsLat");
        assert_string_equal(rec.vars[4].name, "veh.B.Health_total");
        assert_int_equal(rec.vars[4].type, SHM_TYPE_LONG);
        assert_string_equal(rec.vars[4].value, "7");
        assert_int_equal(rec.n_vars, 5);        /* rpm refused before it was made */
        assert_int_equal(rec.counters[SHM_COUNTER_TYPE_MISMATCH], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_BAD_TYPE], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_BAD_FIELD], 1);
        assert_string_equal(rec.vars[2].value, "1.5");
        assert_string_equal(rec.vars[3].value, "VEH_1");        /* empty D: unchanged */
        /* A Q inside a self-describing frame is never a query. */
        assert_int_equal(rec.counters[SHM_COUNTER_QUERIES_IN], 0);
        link_sharedlink_session_free(s);
}

/* Client writes toward a pronto4 peer: a value that is not of its type is never sent (the last
 * good one stays), a long double text goes in its shortest round-trip form. */
static void test_p4_outbound_types(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        cfg.sl.peers[0].on_change = true;
        s = start(T0);
        assert_int_equal(rec.n_sent, 6);
        link_sharedlink_session_outbound(s, T0 + 1, 0, "1");
        EXPECT_SENT(6, "[:BA|N0|D1|D");
        link_sharedlink_session_outbound(s, T0 + 50, 0, "1.5");
        link_sharedlink_session_outbound(s, T0 + 50, 0, "");
        link_sharedlink_session_outbound(s, T0 + 50, 1, "nan");
        assert_int_equal(rec.counters[SHM_COUNTER_TYPE_MISMATCH], 3);
        assert_int_equal(rec.n_sent, 7);
        link_sharedlink_session_outbound(s, T0 + 60, 1, "0.1000000000000000055511151231257827");
        EXPECT_RAW(7, "[:BA|N0|D1|D0.1|CB6]\r\n");
        link_sharedlink_session_outbound(s, T0 + 70, 1, "-1.79769313486231570000000000000e+308");
        EXPECT_SENT(8, "[:BA|N0|D1|D-1.7976931348623157e+308");
        link_sharedlink_session_tick(s, T0 + 100);
        EXPECT_SENT(9, "[:BA|N0|D1|D-1.7976931348623157e+308");
        link_sharedlink_session_free(s);
}

/* Sending E commands: to the pronto4 peer, checked before the link state. */
static void test_p4_command(void **state)
{
        struct link_sharedlink_session *s;
        char text[SLP_VALUE_MAX + 2];

        (void)state;
        assert_int_equal(link_sharedlink_session_new(&cfg, true, &hooks, NULL, &s), 0);
        assert_int_equal(link_sharedlink_session_command(s, T0, -1, "ServoPod", "x"), -ENOTCONN);
        assert_int_equal(link_sharedlink_session_command(s, T0, -1, "Servo Pod", "x"), -EINVAL);
        memset(text, 'x', sizeof(text) - 1);
        text[sizeof(text) - 1] = '\0';
        assert_int_equal(link_sharedlink_session_command(s, T0, -1, "Link", text), -EINVAL);
        assert_int_equal(link_sharedlink_session_command(s, T0, -1, "Link", "a|b"), -EINVAL);
        assert_int_equal(link_sharedlink_session_command(s, T0, 1, "Link", "x"), -EINVAL);
        link_sharedlink_session_up(s, T0);
        assert_int_equal(rec.n_sent, 6);
        assert_int_equal(link_sharedlink_session_command(s, T0, -1, "ServoPod", "0,TELEOP START"),
                         0);
        assert_int_equal(link_sharedlink_session_command(s, T0, 0, "Physics", "0,Stop"), 0);
        assert_int_equal(link_sharedlink_session_command(s, T0, 0, "MUI", ""), 0);
        assert_int_equal(link_sharedlink_session_command(s, T0, 0, "MUI", "x"), -EINVAL);
        /* A bare module request goes out bare (§9), not as EMUI|D. */
        EXPECT_RAW(6, "[:BA|EServoPod|D0,TELEOP START|C02]\r\n", "[:BA|EPhysics|D0,Stop|CE2]\r\n",
                   "[:BA|MUI|CE3]\r\n");
        assert_int_equal(rec.counters[SHM_COUNTER_COMMANDS_OUT], 6);
        rec.send_result = -ENOBUFS;
        assert_int_equal(link_sharedlink_session_command(s, T0, -1, "Link", "x"), -ENOBUFS);
        link_sharedlink_session_free(s);

        /* A link without a pronto4 peer. */
        cfg.sl.peers[0].dialect = CONFIG_DIALECT_BULLETIN;
        cfg.sl.peers[0].declare = false;
        rec.send_result = 0;
        s = start(T0);
        assert_int_equal(link_sharedlink_session_command(s, T0, -1, "Link", "x"), -EOPNOTSUPP);
        link_sharedlink_session_free(s);
}

/* Learned variables that are not retired: those no position of a list refers to. */
static unsigned learned_live(void)
{
        unsigned n = 0;

        for (unsigned i = 0; i < rec.n_vars; i++)
                n += rec.vars[i].position != SHM_POSITION_NONE && !rec.vars[i].retired;
        return n;
}

/* A learned name re-declared with a bad type keeps its place unmapped: its variable, which no
 * position reaches any more, is retired like one the declaration no longer names, so learned
 * variables never outnumber learn_max (found by fuzz_udp_link: declaring a name, then the same
 * name with a bad type, then another name, left the first one behind each round). */
static void test_p4_bad_type_retires(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        cfg.sl.peers[0].learn_max = 1;
        s = start(T0);
        feed(s, T0, ":BA|N0|T0|Qa");
        assert_int_equal(rec.n_vars, 1);
        assert_string_equal(rec.vars[0].name, "veh.A.a");
        feed(s, T0, ":BA|N0|T7|Qa");
        assert_int_equal(rec.counters[SHM_COUNTER_BAD_TYPE], 1);
        assert_true(rec.vars[0].retired);
        /* Its place is still listed (with no value) in the acknowledgement. */
        EXPECT_RAW(1, "[:AB|N0|Ra|D|C65]\r\n");
        for (unsigned round = 0; round < 3; round++) {
                char decl[32];

                snprintf(decl, sizeof(decl), ":BA|N0|T0|Qb%u", round);
                feed(s, T0, decl);
                snprintf(decl, sizeof(decl), ":BA|N0|T7|Qb%u", round);
                feed(s, T0, decl);
                assert_int_equal(learned_live(), 0);
        }
        feed(s, T0, ":BA|N0|T0|Qc");
        assert_int_equal(learned_live(), 1);
        link_sharedlink_session_free(s);
}

/*
 * Issue 21.3: a refusal is warned once per reason on a link, saying what to check; the rest are
 * summed up in one line LINK_SHAREDLINK_REFUSAL_SUMMARY_MS after the first of them, never a line
 * each.
 */
static void test_refusals_summed_up(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        s = start(T0);
        /* 102 frames for A from C (a swapped address: this link is B). */
        for (unsigned i = 0; i < 102; i++)
                feed(s, T0, ":AC|N0|D1");
        assert_int_equal(rec.counters[SHM_COUNTER_NOT_FOR_US], 102);
        assert_int_equal(rec.n_diags, 1);
        assert_string_equal(rec.diags[0], "not_for_us: frames for A from C, but this link is B: "
                            "check `address:` (ours, and the peer's)");
        /* Between two other nodes of a bus (E to D): counted, nothing to warn or sum up. */
        feed(s, T0, ":DE|N0|D1");
        assert_int_equal(rec.counters[SHM_COUNTER_NOT_FOR_US], 103);
        assert_int_equal(rec.n_diags, 1);
        /* Another reason: its own first warning. */
        feed(s, T0, ":BD|N0|D1");
        assert_int_equal(rec.n_diags, 2);
        assert_string_equal(rec.diags[1], "unknown_peer: frames from D, which is not a peer of "
                            "this link: check the peers' `address:`");
        feed(s, T0 + 1, ":BD|N0|D1");
        assert_int_equal(link_sharedlink_session_deadline(s),
                         T0 + LINK_SHAREDLINK_REFUSAL_SUMMARY_MS);
        link_sharedlink_session_tick(s, T0 + LINK_SHAREDLINK_REFUSAL_SUMMARY_MS - 1);
        assert_int_equal(rec.n_diags, 2);
        link_sharedlink_session_tick(s, T0 + LINK_SHAREDLINK_REFUSAL_SUMMARY_MS);
        assert_int_equal(rec.n_diags, 3);
        assert_string_equal(rec.diags[2], "refused in the last 60 s: unknown_peer 1, "
                            "not_for_us 101 (slctl stats has the totals)");
        /* Nothing pending: no deadline, no line. */
        assert_int_equal(link_sharedlink_session_deadline(s), LINK_SHAREDLINK_NEVER);
        link_sharedlink_session_tick(s, T0 + 2 * LINK_SHAREDLINK_REFUSAL_SUMMARY_MS);
        assert_int_equal(rec.n_diags, 3);
        /* A later burst: no warning again, one summary a window after it began. */
        feed(s, T0 + 3 * LINK_SHAREDLINK_REFUSAL_SUMMARY_MS, ":AC|N0|D1");
        assert_int_equal(rec.n_diags, 3);
        link_sharedlink_session_tick(s, T0 + 4 * LINK_SHAREDLINK_REFUSAL_SUMMARY_MS);
        assert_int_equal(rec.n_diags, 4);
        assert_string_equal(rec.diags[3], "refused in the last 60 s: not_for_us 1 (slctl stats "
                            "has the totals)");
        link_sharedlink_session_free(s);
}

/* Issue 8's bad input, each counted by reason, the rest of the frame applied. */
static void test_p4_bad_input(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        cfg.sl.peers[0].learn_max = 2;
        var_add(&(struct config_var){ 0 }, "veh.A.taken");             /* id 0: not ours */
        s = start(T0);
        /* A data frame before any declaration. */
        feed(s, T0, ":BA|N0|D1|D2");
        assert_int_equal(rec.counters[SHM_COUNTER_UNDECLARED_DATA], 1);
        /* A declaration longer than learn_max 2, with a type letter other than 0/2/4 (its
         * position kept, unmapped) and a name held by another variable: a and taken are the
         * two it maps (taken left unmapped); b and c keep their places, unmapped (issue 21.7:
         * the list keeps its declared length). */
        feed(s, T0, ":BA|N0|T7|Qbad|T0|Qa|T0|Qtaken|T0|Qb|T0|Qc");
        assert_int_equal(rec.counters[SHM_COUNTER_BAD_TYPE], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_LEARN_CONFLICT], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_LEARN_FULL], 2);
        assert_int_equal(rec.n_vars, 2);
        assert_string_equal(rec.vars[1].name, "veh.A.a");
        EXPECT_RAW(0, "[:AB|N0|Rbad|D|Ra|D|Rtaken|D|Rb|D|Rc|D|C9C]\r\n");
        /* Positions: 0 unmapped (dropped), 1 = a, 2 and 3 unmapped. */
        feed(s, T0, ":BA|N0|D9|D5|D6|D7");
        assert_string_equal(rec.vars[1].value, "5");
        assert_false(rec.vars[0].valid);
        assert_int_equal(rec.counters[SHM_COUNTER_LIST_MISMATCH], 3);
        /* A value of the wrong type (a is a long): refused, the rest applied. */
        feed(s, T0, ":BA|N1|D5.5|D|D1");
        assert_string_equal(rec.vars[1].value, "5");
        assert_int_equal(rec.counters[SHM_COUNTER_TYPE_MISMATCH], 1);
        assert_int_equal(rec.counters[SHM_COUNTER_LIST_MISMATCH], 4);
        /* A re-declaration with other names replaces the list whole. */
        feed(s, T0, ":BA|N0|T4|Qx|T0|Qa");
        assert_int_equal(rec.counters[SHM_COUNTER_REDECLARED], 1);
        feed(s, T0, ":BA|N0|Dnew|D8");
        assert_string_equal(rec.vars[2].name, "veh.A.x");
        assert_string_equal(rec.vars[2].value, "new");
        assert_string_equal(rec.vars[1].value, "8");
        /* The same declaration again: not counted. */
        feed(s, T0, ":BA|N0|T4|Qx|T0|Qa");
        assert_int_equal(rec.counters[SHM_COUNTER_REDECLARED], 1);
        /* The same names with another type: counted, the new type wins. */
        feed(s, T0, ":BA|N0|T4|Qx|T4|Qa");
        assert_int_equal(rec.counters[SHM_COUNTER_REDECLARED], 2);
        feed(s, T0, ":BA|N0|D|Dtext");
        assert_string_equal(rec.vars[1].value, "text");
        /* An E command longer than a value, or with a bad module: counted, no event. */
        rec.n_events = 0;
        feed_raw(s, T0, "[:BA|ELink|D01234567890123456789012345678901234567890123456789012345678"
                 "90123|C9F]");
        feed(s, T0, ":BA|EServo!Pod|D0");
        assert_int_equal(rec.counters[SHM_COUNTER_BAD_COMMAND], 2);
        assert_int_equal(rec.counters[SHM_COUNTER_COMMANDS_IN], 0);
        assert_int_equal(rec.n_events, 0);
        /* A quote or backslash in a command's text is escaped in the event. */
        feed(s, T0, ":BA|ESay|Da\"b\\c");
        assert_string_equal(rec.events[0], "command module=Say text=\"a\\\"b\\\\c\"");
        /* The table full while learning. */
        rec.add_room = 0;
        feed(s, T0, ":BA|L0|T0|Qo1");
        assert_int_equal(rec.counters[SHM_COUNTER_LEARN_FULL], 3);
        assert_int_equal(h_find(NULL, "veh.A.o1"), -ENOENT);
        link_sharedlink_session_free(s);
}

/* Configured lists and a peer's declarations: bound by name, in the declared order; a name we
 * do not have is an unmapped position (counted once as a declaration that differs). */
static void test_p4_configured_by_name(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        cfg.sl.peers[0].declare = false;        /* a vehicle with configured lists */
        s = start(T0);
        EXPECT_RAW(0, "[:BA|N0|D|D|CF6]\r\n");
        link_sharedlink_session_outbound(s, T0, 0, "1");
        link_sharedlink_session_outbound(s, T0, 1, "2.5");
        /* L0 in another order, with a name we do not send: the whole list in that order. */
        feed(s, T0, ":AB|L0|T2|Qjoy_steer|T0|Qmissing|T0|Qveh_start");
        assert_int_equal(rec.counters[SHM_COUNTER_REDECLARED], 1);
        EXPECT_SENT(1, "[:BA|N0|D2.5|D|D1");
        link_sharedlink_session_outbound(s, T0 + 10, 0, "3");
        link_sharedlink_session_tick(s, T0 + 100);
        EXPECT_SENT(2, "[:BA|N0|D2.5|D|D3");
        /* N0 from the peer: our inbound list by name; acknowledged, as a vehicle does. */
        feed(s, T0 + 110, ":AB|N0|T4|QVehicleName|T2|QAutoGpsLat|T0|QOther");
        assert_int_equal(rec.counters[SHM_COUNTER_REDECLARED], 2);
        EXPECT_SENT(3, "[:BA|N0|RVehicleName|D|RAutoGpsLat|D|ROther|D");
        feed(s, T0 + 120, ":AB|N0|DV|D1.5|D7");
        assert_string_equal(rec.vars[3].value, "V");
        assert_string_equal(rec.vars[2].value, "1.5");
        assert_int_equal(rec.counters[SHM_COUNTER_LIST_MISMATCH], 1);
        /* The acknowledgement carries current values. */
        feed(s, T0 + 130, ":AB|N0|T4|QVehicleName|T2|QAutoGpsLat");
        EXPECT_SENT(4, "[:BA|N0|RVehicleName|DV|RAutoGpsLat|D1.5");
        assert_int_equal(rec.counters[SHM_COUNTER_REDECLARED], 3);
        assert_int_equal(rec.n_vars, 4);        /* nothing made for a configured list */
        link_sharedlink_session_free(s);
}

/* CR LF: always on a byte stream; on a datagram as the link says (sl.crlf). */
static void test_p4_crlf(void **state)
{
        struct link_sharedlink_session *s;

        (void)state;
        cfg.sl.crlf = false;
        s = start(T0);
        assert_string_equal(rec.raw[1], "[:BA|ELink|D0, outbound, on|CA0]");
        link_sharedlink_session_free(s);
        assert_int_equal(link_sharedlink_session_new(&cfg, false, &hooks, NULL, &s), 0);
        link_sharedlink_session_up(s, T0);
        assert_string_equal(rec.raw[7], "[:BA|ELink|D0, outbound, on|CA0]\r\n");
        link_sharedlink_session_free(s);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup(test_periods, setup),
                cmocka_unit_test_setup(test_refresh_compression, setup),
                cmocka_unit_test_setup(test_on_change, setup),
                cmocka_unit_test_setup(test_positions, setup),
                cmocka_unit_test_setup(test_stale, setup),
                cmocka_unit_test_setup(test_replies, setup),
                cmocka_unit_test_setup(test_adhoc, setup),
                cmocka_unit_test_setup(test_queries, setup),
                cmocka_unit_test_setup(test_rejects, setup),
                cmocka_unit_test_setup(test_unknown_variable, setup),
                cmocka_unit_test_setup(test_p4_vehicle, setup_vehicle),
                cmocka_unit_test_setup(test_p4_host_connect, setup_host),
                cmocka_unit_test_setup(test_p4_acknowledgement, setup_host),
                cmocka_unit_test_setup(test_p4_self_describing, setup_host),
                cmocka_unit_test_setup(test_p4_outbound_types, setup_host),
                cmocka_unit_test_setup(test_p4_command, setup_host),
                cmocka_unit_test_setup(test_p4_bad_input, setup_vehicle),
                cmocka_unit_test_setup(test_p4_bad_type_retires, setup_vehicle),
                cmocka_unit_test_setup(test_refusals_summed_up, setup),
                cmocka_unit_test_setup(test_p4_configured_by_name, setup_host),
                cmocka_unit_test_setup(test_p4_crlf, setup_host),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
