/*
 * Client side of the daemon's control socket (src/proto/control.h has the wire format and parses
 * the reply lines): where the socket is, and checking request lines before they leave. The
 * exported functions (sl_request, sl_query, sl_circe_*) are in request.c; these are its internal
 * parts, so that the unit tests can reach them.
 */
#ifndef SL_REQUEST_H
#define SL_REQUEST_H

#include <stddef.h>

struct shm_in_header;
struct sl_client;

/*
 * Sets up the control-socket part of a new handle: its instance name and the runtime directory
 * ($SHAREDLINK_RUNTIME_DIR, else SL_RUNTIME_DIR_DEFAULT). The handle is not shared yet.
 */
void request_init(struct sl_client *c, const char *instance);

/*
 * The control socket path that header h publishes (layout 1.2), checked as hostile input: a NUL
 * within the field, an absolute path naming "<instance>.sock", no control byte. Copies it into
 * buf (size >= SHM_SOCKET_PATH_SIZE) and returns 0; -ENOENT when h publishes none (an older
 * daemon), -EINVAL when the field is not such a path.
 */
int request_published_socket(const struct shm_in_header *h, const char *instance, char *buf,
                             size_t size);

/*
 * Checks a request line with ctlp_request_check(): 1..SL_REQUEST_LINE_MAX bytes, words of
 * printable ASCII (0x21-0x7E) separated by single spaces, at most SL_REQUEST_WORDS_MAX words.
 * Returns 0, or -EINVAL with the reason in why (NUL-terminated, cut to why_size; why may be NULL).
 */
int request_line_check(const char *line, char *why, size_t why_size);

#endif
