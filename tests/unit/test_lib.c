/*
 * Unit tests of libsharedlink against real tables made by the daemon-side module (this process, or
 * a child process, plays the daemon): ids, reads and metadata, writes and their refusals, waiting,
 * events, links, ad hoc names, daemon restarts (clean and crashed), a recreated .out, permissions.
 */
#define _GNU_SOURCE     /* pthread_setname_np */
#include <errno.h>
#include <fcntl.h>
#include <locale.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <cmocka.h>

#include <sharedlink.h>

#include "common/shmtest.h"
#include "lib/client.h"
#include "shm/futex.h"
#include "shm/layout.h"
#include "shm/slot.h"
#include "shm/table.h"
#include "shm/wake.h"

#define WAIT_LIMIT_MS   10000   /* a hang guard, not a timing assertion */
#define ADHOC           4u

enum { LAT, LON, THROTTLE, STEER, STATE, NOTE, NVARS };

#define TEST_FORGED_PID         0x7ffffff0u     /* above any pid_max: no such process */

static const struct shm_var vars[NVARS] = {
        { "AutoGpsLat", SHM_DIR_IN, SHM_TYPE_DOUBLE, 0, "A", 0 },
        { "AutoGpsLon", SHM_DIR_IN, SHM_TYPE_DOUBLE, 0, "A", 1 },
        { "CmdThrottle", SHM_DIR_OUT, SHM_TYPE_DOUBLE, 0, "A", 0 },
        { "CmdSteer", SHM_DIR_OUT, SHM_TYPE_LONG, 0, "A", 1 },
        { "agility.state", SHM_DIR_IN, SHM_TYPE_STRING, 1, NULL, SHM_POSITION_NONE },
        { "Note", SHM_DIR_OUT, SHM_TYPE_STRING, SHM_LINK_NONE, NULL, SHM_POSITION_NONE },
};

struct fixture {
        struct shmtest_table tb;        /* the daemon's side */
        struct sl_client *c;
};

static void config_default(struct fixture *f)
{
        shmtest_table_config(&f->tb, vars, NVARS, ADHOC);
}

static int setup_daemon(void **state)
{
        struct fixture *f = calloc(1, sizeof(*f));

        shmtest_table_init(&f->tb, "lib");
        config_default(f);
        *state = f;
        return shmtest_table_create(&f->tb) == 0 ? 0 : -1;
}

static int setup_bare(void **state)
{
        struct fixture *f = calloc(1, sizeof(*f));

        shmtest_table_init(&f->tb, "lib");
        config_default(f);
        *state = f;
        return 0;
}

static int setup(void **state)
{
        struct fixture *f;

        if (setup_daemon(state) < 0)
                return -1;
        f = *state;
        return sl_open(f->tb.instance, &f->c) == 0 ? 0 : -1;
}

static int teardown(void **state)
{
        struct fixture *f = *state;

        sl_close(f->c);
        shmtest_table_destroy(&f->tb);
        free(f);
        return 0;
}

struct seen {
        unsigned n;
        struct shm_out_change last;
};

static void on_change(void *userdata, const struct shm_out_change *change)
{
        struct seen *s = userdata;

        s->n++;
        s->last = *change;
}

static int scan(struct fixture *f, struct seen *s)
{
        memset(s, 0, sizeof(*s));
        return shm_table_out_scan(f->tb.t, on_change, s);
}

/* ---- open, ids ------------------------------------------------------------------------------ */

static void test_open_errors(void **state)
{
        struct fixture *f = *state;
        struct sl_client *c = NULL;
        char other[64];

        shmtest_instance(other, sizeof(other), "absent");
        assert_int_equal(sl_open(other, &c), -ENOENT);
        assert_null(c);
        assert_int_equal(sl_open("bad/name", &c), -EINVAL);
        /* The daemon's configuration rule (shm_layout_ident_bad): no name it refuses is opened. */
        assert_int_equal(sl_open("a.b", &c), -EINVAL);
        assert_int_equal(sl_open("-x", &c), -EINVAL);
        assert_int_equal(sl_open("abcdefghijabcdefghijabcdefghijabc", &c), -EINVAL);   /* 33 */
        assert_int_equal(sl_open(f->tb.instance, NULL), -EINVAL);
        /* NULL: the environment names the instance. */
        setenv("SHAREDLINK_INSTANCE", f->tb.instance, 1);
        assert_int_equal(sl_open(NULL, &c), 0);
        unsetenv("SHAREDLINK_INSTANCE");
        assert_int_equal(sl_count(c), NVARS);
        assert_null(sl_close(c));
        assert_null(sl_close(NULL));
}

static void test_find_info(void **state)
{
        struct fixture *f = *state;
        struct sl_var_info info = { .size = sizeof(info) };
        struct sl_var_info small = { .size = sizeof(size_t) };

        assert_int_equal(sl_count(f->c), NVARS);
        for (int i = 0; i < NVARS; i++) {
                assert_int_equal(sl_find(f->c, vars[i].name), i);
                assert_int_equal(sl_info(f->c, i, &info), 0);
                assert_int_equal(info.size, sizeof(info));
                assert_string_equal(info.name, vars[i].name);
                assert_int_equal(info.direction, (int)vars[i].direction);
                assert_int_equal(info.type, (int)vars[i].type);
                assert_int_equal(info.link, vars[i].link == SHM_LINK_NONE ? -1 : (int)vars[i].link);
                assert_string_equal(info.peer, vars[i].peer ? vars[i].peer : "");
                assert_int_equal(info.position, vars[i].position);
                assert_int_equal(info.flags, 0);
        }
        assert_int_equal(sl_find(f->c, "NoSuchThing"), -ENOENT);
        assert_int_equal(sl_find(f->c, ""), -ENOENT);
        assert_int_equal(sl_find(f->c, NULL), -EINVAL);
        assert_int_equal(sl_info(f->c, NVARS, &info), -ENOENT);
        assert_int_equal(sl_info(f->c, -1, &info), -ENOENT);
        assert_int_equal(sl_info(f->c, 0, &small), -EINVAL);
        assert_int_equal(sl_count(NULL), -EINVAL);
        assert_int_equal(sl_find(NULL, "x"), -EINVAL);
}

/* ---- reads ---------------------------------------------------------------------------------- */

static void test_read(void **state)
{
        struct fixture *f = *state;
        struct sl_meta meta = { .size = sizeof(meta) };
        char buf[SL_VALUE_SIZE];

        /* Never set: empty, not valid. */
        assert_int_equal(sl_read(f->c, LAT, buf, sizeof(buf), &meta), 0);
        assert_string_equal(buf, "");
        assert_int_equal(meta.flags & SL_FLAG_VALID, 0);
        assert_int_equal(meta.sequence, 0);

        shm_table_begin_at(f->tb.t, 5000, 6000);
        shm_table_set_str(f->tb.t, LAT, "40.12345678");
        shm_table_commit(f->tb.t);
        assert_int_equal(sl_read(f->c, LAT, buf, sizeof(buf), &meta), 11);
        assert_string_equal(buf, "40.12345678");
        assert_int_equal(meta.size, sizeof(meta));
        assert_int_equal(meta.flags, SL_FLAG_VALID);
        assert_int_equal(meta.mono_ns, 5000);
        assert_int_equal(meta.real_ns, 6000);
        assert_int_equal(meta.sequence, 1);
        assert_true(meta.age_ns > 0);
        shm_table_set_str(f->tb.t, LAT, "40.2");
        assert_int_equal(sl_read(f->c, LAT, buf, sizeof(buf), NULL), 4);
        assert_int_equal(sl_read(f->c, LAT, buf, sizeof(buf), &meta), 4);
        assert_int_equal(meta.sequence, 2);

        shm_table_set_link_stale(f->tb.t, 0, 1);
        assert_int_equal(sl_read(f->c, LAT, buf, sizeof(buf), &meta), 4);
        assert_int_equal(meta.flags, SL_FLAG_VALID | SL_FLAG_STALE);

        assert_int_equal(sl_read(f->c, LAT, buf, 4, &meta), -ENOBUFS);  /* no room for NUL */
        assert_int_equal(sl_read(f->c, LAT, buf, 5, &meta), 4);
        assert_int_equal(sl_read(f->c, NVARS, buf, sizeof(buf), &meta), -ENOENT);
        assert_int_equal(sl_read(f->c, -5, buf, sizeof(buf), &meta), -ENOENT);
        assert_int_equal(sl_read(f->c, LAT, NULL, 0, &meta), -EINVAL);
        meta.size = 4;
        assert_int_equal(sl_read(f->c, LAT, buf, sizeof(buf), &meta), -EINVAL);

        /* A caller built against a newer, larger struct: filled up to what we know, rest kept. */
        struct { struct sl_meta m; unsigned char tail[16]; } big;
        memset(&big, 0x77, sizeof(big));
        big.m.size = sizeof(big);
        assert_int_equal(sl_read(f->c, LAT, buf, sizeof(buf), &big.m), 4);
        assert_int_equal(big.m.size, sizeof(big));
        assert_int_equal(big.m.flags, SL_FLAG_VALID | SL_FLAG_STALE);
        for (size_t i = 0; i < sizeof(big.tail); i++)
                assert_int_equal(big.tail[i], 0x77);
}

/* ---- reader slots ------------------------------------------------------------------------- */

#define SHORT_READERS   (10u * CLIENT_READER_SLOTS)     /* threads started over one test */
#define SHORT_BATCH     8u      /* of them alive at once, so that several slots are claimed */
#define SLOT_VALUE      "40.5"

/* One short-lived reader: reads once, then waits until the main thread let it go. */
struct short_reader {
        struct sl_client *c;
        pthread_barrier_t *have_read;   /* the batch and the main thread */
        pthread_barrier_t *may_exit;    /* the same, or NULL: exit right after reading */
        int result;
        char value[SL_VALUE_SIZE];
};

static void *short_reader_main(void *arg)
{
        struct short_reader *r = arg;

        r->result = sl_read(r->c, LAT, r->value, sizeof(r->value), NULL);
        /* A second read goes through the slot the first one claimed (when it was free). */
        if (r->result >= 0)
                r->result = sl_read(r->c, LAT, r->value, sizeof(r->value), NULL);
        pthread_barrier_wait(r->have_read);
        if (r->may_exit)
                pthread_barrier_wait(r->may_exit);
        return NULL;
}

/* Reader slots of c that a thread holds (0 when c has none: ThreadSanitizer, no membarrier). */
static unsigned slots_owned(const struct sl_client *c)
{
        unsigned n = 0;

        for (unsigned i = 0; c->slots && i < CLIENT_READER_SLOTS; i++)
                n += atomic_load_explicit(&c->slots[i].owner, memory_order_acquire) != 0;
        return n;
}

/* Starts a batch of readers on c; the caller meets them at have_read, then at may_exit. */
static void batch_start(struct short_reader *r, pthread_t *th, struct sl_client *c,
                        pthread_barrier_t *have_read, pthread_barrier_t *may_exit, unsigned n)
{
        for (unsigned i = 0; i < n; i++) {
                r[i] = (struct short_reader){ .c = c, .have_read = have_read,
                                              .may_exit = i % 2u ? may_exit : NULL };
                assert_int_equal(pthread_create(&th[i], NULL, short_reader_main, &r[i]), 0);
        }
}

static void batch_join(struct short_reader *r, pthread_t *th, unsigned n)
{
        for (unsigned i = 0; i < n; i++) {
                pthread_join(th[i], NULL);
                assert_int_equal(r[i].result, (int)strlen(SLOT_VALUE));
                assert_string_equal(r[i].value, SLOT_VALUE);
        }
}

/*
 * Ten times as many short-lived threads as a handle has reader slots each read, and every slot
 * a thread claimed is free again once it has exited: dead threads do not keep them from the
 * live ones.
 */
static void test_reader_slots_freed(void **state)
{
        struct fixture *f = *state;
        struct short_reader r[SHORT_BATCH];
        pthread_t th[SHORT_BATCH];
        pthread_barrier_t have_read, may_exit;
        unsigned before = slots_owned(f->c);    /* this thread's, if it read before */

        assert_int_equal(shm_table_set_str(f->tb.t, LAT, SLOT_VALUE), 0);
        assert_int_equal(pthread_barrier_init(&have_read, NULL, SHORT_BATCH + 1u), 0);
        assert_int_equal(pthread_barrier_init(&may_exit, NULL, SHORT_BATCH / 2u + 1u), 0);
        for (unsigned done = 0; done < SHORT_READERS; done += SHORT_BATCH) {
                batch_start(r, th, f->c, &have_read, &may_exit, SHORT_BATCH);
                pthread_barrier_wait(&have_read);
                /* All of them alive and done reading: the first of each slot claimed it. */
                if (f->c->slots)
                        assert_true(slots_owned(f->c) > before);
                pthread_barrier_wait(&may_exit);
                batch_join(r, th, SHORT_BATCH);
                assert_int_equal(slots_owned(f->c), before);
        }
        pthread_barrier_destroy(&may_exit);
        pthread_barrier_destroy(&have_read);
}

/*
 * Threads that hold slots of a handle closed under them: half of them exit while sl_close runs,
 * half after it. Each gives its slot back to a set that outlives the handle (AddressSanitizer
 * would report a use after free), and a handle opened next starts with every slot free.
 */
static void test_reader_slots_close_first(void **state)
{
        struct fixture *f = *state;
        struct short_reader r[SHORT_BATCH];
        pthread_t th[SHORT_BATCH];
        pthread_barrier_t have_read, may_exit;
        struct sl_client *c;

        assert_int_equal(shm_table_set_str(f->tb.t, LAT, SLOT_VALUE), 0);
        assert_int_equal(pthread_barrier_init(&have_read, NULL, SHORT_BATCH + 1u), 0);
        assert_int_equal(pthread_barrier_init(&may_exit, NULL, SHORT_BATCH / 2u + 1u), 0);
        for (unsigned done = 0; done < SHORT_READERS; done += SHORT_BATCH) {
                assert_int_equal(sl_open(f->tb.instance, &c), 0);
                batch_start(r, th, c, &have_read, &may_exit, SHORT_BATCH);
                pthread_barrier_wait(&have_read);
                assert_null(sl_close(c));
                pthread_barrier_wait(&may_exit);
                batch_join(r, th, SHORT_BATCH);
        }
        assert_int_equal(sl_open(f->tb.instance, &c), 0);
        assert_int_equal(slots_owned(c), 0);
        assert_null(sl_close(c));
        pthread_barrier_destroy(&may_exit);
        pthread_barrier_destroy(&have_read);
}

static void test_read_numbers(void **state)
{
        struct fixture *f = *state;
        static const struct {
                const char *text;
                int dr; double d;
                int lr; long l;
        } cases[] = {
                { "40.5", 0, 40.5, -EDOM, 0 },
                { "-113.25", 0, -113.25, -EDOM, 0 },
                { "12", 0, 12.0, 0, 12 },
                { "-7", 0, -7.0, 0, -7 },
                { "1e3", 0, 1000.0, -EDOM, 0 },
                { "abc", -EDOM, 0, -EDOM, 0 },
                { "12abc", -EDOM, 0, -EDOM, 0 },
                { "", -ENODATA, 0, -ENODATA, 0 },
                { "99999999999999999999999", 0, 1e23, -ERANGE, 0 },
                { "1e999", -ERANGE, 0, -EDOM, 0 },
        };
        struct sl_meta meta = { .size = sizeof(meta) };
        double d;
        long l;

        assert_int_equal(sl_read_double(f->c, LAT, &d, &meta), -ENODATA);        /* never set */
        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                shm_table_set_str(f->tb.t, STATE, cases[i].text);
                assert_int_equal(sl_read_double(f->c, STATE, &d, &meta), cases[i].dr);
                if (cases[i].dr == 0)
                        assert_true(d == cases[i].d);
                assert_int_equal(sl_read_long(f->c, STATE, &l, NULL), cases[i].lr);
                if (cases[i].lr == 0)
                        assert_int_equal(l, cases[i].l);
        }
        assert_int_equal(sl_read_double(f->c, STATE, NULL, NULL), -EINVAL);
        assert_int_equal(sl_read_long(f->c, 99, &l, NULL), -ENOENT);
}

/* ---- writes --------------------------------------------------------------------------------- */

static void test_write(void **state)
{
        struct fixture *f = *state;
        struct sl_meta meta = { .size = sizeof(meta) };
        char buf[SL_VALUE_SIZE];
        struct seen s;

        assert_int_equal(sl_write(f->c, THROTTLE, "0.25"), 0);
        /* What was last written reads back at once, before the daemon even looked. */
        assert_int_equal(sl_read(f->c, THROTTLE, buf, sizeof(buf), &meta), 4);
        assert_string_equal(buf, "0.25");
        assert_int_equal(meta.flags, SL_FLAG_VALID | SL_FLAG_OUTBOUND);
        assert_int_equal(meta.sequence, 1);
        assert_true(meta.mono_ns > 0 && meta.real_ns > 0);
        /* And the daemon hears it. */
        assert_int_equal(scan(f, &s), 1);
        assert_int_equal(s.last.id, THROTTLE);
        assert_int_equal(s.last.status, SHM_OUT_CHANGED);
        assert_string_equal(s.last.value, "0.25");
        assert_int_equal(s.last.writer_pid, getpid());

        assert_int_equal(sl_write_long(f->c, STEER, -42), 0);
        assert_int_equal(sl_write(f->c, NOTE, ""), 0);                  /* empty is a value */
        assert_int_equal(scan(f, &s), 2);
        assert_int_equal(sl_read(f->c, STEER, buf, sizeof(buf), NULL), 3);
        assert_string_equal(buf, "-42");
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), &meta), 0);
        assert_int_equal(meta.flags, SL_FLAG_VALID | SL_FLAG_OUTBOUND);
}

static void test_write_refused(void **state)
{
        struct fixture *f = *state;
        char value[80];
        struct seen s;

        assert_int_equal(sl_write(f->c, LAT, "1"), -EPERM);             /* inbound */
        assert_int_equal(sl_write(f->c, STATE, "x"), -EPERM);
        assert_int_equal(sl_write(f->c, NVARS, "1"), -ENOENT);
        assert_int_equal(sl_write(f->c, -1, "1"), -ENOENT);
        assert_int_equal(sl_write(f->c, NOTE, NULL), -EINVAL);
        assert_int_equal(sl_write(NULL, NOTE, "x"), -EINVAL);
        /* Every byte the wire cannot carry. */
        for (int b = 1; b < 256; b++) {
                if (b >= 0x20 && b <= 0x7e && b != '|' && b != '[' && b != ']')
                        continue;
                snprintf(value, sizeof(value), "ab%cd", b);
                assert_int_equal(sl_write(f->c, NOTE, value), -EINVAL);
        }
        /* Lengths: 63 goes, 64 does not. */
        memset(value, 'y', sizeof(value));
        value[SL_VALUE_SIZE - 1] = '\0';
        assert_int_equal(sl_write(f->c, NOTE, value), 0);
        value[SL_VALUE_SIZE - 1] = 'y';
        value[SL_VALUE_SIZE] = '\0';
        assert_int_equal(sl_write(f->c, NOTE, value), -EINVAL);
        value[SL_VALUE_SIZE + 5] = '\0';
        assert_int_equal(sl_write(f->c, NOTE, value), -EINVAL);
        /* Only the 63-byte value reached the table. */
        assert_int_equal(scan(f, &s), 1);
        assert_int_equal(s.last.length, SL_VALUE_SIZE - 1);
        assert_int_equal(shm_table_counter_get(f->tb.t, SHM_LINK_NONE, SHM_COUNTER_OUT_INVALID), 0);
}

/* A long or double variable takes only what the daemon would send for that type: refused where
 * it is written, the table keeping its value, with a reason for the user. */
static void test_write_typed(void **state)
{
        static const char *const not_long[] = { "abc", "", "1.5", "1e3", " 1", "0x10", "1 ",
                                                "9223372036854775808", "+", "--1" };
        static const char *const not_double[] = { "abc", "", "nan", "inf", "1,5", "0x1p3",
                                                  "1e999", ".", "1e", " 1" };
        struct fixture *f = *state;
        char buf[SL_VALUE_SIZE], reason[128];
        struct seen s;

        assert_int_equal(sl_write(f->c, STEER, "1"), 0);
        assert_int_equal(sl_write(f->c, THROTTLE, "0.5"), 0);
        assert_int_equal(scan(f, &s), 2);
        for (size_t i = 0; i < sizeof(not_long) / sizeof(not_long[0]); i++) {
                assert_int_equal(sl_write(f->c, STEER, not_long[i]), -EINVAL);
                assert_int_equal(sl_write_check(f->c, STEER, not_long[i], reason,
                                                sizeof(reason)), -EINVAL);
                assert_non_null(strstr(reason, "not a long"));
        }
        for (size_t i = 0; i < sizeof(not_double) / sizeof(not_double[0]); i++) {
                assert_int_equal(sl_write(f->c, THROTTLE, not_double[i]), -EINVAL);
                assert_int_equal(sl_write_check(f->c, THROTTLE, not_double[i], reason,
                                                sizeof(reason)), -EINVAL);
                assert_non_null(strstr(reason, "not a double"));
        }
        assert_int_equal(sl_write_check(f->c, STEER, "abc", reason, sizeof(reason)), -EINVAL);
        assert_string_equal(reason, "\"abc\" is not a long: [+-] decimal digits within 64 bits");
        /* The table kept its values and the daemon heard nothing more. */
        assert_int_equal(sl_read(f->c, STEER, buf, sizeof(buf), NULL), 1);
        assert_string_equal(buf, "1");
        assert_int_equal(sl_read(f->c, THROTTLE, buf, sizeof(buf), NULL), 3);
        assert_string_equal(buf, "0.5");
        assert_int_equal(scan(f, &s), 0);
        /* What the types take, and a string takes anything the wire carries. */
        assert_int_equal(sl_write_check(f->c, STEER, "-42", reason, sizeof(reason)), 0);
        assert_string_equal(reason, "");
        assert_int_equal(sl_write(f->c, STEER, "+7"), 0);
        assert_int_equal(sl_write(f->c, THROTTLE, "-1.5e-3"), 0);
        assert_int_equal(sl_write(f->c, THROTTLE, "12"), 0);
        assert_int_equal(sl_write(f->c, NOTE, "abc"), 0);
        /* The other refusals say why too. */
        assert_int_equal(sl_write_check(f->c, LAT, "1", reason, sizeof(reason)), -EPERM);
        assert_non_null(strstr(reason, "inbound"));
        assert_int_equal(sl_write_check(f->c, NOTE, "a|b", reason, sizeof(reason)), -EINVAL);
        assert_non_null(strstr(reason, "cannot carry"));
        assert_int_equal(sl_write_check(f->c, NVARS, "1", NULL, 0), -ENOENT);
}

static void test_write_numbers(void **state)
{
        struct fixture *f = *state;
        static const struct { double v; int decimals; int r; const char *text; } cases[] = {
                { 0.25, 2, 0, "0.25" },
                { 0.25, 0, 0, "0" },
                { -113.123456789, 6, 0, "-113.123457" },
                { 0.1, -1, 0, "0.1" },
                { 1.0 / 3.0, -1, 0, "0.3333333333333333" },
                { 1e20, -1, 0, "1e+20" },
                { 40.5, 17, 0, "40.50000000000000000" },
                { 1.0, 18, -EINVAL, NULL },
                { 1e300, 2, -EINVAL, NULL },            /* 300 digits: too long for the wire */
        };
        char buf[SL_VALUE_SIZE];
        double d;

        for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
                assert_int_equal(sl_write_double(f->c, THROTTLE, cases[i].v, cases[i].decimals),
                                 cases[i].r);
                if (cases[i].r == 0) {
                        assert_true(sl_read(f->c, THROTTLE, buf, sizeof(buf), NULL) > 0);
                        assert_string_equal(buf, cases[i].text);
                }
        }
        assert_int_equal(sl_write_double(f->c, THROTTLE, NAN, 2), -EINVAL);
        assert_int_equal(sl_write_double(f->c, THROTTLE, INFINITY, -1), -EINVAL);
        assert_int_equal(sl_write_double(f->c, LAT, 1.0, 2), -EPERM);
        assert_int_equal(sl_write_long(f->c, STEER, -9223372036854775807L - 1), 0);
        assert_int_equal(sl_read(f->c, STEER, buf, sizeof(buf), NULL), 20);
        /* Whatever the program's locale, numbers use '.' (checked where such a locale exists). */
        if (setlocale(LC_NUMERIC, "de_DE.UTF-8")) {
                assert_int_equal(sl_write_double(f->c, THROTTLE, 0.5, 1), 0);
                assert_int_equal(sl_read(f->c, THROTTLE, buf, sizeof(buf), NULL), 3);
                assert_string_equal(buf, "0.5");
                assert_int_equal(sl_read_double(f->c, THROTTLE, &d, NULL), 0);
                assert_true(d == 0.5);
                setlocale(LC_NUMERIC, "C");
        }
}

static void test_write_read_after_repair(void **state)
{
        struct fixture *f = *state;
        char buf[SL_VALUE_SIZE];
        struct sl_meta meta = { .size = sizeof(meta) };
        struct seen s;
        uint64_t word;
        pid_t pid;

        assert_int_equal(sl_write(f->c, NOTE, "kept"), 0);
        assert_int_equal(scan(f, &s), 1);
        /* A writer dies half-way through the next write (in a child: a real dead pid). */
        fflush(NULL);
        pid = fork();
        if (pid == 0) {
                struct shmtest_view v = shmtest_view_open(f->tb.out_name, true);

                if (!v.base || shm_slot_claim(shmtest_out_slot(&v, 2), (uint32_t)getpid(),
                                              &word) < 0)
                        _exit(1);
                shm_slot_store_word(shmtest_out_slot(&v, 2), 0, 0x4141414141414141ull);
                _exit(0);
        }
        assert_int_equal(shmtest_wait(pid), 0);
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), &meta), -EAGAIN);   /* held */
        assert_int_equal(scan(f, &s), 1);
        assert_int_equal(s.last.status, SHM_OUT_REPAIRED);
        /* The lost write is not handed out; what the daemon last accepted is. */
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), &meta), 4);
        assert_string_equal(buf, "kept");
        assert_int_equal(meta.flags, SL_FLAG_VALID | SL_FLAG_OUTBOUND);
        assert_int_equal(sl_write(f->c, NOTE, "again"), 0);
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), NULL), 5);
}

/* The daemon's periodic scans of a slot a live pid holds: skipped until the bound, then taken
 * over (table.h, SHM_TABLE_HELD_SCANS). */
static void scans_until_taken_over(struct fixture *f)
{
        struct seen s;

        for (unsigned k = 1; k < SHM_TABLE_HELD_SCANS; k++)
                assert_int_equal(scan(f, &s), 0);
        assert_int_equal(scan(f, &s), 1);
        assert_int_equal(s.last.status, SHM_OUT_REPAIRED);
        assert_int_equal(s.last.taken_over, 1);
}

/*
 * A slot whose lock word names a live process that is not writing (here pid 1, forged by a
 * hostile member) refuses every sl_write with -EBUSY; after the daemon's bound it is taken over,
 * and sl_write works again.
 */
static void test_write_after_held_taken_over(void **state)
{
        struct fixture *f = *state;
        struct shmtest_view v = shmtest_view_open(f->tb.out_name, true);
        char buf[SL_VALUE_SIZE];
        struct seen s;

        assert_non_null(v.base);
        assert_int_equal(sl_write(f->c, NOTE, "kept"), 0);
        assert_int_equal(scan(f, &s), 1);
        atomic_store(&shmtest_out_slot(&v, 2)->seq, (UINT64_C(1) << 32) | 11u);     /* NOTE's */
        assert_int_equal(sl_write(f->c, NOTE, "lost"), -EBUSY);
        scans_until_taken_over(f);
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), NULL), 4);
        assert_string_equal(buf, "kept");
        assert_int_equal(sl_write(f->c, NOTE, "again"), 0);
        assert_int_equal(scan(f, &s), 1);
        assert_int_equal(s.last.status, SHM_OUT_CHANGED);
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), NULL), 5);
        assert_string_equal(buf, "again");
        shmtest_view_close(&v);
}

/*
 * A writer (a live pid: not gone) claims NOTE's slot and is stopped there; the daemon takes it
 * over; it runs again, stores its whole value "late" into the slot it no longer holds, and its
 * publish fails. The daemon never sees that value (the word did not move).
 */
static void stopped_writer_resumes(struct fixture *f, struct shmtest_view *v)
{
        struct shm_slot *slot = shmtest_out_slot(v, 2);        /* NOTE's */
        uint64_t word;
        struct seen s;

        assert_int_equal(shm_slot_claim(slot, (uint32_t)getppid(), &word), 0);
        scans_until_taken_over(f);
        shm_slot_store(slot, "late", 4, SHM_SLOT_VALID | SHM_SLOT_OUTBOUND, 1, 2);
        shm_slot_store_stamp(slot, 0);
        assert_int_equal(shm_slot_publish(slot, word), -ECANCELED);
        assert_int_equal(scan(f, &s), 0);
}

/*
 * stopped_writer_resumes after an accepted value: readers read that value, from the daemon's
 * mirror, until the next write, never "late".
 */
static void test_write_stopped_writer_resumes(void **state)
{
        struct fixture *f = *state;
        struct shmtest_view v = shmtest_view_open(f->tb.out_name, true);
        char buf[SL_VALUE_SIZE];
        struct seen s;

        assert_non_null(v.base);
        assert_int_equal(sl_write(f->c, NOTE, "kept"), 0);
        assert_int_equal(scan(f, &s), 1);
        stopped_writer_resumes(f, &v);
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), NULL), 4);
        assert_string_equal(buf, "kept");
        assert_int_equal(sl_write(f->c, NOTE, "next"), 0);
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), NULL), 4);
        assert_string_equal(buf, "next");
        shmtest_view_close(&v);
}

/*
 * stopped_writer_resumes with no value ever accepted for the variable: the daemon's mirror names
 * the repaired word and holds no value, and readers take the mirror's word for it: reading the
 * slot would hand out a value the daemon never accepted nor sent.
 */
static void test_write_stopped_writer_never_written(void **state)
{
        struct fixture *f = *state;
        struct shmtest_view v = shmtest_view_open(f->tb.out_name, true);
        struct sl_meta meta = { .size = sizeof(meta) };
        char buf[SL_VALUE_SIZE];

        assert_non_null(v.base);
        stopped_writer_resumes(f, &v);
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), &meta), 0);
        assert_false(meta.flags & SL_FLAG_VALID);
        assert_int_equal(sl_write(f->c, NOTE, "next"), 0);
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), NULL), 4);
        assert_string_equal(buf, "next");
        shmtest_view_close(&v);
}

/*
 * What a member that rewrites a lock word under a writer can make of the slot (stress_out's attacks
 * did this by chance): once the word no longer says "held", a second writer takes the slot, the
 * first one's remaining stores land in the second one's value, and the mix is published under an
 * even word. Every byte is a writer's and the value is well-formed, so neither the library nor
 * the daemon can tell it from a value written whole; the first writer learns only at its publish
 * (-ECANCELED). The lock keeps honest writers apart; it cannot keep a member from writing, and
 * this is one more way to write. stress_out therefore rewrites lock words only while its writers
 * are between writes, and holds everything read to be a complete value.
 */
static void test_write_lock_rewritten_under_writer(void **state)
{
        struct fixture *f = *state;
        struct shmtest_view v = shmtest_view_open(f->tb.out_name, true);
        char buf[SL_VALUE_SIZE];
        struct shm_slot *slot;
        uint64_t first, w;
        struct seen s;

        assert_non_null(v.base);
        slot = shmtest_out_slot(&v, 2);                         /* NOTE's */
        /* The first writer (a live pid, not the daemon's) takes the slot and is preempted. */
        assert_int_equal(shm_slot_claim(slot, (uint32_t)getppid(), &first), 0);
        /* A member forges the word: odd, of a pid no process has; the daemon repairs it. */
        atomic_store(&slot->seq, ((uint64_t)TEST_FORGED_PID << 32) | 1u);
        assert_int_equal(scan(f, &s), 1);
        assert_int_equal(s.last.status, SHM_OUT_REPAIRED);
        /* A second writer writes a whole value. */
        assert_int_equal(sl_write(f->c, NOTE, "BBBBBBBBbbbbbbbb"), 0);
        /* The first one runs again: its next store lands in the published value. */
        memcpy(&w, "AAAAAAAA", sizeof(w));
        shm_slot_store_word(slot, 1, w);
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), NULL), 16);
        assert_string_equal(buf, "BBBBBBBBAAAAAAAA");           /* nobody wrote this whole */
        assert_int_equal(shm_slot_publish(slot, first), -ECANCELED);
        assert_int_equal(scan(f, &s), 1);
        assert_int_equal(s.last.status, SHM_OUT_CHANGED);
        assert_string_equal(s.last.value, "BBBBBBBBAAAAAAAA");
        shmtest_view_close(&v);
}

/* ---- waiting ---------------------------------------------------------------------------------- */

struct waiter {
        struct sl_client *c;
        uint32_t cursor;
        int result;
};

static void *waiter_main(void *arg)
{
        struct waiter *w = arg;

        w->result = sl_wait(w->c, &w->cursor, WAIT_LIMIT_MS);
        return NULL;
}

static void test_wait_thread(void **state)
{
        struct fixture *f = *state;
        struct waiter w = { f->c, 0, -1 };
        uint32_t before;
        pthread_t th;

        sl_wait(f->c, &w.cursor, 0);                    /* catch up with the table */
        assert_int_equal(sl_wait(f->c, &w.cursor, 0), 0);
        assert_int_equal(sl_wait(f->c, &w.cursor, 10), 0);      /* times out: nothing changed */
        before = w.cursor;
        assert_int_equal(pthread_create(&th, NULL, waiter_main, &w), 0);
        shm_table_begin(f->tb.t);
        shm_table_set_str(f->tb.t, LAT, "1");
        shm_table_commit(f->tb.t);
        pthread_join(th, NULL);
        assert_int_equal(w.result, 1);
        assert_int_equal(w.cursor, before + 1);
        assert_int_equal(sl_wait(f->c, &w.cursor, 0), 0);
        assert_int_equal(sl_wait(f->c, NULL, 0), -EINVAL);
}

struct spin_waiter {
        struct sl_client *c;
        uint32_t cursor;
        int timeout_ms;
        struct sl_wait_opts opts;
        _Atomic int started;
        int result;
};

static void *spin_waiter_main(void *arg)
{
        struct spin_waiter *w = arg;

        atomic_store(&w->started, 1);
        w->result = sl_wait_with(w->c, &w->cursor, w->timeout_ms, &w->opts);
        return NULL;
}

/* Publishes one change once the waiter runs; returns the cursor the waiter should end with. */
static uint32_t spin_change(struct fixture *f, struct spin_waiter *w, pthread_t *th)
{
        uint32_t before = w->cursor;

        assert_int_equal(pthread_create(th, NULL, spin_waiter_main, w), 0);
        while (!atomic_load(&w->started))
                sched_yield();
        shm_table_set_str(f->tb.t, LAT, "spun");
        return before + 1;
}

/*
 * SL_WAIT_SPIN: a change during the spin returns 1 with the new cursor; so does one after a short
 * spin, through the futex as before; a spin that meets the timeout returns 0; bad options -EINVAL.
 */
static void test_wait_spin(void **state)
{
        struct fixture *f = *state;
        struct spin_waiter w = { .c = f->c, .timeout_ms = WAIT_LIMIT_MS };
        uint32_t want;
        pthread_t th;

        w.opts = (struct sl_wait_opts){ .size = sizeof(w.opts), .flags = SL_WAIT_SPIN,
                                        .spin_us = SL_WAIT_SPIN_MAX_US };
        sl_wait(f->c, &w.cursor, 0);                    /* catch up with the table */
        assert_int_equal(sl_wait_with(f->c, &w.cursor, 0, &w.opts), 0);  /* 0: just check */
        /* Within the budget, or after it through the futex: either way woken by the change. */
        want = spin_change(f, &w, &th);
        pthread_join(th, NULL);
        assert_int_equal(w.result, 1);
        assert_int_equal(w.cursor, want);
        /* A spin of 1 us, then the sleep; the change comes later (or during, both are fine). */
        w.opts.spin_us = 1;
        atomic_store(&w.started, 0);
        want = spin_change(f, &w, &th);
        pthread_join(th, NULL);
        assert_int_equal(w.result, 1);
        assert_int_equal(w.cursor, want);
        /* Nothing changes: the spin is cut at the timeout, then 0. */
        w.opts.spin_us = SL_WAIT_SPIN_MAX_US;
        assert_int_equal(sl_wait_with(f->c, &w.cursor, 2, &w.opts), 0);
        assert_int_equal(sl_wait_with(f->c, &w.cursor, 0, &w.opts), 0);
        /* Without the flag it is sl_wait; NULL options too. */
        w.opts.flags = 0;
        assert_int_equal(sl_wait_with(f->c, &w.cursor, 1, &w.opts), 0);
        assert_int_equal(sl_wait_with(f->c, &w.cursor, 1, NULL), 0);
        /* Refused: unknown flags, a budget above the limit, a struct too small. */
        w.opts.flags = 0x80;
        assert_int_equal(sl_wait_with(f->c, &w.cursor, 1, &w.opts), -EINVAL);
        w.opts.flags = SL_WAIT_SPIN;
        w.opts.spin_us = SL_WAIT_SPIN_MAX_US + 1;
        assert_int_equal(sl_wait_with(f->c, &w.cursor, 1, &w.opts), -EINVAL);
        w.opts.spin_us = 1;
        w.opts.size = sizeof(size_t);
        assert_int_equal(sl_wait_with(f->c, &w.cursor, 1, &w.opts), -EINVAL);
        assert_int_equal(sl_wait_with(f->c, NULL, 1, NULL), -EINVAL);
}

struct wait_child {
        const char *instance;
        int ready[2];
};

/* Another process: opens, catches up, says so, then blocks until the daemon commits. */
static int wait_child_main(void *arg)
{
        struct wait_child *w = arg;
        struct sl_client *c;
        uint32_t cursor = 0;
        int r;

        close(w->ready[0]);
        if (sl_open(w->instance, &c) < 0)
                return 2;
        sl_wait(c, &cursor, 0);
        if (write(w->ready[1], "r", 1) != 1)
                return 3;
        r = sl_wait(c, &cursor, WAIT_LIMIT_MS);
        sl_close(c);
        return r == 1 ? 0 : 1;
}

static void test_wait_process(void **state)
{
        struct fixture *f = *state;
        struct wait_child w = { f->tb.instance, { -1, -1 } };
        char c;
        pid_t pid;

        assert_int_equal(pipe(w.ready), 0);
        pid = shmtest_fork(wait_child_main, &w);
        close(w.ready[1]);
        assert_int_equal(read(w.ready[0], &c, 1), 1);
        close(w.ready[0]);
        shm_table_event(f->tb.t, SHM_EVENT_LOG, SHM_LINK_NONE, "x=1");     /* events count too */
        assert_int_equal(shmtest_wait(pid), 0);
}

/* ---- events ----------------------------------------------------------------------------------- */

static void event_init(struct sl_event *ev, size_t n)
{
        for (size_t i = 0; i < n; i++)
                ev[i].size = sizeof(ev[i]);
}

static void test_events(void **state)
{
        struct fixture *f = *state;
        struct sl_event ev[4];
        uint64_t cursor = 0, now;

        event_init(ev, 4);
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 4), 0);
        shm_table_event(f->tb.t, SHM_EVENT_LINK_STATE, 1, "state=connected");
        shm_table_eventf(f->tb.t, SHM_EVENT_ACTION, 1, "device=%s sensor_time=%d", "E1E1E1", 5000);
        shm_table_event(f->tb.t, SHM_EVENT_DEVICE_OFFLINE, 1, "device=AAAAAA");
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 4), 3);
        assert_int_equal(ev[0].seq, 1);
        assert_string_equal(ev[0].type_name, "link-state");
        assert_int_equal(ev[1].seq, 2);
        assert_int_equal(ev[1].type, SHM_EVENT_ACTION);
        assert_string_equal(ev[1].type_name, "action");
        assert_int_equal(ev[1].link, 1);
        assert_string_equal(ev[1].link_name, "agility");
        assert_string_equal(ev[1].text, "device=E1E1E1 sensor_time=5000");
        assert_int_equal(ev[1].lost, 0);
        assert_int_equal(ev[1].flags, 0);
        assert_true(ev[1].mono_ns > 0 && ev[1].real_ns > 0);
        assert_string_equal(ev[2].type_name, "device-offline");
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 4), 0);

        /* Overrun: 16 records retained of 40 written, the reader learns how many it lost. */
        for (int i = 0; i < 40; i++)
                shm_table_eventf(f->tb.t, SHM_EVENT_LOG, SHM_LINK_NONE, "i=%d", i);
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 2), 2);
        assert_int_equal(ev[0].seq, 43 - 16 + 1);
        assert_int_equal(ev[0].lost, 24);
        assert_int_equal(ev[0].link, -1);
        assert_string_equal(ev[0].link_name, "");
        assert_int_equal(ev[1].lost, 0);
        assert_int_equal(ev[1].seq, ev[0].seq + 1);

        /* "now": only what comes next. */
        assert_int_equal(sl_events_now(f->c, &now), 0);
        shm_table_event(f->tb.t, SHM_EVENT_KEYS, 0, "keys=3");
        assert_int_equal(sl_events_read(f->c, &now, ev, 4), 1);
        assert_string_equal(ev[0].text, "keys=3");
        assert_string_equal(ev[0].link_name, "vehicle");

        /* Forged cursors (another run's tag, a number ahead of the ring, all ones): never a
         * wrap or a bogus loss count: the read restarts at the oldest record and says so. */
        {
                const uint64_t tag = now >> 48, mask = (UINT64_C(1) << 48) - 1u;
                const uint64_t forged[] = { UINT64_MAX, (tag << 48) | mask,
                                            (tag << 48) | ((now & mask) + 1000u),
                                            ((tag ^ 1u) << 48) | (now & mask) };

                for (size_t i = 0; i < sizeof(forged) / sizeof(forged[0]); i++) {
                        uint64_t c = forged[i];

                        assert_int_equal(sl_events_read(f->c, &c, ev, 1), 1);
                        assert_int_equal(ev[0].seq, 44 - 16 + 1);
                        assert_int_equal(ev[0].lost, 44 - 16);      /* as from cursor 0 */
                        assert_int_equal(ev[0].flags & SL_EVENT_RESTARTED, SL_EVENT_RESTARTED);
                        assert_int_equal(c >> 48, tag);
                }
        }

        ev[0].size = 8;
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 4), -EINVAL);
        ev[0].size = sizeof(ev[0]);
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 0), -EINVAL);
}

/* ---- links, daemon ---------------------------------------------------------------------------- */

static void test_links(void **state)
{
        struct fixture *f = *state;
        struct sl_link_info li = { .size = sizeof(li) };
        struct sl_daemon_info di = { .size = sizeof(di) };
        int found = 0;

        assert_int_equal(sl_link_count(f->c), 2);
        shm_table_link_state(f->tb.t, 1, 3, "connected");
        shm_table_counter_add(f->tb.t, 1, SHM_COUNTER_FRAMES_IN, 7);
        shm_table_counter_add(f->tb.t, 1, SHM_COUNTER_BAD_CHECKSUM, 2);
        assert_int_equal(sl_link_info(f->c, 1, &li), 0);
        assert_string_equal(li.name, "agility");
        assert_string_equal(li.protocol, "circe");
        assert_int_equal(li.state, 3);
        assert_string_equal(li.state_name, "connected");
        assert_int_equal(li.counter_count, SHM_COUNTER_COUNT);
        for (unsigned i = 0; i < li.counter_count; i++) {
                if (strcmp(li.counters[i].name, "frames_in") == 0) {
                        assert_int_equal(li.counters[i].value, 7);
                        found++;
                }
                if (strcmp(li.counters[i].name, "bad_checksum") == 0) {
                        assert_int_equal(li.counters[i].value, 2);
                        found++;
                }
        }
        assert_int_equal(found, 2);
        assert_int_equal(sl_link_info(f->c, 2, &li), -ENOENT);
        assert_int_equal(sl_link_info(f->c, -1, &li), -ENOENT);

        /* A long state (layout 1.4): whole in state_text, its first 31 bytes in state_name; a
         * caller of the first version (no state_text) is still served. */
        {
                static const char why[] = "down: /srv/rec/field-recording-today.rec:1234: "
                                          "time: 6 digits after the point";
                char text[SL_STATE_TEXT_SIZE + 8];
                struct sl_link_info old;

                assert_int_equal(shm_table_link_state(f->tb.t, 1, 4, why), 0);
                assert_int_equal(sl_link_info(f->c, 1, &li), 0);
                assert_string_equal(li.state_text, why);
                assert_int_equal(strlen(li.state_name), SL_STATE_NAME_SIZE - 1);
                assert_memory_equal(li.state_name, why, SL_STATE_NAME_SIZE - 1);
                memset(&old, 0x55, sizeof(old));
                old.size = offsetof(struct sl_link_info, state_text);
                assert_int_equal(sl_link_info(f->c, 1, &old), 0);
                assert_memory_equal(old.state_name, why, SL_STATE_NAME_SIZE - 1);
                assert_int_equal((unsigned char)old.state_text[0], 0x55);      /* untouched */
                old.size--;
                assert_int_equal(sl_link_info(f->c, 1, &old), -EINVAL);
                /* Longer than the field: cut, never refused. */
                memset(text, 'x', sizeof(text) - 1);
                text[sizeof(text) - 1] = '\0';
                assert_int_equal(shm_table_link_state(f->tb.t, 1, 4, text), 0);
                assert_int_equal(sl_link_info(f->c, 1, &li), 0);
                assert_int_equal(strlen(li.state_text), SL_STATE_TEXT_SIZE - 1);
        }

        /* A link added later shows up. */
        shm_table_link_add(f->tb.t, &(struct shm_link_def){ "arena", "circe" });
        assert_int_equal(sl_link_count(f->c), 3);
        assert_int_equal(sl_link_info(f->c, 2, &li), 0);
        assert_string_equal(li.name, "arena");
        assert_string_equal(li.state_name, "");

        shm_table_counter_add(f->tb.t, SHM_LINK_NONE, SHM_COUNTER_OUT_REPAIRED, 1);
        assert_int_equal(sl_daemon_info(f->c, &di), 0);
        assert_int_equal(di.pid, getpid());
        assert_int_equal(di.epoch, shm_table_epoch(f->tb.t));
        assert_int_equal(di.alive, 1);
        assert_int_equal(di.heartbeat_interval_ms, 0);
        assert_true(di.started_real_ns > 0);
        assert_int_equal(di.counters[SHM_COUNTER_OUT_REPAIRED].value, 1);
        assert_string_equal(di.counters[SHM_COUNTER_OUT_REPAIRED].name, "out_repaired");
        assert_int_equal(sl_daemon_alive(f->c), 1);
}

static void test_adhoc_visible(void **state)
{
        struct fixture *f = *state;
        struct shm_var v = { "AdhocTemp", SHM_DIR_IN, SHM_TYPE_STRING, 0, "A", SHM_POSITION_NONE };
        struct sl_var_info info = { .size = sizeof(info) };
        char buf[SL_VALUE_SIZE];
        uint32_t cursor = 0;
        int id;

        sl_wait(f->c, &cursor, 0);
        assert_int_equal(shm_table_add(f->tb.t, &v), NVARS);
        shm_table_set_str(f->tb.t, NVARS, "21.5");
        assert_int_equal(sl_wait(f->c, &cursor, WAIT_LIMIT_MS), 1);
        assert_int_equal(sl_count(f->c), NVARS + 1);
        id = sl_find(f->c, "AdhocTemp");
        assert_int_equal(id, NVARS);
        assert_int_equal(sl_info(f->c, id, &info), 0);
        assert_int_equal(info.flags, SL_VAR_ADHOC);
        assert_int_equal(sl_read(f->c, id, buf, sizeof(buf), NULL), 4);
        assert_string_equal(buf, "21.5");
}

/*
 * Layout 1.5 (issue 19.6): a retired name reads as gone, and its entry, given to another name,
 * never hands that name's value to an id of the old one; a write meant for the old name (made
 * before it was retired, scanned after) never becomes the new one's.
 */
static void test_retired_names(void **state)
{
        struct fixture *f = *state;
        const struct shm_var in_a = { "veh.A.a", SHM_DIR_IN, SHM_TYPE_STRING, 0, "A", 0 };
        const struct shm_var in_b = { "veh.A.b", SHM_DIR_IN, SHM_TYPE_STRING, 0, "A", 0 };
        const struct shm_var out_a = { "veh.A.oa", SHM_DIR_OUT, SHM_TYPE_STRING, 0, "A", 0 };
        const struct shm_var out_b = { "veh.A.ob", SHM_DIR_OUT, SHM_TYPE_STRING, 0, "A", 0 };
        char buf[SL_VALUE_SIZE];
        int a, old_in, old_out, id;
        struct seen s;

        f->tb.cfg.out_spare = 1;
        assert_int_equal(shmtest_table_create(&f->tb), 0);
        assert_int_equal(sl_open(f->tb.instance, &f->c), 0);

        a = shm_table_add(f->tb.t, &in_a);
        assert_int_equal(a, NVARS);
        assert_int_equal(shm_table_set_str(f->tb.t, (uint32_t)a, "old"), 0);
        old_in = sl_find(f->c, "veh.A.a");
        assert_true(old_in >= 0);
        assert_int_equal(sl_read(f->c, old_in, buf, sizeof(buf), NULL), 3);
        /* Only a name added at run time retires, once. */
        assert_int_equal(shm_table_retire(f->tb.t, LAT), -EPERM);
        assert_int_equal(shm_table_retire(f->tb.t, (uint32_t)a), 0);
        assert_int_equal(shm_table_retire(f->tb.t, (uint32_t)a), -ENOENT);
        assert_int_equal(shm_table_find(f->tb.t, "veh.A.a"), -ENOENT);
        assert_int_equal(shm_table_set_str(f->tb.t, (uint32_t)a, "x"), -ENOENT);
        assert_int_equal(sl_find(f->c, "veh.A.a"), -ENOENT);
        assert_int_equal(sl_read(f->c, old_in, buf, sizeof(buf), NULL), -ENOENT);
        /* The next name takes the entry: the directory does not grow. */
        assert_int_equal(shm_table_add(f->tb.t, &in_b), a);
        assert_int_equal(shm_table_count(f->tb.t), NVARS + 1);
        assert_int_equal(shm_table_set_str(f->tb.t, (uint32_t)a, "new"), 0);
        assert_int_equal(sl_read(f->c, old_in, buf, sizeof(buf), NULL), -ENOENT);
        id = sl_find(f->c, "veh.A.b");
        assert_true(id >= 0 && id != old_in);
        assert_int_equal(sl_read(f->c, id, buf, sizeof(buf), NULL), 3);
        assert_string_equal(buf, "new");

        /* Outbound: the entry keeps its .out slot for the next outbound name. */
        a = shm_table_add(f->tb.t, &out_a);
        old_out = sl_find(f->c, "veh.A.oa");
        assert_int_equal(sl_write(f->c, old_out, "scanned"), 0);
        assert_int_equal(scan(f, &s), 1);
        assert_int_equal(s.last.id, a);
        assert_int_equal(sl_write(f->c, old_out, "late"), 0);         /* not scanned yet */
        assert_int_equal(shm_table_retire(f->tb.t, (uint32_t)a), 0);
        assert_int_equal(shm_table_add(f->tb.t, &out_b), a);
        assert_int_equal(scan(f, &s), 0);                               /* "late" dropped */
        assert_int_equal(sl_write(f->c, old_out, "gone"), -ENOENT);
        id = sl_find(f->c, "veh.A.ob");
        assert_true(id >= 0 && id != old_out);
        assert_int_equal(sl_read(f->c, id, buf, sizeof(buf), NULL), 0); /* never "late" */
        assert_int_equal(sl_write(f->c, id, "fresh"), 0);
        assert_int_equal(scan(f, &s), 1);
        assert_int_equal(s.last.id, a);
        assert_string_equal(s.last.value, "fresh");
        assert_int_equal(sl_read(f->c, id, buf, sizeof(buf), NULL), 5);
}

/*
 * A learned name made again with the other direction (Pronto4: a declaration wins over what a
 * beacon made): the same id, through the same handle, now reads its .out slot. The read path
 * keeps each id's direction and .out slot from the id sync (c->id_out), so a sync that missed
 * the rewrite would read the .in slot here and hand out nothing instead of what was written.
 */
static void test_learned_name_changes_direction(void **state)
{
        struct fixture *f = *state;
        const struct shm_var in_x = { "veh.A.x", SHM_DIR_IN, SHM_TYPE_STRING, 0, "A", 0 };
        const struct shm_var out_x = { "veh.A.x", SHM_DIR_OUT, SHM_TYPE_STRING, 0, "A", 0 };
        char buf[SL_VALUE_SIZE];
        struct sl_meta meta = { .size = sizeof(meta) };
        int a, id;
        struct seen s;

        f->tb.cfg.out_spare = 1;
        assert_int_equal(shmtest_table_create(&f->tb), 0);
        assert_int_equal(sl_open(f->tb.instance, &f->c), 0);
        a = shm_table_add(f->tb.t, &in_x);
        assert_int_equal(shm_table_set_str(f->tb.t, (uint32_t)a, "heard"), 0);
        id = sl_find(f->c, "veh.A.x");
        assert_true(id >= 0);
        assert_int_equal(sl_read(f->c, id, buf, sizeof(buf), &meta), 5);
        assert_false(meta.flags & SL_FLAG_OUTBOUND);
        assert_int_equal(sl_write(f->c, id, "refused"), -EPERM);

        assert_int_equal(shm_table_retire(f->tb.t, (uint32_t)a), 0);
        assert_true(shm_table_add(f->tb.t, &out_x) >= 0);       /* an entry of the new direction */
        assert_int_equal(sl_find(f->c, "veh.A.x"), id);
        assert_int_equal(sl_write(f->c, id, "ours"), 0);
        /* Not scanned yet: only the .out slot has it. */
        assert_int_equal(sl_read(f->c, id, buf, sizeof(buf), &meta), 4);
        assert_string_equal(buf, "ours");
        assert_true(meta.flags & SL_FLAG_OUTBOUND);
        /* Scanned: the daemon's mirror in .in, the same value. */
        assert_int_equal(scan(f, &s), 1);
        assert_int_equal(sl_read(f->c, id, buf, sizeof(buf), &meta), 4);
        assert_string_equal(buf, "ours");
        assert_true(meta.flags & SL_FLAG_OUTBOUND);
}

/*
 * A learned name's entry rewritten in the middle of a read, after the read lock's look at the
 * directory and before the copy: the read must notice (client_dir_moved) and not hand the next
 * name's value to the old name's id. The client skips that check for configured names only
 * (CLIENT_INDEX_LEARNED, taken at the id sync), so a read of a learned one that skipped it would
 * return "new" here. The moment is made exact by a fault: the client's view of the entry's
 * directory and slot pages is made inaccessible, and the SIGSEGV handler plays the daemon (through
 * its own mapping of the same object), gives the page back and lets the load run again. The fault
 * is synchronous, in the middle of sl_read, which holds no lock the table's side takes.
 */
static struct {
        struct shm_table *t;
        uint32_t entry;
        uintptr_t page;
        size_t size;
        int rewritten;
} mid_read;

static void mid_read_rewrite(int sig, siginfo_t *info, void *context)
{
        const struct shm_var next = { "veh.A.next", SHM_DIR_IN, SHM_TYPE_STRING, 0, "A", 0 };
        uintptr_t addr = (uintptr_t)info->si_addr;

        (void)context;
        if (sig != SIGSEGV || addr < mid_read.page || addr >= mid_read.page + mid_read.size ||
            mid_read.rewritten) {
                signal(SIGSEGV, SIG_DFL);      /* a real fault: let it kill the test */
                return;
        }
        mprotect((void *)mid_read.page, mid_read.size, PROT_READ);
        mid_read.rewritten = shm_table_retire(mid_read.t, mid_read.entry) == 0 &&
                             shm_table_add(mid_read.t, &next) == (int)mid_read.entry &&
                             shm_table_set_str(mid_read.t, mid_read.entry, "new") == 0 ? 1 : -1;
}

static void test_learned_entry_rewritten_mid_read(void **state)
{
        struct fixture *f = *state;
        const struct shm_var learned = { "veh.A.old", SHM_DIR_IN, SHM_TYPE_STRING, 0, "A", 0 };
        struct sigaction sa = { .sa_sigaction = mid_read_rewrite, .sa_flags = SA_SIGINFO };
        struct sigaction old_sa;
        uintptr_t page = (uintptr_t)sysconf(_SC_PAGESIZE), first, last;
        char buf[SL_VALUE_SIZE];
        int a, old, id;

        assert_int_equal(shmtest_table_create(&f->tb), 0);
        assert_int_equal(sl_open(f->tb.instance, &f->c), 0);
        a = shm_table_add(f->tb.t, &learned);
        assert_int_equal(a, NVARS);
        assert_int_equal(shm_table_set_str(f->tb.t, (uint32_t)a, "old"), 0);
        old = sl_find(f->c, "veh.A.old");
        assert_true(old >= 0);
        assert_int_equal(sl_read(f->c, old, buf, sizeof(buf), NULL), 3);
        assert_string_equal(buf, "old");
        /* The id sync took a configured name for one and the learned one for learned. */
        assert_int_equal(client_index_entry(f->c, LAT), LAT);
        assert_int_equal(client_index_entry(f->c, old), a | CLIENT_INDEX_LEARNED);

        /* The pages of the client's view that hold the entry and its slot, not the header the
         * read lock looks at. */
        first = (uintptr_t)&f->c->map->dir[a] & ~(page - 1);
        last = ((uintptr_t)(&f->c->map->slots[a] + 1) - 1) & ~(page - 1);
        assert_true(((uintptr_t)f->c->map->in & ~(page - 1)) < first);
        mid_read.t = f->tb.t;
        mid_read.entry = (uint32_t)a;
        mid_read.page = first;
        mid_read.size = last + page - first;
        mid_read.rewritten = 0;
        assert_int_equal(sigaction(SIGSEGV, &sa, &old_sa), 0);
        assert_int_equal(mprotect((void *)mid_read.page, mid_read.size, PROT_NONE), 0);
        assert_int_equal(sl_read(f->c, old, buf, sizeof(buf), NULL), -ENOENT);
        assert_int_equal(sigaction(SIGSEGV, &old_sa, NULL), 0);
        assert_int_equal(mid_read.rewritten, 1);
        id = sl_find(f->c, "veh.A.next");
        assert_true(id >= 0 && id != old);
        assert_int_equal(sl_read(f->c, id, buf, sizeof(buf), NULL), 3);
        assert_string_equal(buf, "new");
}

/* ---- daemon restarts --------------------------------------------------------------------------- */

static void test_restart_clean(void **state)
{
        struct fixture *f = *state;
        /* The new daemon's config: other order, one name gone (Note), one new (Extra). */
        static const struct shm_var vars2[] = {
                { "Extra", SHM_DIR_IN, SHM_TYPE_LONG, SHM_LINK_NONE, NULL, SHM_POSITION_NONE },
                { "CmdThrottle", SHM_DIR_OUT, SHM_TYPE_DOUBLE, 0, "A", 0 },
                { "AutoGpsLat", SHM_DIR_IN, SHM_TYPE_DOUBLE, 0, "A", 0 },
                { "AutoGpsLon", SHM_DIR_IN, SHM_TYPE_DOUBLE, 0, "A", 1 },
                { "CmdSteer", SHM_DIR_OUT, SHM_TYPE_LONG, 0, "A", 1 },
                { "agility.state", SHM_DIR_IN, SHM_TYPE_STRING, 1, NULL, SHM_POSITION_NONE },
        };
        struct sl_meta meta = { .size = sizeof(meta) };
        struct waiter w = { f->c, 0, -1 };
        char buf[SL_VALUE_SIZE];
        uint64_t old_epoch = shm_table_epoch(f->tb.t);
        struct seen s;
        pthread_t th;

        shm_table_set_str(f->tb.t, LAT, "1.0");
        sl_wait(f->c, &w.cursor, 0);
        assert_int_equal(pthread_create(&th, NULL, waiter_main, &w), 0);

        /* Clean shutdown: the waiter wakes; values stay readable, flagged stale; no writes. */
        f->tb.t = shm_table_destroy(f->tb.t);
        pthread_join(th, NULL);
        assert_int_equal(w.result, 1);
        assert_int_equal(sl_daemon_alive(f->c), 0);
        assert_int_equal(sl_read(f->c, LAT, buf, sizeof(buf), &meta), 3);
        assert_int_equal(meta.flags, SL_FLAG_VALID | SL_FLAG_STALE);
        assert_int_equal(sl_write(f->c, THROTTLE, "1"), -ENOTCONN);
        assert_int_equal(sl_wait(f->c, &w.cursor, 0), 0);       /* closed is not a change each time */

        /* A new daemon: the same ids keep naming the same variables. */
        f->tb.cfg.vars = vars2;
        f->tb.cfg.nvars = 6;
        assert_int_equal(shm_table_create(&f->tb.cfg, &f->tb.t), 0);
        assert_true(shm_table_epoch(f->tb.t) != old_epoch);
        shm_table_begin(f->tb.t);
        shm_table_set_str(f->tb.t, 2, "2.0");              /* AutoGpsLat, now index 2 */
        shm_table_set_str(f->tb.t, 0, "77");               /* Extra */
        shm_table_commit(f->tb.t);
        assert_int_equal(sl_read(f->c, LAT, buf, sizeof(buf), &meta), 3);
        assert_string_equal(buf, "2.0");
        assert_int_equal(meta.flags, SL_FLAG_VALID);
        assert_int_equal(sl_daemon_alive(f->c), 1);
        assert_int_equal(sl_find(f->c, "AutoGpsLat"), LAT);
        assert_int_equal(sl_read(f->c, NOTE, buf, sizeof(buf), NULL), -ENOENT);      /* gone */
        assert_int_equal(sl_find(f->c, "Note"), -ENOENT);
        assert_int_equal(sl_find(f->c, "Extra"), NVARS);                /* new name, new id */
        assert_int_equal(sl_count(f->c), NVARS + 1);
        assert_int_equal(sl_read(f->c, NVARS, buf, sizeof(buf), NULL), 2);
        assert_string_equal(buf, "77");
        /* Writes reach the new daemon. */
        assert_int_equal(sl_write(f->c, THROTTLE, "0.5"), 0);
        assert_int_equal(scan(f, &s), 1);
        assert_int_equal(s.last.id, 1);                 /* its id in the new table */
        assert_string_equal(s.last.value, "0.5");
        assert_int_equal(sl_wait(f->c, &w.cursor, 0), 1);
}

/*
 * A daemon restart is flagged on the first event of the new run, exactly once, whatever the
 * reader found in between: here the first reads after the restart find the new ring empty, as
 * they do when the reader polls faster than the new daemon logs (the flag used to be lost then).
 */
static void test_events_restart_empty_ring(void **state)
{
        struct fixture *f = *state;
        struct sl_event ev[4];
        uint64_t cursor = 0, tag;
        unsigned flagged = 0;

        event_init(ev, 4);
        shm_table_event(f->tb.t, SHM_EVENT_LOG, SHM_LINK_NONE, "run=1");
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 4), 1);
        tag = cursor >> 48;
        /* A new daemon whose cursor tag differs (16 bits of its epoch: retried on a clash). */
        for (int i = 0; i < 8 && cursor >> 48 == tag; i++) {
                f->tb.t = shm_table_destroy(f->tb.t);
                assert_int_equal(shm_table_create(&f->tb.cfg, &f->tb.t), 0);
                tag = shm_table_epoch(f->tb.t) >> 48;
                tag = tag ? tag : 1u;                   /* as the library tags cursors */
        }
        assert_int_not_equal(cursor >> 48, tag);
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 4), 0);     /* the new ring: empty */
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 4), 0);
        shm_table_event(f->tb.t, SHM_EVENT_DAEMON, SHM_LINK_NONE, "run=2");
        shm_table_event(f->tb.t, SHM_EVENT_LOG, SHM_LINK_NONE, "n=2");
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 1), 1);
        assert_int_equal(ev[0].seq, 1);
        assert_int_equal(ev[0].flags & SL_EVENT_RESTARTED, SL_EVENT_RESTARTED);
        flagged += (ev[0].flags & SL_EVENT_RESTARTED) != 0;
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 4), 1);
        assert_int_equal(ev[0].seq, 2);
        flagged += (ev[0].flags & SL_EVENT_RESTARTED) != 0;
        shm_table_event(f->tb.t, SHM_EVENT_LOG, SHM_LINK_NONE, "n=3");
        assert_int_equal(sl_events_read(f->c, &cursor, ev, 4), 1);
        flagged += (ev[0].flags & SL_EVENT_RESTARTED) != 0;
        assert_int_equal(flagged, 1);
        assert_int_equal(cursor >> 48, tag);
}

struct crash_daemon {
        const struct shm_table_config *cfg;
        int ready[2];
        unsigned beat_ms;               /* 0: no heartbeat; else refresh it this often */
};

/* Starts crash_daemon_main in a child and returns once its table is up; returns the pid. */
static int crash_daemon_main(void *arg);

static pid_t crash_daemon_start(struct crash_daemon *d)
{
        pid_t pid;
        char ch;

        assert_int_equal(pipe(d->ready), 0);
        pid = shmtest_fork(crash_daemon_main, d);
        close(d->ready[1]);
        assert_int_equal(read(d->ready[0], &ch, 1), 1);
        close(d->ready[0]);
        return pid;
}

/* A daemon in a child: publishes a value, says so, (keeps its heartbeat,) and is then killed. */
static int crash_daemon_main(void *arg)
{
        struct crash_daemon *d = arg;
        struct timespec gap = { 0, (long)d->beat_ms * 1000000L };
        struct shm_table *t;

        close(d->ready[0]);
        if (shm_table_create(d->cfg, &t) < 0)
                return 1;
        shm_table_set_str(t, LAT, "from-child");
        if (write(d->ready[1], "r", 1) != 1)
                return 2;
        for (;;) {
                if (!d->beat_ms) {
                        pause();
                        continue;
                }
                shm_table_heartbeat(t);
                nanosleep(&gap, NULL);
        }
}

static void test_restart_after_crash(void **state)
{
        struct fixture *f = *state;
        struct crash_daemon d = { &f->tb.cfg, { -1, -1 }, 0 };
        struct sl_client *c;
        char buf[SL_VALUE_SIZE];
        uint32_t cursor = 0;
        pid_t pid;

        pid = crash_daemon_start(&d);
        assert_int_equal(sl_open(f->tb.instance, &c), 0);
        assert_int_equal(sl_read(c, LAT, buf, sizeof(buf), NULL), 10);
        assert_string_equal(buf, "from-child");
        sl_wait(c, &cursor, 0);

        assert_int_equal(sl_daemon_alive(c), 1);
        kill(pid, SIGKILL);
        assert_int_equal(shmtest_wait(pid), 128 + SIGKILL);
        assert_int_equal(sl_daemon_alive(c), 0);        /* no heartbeat configured: by pid */
        /* The crashed daemon left its objects; the next one replaces them. */
        assert_int_equal(shm_table_create(&f->tb.cfg, &f->tb.t), 0);
        shm_table_set_str(f->tb.t, LAT, "from-parent");
        assert_int_equal(sl_wait(c, &cursor, WAIT_LIMIT_MS), 1);        /* woken by the replace */
        assert_int_equal(sl_read(c, LAT, buf, sizeof(buf), NULL), 11);
        assert_string_equal(buf, "from-parent");
        assert_int_equal(sl_write(c, THROTTLE, "3"), 0);
        sl_close(c);
}

#define HEARTBEAT_MS    20u     /* of the daemon whose death test_read_stale_after_kill sees */

static uint64_t mono_ns(clockid_t id)
{
        struct timespec ts;

        clock_gettime(id, &ts);
        return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

/* The .out change word, mapped read-write as a second view (the test plays other parties). */
static _Atomic uint32_t *out_change_map(struct fixture *f, void **ret_base, size_t *ret_size)
{
        char name[SHM_OBJECT_NAME_SIZE];
        long size;
        void *base;
        int fd;

        assert_int_equal(shm_layout_object_name(f->tb.instance, "out", name, sizeof(name)), 0);
        size = shmtest_object_size(name);
        assert_true(size >= (long)sizeof(struct shm_out_header));
        fd = shm_open(name, O_RDWR, 0);
        assert_true(fd >= 0);
        base = mmap(NULL, (size_t)size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
        close(fd);
        assert_true(base != MAP_FAILED);
        *ret_base = base;
        *ret_size = (size_t)size;
        return &((struct shm_out_header *)base)->change;
}

/*
 * Layout 1.1: once the daemon mirrored an outbound value, reads take the mirror while the .out
 * word is still the one it was copied under, with the same metadata as from .out; a newer write
 * is read from .out at once. Scribbling over the .out value without touching its word shows
 * which copy a read takes.
 */
static void test_read_outbound_mirror(void **state)
{
        struct fixture *f = *state;
        struct sl_meta before = { .size = sizeof(before) }, after = { .size = sizeof(after) };
        char buf[SL_VALUE_SIZE];
        struct shm_slot *slot;
        struct seen s;
        uint64_t word;
        size_t size;
        void *base;

        out_change_map(f, &base, &size);
        slot = (struct shm_slot *)((char *)base + ((struct shm_out_header *)base)->slots_offset);
        word = shm_slot_word(slot);
        assert_int_equal(sl_write(f->c, THROTTLE, "0.5"), 0);
        assert_int_not_equal(shm_slot_word(slot), word);        /* THROTTLE's is .out slot 0 */
        assert_int_equal(sl_read(f->c, THROTTLE, buf, sizeof(buf), &before), 3);
        assert_int_equal(scan(f, &s), 1);                       /* the daemon mirrors it */
        assert_int_equal(sl_read(f->c, THROTTLE, buf, sizeof(buf), &after), 3);
        assert_string_equal(buf, "0.5");
        assert_int_equal(after.sequence, before.sequence);
        assert_int_equal(after.mono_ns, before.mono_ns);
        assert_int_equal(after.real_ns, before.real_ns);
        assert_int_equal(after.flags, SL_FLAG_VALID | SL_FLAG_OUTBOUND);
        /* Bytes changed behind the lock word (a valid value, so only the path tells): the
         * mirror (checked by the daemon) is read, not the slot. */
        shm_slot_store_word(slot, 0, 0x392e30ull);              /* "0.9", little-endian */
        assert_int_equal(sl_read(f->c, THROTTLE, buf, sizeof(buf), NULL), 3);
        assert_string_equal(buf, "0.5");
        /* A new write: read from .out before any scan. */
        assert_int_equal(sl_write(f->c, THROTTLE, "0.75"), 0);
        assert_int_equal(sl_read(f->c, THROTTLE, buf, sizeof(buf), &after), 4);
        assert_string_equal(buf, "0.75");
        assert_int_equal(after.sequence, before.sequence + 1u);
        munmap(base, size);
}

#define BUSY_READER_NAME        "test-reader"

struct busy_reader {
        struct sl_client *c;
        _Atomic int done;
        int result;
        char buf[SL_VALUE_SIZE];
};

/* Reads THROTTLE until a read succeeds (a bounded number of calls). */
static void *busy_reader_main(void *arg)
{
        struct busy_reader *b = arg;

        pthread_setname_np(pthread_self(), BUSY_READER_NAME);
        for (int i = 0; i < 1000; i++) {
                b->result = sl_read(b->c, THROTTLE, b->buf, sizeof(b->buf), NULL);
                if (b->result != -EAGAIN)
                        break;
        }
        atomic_store(&b->done, 1);
        return NULL;
}

/*
 * A writer that is alive but off its CPU in the middle of a write (here: it holds the slot until
 * the reader sleeps) costs a read a wait, not -EAGAIN: the library sleeps, and reads the value
 * once the writer published it. Before, every call returned -EAGAIN at once and never slept.
 */
static void test_read_waits_out_writer(void **state)
{
        struct fixture *f = *state;
        struct busy_reader b = { f->c, 0, 0, "" };
        struct shm_slot *slot;
        pthread_t th;
        uint64_t word;
        size_t size;
        void *base;
        int asleep = 0;

        out_change_map(f, &base, &size);
        slot = (struct shm_slot *)((char *)base + ((struct shm_out_header *)base)->slots_offset);
        assert_int_equal(shm_slot_claim(slot, (uint32_t)getpid(), &word), 0);  /* THROTTLE's */
        shm_slot_store(slot, "0.25", 4, SHM_SLOT_VALID | SHM_SLOT_OUTBOUND, 1, 1);
        assert_int_equal(pthread_create(&th, NULL, busy_reader_main, &b), 0);
        /* Until the reader sleeps in its read, or gave up without ever sleeping. */
        while (!atomic_load(&b.done) && !asleep) {
                asleep = shmtest_thread_state(BUSY_READER_NAME) == 'S';
                sched_yield();
        }
        assert_int_equal(shm_slot_publish(slot, word), 0);
        pthread_join(th, NULL);
        assert_true(asleep);
        assert_int_equal(b.result, 4);
        assert_string_equal(b.buf, "0.25");
        munmap(base, size);
}

struct flag_waiter {
        _Atomic uint32_t *change;
        _Atomic int armed;
        int result;
};

/* Plays the daemon's wake thread: sets the waiter flag, then sleeps on the word. */
static void *flag_waiter_main(void *arg)
{
        struct flag_waiter *w = arg;
        uint32_t v = atomic_load(w->change);

        while (!atomic_compare_exchange_weak(w->change, &v, v | SHM_OUT_WAITING))
                ;
        atomic_store(&w->armed, 1);
        w->result = shm_futex_wait(w->change, v | SHM_OUT_WAITING, WAIT_LIMIT_MS);
        return NULL;
}

/*
 * Layout 1.6: a write marks its .out slot in the touched map, so that the daemon's wake-up scan
 * looks at it alone; a write that finds its slot held for every attempt (here by a forged word
 * of no process) marks it too before it rings, so that scan repairs it.
 */
static void test_write_marks_touched(void **state)
{
        struct fixture *f = *state;
        struct shm_out_header *h;
        _Atomic uint64_t *map;
        struct shm_slot *slot;
        struct seen s;
        size_t size;
        void *base;

        out_change_map(f, &base, &size);
        h = base;
        assert_true(shm_layout_has_touched(h, size));
        map = (_Atomic uint64_t *)(void *)((char *)base + h->touched_offset);
        slot = (struct shm_slot *)((char *)base + h->slots_offset);     /* THROTTLE's: slot 0 */
        assert_int_equal(atomic_load(&map[0]), 0);
        assert_int_equal(sl_write(f->c, THROTTLE, "0.5"), 0);
        assert_int_equal(atomic_load(&map[0]), UINT64_C(1) << 0);
        memset(&s, 0, sizeof(s));
        assert_int_equal(shm_table_out_scan_touched(f->tb.t, on_change, &s), 1);
        assert_string_equal(s.last.value, "0.5");
        assert_int_equal(atomic_load(&map[0]), 0);

        atomic_store(&slot->seq, ((uint64_t)UINT32_MAX << 32) | 1u);    /* pid of no process */
        assert_int_equal(sl_write(f->c, THROTTLE, "0.75"), -EBUSY);
        assert_int_equal(atomic_load(&map[0]), UINT64_C(1) << 0);
        memset(&s, 0, sizeof(s));
        assert_int_equal(shm_table_out_scan_touched(f->tb.t, on_change, &s), 1);
        assert_int_equal(s.last.status, SHM_OUT_REPAIRED);
        assert_int_equal(sl_write(f->c, THROTTLE, "0.75"), 0);
        munmap(base, size);
}

/*
 * A 1.6 client of a 1.5 daemon (both objects say 1.5, no map in the .out header): it marks
 * nothing and adds the old step, which that daemon's full scan answers.
 */
static void test_write_old_daemon_no_mark(void **state)
{
        struct fixture *f = *state;
        char name[SHM_OBJECT_NAME_SIZE];
        struct shmtest_view in;
        struct shm_out_header *h;
        struct sl_client *c;
        _Atomic uint32_t *change;
        _Atomic uint64_t *map;
        uint32_t before, old = (SHM_LAYOUT_MAJOR << 16) | SHM_LAYOUT_MINOR_RETIRE;
        size_t size;
        void *base;

        change = out_change_map(f, &base, &size);
        h = base;
        map = (_Atomic uint64_t *)(void *)((char *)base + h->touched_offset);
        assert_int_equal(shm_layout_object_name(f->tb.instance, "in", name, sizeof(name)), 0);
        in = shmtest_view_open(name, 1);
        assert_non_null(in.base);
        shmtest_in_header(&in)->layout_version = old;
        h->layout_version = old;
        h->touched_words = 0;
        h->touched_offset = 0;
        assert_int_equal(sl_open(f->tb.instance, &c), 0);
        before = atomic_load(change);
        assert_int_equal(sl_write(c, THROTTLE, "1"), 0);
        assert_int_equal(atomic_load(change), before + SHM_OUT_CHANGE_STEP);
        assert_int_equal(atomic_load(&map[0]), 0);
        sl_close(c);
        shmtest_view_close(&in);
        munmap(base, size);
}

/*
 * What the daemon's scan refuses, a client refuses too: a .out whose touched map was moved in
 * its header, or whose version is not the daemon's, is "try again" (the daemon recreates it),
 * never an object to write into and lose the write with.
 */
static void test_write_refuses_scribbled_header(void **state)
{
        struct fixture *f = *state;
        struct shm_out_header *h;
        struct sl_client *c;
        size_t size;
        void *base;

        out_change_map(f, &base, &size);
        h = base;
        h->touched_offset += SHM_CACHE_LINE;
        assert_int_equal(sl_open(f->tb.instance, &c), 0);
        assert_int_equal(sl_write(c, THROTTLE, "1"), -EAGAIN);
        sl_close(c);
        h->touched_offset -= SHM_CACHE_LINE;
        h->layout_version = (SHM_LAYOUT_MAJOR << 16) | SHM_LAYOUT_MINOR_RETIRE;
        assert_int_equal(sl_open(f->tb.instance, &c), 0);
        assert_int_equal(sl_write(c, THROTTLE, "1"), -EAGAIN);
        sl_close(c);
        h->layout_version = SHM_LAYOUT_VERSION;
        assert_int_equal(sl_open(f->tb.instance, &c), 0);
        assert_int_equal(sl_write(c, THROTTLE, "1"), 0);
        sl_close(c);
        munmap(base, size);
}

/*
 * Layout 1.1: a write adds its step (1.6: SHM_OUT_CHANGE_TOUCHED, it marked its slot) and leaves
 * the flag alone when nobody sleeps (no system call: nothing to wake), and clears the flag and
 * wakes the sleeper when it is set.
 */
static void test_write_waiter_flag(void **state)
{
        struct fixture *f = *state;
        struct flag_waiter w = { 0 };
        _Atomic uint32_t *change;
        pthread_t th;
        uint32_t before;
        size_t size;
        void *base;

        change = out_change_map(f, &base, &size);
        w.change = change;
        before = atomic_load(change);
        assert_int_equal(before & SHM_OUT_WAITING, 0);
        assert_int_equal(sl_write(f->c, THROTTLE, "1"), 0);
        assert_int_equal(atomic_load(change), before + SHM_OUT_CHANGE_TOUCHED);
        /* A sleeper: the write must wake it (it returns 0, or -EAGAIN when the write came
         * between its CAS and its sleep), never time out. */
        assert_int_equal(pthread_create(&th, NULL, flag_waiter_main, &w), 0);
        while (!atomic_load(&w.armed))
                sched_yield();
        before = atomic_load(change);
        assert_int_equal(before & SHM_OUT_WAITING, SHM_OUT_WAITING);
        assert_int_equal(sl_write(f->c, THROTTLE, "2"), 0);
        pthread_join(th, NULL);
        assert_true(w.result == 0 || w.result == -EAGAIN);
        assert_int_equal(atomic_load(change), (before & ~SHM_OUT_WAITING) + SHM_OUT_CHANGE_TOUCHED);
        munmap(base, size);
}

/*
 * The real wake thread, asleep (its flag set): a write wakes it and its eventfd becomes readable;
 * and so for every write in a row, whether the thread was asleep or still awake from the last.
 */
static void test_write_wakes_wake_thread(void **state)
{
        struct fixture *f = *state;
        int fd = shm_table_out_wake_fd(f->tb.t);
        _Atomic uint32_t *change;
        struct seen s;
        size_t size;
        void *base;

        assert_true(fd >= 0);
        change = out_change_map(f, &base, &size);
        for (int i = 0; i < 50; i++) {
                struct pollfd p = { .fd = fd, .events = POLLIN };
                char value[16];

                if (i % 2 == 0) {       /* every other time, write only once it sleeps */
                        uint64_t deadline = mono_ns(CLOCK_MONOTONIC) +
                                            (uint64_t)WAIT_LIMIT_MS * 1000000ull;

                        while (!(atomic_load(change) & SHM_OUT_WAITING) &&
                               mono_ns(CLOCK_MONOTONIC) < deadline)
                                sched_yield();
                        assert_int_equal(atomic_load(change) & SHM_OUT_WAITING, SHM_OUT_WAITING);
                }
                snprintf(value, sizeof(value), "%d", i);
                assert_int_equal(sl_write(f->c, THROTTLE, value), 0);
                assert_int_equal(poll(&p, 1, WAIT_LIMIT_MS), 1);
                assert_int_equal(shm_table_out_wake_ack(f->tb.t), 1);
                assert_int_equal(scan(f, &s), 1);
                assert_string_equal(s.last.value, value);
        }
        munmap(base, size);
}


/*
 * age_ns counts to the coarse monotonic clock: never more than the fine clock says after the read,
 * and behind it by at most a few ticks (AGE_LAG_MAX_NS is a wide margin for a loaded machine: the
 * bound checks that the age is the age, not how fast the clock is).
 */
#define AGE_LAG_MAX_NS  1000000000ull
static void test_read_age_coarse(void **state)
{
        struct fixture *f = *state;
        struct sl_meta meta = { .size = sizeof(meta) };
        char buf[SL_VALUE_SIZE];
        uint64_t stamp, before, after;

        stamp = mono_ns(CLOCK_MONOTONIC) - 2u * AGE_LAG_MAX_NS;  /* updated a while ago */
        shm_table_begin_at(f->tb.t, stamp, 1);
        shm_table_set_str(f->tb.t, LAT, "1.5");
        shm_table_commit(f->tb.t);
        before = mono_ns(CLOCK_MONOTONIC);
        assert_int_equal(sl_read(f->c, LAT, buf, sizeof(buf), &meta), 3);
        after = mono_ns(CLOCK_MONOTONIC);
        assert_int_equal(meta.mono_ns, stamp);
        assert_true(meta.age_ns <= after - stamp);
        assert_true(meta.age_ns + AGE_LAG_MAX_NS >= before - stamp);
        /* Updated "in the future" of the coarse clock (within its last tick): age 0, not huge. */
        shm_table_begin_at(f->tb.t, after + 1000000000ull, 1);
        shm_table_set_str(f->tb.t, LAT, "2");
        shm_table_commit(f->tb.t);
        assert_int_equal(sl_read(f->c, LAT, buf, sizeof(buf), &meta), 1);
        assert_int_equal(meta.age_ns, 0);
}

/*
 * The coarse clock sl_read counts ages to comes from the vDSO's own clock_gettime where there is
 * one (client_now_coarse), and is the same clock as the C library's: never before a reading taken
 * before it, never after one taken after.
 */
static void test_read_clock_vdso(void **state)
{
        struct fixture *f = *state;
        struct timespec ts;
        uint64_t before, now, after;

#if defined(__x86_64__) || defined(__aarch64__)
        assert_non_null(f->c->vdso_clock_gettime);
#endif
        clock_gettime(CLOCK_MONOTONIC_COARSE, &ts);
        before = (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
        now = client_now_coarse(f->c);
        clock_gettime(CLOCK_MONOTONIC_COARSE, &ts);
        after = (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
        assert_true(before <= now && now <= after);
}

/*
 * A daemon killed with SIGKILL updates nothing any more, yet reads must say stale once its
 * heartbeat is CLIENT_HEARTBEAT_MISSES intervals old, without asking the kernel about its pid.
 */
static void test_read_stale_after_kill(void **state)
{
        struct fixture *f = *state;
        struct crash_daemon d = { &f->tb.cfg, { -1, -1 }, HEARTBEAT_MS };
        struct sl_meta meta = { .size = sizeof(meta) };
        struct sl_client *c;
        char buf[SL_VALUE_SIZE];
        uint64_t deadline;
        pid_t pid;
        int stale = 0;

        f->tb.cfg.heartbeat_interval_ms = HEARTBEAT_MS;
        pid = crash_daemon_start(&d);
        assert_int_equal(sl_open(f->tb.instance, &c), 0);
        /* Alive and beating: fresh, however long we look (the child keeps beating). */
        for (int i = 0; i < 20; i++) {
                assert_int_equal(sl_read(c, LAT, buf, sizeof(buf), &meta), 10);
                assert_int_equal(meta.flags, SL_FLAG_VALID);
        }
        kill(pid, SIGKILL);
        assert_int_equal(shmtest_wait(pid), 128 + SIGKILL);
        deadline = mono_ns(CLOCK_MONOTONIC) + (uint64_t)WAIT_LIMIT_MS * 1000000ull;
        while (!stale && mono_ns(CLOCK_MONOTONIC) < deadline) {
                struct timespec gap = { 0, (long)HEARTBEAT_MS * 1000000L };

                assert_int_equal(sl_read(c, LAT, buf, sizeof(buf), &meta), 10);
                assert_string_equal(buf, "from-child"); /* the last value is still served */
                stale = (meta.flags & SL_FLAG_STALE) != 0;
                if (!stale)
                        nanosleep(&gap, NULL);
        }
        assert_true(stale);
        assert_int_equal(meta.flags, SL_FLAG_VALID | SL_FLAG_STALE);
        /* Without metadata nothing is said about it, and nothing fails either. */
        assert_int_equal(sl_read(c, LAT, buf, sizeof(buf), NULL), 10);
        sl_close(c);
}

static void test_out_recreated(void **state)
{
        struct fixture *f = *state;
        struct seen s;
        int fd;

        assert_int_equal(sl_write(f->c, NOTE, "a"), 0);
        assert_int_equal(scan(f, &s), 1);
        /* Someone truncates .out under everybody's mappings. */
        fd = shm_open(f->tb.out_name, O_RDWR, 0);
        assert_true(fd >= 0);
        assert_int_equal(ftruncate(fd, 0), 0);
        close(fd);
        assert_int_equal(scan(f, &s), -EBADMSG);                        /* recreated */
        /* The client notices the new .out and writes there. */
        assert_int_equal(sl_write(f->c, NOTE, "b"), 0);
        assert_int_equal(scan(f, &s), 1);
        assert_string_equal(s.last.value, "b");
}

/*
 * Waits (on the wake eventfd, the daemon's event) until a client rang the daemon, then scans as
 * the daemon does; returns the scan's result.
 */
static int wait_rung_and_scan(struct fixture *f, int fd, struct seen *s)
{
        struct pollfd p = { .fd = fd, .events = POLLIN };

        assert_int_equal(poll(&p, 1, WAIT_LIMIT_MS), 1);        /* a hang guard */
        shm_table_out_wake_ack(f->tb.t);
        return scan(f, s);
}

/*
 * A client truncates .out and no writer is left to wake the daemon through it: a client that
 * then finds .out unusable rings the doorbell in .in (layout 1.3), the daemon recreates .out,
 * and the write goes through. Waits on events only (the eventfd, then sl_wait).
 */
static void test_out_truncated_rings_daemon(void **state)
{
        struct fixture *f = *state;
        int wake = shm_table_out_wake_fd(f->tb.t);
        struct sl_client *c;
        uint32_t cursor = 0;
        struct seen s;
        int fd;

        assert_true(wake >= 0);
        /* The wake thread asleep on the .out word: only a wake-up can tell it anything now. */
        assert_int_equal(shmtest_thread_wait_asleep(SHM_WAKE_THREAD_NAME, WAIT_LIMIT_MS), 0);
        /* Everyone's mappings are left as they are (f->c's too: it must not touch .out now). */
        fd = shm_open(f->tb.out_name, O_RDWR, 0);
        assert_true(fd >= 0);
        assert_int_equal(ftruncate(fd, 0), 0);
        close(fd);
        assert_int_equal(sl_open(f->tb.instance, &c), 0);
        sl_wait(c, &cursor, 0);
        assert_int_equal(sl_write(c, NOTE, "a"), -EAGAIN);     /* unusable: rings */
        assert_int_equal(wait_rung_and_scan(f, wake, &s), -EBADMSG);    /* recreated */
        assert_int_equal(sl_wait(c, &cursor, WAIT_LIMIT_MS), 1);       /* the new generation */
        assert_int_equal(sl_write(c, NOTE, "b"), 0);
        assert_int_equal(scan(f, &s), 1);
        assert_string_equal(s.last.value, "b");
        assert_int_equal(shm_table_counter_get(f->tb.t, SHM_LINK_NONE, SHM_COUNTER_OUT_RECREATED),
                         1);
        sl_close(c);
}

/* Fills size bytes at p with bytes of a fixed pseudo-random sequence (no zero words). */
static void scribble(void *p, size_t size, uint64_t seed)
{
        unsigned char *b = p;

        for (size_t i = 0; i < size; i++) {
                seed = seed * 6364136223846793005ull + 1442695040888963407ull;
                b[i] = (unsigned char)(seed >> 56) | 1u;
        }
}

/*
 * Random bytes over .out, its size kept. Over the header: a new client cannot use it and rings,
 * the daemon recreates it. Over the slots only: the daemon repairs the words a writer could not
 * claim (odd, pid of no process) when a client rings, and never takes the bytes for a value.
 */
static void test_out_scribbled_rings_daemon(void **state)
{
        struct fixture *f = *state;
        int wake = shm_table_out_wake_fd(f->tb.t);
        struct shm_out_header *h;
        struct sl_client *c;
        uint32_t cursor = 0;
        struct seen s;
        size_t size;
        void *base;

        assert_true(wake >= 0);
        assert_int_equal(shmtest_thread_wait_asleep(SHM_WAKE_THREAD_NAME, WAIT_LIMIT_MS), 0);
        out_change_map(f, &base, &size);
        h = base;
        scribble(base, sizeof(*h), 1);
        assert_int_equal(sl_open(f->tb.instance, &c), 0);
        sl_wait(c, &cursor, 0);
        assert_true(sl_write(c, THROTTLE, "1") < 0);           /* unusable: rings */
        assert_int_equal(wait_rung_and_scan(f, wake, &s), -EBADMSG);
        munmap(base, size);
        assert_int_equal(sl_wait(c, &cursor, WAIT_LIMIT_MS), 1);
        assert_int_equal(sl_write(c, THROTTLE, "2"), 0);
        assert_int_equal(scan(f, &s), 1);
        assert_string_equal(s.last.value, "2");

        /* Now the slots: odd words with no live writer, garbage values. */
        out_change_map(f, &base, &size);
        h = base;
        scribble((char *)base + h->slots_offset, size - h->slots_offset, 2);
        for (int id = THROTTLE; id <= NOTE; id += (id == STEER ? NOTE - STEER : 1)) {
                int r;

                for (int tries = 0; (r = sl_write(c, id, "3")) == -EBUSY && tries < 4; tries++)
                        wait_rung_and_scan(f, wake, &s);        /* repaired on the ring */
                assert_int_equal(r, 0);
        }
        memset(&s, 0, sizeof(s));
        assert_true(shm_table_out_scan(f->tb.t, on_change, &s) >= 0);
        assert_string_equal(s.last.value, "3");
        assert_int_equal(s.last.status, SHM_OUT_CHANGED);
        munmap(base, size);
        sl_close(c);
}

/* ---- permissions ------------------------------------------------------------------------------ */

struct perm_probe {
        const char *instance;
        int want_open;
        int want_write;
};

static int perm_probe_main(void *arg)
{
        struct perm_probe *p = arg;
        char name[SHM_OBJECT_NAME_SIZE], buf[SL_VALUE_SIZE];
        struct sl_client *c = NULL;
        int r, fd;

        r = sl_open(p->instance, &c);
        if (r != p->want_open)
                return 10;
        if (r < 0)
                return 0;
        if (sl_read(c, LAT, buf, sizeof(buf), NULL) < 0)
                return 11;
        if (sl_write(c, THROTTLE, "0.5") != p->want_write)
                return 12;
        /* Whatever happens, the inbound table is never writable. */
        shm_layout_object_name(p->instance, "in", name, sizeof(name));
        fd = shm_open(name, O_RDWR, 0);
        if (fd >= 0 || errno != EACCES)
                return 13;
        if (p->want_write != 0) {
                shm_layout_object_name(p->instance, "out", name, sizeof(name));
                fd = shm_open(name, O_RDWR, 0);
                if (fd >= 0 || errno != EACCES)
                        return 14;
        }
        sl_close(c);
        return 0;
}

static void test_permissions_no_group(void **state)
{
        struct fixture *f = *state;
        struct perm_probe p = { f->tb.instance, 0, -EACCES };
        const gid_t nogroup = SHMTEST_NOBODY;

        if (geteuid() != 0)
                skip();
        shm_table_set_str(f->tb.t, LAT, "1");
        /* Anyone reads 0644; nobody outside the group writes. */
        assert_int_equal(shmtest_as_user(SHMTEST_NOBODY, SHMTEST_NOBODY, 1, &nogroup,
                                         perm_probe_main, &p), 0);
}

static void test_permissions_group(void **state)
{
        struct fixture *f = *state;
        struct perm_probe outsider = { f->tb.instance, -EACCES, 0 };
        struct perm_probe member = { f->tb.instance, 0, 0 };
        const gid_t nogroup = SHMTEST_NOBODY, group = SHMTEST_GROUP;
        struct seen s;

        if (geteuid() != 0)
                skip();
        f->tb.cfg.has_group = 1;
        f->tb.cfg.gid = SHMTEST_GROUP;
        assert_int_equal(shm_table_create(&f->tb.cfg, &f->tb.t), 0);
        shm_table_set_str(f->tb.t, LAT, "1");
        /* 0640: outside the group, not even readable. */
        assert_int_equal(shmtest_as_user(SHMTEST_NOBODY, SHMTEST_NOBODY, 1, &nogroup,
                                         perm_probe_main, &outsider), 0);
        /* A member (supplementary group) reads and writes. */
        assert_int_equal(shmtest_as_user(SHMTEST_NOBODY, SHMTEST_NOBODY, 1, &group,
                                         perm_probe_main, &member), 0);
        assert_int_equal(scan(f, &s), 1);
        assert_string_equal(s.last.value, "0.5");
}

/* The counter list through the public API (one list: shm/layout.h), as slctl reads it. */
static void test_counter_names_scopes(void **state)
{
        (void)state;
        assert_string_equal(sl_counter_name(0), "frames_in");
        for (unsigned i = 0; i < SHM_COUNTER_COUNT; i++) {
                assert_string_equal(sl_counter_name(i), shm_layout_counter_name(i));
                assert_true(sl_counter_scope(sl_counter_name(i)) != 0);
        }
        assert_null(sl_counter_name(SHM_COUNTER_COUNT));
        assert_int_equal(sl_counter_scope("frames_in"), SL_COUNTER_SHAREDLINK | SL_COUNTER_CIRCE);
        assert_int_equal(sl_counter_scope("bad_address"), SL_COUNTER_SHAREDLINK);
        assert_int_equal(sl_counter_scope("noncompliant_status"), SL_COUNTER_CIRCE);
        assert_int_equal(sl_counter_scope("out_recreated"), SL_COUNTER_DAEMON);
        assert_int_equal(sl_counter_scope("no_such_counter"), 0);
        assert_int_equal(sl_counter_scope(NULL), 0);
}

static void test_strerror(void **state)
{
        static const int codes[] = { ENOENT, EINVAL, EPERM, EACCES, EAGAIN, EBUSY, ECANCELED,
                                     ENOTCONN, ENOBUFS, ENODATA, EDOM, ERANGE, EPROTO, ENOSPC };

        (void)state;
        assert_string_equal(sl_strerror(0), "success");
        for (size_t i = 0; i < sizeof(codes) / sizeof(codes[0]); i++) {
                assert_non_null(sl_strerror(-codes[i]));
                assert_string_not_equal(sl_strerror(-codes[i]), "unexpected error");
                for (size_t j = 0; j < i; j++)
                        assert_string_not_equal(sl_strerror(-codes[i]), sl_strerror(-codes[j]));
        }
        assert_string_equal(sl_strerror(-EXDEV), "unexpected error");
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test_setup_teardown(test_open_errors, setup, teardown),
                cmocka_unit_test_setup_teardown(test_find_info, setup, teardown),
                cmocka_unit_test_setup_teardown(test_read, setup, teardown),
                cmocka_unit_test_setup_teardown(test_read_numbers, setup, teardown),
                cmocka_unit_test_setup_teardown(test_reader_slots_freed, setup, teardown),
                cmocka_unit_test_setup_teardown(test_reader_slots_close_first, setup, teardown),
                cmocka_unit_test_setup_teardown(test_write, setup, teardown),
                cmocka_unit_test_setup_teardown(test_write_refused, setup, teardown),
        cmocka_unit_test_setup_teardown(test_write_typed, setup, teardown),
        cmocka_unit_test_setup_teardown(test_write_numbers, setup, teardown),
                cmocka_unit_test_setup_teardown(test_write_read_after_repair, setup, teardown),
                cmocka_unit_test_setup_teardown(test_write_after_held_taken_over, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_write_stopped_writer_never_written, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_write_stopped_writer_resumes, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_write_lock_rewritten_under_writer, setup,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_read_waits_out_writer, setup, teardown),
                cmocka_unit_test_setup_teardown(test_wait_thread, setup, teardown),
                cmocka_unit_test_setup_teardown(test_wait_process, setup, teardown),
                cmocka_unit_test_setup_teardown(test_wait_spin, setup, teardown),
                cmocka_unit_test_setup_teardown(test_events, setup, teardown),
                cmocka_unit_test_setup_teardown(test_links, setup, teardown),
                cmocka_unit_test_setup_teardown(test_adhoc_visible, setup, teardown),
                cmocka_unit_test_setup_teardown(test_retired_names, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_learned_name_changes_direction, setup_bare,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_learned_entry_rewritten_mid_read, setup_bare,
                                                teardown),
                cmocka_unit_test_setup_teardown(test_restart_clean, setup, teardown),
                cmocka_unit_test_setup_teardown(test_restart_after_crash, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_events_restart_empty_ring, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_recreated, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_truncated_rings_daemon, setup, teardown),
                cmocka_unit_test_setup_teardown(test_out_scribbled_rings_daemon, setup, teardown),
                cmocka_unit_test_setup_teardown(test_read_age_coarse, setup, teardown),
                cmocka_unit_test_setup_teardown(test_read_clock_vdso, setup, teardown),
                cmocka_unit_test_setup_teardown(test_write_marks_touched, setup, teardown),
                cmocka_unit_test_setup_teardown(test_write_old_daemon_no_mark, setup, teardown),
                cmocka_unit_test_setup_teardown(test_write_refuses_scribbled_header, setup, teardown),
                cmocka_unit_test_setup_teardown(test_write_waiter_flag, setup, teardown),
                cmocka_unit_test_setup_teardown(test_read_outbound_mirror, setup, teardown),
                cmocka_unit_test_setup_teardown(test_write_wakes_wake_thread, setup, teardown),
                cmocka_unit_test_setup_teardown(test_read_stale_after_kill, setup_bare, teardown),
                cmocka_unit_test_setup_teardown(test_permissions_no_group, setup, teardown),
                cmocka_unit_test_setup_teardown(test_permissions_group, setup_bare, teardown),
                cmocka_unit_test(test_counter_names_scopes),
                cmocka_unit_test(test_strerror),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
