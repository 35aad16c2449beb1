/*
 * sharedlink-agility: the time between two gate passages (docs/agility.md "Timing").
 *
 * Each passage keeps the gate's own sensor time (CIRCE 025, milliseconds since its clock was
 * last synchronised, 0..999999 and then round again) and the time the caller received it on its
 * own monotonic clock. The run time is the difference of the sensor times when both gates were
 * synchronised and that difference agrees with the received times within
 * AGILITY_SENSOR_AGREE_MS (high precision); else the difference of the received times (low
 * precision). Unlike the reference controller, the sensor difference is taken modulo the sensor
 * clock's period, so a run that spans the wrap from 999999 to 0 keeps high precision; the
 * agreement with the received times is what rules out a clock that restarted.
 *
 * Pure code: no syscalls, no allocation, no logging; the caller passes every time in.
 */
#ifndef SHAREDLINK_AGILITY_TIMING_H
#define SHAREDLINK_AGILITY_TIMING_H

#include <stdbool.h>
#include <stdint.h>

/* Sensor time (025) runs 0..999999 ms and wraps to 0: its period. */
#define AGILITY_SENSOR_PERIOD_MS 1000000u

/*
 * The most a sensor difference may disagree with the received difference and still count. The
 * reference controller's figure and reason: a device that restarts takes at least 4 s to be
 * back in the network, so a restarted clock disagrees by more than this.
 */
#define AGILITY_SENSOR_AGREE_MS 4000u

enum agility_precision {
        AGILITY_PRECISION_HIGH,         /* from the gates' synchronised sensor clocks */
        AGILITY_PRECISION_LOW,          /* from the times the passages were received */
};

struct agility_passage {
        uint64_t received_ms;           /* the caller's monotonic clock when it arrived */
        uint32_t sensor_ms;             /* 025, valid when has_sensor */
        bool has_sensor;
        bool synced;                    /* the gate's clock was synchronised when it passed */
        bool manual;                    /* a pass key on a remote, not a time sensor: never high */
};

struct agility_elapsed {
        uint32_t ms;                    /* UINT32_MAX at most */
        enum agility_precision precision;
};

/* The time from passage from to passage to, with its precision, into *ret. */
void agility_timing_elapsed(const struct agility_passage *from, const struct agility_passage *to,
                            struct agility_elapsed *ret);

/* "high" or "low". */
const char *agility_timing_precision_name(enum agility_precision p);

#endif
