/*
 * sharedlink-agility keys (src/agility/agility_keys.c): a press is a 0 -> 1 bit per device,
 * a release does nothing, several presses come out in ascending bit order, and number entry
 * while 512 or 1024 is held (at most 3 digits, 0 cancels, digits are not commands, only the
 * owning keypad's digits count, no entry on a device that is not a keypad).
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "agility/agility_keys.h"
#include "proto/circe.h"

#define REMOTE 0xAAAAAAu
#define REMOTE2 0xBBBBBBu
#define GATE 0xE1E1E1u

struct fed {
        struct agility_key_event ev[AGILITY_KEY_EVENTS_MAX];
        unsigned n;
};

static struct fed feed(struct agility_keys *k, uint32_t dev, uint16_t keys, bool keypad)
{
        struct fed f;

        memset(&f, 0, sizeof(f));
        assert_int_equal(agility_keys_feed(k, dev, keys, keypad, f.ev, &f.n), 0);
        return f;
}

static void assert_press(const struct fed *f, unsigned i, uint16_t key)
{
        assert_true(i < f->n);
        assert_int_equal(f->ev[i].kind, AGILITY_KEY_PRESS);
        assert_int_equal(f->ev[i].key, key);
}

static void test_press_release(void **state)
{
        struct agility_keys k;
        struct fed f;

        (void)state;
        agility_keys_init(&k);
        f = feed(&k, REMOTE, CIRCE_KEY_READY, true);
        assert_int_equal(f.n, 1);
        assert_press(&f, 0, CIRCE_KEY_READY);
        /* Still held (a repeated status): no second press. */
        f = feed(&k, REMOTE, CIRCE_KEY_READY, true);
        assert_int_equal(f.n, 0);
        /* Released: nothing. */
        f = feed(&k, REMOTE, 0, true);
        assert_int_equal(f.n, 0);
        /* Pressed again: a press. */
        f = feed(&k, REMOTE, CIRCE_KEY_READY, true);
        assert_int_equal(f.n, 1);
        /* Another key while Ready is held: only the new one. */
        f = feed(&k, REMOTE, CIRCE_KEY_READY | CIRCE_KEY_9, true);
        assert_int_equal(f.n, 1);
        assert_press(&f, 0, CIRCE_KEY_9);
        /* Each device has its own state. */
        f = feed(&k, REMOTE2, CIRCE_KEY_READY, true);
        assert_int_equal(f.n, 1);
}

static void test_several_ascending(void **state)
{
        struct agility_keys k;
        struct fed f;

        (void)state;
        agility_keys_init(&k);
        f = feed(&k, GATE, CIRCE_KEY_READY | CIRCE_KEY_PASS_START | CIRCE_KEY_2, false);
        assert_int_equal(f.n, 3);
        assert_press(&f, 0, CIRCE_KEY_2);
        assert_press(&f, 1, CIRCE_KEY_PASS_START);
        assert_press(&f, 2, CIRCE_KEY_READY);
        /* Not a keypad: modifiers and digits are plain presses, no entry. */
        f = feed(&k, GATE, CIRCE_KEY_ENTER_CURRENT, false);
        assert_int_equal(f.n, 1);
        assert_press(&f, 0, CIRCE_KEY_ENTER_CURRENT);
        f = feed(&k, GATE, CIRCE_KEY_ENTER_CURRENT | CIRCE_KEY_1, false);
        assert_press(&f, 0, CIRCE_KEY_1);
        assert_false(k.entering);
}

static void test_entry(void **state)
{
        const uint16_t cur = CIRCE_KEY_ENTER_CURRENT;
        struct agility_keys k;
        struct fed f;

        (void)state;
        agility_keys_init(&k);
        f = feed(&k, REMOTE, cur, true);
        assert_int_equal(f.n, 1);
        assert_int_equal(f.ev[0].kind, AGILITY_KEY_ENTRY_BEGIN);
        assert_true(f.ev[0].current);
        /* "0" first: a digit, but the number is still 0, nothing shown. */
        f = feed(&k, REMOTE, cur | CIRCE_KEY_0, true);
        assert_int_equal(f.n, 0);
        f = feed(&k, REMOTE, cur, true);
        f = feed(&k, REMOTE, cur | CIRCE_KEY_1, true);
        assert_int_equal(f.n, 1);
        assert_int_equal(f.ev[0].kind, AGILITY_KEY_ENTRY_DIGIT);
        assert_int_equal(f.ev[0].number, 1);
        /* 9 is "faults +" without a modifier; with one it is a digit only. */
        f = feed(&k, REMOTE, cur | CIRCE_KEY_9, true);
        assert_int_equal(f.n, 1);
        assert_int_equal(f.ev[0].kind, AGILITY_KEY_ENTRY_DIGIT);
        assert_int_equal(f.ev[0].number, 19);
        /* A fourth digit is dropped. */
        f = feed(&k, REMOTE, cur, true);
        f = feed(&k, REMOTE, cur | CIRCE_KEY_5, true);
        assert_int_equal(f.n, 0);
        /* A second keypad holding its own modifier adds nothing and gets no command. */
        f = feed(&k, REMOTE2, cur | CIRCE_KEY_3, true);
        assert_int_equal(f.n, 0);
        /* Ready still works while entering (command only). */
        f = feed(&k, REMOTE, cur | CIRCE_KEY_READY, true);
        assert_press(&f, 0, CIRCE_KEY_READY);
        /* Releasing the modifier ends the entry: 019 = 19. */
        f = feed(&k, REMOTE, 0, true);
        assert_int_equal(f.n, 1);
        assert_int_equal(f.ev[0].kind, AGILITY_KEY_ENTRY_END);
        assert_true(f.ev[0].current);
        assert_int_equal(f.ev[0].number, 19);
        /* The other keypad's release does not end anything. */
        f = feed(&k, REMOTE2, 0, true);
        assert_int_equal(f.n, 0);
}

static void test_entry_next_in_one_bitmask(void **state)
{
        const uint16_t next = CIRCE_KEY_ENTER_NEXT;
        struct agility_keys k;
        struct fed f;

        (void)state;
        agility_keys_init(&k);
        /* Modifier and digit in the same action: begin, then the digit. */
        f = feed(&k, REMOTE, next | CIRCE_KEY_7, true);
        assert_int_equal(f.n, 2);
        assert_int_equal(f.ev[0].kind, AGILITY_KEY_ENTRY_BEGIN);
        assert_false(f.ev[0].current);
        assert_int_equal(f.ev[1].kind, AGILITY_KEY_ENTRY_DIGIT);
        assert_int_equal(f.ev[1].number, 7);
        f = feed(&k, REMOTE, 0, true);
        assert_int_equal(f.ev[0].kind, AGILITY_KEY_ENTRY_END);
        assert_int_equal(f.ev[0].number, 7);
        /* Held and released without a digit: ends with 0 (cancelled). */
        f = feed(&k, REMOTE, next, true);
        f = feed(&k, REMOTE, 0, true);
        assert_int_equal(f.n, 1);
        assert_int_equal(f.ev[0].number, 0);
}

static void test_digits(void **state)
{
        (void)state;
        assert_int_equal(agility_keys_digit(CIRCE_KEY_0), 0);
        assert_int_equal(agility_keys_digit(CIRCE_KEY_1), 1);
        assert_int_equal(agility_keys_digit(CIRCE_KEY_4), 4);
        assert_int_equal(agility_keys_digit(CIRCE_KEY_7), 7);
        assert_int_equal(agility_keys_digit(CIRCE_KEY_9), 9);
        assert_int_equal(agility_keys_digit(CIRCE_KEY_READY), -1);
        assert_int_equal(agility_keys_digit(CIRCE_KEY_ENTER_NEXT), -1);
}

static void test_table_full(void **state)
{
        struct agility_key_event ev[AGILITY_KEY_EVENTS_MAX];
        struct agility_keys k;
        unsigned n = 99;

        (void)state;
        agility_keys_init(&k);
        for (uint32_t d = 1; d <= AGILITY_KEYS_DEVICES_MAX; d++)
                assert_int_equal(agility_keys_feed(&k, d, CIRCE_KEY_1, true, ev, &n), 0);
        assert_int_equal(agility_keys_feed(&k, REMOTE, CIRCE_KEY_1, true, ev, &n), -ENOSPC);
        /* Known devices still work. */
        assert_int_equal(agility_keys_feed(&k, 1, 0, true, ev, &n), 0);
}

int main(void)
{
        const struct CMUnitTest tests[] = {
                cmocka_unit_test(test_press_release),
                cmocka_unit_test(test_several_ascending),
                cmocka_unit_test(test_entry),
                cmocka_unit_test(test_entry_next_in_one_bitmask),
                cmocka_unit_test(test_digits),
                cmocka_unit_test(test_table_full),
        };

        return cmocka_run_group_tests(tests, NULL, NULL);
}
