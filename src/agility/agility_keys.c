/*
 * sharedlink-agility: remote-control keys into presses and competitor numbers (agility_keys.h).
 */
#include <errno.h>
#include <string.h>

#include "agility/agility_keys.h"
#include "proto/circe.h"

#define MODIFIERS (CIRCE_KEY_ENTER_CURRENT | CIRCE_KEY_ENTER_NEXT)
#define KEY_BITS 16
#define DECIMAL 10

/* Digit keys in the order of their digits 0..9 (Input Keys, PROTOCOLS.md 2.3). */
static const uint16_t digit_keys[DECIMAL] = {
        CIRCE_KEY_0, CIRCE_KEY_1, CIRCE_KEY_2, CIRCE_KEY_3, CIRCE_KEY_4,
        CIRCE_KEY_5, CIRCE_KEY_6, CIRCE_KEY_7, CIRCE_KEY_8, CIRCE_KEY_9,
};

void agility_keys_init(struct agility_keys *k)
{
        memset(k, 0, sizeof(*k));
}

int agility_keys_digit(uint16_t key)
{
        for (int d = 0; d < DECIMAL; d++)
                if (digit_keys[d] == key)
                        return d;
        return -1;
}

static struct agility_keys_device *device_slot(struct agility_keys *k, uint32_t address)
{
        for (unsigned i = 0; i < k->device_count; i++)
                if (k->devices[i].address == address)
                        return &k->devices[i];
        if (k->device_count == AGILITY_KEYS_DEVICES_MAX)
                return NULL;
        k->devices[k->device_count] = (struct agility_keys_device){ .address = address };
        return &k->devices[k->device_count++];
}

static void emit(struct agility_key_event *ev, unsigned *n, struct agility_key_event e)
{
        if (*n < AGILITY_KEY_EVENTS_MAX)
                ev[(*n)++] = e;
}

static uint16_t modifier_of(bool current)
{
        return current ? CIRCE_KEY_ENTER_CURRENT : CIRCE_KEY_ENTER_NEXT;
}

static void begin_entries(struct agility_keys *k, uint32_t device, uint16_t pressed,
                          struct agility_key_event *ev, unsigned *n)
{
        /* Current before next when both go down at once: the lower bit, as the reference
         * walks its table; the second finds the entry taken. */
        for (int pass = 0; pass < 2; pass++) {
                bool current = pass == 0;

                if (!(pressed & modifier_of(current)) || k->entering)
                        continue;
                k->entering = true;
                k->entry_current = current;
                k->entry_owner = device;
                k->entry_digits = 0;
                k->entry_number = 0;
                emit(ev, n, (struct agility_key_event){ .kind = AGILITY_KEY_ENTRY_BEGIN,
                                                       .current = current });
        }
}

static void add_digit(struct agility_keys *k, int digit, struct agility_key_event *ev,
                      unsigned *n)
{
        if (k->entry_digits == AGILITY_NUMBER_DIGITS_MAX)
                return;                 /* the reference drops digits past the third */
        k->entry_digits++;
        k->entry_number = (uint16_t)(k->entry_number * DECIMAL + (uint16_t)digit);
        /* Leading zeros are digits too ("007" is 7), but show nothing until the number is
         * non-zero, as the reference does. */
        if (k->entry_number > 0)
                emit(ev, n, (struct agility_key_event){ .kind = AGILITY_KEY_ENTRY_DIGIT,
                                                       .current = k->entry_current,
                                                       .number = k->entry_number });
}

int agility_keys_feed(struct agility_keys *k, uint32_t device, uint16_t keys, bool keypad,
                      struct agility_key_event *ev, unsigned *ret_count)
{
        struct agility_keys_device *d = device_slot(k, device);
        unsigned n = 0;

        if (!d)
                return -ENOSPC;
        uint16_t pressed = (uint16_t)(keys & ~d->held);
        uint16_t released = (uint16_t)(d->held & ~keys);

        d->held = keys;
        if (keypad)
                begin_entries(k, device, pressed, ev, &n);
        for (int bit = 0; bit < KEY_BITS; bit++) {
                uint16_t key = (uint16_t)(1u << bit);
                int digit = agility_keys_digit(key);

                if (!(pressed & key) || (keypad && (key & MODIFIERS)))
                        continue;
                if (keypad && digit >= 0 && (keys & MODIFIERS)) {
                        /* A digit while a modifier is held is never a command; it counts
                         * when it is the entry's own device and modifier. */
                        if (k->entering && k->entry_owner == device &&
                            (keys & modifier_of(k->entry_current)))
                                add_digit(k, digit, ev, &n);
                        continue;
                }
                emit(ev, &n, (struct agility_key_event){ .kind = AGILITY_KEY_PRESS, .key = key });
        }
        if (keypad && k->entering && k->entry_owner == device &&
            (released & modifier_of(k->entry_current))) {
                k->entering = false;
                emit(ev, &n, (struct agility_key_event){ .kind = AGILITY_KEY_ENTRY_END,
                                                       .current = k->entry_current,
                                                       .number = k->entry_number });
        }
        *ret_count = n;
        return 0;
}
