/*
 * sl_strerror: messages worded for what the library's calls mean by each errno value.
 */
#include <errno.h>
#include <string.h>

#include <sharedlink.h>

#include "lib/export.h"

SL_EXPORT const char *sl_strerror(int err)
{
        if (err >= 0)
                return "success";
        switch (-err) {
        case ENOENT:    return "no such variable, link or instance (is sharedlinkd running?)";
        case EINVAL:    return "invalid argument, or a value the wire cannot carry "
                               "(printable ASCII except | [ ], at most 63 bytes) or the "
                               "variable's type refuses (long, double)";
        case EPERM:     return "not an outbound variable: only the daemon writes it";
        /* Not only writes: with a group configured, reading the tables needs it too (.in is
         * 0640 then), and a non-member's sl_open fails with this. */
        case EACCES:    return "permission denied: not in the daemon's group (writes and "
                               "commands need it, and so do reads when the daemon has one)";
        case EAGAIN:    return "busy: the value kept changing or the tables are being set up; try again";
        case EBUSY:     return "another writer kept the variable busy; try again";
        case ECANCELED: return "write abandoned: the daemon took the slot back from a stalled writer";
        case ENOTCONN:  return "not connected: the daemon is not running (for a command: its "
                               "link is down)";
        case ENOBUFS:   return "buffer too small for the value";
        case ENODATA:   return "no valid value";
        case EDOM:      return "the value is not a number of that type";
        case ERANGE:    return "the value is out of range";
        case EPROTO:    return "shared-memory layout or control reply not understood (library "
                               "and daemon versions differ?)";
        case ENOSPC:    return "too many variables";
        case ENOMEM:    return "out of memory";
        case ECONNREFUSED: return "the daemon's control socket does not answer (is sharedlinkd "
                                  "running? is $SHAREDLINK_RUNTIME_DIR its runtime_dir?)";
        case ETIMEDOUT: return "timed out waiting for the answer";
        case ECONNRESET: return "the daemon closed the connection before answering";
        case ENAMETOOLONG: return "the control socket path is too long";
        case EOPNOTSUPP: return "operation not supported on this link (its protocol or role)";
        default:        return "unexpected error";
        }
}
