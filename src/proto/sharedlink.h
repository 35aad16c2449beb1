/*
 * SharedLink codec (Kairos Autonomi BUL-049): streaming frame decoder, frame encoder, list encoder.
 *
 * Pure code: no syscalls, no allocation, no logging, no global state. The caller owns the decoder
 * and every buffer. The byte-level contract is PROTOCOLS.md section 1; the names of its rules
 * (Decision, Field practice) are quoted where the code applies them.
 *
 * Decoding, on a byte stream (serial, pty):
 *
 *      struct sl_decoder d;              // about 37 KiB: keep it in the link, not on a small stack
 *      struct sl_decode_result r;
 *      sl_decoder_init(&d, max_frame);
 *      while (len > 0) {
 *              size_t n = sl_decoder_feed(&d, buf, len, &r);
 *              buf += n; len -= n;
 *              if (r.kind == SL_RESULT_FRAME)  ... r.frame->fields[0 .. r.frame->nfields) ...
 *              if (r.kind == SL_RESULT_REJECT) ... count r.reason, r.bytes ...
 *      }
 *
 * On a datagram transport (UDP), feed the whole datagram the same way, then call
 * sl_decoder_end() once: it reports a trailing partial frame (SL_REASON_TRUNCATED) or trailing
 * noise, and leaves the decoder ready for the next datagram.
 */
#ifndef SHAREDLINK_PROTO_SHAREDLINK_H
#define SHAREDLINK_PROTO_SHAREDLINK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* ---------------------------------------------------------------------------------------------
 * Limits */

/* Longest value we emit (bytes, no terminator). The decoder passes longer values through, as
 * the grammar has no bound: whoever stores a decoded value checks its length. */
#define SL_VALUE_MAX            63
#define SL_FRAME_DEFAULT        1024    /* default max_frame, '[' through ']' */
#define SL_FRAME_MAX            4096    /* largest configurable max_frame */
#define SL_FRAME_MIN            32      /* smallest configurable max_frame */
#define SL_ADDR_COUNT           16      /* node addresses 'A'..'P' */
#define SL_CHECKSUM_FIELD_MAX   3       /* 'C' and two hex digits */
#define SL_NOISE_RUN_MAX        1024    /* a noise run is reported at least every this many bytes */
/* Every stored field takes at least 2 bytes ("|X"), so a frame never holds more than this. */
#define SL_FIELDS_MAX           (SL_FRAME_MAX / 2)
/* sl_field.index for "N?" and "L?" (ask the peer for its lists, Pronto4 dialect). */
#define SL_INDEX_QUERY          UINT32_MAX
/* sl_field.index saturates here: larger positions are beyond any list (counted by the engine). */
#define SL_INDEX_MAX            (UINT32_MAX - 1)

/* ---------------------------------------------------------------------------------------------
 * Fields and frames */

/* Field types; each known type's value is its letter on the wire. */
enum sl_field_type {
        SL_FIELD_UNKNOWN = 0,   /* an uppercase letter we do not know: skipped by the engine */
        SL_FIELD_N = 'N',       /* start position of the next D ("N?": ask for the N list) */
        SL_FIELD_D = 'D',       /* data; empty = unchanged since last sent (compression) */
        SL_FIELD_Q = 'Q',       /* query a variable by name (Pronto4: name in a declaration) */
        SL_FIELD_R = 'R',       /* the next D is the value of this name */
        SL_FIELD_T = 'T',       /* Pronto4: variable type (0 long, 2 double, 4 string) */
        SL_FIELD_L = 'L',       /* Pronto4: start of the list the sender wants ("L?": ask) */
        SL_FIELD_P = 'P',       /* Pronto4: ping */
        SL_FIELD_G = 'G',       /* Pronto4: pong */
        SL_FIELD_E = 'E',       /* Pronto4: command to a controller module */
        SL_FIELD_C = 'C',       /* checksum: never in sl_frame.fields, refused by the encoder */
};

struct sl_field {
        const char *value;              /* not NUL-terminated; decoded: valid until the next feed */
        uint16_t len;                   /* bytes in value */
        char letter;                    /* the type letter as sent, 'A'..'Z' */
        uint8_t type;                   /* enum sl_field_type (decoder output; ignored by encoders) */
        uint32_t index;                 /* N and L: position, SL_INDEX_QUERY for '?' (decoder) */
};

struct sl_frame {
        char dst, src;                  /* 'A'..'P' */
        uint8_t dst_index, src_index;   /* 0..15 */
        size_t nfields;                 /* fields, checksum excluded, empty fields skipped */
        const struct sl_field *fields;
        size_t unknown_fields;          /* fields of an unknown type (kept in fields, type UNKNOWN) */
        size_t empty_fields;            /* empty fields ("||") skipped */
        const char *raw;                /* the frame as received, '[' through ']' */
        size_t raw_len;
};

/* ---------------------------------------------------------------------------------------------
 * Decoder */

enum sl_result_kind {
        SL_RESULT_NONE = 0,             /* input used up, nothing to report yet */
        SL_RESULT_FRAME,                /* a valid frame: result.frame */
        SL_RESULT_REJECT,               /* bytes dropped: result.reason, result.bytes */
};

/* Why bytes were dropped. The last two never reject a frame; they count skipped fields. */
enum sl_decode_reason {
        SL_REASON_NONE = 0,
        SL_REASON_NOISE,                /* bytes outside frames (CR and LF excepted), one run */
        SL_REASON_RESYNC,               /* '[' inside a frame: the partial frame is abandoned */
        SL_REASON_OVERLONG,             /* longer than max_frame: abandoned, resync on next '[' */
        SL_REASON_TRUNCATED,            /* datagram (or input) ended inside a frame */
        SL_REASON_NO_CHECKSUM,          /* last field is not a checksum field */
        SL_REASON_BAD_CHECKSUM_SYNTAX,  /* 'C' not followed by exactly one or two hex digits */
        SL_REASON_BAD_CHECKSUM,         /* checksum does not match */
        SL_REASON_BAD_HEADER,           /* not ":" dst src "|" */
        SL_REASON_BAD_ADDRESS,          /* dst or src not 'A'..'P' */
        SL_REASON_BAD_FIELD,            /* no type letter, byte outside 0x20-0x7E, bad N/L, 'C' early */
        SL_REASON_NO_FIELDS,            /* only a checksum (grammar: at least one field) */
        SL_REASON_UNKNOWN_FIELD,        /* field of an unknown type (counted in the frame) */
        SL_REASON_EMPTY_FIELD,          /* empty field "||" (counted in the frame) */
        SL_REASON_COUNT
};

struct sl_decode_result {
        enum sl_result_kind kind;
        enum sl_decode_reason reason;   /* REJECT only */
        size_t bytes;                   /* REJECT: bytes dropped; FRAME: frame length */
        const struct sl_frame *frame;   /* FRAME only; valid until the next call on the decoder */
};

/* Caller-allocated; opaque in spirit: use the functions below. */
struct sl_decoder {
        size_t max_frame;               /* '[' through ']' */
        size_t len;                     /* bytes of the frame being collected; 0 = between frames */
        size_t noise;                   /* noise bytes not reported yet */
        struct sl_frame frame;
        struct sl_field fields[SL_FIELDS_MAX];
        uint64_t bars[SL_FRAME_MAX / 64 + 1];   /* where the '|' are in buf (bit i: buf[i + 1]) */
        char buf[SL_FRAME_MAX];
};

/* Prepares @d; max_frame 0 means SL_FRAME_DEFAULT. Returns 0, or -EINVAL if outside
 * SL_FRAME_MIN..SL_FRAME_MAX. */
int sl_decoder_init(struct sl_decoder *d, size_t max_frame);

/* Forgets any partial frame and pending noise without reporting them (e.g. after a reopen). */
void sl_decoder_reset(struct sl_decoder *d);

/* Consumes bytes of @buf until one result is ready or @len is used up; returns the bytes consumed
 * (at least 1 when @len > 0) and fills @ret_result (kind SL_RESULT_NONE when nothing is ready). */
size_t sl_decoder_feed(struct sl_decoder *d, const uint8_t *buf, size_t len,
                       struct sl_decode_result *ret_result);

/* Ends a datagram (or the input): reports a partial frame as TRUNCATED, else pending noise.
 * Returns true and fills @ret_result when there was something to report; the decoder is then idle. */
bool sl_decoder_end(struct sl_decoder *d, struct sl_decode_result *ret_result);

/* Short English name of a reason, e.g. "bad checksum"; never NULL. */
const char *sl_decode_reason_str(enum sl_decode_reason reason);

/* Type of a field letter: the letter itself when known, SL_FIELD_UNKNOWN otherwise. */
enum sl_field_type sl_field_type_of(char letter);

/* ---------------------------------------------------------------------------------------------
 * Encoder. Errors: -EINVAL (address not 'A'..'P', type letter not 'A'..'Z' or 'C', a value byte
 * outside 0x20-0x7E or one of '|' '[' ']', N/L value not digits or '?', no fields),
 * -EMSGSIZE (value longer than SL_VALUE_MAX, or a list value that cannot fit in max_frame),
 * -ENOSPC (the caller's buffer is too small). Nothing useful is left in the buffer on error. */

/* Flags for the encoders. */
#define SL_ENCODE_CRLF          0x1u    /* end the frame with CR LF */

/* Encodes one frame "[:" dst src ("|" field)* "|C" hh "]" into @buf; returns its length or an
 * error. Field letters and values are taken from @fields (type and index are ignored). */
int sl_frame_encode(char *buf, size_t size, char dst, char src,
                    const struct sl_field *fields, size_t nfields, unsigned flags);

/* Encodes a query "Q<name>" for the NUL-terminated @name; returns the length or an error. */
int sl_encode_query(char *buf, size_t size, char dst, char src, const char *name, unsigned flags);

/* Encodes an answer "R<name>|D<value>" (NUL-terminated strings); returns the length or an error. */
int sl_encode_answer(char *buf, size_t size, char dst, char src, const char *name,
                     const char *value, unsigned flags);

/* An outbound list to send to one peer, split into frames by sl_encode_list(). */
struct sl_list {
        char dst, src;
        const char *const *values;      /* count NUL-terminated values, position 0 first */
        const bool *changed;            /* per position: changed since last sent; NULL = all */
        size_t count;
        size_t max_frame;               /* 0 = SL_FRAME_DEFAULT; includes the CR LF when crlf */
        bool compress;                  /* unchanged positions go as an empty D */
        bool full;                      /* full refresh: every value, whatever changed says */
        bool crlf;                      /* end every frame with CR LF */
};

/* Encodes the frame that starts at position *@cursor ("N<cursor>|D..|D..") with as many positions
 * as fit in max_frame and @size; returns its length and advances *@cursor past them, 0 once
 * *@cursor == count, or an error about the value at *@cursor (left unchanged). A frame stops
 * before a bad value, so the error always names the offending position. */
int sl_encode_list(const struct sl_list *list, size_t *cursor, char *buf, size_t size);

#endif
