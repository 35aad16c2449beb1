/*
 * JSON output helpers (json.h).
 */
#include "cli/json.h"

#include <inttypes.h>

void json_string(FILE *f, const char *s)
{
        fputc('"', f);
        for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
                switch (*p) {
                case '"':
                        fputs("\\\"", f);
                        break;
                case '\\':
                        fputs("\\\\", f);
                        break;
                case '\n':
                        fputs("\\n", f);
                        break;
                case '\r':
                        fputs("\\r", f);
                        break;
                case '\t':
                        fputs("\\t", f);
                        break;
                default:
                        if (*p < 0x20 || *p >= 0x7f)
                                fprintf(f, "\\u%04x", *p);
                        else
                                fputc(*p, f);
                }
        }
        fputc('"', f);
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
