/*
 * The ROS 2 test peers' common half (tests/ros2peer/README.md): the one command line of
 * peer_cyclone and peer_fastdds, the values they write and read in a vendor-neutral form, and the
 * lines they print. Each peer decodes and encodes with its own DDS library and its own copy of
 * the types; only parsing and printing are shared, so both print the same line for the same
 * sample. Plain C, so the C++ peer links it too.
 */
#ifndef SHAREDLINK_ROS2PEER_PEER_COMMON_H
#define SHAREDLINK_ROS2PEER_PEER_COMMON_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

#define PEER_EXIT_OK            0
#define PEER_EXIT_FAIL          1       /* a wait timed out or DDS failed */
#define PEER_EXIT_USAGE         2
#define PEER_COVARIANCE_LEN     9       /* NavSatFix.position_covariance */
/* USER_DATA a ROS node gives its participant (rmw: the security enclave). */
#define PEER_PARTICIPANT_USER_DATA "enclave=/;"

enum peer_type {
        PEER_INT64,
        PEER_FLOAT64,
        PEER_STRING,
        PEER_DIAGNOSTIC_ARRAY,
        PEER_NAVSATFIX,
        PEER_TYPE_COUNT
};

enum peer_cmd { PEER_SUB, PEER_PUB };

struct peer_args {
        enum peer_cmd cmd;
        const char *topic;              /* the DDS topic, "rt/..." */
        enum peer_type type;
        const char *value;              /* pub: the VALUE argument */
        bool reliable;
        bool transient_local;
        int depth;                      /* KEEP_LAST depth */
        int count;                      /* sub: samples to wait for */
        int readers;                    /* pub: matched readers to wait for */
        int timeout_ms;                 /* bound on each wait */
        int domain;
        const char *config;             /* the network configuration file */
        bool wait_stdin;                /* pub: write once per line on stdin */
        bool hold;                      /* pub: keep the writer until stdin ends */
};

struct peer_kv {
        char *key;
        char *value;
};

struct peer_status {
        uint8_t level;
        char *name;
        char *message;
        char *hardware_id;
        size_t n_values;
        struct peer_kv *values;
};

/* One value of any of the types, as both peers see it. Strings are owned (peer_value_free). */
struct peer_value {
        enum peer_type type;
        int64_t i;                      /* Int64 */
        double d;                       /* Float64 */
        char *s;                        /* String */
        int32_t sec;                    /* header.stamp and frame_id (DiagnosticArray, NavSatFix) */
        uint32_t nanosec;
        char *frame_id;
        size_t n_status;                /* DiagnosticArray */
        struct peer_status *status;
        int8_t fix_status;              /* NavSatFix */
        uint16_t service;
        double latitude, longitude, altitude;
        double covariance[PEER_COVARIANCE_LEN];
        uint8_t covariance_type;
};

/* Parses argv (peer_X sub|pub ...) into *ret; prints the usage and returns -EINVAL if wrong. */
int peer_args_parse(int argc, char **argv, struct peer_args *ret);

/* The DDS type name ("std_msgs::msg::dds_::Int64_") and the ROS name ("std_msgs/msg/Int64"). */
const char *peer_type_dds_name(enum peer_type t);
const char *peer_type_ros_name(enum peer_type t);

/* The USER_DATA of an endpoint of that type: "typehash=RIHS01_...;". */
const char *peer_type_user_data(enum peer_type t);

/* Parses a pub VALUE of type t (README.md: composite types as '|'-separated fields) into *ret;
 * -EINVAL if it does not parse, -ENOMEM. */
int peer_value_parse(enum peer_type t, const char *text, struct peer_value *ret);

/* Writes the value as the sample line shows it (README.md). */
void peer_value_print(FILE *f, const struct peer_value *v);

/* Frees what the value owns and zeroes it; v may be NULL. */
void peer_value_free(struct peer_value *v);

/* A duplicate of s ("" for NULL), or NULL when out of memory. */
char *peer_strdup(const char *s);

/* The lines on stdout (each flushed at once): a received sample, a matched remote writer, and
 * the peer's own progress ("ready", "matched", "wrote", "acked"). */
void peer_print_sample(const char *topic, const char *type_name, const void *cdr, size_t len,
                       const struct peer_value *v);
void peer_print_writer(const char *topic, const char *type_name, bool reliable,
                       bool transient_local, const void *user_data, size_t len);
void peer_print_line(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* Milliseconds on the monotonic clock, and what is left of timeout_ms since start (0: none). */
int64_t peer_now_ms(void);
int64_t peer_left_ms(int64_t start_ms, int timeout_ms);

/* Reads one line from stdin (a --wait-stdin go-ahead); 0, or -EIO at end of input. */
int peer_wait_stdin(void);

/* Reads stdin to its end (--hold: the writer stays, for late joiners, until the caller lets go). */
void peer_hold_stdin(void);

#ifdef __cplusplus
}
#endif

#endif
