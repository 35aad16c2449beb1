/*
 * The request worker (agilityd_worker.h): one thread, a bounded job queue and a bounded result
 * ring under one mutex, an eventfd to ring the loop. The loop and the thread each hold a
 * reference to the worker; the last one to let go frees it, so a stop that abandons a running
 * job never frees what that job still touches (nor closes the eventfd it may still ring).
 */
#include "agility/agilityd_worker.h"

#include <errno.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include "svc/log.h"

#define WORKER_REFS             2       /* the loop's and the thread's */

struct agilityd_worker_post {
        struct agilityd_worker *w;
        const struct agilityd_job *job;
};

struct agilityd_worker {
        struct evloop *loop;
        agilityd_worker_exec_fn exec;
        void *exec_arg;
        agilityd_worker_result_fn on_result;
        void *arg;
        int fd;                         /* eventfd: the thread writes, the loop reads */
        pthread_t thread;
        atomic_int refs;
        pthread_mutex_t lock;           /* everything below */
        pthread_cond_t work;            /* a job was queued, or the stop */
        pthread_cond_t room;            /* the loop took results, or the stop */
        bool stop;
        bool running;                   /* jobs[job_head] is being run */
        unsigned job_head, job_count;   /* the running job stays queued until it ends */
        struct agilityd_job jobs[AGILITYD_WORKER_JOBS_MAX];
        unsigned res_head, res_count;
        struct agilityd_result results[AGILITYD_WORKER_RESULTS_MAX];
        struct agilityd_worker_stats stats;
};

static void worker_unref(struct agilityd_worker *w)
{
        if (atomic_fetch_sub(&w->refs, 1) != 1)
                return;
        if (w->fd >= 0)
                close(w->fd);
        pthread_cond_destroy(&w->room);
        pthread_cond_destroy(&w->work);
        pthread_mutex_destroy(&w->lock);
        free(w);
}

/* With the lock held: waits for room in the result ring, then puts res there as job's. false
 * once the worker stops (nobody takes it). */
static bool result_push(struct agilityd_worker *w, const struct agilityd_job *job,
                        const struct agilityd_result *res)
{
        struct agilityd_result *slot;

        while (!w->stop && w->res_count == AGILITYD_WORKER_RESULTS_MAX)
                pthread_cond_wait(&w->room, &w->lock);
        if (w->stop)
                return false;
        slot = &w->results[(w->res_head + w->res_count) % AGILITYD_WORKER_RESULTS_MAX];
        *slot = *res;
        slot->job = job->kind;
        slot->tag = job->tag;
        w->res_count++;
        return true;
}

/* Rings the loop. The eventfd counts, so EAGAIN would need 2^64 - 1 unread rings; the thread's
 * reference keeps the fd open even after a stop. */
static int loop_ring(struct agilityd_worker *w)
{
        uint64_t one = 1;

        if (write(w->fd, &one, sizeof(one)) < 0 && errno != EAGAIN)
                return -errno;
        return 0;
}

static void *worker_main(void *arg)
{
        struct agilityd_worker *w = arg;
        struct agilityd_job job;

        pthread_mutex_lock(&w->lock);
        for (;;) {
                struct agilityd_worker_post post = { .w = w, .job = &job };
                struct agilityd_result done = { .kind = AGILITYD_RESULT_DONE };
                bool ring;

                while (!w->stop && w->job_count == 0)
                        pthread_cond_wait(&w->work, &w->lock);
                if (w->stop)
                        break;
                job = w->jobs[w->job_head];
                w->running = true;
                pthread_mutex_unlock(&w->lock);
                w->exec(&job, &post, &done, w->exec_arg);
                pthread_mutex_lock(&w->lock);
                done.kind = AGILITYD_RESULT_DONE;
                /* The end and the job's leaving the queue under one lock: a stop that sees the
                 * job still running sees no end of it on the loop. */
                ring = result_push(w, &job, &done);
                w->running = false;
                w->job_head = (w->job_head + 1u) % AGILITYD_WORKER_JOBS_MAX;
                w->job_count--;
                w->stats.done++;
                if (ring) {
                        pthread_mutex_unlock(&w->lock);
                        loop_ring(w);
                        pthread_mutex_lock(&w->lock);
                }
        }
        pthread_mutex_unlock(&w->lock);
        worker_unref(w);
        return NULL;
}

int agilityd_worker_post(struct agilityd_worker_post *post, const struct agilityd_result *res)
{
        struct agilityd_worker *w = post->w;
        bool ok;

        pthread_mutex_lock(&w->lock);
        ok = result_push(w, post->job, res);
        pthread_mutex_unlock(&w->lock);
        if (!ok)
                return -ECANCELED;
        return loop_ring(w);
}

bool agilityd_worker_stopping(struct agilityd_worker_post *post)
{
        bool stop;

        pthread_mutex_lock(&post->w->lock);
        stop = post->w->stop;
        pthread_mutex_unlock(&post->w->lock);
        return stop;
}

/* The loop: every result posted so far, one at a time and unlocked, so on_result may submit. */
static void worker_on_fd(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct agilityd_worker *w = arg;
        struct agilityd_result res;
        uint64_t v;

        (void)loop;
        (void)revents;
        if (read(fd, &v, sizeof(v)) < 0 && errno != EAGAIN)
                log_msg(LOG_PRIO_WARNING, "request worker eventfd: %s", strerror(errno));
        for (;;) {
                pthread_mutex_lock(&w->lock);
                if (w->stop || w->res_count == 0) {
                        pthread_mutex_unlock(&w->lock);
                        return;
                }
                res = w->results[w->res_head];
                w->res_head = (w->res_head + 1u) % AGILITYD_WORKER_RESULTS_MAX;
                w->res_count--;
                pthread_cond_signal(&w->room);
                pthread_mutex_unlock(&w->lock);
                w->on_result(&res, w->arg);
        }
}

int agilityd_worker_start(struct evloop *loop, agilityd_worker_exec_fn exec, void *exec_arg,
                          agilityd_worker_result_fn on_result, void *arg,
                          struct agilityd_worker **ret)
{
        struct agilityd_worker *w;
        int r;

        if (!loop || !exec || !on_result || !ret)
                return -EINVAL;
        w = calloc(1, sizeof(*w));
        if (!w)
                return -ENOMEM;
        w->loop = loop;
        w->exec = exec;
        w->exec_arg = exec_arg;
        w->on_result = on_result;
        w->arg = arg;
        atomic_init(&w->refs, 1);               /* the loop's; the thread's once it runs */
        pthread_mutex_init(&w->lock, NULL);
        pthread_cond_init(&w->work, NULL);
        pthread_cond_init(&w->room, NULL);
        w->fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
        if (w->fd < 0) {
                r = -errno;
                worker_unref(w);
                return r;
        }
        r = evloop_add_fd(loop, w->fd, POLLIN, worker_on_fd, w);
        if (r < 0) {
                worker_unref(w);
                return r;
        }
        atomic_store(&w->refs, WORKER_REFS);
        r = -pthread_create(&w->thread, NULL, worker_main, w);
        if (r < 0) {
                evloop_del_fd(loop, w->fd);
                atomic_store(&w->refs, 1);
                worker_unref(w);
                return r;
        }
        *ret = w;
        return 0;
}

int agilityd_worker_submit(struct agilityd_worker *w, const struct agilityd_job *job)
{
        int r = 0;

        if (!w || !job)
                return -EINVAL;
        pthread_mutex_lock(&w->lock);
        if (w->stop) {
                r = -ESHUTDOWN;
        } else if (w->job_count == AGILITYD_WORKER_JOBS_MAX) {
                w->stats.refused++;
                r = -ENOSPC;
        } else {
                w->jobs[(w->job_head + w->job_count) % AGILITYD_WORKER_JOBS_MAX] = *job;
                w->job_count++;
                pthread_cond_signal(&w->work);
        }
        pthread_mutex_unlock(&w->lock);
        return r;
}

struct agilityd_worker *agilityd_worker_stop(struct agilityd_worker *w,
                                             struct agilityd_worker_stats *ret_stats)
{
        bool running;

        if (!w)
                return NULL;
        pthread_mutex_lock(&w->lock);
        w->stop = true;
        running = w->running;
        w->stats.abandoned = running;
        w->stats.abandoned_kind = w->jobs[w->job_head].kind;
        w->stats.dropped += w->job_count - (running ? 1u : 0u);
        if (ret_stats)
                *ret_stats = w->stats;
        pthread_cond_broadcast(&w->work);
        pthread_cond_broadcast(&w->room);
        pthread_mutex_unlock(&w->lock);
        evloop_del_fd(w->loop, w->fd);
        /* An idle thread sees the stop at once: joined. One inside a request may wait for the
         * daemon as long as that request's timeout: left to end on its own (its reference keeps
         * the worker alive), or with the process. */
        if (running)
                pthread_detach(w->thread);
        else
                pthread_join(w->thread, NULL);
        worker_unref(w);
        return NULL;
}
