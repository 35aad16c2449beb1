/*
 * sharedlink-ros2 configuration: one YAML file, read with the toolkit's reader (svc/conf.h) as
 * sharedlink-mqtt's is: unknown keys, wrong types, out-of-range numbers, duplicate keys,
 * anchors, aliases and tags are errors "FILE:LINE:COL: message", never a silent default.
 * The keys (conf/sharedlink-ros2.yaml): instance, namespace, publish, writable, domain_id,
 * cyclonedds_uri, navsatfix: [{topic, latitude, longitude, altitude, frame_id}], wait_spin_us,
 * cursor_file.
 */
#ifndef SHAREDLINK_ROS2_CONFIG_H
#define SHAREDLINK_ROS2_CONFIG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <sharedlink.h>

#include "ros2/ros2_names.h"
#include "svc/globs.h"

#define ROS2_CONFIG_DEFAULT     "/etc/sharedlink/sharedlink-ros2.yaml"
#define ROS2_FILE_MAX           (64u * 1024u)   /* bytes of a configuration file */
#define ROS2_ERROR_MAX          512
#define ROS2_INSTANCE_MAX       64
#define ROS2_NAMESPACE_PREFIX   "/sharedlink/"  /* the default namespace: this + instance */
#define ROS2_URI_MAX            4096    /* bytes of cyclonedds_uri (a file:// URI or XML) */
#define ROS2_DOMAIN_MAX         232u    /* the largest id the DDS port mapping allows */
#define ROS2_DOMAIN_ENV         "ROS_DOMAIN_ID"
#define ROS2_NAVSATFIX_MAX      8       /* navsatfix: entries */
#define ROS2_FRAME_MAX          64      /* bytes of a frame_id + NUL */
#define ROS2_FRAME_DEFAULT      "gps"
#define ROS2_PATH_MAX           512     /* bytes of cursor_file + NUL */
#define ROS2_CURSOR_OWNER       "sharedlink-ros2"       /* svc/cursor.h: the file's first word */

/* A NavSatFix built from two or three variables (docs/ros2.md §6). */
struct ros2_navsatfix {
        char topic[ROS2_NAME_SIZE];     /* relative to the namespace, or absolute */
        char latitude[SL_NAME_SIZE];
        char longitude[SL_NAME_SIZE];
        char altitude[SL_NAME_SIZE];    /* "" : none (altitude NaN) */
        char frame_id[ROS2_FRAME_MAX];
        unsigned line, column;          /* of the entry, for messages about its variables */
};

struct ros2_config {
        char instance[ROS2_INSTANCE_MAX];       /* "" : $SHAREDLINK_INSTANCE or "default" */
        char ns[ROS2_NAMESPACE_MAX];            /* "" : ROS2_NAMESPACE_PREFIX<instance> */
        struct globs publish;                   /* default: ["*"] */
        unsigned publish_line, publish_column;  /* of publish: (0: not in the file) */
        struct globs writable;                  /* default: none */
        unsigned domain_id;
        bool domain_set;                        /* domain_id: given (else $ROS_DOMAIN_ID or 0) */
        char cyclonedds_uri[ROS2_URI_MAX];      /* "" : Cyclone's own ($CYCLONEDDS_URI) */
        unsigned n_navsatfix;
        struct ros2_navsatfix navsatfix[ROS2_NAVSATFIX_MAX];
        uint32_t wait_spin_us;                  /* 0..SL_WAIT_SPIN_MAX_US; 0: sleep at once */
        char cursor_file[ROS2_PATH_MAX];        /* "" : beside the lock (main.c) */
};

/* Fills *ret with every default (what an empty file gives). */
void ros2_config_defaults(struct ros2_config *ret);

/* Parses text (len bytes; name is used in messages) into *ret. 0, or -EINVAL / -ENOMEM with
 * "NAME:LINE:COL: message" in err (err_size bytes). */
int ros2_config_parse(const char *name, const char *text, size_t len, struct ros2_config *ret,
                      char *err, size_t err_size);

/* Reads and parses a file. 0 or -errno, message in err. */
int ros2_config_load(const char *path, struct ros2_config *ret, char *err, size_t err_size);

/* The -n check of cursor_file when given (the default's directory is made at the start): a
 * file there must be a cursor of sharedlink-ros2's, else its directory must let one be made.
 * 0, or -errno with "NAME: cursor_file PATH: reason" in err. */
int ros2_config_check_cursor(const struct ros2_config *cfg, const char *name, char *err,
                             size_t err_size);

/* The instance to open and the namespace, defaults applied ($SHAREDLINK_INSTANCE, "default",
 * ROS2_NAMESPACE_PREFIX<instance mapped as a variable name is, ros2_names.h>). 0, or -EINVAL
 * when the instance cannot be mapped (bytes outside a variable name's: set namespace:). */
int ros2_config_names(const struct ros2_config *cfg, char instance[ROS2_INSTANCE_MAX],
                      char ns[ROS2_NAMESPACE_MAX]);

/* The DDS domain: domain_id, else $ROS_DOMAIN_ID (a number 0..ROS2_DOMAIN_MAX), else 0.
 * -EINVAL for an environment value that is not one. */
int ros2_config_domain(const struct ros2_config *cfg, unsigned *ret);

#endif
