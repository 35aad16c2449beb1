/*
 * libFuzzer target for the sharedlink-agility run engine (src/agility/agility_run.c) and the
 * display diff (src/agility/agility_display.c).
 *
 * The input is a program: each step picks an entry point (a Notify Action from one of the
 * class's devices or a stranger, with keys and a sensor time from the input; a sync result; the
 * end of a sync; a lost sync; a tick; start; abort) and moves the fake clock on. After every
 * step the engine must hold its invariants: a valid state, faults 0..95 and refusals 0..15 in
 * steps of 5, a bounded action list with DISPLAY only last and a STORE_RESULT followed by the
 * move to RunCompleted, placements only for clean finishes and in ranking order, a current
 * competitor from the list; and every Visualize the display diff makes is within CIRCE's
 * ranges, never carries Start Timer with a Primary Timer Value, and brings the display to
 * where a second diff finds nothing to send. Any broken invariant is a __builtin_trap().
 */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "agility/agility_run.h"
#include "fuzz_input.h"
#include "proto/circe.h"

#define NCOMP 5
#define STEPS_MAX 400
#define STRANGER 0x999999u

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static const uint32_t devices[] = { 0xE1E1E1u, 0xF1F1F1u, 0x111111u, 0x222222u, 0x333333u,
                                    0xAAAAAAu, 0xBBBBBBu, STRANGER };
#define NDEV (sizeof(devices) / sizeof(devices[0]))

static struct agility_run run;

static void check_actions(const struct agility_actions *a)
{
        CHECK(a->count <= AGILITY_ACTIONS_MAX);
        for (unsigned i = 0; i < a->count; i++) {
                const struct agility_action *x = &a->a[i];

                if (x->kind == AGILITY_ACT_DISPLAY)
                        CHECK(i == a->count - 1);
                if (x->kind == AGILITY_ACT_STORE_RESULT) {
                        CHECK(x->index < NCOMP);
                        CHECK(i + 1 < a->count && a->a[i + 1].kind == AGILITY_ACT_STATE &&
                              a->a[i + 1].to == AGILITY_RUN_COMPLETED);
                }
                if (x->kind == AGILITY_ACT_STATE)
                        CHECK(x->from != x->to && x->to < AGILITY_STATE_COUNT);
                if (x->kind == AGILITY_ACT_NOTICE)
                        CHECK(x->notice < AGILITY_NOTICE_COUNT);
        }
}

static void check_engine(const struct agility_run *r, const struct agility_result *res)
{
        CHECK(r->state < AGILITY_STATE_COUNT);
        CHECK(r->faults <= AGILITY_FAULTS_MAX && r->faults % AGILITY_FAULT_STEP == 0);
        CHECK(r->refusals <= AGILITY_REFUSALS_ELIMINATE &&
              r->refusals % AGILITY_REFUSAL_STEP == 0);
        CHECK(r->passed <= r->cls.intermediates);
        if (r->state != AGILITY_OFFLINE) {
                bool found = false;

                for (size_t i = 0; i < NCOMP; i++)
                        found = found || r->competitors[i].number == r->current;
                CHECK(found);
        }
        for (size_t i = 0; i < NCOMP; i++) {
                bool clean = res[i].completed && res[i].finished && !res[i].eliminated;

                CHECK(clean == (res[i].placement > 0));
        }
        for (size_t i = 1; i < NCOMP; i++) {
                const struct agility_result *a = r->order[i - 1], *b = r->order[i];

                CHECK(agility_rank_compare(a, b) < 0);
                if (a->placement > 0 && b->placement > 0)
                        CHECK(b->placement == a->placement ||
                              b->placement == a->placement + 1);
        }
}

static void check_visualize(const struct sl_circe_visualize *v)
{
        CHECK(!(v->start_timer && v->has_primary));
        CHECK(!v->has_current || (v->current >= 0 && v->current <= CIRCE_COMPETITOR_MAX));
        CHECK(!v->has_next || (v->next >= 0 && v->next <= CIRCE_COMPETITOR_MAX));
        CHECK(!v->has_primary || (v->primary_ms >= 0 && v->primary_ms <= CIRCE_TIME_MS_MAX));
        CHECK(!v->has_secondary ||
              (v->secondary_ms >= 0 && v->secondary_ms <= CIRCE_TIME_MS_MAX));
        CHECK(!v->has_faults || (v->faults >= 0 && v->faults <= CIRCE_COUNT_MAX));
        CHECK(!v->has_refusals || (v->refusals >= 0 && v->refusals <= CIRCE_COUNT_MAX));
        CHECK(!v->has_placement || (v->placement >= 0 && v->placement <= CIRCE_PLACEMENT_MAX));
}

static void check_display(struct agility_display *shown)
{
        struct agility_display want, again;
        struct sl_circe_visualize v;

        agility_run_display(&run, &want);
        agility_display_diff(shown, &want, &v, shown);
        check_visualize(&v);
        CHECK(agility_display_diff(shown, &want, &v, &again) == 0);
}

static struct agility_class make_class(struct input *in)
{
        uint8_t shape = take(in);
        struct agility_class c = {
                .standard_course_time_ms = (shape & 1) ? 40000 : 0,
                .max_course_time_ms = (shape & 2) ? 60000 : 0,
                .intermediates = (shape >> 2) & 3,
                .combined = (shape & 16) != 0,
                .start = devices[0],
                .finish = devices[1],
                .intermediate = { devices[2], devices[3], devices[4] },
                .min_delay_ms = AGILITY_MIN_DELAY_DEFAULT_MS,
                .keypads = { devices[5], (shape & 32) ? devices[0] : devices[6] },
                .keypad_count = 2,
        };
        return c;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        struct input in = { data, size };
        struct agility_competitor comp[NCOMP];
        struct agility_result res[NCOMP];
        struct agility_actions acts;
        struct agility_display shown;
        struct agility_class cls = make_class(&in);
        uint64_t now = 1000000;

        memset(comp, 0, sizeof(comp));
        memset(res, 0, sizeof(res));
        for (size_t i = 0; i < NCOMP; i++) {
                comp[i].number = (uint16_t)(1 + (i * 7) % 11);
                res[i].completed = (take(&in) & 7) == 0;
                res[i].finished = res[i].completed;
                res[i].finish_ms = 30000 + take(&in) * 100u;
        }
        CHECK(agility_run_init(&run, &cls, comp, NCOMP, res, comp[take(&in) % NCOMP].number) ==
              0);
        agility_display_unknown(&shown);
        for (int step = 0; step < STEPS_MAX && in.n > 0; step++) {
                uint8_t op = take(&in);
                uint32_t dev = devices[take(&in) % NDEV];

                switch (op % 8) {
                case 0:
                case 1:
                case 2: {
                        uint16_t keys = (uint16_t)(take(&in) << 8 | take(&in));
                        uint32_t sensor = ((uint32_t)take(&in) << 12 | take(&in)) % 1000000u;

                        agility_run_action(&run, now, dev, op & 8, keys, op & 16, sensor,
                                           &acts);
                        break;
                }
                case 3:
                        agility_run_sync_device(&run, now, dev, op & 8, &acts);
                        break;
                case 4:
                        agility_run_sync_done(&run, now, &acts);
                        break;
                case 5:
                        agility_run_sync_lost(&run, now, dev, &acts);
                        break;
                case 6:
                        agility_run_tick(&run, now, &acts);
                        break;
                default:
                        if (op & 8)
                                agility_run_abort(&run, now, &acts);
                        else
                                agility_run_start_class(&run, now, &acts);
                        if (op & 16)
                                agility_display_unknown(&shown);
                        break;
                }
                check_actions(&acts);
                check_engine(&run, res);
                check_display(&shown);
                /* Whatever was due at now has been done. */
                CHECK(agility_run_next_deadline(&run) > now);
                /* Time moves on: milliseconds, seconds, or minutes (sync age, max time). */
                uint8_t dt = take(&in);

                now += (dt & 0xc0) == 0xc0 ? (uint64_t)(dt & 0x3f) * 60000u :
                       (dt & 0x80) ? (uint64_t)(dt & 0x7f) * 1000u : dt;
        }
        return 0;
}
