/*
 * sharedlink-ros2 bridge logic (see ros2_bridge.h; the contract is docs/ros2.md).
 */
#include "ros2/ros2_bridge.h"

#include <errno.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdint.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <time.h>
#include <unistd.h>

#include <dds/dds.h>
#include <sharedlink.h>

#include "ros2/ros2_dds.h"
#include "ros2/ros2_names.h"
#include "ros2_msgs.h"
#include "svc/changes.h"
#include "svc/cursor.h"
#include "svc/evjson.h"
#include "svc/json.h"
#include "svc/log.h"

#define NS_PER_S                1000000000ull
#define DECIMAL                 10
#define TAKE_BATCH              32      /* samples taken from a reader at once */
#define UNKNOWN_MAX             64      /* set/ writers kept to be judged (again) by a plan */
#define TYPE_NAME_MAX           256     /* bytes of a writer's type name kept, NUL included */
#define JSON_MAX                1024    /* one set_errors payload */
#define DIAG_KV_MAX             (SL_COUNTERS_MAX + 8)   /* values of one status */
#define DIAG_VALUE_SIZE         32      /* a number, a state name */
#define DIAG_TEXT_SIZE          SL_STATE_TEXT_SIZE
#define DIAG_STALE_LIST         200     /* bytes of the list of stale variables of a link */
#define OWN_TOPICS              3       /* events, set_errors, /diagnostics */

/* diagnostic_msgs/msg/DiagnosticStatus levels, sensor_msgs/msg/NavSatStatus values. */
enum {
        DIAG_OK = 0, DIAG_WARN = 1, DIAG_ERROR = 2, DIAG_STALE = 3,
};
#define NAVSAT_NO_FIX           (-1)
#define NAVSAT_FIX              0
#define NAVSAT_SERVICE_GPS      1
#define NAVSAT_COV_UNKNOWN      0

/* Why a write from ROS was refused (codes in set_errors, docs/ros2.md §4). */
enum refusal {
        REFUSE_TOO_LONG,
        REFUSE_BAD_VALUE,
        REFUSE_NOT_FINITE,
        REFUSE_FAILED,
        REFUSE_WRONG_TYPE,
        REFUSE_UNKNOWN,
        REFUSE_COUNT
};

static const char *const refusal_code[REFUSE_COUNT] = {
        [REFUSE_TOO_LONG] = "too_long",
        [REFUSE_BAD_VALUE] = "bad_value",
        [REFUSE_NOT_FINITE] = "not_finite",
        [REFUSE_FAILED] = "failed",
        [REFUSE_WRONG_TYPE] = "wrong_type",
        [REFUSE_UNKNOWN] = "unknown",
};

static const char *const refusal_text[REFUSE_COUNT] = {
        [REFUSE_TOO_LONG] = "value longer than 63 bytes (what the wire carries)",
        [REFUSE_BAD_VALUE] = "value cannot go on the wire (printable ASCII without | [ ])",
        [REFUSE_NOT_FINITE] = "not a finite number",
        [REFUSE_FAILED] = "write failed",
        [REFUSE_WRONG_TYPE] = "a writer of another type on this set topic: its samples never "
                              "arrive",
        [REFUSE_UNKNOWN] = "no writable variable has this set topic",
};

struct var {
        struct sl_var_info info;
        bool present;                   /* sl_info succeeded at the last plan */
        char rel[ROS2_REL_SIZE];        /* "" : the name cannot be mapped */
        bool refused;                   /* collides with another topic */
        bool refused_logged;
        enum ros2_type type;
        dds_entity_t topic, writer;     /* 0: none */
        dds_entity_t set_topic, set_reader;
        bool set_new;                   /* set_reader made by this plan: writers judged before
                                         * it existed are judged again */
        uint64_t seq;                   /* sequence published last */
        bool sent;
};

/* A writer on a set/ topic that no set reader had when it was seen. */
struct unknown_writer {
        dds_guid_t key;
        bool reported;                  /* as unknown (else: seen before the first plan) */
        char topic[ROS2_DDS_NAME_SIZE];
        char type[TYPE_NAME_MAX];
};

struct navsat {
        const struct ros2_navsatfix *cfg;
        char full[ROS2_NAME_SIZE];
        int id[3];                      /* latitude, longitude, altitude (-1: none) */
        uint64_t seq[3];
        bool refused;
        dds_entity_t topic, writer;
};

/* Room for one status of the DiagnosticArray (strings point here). */
struct diag_slot {
        char name[SL_LINK_NAME_SIZE + ROS2_INSTANCE_MAX + 32];
        char hwid[SL_LINK_NAME_SIZE + ROS2_INSTANCE_MAX + 2];
        char message[DIAG_TEXT_SIZE];
        char stale[DIAG_STALE_LIST];
        diagnostic_msgs_msg_dds__KeyValue_ kv[DIAG_KV_MAX];
        char val[DIAG_KV_MAX][DIAG_VALUE_SIZE];
};

struct ros2_bridge {
        const struct ros2_config *cfg;
        char instance[ROS2_INSTANCE_MAX];
        char ns[ROS2_NAMESPACE_MAX];
        char set_prefix[ROS2_DDS_NAME_SIZE];    /* "rt<ns>/set/" */
        dds_entity_t pp;
        dds_guid_t guid;
        dds_listener_t *listener;
        int efd;                        /* rung by DDS's listener threads */
        dds_entity_t pub_reader;        /* DCPSPublication: writers on our set topics */
        dds_entity_t events_topic, events_w;
        dds_entity_t errors_topic, errors_w;
        dds_entity_t diag_topic, diag_w;

        struct sl_client *cl;
        uint64_t epoch;
        struct var *vars;
        unsigned n_vars, cap_vars;
        bool replan;
        bool planned;                   /* a plan exists: writers on set topics can be judged */
        struct unknown_writer *unknown; /* UNKNOWN_MAX: seen before any plan, or reported
                                         * unknown: judged (again) by a plan */
        unsigned n_unknown;
        struct changes changes;         /* what changed since the last scan (sl_changed) */
        bool read_all;                  /* the next scan reads every variable */
        int sent;                       /* values published by the scan under way */
        struct navsat nav[ROS2_NAVSATFIX_MAX];
        unsigned n_refused;             /* variables on a colliding topic */

        char link_state[ROS2_LINKS_MAX][SL_STATE_NAME_SIZE];
        bool diag_due;
        struct diag_slot *diag;         /* ROS2_LINKS_MAX + 1 */
        diagnostic_msgs_msg_dds__DiagnosticStatus_ *diag_status;

        uint64_t ev_cursor;
        struct cursor ev_pos;           /* after the last event written to DDS */
        bool ev_moved;                  /* ev_pos is ahead of what cursor_file holds */
        bool cursor_warned;             /* a failed store was logged (until one succeeds) */
        bool ev_started;
        bool announce_restart;
        bool noticed;                   /* the notices of event noticed_seq went out */
        uint64_t noticed_seq;
        bool events_blocked;

        struct ros2_counters counters;
};

/* ---- DDS's threads -> the loop ------------------------------------------------------------- */

static void on_data(dds_entity_t reader, void *arg)
{
        struct ros2_bridge *b = arg;
        uint64_t one = 1;

        (void)reader;
        /* An eventfd write cannot block here (the counter is far from overflowing), and a
         * failed one only delays the read to the next tick. */
        if (write(b->efd, &one, sizeof(one)) < 0)
                return;
}

static void on_matched(dds_entity_t writer, const dds_publication_matched_status_t st,
                       void *arg)
{
        (void)st;
        on_data(writer, arg);
}

/* ---- creation -------------------------------------------------------------------------------- */

static int fail(char *err, size_t err_size, int r, const char *fmt, ...)
        __attribute__((format(printf, 4, 5)));

static int fail(char *err, size_t err_size, int r, const char *fmt, ...)
{
        va_list ap;

        va_start(ap, fmt);
        vsnprintf(err, err_size, fmt, ap);
        va_end(ap);
        return r;
}

static int own_topics(struct ros2_bridge *b, char *err, size_t err_size)
{
        char full[ROS2_NAME_SIZE], dds[ROS2_DDS_NAME_SIZE];

        if (ros2_names_join(full, sizeof(full), b->ns, ROS2_TOPIC_EVENTS, NULL) < 0 ||
            ros2_names_dds(dds, sizeof(dds), full) < 0)
                return fail(err, err_size, -EINVAL, "namespace %s too long", b->ns);
        /* The listener: a reader matched, so the events held back for one go out (pump). */
        b->events_w = ros2_dds_endpoint(b->pp, ROS2_TYPE_STRING, dds, ROS2_QOS_EVENTS,
                                        b->listener, &b->events_topic);
        if (b->events_w < 0)
                return fail(err, err_size, -EIO, "%s: %s", dds, dds_strretcode(b->events_w));
        ros2_names_join(full, sizeof(full), b->ns, ROS2_TOPIC_SET_ERRORS, NULL);
        ros2_names_dds(dds, sizeof(dds), full);
        b->errors_w = ros2_dds_endpoint(b->pp, ROS2_TYPE_STRING, dds, ROS2_QOS_STATUS, NULL,
                                        &b->errors_topic);
        if (b->errors_w < 0)
                return fail(err, err_size, -EIO, "%s: %s", dds, dds_strretcode(b->errors_w));
        ros2_names_dds(dds, sizeof(dds), ROS2_TOPIC_DIAGNOSTICS);
        b->diag_w = ros2_dds_endpoint(b->pp, ROS2_TYPE_DIAGNOSTICS, dds, ROS2_QOS_STATUS, NULL,
                                      &b->diag_topic);
        if (b->diag_w < 0)
                return fail(err, err_size, -EIO, "%s: %s", dds, dds_strretcode(b->diag_w));
        b->pub_reader = dds_create_reader(b->pp, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, NULL,
                                          b->listener);
        if (b->pub_reader < 0)
                return fail(err, err_size, -EIO, "DCPSPublication: %s",
                            dds_strretcode(b->pub_reader));
        return 0;
}

int ros2_bridge_new(const struct ros2_config *cfg, struct ros2_bridge **ret, char *err,
                    size_t err_size)
{
        struct ros2_bridge *b = calloc(1, sizeof(*b));
        char full[ROS2_NAME_SIZE];
        unsigned domain;
        int r;

        if (!b)
                return fail(err, err_size, -ENOMEM, "out of memory");
        b->cfg = cfg;
        b->efd = -1;
        b->diag = calloc(ROS2_LINKS_MAX + 1, sizeof(*b->diag));
        b->diag_status = calloc(ROS2_LINKS_MAX + 1, sizeof(*b->diag_status));
        b->unknown = calloc(UNKNOWN_MAX, sizeof(*b->unknown));
        if (!b->diag || !b->diag_status || !b->unknown) {
                r = fail(err, err_size, -ENOMEM, "out of memory");
                goto out;
        }
        if (ros2_config_names(cfg, b->instance, b->ns) < 0) {
                r = fail(err, err_size, -EINVAL, "instance %s: the default namespace "
                         ROS2_NAMESPACE_PREFIX "%s is not a ROS name: set namespace:",
                         b->instance, b->instance);
                goto out;
        }
        if (ros2_names_join(full, sizeof(full), b->ns, ROS2_TOPIC_SET, "") < 0 ||
            ros2_names_dds(b->set_prefix, sizeof(b->set_prefix), full) < 0) {
                r = fail(err, err_size, -EINVAL, "namespace %s too long", b->ns);
                goto out;
        }
        if (ros2_config_domain(cfg, &domain) < 0) {
                r = fail(err, err_size, -EINVAL, "$" ROS2_DOMAIN_ENV " %s: not a domain id "
                         "(0..%u)", getenv(ROS2_DOMAIN_ENV), ROS2_DOMAIN_MAX);
                goto out;
        }
        b->efd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
        b->listener = dds_create_listener(b);
        if (b->efd < 0 || !b->listener) {
                r = fail(err, err_size, -errno ? -errno : -ENOMEM, "eventfd: %s",
                         strerror(errno));
                goto out;
        }
        dds_lset_data_available(b->listener, on_data);
        dds_lset_publication_matched(b->listener, on_matched);
        b->pp = ros2_dds_participant(domain, cfg->cyclonedds_uri);
        if (b->pp < 0) {
                r = fail(err, err_size, -EIO, "DDS domain %u cannot be created: %s%s", domain,
                         dds_strretcode(b->pp), cfg->cyclonedds_uri[0] ?
                         " (check cyclonedds_uri; Cyclone logs why on stderr)" :
                         " (check $CYCLONEDDS_URI; Cyclone logs why on stderr)");
                goto out;
        }
        dds_get_guid(b->pp, &b->guid);
        r = own_topics(b, err, err_size);
        if (r < 0)
                goto out;
        for (unsigned i = 0; i < cfg->n_navsatfix; i++) {
                b->nav[i].cfg = &cfg->navsatfix[i];
                for (unsigned k = 0; k < 3; k++)
                        b->nav[i].id[k] = -1;
                ros2_names_join(b->nav[i].full, sizeof(b->nav[i].full), b->ns,
                                cfg->navsatfix[i].topic, NULL);
        }
        b->diag_due = true;
        *ret = b;
        log_msg(LOG_PRIO_INFO, "DDS domain %u, namespace %s", domain, b->ns);
        return 0;
out:
        ros2_bridge_free(b);
        return r;
}

static void var_drop(struct var *v)
{
        if (v->writer)
                dds_delete(v->writer);
        if (v->topic)
                dds_delete(v->topic);
        if (v->set_reader)
                dds_delete(v->set_reader);
        if (v->set_topic)
                dds_delete(v->set_topic);
        v->writer = v->topic = v->set_reader = v->set_topic = 0;
}

struct ros2_bridge *ros2_bridge_free(struct ros2_bridge *b)
{
        if (!b)
                return NULL;
        /* The participant takes every entity with it; the listener's thread is done then. */
        if (b->pp > 0)
                dds_delete(b->pp);
        if (b->listener)
                dds_delete_listener(b->listener);
        if (b->efd >= 0)
                close(b->efd);
        sl_close(b->cl);
        free(b->vars);
        free(b->diag);
        free(b->diag_status);
        free(b->unknown);
        free(b);
        return NULL;
}

static uint64_t daemon_epoch(struct ros2_bridge *b);

/*
 * Where the events start: after the cursor in cursor_file when it belongs to this daemon run
 * (the bridge was restarted: nothing missed, nothing twice). A cursor of another run (the
 * daemon restarted meanwhile) or a file that is not a cursor: at the oldest event the ring
 * holds, with a daemon-restarted notice first for the former (the new run's events are not
 * lost; a ring that wrapped is announced by an overrun notice). No file (a first start): from
 * now on, a ROS topic having no history for a subscriber that was not there; the place is
 * written at once, so that events while a first-started bridge is stopped are not lost either.
 */
static void cursor_start(struct ros2_bridge *b)
{
        const char *path = b->cfg->cursor_file;
        uint64_t epoch = daemon_epoch(b);
        struct cursor c;
        int r = cursor_load(path, ROS2_CURSOR_OWNER, &c);

        b->ev_cursor = 0;
        if (r == 0 && c.epoch == epoch) {
                b->ev_cursor = c.cursor;
                log_msg(LOG_PRIO_INFO, "events: resuming after event %" PRIu64 " (%s)", c.seq,
                        path);
        } else if (r == 0) {
                b->announce_restart = true;
                log_msg(LOG_PRIO_NOTICE, "events: %s is of another daemon run (epoch %016"
                        PRIx64 "): starting at the oldest event retained", path, c.epoch);
        } else if (r == -ENOENT) {
                if (sl_events_now(b->cl, &b->ev_cursor) < 0)
                        b->ev_cursor = 0;
                log_msg(LOG_PRIO_INFO, "events: no cursor in %s yet: from now on", path);
        } else {
                log_msg(LOG_PRIO_WARNING, "events: %s: %s: starting at the oldest event "
                        "retained (events may repeat)", path,
                        r == -EBADMSG ? "not a " ROS2_CURSOR_OWNER " cursor" : strerror(-r));
        }
        b->ev_pos = (struct cursor){ .epoch = epoch, .cursor = b->ev_cursor,
                                     .seq = r == 0 ? c.seq : 0 };
        b->ev_moved = r != 0 || c.epoch != epoch;
}

int ros2_bridge_attach(struct ros2_bridge *b)
{
        int r;

        if (b->cl)
                return 0;
        r = sl_open(b->instance, &b->cl);
        if (r < 0)
                return r;
        cursor_start(b);
        b->ev_started = true;
        b->replan = true;
        b->diag_due = true;
        log_msg(LOG_PRIO_INFO, "sharedlinkd instance %s: attached", b->instance);
        return 0;
}

struct sl_client *ros2_bridge_client(struct ros2_bridge *b)
{
        return b->cl;
}

const char *ros2_bridge_namespace(const struct ros2_bridge *b)
{
        return b->ns;
}

int ros2_bridge_fd(const struct ros2_bridge *b)
{
        return b->efd;
}

bool ros2_bridge_events_blocked(const struct ros2_bridge *b)
{
        return b->events_blocked;
}

const struct ros2_counters *ros2_bridge_counters(const struct ros2_bridge *b)
{
        return &b->counters;
}

static uint64_t daemon_epoch(struct ros2_bridge *b)
{
        struct sl_daemon_info di = { .size = sizeof(di) };

        return sl_daemon_info(b->cl, &di) == 0 ? di.epoch : 0;
}

const char *ros2_bridge_status(struct ros2_bridge *b)
{
        if (!b->cl)
                return "sharedlinkd not found";
        return sl_daemon_alive(b->cl) == 1 ? "running" : "sharedlinkd not running";
}

/* ---- the plan: which variable goes on which topic -------------------------------------------- */

static enum ros2_type var_type(int sl_type)
{
        switch (sl_type) {
        case SL_VAR_LONG:
                return ROS2_TYPE_INT64;
        case SL_VAR_DOUBLE:
                return ROS2_TYPE_FLOAT64;
        default:
                return ROS2_TYPE_STRING;
        }
}

static int vars_grow(struct ros2_bridge *b, unsigned n)
{
        struct var *nv;
        unsigned cap = b->cap_vars ? b->cap_vars : 64;

        if (n <= b->cap_vars)
                return 0;
        while (cap < n)
                cap *= 2;
        nv = realloc(b->vars, cap * sizeof(*nv));
        if (!nv)
                return -ENOMEM;
        memset(nv + b->cap_vars, 0, (cap - b->cap_vars) * sizeof(*nv));
        b->vars = nv;
        b->cap_vars = cap;
        return 0;
}

static bool var_wants_set(const struct ros2_bridge *b, const struct var *v)
{
        return v->info.direction == SL_DIR_OUT && globs_match(&b->cfg->writable, v->info.name);
}

/* Marks in dup[] every variable (then every navsatfix topic) whose topic another one has too,
 * or that is one of the bridge's own names: ros2_bridge_check reports what plan() refuses. */
static int plan_collisions(const char *ns, const struct var *vars, unsigned n_vars,
                           const struct ros2_config *cfg, char (*nav_full)[ROS2_NAME_SIZE],
                           bool *dup)
{
        size_t cap = (size_t)n_vars + cfg->n_navsatfix + OWN_TOPICS, n = 0;
        struct ros2_names_ref *refs = calloc(cap ? cap : 1, sizeof(*refs));
        char (*full)[ROS2_NAME_SIZE] = calloc(n_vars ? n_vars : 1, sizeof(*full));
        static char own[OWN_TOPICS][ROS2_NAME_SIZE];

        if (!refs || !full) {
                free(refs);
                free(full);
                return -ENOMEM;
        }
        for (unsigned i = 0; i < n_vars; i++) {
                const struct var *v = &vars[i];

                if (!v->present || !v->rel[0])
                        continue;
                if (ros2_names_reserved(v->rel)) {
                        dup[i] = true;
                        continue;
                }
                if (ros2_names_join(full[i], sizeof(full[i]), ns, v->rel, NULL) < 0)
                        continue;
                refs[n++] = (struct ros2_names_ref){ full[i], i };
        }
        for (unsigned i = 0; i < cfg->n_navsatfix; i++)
                refs[n++] = (struct ros2_names_ref){ nav_full[i], (size_t)n_vars + i };
        ros2_names_join(own[0], sizeof(own[0]), ns, ROS2_TOPIC_EVENTS, NULL);
        ros2_names_join(own[1], sizeof(own[1]), ns, ROS2_TOPIC_SET_ERRORS, NULL);
        snprintf(own[2], sizeof(own[2]), ROS2_TOPIC_DIAGNOSTICS);
        for (unsigned i = 0; i < OWN_TOPICS; i++)
                refs[n++] = (struct ros2_names_ref){ own[i], cap - OWN_TOPICS + i };
        ros2_names_duplicates(refs, n, dup);
        free(refs);
        free(full);
        return 0;
}

static int var_endpoints(struct ros2_bridge *b, struct var *v)
{
        bool want = v->present && v->rel[0] && !v->refused &&
                    globs_match(&b->cfg->publish, v->info.name);
        bool want_set = v->present && v->rel[0] && !v->refused && var_wants_set(b, v);
        enum ros2_type t = var_type(v->info.type);
        char full[ROS2_NAME_SIZE], dds[ROS2_DDS_NAME_SIZE];

        if ((v->writer || v->set_reader) && (v->type != t || (!want && v->writer) ||
                                             (!want_set && v->set_reader)))
                var_drop(v);
        v->type = t;
        if (want && !v->writer) {
                ros2_names_join(full, sizeof(full), b->ns, v->rel, NULL);
                ros2_names_dds(dds, sizeof(dds), full);
                v->writer = ros2_dds_endpoint(b->pp, t, dds, ROS2_QOS_VALUE, NULL, &v->topic);
                if (v->writer < 0) {
                        log_msg(LOG_PRIO_ERR, "%s: %s", dds, dds_strretcode(v->writer));
                        v->writer = 0;
                        b->counters.dds_errors++;
                }
                v->sent = false;
        }
        if (want_set && !v->set_reader) {
                ros2_names_join(full, sizeof(full), b->ns, ROS2_TOPIC_SET, v->rel);
                ros2_names_dds(dds, sizeof(dds), full);
                v->set_reader = ros2_dds_endpoint(b->pp, t, dds, ROS2_QOS_SET, b->listener,
                                                  &v->set_topic);
                if (v->set_reader < 0) {
                        log_msg(LOG_PRIO_ERR, "%s: %s", dds, dds_strretcode(v->set_reader));
                        v->set_reader = 0;
                        b->counters.dds_errors++;
                }
                v->set_new = v->set_reader != 0;
        }
        return 0;
}

static void nav_endpoints(struct ros2_bridge *b, struct navsat *nv)
{
        const char *names[3] = { nv->cfg->latitude, nv->cfg->longitude, nv->cfg->altitude };
        char dds[ROS2_DDS_NAME_SIZE];

        for (unsigned k = 0; k < 3; k++)
                nv->id[k] = names[k][0] ? sl_find(b->cl, names[k]) : -1;
        if (nv->refused && nv->writer) {
                dds_delete(nv->writer);
                dds_delete(nv->topic);
                nv->writer = nv->topic = 0;
        }
        if (nv->refused || nv->writer)
                return;
        ros2_names_dds(dds, sizeof(dds), nv->full);
        nv->writer = ros2_dds_endpoint(b->pp, ROS2_TYPE_NAVSATFIX, dds, ROS2_QOS_VALUE, NULL,
                                       &nv->topic);
        if (nv->writer < 0) {
                log_msg(LOG_PRIO_ERR, "%s: %s", dds, dds_strretcode(nv->writer));
                nv->writer = 0;
                b->counters.dds_errors++;
        }
}

static void publications_judge(struct ros2_bridge *b);

static int plan(struct ros2_bridge *b)
{
        int count = sl_count(b->cl), r;
        unsigned n, ndup;
        char (*nav_full)[ROS2_NAME_SIZE];
        bool *dup;

        if (count < 0)
                return count;
        n = (unsigned)count;
        if ((r = vars_grow(b, n)) < 0)
                return r;
        b->n_vars = n;
        for (unsigned id = 0; id < n; id++) {
                struct var *v = &b->vars[id];

                v->info = (struct sl_var_info){ .size = sizeof(v->info) };
                v->present = sl_info(b->cl, (int)id, &v->info) == 0;
                if (!v->present || ros2_names_map(v->info.name, v->rel, sizeof(v->rel)) < 0)
                        v->rel[0] = '\0';
        }
        ndup = n + b->cfg->n_navsatfix + OWN_TOPICS;
        dup = calloc(ndup, sizeof(*dup));
        nav_full = calloc(ROS2_NAVSATFIX_MAX, sizeof(*nav_full));
        if (!dup || !nav_full) {
                free(dup);
                free(nav_full);
                return -ENOMEM;
        }
        for (unsigned i = 0; i < b->cfg->n_navsatfix; i++)
                memcpy(nav_full[i], b->nav[i].full, sizeof(nav_full[i]));
        r = plan_collisions(b->ns, b->vars, n, b->cfg, nav_full, dup);
        if (r < 0)
                goto out;
        b->n_refused = 0;
        for (unsigned id = 0; id < n; id++) {
                struct var *v = &b->vars[id];
                bool listed = globs_match(&b->cfg->publish, v->info.name) ||
                              var_wants_set(b, v);

                v->refused = v->present && dup[id] && listed;
                if (v->refused) {
                        b->n_refused++;
                        if (!v->refused_logged)
                                log_msg(LOG_PRIO_ERR, "variable %s: its topic %s/%s is another "
                                        "variable's or the bridge's: not published (rename "
                                        "one, or leave it out of publish:)", v->info.name,
                                        strcmp(b->ns, "/") ? b->ns : "", v->rel);
                }
                v->refused_logged = v->refused;
                var_endpoints(b, v);
        }
        for (unsigned i = 0; i < b->cfg->n_navsatfix; i++) {
                b->nav[i].refused = dup[n + i];
                if (b->nav[i].refused)
                        log_msg(LOG_PRIO_ERR, "navsatfix %s: another topic has this name: not "
                                "published", b->nav[i].full);
                nav_endpoints(b, &b->nav[i]);
        }
        b->replan = false;
        b->diag_due = true;
        b->planned = true;
        publications_judge(b);
out:
        free(dup);
        free(nav_full);
        return r;
}

/* ---- values ---------------------------------------------------------------------------------- */

static bool parse_long(const char *s, int64_t *ret)
{
        char *end;
        long long v;

        errno = 0;
        v = strtoll(s, &end, DECIMAL);
        if (!s[0] || *end || errno)
                return false;
        *ret = v;
        return true;
}

static bool parse_double(const char *s, double *ret)
{
        char *end;
        double v;

        errno = 0;
        v = strtod(s, &end);
        if (!s[0] || *end || errno == ERANGE)
                return false;
        *ret = v;
        return true;
}

static int var_write(const struct var *v, char *text)
{
        dds_return_t rc;

        switch (v->type) {
        case ROS2_TYPE_INT64: {
                std_msgs_msg_dds__Int64_ m;

                if (!parse_long(text, &m.data_))
                        return -EDOM;
                rc = dds_write(v->writer, &m);
                break;
        }
        case ROS2_TYPE_FLOAT64: {
                std_msgs_msg_dds__Float64_ m;

                if (!parse_double(text, &m.data_))
                        return -EDOM;
                rc = dds_write(v->writer, &m);
                break;
        }
        default: {
                std_msgs_msg_dds__String_ m = { .data_ = text };

                rc = dds_write(v->writer, &m);
                break;
        }
        }
        return rc == DDS_RETCODE_OK ? 0 : -EIO;
}

static int var_scan(struct ros2_bridge *b, struct var *v, unsigned id)
{
        struct sl_meta meta = { .size = sizeof(meta) };
        char value[SL_VALUE_SIZE];
        int r;

        if (!v->writer)
                return 0;
        r = sl_read(b->cl, (int)id, value, sizeof(value), &meta);
        if (r == -ENOENT) {
                b->replan = true;       /* retired by the daemon */
                return 0;
        }
        if (r < 0) {
                b->read_all = true;     /* -EAGAIN: a writer kept it busy; the next scan */
                return 0;
        }
        if (!(meta.flags & SL_FLAG_VALID))
                return 0;               /* never set: nothing to say */
        if (v->sent && meta.sequence == v->seq)
                return 0;
        v->seq = meta.sequence;
        v->sent = true;
        r = var_write(v, value);
        if (r == -EDOM) {
                b->counters.unconvertible++;
                log_msg(LOG_PRIO_DEBUG, "%s: %.63s is not a %s", v->info.name, value,
                        ros2_dds_ros_type(v->type));
                return 0;
        }
        if (r < 0) {
                b->counters.dds_errors++;
                return 0;
        }
        b->counters.values_published++;
        return 1;
}

static void stamp(builtin_interfaces_msg_dds__Time_ *t, uint64_t real_ns)
{
        t->sec_ = (int32_t)(real_ns / NS_PER_S);
        t->nanosec_ = (uint32_t)(real_ns % NS_PER_S);
}

static int nav_scan(struct ros2_bridge *b, struct navsat *nv)
{
        sensor_msgs_msg_dds__NavSatFix_ m = { 0 };
        double val[3] = { NAN, NAN, NAN };
        bool news = false, fix = true;
        uint64_t when = 0;
        char frame[ROS2_FRAME_MAX];

        if (!nv->writer)
                return 0;
        for (unsigned k = 0; k < 3; k++) {
                struct sl_meta meta = { .size = sizeof(meta) };
                char text[SL_VALUE_SIZE];

                if (k == 2 && !nv->cfg->altitude[0])
                        break;
                if (nv->id[k] < 0 ||
                    sl_read(b->cl, nv->id[k], text, sizeof(text), &meta) < 0 ||
                    !(meta.flags & SL_FLAG_VALID) || (meta.flags & SL_FLAG_STALE) ||
                    !parse_double(text, &val[k])) {
                        if (k < 2)
                                fix = false;
                        val[k] = NAN;
                }
                if (meta.sequence != nv->seq[k])
                        news = true;
                nv->seq[k] = meta.sequence;
                if (meta.real_ns > when)
                        when = meta.real_ns;
        }
        if (!news)
                return 0;
        snprintf(frame, sizeof(frame), "%s", nv->cfg->frame_id);
        stamp(&m.header_.stamp_, when);
        m.header_.frame_id_ = frame;
        m.status_.status_ = fix ? NAVSAT_FIX : NAVSAT_NO_FIX;
        m.status_.service_ = NAVSAT_SERVICE_GPS;
        m.latitude_ = val[0];
        m.longitude_ = val[1];
        m.altitude_ = val[2];
        m.position_covariance_type_ = NAVSAT_COV_UNKNOWN;
        if (dds_write(nv->writer, &m) != DDS_RETCODE_OK) {
                b->counters.dds_errors++;
                return 0;
        }
        b->counters.navsatfix_published++;
        return 1;
}

/* One id sl_changed named (changes_fn): a name added since the last plan is planned first. */
static int value_changed(void *arg, int id)
{
        struct ros2_bridge *b = arg;
        int r;

        if ((unsigned)id >= b->n_vars && (r = plan(b)) < 0)
                return r;
        if ((unsigned)id < b->n_vars)
                b->sent += var_scan(b, &b->vars[id], (unsigned)id);
        return 0;
}

/*
 * The values: those sl_changed names (svc/changes.h says why what goes out is never older than
 * the table), or every one when it says so (a first scan, a daemon restart or a name retired, a
 * bridge that fell behind the daemon's record) or when the last scan left something unread.
 */
static int values_scan(struct ros2_bridge *b)
{
        bool all = b->read_all;
        int r;

        b->sent = 0;
        b->read_all = false;            /* var_scan may set it again */
        r = changes_follow(&b->changes, b->cl, all, value_changed, b);
        if (r < 0)
                b->read_all = true;
        for (unsigned id = 0; r == 1 && id < b->n_vars; id++)
                b->sent += var_scan(b, &b->vars[id], id);
        return r < 0 ? r : b->sent;
}

static void links_scan(struct ros2_bridge *b)
{
        int n = sl_link_count(b->cl);

        for (int i = 0; i < n && i < ROS2_LINKS_MAX; i++) {
                struct sl_link_info li = { .size = sizeof(li) };

                if (sl_link_info(b->cl, i, &li) < 0)
                        continue;
                if (strcmp(b->link_state[i], li.state_name)) {
                        snprintf(b->link_state[i], sizeof(b->link_state[i]), "%s",
                                 li.state_name);
                        b->diag_due = true;
                }
        }
}

int ros2_bridge_scan(struct ros2_bridge *b)
{
        int r, sent = 0;
        uint64_t epoch;

        if (!b->cl)
                return 0;
        epoch = daemon_epoch(b);
        if (epoch != b->epoch) {
                /* A new daemon run: ids were re-resolved by name, but what they describe may
                 * differ, and sequences start again. */
                b->epoch = epoch;
                for (unsigned id = 0; id < b->n_vars; id++)
                        b->vars[id].sent = false;
                for (unsigned i = 0; i < b->cfg->n_navsatfix; i++)
                        memset(b->nav[i].seq, 0, sizeof(b->nav[i].seq));
                b->replan = true;
        }
        if (b->replan || sl_count(b->cl) != (int)b->n_vars)
                if ((r = plan(b)) < 0) {
                        b->read_all = true;
                        return r;
                }
        if ((r = values_scan(b)) < 0)
                return r;
        sent += r;
        for (unsigned i = 0; i < b->cfg->n_navsatfix; i++)
                sent += nav_scan(b, &b->nav[i]);
        links_scan(b);
        return sent;
}

/* ---- events ---------------------------------------------------------------------------------- */

static int string_write(dds_entity_t w, char *text)
{
        std_msgs_msg_dds__String_ m = { .data_ = text };
        dds_return_t rc = dds_write(w, &m);

        if (rc == DDS_RETCODE_OK)
                return 0;
        return rc == DDS_RETCODE_TIMEOUT ? -EAGAIN : -EIO;
}

static int notice(struct ros2_bridge *b, const char *type, uint64_t seq, uint64_t lost)
{
        char json[EVJSON_MAX];
        int r;

        if (evjson_notice(json, sizeof(json), type, b->epoch, seq, lost) < 0)
                return -ENOBUFS;
        r = string_write(b->events_w, json);
        if (r == 0)
                log_msg(LOG_PRIO_NOTICE, "events: %s before event %" PRIu64 " (%" PRIu64
                        " lost)", type, seq, lost);
        return r;
}

/* The notices that go before event ev, once however often ev is read again. */
static int notices(struct ros2_bridge *b, const struct sl_event *ev)
{
        int r;

        if (b->noticed && b->noticed_seq == ev->seq)
                return 0;
        if (b->announce_restart) {
                if ((r = notice(b, EVJSON_RESTARTED, ev->seq, 0)) < 0)
                        return r;
                b->announce_restart = false;
        }
        if (ev->lost) {
                if ((r = notice(b, EVJSON_OVERRUN, ev->seq, ev->lost)) < 0)
                        return r;
                b->counters.events_lost += ev->lost;
        }
        b->noticed = true;
        b->noticed_seq = ev->seq;
        return 0;
}

/* Events wait in the ring while no reader is matched: written then, they would be taken as
 * done (nobody to acknowledge them) and lost to a subscriber that is discovering the bridge,
 * as every one is right after the bridge (re)starts. The ring keeps them meanwhile (one too
 * many: an overrun notice, as for a bridge that was stopped). */
static bool events_readers(struct ros2_bridge *b)
{
        dds_publication_matched_status_t st;

        return dds_get_publication_matched_status(b->events_w, &st) != DDS_RETCODE_OK ||
               st.current_count > 0;
}

int ros2_bridge_pump(struct ros2_bridge *b)
{
        int sent = 0, r;

        b->events_blocked = false;
        if (!b->cl)
                return 0;
        if (!events_readers(b)) {
                ros2_bridge_cursor_flush(b, 0);         /* a first start's place */
                return 0;
        }
        for (;;) {
                struct sl_event ev = { .size = sizeof(ev) };
                uint64_t cursor = b->ev_cursor;
                char json[EVJSON_MAX];

                r = sl_events_read(b->cl, &cursor, &ev, 1);
                if (r == -EAGAIN || r == 0)
                        break;
                if (r < 0)
                        return r;
                if (ev.flags & SL_EVENT_RESTARTED) {
                        /* Flagged once: remembered until its notice is out. */
                        b->epoch = daemon_epoch(b);
                        b->announce_restart = true;
                        b->noticed = false;
                }
                r = notices(b, &ev);
                if (r == 0) {
                        r = evjson_event(json, sizeof(json), b->epoch, &ev);
                        r = r < 0 ? r : string_write(b->events_w, json);
                }
                if (r == -EAGAIN) {
                        /* The history is full (a reader that does not acknowledge): this event
                         * is read again at the next pump. */
                        b->counters.events_blocked++;
                        b->events_blocked = true;
                        break;
                }
                if (r < 0) {
                        b->counters.dds_errors++;
                        break;
                }
                b->ev_cursor = cursor;
                b->ev_pos = (struct cursor){ .epoch = b->epoch, .cursor = cursor,
                                             .seq = ev.seq };
                b->ev_moved = true;
                b->counters.events_published++;
                sent++;
        }
        ros2_bridge_cursor_flush(b, 0);
        return sent;
}

bool ros2_bridge_cursor_pending(const struct ros2_bridge *b)
{
        return b->cl && b->ev_moved;
}

/*
 * The cursor moves over an event once every reader matched at the time has acknowledged it
 * (dds_wait_for_acks: the reliable protocol's own acknowledgement), not when dds_write returned:
 * a written sample still sits in the writer's history, and a bridge killed then would take it
 * along, lost to the readers although the cursor were past it. So a bridge stopped or killed
 * repeats at most what was written since the last store, never loses an event; one that
 * finds no reader matched has nothing to wait for. The file is not fsynced: a cursor counts
 * only within one daemon run (its epoch), which a power loss ends anyway.
 */
int ros2_bridge_cursor_flush(struct ros2_bridge *b, int64_t wait_ms)
{
        const struct cursor pos = b->ev_pos;
        dds_return_t rc;
        int r;

        if (!b->cl || !b->ev_moved)
                return 0;
        rc = dds_wait_for_acks(b->events_w, DDS_MSECS(wait_ms));
        if (rc == DDS_RETCODE_TIMEOUT)
                return -EAGAIN;         /* at the next pump or tick */
        if (rc != DDS_RETCODE_OK) {
                b->counters.dds_errors++;
                return -EIO;
        }
        r = cursor_store(b->cfg->cursor_file, ROS2_CURSOR_OWNER, &pos, false);
        if (r < 0) {
                b->counters.cursor_errors++;
                if (!b->cursor_warned)
                        log_msg(LOG_PRIO_WARNING, "events: cannot write %s: %s (a restart "
                                "will repeat or skip events)", b->cfg->cursor_file,
                                strerror(-r));
                b->cursor_warned = true;
                return r;
        }
        b->cursor_warned = false;
        b->ev_moved = false;
        return 0;
}

/* ---- writes from ROS ------------------------------------------------------------------------- */

static void refuse(struct ros2_bridge *b, const char *name, const char *topic, enum refusal why,
                   const char *detail)
{
        char json[JSON_MAX];
        struct json_buf j;

        b->counters.set_refused++;
        b->diag_due = true;
        log_msg(LOG_PRIO_DEBUG, "set %s: refused: %s", name, refusal_text[why]);
        json_buf_begin(&j, json, sizeof(json));
        json_buf_str(&j, "name", name);
        json_buf_str(&j, "topic", topic);
        json_buf_str(&j, "code", refusal_code[why]);
        json_buf_str(&j, "error", refusal_text[why]);
        if (detail)
                json_buf_str(&j, "detail", detail);
        if (json_buf_end(&j) >= 0 && string_write(b->errors_w, json) < 0)
                b->counters.dds_errors++;
}

static void set_topic_name(const struct ros2_bridge *b, const struct var *v, char *out,
                           size_t size)
{
        if (ros2_names_join(out, size, b->ns, ROS2_TOPIC_SET, v->rel) < 0)
                out[0] = '\0';
}

static void set_apply(struct ros2_bridge *b, struct var *v, unsigned id, const void *sample)
{
        char text[SL_VALUE_SIZE], topic[ROS2_NAME_SIZE];
        int r;

        set_topic_name(b, v, topic, sizeof(topic));
        switch (v->type) {
        case ROS2_TYPE_INT64:
                snprintf(text, sizeof(text), "%" PRId64,
                         ((const std_msgs_msg_dds__Int64_ *)sample)->data_);
                r = sl_write(b->cl, (int)id, text);
                break;
        case ROS2_TYPE_FLOAT64: {
                double d = ((const std_msgs_msg_dds__Float64_ *)sample)->data_;

                if (!isfinite(d)) {
                        refuse(b, v->info.name, topic, REFUSE_NOT_FINITE, NULL);
                        return;
                }
                r = sl_write_double(b->cl, (int)id, d, -1);
                break;
        }
        default: {
                const char *s = ((const std_msgs_msg_dds__String_ *)sample)->data_;

                if (!s)
                        s = "";
                if (strnlen(s, SL_VALUE_SIZE) >= SL_VALUE_SIZE) {
                        refuse(b, v->info.name, topic, REFUSE_TOO_LONG, NULL);
                        return;
                }
                r = sl_write(b->cl, (int)id, s);
                break;
        }
        }
        if (r == -EINVAL) {
                refuse(b, v->info.name, topic, REFUSE_BAD_VALUE, NULL);
                return;
        }
        if (r < 0) {
                refuse(b, v->info.name, topic, REFUSE_FAILED, sl_strerror(r));
                return;
        }
        b->counters.set_written++;
}

static void set_take(struct ros2_bridge *b, struct var *v, unsigned id)
{
        for (;;) {
                void *buf[TAKE_BATCH] = { NULL };
                dds_sample_info_t si[TAKE_BATCH];
                int n = dds_take(v->set_reader, buf, si, TAKE_BATCH, TAKE_BATCH);

                if (n <= 0)
                        return;
                for (int i = 0; i < n; i++)
                        if (si[i].valid_data)
                                set_apply(b, v, id, buf[i]);
                dds_return_loan(v->set_reader, buf, n);
                if (n < TAKE_BATCH)
                        return;
        }
}

/* Judges a writer on set topic (DDS name) of type type against the set readers: true when
 * one has its topic (then nothing to say, or wrong_type said), false when none does. again:
 * only against readers the last plan made (the others judged it already). */
static bool publication_judge(struct ros2_bridge *b, const char *topic, const char *type,
                              bool again)
{
        const char *rel = topic + strlen(b->set_prefix);

        for (unsigned id = 0; id < b->n_vars; id++) {
                struct var *v = &b->vars[id];
                const char *want = ros2_dds_type_name(v->type);
                char detail[ROS2_NAME_SIZE + 64];

                if (!v->set_reader || strcmp(v->rel, rel) != 0)
                        continue;
                if (again && !v->set_new)
                        return true;
                if (type && !strcmp(type, want))
                        return true;
                snprintf(detail, sizeof(detail), "type %.120s, expected %s (%s)",
                         type ? type : "?", want, ros2_dds_ros_type(v->type));
                refuse(b, v->info.name, topic + strlen(ROS2_DDS_PREFIX), REFUSE_WRONG_TYPE,
                       detail);
                return true;
        }
        return false;
}

/* A writer appeared on one of our set topics (or under set/): one of another type never
 * matches our reader, so its samples vanish; say so on set_errors, once per writer. Before the
 * first plan there is no set reader to judge it by: it is kept, and judged by the plan. One on
 * a topic of no set reader is unknown, and kept too: a later plan may make its reader (a
 * variable the daemon learns later, or after a daemon restart), and then judges it again. */
static void publication(struct ros2_bridge *b, const dds_builtintopic_endpoint_t *ep)
{
        struct unknown_writer *u;

        if (!memcmp(&ep->participant_key, &b->guid, sizeof(b->guid)) || !ep->topic_name ||
            strncmp(ep->topic_name, b->set_prefix, strlen(b->set_prefix)) != 0)
                return;
        if (b->planned && publication_judge(b, ep->topic_name, ep->type_name, false))
                return;
        if (b->planned || b->n_unknown >= UNKNOWN_MAX)
                refuse(b, "", ep->topic_name + strlen(ROS2_DDS_PREFIX), REFUSE_UNKNOWN, NULL);
        if (b->n_unknown >= UNKNOWN_MAX)
                return;                 /* not judged again: it was reported */
        u = &b->unknown[b->n_unknown++];
        u->key = ep->key;
        u->reported = b->planned;
        snprintf(u->topic, sizeof(u->topic), "%s", ep->topic_name);
        snprintf(u->type, sizeof(u->type), "%s", ep->type_name ? ep->type_name : "?");
        if (!u->reported)
                b->counters.set_writers_waiting++;
}

/* A writer gone: not judged again. */
static void publication_gone(struct ros2_bridge *b, const dds_builtintopic_endpoint_t *ep)
{
        for (unsigned i = 0; i < b->n_unknown; i++)
                if (!memcmp(&b->unknown[i].key, &ep->key, sizeof(ep->key))) {
                        if (!b->unknown[i].reported)
                                b->counters.set_writers_waiting--;
                        b->unknown[i] = b->unknown[--b->n_unknown];
                        return;
                }
}

/* Writers discovered or gone since the last look. */
static void publications_take(struct ros2_bridge *b)
{
        for (;;) {
                void *buf[TAKE_BATCH] = { NULL };
                dds_sample_info_t si[TAKE_BATCH];
                int n = dds_take(b->pub_reader, buf, si, TAKE_BATCH, TAKE_BATCH);

                if (n <= 0)
                        return;
                for (int i = 0; i < n; i++) {
                        if (si[i].instance_state != DDS_IST_ALIVE)
                                publication_gone(b, buf[i]);
                        else if (si[i].valid_data)
                                publication(b, buf[i]);
                }
                dds_return_loan(b->pub_reader, buf, n);
                if (n < TAKE_BATCH)
                        return;
        }
}

/* After a plan: the writers seen before the first plan get their verdict (nothing when of the
 * right type, wrong_type, unknown), and the unknown ones on a topic it made a set reader for
 * theirs (nothing, or wrong_type). */
static void publications_judge(struct ros2_bridge *b)
{
        for (unsigned i = 0; i < b->n_unknown;) {
                struct unknown_writer *u = &b->unknown[i];
                bool first = !u->reported;

                if (first)
                        b->counters.set_writers_waiting--;
                if (publication_judge(b, u->topic, u->type, !first)) {
                        *u = b->unknown[--b->n_unknown];
                        continue;
                }
                if (first)
                        refuse(b, "", u->topic + strlen(ROS2_DDS_PREFIX), REFUSE_UNKNOWN, NULL);
                u->reported = true;
                i++;
        }
        for (unsigned id = 0; id < b->n_vars; id++)
                b->vars[id].set_new = false;
}

int ros2_bridge_dds(struct ros2_bridge *b)
{
        uint64_t n;

        if (read(b->efd, &n, sizeof(n)) < 0 && errno != EAGAIN)
                return -errno;
        publications_take(b);
        for (unsigned id = 0; id < b->n_vars; id++)
                if (b->vars[id].set_reader)
                        set_take(b, &b->vars[id], id);
        return 0;
}

/* ---- /diagnostics ---------------------------------------------------------------------------- */

static void kv(struct diag_slot *s, diagnostic_msgs_msg_dds__DiagnosticStatus_ *st,
               const char *key, const char *fmt, ...) __attribute__((format(printf, 4, 5)));

/* Adds key: value to status st (key must live as long as the message: static or in s). */
static void kv(struct diag_slot *s, diagnostic_msgs_msg_dds__DiagnosticStatus_ *st,
               const char *key, const char *fmt, ...)
{
        uint32_t i = st->values_._length;
        va_list ap;

        if (i >= DIAG_KV_MAX)
                return;
        va_start(ap, fmt);
        vsnprintf(s->val[i], sizeof(s->val[i]), fmt, ap);
        va_end(ap);
        s->kv[i].key_ = (char *)(uintptr_t)key;         /* read only by dds_write */
        s->kv[i].value_ = s->val[i];
        st->values_._length = i + 1;
}

static bool state_is(const char *state, const char *const *words)
{
        for (; *words; words++)
                if (!strncmp(state, *words, strlen(*words)))
                        return true;
        return false;
}

static uint8_t link_level(const char *state, unsigned stale, bool alive)
{
        static const char *const up[] = { "up", "connected", NULL };
        static const char *const bad[] = { "down", "disconnected", "stopped", "version-mismatch",
                                           NULL };

        if (!alive)
                return DIAG_STALE;
        if (state_is(state, bad))
                return DIAG_ERROR;
        if (!state_is(state, up) || stale > 0)
                return DIAG_WARN;
        return DIAG_OK;
}

static void diag_link(struct ros2_bridge *b, int link, bool alive,
                      diagnostic_msgs_msg_dds__DiagnosticStatus_ *st, struct diag_slot *s)
{
        struct sl_link_info li = { .size = sizeof(li) };
        unsigned vars = 0, stale = 0;
        size_t used = 0;

        if (sl_link_info(b->cl, link, &li) < 0)
                snprintf(li.name, sizeof(li.name), "%d", link);
        s->stale[0] = '\0';
        for (unsigned id = 0; id < b->n_vars; id++) {
                struct sl_meta meta = { .size = sizeof(meta) };
                const struct var *v = &b->vars[id];
                char value[SL_VALUE_SIZE];

                if (!v->present || v->info.link != link)
                        continue;
                vars++;
                /* A value never set is not stale data: only valid values that went stale. */
                if (sl_read(b->cl, (int)id, value, sizeof(value), &meta) < 0 ||
                    (meta.flags & (SL_FLAG_VALID | SL_FLAG_STALE)) !=
                    (SL_FLAG_VALID | SL_FLAG_STALE))
                        continue;
                stale++;
                if (used + strlen(v->info.name) + 2 < sizeof(s->stale))
                        used += (size_t)snprintf(s->stale + used, sizeof(s->stale) - used,
                                                 "%s%s", used ? " " : "", v->info.name);
        }
        snprintf(s->name, sizeof(s->name), "sharedlink: %s", li.name);
        snprintf(s->hwid, sizeof(s->hwid), "%s/%s", b->instance, li.name);
        snprintf(s->message, sizeof(s->message), "%s", alive ? (li.state_text[0] ?
                 li.state_text : li.state_name) : "sharedlinkd not running: values stale");
        st->level_ = link_level(li.state_name, stale, alive);
        st->name_ = s->name;
        st->hardware_id_ = s->hwid;
        st->message_ = s->message;
        st->values_._buffer = s->kv;
        st->values_._length = 0;
        kv(s, st, "protocol", "%s", li.protocol);
        kv(s, st, "state", "%s", li.state_name);
        kv(s, st, "state_age_ms", "%" PRIu64, li.state_age_ns / 1000000u);
        kv(s, st, "variables", "%u", vars);
        kv(s, st, "stale_variables", "%u", stale);
        if (stale) {
                s->kv[st->values_._length].key_ = (char *)(uintptr_t)"stale";
                s->kv[st->values_._length].value_ = s->stale;
                st->values_._length++;
        }
        for (unsigned i = 0; i < li.counter_count && i < SL_COUNTERS_MAX; i++)
                if (li.counters[i].name)
                        kv(s, st, li.counters[i].name, "%" PRIu64, li.counters[i].value);
}

static void diag_bridge(struct ros2_bridge *b, bool alive,
                        diagnostic_msgs_msg_dds__DiagnosticStatus_ *st, struct diag_slot *s)
{
        const struct ros2_counters *c = &b->counters;

        snprintf(s->name, sizeof(s->name), "sharedlink-ros2: %s", b->instance);
        snprintf(s->hwid, sizeof(s->hwid), "%s", b->instance);
        if (!alive)
                snprintf(s->message, sizeof(s->message), "%s", ros2_bridge_status(b));
        else if (b->n_refused)
                snprintf(s->message, sizeof(s->message), "%u variables not published: their "
                         "topic collides with another", b->n_refused);
        else
                snprintf(s->message, sizeof(s->message), "running");
        st->level_ = !alive ? DIAG_STALE : b->n_refused ? DIAG_WARN : DIAG_OK;
        st->name_ = s->name;
        st->hardware_id_ = s->hwid;
        st->message_ = s->message;
        st->values_._buffer = s->kv;
        st->values_._length = 0;
        kv(s, st, "namespace", "%s", b->ns);
        kv(s, st, "refused_variables", "%u", b->n_refused);
        kv(s, st, "values_published", "%" PRIu64, c->values_published);
        kv(s, st, "unconvertible", "%" PRIu64, c->unconvertible);
        kv(s, st, "events_published", "%" PRIu64, c->events_published);
        kv(s, st, "events_lost", "%" PRIu64, c->events_lost);
        kv(s, st, "events_blocked", "%" PRIu64, c->events_blocked);
        kv(s, st, "cursor_errors", "%" PRIu64, c->cursor_errors);
        kv(s, st, "set_writers_waiting", "%" PRIu64, c->set_writers_waiting);
        kv(s, st, "set_written", "%" PRIu64, c->set_written);
        kv(s, st, "set_refused", "%" PRIu64, c->set_refused);
        kv(s, st, "navsatfix_published", "%" PRIu64, c->navsatfix_published);
        kv(s, st, "dds_errors", "%" PRIu64, c->dds_errors);
}

int ros2_bridge_diagnostics(struct ros2_bridge *b)
{
        diagnostic_msgs_msg_dds__DiagnosticArray_ m = { 0 };
        char frame[] = "";
        bool alive = b->cl && sl_daemon_alive(b->cl) == 1;
        int links = b->cl ? sl_link_count(b->cl) : 0;
        struct timespec ts;
        uint32_t n = 0;

        clock_gettime(CLOCK_REALTIME, &ts);
        stamp(&m.header_.stamp_, (uint64_t)ts.tv_sec * NS_PER_S + (uint64_t)ts.tv_nsec);
        m.header_.frame_id_ = frame;
        diag_bridge(b, alive, &b->diag_status[n], &b->diag[n]);
        n++;
        for (int i = 0; i < links && i < ROS2_LINKS_MAX; i++, n++)
                diag_link(b, i, alive, &b->diag_status[n], &b->diag[n]);
        m.status_._buffer = b->diag_status;
        m.status_._length = n;
        b->diag_due = false;
        if (dds_write(b->diag_w, &m) != DDS_RETCODE_OK) {
                b->counters.dds_errors++;
                return -EIO;
        }
        return 1;
}

bool ros2_bridge_diag_due(const struct ros2_bridge *b)
{
        return b->diag_due;
}

/* ---- -n --------------------------------------------------------------------------------------- */

int ros2_bridge_check(const struct ros2_config *cfg, const char *path, char *err,
                      size_t err_size)
{
        char instance[ROS2_INSTANCE_MAX], ns[ROS2_NAMESPACE_MAX], pos[ROS2_ERROR_MAX];
        char (*nav_full)[ROS2_NAME_SIZE] = NULL;
        struct sl_client *cl = NULL;
        struct var *vars = NULL;
        bool *dup = NULL;
        int count, r;

        err[0] = '\0';
        if (ros2_config_names(cfg, instance, ns) < 0)
                return fail(err, err_size, -EINVAL, "%s: instance %s: the default namespace is "
                            "not a ROS name: set namespace:", path, instance);
        r = sl_open(instance, &cl);
        if (r < 0)
                return r == -ENOENT ? -ENOENT : fail(err, err_size, r, "%s: instance %s: %s",
                                                     path, instance, sl_strerror(r));
        for (unsigned i = 0; i < cfg->n_navsatfix; i++) {
                const struct ros2_navsatfix *f = &cfg->navsatfix[i];
                const char *names[3] = { f->latitude, f->longitude, f->altitude };
                static const char *const keys[3] = { "latitude", "longitude", "altitude" };

                for (unsigned k = 0; k < 3; k++) {
                        struct sl_var_info info = { .size = sizeof(info) };
                        int id = names[k][0] ? sl_find(cl, names[k]) : -1;

                        if (!names[k][0])
                                continue;
                        if (id < 0 || sl_info(cl, id, &info) < 0) {
                                r = fail(err, err_size, -EINVAL, "%s:%u:%u: navsatfix: %s: %s: "
                                         "no such variable in instance %s", path, f->line,
                                         f->column, keys[k], names[k], instance);
                                goto out;
                        }
                        if (info.type == SL_VAR_STRING) {
                                r = fail(err, err_size, -EINVAL, "%s:%u:%u: navsatfix: %s: %s: "
                                         "a string variable, not a number", path, f->line,
                                         f->column, keys[k], names[k]);
                                goto out;
                        }
                }
        }
        count = sl_count(cl);
        vars = calloc(count > 0 ? (size_t)count : 1, sizeof(*vars));
        dup = calloc((size_t)(count > 0 ? count : 0) + ROS2_NAVSATFIX_MAX + OWN_TOPICS,
                     sizeof(*dup));
        nav_full = calloc(ROS2_NAVSATFIX_MAX, sizeof(*nav_full));
        if (!vars || !dup || !nav_full) {
                r = fail(err, err_size, -ENOMEM, "%s: out of memory", path);
                goto out;
        }
        for (int id = 0; id < count; id++) {
                struct var *v = &vars[id];

                v->info.size = sizeof(v->info);
                v->present = sl_info(cl, id, &v->info) == 0 &&
                             (globs_match(&cfg->publish, v->info.name) ||
                              (v->info.direction == SL_DIR_OUT &&
                               globs_match(&cfg->writable, v->info.name))) &&
                             ros2_names_map(v->info.name, v->rel, sizeof(v->rel)) == 0;
        }
        for (unsigned i = 0; i < cfg->n_navsatfix; i++)
                ros2_names_join(nav_full[i], sizeof(nav_full[i]), ns, cfg->navsatfix[i].topic,
                                NULL);
        r = plan_collisions(ns, vars, (unsigned)count, cfg, nav_full, dup);
        if (r < 0)
                goto out;
        for (int id = 0; id < count; id++) {
                if (!vars[id].present || !dup[id])
                        continue;
                if (cfg->publish_line)
                        snprintf(pos, sizeof(pos), "%s:%u:%u", path, cfg->publish_line,
                                 cfg->publish_column);
                else
                        snprintf(pos, sizeof(pos), "%s", path);
                r = fail(err, err_size, -EINVAL, "%s: publish: variable %s: its ROS topic %s/%s "
                         "is another variable's or the bridge's own (rename one, or leave it "
                         "out of publish:)", pos, vars[id].info.name, strcmp(ns, "/") ? ns : "",
                         vars[id].rel);
                goto out;
        }
        for (unsigned i = 0; i < cfg->n_navsatfix; i++)
                if (dup[count + (int)i]) {
                        r = fail(err, err_size, -EINVAL, "%s:%u:%u: navsatfix: topic %s is "
                                 "another topic's", path, cfg->navsatfix[i].line,
                                 cfg->navsatfix[i].column, nav_full[i]);
                        goto out;
                }
        r = 0;
out:
        free(vars);
        free(dup);
        free(nav_full);
        sl_close(cl);
        return r;
}
