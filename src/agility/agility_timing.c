/*
 * sharedlink-agility: the time between two gate passages (agility_timing.h).
 */
#include "agility/agility_timing.h"

static uint32_t clamp_ms(uint64_t ms)
{
        return ms > UINT32_MAX ? UINT32_MAX : (uint32_t)ms;
}

void agility_timing_elapsed(const struct agility_passage *from, const struct agility_passage *to,
                            struct agility_elapsed *ret)
{
        /* The caller's clock is monotonic; a passage handed in out of order counts as zero. */
        uint64_t received = to->received_ms > from->received_ms ?
                            to->received_ms - from->received_ms : 0;

        ret->ms = clamp_ms(received);
        ret->precision = AGILITY_PRECISION_LOW;
        if (!from->has_sensor || !to->has_sensor || !from->synced || !to->synced)
                return;

        /* Modular difference: a run across the wrap (999000 -> 26000) is 27000 ms, not
         * negative. A sensor time outside 0..999999 never reaches here (the codec refuses it),
         * but the modulo keeps the arithmetic in range whatever comes. */
        uint32_t a = from->sensor_ms % AGILITY_SENSOR_PERIOD_MS;
        uint32_t b = to->sensor_ms % AGILITY_SENSOR_PERIOD_MS;
        uint32_t sensor = (b + AGILITY_SENSOR_PERIOD_MS - a) % AGILITY_SENSOR_PERIOD_MS;
        uint64_t diff = sensor > received ? sensor - received : received - sensor;

        if (diff >= AGILITY_SENSOR_AGREE_MS)
                return;
        ret->ms = sensor;
        /* A pass key pressed by hand is timed by its sensor clock, but a human pressed it: the
         * reference controller marks such a time low precision, and so do we. */
        if (!from->manual && !to->manual)
                ret->precision = AGILITY_PRECISION_HIGH;
}

const char *agility_timing_precision_name(enum agility_precision p)
{
        return p == AGILITY_PRECISION_HIGH ? "high" : "low";
}
