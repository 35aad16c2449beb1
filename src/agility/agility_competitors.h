/*
 * sharedlink-agility: the competitor list, imported from CSV (docs/agility.md "Competitors").
 *
 * The reference controller's import format: a header line naming the columns, then one
 * competitor per line. Columns CompetitorNumber, HandlerName, DogName and CountryCode must be
 * there (any order, names matched without regard to case); other columns, such as the results
 * of the reference's own export, are ignored. The separator is the one of TAB ; , : | that the
 * header line holds most often (the reference's rule). A cell may be quoted ("..."), with ""
 * for a quote inside; unquoted cells are trimmed. Empty lines are skipped; CRLF and LF both end
 * a line; a UTF-8 byte order mark is skipped.
 *
 * Numbers are 1..999 and unique; handler and dog are not empty; the country may be. A line that
 * breaks a rule is an error "FILE:LINE: message" and the whole list is refused: nothing half
 * imported.
 *
 * Pure code: no syscalls, no allocation, no logging; the caller reads the file and owns the
 * array.
 */
#ifndef SHAREDLINK_AGILITY_COMPETITORS_H
#define SHAREDLINK_AGILITY_COMPETITORS_H

#include <stddef.h>
#include <stdint.h>

#include "proto/circe.h"

#define AGILITY_COMPETITORS_MAX CIRCE_COMPETITOR_MAX    /* numbers 1..999: at most 999 */
#define AGILITY_NAME_SIZE 64            /* handler or dog name, bytes + NUL */
#define AGILITY_COUNTRY_SIZE 8          /* country code, bytes + NUL */
#define AGILITY_CSV_LINE_MAX 1024       /* bytes of one line, without its end */
#define AGILITY_CSV_COLUMNS_MAX 32      /* columns of the header */
#define AGILITY_CSV_ERROR_SIZE 256      /* "FILE:LINE: message" + NUL */

struct agility_competitor {
        uint16_t number;                /* 1..999 */
        char handler[AGILITY_NAME_SIZE];
        char dog[AGILITY_NAME_SIZE];
        char country[AGILITY_COUNTRY_SIZE];
};

/*
 * Parses the CSV text buf (len bytes; file names it in errors) into out (room for cap) and
 * their number into *ret_count, in file order. Returns 0, or -EINVAL with "FILE:LINE: message"
 * in err (err_size bytes, may be 0) when the text breaks a rule, is empty or lists no
 * competitor, or -ENOSPC when it lists more than cap. *ret_count and out are meaningful only
 * on success.
 */
int agility_competitors_parse(const char *file, const char *buf, size_t len,
                              struct agility_competitor *out, size_t cap, size_t *ret_count,
                              char *err, size_t err_size);

/* The competitor with number in list (n entries), or NULL. */
const struct agility_competitor *agility_competitors_find(const struct agility_competitor *list,
                                                          size_t n, uint16_t number);

#endif
