/*
 * A control server for in-process tests: the real control socket (daemon/control.c) on a real
 * event loop, in a private temp dir, and a guard timer so that a test pumping the loop for a
 * reply fails instead of hanging. The request handler is the test's.
 */
#pragma once

#include <stdbool.h>

#include "common/harness.h"
#include "daemon/control.h"
#include "svc/evloop.h"

struct ctlserver {
        struct harness h;               /* for its temp dir only */
        struct evloop *loop;
        struct control *ctl;
        char path[HARNESS_PATH_MAX + 32];       /* <dir>/c.sock */
        struct evloop_timer guard;      /* armed by the test; sets timed_out when it fires */
        bool timed_out;
};

/* Temp dir (harness_init(tag)), loop, logging to nowhere, the server on <dir>/c.sock handing
 * requests to on_request(arg), the guard (not armed). 0 or -1; ctlserver_free undoes a partial
 * one. */
int ctlserver_init(struct ctlserver *s, const char *tag, control_request_fn on_request,
                   void *arg);

/* Cancels the guard, frees the server (if the test has not), the loop, the temp dir. */
void ctlserver_free(struct ctlserver *s);
