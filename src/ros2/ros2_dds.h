/*
 * sharedlink-ros2: the DDS side, thin (Cyclone DDS 0.10): the ROS 2 types the bridge speaks
 * (src/ros2/idl/ros2_msgs.idl, compiled by idlc), the QoS of each kind of topic, and endpoints
 * made the way a ROS 2 node makes them: the participant's USER_DATA "enclave=/;", each
 * endpoint's "typehash=RIHS01_<hex>;" (Iron and later put the type's hash there), plain CDR
 * (XCDR1) only. docs/ros2.md §2-3 is the contract.
 */
#ifndef SHAREDLINK_ROS2_DDS_H
#define SHAREDLINK_ROS2_DDS_H

#include <stddef.h>

#include <dds/dds.h>

enum ros2_type {
        ROS2_TYPE_INT64,                /* std_msgs/msg/Int64 */
        ROS2_TYPE_FLOAT64,              /* std_msgs/msg/Float64 */
        ROS2_TYPE_STRING,               /* std_msgs/msg/String */
        ROS2_TYPE_DIAGNOSTICS,          /* diagnostic_msgs/msg/DiagnosticArray */
        ROS2_TYPE_NAVSATFIX,            /* sensor_msgs/msg/NavSatFix */
        ROS2_TYPE_COUNT
};

/* How an endpoint behaves (docs/ros2.md §3). */
enum ros2_qos {
        ROS2_QOS_VALUE,                 /* writer: RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1 */
        ROS2_QOS_EVENTS,                /* writer: RELIABLE, VOLATILE, KEEP_ALL, no blocking */
        ROS2_QOS_STATUS,                /* writer: RELIABLE, VOLATILE, KEEP_LAST status depth */
        ROS2_QOS_SET,                   /* reader: RELIABLE, VOLATILE, KEEP_ALL, ignore local */
        ROS2_QOS_COUNT
};

#define ROS2_STATUS_DEPTH       16      /* /diagnostics and set_errors samples kept per writer */
#define ROS2_SET_SAMPLES_MAX    256     /* writes held by a set reader before back-pressure */
#define ROS2_ENCLAVE_USERDATA   "enclave=/;"

/* The ROS name of a type ("std_msgs/msg/Int64") and its DDS name
 * ("std_msgs::msg::dds_::Int64_"). */
const char *ros2_dds_ros_type(enum ros2_type t);
const char *ros2_dds_type_name(enum ros2_type t);

/* The idlc descriptor of a type. */
const dds_topic_descriptor_t *ros2_dds_descriptor(enum ros2_type t);

/* The participant on domain (config: Cyclone XML or file:// URI for a domain of our own, or
 * NULL/"" for Cyclone's default, $CYCLONEDDS_URI), with USER_DATA "enclave=/;". A participant
 * handle, or a negative DDS return code (dds_strretcode). */
dds_entity_t ros2_dds_participant(unsigned domain, const char *config);

/* A writer (or, for ROS2_QOS_SET, a reader) of type t on DDS topic name, with listener l (NULL:
 * none) and that type's typehash USER_DATA; *ret_topic gets the topic entity (deleted with the
 * endpoint by the caller). The endpoint, or a negative DDS return code. */
dds_entity_t ros2_dds_endpoint(dds_entity_t pp, enum ros2_type t, const char *name,
                               enum ros2_qos q, const dds_listener_t *l,
                               dds_entity_t *ret_topic);

#endif
