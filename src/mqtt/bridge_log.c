/*
 * sharedlink-mqtt logging (see bridge_log.h).
 */
#include "mqtt/bridge_log.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

static int log_verbosity;

void bridge_log_init(int verbosity)
{
        log_verbosity = verbosity;
}

void bridge_log(enum bridge_log_prio prio, const char *fmt, ...)
{
        char text[BRIDGE_LOG_LINE_MAX], line[BRIDGE_LOG_LINE_MAX];
        size_t o;
        va_list ap;

        if (prio == BRIDGE_LOG_DEBUG && log_verbosity < 1)
                return;
        va_start(ap, fmt);
        vsnprintf(text, sizeof(text), fmt, ap);
        va_end(ap);
        o = (size_t)snprintf(line, sizeof(line), "<%d>", (int)prio);
        for (const char *p = text; *p && o + 6 < sizeof(line); p++) {
                unsigned char ch = (unsigned char)*p;

                if (ch < 0x20 || ch == 0x7f)
                        o += (size_t)snprintf(line + o, sizeof(line) - o, "\\x%02X", ch);
                else
                        line[o++] = (char)ch;
        }
        line[o++] = '\n';
        /* One write per line: lines never interleave; a failed log write has nowhere to go. */
        if (write(STDERR_FILENO, line, o) < 0)
                return;
}
