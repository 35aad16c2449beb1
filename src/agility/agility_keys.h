/*
 * sharedlink-agility: remote-control keys (CIRCE Input Keys, 024) into presses and competitor
 * numbers (docs/agility.md "Keys").
 *
 * A Notify Action carries the bitmask of the keys held down. A press is a bit that goes from 0
 * to 1 since the device's previous bitmask; a release does nothing (but ends a number entry).
 * While "enter current competitor" (512) or "enter next competitor" (1024) is held on a keypad,
 * the digit keys build a number of at most AGILITY_NUMBER_DIGITS_MAX digits instead of acting as
 * commands; releasing the modifier ends the entry (a number of 0, or no digit, cancels it). The
 * device that pressed the modifier first owns the entry until it releases it.
 *
 * Pure code: no syscalls, no allocation, no logging.
 */
#ifndef SHAREDLINK_AGILITY_KEYS_H
#define SHAREDLINK_AGILITY_KEYS_H

#include <stdbool.h>
#include <stdint.h>

/* Devices whose key state is kept: the class's keypads and gates. */
#define AGILITY_KEYS_DEVICES_MAX 16

/* A competitor number has at most 3 digits (1..999); further digits are dropped. */
#define AGILITY_NUMBER_DIGITS_MAX 3

/* One bitmask yields at most 16 presses, one entry begin and one entry end. */
#define AGILITY_KEY_EVENTS_MAX 18

enum agility_key_event_kind {
        AGILITY_KEY_PRESS,              /* key: one CIRCE_KEY_* bit, pressed as a command */
        AGILITY_KEY_ENTRY_BEGIN,        /* current: entering the current (else next) competitor */
        AGILITY_KEY_ENTRY_DIGIT,        /* number: the number so far */
        AGILITY_KEY_ENTRY_END,          /* number: the number entered, 0 when cancelled */
};

struct agility_key_event {
        enum agility_key_event_kind kind;
        uint16_t key;                   /* AGILITY_KEY_PRESS */
        bool current;                   /* ENTRY_*: the current competitor (else the next) */
        uint16_t number;                /* ENTRY_DIGIT, ENTRY_END */
};

struct agility_keys_device {
        uint32_t address;
        uint16_t held;                  /* the last bitmask */
};

struct agility_keys {
        struct agility_keys_device devices[AGILITY_KEYS_DEVICES_MAX];
        unsigned device_count;
        bool entering;                  /* a number entry is open */
        bool entry_current;             /* ... for the current competitor (else the next) */
        uint32_t entry_owner;           /* ... by this device */
        unsigned entry_digits;
        uint16_t entry_number;
};

/* Empties k: no device, no key held, no entry. */
void agility_keys_init(struct agility_keys *k);

/*
 * Feeds the bitmask keys from device: the events it means, in the reference controller's order
 * (modifier presses, key presses in ascending bit order, modifier releases), into ev (room for
 * AGILITY_KEY_EVENTS_MAX) and their number into *ret_count. Only a keypad enters numbers: for
 * another device every press is an AGILITY_KEY_PRESS (its owner decides what it may do).
 * Returns 0, or -ENOSPC when AGILITY_KEYS_DEVICES_MAX other devices are already known (nothing
 * is reported and nothing changes).
 */
int agility_keys_feed(struct agility_keys *k, uint32_t device, uint16_t keys, bool keypad,
                      struct agility_key_event *ev, unsigned *ret_count);

/* The digit a key stands for (0..9), or -1 when it is not a digit key. */
int agility_keys_digit(uint16_t key);

#endif
