/*
 * peer_cyclone: a ROS 2 peer on Cyclone DDS with its own copy of the types (ros2peer_types.idl,
 * compiled by idlc), to prove what sharedlink-ros2 and peer_fastdds put on the wire; the command
 * line and the lines printed are in tests/ros2peer/README.md.
 *
 * A subscriber takes samples as serialized data (dds_takecdr) so it can print the CDR bytes that
 * arrived and decode them with the type's own deserializer; it reports each matched writer's
 * type name, QoS and USER_DATA from discovery. A publisher waits for matched readers, writes one
 * value and waits for every reliable reader's acknowledgement. Endpoints carry the USER_DATA
 * "typehash=RIHS01_...;" and the participant "enclave=/;", as ROS 2 Iron and later nodes do.
 *
 * It never picks a network by itself: the Cyclone configuration comes from --config FILE or
 * CYCLONEDDS_URI (tests/ros2peer/cyclonedds.xml keeps it to unicast on 127.0.0.1).
 */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>

#include "peer_common.h"
#include "ros2peer_types.h"

#define WRITERS_MAX     64      /* matched writers remembered (each reported once) */
#define URI_MAX         (PATH_MAX + 16)

static const dds_topic_descriptor_t *const descs[PEER_TYPE_COUNT] = {
        [PEER_INT64] = &std_msgs_msg_dds__Int64__desc,
        [PEER_FLOAT64] = &std_msgs_msg_dds__Float64__desc,
        [PEER_STRING] = &std_msgs_msg_dds__String__desc,
        [PEER_DIAGNOSTIC_ARRAY] = &diagnostic_msgs_msg_dds__DiagnosticArray__desc,
        [PEER_NAVSATFIX] = &sensor_msgs_msg_dds__NavSatFix__desc,
};

struct sub_state {
        const struct peer_args *a;
        dds_entity_t reader;
        dds_instance_handle_t writers[WRITERS_MAX];
        size_t n_writers;
};

/* ---- samples <-> the neutral value ---- */

static int from_header(const std_msgs_msg_dds__Header_ *h, struct peer_value *v)
{
        v->sec = h->stamp.sec;
        v->nanosec = h->stamp.nanosec;
        v->frame_id = peer_strdup(h->frame_id);
        return v->frame_id ? 0 : -ENOMEM;
}

static int from_status(const diagnostic_msgs_msg_dds__DiagnosticStatus_ *s, struct peer_status *st)
{
        st->level = s->level;
        st->name = peer_strdup(s->name);
        st->message = peer_strdup(s->message);
        st->hardware_id = peer_strdup(s->hardware_id);
        if (!st->name || !st->message || !st->hardware_id)
                return -ENOMEM;
        st->values = calloc(s->values._length ? s->values._length : 1, sizeof(*st->values));
        if (!st->values)
                return -ENOMEM;
        for (uint32_t k = 0; k < s->values._length; k++) {
                st->values[k].key = peer_strdup(s->values._buffer[k].key);
                st->values[k].value = peer_strdup(s->values._buffer[k].value);
                st->n_values = k + 1;
                if (!st->values[k].key || !st->values[k].value)
                        return -ENOMEM;
        }
        return 0;
}

static int from_sample(enum peer_type t, const void *sample, struct peer_value *v)
{
        v->type = t;
        switch (t) {
        case PEER_INT64:
                v->i = ((const std_msgs_msg_dds__Int64_ *)sample)->data;
                return 0;
        case PEER_FLOAT64:
                v->d = ((const std_msgs_msg_dds__Float64_ *)sample)->data;
                return 0;
        case PEER_STRING:
                v->s = peer_strdup(((const std_msgs_msg_dds__String_ *)sample)->data);
                return v->s ? 0 : -ENOMEM;
        case PEER_DIAGNOSTIC_ARRAY: {
                const diagnostic_msgs_msg_dds__DiagnosticArray_ *m = sample;

                if (from_header(&m->header, v) < 0)
                        return -ENOMEM;
                v->status = calloc(m->status._length ? m->status._length : 1, sizeof(*v->status));
                if (!v->status)
                        return -ENOMEM;
                for (uint32_t i = 0; i < m->status._length; i++) {
                        v->n_status = i + 1;
                        if (from_status(&m->status._buffer[i], &v->status[i]) < 0)
                                return -ENOMEM;
                }
                return 0;
        }
        case PEER_NAVSATFIX: {
                const sensor_msgs_msg_dds__NavSatFix_ *m = sample;

                v->fix_status = m->status.status;
                v->service = m->status.service;
                v->latitude = m->latitude;
                v->longitude = m->longitude;
                v->altitude = m->altitude;
                memcpy(v->covariance, m->position_covariance, sizeof(v->covariance));
                v->covariance_type = m->position_covariance_type;
                return from_header(&m->header, v);
        }
        default:
                return -EINVAL;
        }
}

static void to_header(const struct peer_value *v, std_msgs_msg_dds__Header_ *h)
{
        h->stamp.sec = v->sec;
        h->stamp.nanosec = v->nanosec;
        h->frame_id = v->frame_id;
}

/* Points a sample at the value's data (nothing copied; the sequences' buffers are the caller's
 * to free with free_sample_buffers). */
static int to_sample(const struct peer_value *v, void *sample)
{
        switch (v->type) {
        case PEER_INT64:
                ((std_msgs_msg_dds__Int64_ *)sample)->data = v->i;
                return 0;
        case PEER_FLOAT64:
                ((std_msgs_msg_dds__Float64_ *)sample)->data = v->d;
                return 0;
        case PEER_STRING:
                ((std_msgs_msg_dds__String_ *)sample)->data = v->s;
                return 0;
        case PEER_DIAGNOSTIC_ARRAY: {
                diagnostic_msgs_msg_dds__DiagnosticArray_ *m = sample;

                to_header(v, &m->header);
                m->status._length = m->status._maximum = (uint32_t)v->n_status;
                m->status._buffer = calloc(v->n_status + 1, sizeof(*m->status._buffer));
                if (!m->status._buffer)
                        return -ENOMEM;
                for (size_t i = 0; i < v->n_status; i++) {
                        const struct peer_status *st = &v->status[i];
                        diagnostic_msgs_msg_dds__DiagnosticStatus_ *s = &m->status._buffer[i];

                        s->level = st->level;
                        s->name = st->name;
                        s->message = st->message;
                        s->hardware_id = st->hardware_id;
                        s->values._length = s->values._maximum = (uint32_t)st->n_values;
                        s->values._buffer = calloc(st->n_values + 1, sizeof(*s->values._buffer));
                        if (!s->values._buffer)
                                return -ENOMEM;
                        for (size_t k = 0; k < st->n_values; k++) {
                                s->values._buffer[k].key = st->values[k].key;
                                s->values._buffer[k].value = st->values[k].value;
                        }
                }
                return 0;
        }
        case PEER_NAVSATFIX: {
                sensor_msgs_msg_dds__NavSatFix_ *m = sample;

                to_header(v, &m->header);
                m->status.status = v->fix_status;
                m->status.service = v->service;
                m->latitude = v->latitude;
                m->longitude = v->longitude;
                m->altitude = v->altitude;
                memcpy(m->position_covariance, v->covariance, sizeof(v->covariance));
                m->position_covariance_type = v->covariance_type;
                return 0;
        }
        default:
                return -EINVAL;
        }
}

static void free_sample_buffers(enum peer_type t, void *sample)
{
        diagnostic_msgs_msg_dds__DiagnosticArray_ *m = sample;

        if (t != PEER_DIAGNOSTIC_ARRAY || !m->status._buffer)
                return;
        for (uint32_t i = 0; i < m->status._length; i++)
                free(m->status._buffer[i].values._buffer);
        free(m->status._buffer);
}

/* ---- entities ---- */

static dds_qos_t *endpoint_qos(const struct peer_args *a)
{
        dds_qos_t *q = dds_create_qos();
        const char *ud = peer_type_user_data(a->type);
        /* Plain CDR (XCDR1), as rmw_cyclonedds_cpp and rmw_fastrtps_cpp put on the wire. */
        const dds_data_representation_id_t xcdr1[] = { DDS_DATA_REPRESENTATION_XCDR1 };

        dds_qset_reliability(q, a->reliable ? DDS_RELIABILITY_RELIABLE
                                            : DDS_RELIABILITY_BEST_EFFORT, DDS_INFINITY);
        dds_qset_durability(q, a->transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL
                                                  : DDS_DURABILITY_VOLATILE);
        dds_qset_history(q, DDS_HISTORY_KEEP_LAST, a->depth);
        dds_qset_userdata(q, ud, strlen(ud));
        dds_qset_data_representation(q, 1, xcdr1);
        return q;
}

/* The domain on the configured network: --config FILE wins over CYCLONEDDS_URI; neither is
 * refused rather than falling back to Cyclone's default (multicast on every interface). */
static int create_domain(const struct peer_args *a)
{
        char path[PATH_MAX], uri[URI_MAX];
        dds_entity_t d;

        if (!a->config) {
                const char *env = getenv("CYCLONEDDS_URI");

                if (env && *env)
                        return 0;
                fprintf(stderr, "peer_cyclone: no network configuration: pass --config "
                        "tests/ros2peer/cyclonedds.xml or set CYCLONEDDS_URI\n");
                return -EINVAL;
        }
        if (!realpath(a->config, path)) {
                fprintf(stderr, "peer_cyclone: %s: %s\n", a->config, strerror(errno));
                return -errno;
        }
        snprintf(uri, sizeof(uri), "file://%s", path);
        d = dds_create_domain((dds_domainid_t)a->domain, uri);
        if (d < 0) {
                fprintf(stderr, "peer_cyclone: domain %d: %s\n", a->domain, dds_strretcode(d));
                return -EINVAL;
        }
        return 0;
}

/* ---- sub ---- */

static void report_writer(struct sub_state *s, dds_instance_handle_t ih)
{
        dds_builtintopic_endpoint_t *ep;
        dds_reliability_kind_t rel = DDS_RELIABILITY_BEST_EFFORT;
        dds_durability_kind_t dur = DDS_DURABILITY_VOLATILE;
        dds_duration_t blocking;
        void *ud = NULL;
        size_t ud_len = 0;

        for (size_t i = 0; i < s->n_writers; i++)
                if (s->writers[i] == ih)
                        return;
        if (s->n_writers < WRITERS_MAX)
                s->writers[s->n_writers++] = ih;
        ep = dds_get_matched_publication_data(s->reader, ih);
        if (!ep)
                return;         /* gone again before we looked */
        dds_qget_reliability(ep->qos, &rel, &blocking);
        dds_qget_durability(ep->qos, &dur);
        dds_qget_userdata(ep->qos, &ud, &ud_len);
        peer_print_writer(ep->topic_name, ep->type_name, rel == DDS_RELIABILITY_RELIABLE,
                          dur == DDS_DURABILITY_TRANSIENT_LOCAL, ud, ud_len);
        dds_free(ud);
        dds_builtintopic_free_endpoint(ep);
}

static void report_matched(struct sub_state *s)
{
        dds_instance_handle_t hs[WRITERS_MAX];
        dds_return_t n = dds_get_matched_publications(s->reader, hs, WRITERS_MAX);

        for (dds_return_t i = 0; i < n && i < WRITERS_MAX; i++)
                report_writer(s, hs[i]);
}

/* Prints one taken sample: its bytes as they arrived, then decoded by the type's own code. */
static int print_taken(struct sub_state *s, struct ddsi_serdata *sd)
{
        const dds_topic_descriptor_t *desc = descs[s->a->type];
        uint32_t size = ddsi_serdata_size(sd);
        unsigned char *cdr = malloc(size ? size : 1);
        void *sample = calloc(1, desc->m_size);
        struct peer_value v = { 0 };
        int r = -ENOMEM;

        if (cdr && sample) {
                ddsi_serdata_to_ser(sd, 0, size, cdr);
                r = ddsi_serdata_to_sample(sd, sample, NULL, NULL) ? 0 : -EBADMSG;
                if (r == 0)
                        r = from_sample(s->a->type, sample, &v);
                if (r == 0)
                        peer_print_sample(s->a->topic, desc->m_typename, cdr, size, &v);
                dds_sample_free(sample, desc, DDS_FREE_CONTENTS);
        }
        if (r < 0)
                fprintf(stderr, "peer_cyclone: a sample that does not decode (%s)\n",
                        strerror(-r));
        peer_value_free(&v);
        free(sample);
        free(cdr);
        return r;
}

static int take_all(struct sub_state *s, int *got)
{
        struct ddsi_serdata *sd;
        dds_sample_info_t si;
        int r = 0;

        while (dds_takecdr(s->reader, &sd, 1, &si, DDS_ANY_STATE) == 1) {
                if (si.valid_data) {
                        report_writer(s, si.publication_handle);
                        if (print_taken(s, sd) < 0)
                                r = -EBADMSG;
                        (*got)++;
                }
                ddsi_serdata_unref(sd);
        }
        return r;
}

static int run_sub(const struct peer_args *a, dds_entity_t pp, dds_entity_t topic)
{
        struct sub_state s = { .a = a };
        dds_qos_t *q = endpoint_qos(a);
        dds_entity_t ws;
        int64_t start;
        int got = 0;

        s.reader = dds_create_reader(pp, topic, q, NULL);
        dds_delete_qos(q);
        if (s.reader < 0) {
                fprintf(stderr, "peer_cyclone: reader: %s\n", dds_strretcode(s.reader));
                return PEER_EXIT_FAIL;
        }
        dds_set_status_mask(s.reader, DDS_SUBSCRIPTION_MATCHED_STATUS | DDS_DATA_AVAILABLE_STATUS);
        ws = dds_create_waitset(pp);
        dds_waitset_attach(ws, s.reader, s.reader);
        peer_print_line("ready sub topic=%s type=%s", a->topic, peer_type_dds_name(a->type));
        start = peer_now_ms();
        while (a->count == 0 || got < a->count) {
                int64_t left = peer_left_ms(start, a->timeout_ms);
                uint32_t st;

                if (left == 0) {
                        if (a->count == 0)
                                return PEER_EXIT_OK;
                        fprintf(stderr, "peer_cyclone: timeout: %d of %d samples\n", got, a->count);
                        return PEER_EXIT_FAIL;
                }
                dds_waitset_wait(ws, NULL, 0, DDS_MSECS(left));
                dds_take_status(s.reader, &st, DDS_SUBSCRIPTION_MATCHED_STATUS);
                report_matched(&s);
                if (take_all(&s, &got) < 0)
                        return PEER_EXIT_FAIL;
        }
        return PEER_EXIT_OK;
}

/* ---- pub ---- */

static int wait_matched(const struct peer_args *a, dds_entity_t pp, dds_entity_t writer,
                        int64_t start)
{
        dds_entity_t ws = dds_create_waitset(pp);
        dds_publication_matched_status_t st;

        dds_set_status_mask(writer, DDS_PUBLICATION_MATCHED_STATUS);
        dds_waitset_attach(ws, writer, writer);
        for (;;) {
                int64_t left;

                dds_get_publication_matched_status(writer, &st);
                if ((int)st.current_count >= a->readers)
                        break;
                left = peer_left_ms(start, a->timeout_ms);
                if (left == 0) {
                        fprintf(stderr, "peer_cyclone: timeout: %u of %d readers matched\n",
                                st.current_count, a->readers);
                        return -ETIMEDOUT;
                }
                dds_waitset_wait(ws, NULL, 0, DDS_MSECS(left));
        }
        peer_print_line("matched readers=%u", st.current_count);
        return 0;
}

static int run_pub(const struct peer_args *a, dds_entity_t pp, dds_entity_t topic)
{
        const dds_topic_descriptor_t *desc = descs[a->type];
        struct peer_value v;
        dds_qos_t *q;
        dds_entity_t writer;
        void *sample;
        int64_t start = peer_now_ms();
        int r;

        if (peer_value_parse(a->type, a->value, &v) < 0) {
                fprintf(stderr, "peer_cyclone: not a %s value: %s\n", peer_type_ros_name(a->type),
                        a->value);
                return PEER_EXIT_USAGE;
        }
        q = endpoint_qos(a);
        writer = dds_create_writer(pp, topic, q, NULL);
        dds_delete_qos(q);
        sample = calloc(1, desc->m_size);
        r = writer < 0 || !sample ? -EIO : 0;
        if (r == 0) {
                peer_print_line("ready pub topic=%s type=%s", a->topic, desc->m_typename);
                r = wait_matched(a, pp, writer, start);
        }
        if (r == 0)
                r = to_sample(&v, sample);
        /* Once, or (--wait-stdin) once for each line on stdin until its end. */
        for (int n = 0; r == 0; n++) {
                if (a->wait_stdin && peer_wait_stdin() < 0) {
                        if (n == 0) {
                                fprintf(stderr, "peer_cyclone: end of input, nothing written\n");
                                r = -ENODATA;
                        }
                        break;
                }
                if (dds_write(writer, sample) < 0) {
                        r = -EIO;
                        break;
                }
                printf("wrote topic=%s type=%s value=", a->topic, desc->m_typename);
                peer_value_print(stdout, &v);
                peer_print_line("%s", "");
                if (!a->wait_stdin)
                        break;
        }
        if (r == 0 && dds_wait_for_acks(writer, DDS_MSECS(a->timeout_ms)) < 0) {
                fprintf(stderr, "peer_cyclone: timeout waiting for acknowledgements\n");
                r = -ETIMEDOUT;
        }
        if (r == 0) {
                peer_print_line("acked");
                if (a->hold)
                        peer_hold_stdin();
        }
        else if (r == -EIO)
                fprintf(stderr, "peer_cyclone: writer failed\n");
        if (sample)
                free_sample_buffers(a->type, sample);
        free(sample);
        peer_value_free(&v);
        return r == 0 ? PEER_EXIT_OK : PEER_EXIT_FAIL;
}

int main(int argc, char **argv)
{
        struct peer_args a;
        dds_entity_t pp, topic;
        dds_qos_t *q;
        int rc;

        if (peer_args_parse(argc, argv, &a) < 0)
                return PEER_EXIT_USAGE;
        if (create_domain(&a) < 0)
                return PEER_EXIT_USAGE;
        q = dds_create_qos();
        dds_qset_userdata(q, PEER_PARTICIPANT_USER_DATA, strlen(PEER_PARTICIPANT_USER_DATA));
        pp = dds_create_participant((dds_domainid_t)a.domain, q, NULL);
        dds_delete_qos(q);
        if (pp < 0) {
                fprintf(stderr, "peer_cyclone: participant: %s\n", dds_strretcode(pp));
                return PEER_EXIT_FAIL;
        }
        topic = dds_create_topic(pp, descs[a.type], a.topic, NULL, NULL);
        if (topic < 0) {
                fprintf(stderr, "peer_cyclone: topic %s: %s\n", a.topic, dds_strretcode(topic));
                dds_delete(pp);
                return PEER_EXIT_FAIL;
        }
        rc = a.cmd == PEER_SUB ? run_sub(&a, pp, topic) : run_pub(&a, pp, topic);
        /* Deleting the domain deletes every entity in it and stops its threads. */
        dds_delete(DDS_CYCLONEDDS_HANDLE);
        return rc;
}
