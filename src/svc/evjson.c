/*
 * The JSON of the daemon's events (see evjson.h).
 */
#include "svc/evjson.h"

#include <inttypes.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "svc/json.h"

#define EPOCH_HEX_SIZE          17      /* 16 hex digits + NUL */

static void epoch_hex(char out[EPOCH_HEX_SIZE], uint64_t epoch)
{
        snprintf(out, EPOCH_HEX_SIZE, "%016" PRIx64, epoch);
}

/* "k=v k2=v2" as an object; a word without '=' becomes a key with an empty value. */
static void json_fields(struct json_buf *j, const char *text)
{
        bool first = true;

        json_buf_key(j, "fields");
        json_buf_raw(j, "{", 1);
        for (const char *p = text; *p;) {
                size_t wl = strcspn(p, " "), kl;
                const char *eq;

                if (wl == 0) {
                        p++;
                        continue;
                }
                eq = memchr(p, '=', wl);
                kl = eq ? (size_t)(eq - p) : wl;
                if (!first)
                        json_buf_raw(j, ",", 1);
                first = false;
                json_buf_quoted(j, p, kl);
                json_buf_raw(j, ":", 1);
                json_buf_quoted(j, eq ? eq + 1 : p + wl, eq ? wl - kl - 1 : 0);
                p += wl;
        }
        json_buf_raw(j, "}", 1);
}

int evjson_event(char *buf, size_t size, uint64_t epoch, const struct sl_event *ev)
{
        struct json_buf j;
        char hex[EPOCH_HEX_SIZE];

        epoch_hex(hex, epoch);
        json_buf_begin(&j, buf, size);
        json_buf_str(&j, "epoch", hex);
        json_buf_u64(&j, "seq", ev->seq);
        json_buf_u64(&j, "time_ns", ev->real_ns);
        json_buf_str(&j, "link", ev->link_name);
        json_buf_str(&j, "type", ev->type_name);
        json_buf_str(&j, "text", ev->text);
        json_fields(&j, ev->text);
        json_buf_bool(&j, "truncated", ev->flags & SL_EVENT_TRUNCATED);
        return json_buf_end(&j);
}

int evjson_notice(char *buf, size_t size, const char *type, uint64_t epoch, uint64_t seq,
                  uint64_t lost)
{
        struct json_buf j;
        char hex[EPOCH_HEX_SIZE];

        epoch_hex(hex, epoch);
        json_buf_begin(&j, buf, size);
        json_buf_str(&j, "epoch", hex);
        json_buf_u64(&j, "seq", seq);
        json_buf_str(&j, "link", "");
        json_buf_str(&j, "type", type);
        json_buf_u64(&j, "lost", lost);
        return json_buf_end(&j);
}
