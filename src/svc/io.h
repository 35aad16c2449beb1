/*
 * Whole-buffer and whole-file I/O every daemon and slctl need: write a buffer completely, read a
 * small file (a configuration, a password file) completely, with a size bound; make a directory
 * and its parents.
 */
#ifndef SHAREDLINK_SVC_IO_H
#define SHAREDLINK_SVC_IO_H

#include <stddef.h>
#include <sys/types.h>

/*
 * Writes all LEN bytes of BUF to FD, going on after short writes and EINTR; 0, or -errno of the
 * write that failed (what was written before it stays written). A non-blocking fd that is full
 * gives -EAGAIN: this is for files, pipes and sockets that block.
 */
int io_write_all(int fd, const void *buf, size_t len);

/*
 * Reads the file PATH, at most MAX bytes, into a new NUL-terminated buffer (*ret_text, freed by
 * the caller; *ret_len bytes before the NUL). 0, or -errno: -EFBIG when it is larger than MAX,
 * -EISDIR for a directory (from read(2)). Any readable file does: /dev/null reads as empty.
 */
int io_read_file(const char *path, size_t max, char **ret_text, size_t *ret_len);

/*
 * mkdir -p PATH: every missing directory of the absolute PATH is made with MODE exactly (not
 * subject to the umask: a runtime directory others must reach). 0, -ENOTDIR when PATH exists and
 * is not a directory, -ENAMETOOLONG, or -errno of the mkdir that failed.
 */
int io_mkdir_parents(const char *path, mode_t mode);

#endif
