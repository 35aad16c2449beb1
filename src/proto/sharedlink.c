/*
 * SharedLink codec: PROTOCOLS.md section 1, byte for byte.
 *
 * Grammar (PROTOCOLS.md 1.1, 1.3):
 *
 *      frame    = "[" ":" dst src body "]" [CR] [LF]
 *      dst, src = "A" .. "P"                   ; destination first
 *      body     = 1*( "|" field ) "|" checksum
 *      field    = type value                   ; type: "A" .. "Z"
 *      value    = *( %x20-7E except "|" "[" "]" )
 *      checksum = "C" 1*2HEX                   ; (':' + ... + 'C') mod 256; '[' excluded
 *
 * We emit exactly two uppercase hex digits; we accept lowercase and a single digit (Field
 * practice: one public implementation forgets the zero padding).
 *
 * The stream decoder has two states, told apart by d->len (bytes of the frame collected so far):
 *
 *      IDLE   (len == 0)   Between frames. '[' starts a frame (-> FRAME). CR and LF are whitespace
 *                          in any order. Every other byte is noise: counted, and reported as one
 *                          NOISE result per run, when the next '[' arrives, at slp_decoder_end(),
 *                          or every SLP_NOISE_RUN_MAX bytes so a garbage-only link still shows.
 *      FRAME  (len >= 1)   Copying the frame into d->buf, starting with its '['.
 *                          ']'  -> validate the whole frame -> FRAME or REJECT result; -> IDLE.
 *                          '['  -> RESYNC result for the partial frame; the new '[' starts a new
 *                                  frame (stay in FRAME).
 *                          a byte that would make the frame longer than max_frame -> OVERLONG
 *                                  result; -> IDLE, so the rest of it is noise until the next '['.
 *
 * Validation of a complete frame, in this order (the first failure is the reason): the last field
 * is a checksum field -> its syntax -> its value -> header ":" dst src "|" -> every byte printable
 * -> every field (type letter, N/L value, no early 'C') -> at least one field. The checksum goes
 * first so that line noise shows up as "bad checksum", not as whatever it happened to break.
 *
 * Speed (tests/bench/bench_codec.c): a frame is found with memchr() and copied with memcpy();
 * then one pass over it, eight bytes at a time, computes the checksum, checks the byte range and
 * marks every '|' in a bitmap; the fields are cut at the bitmap's set bits. No per-byte branch
 * or call anywhere on the path of a valid frame.
 */
#include <errno.h>
#include <limits.h>
#include <string.h>

#include "proto/sharedlink.h"

#define SL_HEADER_LEN   4       /* ":" dst src "|" in the body, "[:AB" on the wire */
#define SL_TRAILER_LEN  5       /* "|C" hh "]" */

_Static_assert(SL_HEADER_LEN + SL_TRAILER_LEN == SLP_FRAME_OVERHEAD, "frame overhead");
_Static_assert(SLP_FRAME_MIN <= SLP_FRAME_DEFAULT && SLP_FRAME_DEFAULT <= SLP_FRAME_MAX,
               "frame limits out of order");
_Static_assert(SLP_FRAME_MAX <= UINT16_MAX, "slp_field.len is 16 bits");

static const char sl_hex_upper[] = "0123456789ABCDEF";

static bool is_type_letter(char c)
{
        return c >= 'A' && c <= 'Z';
}

static int hex_value(char c)
{
        if (c >= '0' && c <= '9')
                return c - '0';
        if (c >= 'A' && c <= 'F')
                return c - 'A' + 10;
        if (c >= 'a' && c <= 'f')
                return c - 'a' + 10;
        return -1;
}

const char *slp_address_text(char c)
{
        static const char texts[SLP_ADDR_COUNT][2] = {
                "A", "B", "C", "D", "E", "F", "G", "H", "I", "J", "K", "L", "M", "N", "O", "P",
        };

        return slp_address_valid(c) ? texts[slp_address_index(c)] : NULL;
}

enum slp_field_type slp_field_type_of(char letter)
{
        switch (letter) {
        case 'N': case 'D': case 'Q': case 'R': case 'T':
        case 'L': case 'P': case 'G': case 'E': case 'C':
                return (enum slp_field_type)letter;
        default:
                return SLP_FIELD_UNKNOWN;
        }
}

const char *slp_decode_reason_str(enum slp_decode_reason reason)
{
        switch (reason) {
        case SLP_REASON_NONE:                    return "none";
        case SLP_REASON_NOISE:                   return "noise";
        case SLP_REASON_RESYNC:                  return "resync";
        case SLP_REASON_OVERLONG:                return "overlong frame";
        case SLP_REASON_TRUNCATED:               return "truncated frame";
        case SLP_REASON_NO_CHECKSUM:             return "missing checksum";
        case SLP_REASON_BAD_CHECKSUM_SYNTAX:     return "malformed checksum";
        case SLP_REASON_BAD_CHECKSUM:            return "bad checksum";
        case SLP_REASON_BAD_HEADER:              return "bad header";
        case SLP_REASON_BAD_ADDRESS:             return "bad address";
        case SLP_REASON_BAD_FIELD:               return "bad field";
        case SLP_REASON_NO_FIELDS:               return "no fields";
        case SLP_REASON_UNKNOWN_FIELD:           return "unknown field type";
        case SLP_REASON_EMPTY_FIELD:             return "empty field";
        case SLP_REASON_COUNT:                   break;
        }
        return "unknown reason";
}

/* ---------------------------------------------------------------------------------------------
 * Decoder */

int slp_decoder_init(struct slp_decoder *d, size_t max_frame)
{
        if (max_frame == 0)
                max_frame = SLP_FRAME_DEFAULT;
        if (max_frame < SLP_FRAME_MIN || max_frame > SLP_FRAME_MAX)
                return -EINVAL;
        memset(&d->frame, 0, sizeof(d->frame));
        d->max_frame = max_frame;
        d->len = 0;
        d->noise = 0;
        return 0;
}

void slp_decoder_reset(struct slp_decoder *d)
{
        d->len = 0;
        d->noise = 0;
}

static void result_reject(struct slp_decode_result *r, enum slp_decode_reason reason, size_t bytes)
{
        r->kind = SLP_RESULT_REJECT;
        r->reason = reason;
        r->bytes = bytes;
        r->frame = NULL;
}

/*
 * N and L values: "?" (Pronto4: ask for the list) or decimal digits. Positions beyond
 * SLP_INDEX_MAX saturate: they are beyond any list, which the engine counts as a list mismatch
 * (Decision: the rest of the frame still applies), so they must not kill the frame here.
 */
static bool parse_index(const char *v, size_t len, uint32_t *ret_index)
{
        uint64_t k = 0;

        if (len == 1 && v[0] == '?') {
                *ret_index = SLP_INDEX_QUERY;
                return true;
        }
        if (len == 0)
                return false;
        for (size_t i = 0; i < len; i++) {
                if (v[i] < '0' || v[i] > '9')
                        return false;
                k = k * 10 + (uint64_t)(v[i] - '0');
                if (k > SLP_INDEX_MAX)
                        k = SLP_INDEX_MAX;
        }
        *ret_index = (uint32_t)k;
        return true;
}

/* Checksum field b[lp+1 .. m): "C" and one or two hex digits, whose value goes to *ret_want. */
static enum slp_decode_reason parse_checksum(const char *b, size_t m, size_t lp, unsigned *ret_want)
{
        const char *f = b + lp + 1;
        size_t flen = m - lp - 1;
        unsigned want = 0;

        if (flen == 0 || f[0] != 'C')
                return SLP_REASON_NO_CHECKSUM;
        if (flen < 2 || flen > SLP_CHECKSUM_FIELD_MAX)
                return SLP_REASON_BAD_CHECKSUM_SYNTAX;
        for (size_t i = 1; i < flen; i++) {
                int h = hex_value(f[i]);
                if (h < 0)
                        return SLP_REASON_BAD_CHECKSUM_SYNTAX;
                want = want * 16 + (unsigned)h;
        }
        *ret_want = want;
        return SLP_REASON_NONE;
}

/* Header ":" dst src "|"; b[lp] is the '|' before the checksum, so b[0 .. lp] is readable. */
static enum slp_decode_reason check_header(const char *b, size_t lp)
{
        if (b[0] != ':')
                return SLP_REASON_BAD_HEADER;
        for (size_t i = 1; i <= 2; i++)
                if (i >= lp || !slp_address_valid(b[i]))
                        return SLP_REASON_BAD_ADDRESS;
        if (b[3] != '|')
                return SLP_REASON_BAD_HEADER;
        return SLP_REASON_NONE;
}

/*
 * The hot loops work on eight bytes at a time in a 64-bit word ("SWAR"). The word tests below
 * are the classic bit tricks; swar_eq() is exact per byte, swar_lt() and swar_gt() are exact
 * only as a yes/no answer for the whole word, which is all they are used for.
 */
#define SWAR_ONES       0x0101010101010101ull
#define SWAR_HIGHS      0x8080808080808080ull
#define SWAR_LANES      0x00ff00ff00ff00ffull

/* The high bit of every byte of w equal to c, and nothing else. */
static uint64_t swar_eq(uint64_t w, unsigned char c)
{
        uint64_t t = w ^ (SWAR_ONES * c);

        /* (t & 0x7f) + 0x7f sets the high bit of every byte with a low bit set, without carry. */
        return ~(((t & ~SWAR_HIGHS) + ~SWAR_HIGHS) | t) & SWAR_HIGHS;
}

/* Nonzero if some byte of w is below k (k <= 0x80). */
static uint64_t swar_lt(uint64_t w, unsigned char k)
{
        return (w - SWAR_ONES * k) & ~w & SWAR_HIGHS;
}

/* Nonzero if some byte of w is above k (k < 0x80). */
static uint64_t swar_gt(uint64_t w, unsigned char k)
{
        return ((w + SWAR_ONES * (0x7fu - k)) | w) & SWAR_HIGHS;
}

/* The high bits of the eight bytes of m, as bits 0..7 (byte 0 -> bit 0). The multiplier moves
 * bit 8j + 7 to bit 56 + j; no two partial products meet, so nothing carries. */
static uint64_t swar_movemask(uint64_t m)
{
        return ((m >> 7) * 0x0102040810204080ull) >> 56;
}

/* Eight bytes from p, the byte at p[0] in the low bits whatever the machine's byte order. */
static uint64_t load_word(const char *p)
{
        uint64_t w;

        memcpy(&w, p, sizeof(w));
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
        w = __builtin_bswap64(w);
#endif
        return w;
}

/*
 * One pass over b[0 .. n): returns the checksum (sum mod 256), says whether every byte is
 * printable (0x20-0x7E), and marks every '|' in the bitmap bars (bit i%64 of bars[i/64]), so
 * that splitting the fields needs no second scan and no branch per byte. Each 64-byte block
 * builds its bitmap word in a register. Byte sums go to 16-bit lanes, reduced mod 256 after each
 * block (eight words add at most 8 * 255 to a lane, so no carry reaches the next lane).
 */
static unsigned scan_body(uint64_t *bars, const char *b, size_t n, bool *ret_printable)
{
        uint64_t even = 0, odd = 0, bad = 0, lanes;
        unsigned sum = 0, tail_bad = 0;

        for (size_t blk = 0; blk < n; blk += 64) {
                const char *p = b + blk;
                size_t len = n - blk < 64 ? n - blk : 64, j = 0;
                uint64_t bits = 0;

                for (; j + sizeof(uint64_t) <= len; j += sizeof(uint64_t)) {
                        uint64_t w = load_word(p + j);

                        even += w & SWAR_LANES;
                        odd += (w >> 8) & SWAR_LANES;
                        bad |= swar_lt(w, SLP_VALUE_BYTE_MIN) | swar_gt(w, SLP_VALUE_BYTE_MAX);
                        bits |= swar_movemask(swar_eq(w, '|')) << j;
                }
                for (; j < len; j++) {
                        unsigned char c = (unsigned char)p[j];

                        sum += c;
                        tail_bad |= c < SLP_VALUE_BYTE_MIN || c > SLP_VALUE_BYTE_MAX;
                        bits |= (uint64_t)(c == '|') << j;
                }
                even &= SWAR_LANES;
                odd &= SWAR_LANES;
                bars[blk / 64] = bits;
        }
        /* Four 16-bit lanes, each < 512: their total fits the top 16 bits of the product. */
        lanes = even + odd;
        sum += (unsigned)((lanes * 0x0001000100010001ull) >> 48);
        *ret_printable = bad == 0 && tail_bad == 0;
        return sum & 0xff;
}

/* Stores the field b[pos .. end) (type letter and value) in d->fields, or says why it is bad. */
static enum slp_decode_reason add_field(struct slp_decoder *d, const char *b, size_t pos,
                                        size_t end)
{
        struct slp_frame *f = &d->frame;
        struct slp_field *fl;

        if (end == pos) {
                /* Field practice: "N0||D1" is seen in the field; skip and count. */
                f->empty_fields++;
                return SLP_REASON_NONE;
        }
        /* The checksum is always the last field; one earlier is not a checksum. */
        if (!is_type_letter(b[pos]) || b[pos] == 'C')
                return SLP_REASON_BAD_FIELD;
        /* Cannot trigger: each stored field takes >= 2 bytes of a <= SLP_FRAME_MAX frame. */
        if (f->nfields >= SLP_FIELDS_MAX)
                return SLP_REASON_BAD_FIELD;
        fl = &d->fields[f->nfields];
        fl->letter = b[pos];
        fl->type = (uint8_t)slp_field_type_of(b[pos]);
        fl->value = b + pos + 1;
        fl->len = (uint16_t)(end - pos - 1);
        fl->index = 0;
        if (fl->type == SLP_FIELD_N || fl->type == SLP_FIELD_L) {
                if (!parse_index(fl->value, fl->len, &fl->index))
                        return SLP_REASON_BAD_FIELD;
        } else if (fl->type == SLP_FIELD_UNKNOWN) {
                /* Decision: unknown types are skipped by the engine, never fatal. */
                f->unknown_fields++;
        }
        f->nfields++;
        return SLP_REASON_NONE;
}

/* Splits b[SL_HEADER_LEN .. lp) into fields at the '|' marked in d->bars; b[lp] is the last. */
static enum slp_decode_reason split_fields(struct slp_decoder *d, const char *b, size_t lp)
{
        size_t pos = SL_HEADER_LEN;

        for (size_t w = 0; pos <= lp; w++) {
                uint64_t bits = d->bars[w];

                if (w == 0)
                        bits &= ~0ull << SL_HEADER_LEN;         /* the header's own '|' */
                for (; bits != 0 && pos <= lp; bits &= bits - 1) {
                        size_t end = w * 64 + (size_t)__builtin_ctzll(bits);
                        enum slp_decode_reason r = add_field(d, b, pos, end);

                        if (r != SLP_REASON_NONE)
                                return r;
                        pos = end + 1;
                }
        }
        return d->frame.nfields > 0 ? SLP_REASON_NONE : SLP_REASON_NO_FIELDS;
}

/* Validates the complete frame in d->buf[0 .. d->len) ('[' ... ']') and fills d->frame. */
static enum slp_decode_reason frame_parse(struct slp_decoder *d)
{
        const char *b = d->buf + 1;     /* body, after the '[' */
        size_t m = d->len - 2;          /* without '[' and ']' */
        struct slp_frame *f = &d->frame;
        enum slp_decode_reason r;
        size_t lp = m;
        unsigned want;
        bool printable;

        /* The checksum field follows the last '|'; a valid one is 2 or 3 bytes from the end. */
        while (lp > 0 && b[lp - 1] != '|')
                lp--;
        if (lp == 0)
                return SLP_REASON_NO_CHECKSUM;
        lp--;
        r = parse_checksum(b, m, lp, &want);
        if (r != SLP_REASON_NONE)
                return r;
        /* From ':' (b[0]) through the 'C' (b[lp + 1]) inclusive. */
        if (scan_body(d->bars, b, lp + 2, &printable) != want)
                return SLP_REASON_BAD_CHECKSUM;
        r = check_header(b, lp);
        if (r != SLP_REASON_NONE)
                return r;
        /* The header passed, so any unprintable byte is in a field. */
        if (!printable)
                return SLP_REASON_BAD_FIELD;

        f->dst = b[1];
        f->src = b[2];
        f->dst_index = (uint8_t)slp_address_index(b[1]);
        f->src_index = (uint8_t)slp_address_index(b[2]);
        f->nfields = 0;
        f->fields = d->fields;
        f->unknown_fields = 0;
        f->empty_fields = 0;
        f->raw = d->buf;
        f->raw_len = d->len;
        return split_fields(d, b, lp);
}

/* ']' was just stored: report the frame or why it was dropped; back to IDLE. */
static void frame_complete(struct slp_decoder *d, struct slp_decode_result *r)
{
        enum slp_decode_reason reason = frame_parse(d);

        if (reason == SLP_REASON_NONE) {
                r->kind = SLP_RESULT_FRAME;
                r->reason = SLP_REASON_NONE;
                r->bytes = d->len;
                r->frame = &d->frame;
        } else {
                result_reject(r, reason, d->len);
        }
        d->len = 0;
}

/* IDLE: consumes bytes up to and including a '['; returns the count, with a result if any. */
static size_t feed_idle(struct slp_decoder *d, const uint8_t *p, size_t n,
                        struct slp_decode_result *r)
{
        for (size_t i = 0; i < n; i++) {
                uint8_t c = p[i];

                if (c == '[') {
                        d->buf[0] = '[';
                        d->len = 1;
                        if (d->noise > 0) {
                                result_reject(r, SLP_REASON_NOISE, d->noise);
                                d->noise = 0;
                        }
                        return i + 1;
                }
                if (c == '\r' || c == '\n')
                        continue;
                if (++d->noise >= SLP_NOISE_RUN_MAX) {
                        result_reject(r, SLP_REASON_NOISE, d->noise);
                        d->noise = 0;
                        return i + 1;
                }
        }
        return n;
}

/* FRAME: copies bytes up to ']', '[' or the length limit; returns the count consumed. */
static size_t feed_frame(struct slp_decoder *d, const uint8_t *p, size_t n,
                         struct slp_decode_result *r)
{
        /* Invariant: d->len <= max_frame - 1, so `room` more body bytes fit before the ']'. */
        size_t room = d->max_frame - 1 - d->len;
        size_t scan = n < room + 1 ? n : room + 1;
        const uint8_t *close = memchr(p, ']', scan);
        size_t k = close ? (size_t)(close - p) : scan;
        const uint8_t *open = memchr(p, '[', k);

        if (open) {
                k = (size_t)(open - p);
                result_reject(r, SLP_REASON_RESYNC, d->len + k);
                d->buf[0] = '[';
                d->len = 1;
                return k + 1;
        }
        if (close) {
                memcpy(d->buf + d->len, p, k + 1);
                d->len += k + 1;
                frame_complete(d, r);
                return k + 1;
        }
        if (k > room) {
                /* p[room] is a body byte where only ']' could still fit. */
                result_reject(r, SLP_REASON_OVERLONG, d->len + k);
                d->len = 0;
                return k;
        }
        memcpy(d->buf + d->len, p, k);
        d->len += k;
        return k;
}

size_t slp_decoder_feed(struct slp_decoder *d, const uint8_t *buf, size_t len,
                        struct slp_decode_result *ret_result)
{
        size_t used = 0;

        ret_result->kind = SLP_RESULT_NONE;
        ret_result->reason = SLP_REASON_NONE;
        ret_result->bytes = 0;
        ret_result->frame = NULL;
        while (used < len && ret_result->kind == SLP_RESULT_NONE) {
                if (d->len == 0)
                        used += feed_idle(d, buf + used, len - used, ret_result);
                else
                        used += feed_frame(d, buf + used, len - used, ret_result);
        }
        return used;
}

bool slp_decoder_end(struct slp_decoder *d, struct slp_decode_result *ret_result)
{
        if (d->len > 0) {
                result_reject(ret_result, SLP_REASON_TRUNCATED, d->len);
                d->len = 0;
                return true;
        }
        if (d->noise > 0) {
                result_reject(ret_result, SLP_REASON_NOISE, d->noise);
                d->noise = 0;
                return true;
        }
        return false;
}

/* ---------------------------------------------------------------------------------------------
 * Encoder */

static int check_value(char letter, const char *v, size_t len)
{
        uint32_t index;

        if (len > SLP_VALUE_MAX)
                return -EMSGSIZE;
        for (size_t i = 0; i < len; i++)
                if (!slp_value_byte((unsigned char)v[i]))
                        return -EINVAL;
        if ((letter == 'N' || letter == 'L') && !parse_index(v, len, &index))
                return -EINVAL;
        return 0;
}

/* Length of a NUL-terminated value, or SLP_VALUE_MAX + 1 if longer. */
static size_t value_len(const char *v)
{
        size_t n = 0;

        while (n <= SLP_VALUE_MAX && v[n] != '\0')
                n++;
        return n;
}

/* A list value: its length (as value_len()) and 0, -EMSGSIZE or -EINVAL, in one pass. */
static int list_value_check(const char *v, size_t *ret_len)
{
        unsigned bad = 0;
        size_t n = 0;

        if (!v)
                return -EINVAL;
        for (; n <= SLP_VALUE_MAX && v[n] != '\0'; n++)
                bad |= !slp_value_byte((unsigned char)v[n]);
        *ret_len = n;
        return n > SLP_VALUE_MAX ? -EMSGSIZE : bad ? -EINVAL : 0;
}

static size_t put(char *buf, size_t at, const char *s, size_t n)
{
        memcpy(buf + at, s, n);
        return at + n;
}

/* Writes "[:" dst src into buf (the caller checked the space); returns 4. */
static size_t put_header(char *buf, char dst, char src)
{
        buf[0] = '[';
        buf[1] = ':';
        buf[2] = dst;
        buf[3] = src;
        return SL_HEADER_LEN;
}

/* Sum mod 256 of p[0 .. n): the encoder's checksum, eight bytes at a time. */
static unsigned checksum(const char *p, size_t n)
{
        uint64_t even = 0, odd = 0, lanes;
        unsigned sum;
        size_t i = 0;

        for (; i + sizeof(uint64_t) <= n; i += sizeof(uint64_t)) {
                uint64_t w = load_word(p + i);

                even = (even + (w & SWAR_LANES)) & SWAR_LANES;
                odd = (odd + ((w >> 8) & SWAR_LANES)) & SWAR_LANES;
        }
        lanes = even + odd;
        sum = (unsigned)((lanes * 0x0001000100010001ull) >> 48);
        for (; i < n; i++)
                sum += (unsigned char)p[i];
        return sum & 0xff;
}

/* Appends "|C" hh "]" [CR LF] to the frame buf[0 .. at); returns the new length. */
static size_t put_trailer(char *buf, size_t at, bool crlf)
{
        unsigned sum;

        buf[at++] = '|';
        buf[at++] = 'C';
        /* Sum from ':' (buf[1]) through the 'C' just written; '[' excluded. */
        sum = checksum(buf + 1, at - 1);
        buf[at++] = sl_hex_upper[(sum >> 4) & 0xf];
        buf[at++] = sl_hex_upper[sum & 0xf];
        buf[at++] = ']';
        if (crlf) {
                buf[at++] = '\r';
                buf[at++] = '\n';
        }
        return at;
}

int slp_frame_encode(char *buf, size_t size, char dst, char src,
                     const struct slp_field *fields, size_t nfields, unsigned flags)
{
        bool crlf = flags & SLP_ENCODE_CRLF;
        size_t total = SL_HEADER_LEN + SL_TRAILER_LEN + (crlf ? SLP_CRLF_LEN : 0);
        size_t at;

        if (!slp_address_valid(dst) || !slp_address_valid(src) || nfields == 0)
                return -EINVAL;
        for (size_t i = 0; i < nfields; i++) {
                const struct slp_field *f = &fields[i];
                int r;

                if (!is_type_letter(f->letter) || f->letter == 'C')
                        return -EINVAL;
                r = check_value(f->letter, f->value, f->len);
                if (r < 0)
                        return r;
                total += 2 + (size_t)f->len;
        }
        if (total > size || total > INT_MAX)
                return -ENOSPC;

        at = put_header(buf, dst, src);
        for (size_t i = 0; i < nfields; i++) {
                buf[at++] = '|';
                buf[at++] = fields[i].letter;
                at = put(buf, at, fields[i].value, fields[i].len);
        }
        at = put_trailer(buf, at, crlf);
        return (int)at;
}

int slp_encode_query(char *buf, size_t size, char dst, char src, const char *name, unsigned flags)
{
        struct slp_field f = { .letter = 'Q', .value = name, .len = (uint16_t)value_len(name) };

        return slp_frame_encode(buf, size, dst, src, &f, 1, flags);
}

/* "<letter><name>|D<value>": an answer (R) or a module command (E). */
static int encode_pair(char *buf, size_t size, char dst, char src, char letter, const char *name,
                       const char *value, unsigned flags)
{
        struct slp_field f[2] = {
                { .letter = letter, .value = name, .len = (uint16_t)value_len(name) },
                { .letter = 'D', .value = value, .len = (uint16_t)value_len(value) },
        };

        return slp_frame_encode(buf, size, dst, src, f, 2, flags);
}

int slp_encode_answer(char *buf, size_t size, char dst, char src, const char *name,
                      const char *value, unsigned flags)
{
        return encode_pair(buf, size, dst, src, 'R', name, value, flags);
}

/* Decimal digits of k into out (no terminator); returns the count. */
static size_t format_index(size_t k, char *out)
{
        char tmp[24];
        size_t n = 0;

        do {
                tmp[n++] = (char)('0' + k % 10);
                k /= 10;
        } while (k > 0);
        for (size_t i = 0; i < n; i++)
                out[i] = tmp[n - 1 - i];
        return n;
}

/*
 * Starts a list frame "[:" dst src "|" head k (k = @start) in @buf; returns its length so far,
 * with *@ret_total the length the frame has once closed ("|C" hh "]" [CR LF]), or -EMSGSIZE
 * (beyond max_frame) / -ENOSPC (beyond the caller's @limit) when not even that fits.
 */
static int put_list_head(char *buf, size_t limit, size_t max_frame, char dst, char src,
                         char head, size_t start, bool crlf, size_t *ret_total)
{
        char digits[24];
        size_t ndigits = format_index(start, digits), at;
        size_t total = SL_HEADER_LEN + 2 + ndigits + SL_TRAILER_LEN + (crlf ? SLP_CRLF_LEN : 0);

        if (total > limit)
                return total > max_frame ? -EMSGSIZE : -ENOSPC;
        at = put_header(buf, dst, src);
        buf[at++] = '|';
        buf[at++] = head;
        at = put(buf, at, digits, ndigits);
        *ret_total = total;
        return (int)at;
}

/* What position @pos of @list sends: its value, or "" when compression leaves it out. */
static const char *list_value_to_send(const struct slp_list *list, size_t pos)
{
        bool send = !list->compress || list->full || !list->changed || list->changed[pos];

        return send ? list->values[pos] : "";
}

int slp_encode_list(const struct slp_list *list, size_t *cursor, char *buf, size_t size)
{
        size_t max_frame = list->max_frame ? list->max_frame : SLP_FRAME_DEFAULT;
        size_t limit = max_frame < size ? max_frame : size;
        size_t start = *cursor, pos = start;
        size_t total, at;
        int r;

        if (!slp_address_valid(list->dst) || !slp_address_valid(list->src) ||
            max_frame > SLP_FRAME_MAX)
                return -EINVAL;
        if (start >= list->count)
                return 0;

        r = put_list_head(buf, limit, max_frame, list->dst, list->src, 'N', start, list->crlf,
                          &total);
        if (r < 0)
                return r;
        at = (size_t)r;

        for (; pos < list->count; pos++) {
                const char *v = list_value_to_send(list, pos);
                size_t vlen = 0;
                r = list_value_check(v, &vlen);

                if (r == 0 && total + 2 + vlen > limit)
                        r = total + 2 + vlen > max_frame ? -EMSGSIZE : -ENOSPC;
                if (r < 0) {
                        /* Send what fits; a bad value or one that can never fit (alone in a
                         * frame) is reported by the call that starts at it: never a loop. */
                        if (pos > start)
                                break;
                        return r;
                }
                total += 2 + vlen;
                buf[at++] = '|';
                buf[at++] = 'D';
                at = put(buf, at, v, vlen);
        }
        at = put_trailer(buf, at, list->crlf);
        *cursor = pos;
        return (int)at;
}

/* ---------------------------------------------------------------------------------------------
 * Pronto4 dialect (docs/pronto4.md) */

/* Indexed by enum slp_type: the T digit of each type, 0 where no type has that value. */
static const char type_digits[] = { '0', 0, '2', 0, '4' };

/* The largest double magnitude we accept is 0.17976931348623157e309 (DBL_MAX as "%.17g" prints
 * it, a hair below DBL_MAX itself): its significant digits and decimal exponent. */
static const char dbl_max_digits[] = "17976931348623157";
#define SL_DBL_MAX_EXP10        309
/* Exponent digits saturate here: far beyond anything 63 bytes of mantissa can bring back. */
#define SL_EXP10_SATURATE       100000

int slp_type_parse(const char *value, size_t len, enum slp_type *ret_type)
{
        if (len != 1)
                return -EINVAL;
        switch (value[0]) {
        case '0':
                *ret_type = SLP_TYPE_LONG;
                return 0;
        case '2':
                *ret_type = SLP_TYPE_DOUBLE;
                return 0;
        case '4':
                *ret_type = SLP_TYPE_STRING;
                return 0;
        default:
                return -EINVAL;
        }
}

char slp_type_digit(enum slp_type type)
{
        if ((unsigned)type >= sizeof(type_digits))
                return 0;
        return type_digits[type];
}

static bool is_digit(char c)
{
        return c >= '0' && c <= '9';
}

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define SLP_SWAR                1
#define SLP_ONES                UINT64_C(0x0101010101010101)

/*
 * Nonzero in each byte of w that is no decimal digit, zero in each that is: a digit's high
 * nibble is 3 and its low nibble plus 6 stays below 16. No sum carries into the next byte.
 */
static uint64_t swar_nondigit(uint64_t w)
{
        return ((w & (SLP_ONES * 0xf0u)) ^ (SLP_ONES * 0x30u)) |
               (((w & (SLP_ONES * 0x0fu)) + SLP_ONES * 0x06u) & (SLP_ONES * 0xf0u));
}
#endif

/*
 * The end of the run of digits that starts at v[i]: eight bytes at a time while eight are left
 * (a 63-byte double is a run of 60 digits, checked on every sl_write of it), then byte by byte.
 */
static size_t digits_end(const char *v, size_t len, size_t i)
{
#if defined(SLP_SWAR)
        for (; i + 8u <= len; i += 8u) {
                uint64_t w, m;

                memcpy(&w, v + i, sizeof(w));
                m = swar_nondigit(w);
                if (m)          /* the lowest nonzero byte: the first that is no digit */
                        return i + (size_t)__builtin_ctzll(m) / 8u;
        }
#endif
        while (i < len && is_digit(v[i]))
                i++;
        return i;
}

/* The first index in v[from..to) whose digit is not '0', or `to`. */
static size_t first_nonzero(const char *v, size_t from, size_t to)
{
        while (from < to && v[from] == '0')
                from++;
        return from;
}

/*
 * [+-] 1*DIGIT, within INT64_MIN..INT64_MAX. Up to 18 digits cannot overflow (10^18 < 2^63), so
 * only longer ones are added up (the division per digit was most of a check).
 */
#define SLP_LONG_SAFE_DIGITS    18u

static int check_long(const char *v, size_t len)
{
        uint64_t mag = 0, limit = (uint64_t)INT64_MAX;
        size_t i = 0, start;

        if (i < len && (v[i] == '+' || v[i] == '-')) {
                if (v[i] == '-')
                        limit++;                /* |INT64_MIN| */
                i++;
        }
        start = i;
        if (digits_end(v, len, start) != len || len == start)
                return -EINVAL;
        if (len - start <= SLP_LONG_SAFE_DIGITS)
                return 0;
        for (i = start; i < len; i++) {
                unsigned d = (unsigned)(v[i] - '0');

                if (mag > (limit - d) / 10)
                        return -EINVAL;
                mag = mag * 10 + d;
        }
        return 0;
}

/* [("e" / "E") [+-] 1*DIGIT] from v[*i]: adds the exponent (saturated) to *exp10. */
static int parse_exponent(const char *v, size_t len, size_t *i, long *exp10)
{
        long e = 0;
        bool neg = false;
        size_t start;

        if (*i == len)
                return 0;
        if (v[*i] != 'e' && v[*i] != 'E')
                return -EINVAL;
        (*i)++;
        if (*i < len && (v[*i] == '+' || v[*i] == '-'))
                neg = v[(*i)++] == '-';
        start = *i;
        for (; *i < len && is_digit(v[*i]); (*i)++)
                if (e < SL_EXP10_SATURATE)
                        e = e * 10 + (v[*i] - '0');
        if (*i == start || *i != len)
                return -EINVAL;
        *exp10 += neg ? -e : e;
        return 0;
}

/*
 * The significant digits of a double, from v[first] (those up to int_end, then those from
 * frac_start, past the point, up to frac_end), against dbl_max_digits: 0 when they are not
 * above them, else -EINVAL.
 */
static int check_double_digits(const char *v, size_t first, size_t int_end, size_t frac_start,
                               size_t frac_end)
{
        const size_t nmax = sizeof(dbl_max_digits) - 1;
        size_t i = first;

        for (size_t k = 0; i < frac_end || k < nmax; k++) {
                char a, b;

                if (i == int_end)
                        i = frac_start;         /* over the point */
                a = i < frac_end ? v[i++] : '0';
                b = k < nmax ? dbl_max_digits[k] : '0';
                if (a != b)
                        return a < b ? 0 : -EINVAL;
        }
        return 0;
}

/*
 * A strict decimal double, finite. The value is 0.S x 10^exp10 where S are its significant
 * digits (leading zeros dropped); it is finite when exp10 is below SL_DBL_MAX_EXP10, or equal
 * with S at most dbl_max_digits. No strtod(): its answer depends on the locale. The digits are
 * walked in runs, and S is looked at again only for a value near the largest double: every
 * sl_write of a double variable checks its value here.
 */
static int check_double(const char *v, size_t len)
{
        size_t i = 0, int_start, int_end, frac_start, frac_end, first;
        long exp10;
        int r;

        if (i < len && (v[i] == '+' || v[i] == '-'))
                i++;
        int_start = i;
        i = int_end = frac_start = frac_end = digits_end(v, len, int_start);
        if (i < len && v[i] == '.') {
                frac_start = i + 1;
                i = frac_end = digits_end(v, len, frac_start);
        }
        if (int_end == int_start && frac_end == frac_start)
                return -EINVAL;                 /* no digit */
        first = first_nonzero(v, int_start, int_end);
        if (first < int_end) {
                exp10 = (long)(int_end - first);
        } else {
                first = first_nonzero(v, frac_start, frac_end);
                exp10 = -(long)(first - frac_start);    /* 0.00S: each zero after the point */
        }
        r = parse_exponent(v, len, &i, &exp10);
        if (r < 0)
                return r;
        if (first == frac_end || exp10 < SL_DBL_MAX_EXP10)     /* zero, or below the largest */
                return 0;
        if (exp10 > SL_DBL_MAX_EXP10)
                return -EINVAL;
        return check_double_digits(v, first, int_end, frac_start, frac_end);
}

int slp_value_type_check(enum slp_type type, const char *value, size_t len)
{
        switch (type) {
        case SLP_TYPE_LONG:
                return check_long(value, len);
        case SLP_TYPE_DOUBLE:
                return check_double(value, len);
        case SLP_TYPE_STRING:
                return 0;
        }
        return -EINVAL;
}

int slp_value_check(enum slp_type type, const char *value, size_t len)
{
        int r = check_value('D', value, len);

        return r < 0 ? r : slp_value_type_check(type, value, len);
}

int slp_name_check(const char *name, size_t len)
{
        if (len == 0)
                return -EINVAL;
        if (len > SLP_VALUE_MAX)
                return -EMSGSIZE;
        for (size_t i = 0; i < len; i++)
                if (!slp_name_byte(name[i]))
                        return -EINVAL;
        return 0;
}

static bool has_letter(const struct slp_frame *f, char letter)
{
        for (size_t i = 1; i < f->nfields; i++)
                if (f->fields[i].letter == letter)
                        return true;
        return false;
}

/* The bare module requests (docs/pronto4.md §9): a frame of this one field, letter and all. */
static const char *const bare_requests[] = { "MUI", "MUO", "ML", "MW" };

bool slp_p4_bare_request(const char *module, size_t len)
{
        for (size_t i = 0; i < sizeof(bare_requests) / sizeof(bare_requests[0]); i++)
                if (len == strlen(bare_requests[i]) && memcmp(module, bare_requests[i], len) == 0)
                        return true;
        return false;
}

static bool is_mu(const struct slp_field *f)
{
        char whole[SLP_VALUE_MAX + 1];

        if (f->letter != 'M' || f->len >= sizeof(whole))
                return false;
        whole[0] = 'M';
        memcpy(whole + 1, f->value, f->len);
        return slp_p4_bare_request(whole, f->len + 1u);
}

enum slp_p4_kind slp_p4_kind_of(const struct slp_frame *frame)
{
        const struct slp_field *head;
        bool q, d;

        if (frame->nfields == 0)
                return SLP_P4_OTHER;
        head = &frame->fields[0];
        switch (head->letter) {
        case 'P':
                return SLP_P4_PING;
        case 'G':
                return SLP_P4_PONG;
        case 'E':
                return SLP_P4_COMMAND;
        case 'M':
                return frame->nfields == 1 && is_mu(head) ? SLP_P4_MU : SLP_P4_OTHER;
        case 'N':
        case 'L':
                break;
        default:
                return SLP_P4_OTHER;
        }
        if (head->index == SLP_INDEX_QUERY)
                return SLP_P4_LIST_QUERY;
        /* Decision (docs/pronto4.md §4, §7): a Q makes a declaration, a Q with a D a
         * self-describing frame; an R after N an acknowledgement; else N is positional data. */
        q = has_letter(frame, 'Q');
        d = has_letter(frame, 'D');
        if (q)
                return d && head->letter == 'N' ? SLP_P4_SELF_DESCRIBING : SLP_P4_DECLARATION;
        if (head->letter == 'L')
                return SLP_P4_OTHER;
        return has_letter(frame, 'R') ? SLP_P4_ACKNOWLEDGEMENT : SLP_P4_DATA;
}

int slp_entry_next(const struct slp_frame *frame, size_t *pos, struct slp_entry *ret_entry)
{
        const struct slp_field *f = frame->fields;
        size_t n = frame->nfields, i = *pos;
        struct slp_entry e = { .type = SLP_TYPE_DOUBLE };
        bool bad = false;

        if (i >= n)
                return 0;
        if (f[i].letter == 'T') {
                bad = slp_type_parse(f[i].value, f[i].len, &e.type) < 0;
                e.typed = true;
                i++;
        }
        if (i >= n || (f[i].letter != 'Q' && f[i].letter != 'R')) {
                /* A T without its name, a stray D or another letter: one field, bad. */
                *pos = e.typed ? i : i + 1;
                return -EINVAL;
        }
        e.letter = f[i].letter;
        e.name = f[i].value;
        e.name_len = f[i].len;
        bad |= slp_name_check(e.name, e.name_len) < 0;
        i++;
        if (i < n && f[i].letter == 'D') {
                e.value = f[i].value;
                e.value_len = f[i].len;
                e.has_value = true;
                i++;
        }
        *pos = i;
        if (bad)
                return -EINVAL;
        *ret_entry = e;
        return 1;
}

/* The two fields of position @pos of a named list: T/Q (declaration) or R/D (acknowledgement). */
static int named_entry(const struct slp_named_list *l, size_t pos, bool declaration,
                       struct slp_field ret[2])
{
        const char *name = l->names[pos];
        size_t nlen;
        int r;

        if (!name)
                return -EINVAL;
        nlen = value_len(name);
        r = slp_name_check(name, nlen);
        if (r < 0)
                return r;
        if (declaration) {
                if (!slp_type_digit(l->types[pos]))
                        return -EINVAL;
                ret[0] = (struct slp_field){ .letter = 'T', .len = 1,
                                             .value = &type_digits[l->types[pos]] };
                ret[1] = (struct slp_field){ .letter = 'Q', .value = name, .len = (uint16_t)nlen };
                return 0;
        }
        ret[0] = (struct slp_field){ .letter = 'R', .value = name, .len = (uint16_t)nlen };
        ret[1] = (struct slp_field){ .letter = 'D', .value = l->values[pos] };
        if (!ret[1].value)
                return -EINVAL;
        r = list_value_check(ret[1].value, &nlen);
        ret[1].len = (uint16_t)nlen;
        return r;
}

/* The frame of a named list from *cursor: as slp_encode_list(), two fields per position. */
static int encode_named(const struct slp_named_list *l, bool declaration, size_t *cursor,
                        char *buf, size_t size)
{
        size_t max_frame = l->max_frame ? l->max_frame : SLP_FRAME_DEFAULT;
        size_t limit = max_frame < size ? max_frame : size;
        size_t start = *cursor, pos = start;
        size_t total, at;
        int r;

        if (!slp_address_valid(l->dst) || !slp_address_valid(l->src) ||
            (l->head != 'N' && l->head != 'L') || max_frame > SLP_FRAME_MAX ||
            (l->one_frame && start != 0 && start < l->count))
                return -EINVAL;
        if (start >= l->count)
                return 0;

        r = put_list_head(buf, limit, max_frame, l->dst, l->src, l->head, start, l->crlf, &total);
        if (r < 0)
                return r;
        at = (size_t)r;

        for (; pos < l->count; pos++) {
                struct slp_field f[2];
                size_t need;

                r = named_entry(l, pos, declaration, f);
                need = r < 0 ? 0 : 4 + (size_t)f[0].len + f[1].len;    /* "|T0|Qname" */

                if (r == 0 && total + need > limit)
                        r = total + need > max_frame ? -EMSGSIZE : -ENOSPC;
                if (r < 0) {
                        /* As slp_encode_list(): the call that starts at a bad entry names it. */
                        if (pos > start && !l->one_frame)
                                break;
                        return r;
                }
                total += need;
                for (size_t k = 0; k < 2; k++) {
                        buf[at++] = '|';
                        buf[at++] = f[k].letter;
                        at = put(buf, at, f[k].value, f[k].len);
                }
        }
        at = put_trailer(buf, at, l->crlf);
        *cursor = pos;
        return (int)at;
}

int slp_encode_declaration(const struct slp_named_list *list, size_t *cursor, char *buf,
                           size_t size)
{
        if (!list->types)
                return -EINVAL;
        return encode_named(list, true, cursor, buf, size);
}

int slp_encode_acknowledgement(const struct slp_named_list *list, size_t *cursor, char *buf,
                               size_t size)
{
        if (!list->values)
                return -EINVAL;
        return encode_named(list, false, cursor, buf, size);
}

int slp_encode_list_query(char *buf, size_t size, char dst, char src, char head, unsigned flags)
{
        struct slp_field f = { .letter = head, .value = "?", .len = 1 };

        if (head != 'N' && head != 'L')
                return -EINVAL;
        return slp_frame_encode(buf, size, dst, src, &f, 1, flags);
}

int slp_encode_command(char *buf, size_t size, char dst, char src, const char *module,
                       const char *text, unsigned flags)
{
        size_t mlen = value_len(module);
        int r = slp_name_check(module, mlen);
        struct slp_field bare;

        if (r < 0)
                return r;
        if (!slp_p4_bare_request(module, mlen))
                return encode_pair(buf, size, dst, src, 'E', module, text, flags);
        /* "MUI" goes out as the field M with value "UI": the frame the clients send. */
        if (text && text[0])
                return -EINVAL;
        bare = (struct slp_field){ .letter = module[0], .value = module + 1,
                                   .len = (uint16_t)(mlen - 1u) };
        return slp_frame_encode(buf, size, dst, src, &bare, 1, flags);
}

size_t slp_list_frame_len(size_t fields_len, bool crlf)
{
        return SL_HEADER_LEN + 3 + fields_len + SL_TRAILER_LEN + (crlf ? SLP_CRLF_LEN : 0);
}

int slp_encode_list_whole(const struct slp_list *list, char *buf, size_t size)
{
        size_t max_frame = list->max_frame ? list->max_frame : SLP_FRAME_DEFAULT;
        size_t total = slp_list_frame_len(0, list->crlf);
        size_t cursor = 0;
        int r;

        if (!slp_address_valid(list->dst) || !slp_address_valid(list->src) ||
            max_frame > SLP_FRAME_MAX)
                return -EINVAL;
        if (list->count == 0)
                return 0;
        /* Measure first: slp_encode_list() would split, and this caller wants one frame. */
        for (size_t pos = 0; pos < list->count; pos++) {
                size_t vlen;

                r = list_value_check(list_value_to_send(list, pos), &vlen);
                if (r < 0)
                        return r;
                total += 2 + vlen;
        }
        if (total > max_frame)
                return -EMSGSIZE;
        if (total > size)
                return -ENOSPC;
        r = slp_encode_list(list, &cursor, buf, size);
        return r >= 0 && cursor != list->count ? -EMSGSIZE : r;
}
