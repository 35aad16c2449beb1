/*
 * sharedlink-agility: what a wireless display shows, and the Visualize (CIRCE 07) that brings
 * it from what it shows now to what it should show (docs/agility.md "Displays").
 *
 * The run engine says what the displays should show (agility_run_display); the caller keeps,
 * per display, what it last made it show, and sends only the fields that differ. A display that
 * is new or came back online is "unknown" and gets every field.
 *
 * CIRCE has no "nothing" value: a field is hidden with a value the display does not show
 * (competitor 0, placement 0, fault and refusal count 99, time 999999), as the reference
 * controller does.
 *
 * Precedence: a display applies a Visualize's fields in the order 034 028 029 030 031 038 032
 * 033 035 (PROTOCOLS.md 2.2), so a Primary Timer Value (031) in the same packet as Start Timer
 * (030) would stop the timer it just started. A running timer is therefore sent as 030 alone,
 * and a stopped time as 031 alone.
 *
 * A running timer cannot be shown mid-run to a display that was unknown: 030 starts at zero and
 * would show a wrong time, so such a display gets the timer hidden until the finish sets it (the
 * reference controller does not handle a display joining mid-run at all).
 *
 * Pure code: no syscalls, no allocation, no logging.
 */
#ifndef SHAREDLINK_AGILITY_DISPLAY_H
#define SHAREDLINK_AGILITY_DISPLAY_H

#include <stdbool.h>
#include <stdint.h>

#include <sharedlink.h>

#include "proto/circe.h"

/* Values a display does not show (reference controller, WirelessDisplayUpdateCollector). */
#define AGILITY_HIDDEN_NUMBER 0                         /* 028, 029, 035 */
#define AGILITY_HIDDEN_COUNT CIRCE_COUNT_MAX            /* 032, 033: 99 */
#define AGILITY_HIDDEN_TIME CIRCE_TIME_MS_MAX           /* 031, 038: 999999 */

/* The longest time a display can show: one below the hidden value. */
#define AGILITY_DISPLAY_TIME_MAX (AGILITY_HIDDEN_TIME - 1)

enum agility_timer {
        AGILITY_TIMER_VALUE,            /* primary_ms shown, not running (hidden: 999999) */
        AGILITY_TIMER_RUNNING,          /* running since the start of run number run */
};

struct agility_display {
        bool known;                     /* false: what it shows is unknown; send everything */
        uint16_t current;               /* 028 */
        uint16_t next;                  /* 029 */
        enum agility_timer timer;
        uint32_t primary_ms;            /* 031 when AGILITY_TIMER_VALUE */
        uint32_t run;                   /* AGILITY_TIMER_RUNNING: which start */
        uint32_t secondary_ms;          /* 038 */
        uint8_t faults;                 /* 032 */
        uint8_t refusals;               /* 033 */
        bool eliminated;                /* 034 */
        uint16_t placement;             /* 035: the previous competitor's placement */
};

/* A known display showing nothing. */
void agility_display_blank(struct agility_display *d);

/* An unknown display (a new one, or one back online): the next diff sends every field. */
void agility_display_unknown(struct agility_display *d);

/*
 * The Visualize that takes a display from shown to want into *ret_vis (size set; dests and
 * dest_count left to the caller), and what it will show after it into *ret_shown (may be
 * shown itself). Values beyond what a display shows are clamped (a time to
 * AGILITY_DISPLAY_TIME_MAX, a count to 98). Returns the number of fields set: 0 means nothing
 * to send.
 */
int agility_display_diff(const struct agility_display *shown, const struct agility_display *want,
                         struct sl_circe_visualize *ret_vis, struct agility_display *ret_shown);

#endif
