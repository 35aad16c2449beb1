/*
 * Replay: the transport kind that plays a recording (proto/recording.h, docs/recording.md) into a
 * link engine instead of a wire (transport.h dispatches TRANSPORT_REPLAY here).
 *
 * - The whole file is read and checked at open, bounded by REPLAY_FILE_MAX; a broken line is
 *   refused with "FILE:LINE: message" and nothing is played.
 * - Reads hand out the "<" chunks (what the daemon received), one chunk per read, at the
 *   recorded times divided by speed, counted from the open. The pace comes from a timerfd that the
 *   event loop polls (the transport's fd): it is armed for the next chunk's time, so nothing
 *   sleeps and nothing spins. Speed 0 ("max") keeps it always due: chunks go as fast as the engine
 *   takes them, still in order and one per read, CHANNEL_READ_BUDGET per wakeup like any fd.
 * - Writes (what the engine sends) are counted and dropped; the ">" chunks of the recording are the
 *   reference the end-of-replay log line compares them with.
 * - A recording of a UDP link ("# transport: udp" in its head) is played as datagrams: each "<"
 *   chunk is one read, and the link's engine is told, before it starts, to take each read as one
 *   datagram (replay_file_datagram()), as it did on the wire.
 * - At the end (the time of the recording's last line), a one-line summary is logged and reads
 *   return -ENODATA (the channel then reports "end of recording" and does not reopen), or the
 *   replay starts over when loop is set.
 */
#ifndef SHAREDLINK_DAEMON_REPLAY_H
#define SHAREDLINK_DAEMON_REPLAY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#define REPLAY_FILE_MAX         (64u << 20)     /* bytes of a recording read at open */
#define REPLAY_HEAD_MAX         4096    /* bytes read for the metadata before the first chunk */

struct replay;

/* Reads and checks the recording at path; 0, or -errno with "FILE:LINE: message" (a broken
 * line: -EBADMSG) or "FILE: reason" (-ENOENT, -EFBIG over REPLAY_FILE_MAX...) in err. */
int replay_check_file(const char *path, char *err, size_t errsz);

/* Whether the recording at path says it was made on a datagram transport ("# transport: udp"
 * among the comments before its first chunk, within REPLAY_HEAD_MAX bytes). Reads only the head;
 * false also when it cannot be read (the open then says why). */
bool replay_file_datagram(const char *path);

/* Loads path (as replay_check_file) and starts playing it now; speed 0 is "max". */
int replay_open(const char *path, double speed, bool loop, struct replay **ret_replay, char *err,
                size_t errsz);

/* Logs nothing, frees; returns NULL. NULL ok. */
struct replay *replay_close(struct replay *rp);

/* Whether the loaded recording was made on a datagram transport (as replay_file_datagram()). */
bool replay_datagram(const struct replay *rp);

/* The timerfd to poll for input. */
int replay_fd(const struct replay *rp);

/* The next "<" chunk when it is due (its length), -EAGAIN until then, -ENODATA at the end. */
ssize_t replay_read(struct replay *rp, void *buf, size_t size);

/* Counts len bytes sent by the engine and drops them; returns len. */
ssize_t replay_write(struct replay *rp, size_t len);

#endif
