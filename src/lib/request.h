/*
 * Client side of the daemon's control socket (src/daemon/control.h has the wire format): where the
 * socket is, checking request lines before they leave, and reading the reply lines. The exported
 * functions (sl_request, sl_query, sl_circe_*) are in request.c; these are its internal parts,
 * pure where they can be, so that the unit tests can feed them every kind of reply.
 */
#ifndef SL_REQUEST_H
#define SL_REQUEST_H

#include <stddef.h>

struct sl_client;

/* What one reply line is. */
enum request_reply_kind {
        REQUEST_REPLY_DATA,             /* "DATA <text>": one intermediate line */
        REQUEST_REPLY_OK,               /* "OK[ <text>]": the request succeeded */
        REQUEST_REPLY_ERR,              /* "ERR <errno> <message>": it failed */
};

/*
 * Sets up the control-socket part of a new handle: its instance name and the runtime directory
 * ($SHAREDLINK_RUNTIME_DIR, else SL_RUNTIME_DIR_DEFAULT). The handle is not shared yet.
 */
void request_init(struct sl_client *c, const char *instance);

/*
 * Checks a request line: 1..SL_REQUEST_LINE_MAX bytes, words of printable ASCII (0x21-0x7E)
 * separated by single spaces, at most SL_REQUEST_WORDS_MAX words. Returns 0, or -EINVAL with the
 * reason in why (NUL-terminated, cut to why_size; why may be NULL).
 */
int request_line_check(const char *line, char *why, size_t why_size);

/*
 * Parses one reply line (without its '\n', NUL-terminated, length len). Returns its kind, with
 * *ret_text pointing into line at the text (DATA, OK: maybe ""; ERR: the message, maybe "") and,
 * for ERR, the positive errno in *ret_err; or -EPROTO for anything else (unknown word, a control
 * byte, an errno outside 1..4095, an embedded NUL).
 */
int request_reply_parse(const char *line, size_t len, const char **ret_text, int *ret_err);

#endif
