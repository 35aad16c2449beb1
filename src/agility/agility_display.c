/*
 * sharedlink-agility: display state and the Visualize between two states (agility_display.h).
 */
#include <string.h>

#include "agility/agility_display.h"

void agility_display_blank(struct agility_display *d)
{
        memset(d, 0, sizeof(*d));
        d->known = true;
        d->current = AGILITY_HIDDEN_NUMBER;
        d->next = AGILITY_HIDDEN_NUMBER;
        d->timer = AGILITY_TIMER_VALUE;
        d->primary_ms = AGILITY_HIDDEN_TIME;
        d->secondary_ms = AGILITY_HIDDEN_TIME;
        d->faults = AGILITY_HIDDEN_COUNT;
        d->refusals = AGILITY_HIDDEN_COUNT;
        d->placement = AGILITY_HIDDEN_NUMBER;
}

void agility_display_unknown(struct agility_display *d)
{
        agility_display_blank(d);
        d->known = false;
}

static uint32_t clamp_time(uint32_t ms)
{
        return ms == AGILITY_HIDDEN_TIME || ms <= AGILITY_DISPLAY_TIME_MAX ?
               ms : AGILITY_DISPLAY_TIME_MAX;
}

static uint8_t clamp_count(uint8_t n)
{
        return n == AGILITY_HIDDEN_COUNT || n < AGILITY_HIDDEN_COUNT ?
               n : AGILITY_HIDDEN_COUNT - 1;
}

static uint16_t clamp_number(uint16_t n)
{
        return n > CIRCE_COMPETITOR_MAX ? AGILITY_HIDDEN_NUMBER : n;
}

/* want with every value in what a display can show. */
static void normalise(const struct agility_display *want, struct agility_display *out)
{
        *out = *want;
        out->known = true;
        out->current = clamp_number(want->current);
        out->next = clamp_number(want->next);
        out->placement = want->placement > CIRCE_PLACEMENT_MAX ?
                         AGILITY_HIDDEN_NUMBER : want->placement;
        out->primary_ms = clamp_time(want->primary_ms);
        out->secondary_ms = clamp_time(want->secondary_ms);
        out->faults = clamp_count(want->faults);
        out->refusals = clamp_count(want->refusals);
        if (out->timer == AGILITY_TIMER_RUNNING)
                out->primary_ms = AGILITY_HIDDEN_TIME;
        else
                out->run = 0;
}

/* The timer fields: 030 alone for a timer to start, 031 alone for a value to show. */
static int diff_timer(const struct agility_display *shown, struct agility_display *w,
                      struct sl_circe_visualize *v)
{
        if (w->timer == AGILITY_TIMER_RUNNING) {
                if (shown->known && shown->timer == AGILITY_TIMER_RUNNING &&
                    shown->run == w->run)
                        return 0;
                if (!shown->known) {
                        /* 030 would start at zero mid-run: show no time rather than a wrong
                         * one, and count this run as handled so it is not started later. */
                        v->has_primary = 1;
                        v->primary_ms = AGILITY_HIDDEN_TIME;
                        return 1;
                }
                v->start_timer = 1;
                return 1;
        }
        if (shown->known && shown->timer == AGILITY_TIMER_VALUE &&
            shown->primary_ms == w->primary_ms)
                return 0;
        v->has_primary = 1;
        v->primary_ms = w->primary_ms;
        return 1;
}

int agility_display_diff(const struct agility_display *shown, const struct agility_display *want,
                         struct sl_circe_visualize *ret_vis, struct agility_display *ret_shown)
{
        struct sl_circe_visualize v = { .size = sizeof(v) };
        struct agility_display w;
        bool all = !shown->known;
        int n = 0;

        normalise(want, &w);
        if (all || shown->eliminated != w.eliminated) {
                v.has_eliminated = 1;
                v.eliminated = w.eliminated;
                n++;
        }
        if (all || shown->current != w.current) {
                v.has_current = 1;
                v.current = w.current;
                n++;
        }
        if (all || shown->next != w.next) {
                v.has_next = 1;
                v.next = w.next;
                n++;
        }
        n += diff_timer(shown, &w, &v);
        if (all || shown->secondary_ms != w.secondary_ms) {
                v.has_secondary = 1;
                v.secondary_ms = w.secondary_ms;
                n++;
        }
        if (all || shown->faults != w.faults) {
                v.has_faults = 1;
                v.faults = w.faults;
                n++;
        }
        if (all || shown->refusals != w.refusals) {
                v.has_refusals = 1;
                v.refusals = w.refusals;
                n++;
        }
        if (all || shown->placement != w.placement) {
                v.has_placement = 1;
                v.placement = w.placement;
                n++;
        }
        *ret_vis = v;
        *ret_shown = w;
        return n;
}
