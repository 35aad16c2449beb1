/*
 * The JSON writer (see json.h for the escaping rule).
 */
#include "svc/json.h"

#include <errno.h>
#include <inttypes.h>
#include <string.h>

#define JSON_U64_MAX_TEXT       24      /* "18446744073709551615" and a NUL */
#define JSON_ESCAPE_LEN         6       /* "\u00XX" */
#define UTF8_CONT(b)            (((b) & 0xC0u) == 0x80u)

/*
 * The length of the well-formed UTF-8 sequence of a non-ASCII lead byte at S (LEN bytes left),
 * or 0 when it is not one (RFC 3629 table 2: the second byte's range excludes overlong forms,
 * surrogates and code points above U+10FFFF).
 */
static size_t utf8_sequence(const unsigned char *s, size_t len)
{
        unsigned char lo = 0x80, hi = 0xBF;
        size_t n;

        if (s[0] >= 0xC2 && s[0] <= 0xDF)
                n = 2;
        else if (s[0] >= 0xE0 && s[0] <= 0xEF)
                n = 3;
        else if (s[0] >= 0xF0 && s[0] <= 0xF4)
                n = 4;
        else
                return 0;               /* 0x80..0xC1 (continuation, overlong lead), 0xF5.. */
        if (s[0] == 0xE0)
                lo = 0xA0;              /* overlong below U+0800 */
        else if (s[0] == 0xED)
                hi = 0x9F;              /* U+D800..U+DFFF, the surrogates */
        else if (s[0] == 0xF0)
                lo = 0x90;              /* overlong below U+10000 */
        else if (s[0] == 0xF4)
                hi = 0x8F;              /* above U+10FFFF */
        if (len < n || s[1] < lo || s[1] > hi)
                return 0;
        for (size_t i = 2; i < n; i++)
                if (!UTF8_CONT(s[i]))
                        return 0;
        return n;
}

void json_quote(json_put_fn *put, void *arg, const char *s, size_t len)
{
        static const char hex[] = "0123456789abcdef";
        const unsigned char *p = (const unsigned char *)s;
        size_t i = 0, run = 0;          /* bytes from i - run on pass through unchanged */

        put(arg, "\"", 1);
        while (i < len) {
                unsigned char ch = p[i];
                char esc[JSON_ESCAPE_LEN] = { '\\', 'u', '0', '0', hex[ch >> 4], hex[ch & 0xf] };
                size_t n = 0, k;

                if (ch >= 0x20 && ch < 0x7f && ch != '"' && ch != '\\') {
                        run++;
                        i++;
                        continue;
                }
                if (ch >= 0x80 && (k = utf8_sequence(p + i, len - i)) > 0) {
                        run += k;
                        i += k;
                        continue;
                }
                if (run)
                        put(arg, s + i - run, run);
                run = 0;
                switch (ch) {
                case '"':
                case '\\':
                        esc[1] = (char)ch;
                        n = 2;
                        break;
                case '\n':
                        esc[1] = 'n';
                        n = 2;
                        break;
                case '\r':
                        esc[1] = 'r';
                        n = 2;
                        break;
                case '\t':
                        esc[1] = 't';
                        n = 2;
                        break;
                default:                /* other controls, DEL, bytes that are not UTF-8 */
                        n = JSON_ESCAPE_LEN;
                        break;
                }
                put(arg, esc, n);
                i++;
        }
        if (run)
                put(arg, s + i - run, run);
        put(arg, "\"", 1);
}

/* ---- FILE ---- */

static void file_put(void *arg, const char *s, size_t n)
{
        fwrite(s, 1, n, arg);
}

void json_string(FILE *f, const char *s)
{
        json_quote(file_put, f, s, strlen(s));
}

void json_key(FILE *f, int first, const char *key)
{
        if (!first)
                fputc(',', f);
        json_string(f, key);
        fputc(':', f);
}

void json_member_string(FILE *f, int first, const char *key, const char *value)
{
        json_key(f, first, key);
        json_string(f, value);
}

void json_member_u64(FILE *f, int first, const char *key, uint64_t value)
{
        json_key(f, first, key);
        fprintf(f, "%" PRIu64, value);
}

void json_member_bool(FILE *f, int first, const char *key, int value)
{
        json_key(f, first, key);
        fputs(value ? "true" : "false", f);
}

/* ---- buffer ---- */

void json_buf_raw(struct json_buf *j, const char *s, size_t n)
{
        if (j->overflow || j->len + n >= j->size) {
                j->overflow = true;
                return;
        }
        memcpy(j->buf + j->len, s, n);
        j->len += n;
        j->buf[j->len] = '\0';
}

static void buf_put(void *arg, const char *s, size_t n)
{
        json_buf_raw(arg, s, n);
}

void json_buf_quoted(struct json_buf *j, const char *s, size_t len)
{
        json_quote(buf_put, j, s, len);
}

void json_buf_key(struct json_buf *j, const char *key)
{
        if (j->need_comma)
                json_buf_raw(j, ",", 1);
        j->need_comma = true;
        json_buf_quoted(j, key, strlen(key));
        json_buf_raw(j, ":", 1);
}

void json_buf_begin(struct json_buf *j, char *buf, size_t size)
{
        *j = (struct json_buf){ .buf = buf, .size = size };
        if (size)
                buf[0] = '\0';
        json_buf_raw(j, "{", 1);
}

void json_buf_str(struct json_buf *j, const char *key, const char *value)
{
        json_buf_key(j, key);
        json_buf_quoted(j, value, strlen(value));
}

void json_buf_u64(struct json_buf *j, const char *key, uint64_t value)
{
        char num[JSON_U64_MAX_TEXT];

        json_buf_key(j, key);
        json_buf_raw(j, num, (size_t)snprintf(num, sizeof(num), "%" PRIu64, value));
}

void json_buf_bool(struct json_buf *j, const char *key, bool value)
{
        json_buf_key(j, key);
        json_buf_raw(j, value ? "true" : "false", value ? strlen("true") : strlen("false"));
}

int json_buf_end(struct json_buf *j)
{
        json_buf_raw(j, "}", 1);
        return j->overflow ? -ENOBUFS : (int)j->len;
}
