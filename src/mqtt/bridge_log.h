/*
 * sharedlink-mqtt logging: one line per message on stderr with an sd-daemon(3) priority prefix
 * ("<4>text"), which journald turns into the syslog priority; one write(2) per line. Control
 * bytes in a message (topic or payload text from the network) are written as \xNN so that one
 * message is always one line. Process-wide, like the one stderr it stands for.
 */
#ifndef SHAREDLINK_MQTT_BRIDGE_LOG_H
#define SHAREDLINK_MQTT_BRIDGE_LOG_H

enum bridge_log_prio {
        BRIDGE_LOG_ERR = 3,
        BRIDGE_LOG_WARNING = 4,
        BRIDGE_LOG_NOTICE = 5,
        BRIDGE_LOG_INFO = 6,
        BRIDGE_LOG_DEBUG = 7,
};

#define BRIDGE_LOG_LINE_MAX     1024    /* bytes per line, prefix and newline included */

/* Sets the verbosity: 0 info and worse, >= 1 debug too. */
void bridge_log_init(int verbosity);

/* Writes one message at prio if the verbosity lets it through. */
void bridge_log(enum bridge_log_prio prio, const char *fmt, ...)
        __attribute__((format(printf, 2, 3)));

#endif
