/*
 * sharedlink-agility: a request worker, so that the loop never waits for sharedlinkd
 * (docs/agility.md §9).
 *
 * A control request is a round trip to the daemon: a clock sync takes up to the specification's
 * 3 s, and any request waits for its whole timeout (5 s, a sync 15 s) when the daemon is stopped
 * or too busy to answer. The loop hands such a job to a worker instead: one thread that runs the
 * jobs of a bounded queue one at a time, in order, through the caller's exec function, which
 * may post results on the way (e.g. one per device) and fills in the job's end. The results
 * come back on the loop, through an eventfd, in the order they were posted, the end last, to
 * the caller's on_result; when the loop has the end, the worker has finished the job.
 *
 *      agilityd_worker_start(loop, exec, &lane, on_result, ctx, &w);
 *      agilityd_worker_submit(w, &job);        // -ENOSPC: the queue is full, nothing queued
 *      ...
 *      w = agilityd_worker_stop(w, &stats);    // never waits for a job that is running
 *
 * The decisions (docs/agility.md §9): a full queue refuses the job and counts it (the caller
 * decides: the displays never queue more than one job each, so it does not happen there); at
 * stop, the jobs not started are dropped and counted, and a job still running is abandoned, not
 * waited for (its thread ends when the call returns or with the process, its results are not
 * delivered), so a stop is prompt whatever the daemon does. A result the loop has not taken yet
 * waits in a bounded ring; a job that posts into a full ring waits for room (the loop takes them
 * at every turn) or for the stop.
 */
#ifndef SHAREDLINK_AGILITYD_WORKER_H
#define SHAREDLINK_AGILITYD_WORKER_H

#include <stdbool.h>
#include <stdint.h>

#include <sharedlink.h>

#include "agility/agilityd_config.h"
#include "svc/evloop.h"

#define AGILITYD_WORKER_JOBS_MAX    (AGILITYD_DISPLAYS_MAX + 1) /* a Visualize per display */
#define AGILITYD_WORKER_RESULTS_MAX 64          /* posted, not taken by the loop yet */
#define AGILITYD_WORKER_TEXT_MAX    512         /* a reply's text */

enum agilityd_job_kind {
        AGILITYD_JOB_SYNC_CLOCKS,               /* sl_circe_sync_clocks on link */
        AGILITYD_JOB_VISUALIZE,                 /* sl_circe_visualize of vis to dest on link */
};

/* What the loop asks for; copied into the queue whole. */
struct agilityd_job {
        enum agilityd_job_kind kind;
        uint64_t tag;                           /* the caller's (a sync's generation, a display) */
        char link[AGILITYD_NAME_MAX];
        char dest[SL_CIRCE_ADDRESS_SIZE];       /* VISUALIZE */
        struct sl_circe_visualize vis;          /* VISUALIZE; exec points dests at dest */
};

enum agilityd_result_kind {
        AGILITYD_RESULT_DEVICE,                 /* one device's clock sync: addr, succeeded */
        AGILITYD_RESULT_DONE,                   /* the job ended: err, text */
};

/* What a job reports; the job's kind and tag are filled in by the worker. */
struct agilityd_result {
        enum agilityd_result_kind kind;
        enum agilityd_job_kind job;
        uint64_t tag;
        char addr[SL_CIRCE_ADDRESS_SIZE];
        bool succeeded;
        int err;                                /* DONE: 0, or -errno */
        char text[AGILITYD_WORKER_TEXT_MAX];    /* DONE: the daemon's reply, or why not */
};

/* Counts since the start. */
struct agilityd_worker_stats {
        uint64_t done;                          /* jobs run to their end */
        uint64_t refused;                       /* submits refused: the queue was full */
        uint64_t dropped;                       /* jobs not started at the stop */
        bool abandoned;                         /* a job was still running at the stop */
        enum agilityd_job_kind abandoned_kind;
};

struct agilityd_worker;
struct agilityd_worker_post;                    /* where a running job posts its results */

/* Runs job on the worker's thread: results on the way through agilityd_worker_post, the end
 * (err, text) into *ret_done, which the worker posts as the job's last result. */
typedef void (*agilityd_worker_exec_fn)(const struct agilityd_job *job,
                                        struct agilityd_worker_post *post,
                                        struct agilityd_result *ret_done, void *arg);

/* A result, on the loop, in posting order. */
typedef void (*agilityd_worker_result_fn)(const struct agilityd_result *res, void *arg);

/* Starts the thread (signals must be blocked already: it inherits the mask) and puts its
 * eventfd on loop. 0 or -errno. */
int agilityd_worker_start(struct evloop *loop, agilityd_worker_exec_fn exec, void *exec_arg,
                          agilityd_worker_result_fn on_result, void *arg,
                          struct agilityd_worker **ret);

/* Queues a copy of job. 0, -ENOSPC (the queue is full: counted, nothing queued) or
 * -ESHUTDOWN. */
int agilityd_worker_submit(struct agilityd_worker *w, const struct agilityd_job *job);

/* From exec, on the worker's thread: hands res to the loop. 0, or -ECANCELED once the worker
 * stops (the job should end: nobody takes its results). */
int agilityd_worker_post(struct agilityd_worker_post *post, const struct agilityd_result *res);

/* Whether the worker has been told to stop (exec may end a long job early). */
bool agilityd_worker_stopping(struct agilityd_worker_post *post);

/* Stops: drops what is queued, abandons a running job (never waits for it), takes the eventfd
 * off the loop; the counts into *ret_stats (may be NULL). NULL-safe; returns NULL. */
struct agilityd_worker *agilityd_worker_stop(struct agilityd_worker *w,
                                             struct agilityd_worker_stats *ret_stats);

#endif
