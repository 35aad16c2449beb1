/*
 * The one JSON writer of the project (slctl --json, the MQTT bridge's payloads, and what the next
 * daemons publish). Strings are escaped by one rule, decided here once:
 *
 *   - '"' and '\' as \" and \\; LF, CR and TAB as \n, \r and \t;
 *   - every other byte below 0x20, and DEL (0x7f), as \u00XX (lower-case hex);
 *   - well-formed UTF-8 (RFC 3629: no overlong forms, no surrogates, nothing above U+10FFFF)
 *     passes through unchanged, so "é" stays two bytes of UTF-8, as JSON consumers expect;
 *   - every byte that is not part of well-formed UTF-8 is written as \u00XX, XX the byte.
 *
 * So any byte sequence (names and values come from shared memory, payloads from the network)
 * gives valid JSON, nothing is lost, and an escape \u0080..\u00ff in our output always stands
 * for one raw byte that was not UTF-8 (a real U+0080..U+00FF passes through as UTF-8 and is
 * never escaped).
 *
 * Two sinks: a FILE (slctl writes to stdout as it goes) and a caller's buffer (a payload that is
 * published whole; overflow is sticky and reported at the end).
 */
#ifndef SHAREDLINK_SVC_JSON_H
#define SHAREDLINK_SVC_JSON_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* Where escaped text goes: N bytes of S. */
typedef void json_put_fn(void *arg, const char *s, size_t n);

/* Writes LEN bytes of S as a JSON string (quotes included) through PUT. */
void json_quote(json_put_fn *put, void *arg, const char *s, size_t len);

/* ---- a FILE, written as it goes ---- */

/* Writes s as a JSON string. */
void json_string(FILE *f, const char *s);

/* Writes ,"key": (without the comma when first is set). */
void json_key(FILE *f, int first, const char *key);

/* Writes "key":"value" as json_key + json_string. */
void json_member_string(FILE *f, int first, const char *key, const char *value);

/* Writes "key":number. */
void json_member_u64(FILE *f, int first, const char *key, uint64_t value);

/* Writes "key":true|false. */
void json_member_bool(FILE *f, int first, const char *key, int value);

/* ---- one object in a caller's buffer ---- */

struct json_buf {
        char *buf;
        size_t size, len;
        bool overflow, need_comma;
};

/* Begins an object into buf (size bytes, NUL-terminated as it grows). */
void json_buf_begin(struct json_buf *j, char *buf, size_t size);
void json_buf_str(struct json_buf *j, const char *key, const char *value);
void json_buf_u64(struct json_buf *j, const char *key, uint64_t value);
void json_buf_bool(struct json_buf *j, const char *key, bool value);
/* Adds ,"key": and leaves the value to the caller (json_buf_raw): nested objects, arrays. */
void json_buf_key(struct json_buf *j, const char *key);
/* Appends LEN bytes as they are (JSON the caller made: punctuation, numbers, literals). */
void json_buf_raw(struct json_buf *j, const char *s, size_t len);
/* Appends a JSON string (escaped) with no key: an array item. */
void json_buf_quoted(struct json_buf *j, const char *s, size_t len);
/* Ends the object: its length, or -ENOBUFS when it did not fit. */
int json_buf_end(struct json_buf *j);

#endif
