/*
 * sharedlink-ros2: the ROS 2 type hashes (REP 2011, "ROS Interface Hashing Standard" version 1)
 * of the message types the bridge speaks, and the USER_DATA text that carries them.
 *
 * Iron and later nodes put "typehash=RIHS01_<sha256 hex>;" in the USER_DATA QoS of every reader
 * and writer; a node that finds a different hash for the same type name on a topic logs that the
 * types differ. The hash is the SHA-256 of a JSON form of the type's description (its fields,
 * then every type it references, sorted by name; default values left out), computed by ROS's
 * rosidl_generator_type_description at build time. We have no ROS to run it, so the values are
 * constants here, and tests/ros2peer/test_typehash.py recomputes each one from the .msg
 * definitions by the same algorithm and compares it with this file and with the value ROS itself
 * publishes (make check): a wrong constant fails the check.
 *
 * Matched against a published value (the hash ROS's generator emits, as found in generated
 * rosidl C sources and in independent ROS 2 clients' hash tables; see the test for which):
 * every constant below. None is only recomputed.
 */
#ifndef SHAREDLINK_ROS2_TYPEHASH_H
#define SHAREDLINK_ROS2_TYPEHASH_H

#include <stddef.h>

#define ROS2_TYPEHASH_PREFIX    "RIHS01_"
#define ROS2_TYPEHASH_HEX_LEN   64      /* hex digits of the SHA-256 */
#define ROS2_TYPEHASH_LEN       (sizeof(ROS2_TYPEHASH_PREFIX) - 1 + ROS2_TYPEHASH_HEX_LEN)

/* std_msgs/msg/{Int64,Float64,String}: the value topics. */
#define ROS2_TYPEHASH_INT64 \
        "RIHS01_8cd1048c2f186b6bd9a92472dc1ce51723c0833a221e2b7aecfff111774f4b49"
#define ROS2_TYPEHASH_FLOAT64 \
        "RIHS01_705ba9c3d1a09df43737eb67095534de36fd426c0587779bda2bc51fe790182a"
#define ROS2_TYPEHASH_STRING \
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
/* diagnostic_msgs/msg/DiagnosticArray: /diagnostics (references DiagnosticStatus, KeyValue,
 * std_msgs/Header and builtin_interfaces/Time; their own hashes for completeness). */
#define ROS2_TYPEHASH_DIAGNOSTIC_ARRAY \
        "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e"
#define ROS2_TYPEHASH_DIAGNOSTIC_STATUS \
        "RIHS01_b0e3e692ea2d54a8af2f4ef1930e81556a2db55216b771f8a7d2724ed47bf0e4"
#define ROS2_TYPEHASH_KEY_VALUE \
        "RIHS01_d68081eaa540288c5440753baecef0c4e16e81a5f78ad68902ded5100413bb42"
#define ROS2_TYPEHASH_HEADER \
        "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01"
#define ROS2_TYPEHASH_TIME \
        "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197"
/* sensor_msgs/msg/NavSatFix: the navsatfix: mapping (references NavSatStatus, Header, Time). */
#define ROS2_TYPEHASH_NAVSATFIX \
        "RIHS01_62223ab3fe210a15976021da7afddc9e200dc9ec75231c1b6a557fc598a65404"
#define ROS2_TYPEHASH_NAVSATSTATUS \
        "RIHS01_d1ed3befa628e09571bd273b888ba1c1fd187c9a5e0006b385d7e5e9095a3204"

/* The USER_DATA of an endpoint, as rmw puts it (the key, '=', the hash, ';'). */
#define ROS2_TYPEHASH_USER_DATA(hash)   "typehash=" hash ";"

/* One type: its ROS name ("std_msgs/msg/Int64"), its DDS name ("std_msgs::msg::dds_::Int64_"),
 * its hash and the USER_DATA text of its endpoints. */
struct ros2_typehash {
        const char *ros_name;
        const char *dds_name;
        const char *hash;
        const char *user_data;
};

/* The type of that ROS name or DDS name, NULL when it is none of ours. */
const struct ros2_typehash *ros2_typehash_find(const char *type_name);

/* The "RIHS01_..." hash of that ROS or DDS type name, NULL when it is none of ours. */
const char *ros2_typehash_get(const char *type_name);

/* The "typehash=RIHS01_...;" USER_DATA of that ROS or DDS type name, NULL when none of ours. */
const char *ros2_typehash_user_data(const char *type_name);

/* The i-th known type (0 ..), NULL past the last: for tests and listings. */
const struct ros2_typehash *ros2_typehash_at(size_t i);

#endif
