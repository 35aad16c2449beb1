/*
 * sharedlink-ros2: the DDS side (see ros2_dds.h).
 */
#include "ros2/ros2_dds.h"

#include <stdbool.h>
#include <string.h>

#include "ros2/ros2_typehash.h"
#include "ros2_msgs.h"                  /* idlc's output, in the build tree */

#define MS                      DDS_MSECS(1)

struct type_row {
        const dds_topic_descriptor_t *desc;
        const char *ros;
};

static const struct type_row types[ROS2_TYPE_COUNT] = {
        [ROS2_TYPE_INT64] = { &std_msgs_msg_dds__Int64__desc, "std_msgs/msg/Int64" },
        [ROS2_TYPE_FLOAT64] = { &std_msgs_msg_dds__Float64__desc, "std_msgs/msg/Float64" },
        [ROS2_TYPE_STRING] = { &std_msgs_msg_dds__String__desc, "std_msgs/msg/String" },
        [ROS2_TYPE_DIAGNOSTICS] = { &diagnostic_msgs_msg_dds__DiagnosticArray__desc,
                                    "diagnostic_msgs/msg/DiagnosticArray" },
        [ROS2_TYPE_NAVSATFIX] = { &sensor_msgs_msg_dds__NavSatFix__desc,
                                  "sensor_msgs/msg/NavSatFix" },
};

const char *ros2_dds_ros_type(enum ros2_type t)
{
        return types[t].ros;
}

const char *ros2_dds_type_name(enum ros2_type t)
{
        return types[t].desc->m_typename;
}

const dds_topic_descriptor_t *ros2_dds_descriptor(enum ros2_type t)
{
        return types[t].desc;
}

dds_entity_t ros2_dds_participant(unsigned domain, const char *config)
{
        dds_qos_t *qos = dds_create_qos();
        dds_entity_t pp, dom = 0;

        if (!qos)
                return DDS_RETCODE_OUT_OF_RESOURCES;
        /* A domain of our own only when a configuration is given: without one Cyclone reads
         * $CYCLONEDDS_URI itself, as every ROS 2 node on the machine does. */
        if (config && config[0]) {
                dom = dds_create_domain(domain, config);
                if (dom < 0) {
                        dds_delete_qos(qos);
                        return dom;
                }
        }
        dds_qset_userdata(qos, ROS2_ENCLAVE_USERDATA, strlen(ROS2_ENCLAVE_USERDATA));
        pp = dds_create_participant(domain, qos, NULL);
        dds_delete_qos(qos);
        if (pp < 0 && dom > 0)
                dds_delete(dom);
        return pp;
}

static void qos_fill(dds_qos_t *qos, enum ros2_qos q)
{
        static const dds_data_representation_id_t xcdr1[] = { DDS_DATA_REPRESENTATION_XCDR1 };

        /* Plain CDR only, the encoding every ROS 2 middleware reads. */
        dds_qset_data_representation(qos, 1, xcdr1);
        switch (q) {
        case ROS2_QOS_VALUE:
                dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, 100 * MS);
                dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
                dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 1);
                break;
        case ROS2_QOS_EVENTS:
                /* Never blocks the loop: a full history (a reader that does not acknowledge)
                 * makes dds_write return a timeout at once, and the bridge tries again later
                 * from the same place in the ring. */
                dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, 0);
                dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
                dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
                break;
        case ROS2_QOS_STATUS:
                dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, 100 * MS);
                dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
                dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, ROS2_STATUS_DEPTH);
                break;
        case ROS2_QOS_SET:
                /* VOLATILE: a TRANSIENT_LOCAL writer's old samples are never delivered to a
                 * volatile reader, so an old write cannot come back when we (re)match. KEEP_ALL
                 * with a bound: a flood is held back by the protocol, not dropped. */
                dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, 100 * MS);
                dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
                dds_qset_history(qos, DDS_HISTORY_KEEP_ALL, 0);
                dds_qset_resource_limits(qos, ROS2_SET_SAMPLES_MAX, DDS_LENGTH_UNLIMITED,
                                         DDS_LENGTH_UNLIMITED);
                dds_qset_ignorelocal(qos, DDS_IGNORELOCAL_PARTICIPANT);
                break;
        case ROS2_QOS_COUNT:
                break;
        }
}

dds_entity_t ros2_dds_endpoint(dds_entity_t pp, enum ros2_type t, const char *name,
                               enum ros2_qos q, const dds_listener_t *l,
                               dds_entity_t *ret_topic)
{
        /* The type's RIHS01 hash as Iron and later nodes announce it (ros2_typehash.h). */
        const char *ud = ros2_typehash_user_data(types[t].desc->m_typename);
        dds_qos_t *qos;
        dds_entity_t topic, ep;

        if (!ud)
                return DDS_RETCODE_BAD_PARAMETER;
        qos = dds_create_qos();
        if (!qos)
                return DDS_RETCODE_OUT_OF_RESOURCES;
        topic = dds_create_topic(pp, types[t].desc, name, NULL, NULL);
        if (topic < 0) {
                dds_delete_qos(qos);
                return topic;
        }
        qos_fill(qos, q);
        dds_qset_userdata(qos, ud, strlen(ud));
        if (q == ROS2_QOS_SET)
                ep = dds_create_reader(pp, topic, qos, l);
        else
                ep = dds_create_writer(pp, topic, qos, l);
        dds_delete_qos(qos);
        if (ep < 0) {
                dds_delete(topic);
                return ep;
        }
        *ret_topic = topic;
        return ep;
}
