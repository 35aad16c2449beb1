/*
 * Control server for in-process tests (see ctlserver.h).
 */
#include "common/ctlserver.h"

#include <stdio.h>

#include "svc/log.h"

static void on_guard(struct evloop *loop, struct evloop_timer *t, void *arg)
{
        (void)loop;
        (void)t;
        ((struct ctlserver *)arg)->timed_out = true;
}

int ctlserver_init(struct ctlserver *s, const char *tag, control_request_fn on_request,
                   void *arg)
{
        if (harness_init(&s->h, tag) < 0 || evloop_new(&s->loop) < 0)
                return -1;
        evloop_timer_init(&s->guard, s->loop, on_guard, s);
        log_init(-1, -1);
        snprintf(s->path, sizeof(s->path), "%s/c.sock", s->h.dir);
        return control_new(s->loop, s->path, 0, 0, on_request, arg, &s->ctl) < 0 ? -1 : 0;
}

void ctlserver_free(struct ctlserver *s)
{
        if (s->loop)
                evloop_timer_cancel(&s->guard);
        s->ctl = control_free(s->ctl);
        s->loop = evloop_free(s->loop);
        harness_cleanup(&s->h);
}
