/*
 * sharedlink-agility: the results as CSV in the reference's export format (agility_export.h).
 */
#include <errno.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "agility/agility_export.h"

#define SEP ','
#define QUOTE '"'
#define EOL "\r\n"
#define MS_PER_S 1000u
#define RESULT_COLUMNS 4        /* FaultCount, RefusalCount, IsEliminated, Placement */

static const char header[] = "CompetitorNumber,HandlerName,DogName,CountryCode,"
                             "IntermediateTime1,IntermediateTime2,IntermediateTime3,FinishTime,"
                             "FaultCount,RefusalCount,IsEliminated,Placement" EOL;

/* A growing line in the caller's buffer; overflow is sticky. */
struct line {
        char *buf;
        size_t size, len;
        bool overflow;
};

static void put(struct line *l, const char *s, size_t n)
{
        if (l->overflow || n >= l->size - l->len) {
                l->overflow = true;
                return;
        }
        memcpy(l->buf + l->len, s, n);
        l->len += n;
        l->buf[l->len] = '\0';
}

static void put_char(struct line *l, char c)
{
        put(l, &c, 1);
}

static bool needs_quotes(const char *s)
{
        size_t n = strlen(s);

        if (n > 0 && (s[0] == ' ' || s[0] == '\t' || s[n - 1] == ' ' || s[n - 1] == '\t'))
                return true;
        return strpbrk(s, ",\"\r\n") != NULL;
}

/* A separator (unless first) and the text cell s, quoted when it must be. */
static void cell(struct line *l, const char *s, bool first)
{
        if (!first)
                put_char(l, SEP);
        if (!needs_quotes(s)) {
                put(l, s, strlen(s));
                return;
        }
        put_char(l, QUOTE);
        for (; *s; s++) {
                if (*s == QUOTE)
                        put_char(l, QUOTE);
                put_char(l, *s);
        }
        put_char(l, QUOTE);
}

int agility_export_time(char *buf, size_t size, uint32_t ms, enum agility_precision p)
{
        int n = snprintf(buf, size, "%u.%03u%s", (unsigned)(ms / MS_PER_S),
                         (unsigned)(ms % MS_PER_S), p == AGILITY_PRECISION_LOW ? "~" : "");

        return n < 0 || (size_t)n >= size ? -ENOBUFS : n;
}

int agility_export_header(char *buf, size_t size)
{
        struct line l = { .buf = buf, .size = size };

        if (size == 0)
                return -ENOBUFS;
        buf[0] = '\0';
        put(&l, header, sizeof(header) - 1);
        return l.overflow ? -ENOBUFS : (int)l.len;
}

int agility_export_row(char *buf, size_t size, const struct agility_competitor *c,
                       const struct agility_result *r)
{
        struct line l = { .buf = buf, .size = size };
        char t[AGILITY_EXPORT_TIME_MAX];

        if (size == 0)
                return -ENOBUFS;
        buf[0] = '\0';
        snprintf(t, sizeof(t), "%u", (unsigned)c->number);
        cell(&l, t, true);
        cell(&l, c->handler, false);
        cell(&l, c->dog, false);
        cell(&l, c->country, false);
        for (unsigned k = 0; k < AGILITY_INTERMEDIATES_MAX; k++) {
                t[0] = '\0';
                if (r->completed && k < r->intermediates)
                        agility_export_time(t, sizeof(t), r->intermediate_ms[k],
                                            r->intermediate_precision[k]);
                cell(&l, t, false);
        }
        t[0] = '\0';
        if (r->completed && r->finished)
                agility_export_time(t, sizeof(t), r->finish_ms, r->finish_precision);
        cell(&l, t, false);
        if (r->completed) {
                snprintf(t, sizeof(t), "%u", (unsigned)r->faults);
                cell(&l, t, false);
                snprintf(t, sizeof(t), "%u", (unsigned)r->refusals);
                cell(&l, t, false);
                cell(&l, r->eliminated ? "True" : "False", false);
                t[0] = '\0';
                if (r->placement > 0)
                        snprintf(t, sizeof(t), "%u", (unsigned)r->placement);
                cell(&l, t, false);
        } else {
                for (int k = 0; k < RESULT_COLUMNS; k++)
                        cell(&l, "", false);
        }
        put(&l, EOL, sizeof(EOL) - 1);
        return l.overflow ? -ENOBUFS : (int)l.len;
}
