/*
 * Control-socket line protocol (DESIGN.md §2.6): the grammar both ends of `<instance>.sock` speak.
 * The daemon (src/daemon/control.c) splits requests and formats replies with it; the library
 * (src/lib/request.c) builds requests and parses replies with it. Pure code: no syscalls, no
 * allocation, no logging, no global state; the caller owns every buffer.
 *
 * Names carry the prefix ctlp_ / CTLP_ ("control protocol"): control_ is the daemon's server.
 *
 *      request = word *( SP word ) LF          ; at most CTLP_LINE_MAX bytes, LF included
 *      word    = 1*( %x21-7E )                 ; at most CTLP_WORDS_MAX words
 *      reply   = *( "DATA" [ SP text ] LF ) ( "OK" [ SP text ] / "ERR" SP errno [ SP text ] ) LF
 *      errno   = %x31-39 *DIGIT                ; 1..CTLP_ERRNO_MAX, decimal
 *      text    = *( HTAB / %x20-7E )           ; a reply line is at most CTLP_REPLY_LINE_MAX
 *                                              ; bytes, LF not included
 *
 * Be strict in what you send, liberal in what you accept: a client sends words separated by
 * single spaces (ctlp_request_check, struct ctlp_builder); the daemon also takes runs of spaces
 * and leading or trailing ones (ctlp_request_split). The daemon turns every control byte of a
 * reply's text into a space (ctlp_reply_format), so one reply line is always one line.
 */
#ifndef SHAREDLINK_PROTO_CONTROL_H
#define SHAREDLINK_PROTO_CONTROL_H

#include <stdbool.h>
#include <stddef.h>

/* ---- Limits ------------------------------------------------------------------------------- */

#define CTLP_LINE_MAX           1024    /* request line, '\n' included */
#define CTLP_WORDS_MAX          32      /* words of one request */
#define CTLP_REPLY_LINE_MAX     4095    /* reply line, '\n' not included */
#define CTLP_ERRNO_MAX          4095    /* largest errno of an ERR line (the kernel's MAX_ERRNO) */
/* A command to a link that is down may end in "wait=MS": the engine then waits up to MS (at most
 * CTLP_WAIT_MAX_MS) for the link instead of failing at once with ENOTCONN. */
#define CTLP_WAIT_PREFIX        "wait="
#define CTLP_WAIT_MAX_MS        60000
/* Smallest buffer ctlp_reply_format() writes into: "ERR 4294967295" '\n' NUL. */
#define CTLP_REPLY_HEAD_MAX     16

/* ---- Requests ----------------------------------------------------------------------------- */

/* Why a request line or word is refused. */
enum ctlp_reason {
        CTLP_REASON_NONE = 0,
        CTLP_REASON_EMPTY,              /* no word at all (or an empty word) */
        CTLP_REASON_TOO_LONG,           /* the line would pass CTLP_LINE_MAX with its '\n' */
        CTLP_REASON_BAD_BYTE,           /* a byte outside printable ASCII (NUL, TAB, CR, 0x7F..) */
        CTLP_REASON_BAD_SPACE,          /* strict grammar: a leading, trailing or double space */
        CTLP_REASON_TOO_MANY_WORDS,     /* more than CTLP_WORDS_MAX words */
};

/* True for the bytes a word is made of (printable ASCII but space, 0x21-0x7E). */
bool ctlp_is_word_byte(unsigned char ch);

/*
 * Checks line[0..len) (no '\n') against the strict grammar a client sends. Returns
 * CTLP_REASON_NONE, or the first reason it fails with the offset of the offending byte in
 * *ret_pos (BAD_BYTE and BAD_SPACE; ret_pos may be NULL). A NUL inside len is a BAD_BYTE.
 */
enum ctlp_reason ctlp_request_check(const char *line, size_t len, size_t *ret_pos);

/*
 * Splits line[0..len) (no '\n'; line[len] must be a NUL) in place into words, the liberal way
 * the daemon reads: runs of spaces separate words, leading and trailing ones are ignored. The
 * spaces become NULs; argv[0..argc) point into line and argv[argc] is NULL. Returns
 * CTLP_REASON_NONE with *ret_argc >= 1, or EMPTY, TOO_LONG, BAD_BYTE (a NUL inside len too) or
 * TOO_MANY_WORDS (line then partly split: scratch).
 */
enum ctlp_reason ctlp_request_split(char *line, size_t len, char *argv[CTLP_WORDS_MAX + 1],
                                    int *ret_argc);

/* A request under construction, word by word; line is always NUL-terminated, without '\n'. */
struct ctlp_builder {
        char line[CTLP_LINE_MAX];
        size_t len;
        unsigned words;
};

/* Empties b. */
void ctlp_builder_init(struct ctlp_builder *b);

/*
 * Appends word[0..len) (with a space before it unless it is the first). Returns
 * CTLP_REASON_NONE, or EMPTY (len 0), BAD_BYTE (a space or a byte outside printable ASCII),
 * TOO_LONG or TOO_MANY_WORDS, checked in that order; b is unchanged on failure.
 */
enum ctlp_reason ctlp_builder_add(struct ctlp_builder *b, const char *word, size_t len);

/* ---- Replies ------------------------------------------------------------------------------ */

/* What one reply line is. */
enum ctlp_reply_kind {
        CTLP_REPLY_DATA,                /* "DATA[ <text>]": one intermediate line */
        CTLP_REPLY_OK,                  /* "OK[ <text>]": the request succeeded, final */
        CTLP_REPLY_ERR,                 /* "ERR <errno>[ <text>]": it failed, final */
};

/*
 * Writes one reply line, '\n' and a NUL into buf: the kind's word ("ERR" followed by err as a
 * positive decimal; err may be given positive or negative), then " <text>" unless text is NULL.
 * The text is cut so that the line with its '\n' takes at most size - 1 bytes, and its control
 * bytes become spaces. Returns the length without the NUL; size must be at least
 * CTLP_REPLY_HEAD_MAX (else nothing is written and 0 returned).
 */
size_t ctlp_reply_format(char *buf, size_t size, enum ctlp_reply_kind kind, int err,
                         const char *text);

/*
 * Parses one reply line (without its '\n', NUL-terminated, length len). Returns its kind, with
 * *ret_text pointing into line at the text (DATA, OK: maybe ""; ERR: the message, maybe "") and,
 * for ERR, the errno (1..CTLP_ERRNO_MAX) in *ret_err; or -EPROTO for anything else (unknown
 * word, a control byte other than TAB, a bad errno, an embedded NUL, longer than
 * CTLP_REPLY_LINE_MAX).
 */
int ctlp_reply_parse(const char *line, size_t len, const char **ret_text, int *ret_err);

#endif
