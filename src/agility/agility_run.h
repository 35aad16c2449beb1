/*
 * sharedlink-agility: the run state machine of one class (docs/agility.md "States").
 *
 *   Offline -> SetupCompleted -> WaitingForSync -> ReadyToStart -> StartPassed
 *           -> Intermediate1..3Passed -> FinishPassed -> RunCompleted -> (Ready) WaitingForSync ...
 *
 * The engine takes what happened (a Notify Action, a device's clock synchronisation result,
 * time passing) and answers with actions for its caller: synchronise the clocks, store a
 * completed run, update the displays, a state change, a notice worth logging. It never does
 * anything itself, and it never reads a clock: every entry point gets "now" (the caller's
 * monotonic clock in ms), so the tests drive it on a fake clock.
 *
 * The rules are the reference controller's (bkoelman/DogAgilityCompetitionManagement,
 * src/Controller/Engine/CompetitionClassController.cs and its helpers); where this engine does
 * otherwise, docs/agility.md says so and why.
 *
 * It includes proto/circe.h for the key and range constants only: no function of the codec is
 * called, so the daemon links nothing but the public library.
 *
 * Pure code: no syscalls, no allocation, no logging. The caller owns the engine struct, the
 * competitor list and the results array.
 */
#ifndef SHAREDLINK_AGILITY_RUN_H
#define SHAREDLINK_AGILITY_RUN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "agility/agility_competitors.h"
#include "agility/agility_display.h"
#include "agility/agility_keys.h"
#include "agility/agility_rank.h"
#include "agility/agility_timing.h"

#define AGILITY_KEYPADS_MAX 8           /* remote controls of a class */
#define AGILITY_GATES_MAX (2 + AGILITY_INTERMEDIATES_MAX)  /* start, finish, intermediates */
#define AGILITY_ACTIONS_MAX 32          /* actions of one call */

/* Faults and refusals move in steps of 5; faults stop at 95, three refusals (15) eliminate
 * (reference: CompetitionRunResult). */
#define AGILITY_FAULT_STEP 5
#define AGILITY_FAULTS_MAX 95
#define AGILITY_REFUSAL_STEP 5
#define AGILITY_REFUSALS_ELIMINATE 15

/* Clock synchronisation grows old: a resync is recommended after 10 min and required after
 * 15 (reference: ClockSynchronizationMonitor); the sensor clock wraps after 16 min 40 s. */
#define AGILITY_SYNC_RECOMMEND_MS (10u * 60u * 1000u)
#define AGILITY_SYNC_REQUIRE_MS (15u * 60u * 1000u)

/* Combined start/finish gate: the reference's default minimum time between the two. */
#define AGILITY_MIN_DELAY_DEFAULT_MS 3000u

enum agility_state {
        AGILITY_OFFLINE,
        AGILITY_SETUP_COMPLETED,
        AGILITY_WAITING_FOR_SYNC,
        AGILITY_READY_TO_START,
        AGILITY_START_PASSED,
        AGILITY_INTERMEDIATE1_PASSED,
        AGILITY_INTERMEDIATE2_PASSED,
        AGILITY_INTERMEDIATE3_PASSED,
        AGILITY_FINISH_PASSED,
        AGILITY_RUN_COMPLETED,
        AGILITY_STATE_COUNT
};

/* The course and its devices. Addresses are CIRCE addresses (24 bits, not 0, not FFFFFF). */
struct agility_class {
        uint32_t standard_course_time_ms;       /* 0: none */
        uint32_t max_course_time_ms;            /* 0: none */
        unsigned intermediates;                 /* intermediate timers, 0..3 */
        bool combined;                          /* one start/finish gate: start (= finish) */
        uint32_t start;                         /* the start gate, or the combined gate */
        uint32_t finish;                        /* the finish gate (combined: ignored) */
        uint32_t intermediate[AGILITY_INTERMEDIATES_MAX];
        uint32_t min_delay_ms;                  /* combined: least time from start to finish */
        uint32_t keypads[AGILITY_KEYPADS_MAX];  /* remote controls whose keys count */
        unsigned keypad_count;
};

enum agility_action_kind {
        AGILITY_ACT_STATE,              /* the state went from .from to .to */
        AGILITY_ACT_SYNC_CLOCKS,        /* synchronise the gates' clocks, then report each
                                         * gate (agility_run_sync_device) and the end
                                         * (agility_run_sync_done) */
        AGILITY_ACT_STORE_RESULT,       /* a run completed: store results[.index] (and the
                                         * placements that moved) before the display shows it */
        AGILITY_ACT_DISPLAY,            /* what the displays should show changed:
                                         * agility_run_display(); always the last action */
        AGILITY_ACT_NOTICE,             /* something worth a log line: .notice, .device */
};

enum agility_notice {
        AGILITY_NOTICE_SYNC_FAILED,     /* gate .device did not synchronise: back to setup */
        AGILITY_NOTICE_SYNC_RECOMMENDED,/* the last sync is 10 min old: press Ready to resync */
        AGILITY_NOTICE_SYNC_REQUIRED,   /* ... 15 min old: back to setup, press Ready */
        AGILITY_NOTICE_CLASS_COMPLETED, /* no competitor left: offline */
        AGILITY_NOTICE_OUT_OF_ORDER,    /* a passage of gate .device that the state refuses */
        AGILITY_NOTICE_TOO_SOON,        /* combined gate: finish before the minimum delay */
        AGILITY_NOTICE_NOT_KEYPAD,      /* a command key from .device, which is no keypad */
        AGILITY_NOTICE_NOT_GATE,        /* a pass key from .device, which is not that gate */
        AGILITY_NOTICE_NO_TIME,         /* an action of gate .device without keys or time */
        AGILITY_NOTICE_UNKNOWN_DEVICE,  /* an action from .device, in no role of the class */
        AGILITY_NOTICE_UNKNOWN_COMPETITOR, /* an entered number .number not in the list */
        AGILITY_NOTICE_MAX_COURSE_TIME, /* the maximum course time passed: eliminated */
        AGILITY_NOTICE_COUNT
};

struct agility_action {
        enum agility_action_kind kind;
        enum agility_state from, to;    /* STATE */
        enum agility_notice notice;     /* NOTICE */
        uint32_t device;                /* NOTICE: the device concerned, 0 if none */
        uint16_t number;                /* NOTICE: the competitor number concerned */
        size_t index;                   /* STORE_RESULT: into results[] */
};

struct agility_actions {
        struct agility_action a[AGILITY_ACTIONS_MAX];
        unsigned count;
        bool overflow;                  /* some notices did not fit (never a state or store) */
};

/* The current run: what the scoreboard shows (GET /api/state). */
struct agility_run_view {
        enum agility_state state;
        uint16_t current, next;         /* competitor numbers, 0: none */
        uint8_t faults, refusals;
        bool eliminated;
        bool started, finished;
        uint32_t elapsed_ms;            /* finished: the run time; started: since the start
                                         * as received; else 0 */
        enum agility_precision precision;       /* of elapsed_ms */
        unsigned intermediates;         /* intermediate times taken */
        uint32_t intermediate_ms[AGILITY_INTERMEDIATES_MAX];
};

struct agility_run {
        struct agility_class cls;
        const struct agility_competitor *competitors;
        struct agility_result *results;         /* parallel to competitors */
        size_t count;
        const struct agility_result *order[AGILITY_COMPETITORS_MAX];   /* the ranking */
        enum agility_state state;
        uint16_t current;               /* 0: none */
        uint16_t next_typed;            /* a next competitor entered by hand, 0: none */
        uint16_t last_completed;        /* for the previous placement, 0: none */
        struct agility_keys keys;
        /* Clock synchronisation of the gates (cls order: start, finish, intermediates). */
        uint32_t gates[AGILITY_GATES_MAX];
        unsigned gate_count;
        bool gate_synced[AGILITY_GATES_MAX];    /* succeeded in the last sync */
        bool gate_lost[AGILITY_GATES_MAX];      /* asked for a sync since */
        bool sync_valid;                /* the last sync succeeded, at sync_at_ms */
        uint64_t sync_at_ms;
        bool sync_recommended;          /* the 10 min notice was given */
        /* The run in progress. */
        bool started, finished, showing_existing;
        struct agility_passage start;
        unsigned passed;                /* intermediates passed */
        struct agility_elapsed intermediate[AGILITY_INTERMEDIATES_MAX];
        struct agility_elapsed finish;
        uint8_t faults, refusals;
        bool manual_eliminated, time_eliminated;
        uint32_t run_seq;               /* counts starts: a display's running timer */
        /* The number being entered on a keypad, shown while it is typed. */
        bool entering, entry_current;
        uint16_t entry_number;
        struct agility_display shown;   /* the display the last call asked for */
};

/*
 * Sets up run for class cls (copied) with count competitors (kept by pointer, count >= 1) and
 * their results (count entries, by pointer: completed runs as loaded, the rest zero; the
 * competitor numbers are filled in here). last_completed: the last completed competitor of an
 * earlier session, 0 if none. Placements are recomputed. The state is Offline. Returns 0, or
 * -EINVAL for a class that breaks the rules (docs/agility.md) or no competitor.
 */
int agility_run_init(struct agility_run *run, const struct agility_class *cls,
                     const struct agility_competitor *competitors, size_t count,
                     struct agility_result *results, uint16_t last_completed);

/* Offline -> SetupCompleted with the best starting competitor (else nothing). */
void agility_run_start_class(struct agility_run *run, uint64_t now_ms,
                             struct agility_actions *acts);

/* Any state -> Offline (the run in progress is dropped). */
void agility_run_abort(struct agility_run *run, uint64_t now_ms, struct agility_actions *acts);

/* A Notify Action from device: input keys (when has_keys) and sensor time (when has_sensor). */
void agility_run_action(struct agility_run *run, uint64_t now_ms, uint32_t device,
                        bool has_keys, uint16_t keys, bool has_sensor, uint32_t sensor_ms,
                        struct agility_actions *acts);

/* The clock synchronisation result of one device (after AGILITY_ACT_SYNC_CLOCKS). */
void agility_run_sync_device(struct agility_run *run, uint64_t now_ms, uint32_t device,
                             bool succeeded, struct agility_actions *acts);

/* The synchronisation ended: a gate that did not succeed fails it. */
void agility_run_sync_done(struct agility_run *run, uint64_t now_ms,
                           struct agility_actions *acts);

/* device reports that its clock needs a sync (Notify Status 027:1, e.g. it restarted). */
void agility_run_sync_lost(struct agility_run *run, uint64_t now_ms, uint32_t device,
                           struct agility_actions *acts);

/* Time passed: maximum course time, resync recommended or required. */
void agility_run_tick(struct agility_run *run, uint64_t now_ms, struct agility_actions *acts);

/* When agility_run_tick next has something to do (UINT64_MAX: nothing). */
uint64_t agility_run_next_deadline(const struct agility_run *run);

/* What the displays should show now, into *ret. */
void agility_run_display(const struct agility_run *run, struct agility_display *ret);

/* The run in progress as the scoreboard shows it, into *ret. */
void agility_run_view(const struct agility_run *run, uint64_t now_ms,
                      struct agility_run_view *ret);

/* The competitor the engine calls "next" now (typed, else the best), 0: none. */
uint16_t agility_run_next(const struct agility_run *run);

/* "Offline", "SetupCompleted", ... (the reference's names). */
const char *agility_run_state_name(enum agility_state s);

/* "sync-failed", "out-of-order", ... */
const char *agility_run_notice_name(enum agility_notice n);

#endif
