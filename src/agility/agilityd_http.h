/*
 * sharedlink-agility: the scoreboard over HTTP (docs/agility.md §8, §11), read-only, served by
 * libmicrohttpd on its own threads (one per connection, so a Server-Sent Events stream may wait
 * for the next change without holding up anything else):
 *
 *   GET /                  the scoreboard page: one self-contained HTML file (no CDN, no
 *                          framework: venues have no internet) with the update of the moment
 *                          inside it, updated by /events
 *   GET /api/state         the run in progress (JSON)
 *   GET /api/results       the completed runs in ranking order (JSON list)
 *   GET /api/results.csv   every competitor in the reference controller's export format
 *   GET /events            text/event-stream: "event: update" with {"state":..., "results":...}
 *                          at once and at every change, a comment line every 15 s otherwise
 *
 * Any other method is 405; any other path 404. The engine thread publishes a snapshot after
 * every change (agilityd_http_publish); the HTTP threads only read snapshots, under a mutex.
 */
#ifndef SHAREDLINK_AGILITYD_HTTP_H
#define SHAREDLINK_AGILITYD_HTTP_H

#include <stddef.h>
#include <stdint.h>

#include "agility/agility_run.h"
#include "agility/agilityd_config.h"

#define AGILITYD_HTTP_CONNECTIONS_MAX 64        /* at once; SSE streams included */
#define AGILITYD_HTTP_KEEPALIVE_MS 15000u       /* an SSE comment when nothing changed */
/* A connection that neither sends nor receives for this long is closed, so that clients holding
 * idle sockets cannot take every one of AGILITYD_HTTP_CONNECTIONS_MAX; an SSE stream always
 * sends within AGILITYD_HTTP_KEEPALIVE_MS, so it is never cut. */
#define AGILITYD_HTTP_IDLE_S    60u
#define AGILITYD_JSON_MAX       (512u * 1024u)  /* results of 999 competitors, with names */

struct agilityd_http;

/* Starts serving on cfg's http_host:http_port (port 0: any free one, in *ret_port); cfg as in
 * agilityd_http_publish. 0, or -errno with err set. */
int agilityd_http_start(const struct agilityd_config *cfg, struct agilityd_http **ret,
                        uint16_t *ret_port, char *err, size_t err_size);

/* Publishes the engine's state at now_ms (its monotonic clock) to every reader and stream;
 * cfg (the class name and the competitors' names, which a reload replaces) must stay valid
 * until the next publish or the stop. */
void agilityd_http_publish(struct agilityd_http *h, const struct agilityd_config *cfg,
                           const struct agility_run *run, uint64_t now_ms);

/* Stops serving (open streams end); NULL-safe; returns NULL. */
struct agilityd_http *agilityd_http_stop(struct agilityd_http *h);

/* ---- the documents, for the server and the tests --------------------------------------------- */

/* /api/state for view v taken at view_ms, rendered at now_ms (the running clock moves on). The
 * length, or -ENOBUFS. */
int agilityd_json_state(char *buf, size_t size, const struct agilityd_config *cfg,
                        const struct agility_run_view *v, uint64_t view_ms, uint64_t now_ms);

/* /api/results: the completed runs of run, in ranking order. The length, or -ENOBUFS. */
int agilityd_json_results(char *buf, size_t size, const struct agilityd_config *cfg,
                          const struct agility_run *run);

/* The page around doc (the {"state":...,"results":...} of an update), malloc'd and
 * NUL-terminated, its length in *ret_len; NULL without memory. The JSON goes into a <script>
 * element: each '<' is written \u003c, so no name in it can end that element. */
char *agilityd_page(const char *doc, size_t doc_len, size_t *ret_len);

/* /api/results.csv. The length, or -ENOBUFS. */
int agilityd_csv_results(char *buf, size_t size, const struct agility_run *run);

#endif
