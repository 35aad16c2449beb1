/*
 * SharedLink codec (Kairos Autonomi BUL-049): streaming frame decoder, frame encoder, list encoder.
 *
 * Pure code: no syscalls, no allocation, no logging, no global state. The caller owns the decoder
 * and every buffer. The byte-level contract is PROTOCOLS.md section 1; the names of its rules
 * (Decision, Field practice) are quoted where the code applies them.
 *
 * Names carry the prefix slp_ / SLP_ ("SharedLink protocol"): sl_ / SL_ belong to the public
 * client API (include/sharedlink.h), which a program may include next to this header.
 *
 * Decoding, on a byte stream (serial, pty):
 *
 *      struct slp_decoder d;     // about 37 KiB: keep it in the link, not on a small stack
 *      struct slp_decode_result r;
 *      slp_decoder_init(&d, max_frame);
 *      while (len > 0) {
 *              size_t n = slp_decoder_feed(&d, buf, len, &r);
 *              buf += n; len -= n;
 *              if (r.kind == SLP_RESULT_FRAME)  ... r.frame->fields[0 .. r.frame->nfields) ...
 *              if (r.kind == SLP_RESULT_REJECT) ... count r.reason, r.bytes ...
 *      }
 *
 * On a datagram transport (UDP), feed the whole datagram the same way, then call
 * slp_decoder_end() once: it reports a trailing partial frame (SLP_REASON_TRUNCATED) or trailing
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
#define SLP_VALUE_MAX            63
#define SLP_FRAME_DEFAULT        1024   /* default max_frame, '[' through ']' */
#define SLP_FRAME_MAX            4096   /* largest configurable max_frame */
#define SLP_FRAME_MIN            32     /* smallest configurable max_frame */
#define SLP_ADDR_COUNT           16     /* node addresses 'A'..'P' */
#define SLP_CHECKSUM_FIELD_MAX   3      /* 'C' and two hex digits */
#define SLP_NOISE_RUN_MAX        1024   /* a noise run is reported at least every this many bytes */
/* What a frame takes besides its fields: "[:AB" and "|C" hh "]"; and the CR LF after it. */
#define SLP_FRAME_OVERHEAD       9
#define SLP_CRLF_LEN             2
/* Every stored field takes at least 2 bytes ("|X"), so a frame never holds more than this. */
#define SLP_FIELDS_MAX           (SLP_FRAME_MAX / 2)
/* slp_field.index for "N?" and "L?" (ask the peer for its lists, Pronto4 dialect). */
#define SLP_INDEX_QUERY          UINT32_MAX
/* slp_field.index saturates here: larger positions are beyond any list (counted by the engine). */
#define SLP_INDEX_MAX            (UINT32_MAX - 1)

/* ---------------------------------------------------------------------------------------------
 * Node addresses: the one statement of the rule, for the codec, the config and the library */

/* Whether c is a SharedLink node address, 'A'..'P' (PROTOCOLS.md 1.1, the frame grammar).
 * Inline: the decoder asks it of every frame's two address bytes. */
static inline bool slp_address_valid(char c)
{
        return c >= 'A' && c < 'A' + SLP_ADDR_COUNT;
}

/* Whether text[0..len) is one node address as written in a config or a command ("A".."P"). */
static inline bool slp_address_text_valid(const char *text, size_t len)
{
        return len == 1 && slp_address_valid(text[0]);
}

/* The index 0..SLP_ADDR_COUNT-1 of a valid node address (slp_address_valid()). */
static inline unsigned slp_address_index(char c)
{
        return (unsigned)(c - 'A');
}

/* A valid node address as a NUL-terminated string of static storage ("A".."P"), or NULL. */
const char *slp_address_text(char c);

/* ---------------------------------------------------------------------------------------------
 * Value bytes and name bytes: the one statement of each rule, for the codec, the table, the
 * config and the library */

#define SLP_VALUE_BYTE_MIN       0x20   /* printable ASCII, space included ... */
#define SLP_VALUE_BYTE_MAX       0x7e   /* ... up to '~' */

/* Whether c may appear in a value on the wire: printable ASCII 0x20-0x7E except the framing
 * characters '|' '[' ']' (PROTOCOLS.md 1.2). */
static inline bool slp_value_byte(unsigned char c)
{
        return c >= SLP_VALUE_BYTE_MIN && c <= SLP_VALUE_BYTE_MAX && c != '|' && c != '[' &&
               c != ']';
}

/* Whether c may appear in a name: a variable name (sharedlinkd.yaml(5): "letters, digits, _ .
 * and -"), a name a Pronto4 peer declares, a module of a command. */
static inline bool slp_name_byte(char c)
{
        return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
               c == '_' || c == '.' || c == '-';
}

/* ---------------------------------------------------------------------------------------------
 * Fields and frames */

/* Field types; each known type's value is its letter on the wire. */
enum slp_field_type {
        SLP_FIELD_UNKNOWN = 0,  /* an uppercase letter we do not know: skipped by the engine */
        SLP_FIELD_N = 'N',      /* start position of the next D ("N?": ask for the N list) */
        SLP_FIELD_D = 'D',      /* data; empty = unchanged since last sent (compression) */
        SLP_FIELD_Q = 'Q',      /* query a variable by name (Pronto4: name in a declaration) */
        SLP_FIELD_R = 'R',      /* the next D is the value of this name */
        SLP_FIELD_T = 'T',      /* Pronto4: variable type (0 long, 2 double, 4 string) */
        SLP_FIELD_L = 'L',      /* Pronto4: start of the list the sender wants ("L?": ask) */
        SLP_FIELD_P = 'P',      /* Pronto4: ping */
        SLP_FIELD_G = 'G',      /* Pronto4: pong */
        SLP_FIELD_E = 'E',      /* Pronto4: command to a controller module */
        SLP_FIELD_C = 'C',      /* checksum: never in slp_frame.fields, refused by the encoder */
};

struct slp_field {
        const char *value;              /* not NUL-terminated; decoded: valid until the next feed */
        uint16_t len;                   /* bytes in value */
        char letter;                    /* the type letter as sent, 'A'..'Z' */
        uint8_t type;                   /* enum slp_field_type (decoder output only) */
        uint32_t index;                 /* N and L: position, SLP_INDEX_QUERY for '?' (decoder) */
};

struct slp_frame {
        char dst, src;                  /* 'A'..'P' */
        uint8_t dst_index, src_index;   /* 0..15 */
        size_t nfields;                 /* fields, checksum excluded, empty fields skipped */
        const struct slp_field *fields;
        size_t unknown_fields;          /* fields of an unknown type (kept in fields, type UNKNOWN) */
        size_t empty_fields;            /* empty fields ("||") skipped */
        const char *raw;                /* the frame as received, '[' through ']' */
        size_t raw_len;
};

/* ---------------------------------------------------------------------------------------------
 * Decoder */

enum slp_result_kind {
        SLP_RESULT_NONE = 0,            /* input used up, nothing to report yet */
        SLP_RESULT_FRAME,               /* a valid frame: result.frame */
        SLP_RESULT_REJECT,              /* bytes dropped: result.reason, result.bytes */
};

/* Why bytes were dropped. The last two never reject a frame; they count skipped fields. */
enum slp_decode_reason {
        SLP_REASON_NONE = 0,
        SLP_REASON_NOISE,               /* bytes outside frames (CR and LF excepted), one run */
        SLP_REASON_RESYNC,              /* '[' inside a frame: the partial frame is abandoned */
        SLP_REASON_OVERLONG,            /* longer than max_frame: abandoned, resync on next '[' */
        SLP_REASON_TRUNCATED,           /* datagram (or input) ended inside a frame */
        SLP_REASON_NO_CHECKSUM,         /* last field is not a checksum field */
        SLP_REASON_BAD_CHECKSUM_SYNTAX, /* 'C' not followed by exactly one or two hex digits */
        SLP_REASON_BAD_CHECKSUM,        /* checksum does not match */
        SLP_REASON_BAD_HEADER,          /* not ":" dst src "|" */
        SLP_REASON_BAD_ADDRESS,         /* dst or src not 'A'..'P' */
        SLP_REASON_BAD_FIELD,           /* no type letter, byte not 0x20-0x7E, bad N/L, early C */
        SLP_REASON_NO_FIELDS,           /* only a checksum (grammar: at least one field) */
        SLP_REASON_UNKNOWN_FIELD,       /* field of an unknown type (counted in the frame) */
        SLP_REASON_EMPTY_FIELD,         /* empty field "||" (counted in the frame) */
        SLP_REASON_COUNT
};

struct slp_decode_result {
        enum slp_result_kind kind;
        enum slp_decode_reason reason;  /* REJECT only */
        size_t bytes;                   /* REJECT: bytes dropped; FRAME: frame length */
        const struct slp_frame *frame;  /* FRAME only; valid until the next call on the decoder */
};

/* Caller-allocated; opaque in spirit: use the functions below. */
struct slp_decoder {
        size_t max_frame;               /* '[' through ']' */
        size_t len;                     /* bytes of the frame being collected; 0 = between frames */
        size_t noise;                   /* noise bytes not reported yet */
        struct slp_frame frame;
        struct slp_field fields[SLP_FIELDS_MAX];
        uint64_t bars[SLP_FRAME_MAX / 64 + 1];  /* where the '|' are in buf (bit i: buf[i + 1]) */
        char buf[SLP_FRAME_MAX];
};

/* Prepares @d; max_frame 0 means SLP_FRAME_DEFAULT. Returns 0, or -EINVAL if outside
 * SLP_FRAME_MIN..SLP_FRAME_MAX. */
int slp_decoder_init(struct slp_decoder *d, size_t max_frame);

/* Forgets any partial frame and pending noise without reporting them (e.g. after a reopen). */
void slp_decoder_reset(struct slp_decoder *d);

/* Consumes bytes of @buf until one result is ready or @len is used up; returns the bytes consumed
 * (at least 1 when @len > 0) and fills @ret_result (kind SLP_RESULT_NONE when nothing is ready). */
size_t slp_decoder_feed(struct slp_decoder *d, const uint8_t *buf, size_t len,
                        struct slp_decode_result *ret_result);

/* Ends a datagram (or the input): reports a partial frame as TRUNCATED, else pending noise.
 * Returns true and fills @ret_result when there was something to report; the decoder is then idle. */
bool slp_decoder_end(struct slp_decoder *d, struct slp_decode_result *ret_result);

/* Short English name of a reason, e.g. "bad checksum"; never NULL. */
const char *slp_decode_reason_str(enum slp_decode_reason reason);

/* Type of a field letter: the letter itself when known, SLP_FIELD_UNKNOWN otherwise. */
enum slp_field_type slp_field_type_of(char letter);

/* ---------------------------------------------------------------------------------------------
 * Encoder. Errors: -EINVAL (address not 'A'..'P', type letter not 'A'..'Z' or 'C', a value byte
 * outside 0x20-0x7E or one of '|' '[' ']', N/L value not digits or '?', no fields),
 * -EMSGSIZE (value longer than SLP_VALUE_MAX, or a list value that cannot fit in max_frame),
 * -ENOSPC (the caller's buffer is too small). Nothing useful is left in the buffer on error. */

/* Flags for the encoders. */
#define SLP_ENCODE_CRLF          0x1u   /* end the frame with CR LF */

/* Encodes one frame "[:" dst src ("|" field)* "|C" hh "]" into @buf; returns its length or an
 * error. Field letters and values are taken from @fields (type and index are ignored). */
int slp_frame_encode(char *buf, size_t size, char dst, char src,
                     const struct slp_field *fields, size_t nfields, unsigned flags);

/* Encodes a query "Q<name>" for the NUL-terminated @name; returns the length or an error. */
int slp_encode_query(char *buf, size_t size, char dst, char src, const char *name, unsigned flags);

/* Encodes an answer "R<name>|D<value>" (NUL-terminated strings); returns the length or an error. */
int slp_encode_answer(char *buf, size_t size, char dst, char src, const char *name,
                      const char *value, unsigned flags);

/* An outbound list to send to one peer, split into frames by slp_encode_list(). */
struct slp_list {
        char dst, src;
        const char *const *values;      /* count NUL-terminated values, position 0 first */
        const bool *changed;            /* per position: changed since last sent; NULL = all */
        size_t count;
        size_t max_frame;               /* 0 = SLP_FRAME_DEFAULT; includes the CR LF when crlf */
        bool compress;                  /* unchanged positions go as an empty D */
        bool full;                      /* full refresh: every value, whatever changed says */
        bool crlf;                      /* end every frame with CR LF */
};

/* Encodes the frame that starts at position *@cursor ("N<cursor>|D..|D..") with as many positions
 * as fit in max_frame and @size; returns its length and advances *@cursor past them, 0 once
 * *@cursor == count, or an error about the value at *@cursor (left unchanged). A frame stops
 * before a bad value, so the error always names the offending position. */
int slp_encode_list(const struct slp_list *list, size_t *cursor, char *buf, size_t size);

/* ---------------------------------------------------------------------------------------------
 * Pronto4 dialect (docs/pronto4.md): variable types, value and name checks, declarations,
 * their acknowledgement, list queries, module commands, and the one-frame data list. */

/* The digit after T. Decision: any other digit, or anything but one digit, is an error. */
enum slp_type {
        SLP_TYPE_LONG = 0,              /* "T0": optional sign and decimal digits, fits int64 */
        SLP_TYPE_DOUBLE = 2,            /* "T2": decimal, finite; also a name without T */
        SLP_TYPE_STRING = 4,            /* "T4": any value of the wire charset */
};

/* Longest long: "-9223372036854775808". Longest double we emit with %.17g:
 * "-1.7976931348623157e+308". The worst case of a data list at config check (config.c). */
#define SLP_LONG_TEXT_MAX        20
#define SLP_DOUBLE_TEXT_MAX      24

/* The type a T field's value names ("0", "2" or "4"): 0 and *@ret_type, or -EINVAL. */
int slp_type_parse(const char *value, size_t len, enum slp_type *ret_type);

/* The T digit of @type ('0', '2', '4'), or 0 for a value outside enum slp_type. */
char slp_type_digit(enum slp_type type);

/*
 * Whether @value (@len bytes, not NUL-terminated) is a valid value of @type: 0, -EINVAL, or
 * -EMSGSIZE (longer than SLP_VALUE_MAX). Every type: wire charset (0x20-0x7E without | [ ]).
 * Long: [+-] 1*DIGIT within int64. Double: [+-] (1*DIGIT ["." *DIGIT] / "." 1*DIGIT)
 * [("e"/"E") [+-] 1*DIGIT], at most 1.7976931348623157e308 in magnitude (so strtod() gives a
 * finite number), no spaces, no hex, inf or nan: the same answer in every locale. An empty value
 * is not a long or a double (an empty D means "unchanged": the caller handles it first).
 */
int slp_value_check(enum slp_type type, const char *value, size_t len);

/*
 * slp_value_check's rule for the type alone, for a value already known to be within
 * SLP_VALUE_MAX and the wire's charset (sl_write checks that first, eight bytes at a time): 0 or
 * -EINVAL. A long or a double is within the charset whenever it passes.
 */
int slp_value_type_check(enum slp_type type, const char *value, size_t len);

/* What a decoded frame is in the Pronto4 dialect, told by its first field and the letters after
 * it (docs/pronto4.md §2); bulletin traffic that means nothing more is SLP_P4_OTHER. */
enum slp_p4_kind {
        SLP_P4_OTHER = 0,               /* Q, R answers, D without N, L<k> without Q ... */
        SLP_P4_DATA,                    /* N<k> and D fields only: positional data */
        SLP_P4_DECLARATION,             /* N<k> or L<k>, then [T] Q entries, no D */
        SLP_P4_ACKNOWLEDGEMENT,         /* N<k>, then R D pairs: the answer to a declaration */
        SLP_P4_SELF_DESCRIBING,         /* N<k>, then [T] Q D triples: values by name */
        SLP_P4_LIST_QUERY,              /* N? or L? (fields[0].letter says which) */
        SLP_P4_PING,                    /* P<n>: answer G<n> */
        SLP_P4_PONG,                    /* G<n> */
        SLP_P4_COMMAND,                 /* E<module> [D<text>] */
        SLP_P4_MU,                      /* MUI, MUO, ML or MW alone */
};

/* Whether @module[0..@len) is a bare module request, a frame of its name alone ("MUI", "MUO",
 * "ML", "MW"; docs/pronto4.md §9) rather than "E<module>|D<text>". */
bool slp_p4_bare_request(const char *module, size_t len);

/* Classifies @frame; pure, never fails. */
enum slp_p4_kind slp_p4_kind_of(const struct slp_frame *frame);

/* One entry of a declaration, an acknowledgement or a self-describing frame: [T<t>] Q<name> or
 * R<name>, then an optional D<value>. Pointers into the frame (valid as the frame is). */
struct slp_entry {
        const char *name;
        const char *value;              /* has_value only */
        uint16_t name_len, value_len;
        enum slp_type type;             /* SLP_TYPE_DOUBLE when !typed (a name without T) */
        bool typed, has_value;
        char letter;                    /* 'Q' or 'R' */
};

/*
 * Walks the entries of @frame from field *@pos (1 = after the head N/L field; the caller starts
 * there). Returns 1 with the entry in *@ret_entry, 0 at the end, or -EINVAL for a bad entry (a T
 * whose value is not 0, 2 or 4, a T not followed by a name, a name that fails slp_name_check(),
 * a stray D or another letter); *@pos always moves past what was read, so the caller counts the
 * bad entry and goes on (the entry of a bad T is consumed with it: never learned untyped).
 */
int slp_entry_next(const struct slp_frame *frame, size_t *pos, struct slp_entry *ret_entry);

/* A declared name (Q of a declaration, R of an acknowledgement, E's module): 1..SLP_VALUE_MAX
 * bytes of letters, digits, '_', '.', '-'. Returns 0, -EINVAL or -EMSGSIZE. */
int slp_name_check(const char *name, size_t len);

/*
 * A named list: a declaration "N0|T<t>|Q<name>|..." (or "L0|..."), or the acknowledgement of a
 * declaration "N0|R<name>|D<value>|...". Split into frames like slp_encode_list() (each frame
 * starts "N<k>" or "L<k>" at its first position), or in exactly one frame with one_frame.
 */
struct slp_named_list {
        char dst, src;
        char head;                      /* 'N' (the list the sender sends) or 'L' (receives) */
        const char *const *names;       /* count NUL-terminated names, position 0 first */
        const enum slp_type *types;     /* declarations: the type of each name */
        const char *const *values;      /* acknowledgements: the value of each name */
        size_t count;                   /* 0: a declaration of an empty list, "N0" alone */
        size_t max_frame;               /* 0 = SLP_FRAME_DEFAULT; includes the CR LF when crlf */
        bool crlf;
        bool one_frame;                 /* -EMSGSIZE unless the whole list fits one frame */
};

/* Encodes the declaration frame that starts at *@cursor, "N<cursor>|T<t>|Q<name>..." with every
 * entry typed (never the untyped double); same contract as slp_encode_list(). An empty list
 * gives one frame "N0" (or "L0"): the peer learns the list is empty. -EINVAL also for a head
 * other than N/L, a bad name or a type outside enum slp_type. */
int slp_encode_declaration(const struct slp_named_list *list, size_t *cursor, char *buf,
                           size_t size);

/* Encodes the acknowledgement frame that starts at *@cursor, "N<cursor>|R<name>|D<value>..."
 * (values may be empty); same contract as slp_encode_declaration(). */
int slp_encode_acknowledgement(const struct slp_named_list *list, size_t *cursor, char *buf,
                               size_t size);

/* Encodes "N?" (@head 'N': send me your N list) or "L?" ('L'); returns the length or an error. */
int slp_encode_list_query(char *buf, size_t size, char dst, char src, char head, unsigned flags);

/* Encodes "E<module>|D<text>" (NUL-terminated; module as slp_name_check(), text the wire charset,
 * at most SLP_VALUE_MAX bytes, may be empty); returns the length or an error. A bare module
 * request (slp_p4_bare_request: MUI, MUO, ML, MW) goes out bare, "MUI", and takes no text
 * (-EINVAL). */
int slp_encode_command(char *buf, size_t size, char dst, char src, const char *module,
                       const char *text, unsigned flags);

/* Length of a list frame "[:AB|N0" ... "|C" hh "]" [CR LF] whose fields after the N0 take
 * @fields_len bytes (each "|", a letter and its value): what a configuration check needs. */
size_t slp_list_frame_len(size_t fields_len, bool crlf);

/* Encodes the whole list in one frame starting "N0" (compression and changed as in
 * slp_encode_list()); returns its length, -EMSGSIZE when it cannot fit max_frame, -ENOSPC when
 * it fits max_frame but not @size, or -EINVAL for a bad value or address. */
int slp_encode_list_whole(const struct slp_list *list, char *buf, size_t size);

#endif
