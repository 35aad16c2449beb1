/*
 * Recordings: escape, format, parse (see recording.h and docs/recording.md).
 */
#include "proto/recording.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#define REC_US_PER_S            1000000ull
#define REC_DROPPED_DIGITS      20      /* a uint64_t in decimal */

/* The messages spell these limits out. */
_Static_assert(REC_PIECE_MAX == 1000 && REC_CHUNK_MAX == 8192, "update the messages");

static const char rec_hex[] = "0123456789abcdef";

/* ---------------------------------------------------------------------------------------------
 * Writing */

size_t rec_escape(char *out, const uint8_t *data, size_t len)
{
        size_t n = 0;

        for (size_t i = 0; i < len; i++) {
                uint8_t b = data[i];

                switch (b) {
                case ' ':
                        out[n++] = '\\';
                        out[n++] = 's';
                        continue;
                case '\\':
                        out[n++] = '\\';
                        out[n++] = '\\';
                        continue;
                case '\r':
                        out[n++] = '\\';
                        out[n++] = 'r';
                        continue;
                case '\n':
                        out[n++] = '\\';
                        out[n++] = 'n';
                        continue;
                case '\t':
                        out[n++] = '\\';
                        out[n++] = 't';
                        continue;
                default:
                        break;
                }
                if (b >= 0x21 && b <= 0x7e) {
                        out[n++] = (char)b;
                        continue;
                }
                out[n++] = '\\';
                out[n++] = 'x';
                out[n++] = rec_hex[b >> 4];
                out[n++] = rec_hex[b & 0xf];
        }
        out[n] = '\0';
        return n;
}

size_t rec_format_chunk(char *out, uint64_t t_us, enum rec_dir dir, bool more,
                        const uint8_t *data, size_t len, size_t *ret_used)
{
        size_t used = len < REC_PIECE_MAX ? len : REC_PIECE_MAX;
        int head;

        head = snprintf(out, REC_LINE_MAX + 1, "%llu.%06llu %c%s ",
                        (unsigned long long)(t_us / REC_US_PER_S),
                        (unsigned long long)(t_us % REC_US_PER_S),
                        dir == REC_DIR_IN ? '<' : '>', more ? "+" : "");
        *ret_used = used;
        return (size_t)head + rec_escape(out + head, data, used);
}

/* ---------------------------------------------------------------------------------------------
 * Reading one line */

static int rec_hex_digit(char c)
{
        if (c >= '0' && c <= '9')
                return c - '0';
        if (c >= 'a' && c <= 'f')
                return c - 'a' + 10;
        return -1;
}

/* "seconds.micros" at line[*pos..len); advances *pos. */
static const char *rec_parse_time(const char *line, size_t len, size_t *pos, uint64_t *ret_us)
{
        size_t p = *pos, start = p;
        uint64_t s = 0, us = 0;

        while (p < len && line[p] >= '0' && line[p] <= '9') {
                if (p - start == REC_SECONDS_DIGITS)
                        return "time: too many digits before the point";
                s = s * 10 + (uint64_t)(line[p] - '0');
                p++;
        }
        if (p == start)
                return "time: SECONDS.MICROS expected";
        if (p - start > 1 && line[start] == '0')
                return "time: leading zero";
        if (p == len || line[p] != '.')
                return "time: '.' and 6 digits of microseconds expected";
        p++;
        for (unsigned i = 0; i < REC_MICROS_DIGITS; i++, p++) {
                if (p == len || line[p] < '0' || line[p] > '9')
                        return "time: 6 digits of microseconds expected";
                us = us * 10 + (uint64_t)(line[p] - '0');
        }
        *pos = p;
        *ret_us = s * REC_US_PER_S + us;
        return NULL;
}

/* The escaped bytes at line[pos..len) into ret->data. */
static const char *rec_parse_bytes(const char *line, size_t len, size_t pos,
                                   struct rec_line *ret)
{
        size_t n = 0;

        if (pos == len)
                return "missing bytes";
        while (pos < len) {
                unsigned char c = (unsigned char)line[pos++];
                int hi, lo;

                if (n == REC_PIECE_MAX)
                        return "more than 1000 bytes on one line";
                if (c == ' ')
                        return "a space in the bytes (write it \\s)";
                if (c < 0x21 || c > 0x7e)
                        return "a control or non-ASCII byte in the line (write it \\xHH)";
                if (c != '\\') {
                        ret->data[n++] = c;
                        continue;
                }
                if (pos == len)
                        return "backslash at the end of the line";
                switch (line[pos++]) {
                case 's':
                        ret->data[n++] = ' ';
                        continue;
                case '\\':
                        ret->data[n++] = '\\';
                        continue;
                case 'r':
                        ret->data[n++] = '\r';
                        continue;
                case 'n':
                        ret->data[n++] = '\n';
                        continue;
                case 't':
                        ret->data[n++] = '\t';
                        continue;
                case 'x':
                        break;
                default:
                        return "bad escape (\\s \\\\ \\r \\n \\t \\xHH)";
                }
                hi = pos < len ? rec_hex_digit(line[pos]) : -1;
                lo = pos + 1 < len ? rec_hex_digit(line[pos + 1]) : -1;
                if (hi < 0 || lo < 0)
                        return "\\x needs two lower-case hex digits";
                ret->data[n++] = (uint8_t)(hi << 4 | lo);
                pos += 2;
        }
        ret->len = n;
        return NULL;
}

static const char *rec_parse_comment(const char *line, size_t len)
{
        for (size_t i = 1; i < len; i++) {
                unsigned char c = (unsigned char)line[i];

                if (c != '\t' && (c < 0x20 || c > 0x7e))
                        return "a control or non-ASCII byte in a comment";
        }
        return NULL;
}

int rec_parse_line(const char *line, size_t len, struct rec_line *ret, const char **ret_why)
{
        const char *why;
        size_t pos = 0;

        memset(ret, 0, offsetof(struct rec_line, data));
        if (len > REC_LINE_MAX) {
                why = "line too long";
                goto bad;
        }
        if (memchr(line, '\0', len)) {
                why = "NUL byte in the line";
                goto bad;
        }
        if (len > 0 && line[0] == '#') {
                why = rec_parse_comment(line, len);
                if (why)
                        goto bad;
                ret->comment = true;
                return 0;
        }
        if (len == 0) {
                why = "empty line";
                goto bad;
        }
        why = rec_parse_time(line, len, &pos, &ret->t_us);
        if (why)
                goto bad;
        if (pos == len || line[pos] != ' ') {
                why = "missing direction";
                goto bad;
        }
        pos++;
        if (pos < len && (line[pos] == '<' || line[pos] == '>')) {
                ret->dir = line[pos] == '<' ? REC_DIR_IN : REC_DIR_OUT;
                pos++;
                if (pos < len && line[pos] == '+') {
                        ret->more = true;
                        pos++;
                }
        } else {
                why = pos == len ? "missing direction" : "unknown direction (< or > expected)";
                goto bad;
        }
        if (pos < len && line[pos] != ' ') {
                why = "unknown direction (< or > expected)";
                goto bad;
        }
        if (pos == len) {
                why = "missing bytes";
                goto bad;
        }
        why = rec_parse_bytes(line, len, pos + 1, ret);
        if (why)
                goto bad;
        return 0;
bad:
        *ret_why = why;
        return -EINVAL;
}

/* ---------------------------------------------------------------------------------------------
 * Reading a recording */

void rec_reader_init(struct rec_reader *r)
{
        memset(r, 0, offsetof(struct rec_reader, chunk));
        r->why[0] = '\0';
}

static int rec_fail(struct rec_reader *r, const char *why)
{
        snprintf(r->why, sizeof(r->why), "%s", why);
        return -EINVAL;
}

/* "# transport: X" before the first chunk: X kept, when it fits (the first one counts). */
static void rec_note_transport(struct rec_reader *r, const char *line, size_t len)
{
        size_t plen = strlen(REC_TRANSPORT_PREFIX);

        if (r->chunk_seen || r->transport[0] || len <= plen || len - plen >= REC_META_MAX ||
            memcmp(line, REC_TRANSPORT_PREFIX, plen) != 0)
                return;
        memcpy(r->transport, line + plen, len - plen);
        r->transport[len - plen] = '\0';
}

/* "# dropped N chunks": adds N to r->dropped; "# transport: X" is kept (other comments are
 * metadata only). */
static void rec_note_comment(struct rec_reader *r, const char *line, size_t len)
{
        size_t plen = strlen(REC_DROPPED_PREFIX), p = plen;
        uint64_t n = 0;

        rec_note_transport(r, line, len);
        if (len <= plen || memcmp(line, REC_DROPPED_PREFIX, plen) != 0)
                return;
        while (p < len && p - plen < REC_DROPPED_DIGITS && line[p] >= '0' && line[p] <= '9')
                n = n * 10 + (uint64_t)(line[p++] - '0');
        if (p > plen)
                r->dropped += n;
}

int rec_reader_line(struct rec_reader *r, const char *line, size_t len)
{
        struct rec_line lbuf;           /* about 1 KiB: a piece and its fields */
        struct rec_line *l = &lbuf;
        const char *why;

        r->line_no++;
        if (!r->header_seen) {
                if (len != strlen(REC_HEADER) || memcmp(line, REC_HEADER, len) != 0)
                        return rec_fail(r, "not a recording: the first line must be \""
                                        REC_HEADER "\"");
                r->header_seen = true;
                return 0;
        }
        if (rec_parse_line(line, len, l, &why) < 0)
                return rec_fail(r, why);
        if (l->comment) {
                if (r->continuing)
                        return rec_fail(r, "a comment inside a chunk continued with '+'");
                rec_note_comment(r, line, len);
                return 0;
        }
        r->chunk_seen = true;
        if (l->t_us < r->last_t_us)
                return rec_fail(r, "time goes backwards");
        if (r->continuing) {
                if (l->dir != r->dir || l->t_us != r->last_t_us)
                        return rec_fail(r, "a continued chunk must go on with the same time "
                                        "and direction");
        } else {
                r->len = 0;
                r->dir = l->dir;
        }
        if (r->len + l->len > REC_CHUNK_MAX)
                return rec_fail(r, "chunk longer than 8192 bytes");
        memcpy(r->chunk + r->len, l->data, l->len);
        r->len += l->len;
        r->last_t_us = l->t_us;
        r->continuing = l->more;
        return l->more ? 0 : 1;
}

bool rec_reader_datagram(const struct rec_reader *r)
{
        return strcmp(r->transport, REC_TRANSPORT_DATAGRAM) == 0;
}

int rec_reader_end(struct rec_reader *r)
{
        if (!r->header_seen)
                return rec_fail(r, "empty file: no \"" REC_HEADER "\" line");
        if (r->continuing)
                return rec_fail(r, "the recording ends inside a chunk continued with '+'");
        return 0;
}

int rec_parse_text(struct rec_reader *r, const char *text, size_t len,
                   int (*fn)(void *arg, const struct rec_reader *r), void *arg)
{
        size_t pos = 0;

        while (pos < len) {
                const char *nl = memchr(text + pos, '\n', len - pos);
                size_t ll = nl ? (size_t)(nl - (text + pos)) : len - pos;
                int k;

                if (ll > REC_LINE_MAX) {
                        r->line_no++;
                        return rec_fail(r, "line too long");
                }
                if (!nl) {
                        r->line_no++;
                        return rec_fail(r, "the last line has no newline (file cut short?)");
                }
                k = rec_reader_line(r, text + pos, ll);
                if (k < 0)
                        return k;
                if (k > 0 && fn) {
                        int s = fn(arg, r);

                        if (s < 0)
                                return s;
                }
                pos += ll + 1;
        }
        return rec_reader_end(r);
}
