/*
 * sharedlink-agility: the competitor list from CSV (agility_competitors.h).
 */
#include <errno.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "agility/agility_competitors.h"

#define QUOTE '"'
#define SHOWN_MAX 32            /* bytes of a bad value quoted in an error */
#define DECIMAL 10

/* The reference's separators, in its order of preference on a tie. */
static const char separators[] = { '\t', ';', ',', ':', '|' };

/* The columns this list needs (the reference's names). */
enum column {
        COL_NUMBER,
        COL_HANDLER,
        COL_DOG,
        COL_COUNTRY,
        COL_COUNT
};

static const char *const column_names[COL_COUNT] = {
        [COL_NUMBER] = "CompetitorNumber",
        [COL_HANDLER] = "HandlerName",
        [COL_DOG] = "DogName",
        [COL_COUNTRY] = "CountryCode",
};

struct parse {
        const char *file;
        const char *p, *end;            /* the text not read yet */
        unsigned line;                  /* number of the line last read */
        char *err;
        size_t err_size;
        char sep;
        /* The line last split: its cells, NUL-separated, unquoted. */
        char cells[AGILITY_CSV_LINE_MAX + 1];
        unsigned start[AGILITY_CSV_COLUMNS_MAX];
        unsigned ncells;
};

__attribute__((format(printf, 2, 3)))
static int fail(struct parse *ps, const char *fmt, ...)
{
        char msg[AGILITY_CSV_ERROR_SIZE];
        va_list ap;

        va_start(ap, fmt);
        vsnprintf(msg, sizeof(msg), fmt, ap);
        va_end(ap);
        /* An empty text fails before its first line: call it line 1. */
        if (ps->err_size > 0)
                snprintf(ps->err, ps->err_size, "%s:%u: %s", ps->file,
                         ps->line ? ps->line : 1, msg);
        return -EINVAL;
}

/* A bad value as it may appear in an error: at most SHOWN_MAX bytes, unprintables as '?'. */
static const char *shown(const char *s, char *buf)
{
        size_t i = 0;

        for (; s[i] != '\0' && i < SHOWN_MAX; i++)
                buf[i] = (s[i] >= ' ' && s[i] < 0x7f) ? s[i] : '?';
        buf[i] = '\0';
        return buf;
}

/* The next line without its end into *ret, *ret_len; false at the end of the text. */
static int next_line(struct parse *ps, const char **ret, size_t *ret_len)
{
        if (ps->p >= ps->end)
                return 0;
        const char *s = ps->p;
        const char *e = s;

        while (e < ps->end && *e != '\n' && *e != '\r')
                e++;
        ps->line++;
        ps->p = e;
        if (ps->p < ps->end && *ps->p == '\r')
                ps->p++;
        if (ps->p < ps->end && *ps->p == '\n')
                ps->p++;
        *ret = s;
        *ret_len = (size_t)(e - s);
        if (memchr(s, '\0', *ret_len))
                return fail(ps, "a NUL byte in the line");
        if (*ret_len > AGILITY_CSV_LINE_MAX)
                return fail(ps, "line longer than %d bytes", AGILITY_CSV_LINE_MAX);
        return 1;
}

static bool blank(const char *s, size_t len)
{
        for (size_t i = 0; i < len; i++)
                if (s[i] != ' ' && s[i] != '\t')
                        return false;
        return true;
}

static bool space(const struct parse *ps, char c)
{
        return c == ' ' || (c == '\t' && ps->sep != '\t');
}

/* Splits line into ps->cells / start / ncells: 0 or -EINVAL. */
static int split(struct parse *ps, const char *s, size_t len)
{
        size_t i = 0, o = 0;

        ps->ncells = 0;
        for (;;) {
                if (ps->ncells == AGILITY_CSV_COLUMNS_MAX)
                        return fail(ps, "more than %d cells", AGILITY_CSV_COLUMNS_MAX);
                ps->start[ps->ncells++] = (unsigned)o;
                while (i < len && space(ps, s[i]))
                        i++;
                if (i < len && s[i] == QUOTE) {
                        for (i++;; i++) {
                                if (i == len)
                                        return fail(ps, "a quote that does not close");
                                if (s[i] == QUOTE && i + 1 < len && s[i + 1] == QUOTE)
                                        ps->cells[o++] = s[i++];
                                else if (s[i] == QUOTE)
                                        break;
                                else
                                        ps->cells[o++] = s[i];
                        }
                        for (i++; i < len && space(ps, s[i]); i++)
                                ;
                        if (i < len && s[i] != ps->sep)
                                return fail(ps, "text after a closing quote");
                } else {
                        size_t first = o;

                        for (; i < len && s[i] != ps->sep; i++) {
                                if (s[i] == QUOTE)
                                        return fail(ps, "a quote inside an unquoted cell");
                                ps->cells[o++] = s[i];
                        }
                        while (o > first && space(ps, ps->cells[o - 1]))
                                o--;
                }
                ps->cells[o++] = '\0';
                if (i == len)
                        return 0;
                i++;                    /* the separator */
        }
}

static const char *cell(const struct parse *ps, unsigned index)
{
        return &ps->cells[ps->start[index]];
}

static char pick_separator(const char *s, size_t len)
{
        char best = separators[0];
        size_t best_count = 0;

        for (size_t k = 0; k < sizeof(separators); k++) {
                size_t count = 0;

                for (size_t i = 0; i < len; i++)
                        count += s[i] == separators[k];
                if (count > best_count) {
                        best = separators[k];
                        best_count = count;
                }
        }
        return best;
}

/* Reads the header: the index of each needed column into col. */
static int header(struct parse *ps, unsigned col[COL_COUNT])
{
        const char *s;
        size_t len;
        int r;

        while ((r = next_line(ps, &s, &len)) > 0 && blank(s, len))
                ;
        if (r < 0)
                return r;
        if (r == 0)
                return fail(ps, "no header line (CompetitorNumber, HandlerName, DogName, "
                                "CountryCode)");
        ps->sep = pick_separator(s, len);
        if ((r = split(ps, s, len)) < 0)
                return r;
        for (int c = 0; c < COL_COUNT; c++) {
                bool found = false;

                for (unsigned i = 0; i < ps->ncells; i++) {
                        if (strcasecmp(cell(ps, i), column_names[c]) != 0)
                                continue;
                        if (found)
                                return fail(ps, "column %s appears twice", column_names[c]);
                        col[c] = i;
                        found = true;
                }
                if (!found)
                        return fail(ps, "no column %s in the header", column_names[c]);
        }
        return 0;
}

static int number(struct parse *ps, const char *s, uint16_t *ret)
{
        char buf[SHOWN_MAX + 1];
        unsigned v = 0;
        size_t i = 0;

        for (; s[i] >= '0' && s[i] <= '9'; i++)
                if (v <= CIRCE_COMPETITOR_MAX)
                        v = v * DECIMAL + (unsigned)(s[i] - '0');
        if (i == 0 || s[i] != '\0' || v < 1 || v > CIRCE_COMPETITOR_MAX)
                return fail(ps, "competitor number '%s' is not a number 1..%d", shown(s, buf),
                            CIRCE_COMPETITOR_MAX);
        *ret = (uint16_t)v;
        return 0;
}

static int text(struct parse *ps, const char *what, const char *s, bool may_be_empty,
                char *out, size_t size)
{
        size_t len = strlen(s);

        if (len == 0 && !may_be_empty)
                return fail(ps, "%s is empty", what);
        if (len >= size)
                return fail(ps, "%s longer than %zu bytes", what, size - 1);
        for (size_t i = 0; i < len; i++)
                if ((unsigned char)s[i] < ' ' || s[i] == 0x7f)
                        return fail(ps, "%s holds a control character", what);
        memcpy(out, s, len + 1);
        return 0;
}

static int row(struct parse *ps, const unsigned col[COL_COUNT], struct agility_competitor *c)
{
        int r;

        if ((r = number(ps, cell(ps, col[COL_NUMBER]), &c->number)) < 0 ||
            (r = text(ps, "handler name", cell(ps, col[COL_HANDLER]), false, c->handler,
                      sizeof(c->handler))) < 0 ||
            (r = text(ps, "dog name", cell(ps, col[COL_DOG]), false, c->dog,
                      sizeof(c->dog))) < 0 ||
            (r = text(ps, "country code", cell(ps, col[COL_COUNTRY]), true, c->country,
                      sizeof(c->country))) < 0)
                return r;
        return 0;
}

int agility_competitors_parse(const char *file, const char *buf, size_t len,
                              struct agility_competitor *out, size_t cap, size_t *ret_count,
                              char *err, size_t err_size)
{
        static const char bom[] = "\xef\xbb\xbf";
        struct parse ps = { .file = file, .p = buf, .end = buf + len, .err = err,
                            .err_size = err_size };
        unsigned seen[CIRCE_COMPETITOR_MAX + 1] = { 0 };        /* line of each number */
        unsigned col[COL_COUNT], header_cells;
        const char *s;
        size_t n = 0, slen;
        int r;

        if (err_size > 0)
                err[0] = '\0';
        if (len >= sizeof(bom) - 1 && memcmp(buf, bom, sizeof(bom) - 1) == 0)
                ps.p += sizeof(bom) - 1;
        if ((r = header(&ps, col)) < 0)
                return r;
        header_cells = ps.ncells;
        while ((r = next_line(&ps, &s, &slen)) > 0) {
                struct agility_competitor c;

                if (blank(s, slen))
                        continue;
                if ((r = split(&ps, s, slen)) < 0)
                        return r;
                if (ps.ncells != header_cells)
                        return fail(&ps, "%u cells, but the header has %u", ps.ncells,
                                    header_cells);
                if ((r = row(&ps, col, &c)) < 0)
                        return r;
                if (seen[c.number])
                        return fail(&ps, "competitor number %u is already on line %u",
                                    (unsigned)c.number, seen[c.number]);
                if (n == cap) {
                        fail(&ps, "more than %zu competitors", cap);
                        return -ENOSPC;
                }
                seen[c.number] = ps.line;
                out[n++] = c;
        }
        if (r < 0)
                return r;
        if (n == 0)
                return fail(&ps, "no competitor after the header");
        *ret_count = n;
        return 0;
}

const struct agility_competitor *agility_competitors_find(const struct agility_competitor *list,
                                                          size_t n, uint16_t number)
{
        for (size_t i = 0; i < n; i++)
                if (list[i].number == number)
                        return &list[i];
        return NULL;
}
