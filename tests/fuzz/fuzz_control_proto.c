/*
 * libFuzzer target for the control-socket line protocol (src/proto/control.c).
 *
 * The input is used three ways:
 *  1. as a request line: the strict check and the daemon's split must agree (a line the strict
 *     grammar passes splits into exactly its words), every word split out is non-empty printable
 *     ASCII, and rebuilding the words with the builder gives a line the strict check passes and
 *     that splits into the same words;
 *  2. as a reply line: whatever parses must be formatted back by ctlp_reply_format() into a line
 *     that parses to the same kind, errno and text (TABs become spaces);
 *  3. as the text of a reply the daemon formats, with the kind and errno from the first bytes
 *     and a buffer size from the input: the result is one line within the buffer, and it parses.
 * Any broken invariant is a __builtin_trap().
 */
#include <errno.h>
#include <limits.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "proto/control.h"

#define CHECK(cond)                                                                            \
        do {                                                                                   \
                if (!(cond))                                                                   \
                        __builtin_trap();                                                      \
        } while (0)

#define REPLY_BUF (CTLP_REPLY_LINE_MAX + 1)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* ---- Requests ------------------------------------------------------------------------------- */

/* Rebuilds argv with the builder; it must take every word the split gave. */
static void rebuild(struct ctlp_builder *b, int argc, char *const *argv)
{
        ctlp_builder_init(b);
        for (int i = 0; i < argc; i++)
                CHECK(ctlp_builder_add(b, argv[i], strlen(argv[i])) == CTLP_REASON_NONE);
        CHECK(b->len == strlen(b->line));
        CHECK(ctlp_request_check(b->line, b->len, NULL) == CTLP_REASON_NONE);
}

static void fuzz_request(const uint8_t *data, size_t size)
{
        static char line[CTLP_LINE_MAX + 1], again[CTLP_LINE_MAX];
        static struct ctlp_builder b;
        char *argv[CTLP_WORDS_MAX + 1], *argv2[CTLP_WORDS_MAX + 1];
        size_t n = size < CTLP_LINE_MAX ? size : CTLP_LINE_MAX, pos = SIZE_MAX;
        enum ctlp_reason strict, split;
        int argc = 0, argc2 = 0;

        memcpy(line, data, n);
        line[n] = '\0';
        strict = ctlp_request_check(line, n, &pos);
        if (strict == CTLP_REASON_BAD_BYTE || strict == CTLP_REASON_BAD_SPACE)
                CHECK(pos < n);
        split = ctlp_request_split(line, n, argv, &argc);
        if (strict == CTLP_REASON_NONE)
                CHECK(split == CTLP_REASON_NONE);
        if (split != CTLP_REASON_NONE)
                return;
        CHECK(argc >= 1 && argc <= CTLP_WORDS_MAX && argv[argc] == NULL);
        for (int i = 0; i < argc; i++) {
                size_t len = strlen(argv[i]);

                CHECK(len > 0 && argv[i] >= line && argv[i] + len <= line + n);
                for (size_t k = 0; k < len; k++)
                        CHECK(ctlp_is_word_byte((unsigned char)argv[i][k]));
        }
        rebuild(&b, argc, argv);
        /* A strict line is its words joined by single spaces. */
        if (strict == CTLP_REASON_NONE)
                CHECK(b.len == n && memcmp(b.line, data, n) == 0);
        memcpy(again, b.line, b.len + 1);
        CHECK(ctlp_request_split(again, b.len, argv2, &argc2) == CTLP_REASON_NONE);
        CHECK(argc2 == argc);
        for (int i = 0; i < argc; i++)
                CHECK(strcmp(argv[i], argv2[i]) == 0);
}

/* ---- Replies -------------------------------------------------------------------------------- */

/* Parses buf[0..len) (a formatted line without its '\n'): the kind, errno and text must be these;
 * text NULL: not compared. */
static void check_parses(char *buf, size_t len, int kind, int err, const char *text)
{
        const char *got;
        int got_err = 0;

        CHECK(len > 0 && buf[len - 1] == '\n' && buf[len] == '\0');
        CHECK(memchr(buf, '\n', len - 1) == NULL);
        buf[len - 1] = '\0';
        CHECK(ctlp_reply_parse(buf, len - 1, &got, &got_err) == kind);
        if (kind == CTLP_REPLY_ERR)
                CHECK(got_err == err);
        if (text)
                CHECK(strcmp(got, text) == 0);
}

static void fuzz_reply(const uint8_t *data, size_t size)
{
        /* Room for the longest line a client takes, '\n' and NUL: the daemon's own buffer is one
         * byte shorter, so it may cut the longest text by one byte. */
        static char line[CTLP_REPLY_LINE_MAX + 2], buf[CTLP_REPLY_LINE_MAX + 2], want[REPLY_BUF];
        size_t n = size < sizeof(line) - 1 ? size : sizeof(line) - 1, len;
        const char *text = NULL;
        int err = 0, kind;

        memcpy(line, data, n);
        line[n] = '\0';
        kind = ctlp_reply_parse(line, n, &text, &err);
        if (kind < 0) {
                CHECK(kind == -EPROTO);
                return;
        }
        CHECK(kind == CTLP_REPLY_DATA || kind == CTLP_REPLY_OK || kind == CTLP_REPLY_ERR);
        CHECK(text >= line && text <= line + n);
        if (kind == CTLP_REPLY_ERR)
                CHECK(err >= 1 && err <= CTLP_ERRNO_MAX);
        /* What the daemon sends for it: the same line, TABs turned into spaces. */
        len = strlen(text);
        memcpy(want, text, len + 1);
        for (size_t i = 0; i < len; i++)
                if (want[i] == '\t')
                        want[i] = ' ';
        len = ctlp_reply_format(buf, sizeof(buf), (enum ctlp_reply_kind)kind, err, text);
        check_parses(buf, len, kind, err, want);
}

static void fuzz_format(const uint8_t *data, size_t size)
{
        static char text[REPLY_BUF + 16], buf[REPLY_BUF];
        enum ctlp_reply_kind kind;
        size_t bufsize, n, len;
        int err;

        if (size < 4)
                return;
        kind = (enum ctlp_reply_kind)(data[0] % 3u);
        err = (int)(int8_t)data[1] * 64 + data[2] % 64;         /* negative, zero and positive */
        bufsize = CTLP_REPLY_HEAD_MAX - 1u + (size_t)data[3] * 17u % (sizeof(buf) - 14u);
        data += 4;
        size -= 4;
        n = size < sizeof(text) - 1 ? size : sizeof(text) - 1;
        memcpy(text, data, n);
        text[n] = '\0';
        memset(buf, 'z', sizeof(buf));
        len = ctlp_reply_format(buf, bufsize, kind, err, n ? text : NULL);
        if (bufsize < CTLP_REPLY_HEAD_MAX) {
                CHECK(len == 0 && buf[0] == 'z');
                return;
        }
        CHECK(len >= 3 && len <= bufsize - 1);
        CHECK(buf[len + 1] == 'z' || len + 1 == sizeof(buf));   /* nothing past the NUL */
        for (size_t i = 0; i + 1 < len; i++)
                CHECK((unsigned char)buf[i] >= 0x20 && buf[i] != 0x7f);
        /* An errno outside 1..CTLP_ERRNO_MAX is formatted, but no client takes it. */
        if (kind == CTLP_REPLY_ERR && (err == 0 || err > CTLP_ERRNO_MAX || err < -CTLP_ERRNO_MAX)) {
                buf[len - 1] = '\0';
                CHECK(ctlp_reply_parse(buf, len - 1, &(const char *){ NULL }, &(int){ 0 }) ==
                      -EPROTO);
                return;
        }
        check_parses(buf, len, (int)kind, err < 0 ? -err : err, NULL);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
        fuzz_request(data, size);
        fuzz_reply(data, size);
        fuzz_format(data, size);
        return 0;
}
