/*
 * Wire builders for tests (see wire.h): checksums by the rules of PROTOCOLS.md, not the codecs'.
 */
#include "common/wire.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define WIRE_SUM_MASK   0xffu           /* both checksums are 8-bit sums */
#define WIRE_CC_LEN     2               /* two hex digits */
#define WIRE_SLP_TAIL   "|C"            /* the checksum field indicator, counted in the sum */
#define WIRE_SLP_TAIL_LEN 2
#define WIRE_SLP_TEXT_MAX 4200          /* above the largest max_frame (4096) */

static void overflow(const char *what, size_t need, size_t size)
{
        fprintf(stderr, "wire: %s needs %zu bytes, the test gave %zu\n", what, need, size);
        abort();
}

unsigned wire_slp_sum(const char *p, size_t n)
{
        unsigned sum = 0;

        for (size_t i = 0; i < n; i++)
                sum += (unsigned char)p[i];
        return sum & WIRE_SUM_MASK;
}

size_t wire_slp_raw(char *out, size_t size, const char *text, bool crlf)
{
        /* '[' is not in the sum (§1.3): ':' .. 'C' is the text and the "|C" after it. */
        unsigned sum = (wire_slp_sum(text, strlen(text)) +
                        wire_slp_sum(WIRE_SLP_TAIL, WIRE_SLP_TAIL_LEN)) & WIRE_SUM_MASK;
        int n = snprintf(out, size, "[%s" WIRE_SLP_TAIL "%02X]%s", text, sum, crlf ? "\r\n" : "");

        if (n < 0 || (size_t)n >= size)
                overflow("a SharedLink frame", n < 0 ? 0 : (size_t)n + 1, size);
        return (size_t)n;
}

size_t wire_slp_frame(char *out, size_t size, char dst, char src, const char *body, bool crlf)
{
        char text[WIRE_SLP_TEXT_MAX];
        int n = snprintf(text, sizeof(text), ":%c%c|%s", dst, src, body);

        if (n < 0 || (size_t)n >= sizeof(text))
                overflow("a SharedLink body", n < 0 ? 0 : (size_t)n + 1, sizeof(text));
        return wire_slp_raw(out, size, text, crlf);
}

size_t wire_slp_close(char *buf, size_t size, size_t n)
{
        /* the tail, the digits, ']' and snprintf's NUL */
        size_t need = n + WIRE_SLP_TAIL_LEN + WIRE_CC_LEN + 2;
        unsigned sum;

        if (n < 1 || need > size)
                overflow("closing a SharedLink frame", need, size);
        memcpy(buf + n, WIRE_SLP_TAIL, WIRE_SLP_TAIL_LEN);
        n += WIRE_SLP_TAIL_LEN;
        sum = wire_slp_sum(buf + 1, n - 1);
        n += (size_t)snprintf(buf + n, size - n, "%02X]", sum);
        return n;
}

unsigned wire_circe_sum(const uint8_t *p, size_t n)
{
        unsigned sum = 0;

        for (size_t i = 0; i < n; i++)
                sum += p[i];
        return sum & WIRE_SUM_MASK;
}

/* Appends [CC] ETX to the packet out[0 .. n) (STX and body); the length. */
static size_t circe_finish(uint8_t *out, size_t size, size_t n, enum wire_cs cs)
{
        if (n + WIRE_CC_LEN + 1 > size)
                overflow("a CIRCE packet", n + WIRE_CC_LEN + 1, size);
        if (cs != WIRE_CS_NONE) {
                unsigned sum = (wire_circe_sum(out, n) + (cs == WIRE_CS_WRONG)) & WIRE_SUM_MASK;
                char cc[WIRE_CC_LEN + 1];

                snprintf(cc, sizeof(cc), cs == WIRE_CS_LOWER ? "%02x" : "%02X", sum);
                memcpy(out + n, cc, WIRE_CC_LEN);
                n += WIRE_CC_LEN;
        }
        out[n++] = WIRE_CIRCE_ETX;
        return n;
}

size_t wire_circe_packet(uint8_t *out, size_t size, const char *body, size_t body_len,
                         enum wire_cs cs)
{
        if (body_len + 1 > size)
                overflow("a CIRCE packet", body_len + 1, size);
        out[0] = WIRE_CIRCE_STX;
        memcpy(out + 1, body, body_len);
        return circe_finish(out, size, body_len + 1, cs);
}

size_t wire_circe_str(uint8_t *out, size_t size, const char *body, enum wire_cs cs)
{
        return wire_circe_packet(out, size, body, strlen(body), cs);
}

size_t wire_circe_text(uint8_t *out, size_t size, const char *text, enum wire_cs cs)
{
        size_t len = strlen(text);

        if (len + 1 > size)
                overflow("a CIRCE packet", len + 1, size);
        out[0] = WIRE_CIRCE_STX;
        for (size_t i = 0; i < len; i++)
                out[1 + i] = text[i] == '|' ? WIRE_CIRCE_TAB : (uint8_t)text[i];
        return circe_finish(out, size, len + 1, cs);
}

void wire_circe_show(const uint8_t *p, size_t n, char *out, size_t size)
{
        size_t o = 0;

        if (size == 0)
                return;
        for (size_t i = 0; i < n; i++) {
                const char *w = p[i] == WIRE_CIRCE_STX ? "<STX>" : p[i] == WIRE_CIRCE_ETX ?
                                "<ETX>" : p[i] == WIRE_CIRCE_TAB ? "<TAB>" : NULL;
                size_t wl = w ? strlen(w) : 1;

                if (o + wl >= size)
                        break;
                if (w)
                        memcpy(out + o, w, wl);
                else
                        out[o] = (char)p[i];
                o += wl;
        }
        out[o] = '\0';
}
