/*
 * Unit tests of the shared-memory building blocks: layout checks, seqlock primitives, value slots,
 * the event ring, futexes across processes, the SIGBUS guard and the wake thread.
 */
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "common/shmtest.h"
#include "shm/events.h"
#include "shm/futex.h"
#include "shm/guard.h"
#include "shm/layout.h"
#include "shm/seqlock.h"
#include "shm/slot.h"
#include "shm/wake.h"

#define POLL_LIMIT_MS   10000   /* a hang guard, not a timing assertion */

/* ---- layout -------------------------------------------------------------------------------- */

static void test_geometry(void **state)
{
        static const uint32_t caps[] = { 0, 1, 7, 100, 4096, SHM_CAPACITY_MAX };
        struct shm_in_geometry g;

        (void)state;
        for (size_t i = 0; i < sizeof(caps) / sizeof(caps[0]); i++) {
                shm_layout_in_geometry(caps[i], SHM_EVENTS_DEFAULT, &g);
                assert_int_equal(g.links_offset, sizeof(struct shm_in_header));
                assert_int_equal(g.events_offset % SHM_CACHE_LINE, 0);
                assert_int_equal(g.dir_offset % SHM_CACHE_LINE, 0);
                assert_int_equal(g.slots_offset % SHM_CACHE_LINE, 0);
                assert_true(g.events_offset >= g.links_offset + SHM_LINKS_MAX * sizeof(struct shm_link));
                assert_true(g.dir_offset >= g.events_offset + SHM_EVENTS_DEFAULT * sizeof(struct shm_event));
                assert_true(g.slots_offset >= g.dir_offset + caps[i] * sizeof(struct shm_dir_entry));
                assert_int_equal(g.total_size, g.slots_offset + caps[i] * sizeof(struct shm_slot));
        }
        assert_int_equal(shm_layout_out_size(3), sizeof(struct shm_out_header) + 3 * 128);
}

/* Builds a valid .in header in h for capacity 4 (no object needed: the check is pure). */
static void header_make(struct shm_in_header *h)
{
        struct shm_in_geometry g;

        memset(h, 0, sizeof(*h));
        shm_layout_in_geometry(4, SHM_EVENTS_MIN, &g);
        h->layout_version = SHM_LAYOUT_VERSION;
        h->header_size = sizeof(*h);
        h->total_size = g.total_size;
        h->capacity = 4;
        h->out_capacity = 1;
        h->slot_size = sizeof(struct shm_slot);
        h->dir_entry_size = sizeof(struct shm_dir_entry);
        h->link_max = SHM_LINKS_MAX;
        h->link_size = sizeof(struct shm_link);
        h->counter_max = SHM_COUNTERS_MAX;
        h->event_size = sizeof(struct shm_event);
        h->event_capacity = SHM_EVENTS_MIN;
        h->links_offset = g.links_offset;
        h->events_offset = g.events_offset;
        h->dir_offset = g.dir_offset;
        h->slots_offset = g.slots_offset;
        atomic_store(&h->magic, SHM_IN_MAGIC);
}

static void test_check_in(void **state)
{
        struct shm_in_header *h = malloc(sizeof(*h));
        uint64_t size;

        (void)state;
        header_make(h);
        size = h->total_size;
        assert_int_equal(shm_layout_check_in(h, size), 0);
        assert_int_equal(shm_layout_check_in(h, size - 1), -EPROTO);    /* object too small */
        assert_int_equal(shm_layout_check_in(h, 100), -EAGAIN);         /* not sized yet */
        atomic_store(&h->magic, 0);
        assert_int_equal(shm_layout_check_in(h, size), -EAGAIN);        /* not ready */
        atomic_store(&h->magic, SHM_OUT_MAGIC);
        assert_int_equal(shm_layout_check_in(h, size), -EPROTO);        /* not .in */
        header_make(h);
        h->layout_version = (SHM_LAYOUT_MAJOR + 1) << 16;
        assert_int_equal(shm_layout_check_in(h, size), -EPROTO);
        header_make(h);
        h->layout_version = SHM_LAYOUT_VERSION + 1;                     /* minor: fine */
        assert_int_equal(shm_layout_check_in(h, size), 0);
        header_make(h);
        h->slot_size = 64;
        assert_int_equal(shm_layout_check_in(h, size), -EPROTO);
        header_make(h);
        h->event_capacity = 24;                                         /* not a power of two */
        assert_int_equal(shm_layout_check_in(h, size), -EPROTO);
        header_make(h);
        h->dir_offset += 64;
        assert_int_equal(shm_layout_check_in(h, size), -EPROTO);
        header_make(h);
        h->out_capacity = 5;                                            /* > capacity */
        assert_int_equal(shm_layout_check_in(h, size), -EPROTO);
        free(h);
}

static void test_check_out(void **state)
{
        struct shm_out_header h;
        struct shm_out_geometry g;
        uint64_t size;

        (void)state;
        shm_layout_out_geometry(2, &g);
        size = g.object_size;
        assert_int_equal(g.total_size, shm_layout_out_size(2));
        assert_true(g.touched_offset >= g.total_size && g.touched_offset % SHM_CACHE_LINE == 0);
        assert_int_equal(g.touched_words, 1);
        memset(&h, 0, sizeof(h));
        h.layout_version = SHM_LAYOUT_VERSION;
        h.header_size = sizeof(h);
        h.total_size = g.total_size;
        h.slot_size = sizeof(struct shm_slot);
        h.capacity = 2;
        h.slots_offset = sizeof(h);
        h.touched_words = g.touched_words;
        h.touched_offset = g.touched_offset;
        assert_int_equal(shm_layout_check_out(&h, size), -EAGAIN);
        atomic_store(&h.magic, SHM_OUT_MAGIC);
        assert_int_equal(shm_layout_check_out(&h, size), 0);
        assert_int_equal(shm_layout_has_touched(&h, size), 1);
        /* 1.6: the map cut off, or moved, is a scribbled header. */
        assert_int_equal(shm_layout_check_out(&h, size - 8), -EPROTO);
        h.touched_offset += SHM_CACHE_LINE;
        assert_int_equal(shm_layout_check_out(&h, size), -EPROTO);
        h.touched_offset = g.touched_offset;
        /* A 1.5 object: no map, and the slots are all it needs. */
        h.layout_version = (SHM_LAYOUT_MAJOR << 16) | SHM_LAYOUT_MINOR_RETIRE;
        assert_int_equal(shm_layout_check_out(&h, g.total_size), 0);
        assert_int_equal(shm_layout_has_touched(&h, size), 0);
        h.layout_version = SHM_LAYOUT_VERSION;
        assert_int_equal(shm_layout_check_out(&h, g.total_size - 8), -EPROTO);
        h.capacity = 3;
        assert_int_equal(shm_layout_check_out(&h, size), -EPROTO);
        h.capacity = 2;
        atomic_store(&h.magic, 0x1234);
        assert_int_equal(shm_layout_check_out(&h, size), -EPROTO);
}

static void test_value_charset(void **state)
{
        char v[2] = { 0, 0 };

        (void)state;
        /* Every byte value: accepted exactly when printable ASCII and not | [ ]. */
        for (int b = 0; b < 256; b++) {
                int want = b >= 0x20 && b <= 0x7e && b != '|' && b != '[' && b != ']';

                v[0] = (char)b;
                assert_int_equal(shm_layout_value_char(b), want);
                assert_int_equal(shm_layout_value_check(v, 1), want ? 0 : -EINVAL);
        }
}

/*
 * The check works a word at a time: every byte value at every position of every length, among
 * valid neighbours, and bad bytes just past the length (which must not count).
 */
static void test_value_charset_positions(void **state)
{
        char v[SHM_VALUE_SIZE + 8];

        (void)state;
        for (size_t len = 1; len <= SHM_VALUE_MAX; len++) {
                for (size_t pos = 0; pos < len; pos++) {
                        for (int b = 0; b < 256; b++) {
                                int want = shm_layout_value_char(b);

                                memset(v, '~', sizeof(v));
                                memset(v + len, '|', sizeof(v) - len);  /* beyond: ignored */
                                v[pos] = (char)b;
                                assert_int_equal(shm_layout_value_check(v, len),
                                                 want ? 0 : -EINVAL);
                                assert_int_equal(shm_layout_value_check_field(v, len),
                                                 want ? 0 : -EINVAL);
                        }
                }
                memset(v, ' ', sizeof(v));
                v[len] = '\0';
                v[len + 1] = (char)0x80;
                assert_int_equal(shm_layout_value_check(v, len), 0);
                assert_int_equal(shm_layout_value_check_field(v, len), 0);
        }
}

static void test_value_length(void **state)
{
        char v[SHM_VALUE_SIZE + 1];

        (void)state;
        memset(v, 'x', sizeof(v));
        assert_int_equal(shm_layout_value_check(v, 0), 0);
        assert_int_equal(shm_layout_value_check(v, SHM_VALUE_MAX), 0);
        assert_int_equal(shm_layout_value_check(v, SHM_VALUE_MAX + 1), -EINVAL);
        assert_int_equal(shm_layout_value_check_field(v, SHM_VALUE_MAX), 0);
        assert_int_equal(shm_layout_value_check_field(v, SHM_VALUE_MAX + 1), -EINVAL);
        assert_int_equal(shm_layout_value_check("a b-1.5e3 ,;:", 13), 0);
}

static void test_names(void **state)
{
        static const struct { const char *name; int ok; } names[] = {
                { "AutoGpsLat", 1 }, { "agility.device.E1E1E1.signal", 1 }, { "x", 1 },
                { "", 0 }, { "has space", 0 }, { "pipe|", 0 }, { "[x", 0 }, { "x]", 0 },
                { "tab\t", 0 }, { "\x7f", 0 }, { "\xc3\xa9", 0 },
                { "12345678901234567890123456789012345678901234567", 1 },      /* 47 */
                { "123456789012345678901234567890123456789012345678", 0 },     /* 48 */
        };
        static const struct { const char *name; int ok; } instances[] = {
                { "default", 1 }, { "demo-1_a", 1 }, { "_x", 1 }, { "", 0 }, { ".hidden", 0 },
                { "a.b", 0 }, { "-x", 0 }, { "a/b", 0 }, { "a b", 0 }, { "x:y", 0 },
                { "12345678901234567890123456789012", 1 },                    /* 32 */
                { "123456789012345678901234567890123", 0 },                   /* 33 */
        };
        char obj[SHM_OBJECT_NAME_SIZE];

        (void)state;
        for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++)
                assert_int_equal(shm_layout_name_check(names[i].name), names[i].ok ? 0 : -EINVAL);
        assert_int_equal(shm_layout_name_check(NULL), -EINVAL);
        for (size_t i = 0; i < sizeof(instances) / sizeof(instances[0]); i++)
                assert_int_equal(shm_layout_instance_check(instances[i].name),
                                 instances[i].ok ? 0 : -EINVAL);
        assert_int_equal(shm_layout_object_name("demo", "in", obj, sizeof(obj)), 0);
        assert_string_equal(obj, "/sharedlink.demo.in");
        assert_int_equal(shm_layout_object_name("demo", "in", obj, 10), -ENAMETOOLONG);
        assert_int_equal(shm_layout_object_name("a/b", "in", obj, sizeof(obj)), -EINVAL);
}

static void test_name_tables(void **state)
{
        (void)state;
        assert_string_equal(shm_layout_counter_name(SHM_COUNTER_FRAMES_IN), "frames_in");
        assert_string_equal(shm_layout_counter_name(SHM_COUNTER_TX_DROPPED), "tx_dropped");
        assert_null(shm_layout_counter_name(SHM_COUNTER_COUNT));
        for (unsigned i = 0; i < SHM_COUNTER_COUNT; i++) {
                assert_non_null(shm_layout_counter_name(i));
                for (unsigned j = 0; j < i; j++)        /* names are unique */
                        assert_string_not_equal(shm_layout_counter_name(i), shm_layout_counter_name(j));
        }
        assert_string_equal(shm_layout_event_name(SHM_EVENT_ACTION), "action");
        assert_string_equal(shm_layout_event_name(SHM_EVENT_DEVICE_OFFLINE), "device-offline");
        assert_string_equal(shm_layout_event_name(SHM_EVENT_LINK_STATE), "link-state");
        assert_string_equal(shm_layout_event_name(9999), "unknown");
        assert_string_equal(shm_layout_type_name(SHM_TYPE_DOUBLE), "double");
        assert_string_equal(shm_layout_type_name(7), "unknown");
}

/* ---- seqlock primitives -------------------------------------------------------------------- */

static void test_seqlock_single_writer(void **state)
{
        _Atomic uint64_t seq = 0;
        uint64_t start, odd;

        (void)state;
        start = shm_seqlock_read_begin(&seq);
        assert_false(shm_seqlock_odd(start));
        assert_false(shm_seqlock_read_retry(&seq, start));
        odd = shm_seqlock_write_begin(&seq);
        assert_true(shm_seqlock_odd(odd));
        assert_true(shm_seqlock_odd(shm_seqlock_read_begin(&seq)));
        assert_true(shm_seqlock_read_retry(&seq, start));       /* a write started: retry */
        shm_seqlock_write_end(&seq, odd);
        assert_int_equal(atomic_load(&seq), 2);
        assert_true(shm_seqlock_read_retry(&seq, start));       /* and finished: still retry */
}

static void test_seqlock_claim(void **state)
{
        _Atomic uint64_t seq = 0;
        uint64_t word, seen, other;

        (void)state;
        assert_int_equal(shm_seqlock_claim(&seq, 1234, &word, &seen), 0);
        assert_true(shm_seqlock_odd(word));
        assert_int_equal(shm_seqlock_pid(word), 1234);
        assert_int_equal(shm_seqlock_sequence(word), 1);
        assert_int_equal(shm_seqlock_claim(&seq, 99, &other, &seen), -EBUSY);  /* held */
        assert_int_equal(seen, word);
        assert_int_equal(shm_seqlock_release(&seq, word), 0);
        assert_int_equal(shm_seqlock_sequence(atomic_load(&seq)), 2);
        assert_int_equal(shm_seqlock_pid(atomic_load(&seq)), 1234);    /* last writer kept */
        assert_int_equal(shm_seqlock_release(&seq, word), -ECANCELED);  /* not held any more */

        /* The 32-bit sequence wraps without touching the pid half. */
        atomic_store(&seq, ((uint64_t)7 << 32) | 0xfffffffeu);
        assert_int_equal(shm_seqlock_claim(&seq, 8, &word, &seen), 0);
        assert_int_equal(shm_seqlock_sequence(word), 0xffffffffu);
        assert_int_equal(shm_seqlock_release(&seq, word), 0);
        assert_int_equal(atomic_load(&seq), (uint64_t)8 << 32);
}

/* ---- slots --------------------------------------------------------------------------------- */

static void test_slot_write_read(void **state)
{
        struct shm_slot *slot = aligned_alloc(64, sizeof(*slot));
        struct shm_slot_copy c;

        (void)state;
        memset(slot, 0, sizeof(*slot));
        assert_int_equal(shm_slot_read(slot, &c), 0);
        assert_int_equal(c.flags, 0);
        assert_int_equal(c.length, 0);
        shm_slot_write(slot, "a much longer value than the next", 33, SHM_SLOT_VALID, 11, 22);
        shm_slot_write(slot, "40.5", 4, SHM_SLOT_VALID, 33, 44);
        assert_int_equal(shm_slot_read(slot, &c), 0);
        assert_int_equal(c.word, 4);
        assert_int_equal(c.length, 4);
        assert_int_equal(c.mono_ns, 33);
        assert_int_equal(c.real_ns, 44);
        assert_int_equal(c.flags, SHM_SLOT_VALID);
        /* NUL-padded: nothing of the longer, older value is left behind the terminator. */
        for (unsigned i = 4; i < SHM_VALUE_SIZE; i++)
                assert_int_equal(c.value[i], 0);
        assert_memory_equal(c.value, "40.5", 5);
        assert_int_equal(shm_slot_copy_check(&c), 0);
        shm_slot_write_flags(slot, SHM_SLOT_VALID | SHM_SLOT_STALE);
        assert_int_equal(shm_slot_read(slot, &c), 0);
        assert_int_equal(c.flags, SHM_SLOT_VALID | SHM_SLOT_STALE);
        assert_memory_equal(c.value, "40.5", 5);
        free(slot);
}

/* shm_slot_read_to: the value goes to the caller's buffer, the rest to the head. */
static void test_slot_read_to(void **state)
{
        struct shm_slot *slot = aligned_alloc(64, sizeof(*slot));
        struct shm_slot_head c;
        char value[SHM_VALUE_SIZE];
        uint64_t word;

        (void)state;
        memset(slot, 0, sizeof(*slot));
        shm_slot_write(slot, "a much longer value than the next", 33, SHM_SLOT_VALID, 11, 22);
        shm_slot_write(slot, "40.5", 4, SHM_SLOT_VALID, 33, 44);
        memset(&c, 'x', sizeof(c));
        memset(value, 'y', sizeof(value));
        assert_int_equal(shm_slot_read_to(slot, &c, value), 0);
        assert_int_equal(c.word, 4);
        assert_int_equal(c.length, 4);
        assert_int_equal(c.mono_ns, 33);
        assert_int_equal(c.real_ns, 44);
        assert_int_equal(c.flags, SHM_SLOT_VALID);
        assert_memory_equal(value, "40.5", 5);
        for (unsigned i = 4; i < SHM_VALUE_SIZE; i++)
                assert_int_equal(value[i], 0);
        assert_int_equal(shm_slot_head_check(&c, value), 0);
        value[1] = '|';                 /* not a wire byte */
        assert_int_equal(shm_slot_head_check(&c, value), -EINVAL);
        /* Odd for every attempt: -EAGAIN, as shm_slot_read. */
        assert_int_equal(shm_slot_claim(slot, 7, &word), 0);
        assert_int_equal(shm_slot_read_to(slot, &c, value), -EAGAIN);
        assert_int_equal(shm_slot_publish(slot, word), 0);
        assert_int_equal(shm_slot_read_to(slot, &c, value), 0);
        free(slot);
}

static void test_slot_odd_never_handed_out(void **state)
{
        struct shm_slot *slot = aligned_alloc(64, sizeof(*slot));
        struct shm_slot_copy c;
        uint64_t word;

        (void)state;
        memset(slot, 0, sizeof(*slot));
        shm_slot_write(slot, "old", 3, SHM_SLOT_VALID, 1, 1);
        assert_int_equal(shm_slot_claim(slot, 4242, &word), 0);
        shm_slot_store_word(slot, 0, 0x2e2e2e2e2e2e2e2eull);            /* half a new value */
        assert_int_equal(shm_slot_read(slot, &c), -EAGAIN);             /* nothing handed out */
        assert_int_equal(shm_slot_claim(slot, 4343, &word) == -EBUSY, 1);
        free(slot);
}

static void test_slot_claim_publish_repair(void **state)
{
        struct shm_slot *slot = aligned_alloc(64, sizeof(*slot));
        struct shm_slot_copy c;
        uint64_t word, odd;

        (void)state;
        memset(slot, 0, sizeof(*slot));
        assert_int_equal(shm_slot_claim(slot, 100, &word), 0);
        shm_slot_store(slot, "12", 2, SHM_SLOT_VALID, 5, 6);
        assert_int_equal(shm_slot_publish(slot, word), 0);
        assert_int_equal(shm_slot_read(slot, &c), 0);
        assert_int_equal(shm_slot_copy_check(&c), 0);
        assert_int_equal(shm_seqlock_pid(c.word), 100);

        /* A writer dies half-way: the daemon repairs, the value is marked not valid. */
        assert_int_equal(shm_slot_claim(slot, 101, &odd), 0);
        shm_slot_store_word(slot, 0, 0x3939393939393939ull);
        assert_int_equal(shm_slot_repair(slot, odd + 2, 1, 7, 8), -EAGAIN);    /* stale word */
        assert_int_equal(shm_slot_repair(slot, odd, 1, 7, 8), 0);
        assert_int_equal(shm_slot_read(slot, &c), 0);
        assert_false(shm_seqlock_odd(c.word));
        assert_int_equal(c.flags, SHM_SLOT_REPAIRED);
        assert_int_equal(c.length, SHM_SLOT_LENGTH_NONE);
        assert_int_equal(shm_slot_copy_check(&c), -EINVAL);
        /* The writer was only stopped: it comes back, stores the rest of its value (the lock no
         * longer its), and learns its write was abandoned. Half a value never looks valid. */
        shm_slot_store_word(slot, 1, 0x3939393939393939ull);
        atomic_store(&slot->flags, SHM_SLOT_VALID);
        assert_int_equal(shm_slot_read(slot, &c), 0);
        assert_int_equal(shm_slot_copy_check(&c), -EINVAL);
        assert_int_equal(shm_slot_publish(slot, odd), -ECANCELED);
        /* And the slot is usable again. */
        assert_int_equal(shm_slot_claim(slot, 102, &word), 0);
        shm_slot_store(slot, "13", 2, SHM_SLOT_VALID, 9, 9);
        assert_int_equal(shm_slot_publish(slot, word), 0);
        assert_int_equal(shm_slot_read(slot, &c), 0);
        assert_int_equal(shm_slot_copy_check(&c), 0);
        free(slot);
}

static void test_slot_copy_check(void **state)
{
        struct shm_slot_copy c;

        (void)state;
        memset(&c, 0, sizeof(c));
        c.flags = SHM_SLOT_VALID;
        c.length = 3;
        memcpy(c.value, "abc", 4);
        assert_int_equal(shm_slot_copy_check(&c), 0);
        c.flags = 0;
        assert_int_equal(shm_slot_copy_check(&c), -EINVAL);             /* not valid */
        c.flags = SHM_SLOT_VALID;
        c.value[3] = 'd';
        assert_int_equal(shm_slot_copy_check(&c), -EINVAL);             /* no terminator */
        c.value[3] = 0;
        c.length = SHM_VALUE_SIZE;
        assert_int_equal(shm_slot_copy_check(&c), -EINVAL);             /* too long */
        c.length = UINT32_MAX;
        assert_int_equal(shm_slot_copy_check(&c), -EINVAL);
        c.length = 3;
        for (int b = 0; b < 256; b++) {
                c.value[1] = (char)b;
                assert_int_equal(shm_slot_copy_check(&c) == 0, shm_layout_value_char(b));
        }
}

/* ---- event ring ---------------------------------------------------------------------------- */

#define RING 16u

struct ring {
        struct shm_event ev[RING];
        _Atomic uint64_t head;
};

static void test_events_in_order(void **state)
{
        struct ring *r = calloc(1, sizeof(*r));
        struct shm_event_copy e;
        uint64_t cursor = 0;
        char text[32];

        (void)state;
        assert_int_equal(shm_events_read(r->ev, RING, &r->head, &cursor, &e), 0);
        for (unsigned i = 1; i <= 5; i++) {
                snprintf(text, sizeof(text), "n=%u", i);
                assert_int_equal(shm_events_write(r->ev, RING, &r->head, SHM_EVENT_ACTION, 2, text,
                                                  i * 10, i * 100), i);
        }
        for (unsigned i = 1; i <= 5; i++) {
                assert_int_equal(shm_events_read(r->ev, RING, &r->head, &cursor, &e), 1);
                snprintf(text, sizeof(text), "n=%u", i);
                assert_int_equal(e.number, i);
                assert_int_equal(e.lost, 0);
                assert_int_equal(e.type, SHM_EVENT_ACTION);
                assert_int_equal(e.link, 2);
                assert_int_equal(e.mono_ns, i * 10);
                assert_string_equal(e.text, text);
                assert_int_equal(cursor, i);
        }
        assert_int_equal(shm_events_read(r->ev, RING, &r->head, &cursor, &e), 0);
        free(r);
}

static void test_events_overrun(void **state)
{
        struct ring *r = calloc(1, sizeof(*r));
        struct shm_event_copy e;
        uint64_t cursor = 3;

        (void)state;
        for (unsigned i = 1; i <= 40; i++)
                shm_events_write(r->ev, RING, &r->head, SHM_EVENT_LOG, SHM_LINK_NONE, "x", i, i);
        /* Cursor at 3, head 40, 16 retained (25..40): 4..24 were lost and the reader is told. */
        assert_int_equal(shm_events_read(r->ev, RING, &r->head, &cursor, &e), 1);
        assert_int_equal(e.number, 25);
        assert_int_equal(e.lost, 21);
        assert_int_equal(shm_events_read(r->ev, RING, &r->head, &cursor, &e), 1);
        assert_int_equal(e.number, 26);
        assert_int_equal(e.lost, 0);
        /* A cursor ahead of the producer does not belong to this ring. */
        cursor = 1000;
        assert_int_equal(shm_events_read(r->ev, RING, &r->head, &cursor, &e), -ESTALE);
        free(r);
}

static void test_events_truncated(void **state)
{
        struct ring *r = calloc(1, sizeof(*r));
        char text[SHM_EVENT_TEXT_SIZE + 50];
        struct shm_event_copy e;
        uint64_t cursor = 0;

        (void)state;
        memset(text, 'k', sizeof(text) - 1);
        text[sizeof(text) - 1] = '\0';
        shm_events_write(r->ev, RING, &r->head, SHM_EVENT_LOG, 0, text, 1, 1);
        shm_events_write(r->ev, RING, &r->head, SHM_EVENT_LOG, 0, NULL, 1, 1);
        assert_int_equal(shm_events_read(r->ev, RING, &r->head, &cursor, &e), 1);
        assert_int_equal(e.flags, SHM_EVENT_TRUNCATED);
        assert_int_equal(strlen(e.text), SHM_EVENT_TEXT_SIZE - 1);
        assert_int_equal(shm_events_read(r->ev, RING, &r->head, &cursor, &e), 1);
        assert_int_equal(e.flags, 0);
        assert_string_equal(e.text, "");
        free(r);
}

/* ---- futex across processes ---------------------------------------------------------------- */

struct futex_child {
        _Atomic uint32_t *word;
        uint32_t expected;
};

static int futex_waiter(void *arg)
{
        struct futex_child *f = arg;

        for (;;) {
                if (atomic_load(f->word) != f->expected)
                        return 0;
                if (shm_futex_wait(f->word, f->expected, POLL_LIMIT_MS) == -ETIMEDOUT)
                        return 1;
        }
}

static void test_futex_shared(void **state)
{
        _Atomic uint32_t *word = mmap(NULL, 4096, PROT_READ | PROT_WRITE,
                                      MAP_SHARED | MAP_ANONYMOUS, -1, 0);
        struct futex_child f;
        pid_t pid;

        (void)state;
        assert_ptr_not_equal(word, MAP_FAILED);
        atomic_store(word, 5);
        assert_int_equal(shm_futex_wait(word, 6, 0), -EAGAIN);          /* differs already */
        assert_int_equal(shm_futex_wait(word, 5, 1), -ETIMEDOUT);
        assert_int_equal(shm_futex_wake(word, 1), 0);                   /* nobody waits */
        f.word = word;
        f.expected = 5;
        pid = shmtest_fork(futex_waiter, &f);
        atomic_store(word, 6);
        assert_true(shm_futex_wake(word, 1) >= 0);
        assert_int_equal(shmtest_wait(pid), 0);
        munmap((void *)(uintptr_t)word, 4096);
}

/* ---- SIGBUS guard ------------------------------------------------------------------------- */

struct guard_read {
        const volatile char *p;
        size_t n;
        unsigned sum;
};

static void guard_read_fn(void *arg)
{
        struct guard_read *g = arg;

        for (size_t i = 0; i < g->n; i++)
                g->sum += (unsigned char)g->p[i];
}

static void test_guard_sigbus(void **state)
{
        char name[64];
        struct guard_read g;
        long page = sysconf(_SC_PAGESIZE);
        char *map;
        int fd;

        (void)state;
        assert_int_equal(shm_guard_install(), 0);
        snprintf(name, sizeof(name), "/sharedlink-test-guard-%d", (int)getpid());
        fd = shm_open(name, O_RDWR | O_CREAT | O_EXCL, 0600);
        assert_true(fd >= 0);
        shm_unlink(name);
        assert_int_equal(ftruncate(fd, 2 * page), 0);
        map = mmap(NULL, (size_t)(2 * page), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
        assert_ptr_not_equal(map, MAP_FAILED);
        memset(map, 1, (size_t)(2 * page));
        g = (struct guard_read){ map, (size_t)(2 * page), 0 };
        assert_int_equal(shm_guard_run(guard_read_fn, &g), 0);
        assert_int_equal(g.sum, 2 * page);
        /* Truncated under the mapping: touching it raises SIGBUS, the guard turns it into -EFAULT,
         * more than once (the signal must not stay blocked after the jump). */
        assert_int_equal(ftruncate(fd, page / 2), 0);
        for (int round = 0; round < 3; round++) {
                g = (struct guard_read){ map, (size_t)(2 * page), 0 };
                assert_int_equal(shm_guard_run(guard_read_fn, &g), -EFAULT);
                /* Bytes up to the new end read back, the rest of that page reads as zero, and
                 * the next page faulted. */
                assert_int_equal(g.sum, (unsigned)(page / 2));
        }
        /* Grown back: readable again. */
        assert_int_equal(ftruncate(fd, 2 * page), 0);
        g = (struct guard_read){ map, (size_t)(2 * page), 0 };
        assert_int_equal(shm_guard_run(guard_read_fn, &g), 0);
        munmap(map, (size_t)(2 * page));
        close(fd);
}

static int unguarded_child(void *arg)
{
        volatile char *p = arg;

        /* Our handler in front of the default action (cmocka installs its own for each test). */
        signal(SIGBUS, SIG_DFL);
        if (shm_guard_install() < 0)
                return 2;
        return p[0];    /* no guard armed: must die of SIGBUS as without the handler */
}

static void test_guard_unarmed_still_fatal(void **state)
{
        char name[64];
        long page = sysconf(_SC_PAGESIZE);
        char *map;
        int fd;

        (void)state;
        assert_int_equal(shm_guard_install(), 0);
        snprintf(name, sizeof(name), "/sharedlink-test-guard2-%d", (int)getpid());
        fd = shm_open(name, O_RDWR | O_CREAT | O_EXCL, 0600);
        assert_true(fd >= 0);
        shm_unlink(name);
        assert_int_equal(ftruncate(fd, page), 0);
        map = mmap(NULL, (size_t)page, PROT_READ, MAP_SHARED, fd, 0);
        assert_ptr_not_equal(map, MAP_FAILED);
        assert_int_equal(ftruncate(fd, 0), 0);
        assert_int_equal(shmtest_wait(shmtest_fork(unguarded_child, map)), 128 + SIGBUS);
        munmap(map, (size_t)page);
        close(fd);
}

/* ---- wake thread --------------------------------------------------------------------------- */

struct bump {
        _Atomic uint32_t *word;
};

static int bump_child(void *arg)
{
        struct bump *b = arg;

        atomic_fetch_add(b->word, 1);
        return shm_futex_wake(b->word, 1) >= 0 ? 0 : 1;
}

static int fd_readable(int fd)
{
        struct pollfd p = { .fd = fd, .events = POLLIN };

        return poll(&p, 1, POLL_LIMIT_MS) == 1 && (p.revents & POLLIN);
}

static void test_wake_thread(void **state)
{
        _Atomic uint32_t *words = mmap(NULL, 4096, PROT_READ | PROT_WRITE,
                                       MAP_SHARED | MAP_ANONYMOUS, -1, 0);
        struct shm_wake *w;
        struct bump b;

        (void)state;
        assert_int_equal(shm_guard_install(), 0);
        assert_int_equal(shm_wake_start(&w), 0);
        assert_int_equal(shm_wake_ack(w), 0);                           /* nothing yet */
        shm_wake_watch(w, &words[0]);
        b.word = &words[0];
        assert_int_equal(shmtest_wait(shmtest_fork(bump_child, &b)), 0);
        assert_true(fd_readable(shm_wake_fd(w)));
        assert_int_equal(shm_wake_ack(w), 1);
        assert_int_equal(shm_wake_ack(w), 0);
        /* Re-pointed: the new word's current value is the baseline, its changes signal. */
        atomic_store(&words[16], 77);
        shm_wake_watch(w, &words[16]);
        b.word = &words[16];
        assert_int_equal(shmtest_wait(shmtest_fork(bump_child, &b)), 0);
        assert_true(fd_readable(shm_wake_fd(w)));
        assert_int_equal(shm_wake_ack(w), 1);
        shm_wake_watch(w, NULL);
        munmap((void *)(uintptr_t)words, 4096);        /* safe after watch(NULL) */
        assert_null(shm_wake_stop(w));
        assert_null(shm_wake_stop(NULL));
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_geometry),
                cmocka_unit_test(test_check_in),
                cmocka_unit_test(test_check_out),
                cmocka_unit_test(test_value_charset),
                cmocka_unit_test(test_value_charset_positions),
                cmocka_unit_test(test_value_length),
                cmocka_unit_test(test_names),
                cmocka_unit_test(test_name_tables),
                cmocka_unit_test(test_seqlock_single_writer),
                cmocka_unit_test(test_seqlock_claim),
                cmocka_unit_test(test_slot_write_read),
                cmocka_unit_test(test_slot_read_to),
                cmocka_unit_test(test_slot_odd_never_handed_out),
                cmocka_unit_test(test_slot_claim_publish_repair),
                cmocka_unit_test(test_slot_copy_check),
                cmocka_unit_test(test_events_in_order),
                cmocka_unit_test(test_events_overrun),
                cmocka_unit_test(test_events_truncated),
                cmocka_unit_test(test_futex_shared),
                cmocka_unit_test(test_guard_sigbus),
                cmocka_unit_test(test_guard_unarmed_still_fatal),
                cmocka_unit_test(test_wake_thread),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
