/*
 * Control-socket line protocol (control.h has the grammar).
 */
#include "proto/control.h"

#include <errno.h>
#include <string.h>

#define WORD_DATA       "DATA"
#define WORD_OK         "OK"
#define WORD_ERR        "ERR"

bool ctlp_is_word_byte(unsigned char ch)
{
        return ch > ' ' && ch < 0x7f;
}

/* ---- Requests ----------------------------------------------------------------------------- */

enum ctlp_reason ctlp_request_check(const char *line, size_t len, size_t *ret_pos)
{
        size_t words = 1;

        if (len == 0)
                return CTLP_REASON_EMPTY;
        if (len >= CTLP_LINE_MAX)
                return CTLP_REASON_TOO_LONG;
        for (size_t i = 0; i < len; i++) {
                unsigned char ch = (unsigned char)line[i];
                enum ctlp_reason r;

                if (ctlp_is_word_byte(ch))
                        continue;
                if (ch == ' ' && i > 0 && i + 1u < len && line[i - 1] != ' ') {
                        words++;
                        continue;
                }
                r = ch == ' ' ? CTLP_REASON_BAD_SPACE : CTLP_REASON_BAD_BYTE;
                if (ret_pos)
                        *ret_pos = i;
                return r;
        }
        return words > CTLP_WORDS_MAX ? CTLP_REASON_TOO_MANY_WORDS : CTLP_REASON_NONE;
}

enum ctlp_reason ctlp_request_split(char *line, size_t len, char *argv[CTLP_WORDS_MAX + 1],
                                    int *ret_argc)
{
        char *p = line, *end = line + len;
        int argc = 0;

        if (len >= CTLP_LINE_MAX)
                return CTLP_REASON_TOO_LONG;
        for (size_t i = 0; i < len; i++)
                if (line[i] != ' ' && !ctlp_is_word_byte((unsigned char)line[i]))
                        return CTLP_REASON_BAD_BYTE;
        for (;;) {
                while (p < end && *p == ' ')
                        *p++ = '\0';
                if (p == end)
                        break;
                if (argc == CTLP_WORDS_MAX)
                        return CTLP_REASON_TOO_MANY_WORDS;
                argv[argc++] = p;
                while (p < end && *p != ' ')
                        p++;
        }
        argv[argc] = NULL;
        if (argc == 0)
                return CTLP_REASON_EMPTY;
        *ret_argc = argc;
        return CTLP_REASON_NONE;
}

void ctlp_builder_init(struct ctlp_builder *b)
{
        b->line[0] = '\0';
        b->len = 0;
        b->words = 0;
}

enum ctlp_reason ctlp_builder_add(struct ctlp_builder *b, const char *word, size_t len)
{
        size_t sep = b->len ? 1u : 0u;

        if (len == 0)
                return CTLP_REASON_EMPTY;
        for (size_t i = 0; i < len; i++)
                if (!ctlp_is_word_byte((unsigned char)word[i]))
                        return CTLP_REASON_BAD_BYTE;
        /* The line and its '\n' must fit CTLP_LINE_MAX. */
        if (b->len + sep + len > CTLP_LINE_MAX - 1u)
                return CTLP_REASON_TOO_LONG;
        if (b->words >= CTLP_WORDS_MAX)
                return CTLP_REASON_TOO_MANY_WORDS;
        if (sep)
                b->line[b->len++] = ' ';
        memcpy(b->line + b->len, word, len);
        b->len += len;
        b->line[b->len] = '\0';
        b->words++;
        return CTLP_REASON_NONE;
}

/* ---- Replies ------------------------------------------------------------------------------ */

/* Writes n in decimal at buf; returns the number of digits (at most 10). */
static size_t put_decimal(char *buf, unsigned n)
{
        char digits[10];
        size_t k = 0;

        do {
                digits[k++] = (char)('0' + n % 10u);
                n /= 10u;
        } while (n);
        for (size_t i = 0; i < k; i++)
                buf[i] = digits[k - 1u - i];
        return k;
}

size_t ctlp_reply_format(char *buf, size_t size, enum ctlp_reply_kind kind, int err,
                         const char *text)
{
        const char *word = kind == CTLP_REPLY_DATA ? WORD_DATA :
                           kind == CTLP_REPLY_OK ? WORD_OK : WORD_ERR;
        size_t len = strlen(word);

        if (!buf || size < CTLP_REPLY_HEAD_MAX)
                return 0;
        memcpy(buf, word, len);
        if (kind == CTLP_REPLY_ERR) {
                /* Unsigned negation: defined for INT_MIN too. */
                unsigned e = err < 0 ? 0u - (unsigned)err : (unsigned)err;

                buf[len++] = ' ';
                len += put_decimal(buf + len, e);
        }
        /* Room is kept for '\n' and NUL; the head always fits (CTLP_REPLY_HEAD_MAX). */
        if (text && len + 2u < size) {
                buf[len++] = ' ';
                for (; *text && len + 2u < size; text++) {
                        unsigned char ch = (unsigned char)*text;

                        buf[len++] = ch < 0x20 || ch == 0x7f ? ' ' : (char)ch;
                }
        }
        buf[len++] = '\n';
        buf[len] = '\0';
        return len;
}

/* The text after word when line starts with it and then ends or has a space; else NULL. */
static const char *after_word(const char *line, const char *word)
{
        size_t n = strlen(word);

        if (strncmp(line, word, n) != 0)
                return NULL;
        if (line[n] == '\0')
                return line + n;
        return line[n] == ' ' ? line + n + 1 : NULL;
}

int ctlp_reply_parse(const char *line, size_t len, const char **ret_text, int *ret_err)
{
        const char *text;
        unsigned err = 0;

        if (len > CTLP_REPLY_LINE_MAX || strlen(line) != len)
                return -EPROTO;         /* too long, or an embedded NUL */
        for (size_t i = 0; i < len; i++) {
                unsigned char ch = (unsigned char)line[i];

                if ((ch < ' ' && ch != '\t') || ch == 0x7f)
                        return -EPROTO;
        }
        text = after_word(line, WORD_DATA);
        if (text) {
                *ret_text = text;
                return CTLP_REPLY_DATA;
        }
        text = after_word(line, WORD_OK);
        if (text) {
                *ret_text = text;
                return CTLP_REPLY_OK;
        }
        text = after_word(line, WORD_ERR);
        if (!text || *text < '1' || *text > '9')
                return -EPROTO;
        for (; *text >= '0' && *text <= '9'; text++) {
                err = err * 10u + (unsigned)(*text - '0');
                if (err > CTLP_ERRNO_MAX)
                        return -EPROTO;
        }
        if (*text != '\0' && *text != ' ')
                return -EPROTO;
        *ret_text = *text ? text + 1 : text;
        *ret_err = (int)err;
        return CTLP_REPLY_ERR;
}
