/*
 * The little JSON slctl writes: strings escaped so that any byte sequence (names and values come
 * from shared memory) still gives valid JSON, and unsigned numbers.
 */
#ifndef SLCTL_JSON_H
#define SLCTL_JSON_H

#include <stdint.h>
#include <stdio.h>

/* Writes s as a JSON string: quotes, \" \\ \n \r \t, other bytes below 0x20 and every byte from
 * 0x7f up as \u00XX (so invalid UTF-8 cannot make the output invalid). */
void json_string(FILE *f, const char *s);

/* Writes ,"key": (without the comma when first is set). */
void json_key(FILE *f, int first, const char *key);

/* Writes "key":"value" as json_key + json_string. */
void json_member_string(FILE *f, int first, const char *key, const char *value);

/* Writes "key":number. */
void json_member_u64(FILE *f, int first, const char *key, uint64_t value);

/* Writes "key":true|false. */
void json_member_bool(FILE *f, int first, const char *key, int value);

#endif
