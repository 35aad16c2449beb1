/*
 * Recordings of a link's traffic (docs/recording.md has the format byte for byte): what
 * `slctl record` writes and the replay transport reads. Pure code: no syscalls, no allocation,
 * no logging; the caller owns every buffer. Prefix rec_.
 *
 *      file    = header LF *( ( comment / chunk ) LF )
 *      header  = "# sharedlink recording 1"
 *      comment = "#" *( HTAB / %x20-7E )             ; metadata, "# dropped N chunks"
 *      chunk   = time SP dir SP bytes
 *      time    = seconds "." 6DIGIT                  ; CLOCK_MONOTONIC since the start
 *      seconds = "0" / %x31-39 *DIGIT                ; at most REC_SECONDS_DIGITS digits
 *      dir     = ( "<" / ">" ) [ "+" ]               ; < received, > sent; + continued
 *      bytes   = 1*( %x21-5B / %x5D-7E / "\s" / "\\" / "\r" / "\n" / "\t" / "\x" 2LHEX )
 *
 * One line carries at most REC_PIECE_MAX bytes of a chunk, so that a line always fits one DATA
 * line of the control socket. A longer chunk (a large datagram, a big read) is cut into pieces:
 * every piece but the last has "+" after its direction, and the pieces share time and direction.
 * Times never decrease.
 */
#ifndef SHAREDLINK_PROTO_RECORDING_H
#define SHAREDLINK_PROTO_RECORDING_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define REC_HEADER              "# sharedlink recording 1"
#define REC_DROPPED_PREFIX      "# dropped "            /* "# dropped N chunks" */
#define REC_TRANSPORT_PREFIX    "# transport: "         /* the recorded link's transport */
#define REC_TRANSPORT_DATAGRAM  "udp"   /* a transport whose chunks are datagrams */
#define REC_PIECE_MAX           1000    /* chunk bytes one line carries */
#define REC_CHUNK_MAX           8192    /* bytes of one whole chunk (TRANSPORT_DATAGRAM_MAX) */
#define REC_SECONDS_DIGITS      10      /* time: seconds before the point */
#define REC_MICROS_DIGITS       6
#define REC_ESCAPE_MAX          4       /* "\xHH": the longest form of one byte */
/* The longest chunk line: time, SP, dir, SP, escaped piece (no '\n'). */
#define REC_LINE_MAX            (REC_SECONDS_DIGITS + 1 + REC_MICROS_DIGITS + 1 + 2 + 1 + \
                                 REC_PIECE_MAX * REC_ESCAPE_MAX)
#define REC_WHY_MAX             96      /* a parse error message, NUL included */
#define REC_META_MAX            32      /* a metadata value the reader keeps, NUL included */

enum rec_dir {
        REC_DIR_IN,                     /* '<': the daemon received it from the wire */
        REC_DIR_OUT,                    /* '>': the daemon sent it */
};

/* Escapes data[0..len) into out (room for len * REC_ESCAPE_MAX bytes and a NUL); returns the
 * length written, without the NUL. */
size_t rec_escape(char *out, const uint8_t *data, size_t len);

/*
 * Formats one chunk line (no '\n', NUL-terminated) from at most REC_PIECE_MAX bytes of data:
 * t_us microseconds since the start, dir, and "+" when more pieces of the chunk follow. out needs
 * REC_LINE_MAX + 1 bytes. Returns the line's length; *ret_used gets how many bytes it took.
 */
size_t rec_format_chunk(char *out, uint64_t t_us, enum rec_dir dir, bool more,
                        const uint8_t *data, size_t len, size_t *ret_used);

/* One line read (rec_parse_line). */
struct rec_line {
        bool comment;                   /* a '#' line: nothing else is set */
        uint64_t t_us;
        enum rec_dir dir;
        bool more;                      /* "+": the chunk goes on on the next line */
        size_t len;
        uint8_t data[REC_PIECE_MAX];
};

/*
 * Parses one line (without its '\n'; len bytes, NULs included) on its own, without looking at
 * the lines around it. 0, or -EINVAL with a static message in *ret_why.
 */
int rec_parse_line(const char *line, size_t len, struct rec_line *ret, const char **ret_why);

/* A whole recording read line by line: the rules between lines and the chunks they make. */
struct rec_reader {
        unsigned line_no;               /* of the last line fed, 1-based */
        bool header_seen;
        bool continuing;                /* the last piece had "+" */
        uint64_t last_t_us;
        uint64_t dropped;               /* the sum of "# dropped N chunks" comments */
        bool chunk_seen;                /* a chunk line came: metadata is over */
        char transport[REC_META_MAX];   /* of the first "# transport: X" before any chunk
                                         * ("" when none, or when X is longer) */
        enum rec_dir dir;               /* of the chunk being assembled */
        size_t len;
        uint8_t chunk[REC_CHUNK_MAX];
        char why[REC_WHY_MAX];          /* the message of the last error */
};

/* Empties r for a new recording. */
void rec_reader_init(struct rec_reader *r);

/*
 * Feeds the next line (without its '\n'). Returns 1 with a whole chunk in r->chunk[0..r->len),
 * r->dir and r->last_t_us (valid until the next call); 0 for a comment or a piece that the next
 * line continues; -EINVAL for a broken line, the message in r->why and the line in r->line_no.
 */
int rec_reader_line(struct rec_reader *r, const char *line, size_t len);

/* Whether the recording read so far says its chunks were datagrams ("# transport: udp"). */
bool rec_reader_datagram(const struct rec_reader *r);

/* The recording ended: 0, or -EINVAL (no header, a chunk cut after "+") with r->why set. */
int rec_reader_end(struct rec_reader *r);

/*
 * Splits text[0..len) into lines and feeds them to r: for each whole chunk, fn(arg, r) when fn
 * is not NULL (a negative return stops with it). Every line must end with '\n' and hold at most
 * REC_LINE_MAX bytes. 0, or -EINVAL with r->why and r->line_no naming the broken line.
 */
int rec_parse_text(struct rec_reader *r, const char *text, size_t len,
                   int (*fn)(void *arg, const struct rec_reader *r), void *arg);

#endif
