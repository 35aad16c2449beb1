/*
 * sharedlink-mqtt wire formats (see bridge_format.h).
 */
#include "mqtt/bridge_format.h"

#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <string.h>

#include "proto/sharedlink.h"
#include "svc/json.h"

#define NS_PER_MS               1000000u
#define SET_LEVEL               "/" BRIDGE_TOPIC_SET "/"
#define ERROR_SUFFIX            "/" BRIDGE_TOPIC_ERROR

static const char *const reserved_words[] = {
        BRIDGE_TOPIC_SET, BRIDGE_TOPIC_EVENTS, BRIDGE_TOPIC_LINKS, BRIDGE_TOPIC_STATUS,
        BRIDGE_TOPIC_BRIDGE,
};

static const char *const refusal_text[BRIDGE_REFUSE_COUNT] = {
        [BRIDGE_REFUSE_NONE] = "accepted",
        [BRIDGE_REFUSE_TOPIC] = "not a set topic of one variable name",
        [BRIDGE_REFUSE_UNKNOWN] = "no such variable",
        [BRIDGE_REFUSE_INBOUND] = "an inbound variable is read only",
        [BRIDGE_REFUSE_NOT_WRITABLE] = "not writable from MQTT (writable: in the configuration)",
        [BRIDGE_REFUSE_TOO_LONG] = "value longer than 63 bytes",
        [BRIDGE_REFUSE_NOT_UTF8] = "value is not UTF-8",
        [BRIDGE_REFUSE_BAD_VALUE] = "value cannot go on the wire (printable ASCII without | [ ])",
        [BRIDGE_REFUSE_FAILED] = "write failed",
        [BRIDGE_REFUSE_RETAINED] = "a retained message is never applied (publish writes without "
                                   "retain, and clear this one)",
        [BRIDGE_REFUSE_QUEUED] = "it waited in the broker while the bridge was disconnected: "
                                 "never applied late",
};

static const char *const refusal_code[BRIDGE_REFUSE_COUNT] = {
        [BRIDGE_REFUSE_NONE] = "ok",
        [BRIDGE_REFUSE_TOPIC] = "bad-topic",
        [BRIDGE_REFUSE_UNKNOWN] = "unknown",
        [BRIDGE_REFUSE_INBOUND] = "inbound",
        [BRIDGE_REFUSE_NOT_WRITABLE] = "not-writable",
        [BRIDGE_REFUSE_TOO_LONG] = "too-long",
        [BRIDGE_REFUSE_NOT_UTF8] = "not-utf8",
        [BRIDGE_REFUSE_BAD_VALUE] = "bad-value",
        [BRIDGE_REFUSE_FAILED] = "failed",
        [BRIDGE_REFUSE_RETAINED] = "retained",
        [BRIDGE_REFUSE_QUEUED] = "queued",
};

int bridge_format_topic(char *buf, size_t size, const char *base, const char *a, const char *b)
{
        int n = b ? snprintf(buf, size, "%s/%s/%s", base, a, b) :
                    snprintf(buf, size, "%s/%s", base, a);

        return n < 0 || (size_t)n >= size ? -ENAMETOOLONG : 0;
}

int bridge_format_name_ok(const char *name)
{
        if (!name[0] || strlen(name) >= SL_NAME_SIZE)
                return 0;
        for (const char *p = name; *p; p++)
                if (!slp_name_byte(*p))         /* the tables' own rule: never '/', '+' or '#' */
                        return 0;
        for (size_t i = 0; i < sizeof(reserved_words) / sizeof(reserved_words[0]); i++)
                if (!strcmp(name, reserved_words[i]))
                        return 0;
        return 1;
}

int bridge_format_set_topic(const char *base, const char *topic, char *ret_name)
{
        size_t bl = strlen(base), sl = strlen(SET_LEVEL), nl;
        const char *name, *slash;

        if (strncmp(topic, base, bl) != 0 || strncmp(topic + bl, SET_LEVEL, sl) != 0)
                return -EINVAL;
        name = topic + bl + sl;
        slash = strchr(name, '/');
        if (slash) {
                char own[SL_NAME_SIZE];

                /* Our own replies come back to us through the set/# subscription: only under
                 * a name we could have answered for, anything else is refused. */
                nl = (size_t)(slash - name);
                if (strcmp(slash, ERROR_SUFFIX) != 0 || nl == 0 || nl >= sizeof(own))
                        return -EINVAL;
                memcpy(own, name, nl);
                own[nl] = '\0';
                return bridge_format_name_ok(own) ? 0 : -EINVAL;
        }
        nl = strlen(name);
        if (nl == 0 || nl >= SL_NAME_SIZE || !bridge_format_name_ok(name))
                return -EINVAL;
        memcpy(ret_name, name, nl + 1);
        return 1;
}

/* Length of the UTF-8 sequence at p (at most left bytes), or 0 when it is not valid UTF-8:
 * no overlong forms, no surrogates, nothing above U+10FFFF. */
static size_t utf8_sequence(const unsigned char *p, size_t left)
{
        uint32_t cp;
        size_t n;

        if (p[0] < 0x80)
                return 1;
        if (p[0] >= 0xC2 && p[0] <= 0xDF)
                n = 2, cp = p[0] & 0x1Fu;
        else if (p[0] >= 0xE0 && p[0] <= 0xEF)
                n = 3, cp = p[0] & 0x0Fu;
        else if (p[0] >= 0xF0 && p[0] <= 0xF4)
                n = 4, cp = p[0] & 0x07u;
        else
                return 0;
        if (n > left)
                return 0;
        for (size_t i = 1; i < n; i++) {
                if ((p[i] & 0xC0) != 0x80)
                        return 0;
                cp = (cp << 6) | (p[i] & 0x3Fu);
        }
        if ((n == 3 && cp < 0x800) || (n == 4 && cp < 0x10000) || cp > 0x10FFFF ||
            (cp >= 0xD800 && cp <= 0xDFFF))
                return 0;
        return n;
}

enum bridge_refusal bridge_format_check_value(const void *payload, size_t len)
{
        const unsigned char *p = payload;

        if (len > BRIDGE_SET_PAYLOAD_MAX)
                return BRIDGE_REFUSE_TOO_LONG;
        for (size_t i = 0; i < len;) {
                size_t n = utf8_sequence(p + i, len - i);

                if (n == 0)
                        return BRIDGE_REFUSE_NOT_UTF8;
                if (p[i] == 0)
                        return BRIDGE_REFUSE_BAD_VALUE;
                i += n;
        }
        return BRIDGE_REFUSE_NONE;
}

const char *bridge_format_refusal(enum bridge_refusal r)
{
        return (unsigned)r < BRIDGE_REFUSE_COUNT ? refusal_text[r] : "refused";
}

/* ---- JSON (the toolkit's writer, svc/json.h) ---------------------------------------------- */

int bridge_format_error(char *buf, size_t size, const char *name, enum bridge_refusal r,
                        int err, const char *detail)
{
        struct json_buf j;

        json_buf_begin(&j, buf, size);
        json_buf_str(&j, "name", name);
        json_buf_str(&j, "code", (unsigned)r < BRIDGE_REFUSE_COUNT ? refusal_code[r] : "?");
        json_buf_str(&j, "error", bridge_format_refusal(r));
        if (detail)
                json_buf_str(&j, "detail", detail);
        else if (err < 0)
                json_buf_str(&j, "detail", sl_strerror(err));
        return json_buf_end(&j);
}

static const char *type_name(int type)
{
        switch (type) {
        case SL_VAR_LONG:
                return "long";
        case SL_VAR_DOUBLE:
                return "double";
        default:
                return "string";
        }
}

int bridge_format_meta(char *buf, size_t size, const struct sl_var_info *info,
                       const struct sl_meta *meta, const char *link_name)
{
        struct json_buf j;

        json_buf_begin(&j, buf, size);
        json_buf_bool(&j, "valid", meta->flags & SL_FLAG_VALID);
        json_buf_bool(&j, "stale", meta->flags & SL_FLAG_STALE);
        json_buf_u64(&j, "age_ms", meta->age_ns / NS_PER_MS);
        json_buf_u64(&j, "seq", meta->sequence);
        json_buf_u64(&j, "time_ns", meta->real_ns);
        json_buf_str(&j, "direction", info->direction == SL_DIR_OUT ? "out" : "in");
        json_buf_str(&j, "type", type_name(info->type));
        json_buf_str(&j, "link", link_name);
        json_buf_str(&j, "peer", info->peer);
        json_buf_bool(&j, "repaired", meta->flags & SL_FLAG_REPAIRED);
        return json_buf_end(&j);
}
