/*
 * sharedlink-mqtt bridge logic (see bridge.h).
 */
#include "mqtt/bridge.h"

#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sharedlink.h>

#include "svc/cursor.h"
#include "mqtt/bridge_format.h"
#include "svc/changes.h"
#include "svc/evjson.h"
#include "svc/json.h"
#include "svc/log.h"

#define INSTANCE_ENV            "SHAREDLINK_INSTANCE"
#define INSTANCE_DEFAULT        "default"
#define FLAGS_PUBLISHED         (SL_FLAG_VALID | SL_FLAG_STALE | SL_FLAG_REPAIRED)

struct bridge_var {
        struct sl_var_info info;
        bool publish;                   /* matches publish: and the name can be a topic */
        bool published;                 /* something is retained on its topics */
        uint32_t flags;                 /* what was published last */
        char value[SL_VALUE_SIZE];
};

/* A published event (or notice) not yet acknowledged, with the position it moves the cursor
 * to once it and everything before it are acknowledged. */
struct inflight {
        int mid;
        bool acked;
        struct cursor pos;
};

struct bridge {
        const struct bridge_config *cfg;
        char instance[BRIDGE_INSTANCE_MAX];
        char base[BRIDGE_BASE_MAX];
        char cursor_path[BRIDGE_PATH_MAX];
        struct sl_client *cl;
        uint64_t epoch;                 /* of the daemon run seen last */

        struct bridge_var *vars;
        unsigned n_vars, cap_vars;
        struct changes changes;         /* what changed since the last scan (sl_changed) */
        bool read_all;                  /* the next scan reads every variable */
        int alive;                      /* sl_daemon_alive at the last scan (-1: none yet) */
        char link_state[BRIDGE_LINKS_MAX][SL_STATE_NAME_SIZE];
        char link_name[BRIDGE_LINKS_MAX][SL_LINK_NAME_SIZE];
        bool link_published[BRIDGE_LINKS_MAX];
        const char *status;             /* published last, NULL: never */
        bool writes_ready;              /* set/ messages reach the bridge (bridge_writes_ready) */

        struct cursor read;             /* after the last event published */
        struct cursor done;             /* after the last event acknowledged (what goes to disk) */
        bool done_dirty;
        bool announce_restart;          /* a "daemon-restarted" notice is due */
        struct inflight *window;
        unsigned w_head, w_count;

        struct bridge_counters counters;
        uint64_t counters_version;
};

static void count(struct bridge *b, uint64_t *counter, uint64_t n)
{
        *counter += n;
        b->counters_version++;
}

int bridge_new(const struct bridge_config *cfg, struct bridge **ret)
{
        struct bridge *b = calloc(1, sizeof(*b));
        const char *inst = cfg->instance[0] ? cfg->instance : getenv(INSTANCE_ENV);
        int n;

        if (!b)
                return -ENOMEM;
        b->cfg = cfg;
        b->alive = -1;
        if (!inst || !inst[0])
                inst = INSTANCE_DEFAULT;
        if (strlen(inst) >= sizeof(b->instance) || strpbrk(inst, "/+#")) {
                free(b);
                return -EINVAL;
        }
        strcpy(b->instance, inst);
        n = snprintf(b->base, sizeof(b->base), "%s/%s", cfg->prefix, b->instance);
        if (n < 0 || (size_t)n >= sizeof(b->base)) {
                free(b);
                return -EINVAL;
        }
        if (cfg->cursor_file[0])
                n = snprintf(b->cursor_path, sizeof(b->cursor_path), "%s", cfg->cursor_file);
        else
                n = snprintf(b->cursor_path, sizeof(b->cursor_path), BRIDGE_CURSOR_DIR "/%s.cursor",
                             b->instance);
        if (n < 0 || (size_t)n >= sizeof(b->cursor_path)) {
                free(b);
                return -EINVAL;
        }
        b->window = calloc(cfg->events_window ? cfg->events_window : 1, sizeof(*b->window));
        if (!b->window) {
                free(b);
                return -ENOMEM;
        }
        *ret = b;
        return 0;
}

struct bridge *bridge_free(struct bridge *b)
{
        if (!b)
                return NULL;
        sl_close(b->cl);
        free(b->vars);
        free(b->window);
        free(b);
        return NULL;
}

bool bridge_attached(const struct bridge *b)
{
        return b->cl != NULL;
}

struct sl_client *bridge_client(struct bridge *b)
{
        return b->cl;
}

const char *bridge_base(const struct bridge *b)
{
        return b->base;
}

static uint64_t daemon_epoch(struct bridge *b)
{
        struct sl_daemon_info di = { .size = sizeof(di) };

        return sl_daemon_info(b->cl, &di) == 0 ? di.epoch : b->epoch;
}

/* Where the events start: after the cursor on disk when it belongs to this daemon run; else at
 * the oldest event the ring still holds (a first start, or a daemon that restarted meanwhile:
 * the ring's history is published rather than risking the loss of a gate passage). */
static void cursor_start(struct bridge *b)
{
        struct cursor c;
        int r = cursor_load(b->cursor_path, BRIDGE_CURSOR_OWNER, &c);

        memset(&b->read, 0, sizeof(b->read));
        b->read.epoch = b->epoch;
        if (r == 0 && c.epoch == b->epoch) {
                b->read = c;
                log_msg(LOG_PRIO_INFO, "events: resuming after event %" PRIu64 " (%s)",
                        c.seq, b->cursor_path);
        } else if (r == 0) {
                b->announce_restart = true;
                log_msg(LOG_PRIO_NOTICE, "events: %s is of another daemon run (epoch "
                        "%016" PRIx64 "): starting at the oldest event retained",
                        b->cursor_path, c.epoch);
        } else if (r == -ENOENT) {
                log_msg(LOG_PRIO_INFO, "events: no cursor in %s yet: starting at the "
                        "oldest event retained", b->cursor_path);
        } else {
                count(b, &b->counters.cursor_errors, 1);
                log_msg(LOG_PRIO_WARNING, "events: %s: %s: starting at the oldest event "
                        "retained (events may repeat)", b->cursor_path,
                        r == -EBADMSG ? "not a cursor file" : strerror(-r));
        }
        b->done = b->read;
        b->done_dirty = false;
}

int bridge_attach(struct bridge *b)
{
        int r;

        if (b->cl)
                return 0;
        r = sl_open(b->instance, &b->cl);
        if (r < 0) {
                b->cl = NULL;
                return r;
        }
        b->epoch = daemon_epoch(b);
        log_msg(LOG_PRIO_INFO, "instance %s: %d variables, %d links", b->instance,
                sl_count(b->cl), sl_link_count(b->cl));
        if (b->cfg->events)
                cursor_start(b);
        return 0;
}

static int publish(struct bridge *b, const struct bridge_sink *sink, const char *topic,
                   const void *payload, size_t len, int qos, bool retain, int *ret_mid)
{
        int mid = 0;
        int r = sink->publish(sink->arg, topic, payload, len, qos, retain, &mid);

        if (r < 0) {
                count(b, &b->counters.publish_errors, 1);
                return r;
        }
        if (ret_mid)
                *ret_mid = mid;
        return 0;
}

/* ---- values ---------------------------------------------------------------------------------- */

static int var_describe(struct bridge *b, int id, struct bridge_var *v)
{
        v->info.size = sizeof(v->info);
        if (sl_info(b->cl, id, &v->info) < 0)
                return -ENOENT;
        if (!bridge_format_name_ok(v->info.name)) {
                if (v->publish || !v->published)
                        log_msg(LOG_PRIO_WARNING, "variable %s: the name cannot be an MQTT "
                                "topic level: not published", v->info.name);
                count(b, &b->counters.unpublishable, 1);
                v->publish = false;
                return 0;
        }
        v->publish = globs_match(&b->cfg->publish, v->info.name);
        return 0;
}

/* New ids (names the daemon added, or a first scan); bounded by the daemon's table. */
static int vars_grow(struct bridge *b)
{
        int n = sl_count(b->cl);

        if (n < 0)
                return n;
        if ((unsigned)n > BRIDGE_VARS_MAX)
                n = BRIDGE_VARS_MAX;
        if ((unsigned)n > b->cap_vars) {
                struct bridge_var *nv = realloc(b->vars, (size_t)n * sizeof(*nv));

                if (!nv)
                        return -ENOMEM;
                b->vars = nv;
                b->cap_vars = (unsigned)n;
        }
        for (unsigned id = b->n_vars; id < (unsigned)n; id++) {
                struct bridge_var *v = &b->vars[id];

                memset(v, 0, sizeof(*v));
                var_describe(b, (int)id, v);
        }
        b->n_vars = (unsigned)n;
        return 0;
}

static const char *link_name(struct bridge *b, int link)
{
        return link >= 0 && link < BRIDGE_LINKS_MAX ? b->link_name[link] : "";
}

/* The value (retained; an empty payload clears the retained message: a value never set, lost or
 * gone) and the meta JSON. */
static int var_publish(struct bridge *b, const struct bridge_sink *sink, struct bridge_var *v,
                       const char *value, const struct sl_meta *meta)
{
        char topic[BRIDGE_TOPIC_MAX], json[BRIDGE_JSON_MAX];
        size_t len = meta && (meta->flags & SL_FLAG_VALID) ? strlen(value) : 0;
        int r, n;

        if (bridge_format_topic(topic, sizeof(topic), b->base, v->info.name, NULL) < 0)
                return -ENAMETOOLONG;
        r = publish(b, sink, topic, value, len, b->cfg->qos, b->cfg->retain, NULL);
        if (r < 0)
                return r;
        count(b, &b->counters.values_published, 1);
        if (b->cfg->meta != BRIDGE_META_JSON)
                return 0;
        bridge_format_topic(topic, sizeof(topic), b->base, v->info.name, BRIDGE_TOPIC_META);
        if (meta)
                n = bridge_format_meta(json, sizeof(json), &v->info, meta,
                                       link_name(b, v->info.link));
        else
                n = 0;  /* the variable is gone: clear its meta too */
        if (n < 0)
                return n;
        return publish(b, sink, topic, json, (size_t)n, b->cfg->qos, b->cfg->retain, NULL);
}

static int var_scan(struct bridge *b, const struct bridge_sink *sink, unsigned id, bool full)
{
        struct bridge_var *v = &b->vars[id];
        struct sl_meta meta = { .size = sizeof(meta) };
        char value[SL_VALUE_SIZE];
        int r;

        if (!v->publish)
                return 0;
        r = sl_read(b->cl, (int)id, value, sizeof(value), &meta);
        if (r == -ENOENT) {     /* gone with a daemon restart: clear what we retained */
                if (!v->published)
                        return 0;
                r = var_publish(b, sink, v, "", NULL);
                if (r == 0)
                        v->published = false;
                return r < 0 ? r : 1;
        }
        if (r < 0) {
                b->read_all = true;     /* -EAGAIN: a writer kept it busy; the next scan */
                return 0;
        }
        /* On change of the value or of its state: a peer that repeats a value every period
         * bumps the sequence without news for a subscriber. */
        if (!full && v->published && v->flags == (meta.flags & FLAGS_PUBLISHED) &&
            !strcmp(v->value, value))
                return 0;
        r = var_publish(b, sink, v, value, &meta);
        if (r < 0)
                return r;
        v->published = true;
        v->flags = meta.flags & FLAGS_PUBLISHED;
        memcpy(v->value, value, sizeof(value));
        return 1;
}

struct values_scan {
        struct bridge *b;
        const struct bridge_sink *sink;
        int sent;
};

/* One id sl_changed named (changes_fn): a name added since the last scan is described first. */
static int value_changed(void *arg, int id)
{
        struct values_scan *vs = arg;
        struct bridge *b = vs->b;
        int r;

        if ((unsigned)id >= b->n_vars && (r = vars_grow(b)) < 0)
                return r;
        if ((unsigned)id >= b->n_vars)
                return 0;
        r = var_scan(b, vs->sink, (unsigned)id, false);
        if (r < 0)
                return r;
        vs->sent += r;
        return 0;
}

/*
 * The values: those sl_changed names (svc/changes.h says why what goes out is never older than
 * the table), or every one when it says so, when full, or when the last scan left something
 * unread: one that failed half-way (the broker gone) took ids it did not publish. So does a
 * scan after the daemon stopped or came back, since staleness by heartbeat is no change the
 * daemon can record.
 */
static int values_scan(struct bridge *b, const struct bridge_sink *sink, bool full)
{
        struct values_scan vs = { b, sink, 0 };
        int alive = sl_daemon_alive(b->cl), r;
        bool all = full || b->read_all || alive != b->alive;

        b->alive = alive;
        b->read_all = false;
        r = changes_follow(&b->changes, b->cl, all, value_changed, &vs);
        for (unsigned id = 0; r == 1 && id < b->n_vars; id++) {
                int n = var_scan(b, sink, id, full);

                if (n < 0) {
                        r = n;
                        break;
                }
                vs.sent += n;
        }
        if (r < 0) {
                b->read_all = true;
                return r;
        }
        return vs.sent;
}

static int links_scan(struct bridge *b, const struct bridge_sink *sink, bool full)
{
        int n = sl_link_count(b->cl), sent = 0;

        for (int i = 0; i < n && i < BRIDGE_LINKS_MAX; i++) {
                struct sl_link_info li = { .size = sizeof(li) };
                char topic[BRIDGE_TOPIC_MAX];

                if (sl_link_info(b->cl, i, &li) < 0)
                        continue;
                snprintf(b->link_name[i], sizeof(b->link_name[i]), "%s", li.name);
                if (!full && b->link_published[i] && !strcmp(b->link_state[i], li.state_name))
                        continue;
                if (!bridge_format_name_ok(li.name) ||
                    bridge_format_topic(topic, sizeof(topic), b->base, BRIDGE_TOPIC_LINKS,
                                        li.name) < 0)
                        continue;
                if (publish(b, sink, topic, li.state_name, strlen(li.state_name), b->cfg->qos,
                            true, NULL) < 0)
                        return -ENOTCONN;
                snprintf(b->link_state[i], sizeof(b->link_state[i]), "%s", li.state_name);
                b->link_published[i] = true;
                sent++;
        }
        return sent;
}

const char *bridge_status(struct bridge *b)
{
        return b->cl && sl_daemon_alive(b->cl) == 1 ? BRIDGE_STATUS_ONLINE :
                                                       BRIDGE_STATUS_OFFLINE;
}

static int status_scan(struct bridge *b, const struct bridge_sink *sink, bool full)
{
        const char *s = bridge_status(b);
        bool waiting = b->cfg->writable.count > 0 && !b->writes_ready &&
                       !strcmp(s, BRIDGE_STATUS_ONLINE);
        char topic[BRIDGE_TOPIC_MAX];
        bool news;

        /* online promises that writes are taken too, when there are any to take. Right after
         * a connection the writes' subscription is a moment behind: the broker holds offline
         * then (the will, or the last clean stop), so nothing is said until it is online;
         * writes that stop being taken later make it offline. */
        if (waiting && (full || !b->status)) {
                b->status = NULL;
                return 0;
        }
        if (waiting)
                s = BRIDGE_STATUS_OFFLINE;
        news = !b->status || strcmp(b->status, s) != 0;
        if (!full && !news)
                return 0;
        bridge_format_topic(topic, sizeof(topic), b->base, BRIDGE_TOPIC_STATUS, NULL);
        if (publish(b, sink, topic, s, strlen(s), BRIDGE_STATUS_QOS, true, NULL) < 0)
                return -ENOTCONN;
        if (news)
                log_msg(LOG_PRIO_INFO, "status: %s", s);
        b->status = s;
        return 1;
}

int bridge_scan(struct bridge *b, const struct bridge_sink *sink, bool full)
{
        int r, sent = 0;
        uint64_t epoch;

        if (!b->cl)
                return status_scan(b, sink, full);
        epoch = daemon_epoch(b);
        if (epoch != b->epoch) {
                /* A new daemon run: the library re-resolved our ids by name, but what they
                 * describe (link, peer, type) may differ. */
                b->epoch = epoch;
                for (unsigned id = 0; id < b->n_vars; id++)
                        var_describe(b, (int)id, &b->vars[id]);
                full = true;
        }
        if ((r = vars_grow(b)) < 0)
                return r;
        if ((r = links_scan(b, sink, full)) < 0)
                return r;
        sent += r;
        if ((r = values_scan(b, sink, full)) < 0)
                return r;
        sent += r;
        if ((r = status_scan(b, sink, full)) < 0)
                return r;
        return sent + r;
}

/* ---- events ---------------------------------------------------------------------------------- */

static int window_push(struct bridge *b, int mid, const struct cursor *pos)
{
        struct inflight *w = &b->window[(b->w_head + b->w_count) % b->cfg->events_window];

        w->mid = mid;
        w->acked = false;
        w->pos = *pos;
        b->w_count++;
        return 0;
}

/* A notice: it moves the cursor nowhere (its position is the event before it). */
static int notice(struct bridge *b, const struct bridge_sink *sink, const char *type,
                  uint64_t seq, uint64_t lost)
{
        char topic[BRIDGE_TOPIC_MAX], json[BRIDGE_JSON_MAX];
        int n = evjson_notice(json, sizeof(json), type, b->epoch, seq, lost), mid, r;

        bridge_format_topic(topic, sizeof(topic), b->base, BRIDGE_TOPIC_EVENTS, NULL);
        r = publish(b, sink, topic, json, (size_t)n, b->cfg->events_qos, false, &mid);
        if (r < 0)
                return r;
        log_msg(LOG_PRIO_NOTICE, "events: %s before event %" PRIu64 " (%" PRIu64 " lost)",
                type, seq, lost);
        return window_push(b, mid, &b->read);
}

static int event_publish(struct bridge *b, const struct bridge_sink *sink,
                         const struct sl_event *ev, const struct cursor *pos)
{
        char topic[BRIDGE_TOPIC_MAX], json[EVJSON_MAX];
        int n, mid, r;

        if (ev->link_name[0] && bridge_format_name_ok(ev->link_name))
                r = bridge_format_topic(topic, sizeof(topic), b->base, BRIDGE_TOPIC_EVENTS,
                                        ev->link_name);
        else
                r = bridge_format_topic(topic, sizeof(topic), b->base, BRIDGE_TOPIC_EVENTS, NULL);
        n = evjson_event(json, sizeof(json), b->epoch, ev);
        if (r < 0 || n < 0)
                return r < 0 ? r : n;
        r = publish(b, sink, topic, json, (size_t)n, b->cfg->events_qos, false, &mid);
        if (r < 0)
                return r;
        count(b, &b->counters.events_published, 1);
        return window_push(b, mid, pos);
}

int bridge_pump(struct bridge *b, const struct bridge_sink *sink)
{
        int sent = 0, r;

        if (!b->cl || !b->cfg->events)
                return 0;
        /* Events acknowledged since the cursor was last written would be sent again by a bridge
         * killed now, on top of those in flight: the cursor goes to disk before the window
         * refills, so a killed bridge repeats at most events_window events. */
        if (b->done_dirty)
                bridge_cursor_flush(b, false);
        /* A notice and its event take two places: stop while fewer are free. */
        while (b->w_count + 2 <= b->cfg->events_window) {
                struct sl_event ev = { .size = sizeof(ev) };
                struct cursor pos;
                uint64_t cursor = b->read.cursor;

                r = sl_events_read(b->cl, &cursor, &ev, 1);
                if (r == -EAGAIN || r == 0)
                        break;
                if (r < 0)
                        return r;
                if (ev.flags & SL_EVENT_RESTARTED) {
                        b->epoch = daemon_epoch(b);
                        b->announce_restart = true;
                }
                if (b->announce_restart) {
                        if ((r = notice(b, sink, EVJSON_RESTARTED, ev.seq, 0)) < 0)
                                return r;
                        b->announce_restart = false;
                }
                if (ev.lost) {
                        count(b, &b->counters.events_lost, ev.lost);
                        if ((r = notice(b, sink, EVJSON_OVERRUN, ev.seq, ev.lost)) < 0)
                                return r;
                }
                pos = (struct cursor){ .epoch = b->epoch, .cursor = cursor,
                                              .seq = ev.seq };
                if ((r = event_publish(b, sink, &ev, &pos)) < 0)
                        return r;
                b->read = pos;
                sent++;
        }
        return sent;
}

void bridge_acked(struct bridge *b, int mid)
{
        unsigned cap = b->cfg->events_window;

        for (unsigned i = 0; i < b->w_count; i++) {
                struct inflight *w = &b->window[(b->w_head + i) % cap];

                if (w->mid == mid && !w->acked) {
                        w->acked = true;
                        break;
                }
        }
        /* The cursor moves only over a prefix of acknowledged events: ring order. */
        while (b->w_count > 0 && b->window[b->w_head].acked) {
                b->done = b->window[b->w_head].pos;
                b->done_dirty = true;
                b->w_head = (b->w_head + 1) % cap;
                b->w_count--;
                count(b, &b->counters.events_acked, 1);
        }
}

void bridge_broker_error(struct bridge *b)
{
        count(b, &b->counters.broker_errors, 1);
}

unsigned bridge_unacked(const struct bridge *b)
{
        return b->w_count;
}

int bridge_cursor_flush(struct bridge *b, bool sync)
{
        int r;

        if (!b->done_dirty && !sync)
                return 0;
        if (!b->cfg->events || !b->cl)
                return 0;
        r = cursor_store(b->cursor_path, BRIDGE_CURSOR_OWNER, &b->done, sync);
        if (r < 0) {
                count(b, &b->counters.cursor_errors, 1);
                log_msg(LOG_PRIO_WARNING, "events: cannot write %s: %s", b->cursor_path,
                        strerror(-r));
                return r;
        }
        b->done_dirty = false;
        return 0;
}

/* ---- set/ ------------------------------------------------------------------------------------ */

static int refuse_detail(struct bridge *b, const struct bridge_sink *sink, const char *name,
                         enum bridge_refusal why, int err, const char *detail);

static int refuse(struct bridge *b, const struct bridge_sink *sink, const char *name,
                  enum bridge_refusal why, int err)
{
        return refuse_detail(b, sink, name, why, err, NULL);
}

/* refuse(), the error's detail saying why (NULL: sl_strerror(err)). */
static int refuse_detail(struct bridge *b, const struct bridge_sink *sink, const char *name,
                         enum bridge_refusal why, int err, const char *detail)
{
        char topic[BRIDGE_TOPIC_MAX], json[BRIDGE_JSON_MAX];
        char set[BRIDGE_TOPIC_MAX];
        int n;

        count(b, &b->counters.set_refused, 1);
        log_msg(LOG_PRIO_DEBUG, "set %s: refused: %s", name, bridge_format_refusal(why));
        if (!name[0])
                return -EINVAL;
        bridge_format_topic(set, sizeof(set), b->base, BRIDGE_TOPIC_SET, name);
        n = bridge_format_error(json, sizeof(json), name, why, err, detail);
        if (n >= 0 && (size_t)snprintf(topic, sizeof(topic), "%s/" BRIDGE_TOPIC_ERROR, set) <
                      sizeof(topic))
                publish(b, sink, topic, json, (size_t)n, b->cfg->set_qos, false, NULL);
        return why == BRIDGE_REFUSE_INBOUND || why == BRIDGE_REFUSE_NOT_WRITABLE ||
               why == BRIDGE_REFUSE_RETAINED || why == BRIDGE_REFUSE_QUEUED ? -EPERM : -EINVAL;
}

int bridge_set(struct bridge *b, const struct bridge_sink *sink, const char *topic,
               const void *payload, size_t len, enum bridge_set_via via)
{
        struct sl_var_info info = { .size = sizeof(info) };
        char name[SL_NAME_SIZE] = "", value[SL_VALUE_SIZE], reason[SL_WRITE_REASON_SIZE];
        enum bridge_refusal why;
        int r = bridge_format_set_topic(b->base, topic, name), id;

        if (r == 0)
                return 0;
        if (r < 0) {
                log_msg(LOG_PRIO_DEBUG, "set: topic %.200s refused", topic);
                return refuse(b, sink, "", BRIDGE_REFUSE_TOPIC, 0);
        }
        /* Whatever the message says, an old write must never come back (on a vehicle: a
         * throttle command). An empty retained message is a publisher removing its retained
         * one from the broker: not a write, and nothing to answer. */
        if (via == BRIDGE_SET_RETAINED && len == 0)
                return 0;
        if (via == BRIDGE_SET_RETAINED)
                return refuse(b, sink, name, BRIDGE_REFUSE_RETAINED, 0);
        if (via == BRIDGE_SET_QUEUED)
                return refuse(b, sink, name, BRIDGE_REFUSE_QUEUED, 0);
        if (!b->cl)
                return refuse(b, sink, name, BRIDGE_REFUSE_FAILED, -ENOTCONN);
        id = sl_find(b->cl, name);
        if (id < 0 || sl_info(b->cl, id, &info) < 0)
                return refuse(b, sink, name, BRIDGE_REFUSE_UNKNOWN, 0);
        if (info.direction != SL_DIR_OUT)
                return refuse(b, sink, name, BRIDGE_REFUSE_INBOUND, 0);
        if (!globs_match(&b->cfg->writable, name))
                return refuse(b, sink, name, BRIDGE_REFUSE_NOT_WRITABLE, 0);
        why = bridge_format_check_value(payload, len);
        if (why != BRIDGE_REFUSE_NONE)
                return refuse(b, sink, name, why, 0);
        memcpy(value, payload, len);
        value[len] = '\0';
        r = sl_write(b->cl, id, value);
        if (r == -EINVAL) {
                /* The library says why: bytes, length, or the variable's type. */
                if (sl_write_check(b->cl, id, value, reason, sizeof(reason)) != -EINVAL)
                        reason[0] = '\0';
                return refuse_detail(b, sink, name, BRIDGE_REFUSE_BAD_VALUE, r,
                                     reason[0] ? reason : NULL);
        }
        if (r < 0)
                return refuse(b, sink, name, BRIDGE_REFUSE_FAILED, r);
        count(b, &b->counters.set_written, 1);
        return 1;
}

void bridge_writes_ready(struct bridge *b, bool ready)
{
        b->writes_ready = ready;
}

/* ---- counters -------------------------------------------------------------------------------- */

const struct bridge_counters *bridge_counters(const struct bridge *b)
{
        return &b->counters;
}

uint64_t bridge_counters_version(const struct bridge *b)
{
        return b->counters_version;
}

int bridge_counters_json(const struct bridge *b, char *buf, size_t size)
{
        const struct bridge_counters *c = &b->counters;
        struct json_buf j;

        json_buf_begin(&j, buf, size);
        json_buf_u64(&j, "values_published", c->values_published);
        json_buf_u64(&j, "events_published", c->events_published);
        json_buf_u64(&j, "events_acked", c->events_acked);
        json_buf_u64(&j, "events_lost", c->events_lost);
        json_buf_u64(&j, "events_unacked", b->w_count);
        json_buf_u64(&j, "last_event_acked", b->done.seq);
        json_buf_u64(&j, "set_written", c->set_written);
        json_buf_u64(&j, "set_refused", c->set_refused);
        json_buf_u64(&j, "unpublishable", c->unpublishable);
        json_buf_u64(&j, "publish_errors", c->publish_errors);
        json_buf_u64(&j, "cursor_errors", c->cursor_errors);
        json_buf_u64(&j, "broker_errors", c->broker_errors);
        return json_buf_end(&j);
}
