/*
 * Wire builders for tests: SharedLink frames and CIRCE packets written by hand, from
 * PROTOCOLS.md (§1.1, §1.3 and §2.1), never through the codecs under test, so that a codec bug
 * cannot hide behind its own encoder. Plain C, no cmocka (benchmarks use it too).
 *
 * A buffer too small for what a test builds is a bug in the test, not an input: the builders
 * then print what overflowed and abort, so it can neither pass nor corrupt memory silently.
 */
#pragma once

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* ---- SharedLink (PROTOCOLS.md §1) --------------------------------------------------------- */

/* The 8-bit sum of p[0 .. n): the checksum of a frame whose bytes ':' .. 'C' these are. */
unsigned wire_slp_sum(const char *p, size_t n);

/* "[" text "|C" hh "]" (+ CR LF when crlf) into out; text starts at the ':' (any header, for
 * tests of bad ones). Returns the length (out is NUL-terminated). */
size_t wire_slp_raw(char *out, size_t size, const char *text, bool crlf);

/* "[:" dst src "|" body "|C" hh "]" (+ CR LF when crlf) into out; the length. */
size_t wire_slp_frame(char *out, size_t size, char dst, char src, const char *body, bool crlf);

/* Appends "|C" hh "]" to the frame buf[0 .. n) (buf[0] is the '['); returns the new length. */
size_t wire_slp_close(char *buf, size_t size, size_t n);

/* ---- CIRCE (PROTOCOLS.md §2.1) ---------------------------------------------------------- */

#define WIRE_CIRCE_STX 0x02
#define WIRE_CIRCE_ETX 0x03
#define WIRE_CIRCE_TAB 0x09

enum wire_cs {
        WIRE_CS_NONE,   /* no checksum: the body ends with TAB */
        WIRE_CS_UPPER,  /* the right checksum, uppercase (what we send) */
        WIRE_CS_LOWER,  /* the right checksum, lowercase (accepted) */
        WIRE_CS_WRONG,  /* the right checksum + 1 */
};

/* The sum of p[0 .. n) mod 256: a packet's checksum when p runs from STX through the last TAB. */
unsigned wire_circe_sum(const uint8_t *p, size_t n);

/* STX body [CC] ETX into out; body is "op TAB pid:value TAB ..." (body_len bytes, any bytes).
 * Returns the length. */
size_t wire_circe_packet(uint8_t *out, size_t size, const char *body, size_t body_len,
                         enum wire_cs cs);

/* Like wire_circe_packet on a NUL-terminated body. */
size_t wire_circe_str(uint8_t *out, size_t size, const char *body, enum wire_cs cs);

/* Like wire_circe_packet on a NUL-terminated body in which '|' stands for TAB (readable
 * vectors: "52|015:E1E1E1|"). */
size_t wire_circe_text(uint8_t *out, size_t size, const char *text, enum wire_cs cs);

/* p[0 .. n) with STX, ETX and TAB spelled <STX>, <ETX>, <TAB>, for failure messages; out is
 * NUL-terminated and truncated to size. */
void wire_circe_show(const uint8_t *p, size_t n, char *out, size_t size);
