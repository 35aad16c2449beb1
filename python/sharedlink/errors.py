"""Exceptions: every failure of a library call is a SharedLinkError carrying the errno (positive,
as in OSError) and sl_strerror's text; commands also carry the one line that says why (`detail`:
the daemon's message, or the argument the library refused).

The subclasses group the errno values a caller handles differently, and also derive from the
built-in exception a Python caller would expect: a missing name is a KeyError, a refused write a
PermissionError, a timeout a TimeoutError, a bad value a ValueError.
"""
import errno as _errno


class SharedLinkError(OSError):
    """A libsharedlink call failed: .errno, .strerror (sl_strerror), .detail (or None)."""

    def __init__(self, err, strerror, detail=None):
        super().__init__(err, strerror)
        self.detail = detail

    def __str__(self):
        name = _errno.errorcode.get(self.errno, str(self.errno))
        if self.detail:
            return "%s: %s (%s)" % (self.detail, self.strerror, name)
        return "%s (%s)" % (self.strerror, name)

    # OSError pickles through args (errno, strerror): keep detail too.
    def __reduce__(self):
        return (type(self), (self.errno, self.strerror, self.detail))


class NotFound(SharedLinkError, KeyError):
    """ENOENT: no such variable, link or instance (is sharedlinkd running?)."""

    # KeyError quotes its message; a plain message reads better.
    __str__ = SharedLinkError.__str__


class PermissionDenied(SharedLinkError, PermissionError):
    """EPERM (an inbound variable: only the daemon writes it) or EACCES (not in the group)."""


class NoData(SharedLinkError):
    """ENODATA: the variable has no valid value (never set, or lost)."""


class InvalidValue(SharedLinkError, ValueError):
    """EINVAL, EDOM, ERANGE: an argument or value the library or the wire refuses."""


class Busy(SharedLinkError):
    """EAGAIN, EBUSY: a writer kept the value or slot busy (try again), or a command runs."""


class NotRunning(SharedLinkError, ConnectionError):
    """ENOTCONN, ECONNREFUSED, ECONNRESET: no daemon (or, for a command, its link is down)."""


class Timeout(SharedLinkError, TimeoutError):
    """ETIMEDOUT: no answer in time (a query's peer, a command)."""


class NotSupported(SharedLinkError):
    """EOPNOTSUPP: a command for another protocol or role."""


_BY_ERRNO = {
    _errno.ENOENT: NotFound,
    _errno.EPERM: PermissionDenied,
    _errno.EACCES: PermissionDenied,
    _errno.ENODATA: NoData,
    _errno.EINVAL: InvalidValue,
    _errno.EDOM: InvalidValue,
    _errno.ERANGE: InvalidValue,
    _errno.EAGAIN: Busy,
    _errno.EBUSY: Busy,
    _errno.ENOTCONN: NotRunning,
    _errno.ECONNREFUSED: NotRunning,
    _errno.ECONNRESET: NotRunning,
    _errno.ETIMEDOUT: Timeout,
    _errno.EOPNOTSUPP: NotSupported,
}


def error_class(err):
    """The exception class for a positive errno value."""
    return _BY_ERRNO.get(err, SharedLinkError)
