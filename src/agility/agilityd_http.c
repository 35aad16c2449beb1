/*
 * sharedlink-agility's scoreboard (agilityd_http.h): libmicrohttpd, one thread per connection,
 * snapshots published by the engine thread under one mutex; a condition variable wakes the
 * event streams.
 */
#include "agility/agilityd_http.h"

#include <arpa/inet.h>
#include <errno.h>
#include <inttypes.h>
#include <pthread.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <microhttpd.h>

#include "agility/agility_export.h"
#include "svc/json.h"

#define NS_PER_MS               1000000ull
#define SSE_BLOCK               4096u           /* what MHD asks of the stream at a time */
#define NUM_MAX                 24
#define STATE_MAX               8192u           /* /api/state: two competitors' names at most */

struct agilityd_http {
        struct MHD_Daemon *mhd;
        const struct agilityd_config *cfg;
        pthread_mutex_t lock;
        pthread_cond_t changed;
        bool closing;
        uint64_t version;               /* counts publishes */
        struct agility_run_view view;
        uint64_t view_ms;
        char *results;                  /* /api/results */
        int results_len;
        char *csv;                      /* /api/results.csv */
        int csv_len;
};

/* One event stream: what it has sent, and the message being sent. */
struct sse {
        struct agilityd_http *h;
        uint64_t version;               /* the last version sent; 0: none yet */
        char *msg;
        size_t len, off;
};

_Static_assert(AGILITYD_HTTP_KEEPALIVE_MS < AGILITYD_HTTP_IDLE_S * 1000u,
               "an SSE stream sends before the idle timeout");

static uint64_t mono_ms(void)
{
        struct timespec ts;

        clock_gettime(CLOCK_MONOTONIC, &ts);
        return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / NS_PER_MS;
}

/* ---- the documents --------------------------------------------------------------------------- */

static void raw_num(struct json_buf *j, uint64_t v)
{
        char num[NUM_MAX];

        json_buf_raw(j, num, (size_t)snprintf(num, sizeof(num), "%" PRIu64, v));
}

static void member_num_or_null(struct json_buf *j, const char *key, bool has, uint64_t v)
{
        json_buf_key(j, key);
        if (has)
                raw_num(j, v);
        else
                json_buf_raw(j, "null", strlen("null"));
}

static void member_competitor(struct json_buf *j, const char *key,
                              const struct agilityd_config *cfg, uint16_t number)
{
        const struct agility_competitor *c =
                agility_competitors_find(cfg->competitors, cfg->competitor_count, number);

        json_buf_key(j, key);
        if (!c) {
                json_buf_raw(j, "null", strlen("null"));
                return;
        }
        json_buf_raw(j, "{", 1);
        j->need_comma = false;
        json_buf_u64(j, "number", c->number);
        json_buf_str(j, "handler", c->handler);
        json_buf_str(j, "dog", c->dog);
        json_buf_str(j, "country", c->country);
        json_buf_raw(j, "}", 1);
        j->need_comma = true;
}

static bool running(enum agility_state s)
{
        return s >= AGILITY_START_PASSED && s <= AGILITY_INTERMEDIATE3_PASSED;
}

int agilityd_json_state(char *buf, size_t size, const struct agilityd_config *cfg,
                        const struct agility_run_view *v, uint64_t view_ms, uint64_t now_ms)
{
        struct json_buf j;
        bool run = running(v->state) && !v->finished;

        json_buf_begin(&j, buf, size);
        json_buf_str(&j, "class", cfg->class_name);
        json_buf_str(&j, "state", agility_run_state_name(v->state));
        member_num_or_null(&j, "current", v->current != 0, v->current);
        member_num_or_null(&j, "next", v->next != 0, v->next);
        member_competitor(&j, "current_competitor", cfg, v->current);
        member_competitor(&j, "next_competitor", cfg, v->next);
        json_buf_u64(&j, "faults", v->faults);
        json_buf_u64(&j, "refusals", v->refusals);
        json_buf_bool(&j, "eliminated", v->eliminated);
        json_buf_bool(&j, "started", v->started);
        json_buf_bool(&j, "finished", v->finished);
        member_num_or_null(&j, "elapsed_ms", v->finished, v->elapsed_ms);
        json_buf_key(&j, "precision");
        if (v->finished)
                json_buf_quoted(&j, agility_timing_precision_name(v->precision),
                                strlen(agility_timing_precision_name(v->precision)));
        else
                json_buf_raw(&j, "null", strlen("null"));
        /* The clock since the start as received, as of now: the page ticks on from it. */
        member_num_or_null(&j, "running_ms", run, v->elapsed_ms +
                           (now_ms > view_ms ? now_ms - view_ms : 0));
        json_buf_key(&j, "intermediate_ms");
        json_buf_raw(&j, "[", 1);
        for (unsigned k = 0; k < v->intermediates; k++) {
                if (k)
                        json_buf_raw(&j, ",", 1);
                raw_num(&j, v->intermediate_ms[k]);
        }
        json_buf_raw(&j, "]", 1);
        json_buf_u64(&j, "standard_course_time_ms", cfg->cls.standard_course_time_ms);
        json_buf_u64(&j, "max_course_time_ms", cfg->cls.max_course_time_ms);
        return json_buf_end(&j);
}

static void result_object(struct json_buf *j, const struct agilityd_config *cfg,
                          const struct agility_result *r)
{
        const struct agility_competitor *c =
                agility_competitors_find(cfg->competitors, cfg->competitor_count, r->competitor);

        json_buf_raw(j, "{", 1);
        j->need_comma = false;
        json_buf_u64(j, "competitor", r->competitor);
        json_buf_str(j, "handler", c ? c->handler : "");
        json_buf_str(j, "dog", c ? c->dog : "");
        json_buf_str(j, "country", c ? c->country : "");
        json_buf_key(j, "intermediate_ms");
        json_buf_raw(j, "[", 1);
        for (unsigned k = 0; k < r->intermediates; k++) {
                if (k)
                        json_buf_raw(j, ",", 1);
                raw_num(j, r->intermediate_ms[k]);
        }
        json_buf_raw(j, "]", 1);
        member_num_or_null(j, "finish_ms", r->finished, r->finish_ms);
        json_buf_key(j, "precision");
        if (r->finished)
                json_buf_quoted(j, agility_timing_precision_name(r->finish_precision),
                                strlen(agility_timing_precision_name(r->finish_precision)));
        else
                json_buf_raw(j, "null", strlen("null"));
        json_buf_u64(j, "faults", r->faults);
        json_buf_u64(j, "refusals", r->refusals);
        json_buf_bool(j, "eliminated", r->eliminated);
        json_buf_u64(j, "penalty", r->penalty_ms);
        member_num_or_null(j, "placement", r->placement != 0, r->placement);
        json_buf_raw(j, "}", 1);
}

/* A JSON list, not an object: json_buf_begin's "{" is replaced by "[". */
int agilityd_json_results(char *buf, size_t size, const struct agilityd_config *cfg,
                          const struct agility_run *run)
{
        struct json_buf j;
        bool first = true;

        json_buf_begin(&j, buf, size);
        if (size)
                buf[0] = '[';
        for (size_t i = 0; i < run->count; i++) {
                const struct agility_result *r = run->order[i];

                if (!r || !r->completed)
                        continue;
                if (!first)
                        json_buf_raw(&j, ",", 1);
                first = false;
                result_object(&j, cfg, r);
        }
        json_buf_raw(&j, "]", 1);
        return j.overflow ? -ENOBUFS : (int)j.len;
}

int agilityd_csv_results(char *buf, size_t size, const struct agility_run *run)
{
        size_t len = 0;
        int n = agility_export_header(buf, size);

        if (n < 0)
                return n;
        len = (size_t)n;
        for (size_t i = 0; i < run->count; i++) {
                n = agility_export_row(buf + len, size - len, &run->competitors[i],
                                       &run->results[i]);
                if (n < 0)
                        return n;
                len += (size_t)n;
        }
        return (int)len;
}

/* ---- the page -------------------------------------------------------------------------------- */

/* The whole scoreboard: no file, no CDN, no framework; EventSource and a little DOM. The page
 * is served in two halves with the update of the moment between them (page_top's last element
 * opens <script type="application/json">): the page shows the run as it is from its first
 * paint, without waiting for a request of its own, and /events brings every change after. A
 * browser that reloads the page, or one that renders it headless and dumps it, sees the same. */
static const char page_top[] =
"<!DOCTYPE html>\n"
"<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
"<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
"<title>Agility scoreboard</title>\n"
"<style>\n"
"body{font-family:system-ui,sans-serif;margin:0;background:#111;color:#eee}\n"
"header{display:flex;justify-content:space-between;padding:.4em .8em;background:#246;"
"font-size:1.6em}\n"
"main{display:flex;flex-wrap:wrap;gap:1em;padding:1em}\n"
"section{background:#222;border-radius:.5em;padding:1em 1.2em;flex:1 1 24em}\n"
"h2{margin:0 0 .4em;font-size:1.2em;color:#9bd}\n"
".label{color:#9bd;font-size:1.1em}\n"
"#current{font-size:2.2em;font-weight:bold}\n"
"#clock{font-size:7em;font-weight:bold;font-variant-numeric:tabular-nums;"
"line-height:1.1;margin:.1em 0}\n"
".counts{display:flex;gap:1.5em;font-size:1.8em;align-items:baseline}\n"
".counts b{font-size:1.4em;font-variant-numeric:tabular-nums}\n"
".elim{color:#f55;font-weight:bold}.low{color:#fc6}\n"
"#next{font-size:1.3em}\n"
"table{border-collapse:collapse;width:100%;font-size:1.3em}\n"
"td,th{padding:.25em .5em;text-align:left}th{color:#9bd;border-bottom:1px solid #444}\n"
"td.place{font-weight:bold}td.time,td.penalty{font-variant-numeric:tabular-nums}\n"
"tr:nth-child(even){background:#2a2a2a}\n"
"</style></head><body>\n"
"<header><span id=\"class\"></span><span id=\"state\"></span></header>\n"
"<main><section>\n"
"<div class=\"label\">Current competitor</div><div id=\"current\">-</div>\n"
"<div id=\"clock\">0.000</div>\n"
"<div class=\"counts\"><span>Faults <b id=\"faults\">0</b></span>"
"<span>Refusals <b id=\"refusals\">0</b></span><span id=\"eliminated\" class=\"elim\"></span>"
"</div>\n"
"<p><span class=\"label\">Next</span> <span id=\"next\">-</span></p>\n"
"</section><section><h2>Ranking</h2><table><thead><tr><th>#</th><th>No</th><th>Handler</th>"
"<th>Dog</th><th>Time</th><th>F</th><th>R</th><th>Penalty</th></tr></thead>\n"
"<tbody id=\"ranking\"></tbody></table></section></main>\n"
"<script type=\"application/json\" id=\"initial\">";

static const char page_bottom[] =
"</script>\n"
"<script>\n"
"'use strict';\n"
"let st=null,at=0;\n"
"const $=id=>document.getElementById(id);\n"
"const secs=ms=>(ms/1000).toFixed(3);\n"
"const who=c=>c?c.number+' '+c.handler+' / '+c.dog:'-';\n"
"function tick(){\n"
" if(!st)return;\n"
" let ms=st.elapsed_ms!==null?st.elapsed_ms:st.running_ms!==null?"
"st.running_ms+(performance.now()-at):0;\n"
" $('clock').textContent=secs(ms)+(st.precision==='low'?'~':'');\n"
" $('clock').className=st.precision==='low'?'low':'';\n"
"}\n"
"function show(u){\n"
" st=u.state;at=performance.now();\n"
" $('class').textContent=st.class;$('state').textContent=st.state;\n"
" $('current').textContent=who(st.current_competitor);\n"
" $('next').textContent=who(st.next_competitor);\n"
" $('faults').textContent=st.faults;$('refusals').textContent=st.refusals;\n"
" $('eliminated').textContent=st.eliminated?'ELIMINATED':'';\n"
" const tb=$('ranking');tb.textContent='';\n"
" for(const r of u.results){\n"
"  const tr=document.createElement('tr');\n"
"  const t=r.finish_ms===null?'-':secs(r.finish_ms)+(r.precision==='low'?'~':'');\n"
"  const cells=[['place',r.placement===null?(r.eliminated?'E':'-'):r.placement],"
"['number',r.competitor],['handler',r.handler],['dog',r.dog],['time',t],"
"['faults',r.faults],['refusals',r.refusals],['penalty',secs(r.penalty)]];\n"
"  for(const [c,v] of cells){\n"
"   const td=document.createElement('td');td.className=c;td.textContent=v;"
"tr.appendChild(td);}\n"
"  tr.dataset.competitor=r.competitor;tb.appendChild(tr);\n"
" }\n"
" tick();\n"
"}\n"
"show(JSON.parse($('initial').textContent));\n"
"const es=new EventSource('/events');\n"
"es.addEventListener('update',e=>show(JSON.parse(e.data)));\n"
"setInterval(tick,50);\n"
"</script></body></html>\n";

/* ---- serving --------------------------------------------------------------------------------- */

static enum MHD_Result reply(struct MHD_Connection *conn, unsigned status, const char *type,
                             const char *body, size_t len)
{
        struct MHD_Response *resp = MHD_create_response_from_buffer(len, (void *)(uintptr_t)body,
                                                                    MHD_RESPMEM_MUST_COPY);
        enum MHD_Result r;

        if (!resp)
                return MHD_NO;
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, type);
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
        r = MHD_queue_response(conn, status, resp);
        MHD_destroy_response(resp);
        return r;
}

/* {"state":...,"results":...} of the current version between head and tail, malloc'd; called
 * with the lock held. */
static char *update_doc(struct agilityd_http *h, const char *head, const char *tail,
                        size_t *ret_len)
{
        static const char state_key[] = "{\"state\":";
        size_t head_len = strlen(head);
        size_t cap = head_len + sizeof(state_key) + STATE_MAX + (size_t)h->results_len +
                     strlen(tail) + 32;
        char *m = malloc(cap);
        size_t len = head_len;
        int n;

        if (!m)
                return NULL;
        memcpy(m, head, head_len);
        memcpy(m + len, state_key, sizeof(state_key) - 1);
        len += sizeof(state_key) - 1;
        n = agilityd_json_state(m + len, cap - len, h->cfg, &h->view, h->view_ms, mono_ms());
        if (n < 0) {
                free(m);
                return NULL;
        }
        len += (size_t)n;
        len += (size_t)snprintf(m + len, cap - len, ",\"results\":%s}%s", h->results, tail);
        *ret_len = len;
        return m;
}

/* The update message of the current version ("event: update\ndata: {...}\n\n"); as update_doc. */
static char *update_message(struct agilityd_http *h, size_t *ret_len)
{
        return update_doc(h, "event: update\ndata: ", "\n\n", ret_len);
}

static ssize_t sse_read(void *cls, uint64_t pos, char *buf, size_t max)
{
        struct sse *s = cls;
        struct agilityd_http *h = s->h;
        size_t n;

        (void)pos;
        if (s->off == s->len) {
                struct timespec until;
                uint64_t v;

                free(s->msg);
                s->msg = NULL;
                s->len = s->off = 0;
                clock_gettime(CLOCK_REALTIME, &until);
                until.tv_sec += AGILITYD_HTTP_KEEPALIVE_MS / 1000u;
                pthread_mutex_lock(&h->lock);
                while (!h->closing && h->version == s->version)
                        if (pthread_cond_timedwait(&h->changed, &h->lock, &until) == ETIMEDOUT)
                                break;
                v = h->version;
                if (!h->closing && v != s->version) {
                        s->msg = update_message(h, &s->len);
                        s->version = v;
                }
                pthread_mutex_unlock(&h->lock);
                if (h->closing)
                        return MHD_CONTENT_READER_END_OF_STREAM;
                if (!s->msg) {
                        /* Nothing new (or no memory): a comment keeps proxies from timing out. */
                        static const char ping[] = ": keepalive\n\n";

                        n = sizeof(ping) - 1 < max ? sizeof(ping) - 1 : max;
                        memcpy(buf, ping, n);
                        return (ssize_t)n;
                }
        }
        n = s->len - s->off < max ? s->len - s->off : max;
        memcpy(buf, s->msg + s->off, n);
        s->off += n;
        return (ssize_t)n;
}

static void sse_free(void *cls)
{
        struct sse *s = cls;

        free(s->msg);
        free(s);
}

static enum MHD_Result serve_events(struct agilityd_http *h, struct MHD_Connection *conn)
{
        struct sse *s = calloc(1, sizeof(*s));
        struct MHD_Response *resp;
        enum MHD_Result r;

        if (!s)
                return MHD_NO;
        s->h = h;
        resp = MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, SSE_BLOCK, sse_read, s,
                                                 sse_free);
        if (!resp) {
                free(s);
                return MHD_NO;
        }
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, "text/event-stream");
        MHD_add_response_header(resp, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
        r = MHD_queue_response(conn, MHD_HTTP_OK, resp);
        MHD_destroy_response(resp);
        return r;
}

static enum MHD_Result serve_copy(struct agilityd_http *h, struct MHD_Connection *conn,
                                  bool csv)
{
        enum MHD_Result r;

        pthread_mutex_lock(&h->lock);
        r = reply(conn, MHD_HTTP_OK, csv ? "text/csv; charset=utf-8" :
                  "application/json", csv ? h->csv : h->results,
                  (size_t)(csv ? h->csv_len : h->results_len));
        pthread_mutex_unlock(&h->lock);
        return r;
}

char *agilityd_page(const char *doc, size_t doc_len, size_t *ret_len)
{
        static const char lt[] = "\\u003c";
        size_t len, lts = 0;
        char *page;

        for (size_t i = 0; i < doc_len; i++)
                lts += doc[i] == '<';
        page = malloc(sizeof(page_top) + doc_len + lts * (sizeof(lt) - 2) + sizeof(page_bottom));
        if (!page)
                return NULL;
        memcpy(page, page_top, sizeof(page_top) - 1);
        len = sizeof(page_top) - 1;
        for (size_t i = 0; i < doc_len; i++) {
                if (doc[i] == '<') {
                        memcpy(page + len, lt, sizeof(lt) - 1);
                        len += sizeof(lt) - 1;
                } else {
                        page[len++] = doc[i];
                }
        }
        memcpy(page + len, page_bottom, sizeof(page_bottom));
        *ret_len = len + sizeof(page_bottom) - 1;
        return page;
}

static enum MHD_Result serve_page(struct agilityd_http *h, struct MHD_Connection *conn)
{
        char *doc, *page = NULL;
        size_t doc_len = 0, len = 0;
        enum MHD_Result r;

        pthread_mutex_lock(&h->lock);
        doc = update_doc(h, "", "", &doc_len);
        pthread_mutex_unlock(&h->lock);
        if (doc)
                page = agilityd_page(doc, doc_len, &len);
        free(doc);
        if (!page)
                return reply(conn, MHD_HTTP_INTERNAL_SERVER_ERROR, "text/plain", "", 0);
        r = reply(conn, MHD_HTTP_OK, "text/html; charset=utf-8", page, len);
        free(page);
        return r;
}

static enum MHD_Result serve_state(struct agilityd_http *h, struct MHD_Connection *conn)
{
        char buf[STATE_MAX];
        int n;

        /* Under the lock: a reload may replace the configuration (the names). */
        pthread_mutex_lock(&h->lock);
        n = agilityd_json_state(buf, sizeof(buf), h->cfg, &h->view, h->view_ms, mono_ms());
        pthread_mutex_unlock(&h->lock);
        if (n < 0)
                return reply(conn, MHD_HTTP_INTERNAL_SERVER_ERROR, "text/plain", "", 0);
        return reply(conn, MHD_HTTP_OK, "application/json", buf, (size_t)n);
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *conn, const char *url,
                                  const char *method, const char *version,
                                  const char *upload_data, size_t *upload_size, void **con_cls)
{
        static const char not_allowed[] = "read-only: GET and HEAD only\n";
        static const char not_found[] = "not found\n";
        struct agilityd_http *h = cls;

        (void)version;
        (void)upload_data;
        (void)upload_size;
        (void)con_cls;
        if (strcmp(method, MHD_HTTP_METHOD_GET) != 0 && strcmp(method, MHD_HTTP_METHOD_HEAD) != 0)
                return reply(conn, MHD_HTTP_METHOD_NOT_ALLOWED, "text/plain", not_allowed,
                             sizeof(not_allowed) - 1);
        if (strcmp(url, "/") == 0 || strcmp(url, "/index.html") == 0)
                return serve_page(h, conn);
        if (strcmp(url, "/api/state") == 0)
                return serve_state(h, conn);
        if (strcmp(url, "/api/results") == 0)
                return serve_copy(h, conn, false);
        if (strcmp(url, "/api/results.csv") == 0)
                return serve_copy(h, conn, true);
        if (strcmp(url, "/events") == 0)
                return serve_events(h, conn);
        return reply(conn, MHD_HTTP_NOT_FOUND, "text/plain", not_found, sizeof(not_found) - 1);
}

int agilityd_http_start(const struct agilityd_config *cfg, struct agilityd_http **ret,
                        uint16_t *ret_port, char *err, size_t err_size)
{
        struct agilityd_http *h = calloc(1, sizeof(*h));
        struct sockaddr_in6 a6 = { .sin6_family = AF_INET6 };
        struct sockaddr_in a4 = { .sin_family = AF_INET };
        const struct sockaddr *sa;
        const union MHD_DaemonInfo *info;
        unsigned flags = MHD_USE_THREAD_PER_CONNECTION | MHD_USE_INTERNAL_POLLING_THREAD |
                         MHD_USE_POLL;

        if (!h || !(h->results = malloc(AGILITYD_JSON_MAX)) ||
            !(h->csv = malloc(AGILITYD_JSON_MAX))) {
                snprintf(err, err_size, "http: out of memory");
                if (h) {
                        free(h->results);
                        free(h);
                }
                return -ENOMEM;
        }
        h->cfg = cfg;
        h->results_len = snprintf(h->results, AGILITYD_JSON_MAX, "[]");
        h->csv_len = 0;
        h->csv[0] = '\0';
        pthread_mutex_init(&h->lock, NULL);
        pthread_cond_init(&h->changed, NULL);
        if (inet_pton(AF_INET, cfg->http_host, &a4.sin_addr) == 1) {
                a4.sin_port = htons(cfg->http_port);
                sa = (const struct sockaddr *)&a4;
        } else {
                inet_pton(AF_INET6, cfg->http_host, &a6.sin6_addr);
                a6.sin6_port = htons(cfg->http_port);
                sa = (const struct sockaddr *)&a6;
                flags |= MHD_USE_IPv6;
        }
        h->mhd = MHD_start_daemon(flags, cfg->http_port, NULL, NULL, on_request, h,
                                  MHD_OPTION_SOCK_ADDR, sa,
                                  MHD_OPTION_CONNECTION_LIMIT,
                                  (unsigned)AGILITYD_HTTP_CONNECTIONS_MAX,
                                  MHD_OPTION_CONNECTION_TIMEOUT, (unsigned)AGILITYD_HTTP_IDLE_S,
                                  MHD_OPTION_END);
        if (!h->mhd) {
                snprintf(err, err_size, "http: cannot listen on %s port %u (in use, or not an "
                         "address of this machine)", cfg->http_host, (unsigned)cfg->http_port);
                agilityd_http_stop(h);
                return -EADDRNOTAVAIL;
        }
        info = MHD_get_daemon_info(h->mhd, MHD_DAEMON_INFO_BIND_PORT);
        *ret_port = info ? info->port : cfg->http_port;
        *ret = h;
        return 0;
}

void agilityd_http_publish(struct agilityd_http *h, const struct agilityd_config *cfg,
                           const struct agility_run *run, uint64_t now_ms)
{
        int n;

        if (!h)
                return;
        pthread_mutex_lock(&h->lock);
        h->cfg = cfg;
        agility_run_view(run, now_ms, &h->view);
        h->view_ms = now_ms;
        n = agilityd_json_results(h->results, AGILITYD_JSON_MAX, h->cfg, run);
        h->results_len = n < 0 ? snprintf(h->results, AGILITYD_JSON_MAX, "[]") : n;
        n = agilityd_csv_results(h->csv, AGILITYD_JSON_MAX, run);
        h->csv_len = n < 0 ? 0 : n;
        h->version++;
        pthread_cond_broadcast(&h->changed);
        pthread_mutex_unlock(&h->lock);
}

struct agilityd_http *agilityd_http_stop(struct agilityd_http *h)
{
        if (!h)
                return NULL;
        pthread_mutex_lock(&h->lock);
        h->closing = true;
        pthread_cond_broadcast(&h->changed);
        pthread_mutex_unlock(&h->lock);
        if (h->mhd)
                MHD_stop_daemon(h->mhd);
        pthread_cond_destroy(&h->changed);
        pthread_mutex_destroy(&h->lock);
        free(h->results);
        free(h->csv);
        free(h);
        return NULL;
}
