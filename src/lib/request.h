/*
 * Client side of the daemon's control socket (src/proto/control.h has the wire format and parses
 * the reply lines): checking request lines before they leave (where the socket is: sockpath.h). The
 * exported functions (sl_request, sl_query, sl_circe_*) are in request.c; these are its internal
 * parts, so that the unit tests can reach them.
 */
#ifndef SL_REQUEST_H
#define SL_REQUEST_H

#include <stddef.h>

/*
 * Checks a request line with ctlp_request_check(): 1..SL_REQUEST_LINE_MAX bytes, words of
 * printable ASCII (0x21-0x7E) separated by single spaces, at most SL_REQUEST_WORDS_MAX words.
 * Returns 0, or -EINVAL with the reason in why (NUL-terminated, cut to why_size; why may be NULL).
 */
int request_line_check(const char *line, char *why, size_t why_size);

#endif
