/*
 * sharedlink-ros2: ROS 2 names, as pure functions (no I/O, no allocation). Unit tested on their
 * own (tests/unit/test_ros2_names.c); the rule is the contract of docs/ros2.md §1.
 *
 * A ROS 2 topic name (rmw's validation, rmw/validate_full_topic_name.c) is absolute, made of
 * tokens separated by single '/', each token one or more of [A-Za-z0-9_] not starting with a
 * digit, at most ROS2_NAME_MAX bytes in all; the DDS topic is "rt" + that name.
 *
 * A variable name (1..47 bytes of [A-Za-z0-9_.-]) becomes the relative name below the
 * namespace by one rule, applied per '.'-separated token:
 *   - '.' separates tokens ('/' in ROS);
 *   - '-' (the one byte a variable name may hold that ROS does not) becomes '_';
 *   - a token that is empty (a leading, trailing or doubled '.') or starts with a digit gets a
 *     '_' in front.
 * So "pronto.A.AutoGpsLat" is "pronto/A/AutoGpsLat", "gate-1.2nd" is "gate_1/_2nd", "a..b"
 * is "a/_/b". Two names that map to one topic ("a-b" and "a_b") are refused
 * (ros2_names_duplicates),
 * never merged.
 */
#ifndef SHAREDLINK_ROS2_NAMES_H
#define SHAREDLINK_ROS2_NAMES_H

#include <stdbool.h>
#include <stddef.h>

#include <sharedlink.h>

#define ROS2_NAME_MAX           247     /* bytes of a full topic name (rmw's limit) */
#define ROS2_NAME_SIZE          (ROS2_NAME_MAX + 1)
#define ROS2_DDS_PREFIX         "rt"    /* ROS topics on DDS: "rt" + the absolute name */
#define ROS2_DDS_NAME_SIZE      (ROS2_NAME_SIZE + sizeof(ROS2_DDS_PREFIX) - 1)
/* A mapped variable name: every token may gain one '_' (at most SL_NAME_SIZE - 1 tokens). */
#define ROS2_REL_SIZE           (2 * SL_NAME_SIZE)
#define ROS2_NAMESPACE_MAX      128     /* bytes of the namespace: with set/ and a mapped name
                                         * it stays under ROS2_NAME_MAX */
/* The bridge's own names below the namespace, and the one absolute name it publishes. */
#define ROS2_TOPIC_SET          "set"
#define ROS2_TOPIC_EVENTS       "events"
#define ROS2_TOPIC_SET_ERRORS   "set_errors"
#define ROS2_TOPIC_DIAGNOSTICS  "/diagnostics"

_Static_assert(ROS2_NAMESPACE_MAX + sizeof("/" ROS2_TOPIC_SET "/") + ROS2_REL_SIZE <
               ROS2_NAME_SIZE, "a set topic of any variable fits a ROS name");

/* The relative ROS name of variable name into out (ROS2_REL_SIZE). 0, or -EINVAL for a name
 * that is not a variable name (empty, too long, other bytes). */
int ros2_names_map(const char *name, char *out, size_t size);

/* Whether s is a valid absolute ROS name ("/" alone allowed when root_ok: a namespace). */
bool ros2_names_valid(const char *s, bool root_ok);

/* Whether s is a valid relative ROS name (tokens as above, no leading or trailing '/'). */
bool ros2_names_valid_relative(const char *s);

/* Whether rel (a mapped variable name) is one the bridge keeps below the namespace: "events",
 * "set_errors", "set" with anything below it (the writes). */
bool ros2_names_reserved(const char *rel);

/* One topic someone wants: its full name and who (an index of the caller's). */
struct ros2_names_ref {
        const char *name;
        size_t owner;
};

/* Sorts refs[0..n-1] by name and sets dup[owner] for every ref whose name another ref has too
 * (dup[] is indexed by owner and not cleared here). */
void ros2_names_duplicates(struct ros2_names_ref *refs, size_t n, bool *dup);

/* "<ns>/<a>[/<b>]" into out (ns "/" gives "/<a>..."); a starting with '/' is taken as it is
 * (b must then be NULL). 0 or -ENAMETOOLONG (over ROS2_NAME_MAX). */
int ros2_names_join(char *out, size_t size, const char *ns, const char *a, const char *b);

/* The DDS topic name of ROS name full: "rt" + full. 0 or -ENAMETOOLONG. */
int ros2_names_dds(char *out, size_t size, const char *full);

#endif
