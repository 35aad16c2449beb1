/*
 * sharedlink-agility: the results as CSV, in the reference controller's export format
 * (docs/agility.md "Export"), so a club can take them into its own tools or back into the
 * reference.
 *
 * Columns, in this order: CompetitorNumber, HandlerName, DogName, CountryCode,
 * IntermediateTime1, IntermediateTime2, IntermediateTime3, FinishTime, FaultCount,
 * RefusalCount, IsEliminated, Placement. One row per competitor in list order; a competitor
 * without a completed run has only the first four. Times are seconds with three decimals
 * ("27.000"), a low-precision time ends in "~" ("27.040~"); IsEliminated is True or False;
 * Placement is empty when not placed. Separator ",", a cell holding a separator, a quote, a
 * line end or leading or trailing whitespace is quoted with "" for a quote; lines end CRLF
 * (RFC 4180). The reference writes times and booleans the same way (invariant culture).
 *
 * Pure code: no syscalls, no allocation, no logging; the caller writes the lines.
 */
#ifndef SHAREDLINK_AGILITY_EXPORT_H
#define SHAREDLINK_AGILITY_EXPORT_H

#include <stddef.h>
#include <stdint.h>

#include "agility/agility_competitors.h"
#include "agility/agility_rank.h"
#include "agility/agility_timing.h"

/* A row is at most 3 quoted names of 2 * 63 bytes + 2 quotes, and 8 short fields: 512 is
 * ample. */
#define AGILITY_EXPORT_LINE_MAX 512
#define AGILITY_EXPORT_TIME_MAX 16      /* "4294967.295~" + NUL */

/* The header line with its CRLF into buf; its length, or -ENOBUFS. */
int agility_export_header(char *buf, size_t size);

/* The row of competitor c with result r (r->completed false: no run) and its CRLF into buf;
 * its length, or -ENOBUFS. */
int agility_export_row(char *buf, size_t size, const struct agility_competitor *c,
                       const struct agility_result *r);

/* A time as the reference writes it ("27.000", "27.040~") into buf; its length or -ENOBUFS. */
int agility_export_time(char *buf, size_t size, uint32_t ms, enum agility_precision p);

#endif
