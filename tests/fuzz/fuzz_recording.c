/*
 * libFuzzer target for the recording format (src/proto/recording.c).
 *
 * The input is used two ways:
 *  1. as one line: whatever rec_parse_line() takes (a chunk line) is formatted back by
 *     rec_format_chunk() into a line that parses to the same time, direction, "+" and bytes;
 *  2. as a whole recording: rec_parse_text() either refuses it with a message and a line number
 *     within the text, or every chunk it hands out is written again, piece by piece, into a new
 *     recording that parses to the same chunks (count and bytes).
 * Any broken invariant is a __builtin_trap().
 */
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "proto/recording.h"
#include "fuzz_input.h"

#define FUZZ_TEXT_MAX   (64 * 1024)     /* the rewritten recording */

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

struct rewrite {
        char *text;
        size_t len, cap;
        size_t chunks, bytes;
        bool full;
};

static void fuzz_line(const uint8_t *data, size_t size)
{
        static struct rec_line a, b;
        static char line[REC_LINE_MAX + 1];
        const char *why = NULL;
        size_t used, len;

        if (rec_parse_line((const char *)data, size, &a, &why) < 0) {
                CHECK(why && *why);
                return;
        }
        if (a.comment)
                return;
        len = rec_format_chunk(line, a.t_us, a.dir, a.more, a.data, a.len, &used);
        CHECK(used == a.len && len <= REC_LINE_MAX && strlen(line) == len);
        CHECK(rec_parse_line(line, len, &b, &why) == 0);
        CHECK(!b.comment && b.t_us == a.t_us && b.dir == a.dir && b.more == a.more);
        CHECK(b.len == a.len && memcmp(b.data, a.data, a.len) == 0);
}

/* Writes each chunk again as pieces, while it fits. */
static int rewrite_chunk(void *arg, const struct rec_reader *r)
{
        struct rewrite *w = arg;
        size_t off = 0, used;

        w->chunks++;
        w->bytes += r->len;
        do {
                if (w->cap - w->len < REC_LINE_MAX + 2) {
                        w->full = true;
                        return 0;
                }
                w->len += rec_format_chunk(w->text + w->len, r->last_t_us, r->dir,
                                           r->len - off > REC_PIECE_MAX, r->chunk + off,
                                           r->len - off, &used);
                w->text[w->len++] = '\n';
                off += used;
        } while (off < r->len);
        return 0;
}

static void fuzz_text(const uint8_t *data, size_t size)
{
        struct rec_reader *r = malloc(sizeof(*r)), *r2 = malloc(sizeof(*r2));
        struct rewrite w = { .cap = FUZZ_TEXT_MAX }, w2 = { .cap = FUZZ_TEXT_MAX };
        int k;

        w.text = malloc(w.cap);
        w2.text = malloc(w2.cap);
        CHECK(r && r2 && w.text && w2.text);
        rec_reader_init(r);
        w.len = (size_t)(stpcpy(w.text, REC_HEADER "\n") - w.text);
        k = rec_parse_text(r, (const char *)data, size, rewrite_chunk, &w);
        if (k < 0) {
                CHECK(r->why[0] != '\0');
                CHECK(r->line_no >= 1 || size == 0);
        } else if (!w.full) {
                rec_reader_init(r2);
                CHECK(rec_parse_text(r2, w.text, w.len, rewrite_chunk, &w2) == 0);
                CHECK(w2.chunks == w.chunks && w2.bytes == w.bytes);
        }
        free(w2.text);
        free(w.text);
        free(r2);
        free(r);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        fuzz_line(data, size);
        fuzz_text(data, size);
        return 0;
}
