/*
 * One holder at a time: a lock file, so that a second copy of a daemon on the same thing (two
 * sharedlink-mqtt on one instance and topic prefix, two sharedlink-ros2 on one instance,
 * namespace and domain) refuses to start and names the first, instead of publishing everything
 * twice and fighting over writes.
 *
 * The lock is flock(2) on "<dir>/<parts joined by '.'>.lock". The kernel drops it when its holder
 * dies, however it dies (SIGKILL, a crash): a dead daemon never blocks its successor, so nothing
 * is ever removed, and nothing stale is read. The file is never unlinked either: unlinking a lock
 * file lets two processes hold locks on two different files of one name.
 *
 * Who holds it: the holder also keeps a POSIX read lock (fcntl F_SETLK) on the whole file, and
 * F_GETLK tells anyone who can open the file the pid of a process that holds such a lock. No pid
 * is written into the file (one written there goes stale, and could not be rewritten by another
 * user), so the file needs only read access: one made by root (a daemon run by hand) still serves
 * the service's user, who can always read it (made 0644 whatever the umask). The pid is 0 when
 * the kernel cannot say: the holder is in another pid namespace, or is between its two locks.
 */
#ifndef SHAREDLINK_SVC_LOCKFILE_H
#define SHAREDLINK_SVC_LOCKFILE_H

#include <stddef.h>
#include <sys/types.h>

#define LOCKFILE_SUFFIX         ".lock"
#define LOCKFILE_MODE           0644    /* anyone who may run the daemon must be able to read it */
#define LOCKFILE_DIR_MODE       0755    /* a runtime directory made here, as sharedlinkd makes it */
#define LOCKFILE_NAME_MAX       200     /* bytes of the file name, suffix included (NAME_MAX 255) */
#define LOCKFILE_HASH_LEN       16      /* hex digits that end a name cut to LOCKFILE_NAME_MAX */
#define LOCKFILE_PATH_MAX       4096
/* Where the daemons that are clients of sharedlinkd keep theirs: the library's runtime directory
 * ($SHAREDLINK_RUNTIME_DIR, else SL_RUNTIME_DIR_DEFAULT), beside the control socket. */
#define LOCKFILE_DIR_ENV        "SHAREDLINK_RUNTIME_DIR"

struct lockfile {
        int fd;                         /* open while held; -1 */
        char path[LOCKFILE_PATH_MAX];
};

/* Not held, no path. */
void lockfile_init(struct lockfile *l);

/*
 * Names l's file: "<dir>/<parts[0]>.<parts[1]>...<LOCKFILE_SUFFIX>", each byte of a part that is
 * not a letter, a digit, '_' or '-' as %XX (so '/' and '.' in a topic or namespace cannot make
 * another name). A name longer than LOCKFILE_NAME_MAX keeps its start and ends in a hash of the
 * whole. 0, or -ENAMETOOLONG (dir too long).
 */
int lockfile_name(struct lockfile *l, const char *dir, const char *const *parts, size_t n_parts);

/*
 * Takes l's file (named by lockfile_name), making it (LOCKFILE_MODE) and its directory
 * (LOCKFILE_DIR_MODE, parents too) when missing. 0: held until lockfile_release or the process
 * ends; -EBUSY: another process holds it, its pid in *ret_holder (0: unknown, see above); or
 * -errno of what failed (-EACCES: this user may not make or read the file).
 */
int lockfile_take(struct lockfile *l, pid_t *ret_holder);

/*
 * lockfile_name in the client daemons' directory (LOCKFILE_DIR_ENV or the library's default),
 * then lockfile_take, logged: when another holds it, at err, "another PROGRAM (pid N) already
 * WHAT (lock PATH): not starting a second one" (WHAT e.g. "bridges instance vehicle to topics
 * sharedlink/vehicle/..."); any other failure with its reason. 0 or -errno.
 */
int lockfile_take_service(struct lockfile *l, const char *program, const char *what,
                          const char *const *parts, size_t n_parts);

/* Lets go (closing the file drops both locks). Not held: nothing. */
void lockfile_release(struct lockfile *l);

#endif
