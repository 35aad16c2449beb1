/*
 * The waker (waker.h): one thread per waker, sleeping in sl_wait slices so that a stop is seen
 * within WAKER_SLICE_MS; the eventfd coalesces changes, so the loop runs once for a burst. With
 * an on_thread callback the thread does the caller's hot work itself and rings the loop only when
 * asked to; a change that comes while it works moves the change word past its cursor, so the next
 * sl_wait returns at once and nothing is missed.
 */
#include "svc/waker.h"

#include <errno.h>
#include <inttypes.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include "svc/log.h"

struct waker {
        struct evloop *loop;
        struct sl_client *c;
        waker_fn fn;
        waker_thread_fn on_thread;      /* NULL: none */
        void *arg;
        struct sl_wait_opts wait;       /* flags 0: plain sl_wait */
        int fd;                         /* eventfd: the thread writes, the loop reads */
        pthread_t thread;
        atomic_bool stop;
};

static void *waker_main(void *arg)
{
        struct waker *w = arg;
        uint32_t cursor = 0;
        uint64_t one = 1;

        while (!atomic_load(&w->stop)) {
                int r = sl_wait_with(w->c, &cursor, WAKER_SLICE_MS, &w->wait);

                if (r == 1 && (!w->on_thread || w->on_thread(w->arg)) &&
                    write(w->fd, &one, sizeof(one)) < 0 && errno != EAGAIN)
                        break;
                if (r < 0)
                        poll(NULL, 0, WAKER_SLICE_MS);  /* e.g. -ENOMEM: do not spin */
        }
        return NULL;
}

static void waker_on_fd(struct evloop *loop, int fd, unsigned revents, void *arg)
{
        struct waker *w = arg;
        uint64_t v;

        (void)loop;
        (void)revents;
        if (read(fd, &v, sizeof(v)) < 0 && errno != EAGAIN)
                log_msg(LOG_PRIO_WARNING, "waker eventfd: %s", strerror(errno));
        w->fn(w->arg);
}

int waker_start(struct evloop *loop, struct sl_client *c, waker_fn fn, void *arg,
                struct waker **ret)
{
        return waker_start_with(loop, c, fn, arg, NULL, ret);
}

int waker_start_with(struct evloop *loop, struct sl_client *c, waker_fn fn, void *arg,
                     const struct waker_opts *opts, struct waker **ret)
{
        struct waker_opts none = { 0 };
        struct waker *w;
        int r;

        if (!opts)
                opts = &none;
        if (opts->spin_us > SL_WAIT_SPIN_MAX_US) {
                log_msg(LOG_PRIO_ERR, "waker: a spin of %" PRIu32 " us is over %u",
                        opts->spin_us, SL_WAIT_SPIN_MAX_US);
                return -EINVAL;
        }
        w = calloc(1, sizeof(*w));
        if (!w)
                return -ENOMEM;
        *w = (struct waker){
                .loop = loop, .c = c, .fn = fn, .on_thread = opts->on_thread, .arg = arg,
                .wait = { .size = sizeof(w->wait), .flags = opts->spin_us ? SL_WAIT_SPIN : 0,
                          .spin_us = opts->spin_us },
        };
        w->fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
        if (w->fd < 0) {
                r = -errno;
                log_msg(LOG_PRIO_ERR, "waker eventfd: %s", strerror(-r));
                free(w);
                return r;
        }
        r = evloop_add_fd(loop, w->fd, POLLIN, waker_on_fd, w);
        if (r == 0) {
                r = -pthread_create(&w->thread, NULL, waker_main, w);
                if (r < 0)
                        evloop_del_fd(loop, w->fd);
        }
        if (r < 0) {
                log_msg(LOG_PRIO_ERR, "waker thread: %s", strerror(-r));
                close(w->fd);
                free(w);
                return r;
        }
        *ret = w;
        return 0;
}

struct waker *waker_stop(struct waker *w)
{
        if (!w)
                return NULL;
        atomic_store(&w->stop, true);
        pthread_join(w->thread, NULL);
        evloop_del_fd(w->loop, w->fd);
        close(w->fd);
        free(w);
        return NULL;
}
