/*
 * sharedlink-agility: the class file (docs/agility.md §8, conf/sharedlink-agility.yaml), read
 * with the toolkit's reader (svc/conf.h), so its rules and messages are those of every daemon
 * of the house: "FILE:LINE:COL: message".
 *
 *   instance: default                    # the sharedlinkd instance ("": $SHAREDLINK_INSTANCE)
 *   link: agility                        # the CIRCE controller link
 *   class: {name: "Jumping A", standard_course_time_ms: 40000, max_course_time_ms: 80000,
 *           intermediates: 0}
 *   gates: {start: E1E1E1, finish: E2E2E2, intermediate: []}   # or {start_finish, min_delay_ms}
 *   keypads: [AAAAAA]
 *   displays: [D15D15]
 *   competitors: /etc/sharedlink/agility/competitors.csv
 *   database: /var/lib/sharedlink-agility/results.db
 *   http: "127.0.0.1:8431"
 *
 * The competitor list named by the file is read here too (agility_competitors_parse), so -n
 * checks everything a start needs but the network: "dogs.csv:4: competitor number 1 is
 * already on line 2".
 */
#ifndef SHAREDLINK_AGILITYD_CONFIG_H
#define SHAREDLINK_AGILITYD_CONFIG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "agility/agility_competitors.h"
#include "agility/agility_run.h"

#define AGILITYD_CONFIG_DEFAULT "/etc/sharedlink/sharedlink-agility.yaml"
#define AGILITYD_FILE_MAX       (64u * 1024u)   /* bytes of a class file */
#define AGILITYD_CSV_MAX        (1024u * 1024u) /* bytes of a competitor list */
#define AGILITYD_ERROR_MAX      512
#define AGILITYD_PATH_MAX       256
#define AGILITYD_NAME_MAX       64      /* instance, link, class name: bytes + NUL */
#define AGILITYD_HOST_MAX       64      /* the HTTP bind address: bytes + NUL */
#define AGILITYD_DISPLAYS_MAX   16      /* wireless displays of a class */
#define AGILITYD_HTTP_HOST_DEFAULT "127.0.0.1"
#define AGILITYD_HTTP_PORT_DEFAULT 8431

struct agilityd_config {
        char instance[AGILITYD_NAME_MAX];       /* "": $SHAREDLINK_INSTANCE, else "default" */
        char link[AGILITYD_NAME_MAX];
        char class_name[AGILITYD_NAME_MAX];
        struct agility_class cls;
        uint32_t displays[AGILITYD_DISPLAYS_MAX];
        unsigned display_count;
        char competitors_path[AGILITYD_PATH_MAX];
        char database[AGILITYD_PATH_MAX];
        char http_host[AGILITYD_HOST_MAX];      /* numeric IPv4 or IPv6 address */
        uint16_t http_port;
        /* The competitor list, loaded from competitors_path. */
        struct agility_competitor competitors[AGILITY_COMPETITORS_MAX];
        size_t competitor_count;
};

/* Parses LEN bytes of TEXT (the file NAME) into *ret, without the competitor list. 0, or
 * -errno with "NAME:LINE:COL: message" in err. */
int agilityd_config_parse(const char *name, const char *text, size_t len,
                          struct agilityd_config *ret, char *err, size_t err_size);

/* Reads the file PATH and the competitor list it names into *ret. 0, or -errno with the
 * message in err. */
int agilityd_config_load(const char *path, struct agilityd_config *ret, char *err,
                         size_t err_size);

/* "E1E1E1" for addr (buf: SL_CIRCE_ADDRESS_SIZE bytes). */
void agilityd_address_format(uint32_t addr, char *buf);

/* Parses six hex digits (either case) into *ret; -EINVAL for anything else. */
int agilityd_address_parse(const char *s, uint32_t *ret);

#endif
