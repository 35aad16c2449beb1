/*
 * Waiting for values through the client library (see slwait.h).
 */
#include "common/slwait.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "common/harness.h"

#define SLWAIT_NS_PER_MS 1000000u

/* The text of name now into buf; false when it does not exist or cannot be read. */
static bool slwait_read(struct sl_client *c, const char *name, char *buf, size_t size)
{
        int id = sl_find(c, name);

        return id >= 0 && sl_read(c, id, buf, size, NULL) >= 0;
}

bool slwait_value_is(struct sl_client *c, const char *name, const char *want)
{
        char buf[SL_VALUE_SIZE];

        return slwait_read(c, name, buf, sizeof(buf)) && strcmp(buf, want) == 0;
}

int slwait_value(struct sl_client *c, const char *name, const char *want, int timeout_ms,
                 char *last, size_t lastsz)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)timeout_ms * SLWAIT_NS_PER_MS;
        char buf[SL_VALUE_SIZE] = "";
        uint32_t cursor = 0;

        for (;;) {
                if (slwait_read(c, name, buf, sizeof(buf)) && strcmp(buf, want) == 0)
                        return 0;
                if (harness_now_ns() >= deadline)
                        break;
                sl_wait(c, &cursor, SLWAIT_SLICE_MS);
        }
        if (lastsz)
                snprintf(last, lastsz, "%s", buf);
        return -ETIMEDOUT;
}

int slwait_link_state(struct sl_client *c, int link, const char *prefix, int timeout_ms)
{
        uint64_t deadline = harness_now_ns() + (uint64_t)timeout_ms * SLWAIT_NS_PER_MS;
        uint32_t cursor = 0;

        for (;;) {
                struct sl_link_info li = { .size = sizeof(li) };

                if (sl_link_info(c, link, &li) == 0 &&
                    strncmp(li.state_name, prefix, strlen(prefix)) == 0)
                        return 0;
                if (harness_now_ns() >= deadline)
                        return -ETIMEDOUT;
                sl_wait(c, &cursor, SLWAIT_SLICE_MS);
        }
}

int slwait_changes_now(struct sl_client *c, uint64_t *ret_cursor)
{
        uint64_t cursor = 0;
        uint32_t flags;
        int r = sl_changed(c, &cursor, NULL, 0, &flags);

        if (r < 0)
                return r;
        if (flags != (SL_CHANGED_ALL | SL_CHANGED_START))
                return -EPROTO;
        *ret_cursor = cursor;
        return 0;
}

int slwait_changes_overrun(struct sl_client *c, uint64_t cursor)
{
        uint32_t flags;
        int r = sl_changed(c, &cursor, NULL, 0, &flags);

        return r < 0 ? r : (flags & SL_CHANGED_OVERRUN) != 0;
}
