/*
 * sharedlink-agility: the run state machine of one class (agility_run.h).
 */
#include <errno.h>
#include <string.h>

#include "agility/agility_run.h"
#include "proto/circe.h"

/* Room kept for state changes and stores: notices never take the last slots. */
#define ACTIONS_RESERVED 8

/* What a gate does in the class. */
enum role {
        ROLE_NONE,
        ROLE_START,
        ROLE_START_FINISH,              /* the combined gate, passed without a key */
        ROLE_INTERMEDIATE,
        ROLE_FINISH,
};

static const char *const state_names[AGILITY_STATE_COUNT] = {
        [AGILITY_OFFLINE] = "Offline",
        [AGILITY_SETUP_COMPLETED] = "SetupCompleted",
        [AGILITY_WAITING_FOR_SYNC] = "WaitingForSync",
        [AGILITY_READY_TO_START] = "ReadyToStart",
        [AGILITY_START_PASSED] = "StartPassed",
        [AGILITY_INTERMEDIATE1_PASSED] = "Intermediate1Passed",
        [AGILITY_INTERMEDIATE2_PASSED] = "Intermediate2Passed",
        [AGILITY_INTERMEDIATE3_PASSED] = "Intermediate3Passed",
        [AGILITY_FINISH_PASSED] = "FinishPassed",
        [AGILITY_RUN_COMPLETED] = "RunCompleted",
};

static const char *const notice_names[AGILITY_NOTICE_COUNT] = {
        [AGILITY_NOTICE_SYNC_FAILED] = "sync-failed",
        [AGILITY_NOTICE_SYNC_RECOMMENDED] = "sync-recommended",
        [AGILITY_NOTICE_SYNC_REQUIRED] = "sync-required",
        [AGILITY_NOTICE_CLASS_COMPLETED] = "class-completed",
        [AGILITY_NOTICE_OUT_OF_ORDER] = "out-of-order",
        [AGILITY_NOTICE_TOO_SOON] = "too-soon",
        [AGILITY_NOTICE_NOT_KEYPAD] = "not-keypad",
        [AGILITY_NOTICE_NOT_GATE] = "not-gate",
        [AGILITY_NOTICE_NO_TIME] = "no-time",
        [AGILITY_NOTICE_UNKNOWN_DEVICE] = "unknown-device",
        [AGILITY_NOTICE_UNKNOWN_COMPETITOR] = "unknown-competitor",
        [AGILITY_NOTICE_MAX_COURSE_TIME] = "max-course-time",
};

const char *agility_run_state_name(enum agility_state s)
{
        return (unsigned)s < AGILITY_STATE_COUNT ? state_names[s] : "?";
}

const char *agility_run_notice_name(enum agility_notice n)
{
        return (unsigned)n < AGILITY_NOTICE_COUNT ? notice_names[n] : "?";
}

/* ---- Actions ------------------------------------------------------------------------------ */

static void push(struct agility_actions *acts, struct agility_action a, unsigned limit)
{
        if (acts->count < limit)
                acts->a[acts->count++] = a;
        else
                acts->overflow = true;
}

static void notice(struct agility_actions *acts, enum agility_notice n, uint32_t device,
                   uint16_t number)
{
        push(acts, (struct agility_action){ .kind = AGILITY_ACT_NOTICE, .notice = n,
                                            .device = device, .number = number },
             AGILITY_ACTIONS_MAX - ACTIONS_RESERVED);
}

static void set_state(struct agility_run *run, enum agility_state to,
                      struct agility_actions *acts)
{
        if (run->state == to)
                return;
        push(acts, (struct agility_action){ .kind = AGILITY_ACT_STATE, .from = run->state,
                                            .to = to }, AGILITY_ACTIONS_MAX);
        run->state = to;
}

/* ---- Lookups ------------------------------------------------------------------------------ */

static bool running(const struct agility_run *run)
{
        return run->state >= AGILITY_START_PASSED && run->state <= AGILITY_INTERMEDIATE3_PASSED;
}

/* Faults, refusals, elimination and reset apply from ReadyToStart to FinishPassed. */
static bool scoring(const struct agility_run *run)
{
        return run->state >= AGILITY_READY_TO_START && run->state <= AGILITY_FINISH_PASSED;
}

/* The reference's windows for entering the current (to FinishPassed) and next competitor. */
static bool entry_allowed(const struct agility_run *run, bool current)
{
        enum agility_state last = current ? AGILITY_FINISH_PASSED : AGILITY_RUN_COMPLETED;

        return run->state >= AGILITY_SETUP_COMPLETED && run->state <= last;
}

static bool eliminated(const struct agility_run *run)
{
        return run->manual_eliminated || run->time_eliminated ||
               run->refusals >= AGILITY_REFUSALS_ELIMINATE;
}

static long index_of(const struct agility_run *run, uint16_t number)
{
        for (size_t i = 0; i < run->count; i++)
                if (run->competitors[i].number == number)
                        return (long)i;
        return -1;
}

static const struct agility_result *result_of(const struct agility_run *run, uint16_t number)
{
        long i = index_of(run, number);

        return i < 0 ? NULL : &run->results[i];
}

/* The smallest number above after (0: from the start) without a completed run, other than
 * skip; 0 if none. */
static uint16_t first_open_after(const struct agility_run *run, uint16_t after, uint16_t skip)
{
        uint16_t best = 0;

        for (size_t i = 0; i < run->count; i++) {
                uint16_t n = run->competitors[i].number;

                if (n > after && n != skip && !run->results[i].completed &&
                    (best == 0 || n < best))
                        best = n;
        }
        return best;
}

/* Reference GetBestStartingCompetitorNumber: after the last completed, else the first open,
 * else the first of all. */
static uint16_t best_start(const struct agility_run *run)
{
        uint16_t n = run->last_completed ? first_open_after(run, run->last_completed, 0) : 0;

        if (n == 0)
                n = first_open_after(run, 0, 0);
        if (n == 0) {
                for (size_t i = 0; i < run->count; i++)
                        if (n == 0 || run->competitors[i].number < n)
                                n = run->competitors[i].number;
        }
        return n;
}

/* Reference GetBestNextCompetitorNumberOrNull: the first open one after current, else the
 * first open one but current. */
static uint16_t best_next(const struct agility_run *run, uint16_t current)
{
        uint16_t n = first_open_after(run, current, 0);

        return n ? n : first_open_after(run, 0, current);
}

uint16_t agility_run_next(const struct agility_run *run)
{
        if (run->state == AGILITY_OFFLINE || run->current == 0)
                return 0;
        return run->next_typed ? run->next_typed : best_next(run, run->current);
}

static int gate_index(const struct agility_run *run, uint32_t device)
{
        for (unsigned i = 0; i < run->gate_count; i++)
                if (run->gates[i] == device)
                        return (int)i;
        return -1;
}

static bool is_keypad(const struct agility_run *run, uint32_t device)
{
        for (unsigned i = 0; i < run->cls.keypad_count; i++)
                if (run->cls.keypads[i] == device)
                        return true;
        return false;
}

/* The role of a gate passed without a key, and its intermediate index into *ret_i. */
static enum role gate_role(const struct agility_run *run, uint32_t device, unsigned *ret_i)
{
        if (device == run->cls.start)
                return run->cls.combined ? ROLE_START_FINISH : ROLE_START;
        if (!run->cls.combined && device == run->cls.finish)
                return ROLE_FINISH;
        for (unsigned i = 0; i < run->cls.intermediates; i++) {
                if (run->cls.intermediate[i] == device) {
                        *ret_i = i;
                        return ROLE_INTERMEDIATE;
                }
        }
        return ROLE_NONE;
}

/* Synchronised: in the last successful sync, not lost since, and not too old. */
static bool gate_synced(const struct agility_run *run, uint32_t device, uint64_t now_ms)
{
        int g = gate_index(run, device);

        return g >= 0 && run->sync_valid && run->gate_synced[g] && !run->gate_lost[g] &&
               now_ms - run->sync_at_ms < AGILITY_SYNC_REQUIRE_MS;
}

/* ---- The run in progress ------------------------------------------------------------------ */

static void reset_run_data(struct agility_run *run)
{
        run->started = false;
        run->finished = false;
        run->showing_existing = false;
        run->passed = 0;
        run->faults = 0;
        run->refusals = 0;
        run->manual_eliminated = false;
        run->time_eliminated = false;
}

/* Reference ClearCurrentRunOrShowExistingRun: a competitor who already ran is shown with that
 * run until something changes; the others start from zero. */
static void clear_or_show_existing(struct agility_run *run, struct agility_actions *acts)
{
        const struct agility_result *r = result_of(run, run->current);

        reset_run_data(run);
        run->showing_existing = r && r->completed;
        set_state(run, AGILITY_READY_TO_START, acts);
}

static void start_sync(struct agility_run *run, struct agility_actions *acts)
{
        set_state(run, AGILITY_WAITING_FOR_SYNC, acts);
        memset(run->gate_synced, 0, sizeof(run->gate_synced));
        memset(run->gate_lost, 0, sizeof(run->gate_lost));
        run->sync_valid = false;
        run->sync_recommended = false;
        push(acts, (struct agility_action){ .kind = AGILITY_ACT_SYNC_CLOCKS },
             AGILITY_ACTIONS_MAX);
}

static void go_offline(struct agility_run *run, struct agility_actions *acts)
{
        reset_run_data(run);
        run->entering = false;
        run->sync_valid = false;
        set_state(run, AGILITY_OFFLINE, acts);
}

/* Ready in SetupCompleted (first: the current competitor) or RunCompleted (the next one). */
static void prepare(struct agility_run *run, bool first, struct agility_actions *acts)
{
        if (!first) {
                run->current = agility_run_next(run);
                run->next_typed = 0;
                if (run->current == 0) {
                        notice(acts, AGILITY_NOTICE_CLASS_COMPLETED, 0, 0);
                        go_offline(run, acts);
                        return;
                }
        }
        reset_run_data(run);
        start_sync(run, acts);
}

static void complete(struct agility_run *run, struct agility_actions *acts)
{
        long i = index_of(run, run->current);

        if (i < 0)
                return;
        struct agility_result *r = &run->results[i];

        *r = (struct agility_result){
                .competitor = run->current,
                .completed = true,
                .finished = run->finished,
                .eliminated = eliminated(run),
                .faults = run->faults,
                .refusals = run->refusals,
                .intermediates = (uint8_t)run->passed,
        };
        for (unsigned k = 0; k < run->passed; k++) {
                r->intermediate_ms[k] = run->intermediate[k].ms;
                r->intermediate_precision[k] = run->intermediate[k].precision;
        }
        if (run->finished) {
                r->finish_ms = run->finish.ms;
                r->finish_precision = run->finish.precision;
        }
        run->last_completed = run->current;
        agility_rank_place(run->results, run->count, run->cls.standard_course_time_ms,
                           run->order);
        push(acts, (struct agility_action){ .kind = AGILITY_ACT_STORE_RESULT, .index = (size_t)i },
             AGILITY_ACTIONS_MAX);
        set_state(run, AGILITY_RUN_COMPLETED, acts);
}

static void ready(struct agility_run *run, struct agility_actions *acts)
{
        switch (run->state) {
        case AGILITY_SETUP_COMPLETED:
                prepare(run, true, acts);
                break;
        case AGILITY_READY_TO_START:
                start_sync(run, acts);          /* the reference resyncs on demand */
                break;
        case AGILITY_RUN_COMPLETED:
                prepare(run, false, acts);
                break;
        case AGILITY_FINISH_PASSED:
                complete(run, acts);
                break;
        default:
                /* A run still going completes only once it is eliminated. */
                if (running(run) && eliminated(run))
                        complete(run, acts);
                break;
        }
}

static void start_run(struct agility_run *run, const struct agility_passage *p,
                      struct agility_actions *acts)
{
        run->showing_existing = false;
        run->start = *p;
        run->started = true;
        run->time_eliminated = false;
        run->run_seq++;
        set_state(run, AGILITY_START_PASSED, acts);
}

static void finish_run(struct agility_run *run, const struct agility_passage *p,
                       struct agility_actions *acts)
{
        agility_timing_elapsed(&run->start, p, &run->finish);
        run->finished = true;
        /* The measured time decides, not the timer that may have fired first while the
         * finish passage was on its way (agility_run_tick). */
        run->time_eliminated = run->cls.max_course_time_ms > 0 &&
                               run->finish.ms > run->cls.max_course_time_ms;
        set_state(run, AGILITY_FINISH_PASSED, acts);
}

static void passage(struct agility_run *run, enum role role, unsigned inter,
                    const struct agility_passage *p, uint32_t device,
                    struct agility_actions *acts)
{
        struct agility_elapsed el;

        switch (role) {
        case ROLE_START_FINISH:
                if (run->state == AGILITY_READY_TO_START) {
                        start_run(run, p, acts);
                        return;
                }
                if (!running(run))
                        break;
                agility_timing_elapsed(&run->start, p, &el);
                if (el.ms < run->cls.min_delay_ms) {
                        notice(acts, AGILITY_NOTICE_TOO_SOON, device, 0);
                        return;
                }
                finish_run(run, p, acts);
                return;
        case ROLE_START:
                if (run->state != AGILITY_READY_TO_START)
                        break;
                start_run(run, p, acts);
                return;
        case ROLE_INTERMEDIATE:
                /* Strictly in order: intermediate k only right after k - 1 (or the start). */
                if (inter >= run->cls.intermediates ||
                    (unsigned)run->state != AGILITY_START_PASSED + inter)
                        break;
                agility_timing_elapsed(&run->start, p, &run->intermediate[inter]);
                run->passed = inter + 1;
                set_state(run, (enum agility_state)(AGILITY_START_PASSED + inter + 1), acts);
                return;
        case ROLE_FINISH:
                if (!running(run))
                        break;
                finish_run(run, p, acts);
                return;
        case ROLE_NONE:
                break;
        }
        notice(acts, AGILITY_NOTICE_OUT_OF_ORDER, device, 0);
}

/* ---- Keys --------------------------------------------------------------------------------- */

/* A shown earlier run goes away at the first change, as the reference's
 * HideExistingRunResultIfAny: the run data under it is already zero. */
static void hide_existing(struct agility_run *run)
{
        run->showing_existing = false;
}

static void command(struct agility_run *run, uint16_t key, struct agility_actions *acts)
{
        if (key == CIRCE_KEY_READY) {
                ready(run, acts);
                return;
        }
        if (!scoring(run))
                return;
        switch (key) {
        case CIRCE_KEY_3:               /* toggle elimination */
                hide_existing(run);
                run->manual_eliminated = !run->manual_eliminated;
                break;
        case CIRCE_KEY_5:               /* refusals - */
                hide_existing(run);
                if (run->refusals >= AGILITY_REFUSAL_STEP)
                        run->refusals -= AGILITY_REFUSAL_STEP;
                break;
        case CIRCE_KEY_6:               /* refusals + */
                hide_existing(run);
                if (run->refusals < AGILITY_REFUSALS_ELIMINATE)
                        run->refusals += AGILITY_REFUSAL_STEP;
                break;
        case CIRCE_KEY_8:               /* faults - */
                hide_existing(run);
                if (run->faults >= AGILITY_FAULT_STEP)
                        run->faults -= AGILITY_FAULT_STEP;
                break;
        case CIRCE_KEY_9:               /* faults + */
                hide_existing(run);
                if (run->faults <= AGILITY_FAULTS_MAX - AGILITY_FAULT_STEP)
                        run->faults += AGILITY_FAULT_STEP;
                break;
        case CIRCE_KEY_RESET_RUN:
                clear_or_show_existing(run, acts);
                break;
        default:
                break;                  /* keys 1, 4, 7, 0: sounds in the reference; none here */
        }
}

/* A pass key pressed on a remote: a passage if the remote is that gate. Returns false when
 * the key is not a pass key for this device (then it is an ordinary key). */
static bool pass_key(struct agility_run *run, uint64_t now_ms, uint32_t device, uint16_t key,
                     bool has_sensor, uint32_t sensor_ms, struct agility_actions *acts)
{
        struct agility_passage p = { .received_ms = now_ms, .sensor_ms = sensor_ms,
                                     .has_sensor = has_sensor, .manual = true,
                                     .synced = gate_synced(run, device, now_ms) };
        unsigned inter = 0;
        enum role role = gate_role(run, device, &inter);

        if (key == CIRCE_KEY_PASS_START || key == CIRCE_KEY_PASS_FINISH) {
                bool is_start = key == CIRCE_KEY_PASS_START;
                bool ok = is_start ? (role == ROLE_START || role == ROLE_START_FINISH) :
                                     (role == ROLE_FINISH || role == ROLE_START_FINISH);

                if (!ok)
                        notice(acts, AGILITY_NOTICE_NOT_GATE, device, 0);
                else
                        passage(run, is_start ? ROLE_START : ROLE_FINISH, 0, &p, device, acts);
                return true;
        }
        if (key == CIRCE_KEY_2 && role == ROLE_INTERMEDIATE) {
                passage(run, ROLE_INTERMEDIATE, inter, &p, device, acts);
                return true;
        }
        return false;
}

static void select_competitor(struct agility_run *run, bool current, uint16_t number,
                              struct agility_actions *acts)
{
        if (index_of(run, number) < 0) {
                notice(acts, AGILITY_NOTICE_UNKNOWN_COMPETITOR, 0, number);
                return;
        }
        if (!current) {
                if (number != run->current)
                        run->next_typed = number;
                return;
        }
        run->current = number;
        if (run->next_typed == number)
                run->next_typed = 0;
        if (run->state == AGILITY_READY_TO_START)
                clear_or_show_existing(run, acts);
}

static void key_event(struct agility_run *run, uint64_t now_ms, uint32_t device, bool keypad,
                      const struct agility_key_event *e, bool has_sensor, uint32_t sensor_ms,
                      struct agility_actions *acts)
{
        switch (e->kind) {
        case AGILITY_KEY_ENTRY_BEGIN:
                run->entering = true;
                run->entry_current = e->current;
                run->entry_number = 0;
                break;
        case AGILITY_KEY_ENTRY_DIGIT:
                run->entry_number = e->number;
                break;
        case AGILITY_KEY_ENTRY_END:
                run->entering = false;
                if (e->number > 0 && entry_allowed(run, e->current))
                        select_competitor(run, e->current, e->number, acts);
                break;
        case AGILITY_KEY_PRESS:
                if (pass_key(run, now_ms, device, e->key, has_sensor, sensor_ms, acts))
                        break;
                if (!keypad)
                        notice(acts, AGILITY_NOTICE_NOT_KEYPAD, device, 0);
                else
                        command(run, e->key, acts);
                break;
        }
}

/* ---- Timers ------------------------------------------------------------------------------- */

static void check_timers(struct agility_run *run, uint64_t now_ms, struct agility_actions *acts)
{
        if (run->state == AGILITY_READY_TO_START && run->sync_valid) {
                uint64_t age = now_ms - run->sync_at_ms;

                if (age >= AGILITY_SYNC_REQUIRE_MS) {
                        notice(acts, AGILITY_NOTICE_SYNC_REQUIRED, 0, 0);
                        run->sync_valid = false;
                        set_state(run, AGILITY_SETUP_COMPLETED, acts);
                } else if (age >= AGILITY_SYNC_RECOMMEND_MS && !run->sync_recommended) {
                        run->sync_recommended = true;
                        notice(acts, AGILITY_NOTICE_SYNC_RECOMMENDED, 0, 0);
                }
        }
        if (running(run) && run->cls.max_course_time_ms > 0 && !run->time_eliminated &&
            now_ms - run->start.received_ms > run->cls.max_course_time_ms) {
                run->time_eliminated = true;
                notice(acts, AGILITY_NOTICE_MAX_COURSE_TIME, 0, run->current);
        }
}

uint64_t agility_run_next_deadline(const struct agility_run *run)
{
        uint64_t d = UINT64_MAX;

        if (run->state == AGILITY_READY_TO_START && run->sync_valid) {
                d = run->sync_at_ms + AGILITY_SYNC_REQUIRE_MS;
                if (!run->sync_recommended)
                        d = run->sync_at_ms + AGILITY_SYNC_RECOMMEND_MS;
        }
        if (running(run) && run->cls.max_course_time_ms > 0 && !run->time_eliminated) {
                /* "More than the maximum": the first millisecond past it. */
                uint64_t t = run->start.received_ms + run->cls.max_course_time_ms + 1;

                if (t < d)
                        d = t;
        }
        return d;
}

/* ---- Display ------------------------------------------------------------------------------ */

static void show_result(const struct agility_result *r, struct agility_display *d)
{
        d->eliminated = r->eliminated;
        d->faults = r->faults;
        d->refusals = r->refusals;
        d->primary_ms = r->finished ? r->finish_ms : AGILITY_HIDDEN_TIME;
        d->secondary_ms = r->intermediates ? r->intermediate_ms[r->intermediates - 1] :
                                             AGILITY_HIDDEN_TIME;
}

void agility_run_display(const struct agility_run *run, struct agility_display *d)
{
        const struct agility_result *prev = result_of(run, run->last_completed);

        agility_display_blank(d);
        if (run->state == AGILITY_OFFLINE)
                return;
        d->current = run->current;
        d->next = agility_run_next(run);
        if (run->entering && run->entry_number > 0 && entry_allowed(run, run->entry_current)) {
                if (run->entry_current)
                        d->current = run->entry_number;
                else
                        d->next = run->entry_number;
        }
        if (prev && run->last_completed)
                d->placement = prev->placement;
        if (run->state == AGILITY_SETUP_COMPLETED || run->state == AGILITY_WAITING_FOR_SYNC)
                return;                 /* no run to show yet */
        if (run->showing_existing) {
                show_result(result_of(run, run->current), d);
                return;
        }
        d->faults = run->faults;
        d->refusals = run->refusals;
        d->eliminated = eliminated(run);
        if (run->passed > 0)
                d->secondary_ms = run->intermediate[run->passed - 1].ms;
        if (run->finished) {
                d->primary_ms = run->finish.ms;
        } else if (running(run)) {
                d->timer = AGILITY_TIMER_RUNNING;
                d->run = run->run_seq;
        } else if (run->state == AGILITY_READY_TO_START) {
                d->primary_ms = 0;
        }
}

static bool display_equal(const struct agility_display *a, const struct agility_display *b)
{
        return a->known == b->known && a->current == b->current && a->next == b->next &&
               a->timer == b->timer && a->primary_ms == b->primary_ms && a->run == b->run &&
               a->secondary_ms == b->secondary_ms && a->faults == b->faults &&
               a->refusals == b->refusals && a->eliminated == b->eliminated &&
               a->placement == b->placement;
}

/* ---- Entry points ------------------------------------------------------------------------- */

static void begin(struct agility_run *run, uint64_t now_ms, struct agility_actions *acts)
{
        acts->count = 0;
        acts->overflow = false;
        check_timers(run, now_ms, acts);
}

/* Every entry point ends here: the timers again (the input may have moved the class into a
 * state where one is already due, e.g. a reset into ReadyToStart with a sync 15 min old), then
 * one DISPLAY action, last, when the displays should change. */
static void end(struct agility_run *run, uint64_t now_ms, struct agility_actions *acts)
{
        struct agility_display want;

        check_timers(run, now_ms, acts);
        agility_run_display(run, &want);
        if (display_equal(&want, &run->shown))
                return;
        run->shown = want;
        push(acts, (struct agility_action){ .kind = AGILITY_ACT_DISPLAY }, AGILITY_ACTIONS_MAX);
}

static bool address_ok(uint32_t a)
{
        return a != CIRCE_ADDRESS_UNCONFIGURED && a < CIRCE_ADDRESS_RESERVED;
}

static int add_gate(struct agility_run *run, uint32_t address)
{
        if (!address_ok(address) || gate_index(run, address) >= 0)
                return -EINVAL;
        run->gates[run->gate_count++] = address;
        return 0;
}

static int check_class(struct agility_run *run)
{
        const struct agility_class *c = &run->cls;

        if (c->intermediates > AGILITY_INTERMEDIATES_MAX || c->keypad_count > AGILITY_KEYPADS_MAX)
                return -EINVAL;
        if (c->max_course_time_ms > 0 && c->max_course_time_ms < c->standard_course_time_ms)
                return -EINVAL;
        run->gate_count = 0;
        if (add_gate(run, c->start) < 0 || (!c->combined && add_gate(run, c->finish) < 0))
                return -EINVAL;
        for (unsigned i = 0; i < c->intermediates; i++)
                if (add_gate(run, c->intermediate[i]) < 0)
                        return -EINVAL;
        for (unsigned i = 0; i < c->keypad_count; i++)
                if (!address_ok(c->keypads[i]))
                        return -EINVAL;
        return 0;
}

int agility_run_init(struct agility_run *run, const struct agility_class *cls,
                     const struct agility_competitor *competitors, size_t count,
                     struct agility_result *results, uint16_t last_completed)
{
        memset(run, 0, sizeof(*run));
        run->cls = *cls;
        if (count == 0 || count > AGILITY_COMPETITORS_MAX || check_class(run) < 0)
                return -EINVAL;
        for (size_t i = 0; i < count; i++) {
                uint16_t n = competitors[i].number;

                if (n == 0 || n > CIRCE_COMPETITOR_MAX)
                        return -EINVAL;
                for (size_t j = 0; j < i; j++)
                        if (competitors[j].number == n)
                                return -EINVAL;
        }
        run->competitors = competitors;
        run->results = results;
        run->count = count;
        for (size_t i = 0; i < count; i++) {
                if (!results[i].completed)
                        results[i] = (struct agility_result){ 0 };
                results[i].competitor = competitors[i].number;
        }
        run->last_completed = index_of(run, last_completed) >= 0 ? last_completed : 0;
        agility_rank_place(results, count, cls->standard_course_time_ms, run->order);
        agility_keys_init(&run->keys);
        run->state = AGILITY_OFFLINE;
        agility_run_display(run, &run->shown);
        return 0;
}

void agility_run_start_class(struct agility_run *run, uint64_t now_ms,
                             struct agility_actions *acts)
{
        begin(run, now_ms, acts);
        if (run->state == AGILITY_OFFLINE) {
                run->current = best_start(run);
                run->next_typed = 0;
                reset_run_data(run);
                set_state(run, AGILITY_SETUP_COMPLETED, acts);
        }
        end(run, now_ms, acts);
}

void agility_run_abort(struct agility_run *run, uint64_t now_ms, struct agility_actions *acts)
{
        begin(run, now_ms, acts);
        go_offline(run, acts);
        end(run, now_ms, acts);
}

void agility_run_action(struct agility_run *run, uint64_t now_ms, uint32_t device,
                        bool has_keys, uint16_t keys, bool has_sensor, uint32_t sensor_ms,
                        struct agility_actions *acts)
{
        struct agility_key_event ev[AGILITY_KEY_EVENTS_MAX];
        bool keypad = is_keypad(run, device);
        unsigned n = 0, inter = 0;
        enum role role = gate_role(run, device, &inter);

        begin(run, now_ms, acts);
        if (!keypad && role == ROLE_NONE) {
                notice(acts, AGILITY_NOTICE_UNKNOWN_DEVICE, device, 0);
        } else if (!has_keys) {
                /* A time sensor reports a passage as a sensor time without keys (reference
                 * DeviceActionAdapter); a keypad's action without keys means nothing. */
                struct agility_passage p = { .received_ms = now_ms, .sensor_ms = sensor_ms,
                                             .has_sensor = true,
                                             .synced = gate_synced(run, device, now_ms) };

                if (role != ROLE_NONE && !has_sensor)
                        notice(acts, AGILITY_NOTICE_NO_TIME, device, 0);
                else if (role != ROLE_NONE)
                        passage(run, role, inter, &p, device, acts);
        } else if (agility_keys_feed(&run->keys, device, keys, keypad, ev, &n) == 0) {
                for (unsigned i = 0; i < n; i++)
                        key_event(run, now_ms, device, keypad, &ev[i], has_sensor, sensor_ms,
                                  acts);
        }
        end(run, now_ms, acts);
}

void agility_run_sync_device(struct agility_run *run, uint64_t now_ms, uint32_t device,
                             bool succeeded, struct agility_actions *acts)
{
        int g = gate_index(run, device);

        begin(run, now_ms, acts);
        if (run->state == AGILITY_WAITING_FOR_SYNC && g >= 0) {
                bool all = true;

                run->gate_synced[g] = succeeded;
                /* A gate may say it needs a sync (027:1) while the sync is on its way; its
                 * success afterwards answers that. */
                if (succeeded)
                        run->gate_lost[g] = false;
                for (unsigned i = 0; i < run->gate_count; i++)
                        all = all && run->gate_synced[i];
                if (all) {
                        run->sync_valid = true;
                        run->sync_at_ms = now_ms;
                        run->sync_recommended = false;
                        clear_or_show_existing(run, acts);
                }
        }
        end(run, now_ms, acts);
}

void agility_run_sync_done(struct agility_run *run, uint64_t now_ms,
                           struct agility_actions *acts)
{
        begin(run, now_ms, acts);
        if (run->state == AGILITY_WAITING_FOR_SYNC) {
                uint32_t failed = 0;

                for (unsigned i = 0; i < run->gate_count && failed == 0; i++)
                        if (!run->gate_synced[i])
                                failed = run->gates[i];
                /* The reference goes offline here; back to setup keeps the class, and Ready
                 * tries again with the same competitor. */
                notice(acts, AGILITY_NOTICE_SYNC_FAILED, failed, 0);
                set_state(run, AGILITY_SETUP_COMPLETED, acts);
        }
        end(run, now_ms, acts);
}

void agility_run_sync_lost(struct agility_run *run, uint64_t now_ms, uint32_t device,
                           struct agility_actions *acts)
{
        int g = gate_index(run, device);

        begin(run, now_ms, acts);
        if (g >= 0)
                run->gate_lost[g] = true;
        end(run, now_ms, acts);
}

void agility_run_tick(struct agility_run *run, uint64_t now_ms, struct agility_actions *acts)
{
        begin(run, now_ms, acts);
        end(run, now_ms, acts);
}

void agility_run_view(const struct agility_run *run, uint64_t now_ms,
                      struct agility_run_view *ret)
{
        *ret = (struct agility_run_view){
                .state = run->state,
                .current = run->state == AGILITY_OFFLINE ? 0 : run->current,
                .next = agility_run_next(run),
                .faults = run->faults,
                .refusals = run->refusals,
                .eliminated = eliminated(run),
                .started = run->started,
                .finished = run->finished,
                .precision = AGILITY_PRECISION_LOW,
                .intermediates = run->passed,
        };
        for (unsigned k = 0; k < run->passed; k++)
                ret->intermediate_ms[k] = run->intermediate[k].ms;
        if (run->finished) {
                ret->elapsed_ms = run->finish.ms;
                ret->precision = run->finish.precision;
        } else if (running(run) && now_ms > run->start.received_ms) {
                uint64_t e = now_ms - run->start.received_ms;

                ret->elapsed_ms = e > UINT32_MAX ? UINT32_MAX : (uint32_t)e;
        }
}
