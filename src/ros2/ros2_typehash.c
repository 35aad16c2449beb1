/*
 * sharedlink-ros2: ROS 2 type hashes (see ros2_typehash.h).
 */
#include "ros2/ros2_typehash.h"

#include <string.h>

/* ROS names pkg/msg/Type map to DDS names pkg::msg::dds_::Type_ (rosidl_typesupport's rule for
 * the types rmw registers with DDS); both spellings are kept whole so a lookup is one strcmp. */
#define TYPE(pkg, name, hash_) \
        { pkg "/msg/" name, pkg "::msg::dds_::" name "_", hash_, ROS2_TYPEHASH_USER_DATA(hash_) }

static const struct ros2_typehash types[] = {
        TYPE("std_msgs", "Int64", ROS2_TYPEHASH_INT64),
        TYPE("std_msgs", "Float64", ROS2_TYPEHASH_FLOAT64),
        TYPE("std_msgs", "String", ROS2_TYPEHASH_STRING),
        TYPE("std_msgs", "Header", ROS2_TYPEHASH_HEADER),
        TYPE("builtin_interfaces", "Time", ROS2_TYPEHASH_TIME),
        TYPE("diagnostic_msgs", "DiagnosticArray", ROS2_TYPEHASH_DIAGNOSTIC_ARRAY),
        TYPE("diagnostic_msgs", "DiagnosticStatus", ROS2_TYPEHASH_DIAGNOSTIC_STATUS),
        TYPE("diagnostic_msgs", "KeyValue", ROS2_TYPEHASH_KEY_VALUE),
        TYPE("sensor_msgs", "NavSatFix", ROS2_TYPEHASH_NAVSATFIX),
        TYPE("sensor_msgs", "NavSatStatus", ROS2_TYPEHASH_NAVSATSTATUS),
};

/* Every hash has the one length REP 2011 gives version 01; a typo that drops a digit fails the
 * build rather than a ROS node's comparison. */
#define HASH_OK(h)      (sizeof(h) - 1 == ROS2_TYPEHASH_LEN)
_Static_assert(HASH_OK(ROS2_TYPEHASH_INT64) && HASH_OK(ROS2_TYPEHASH_FLOAT64) &&
               HASH_OK(ROS2_TYPEHASH_STRING) && HASH_OK(ROS2_TYPEHASH_HEADER) &&
               HASH_OK(ROS2_TYPEHASH_TIME) && HASH_OK(ROS2_TYPEHASH_DIAGNOSTIC_ARRAY) &&
               HASH_OK(ROS2_TYPEHASH_DIAGNOSTIC_STATUS) && HASH_OK(ROS2_TYPEHASH_KEY_VALUE) &&
               HASH_OK(ROS2_TYPEHASH_NAVSATFIX) && HASH_OK(ROS2_TYPEHASH_NAVSATSTATUS),
               "a RIHS01 hash is the prefix and 64 hex digits");

const struct ros2_typehash *ros2_typehash_find(const char *type_name)
{
        if (!type_name)
                return NULL;
        for (size_t i = 0; i < sizeof(types) / sizeof(types[0]); i++)
                if (strcmp(types[i].ros_name, type_name) == 0 ||
                    strcmp(types[i].dds_name, type_name) == 0)
                        return &types[i];
        return NULL;
}

const char *ros2_typehash_get(const char *type_name)
{
        const struct ros2_typehash *t = ros2_typehash_find(type_name);

        return t ? t->hash : NULL;
}

const char *ros2_typehash_user_data(const char *type_name)
{
        const struct ros2_typehash *t = ros2_typehash_find(type_name);

        return t ? t->user_data : NULL;
}

const struct ros2_typehash *ros2_typehash_at(size_t i)
{
        return i < sizeof(types) / sizeof(types[0]) ? &types[i] : NULL;
}
