"""sharedlink: read and write the shared variables of a running sharedlinkd from Python.

A thin ctypes binding of libsharedlink.so.1 (no compiled extension): reads go straight to the
daemon's shared memory through the C library, commands through its control socket.

    import sharedlink

    with sharedlink.Client("vehicle") as c:     # None: $SHAREDLINK_INSTANCE, else "default"
        lat = c["AutoGpsLat"]                   # float/int/str by the variable's type; None: unset
        value, meta = c.read("AutoGpsLat")      # the text, and when/how it was updated
        c["CmdThrottle"] = 0.25                 # outbound: the daemon sends it to the peer
        for name in c.wait(["AutoGpsLat"], timeout=1.0):   # until one of them changes
            print(name, c.read_double(name))
        for ev in c.events(follow=True):        # CIRCE actions, link states, ...
            print(ev.seq, ev.link, ev.type, ev.fields)

Every failure raises a SharedLinkError subclass carrying the errno and sl_strerror's text (see
sharedlink.errors). Library lookup: $SHAREDLINK_LIB, the path `make install` recorded, then the
dynamic loader ("libsharedlink.so.1").
"""
import ctypes
import errno as _errno
import time
from typing import NamedTuple, Optional

from . import _lib
from ._lib import (SL_DIR_IN, SL_DIR_OUT, SL_FLAG_OUTBOUND, SL_FLAG_REPAIRED,  # noqa: F401
                   SL_FLAG_STALE, SL_FLAG_VALID, SL_VAR_ADHOC, SL_VAR_DOUBLE, SL_VAR_LONG,
                   SL_VAR_STRING, SL_VALUE_SIZE, SL_EVENT_RESTARTED, SL_EVENT_TRUNCATED)
from .errors import (Busy, InvalidValue, NoData, NotFound, NotRunning,  # noqa: F401
                     NotSupported, PermissionDenied, SharedLinkError, Timeout, error_class)

__version__ = "0.1.0"
__all__ = ["Client", "Meta", "VarInfo", "LinkInfo", "DaemonInfo", "Event", "strerror",
           "SharedLinkError", "NotFound", "PermissionDenied", "NoData", "InvalidValue", "Busy",
           "NotRunning", "Timeout", "NotSupported"]

_lib_ = _lib.lib
_sl_read = _lib.fast.sl_read                    # unchecked: called only with exact types
_sl_read_double = _lib.fast.sl_read_double
_sl_read_long = _lib.fast.sl_read_long
_byref = ctypes.byref
_c_double = ctypes.c_double
_c_long = ctypes.c_long
_value_buf = ctypes.c_char * SL_VALUE_SIZE
_VALUE_SIZE = ctypes.c_size_t(SL_VALUE_SIZE)
_sl_meta = _lib.sl_meta
_META_SIZE = ctypes.sizeof(_lib.sl_meta)

READ_TRIES = 8                  # -EAGAIN (a writer kept the slot busy) is retried this often
WAIT_SLICE_S = 0.5              # a blocked wait returns to Python this often, so Ctrl-C works
EVENTS_BATCH = 16               # events fetched per sl_events_read
_REPLY_SIZE = _lib.SL_REPLY_LINE_MAX + 1
_MS = 1000.0


def strerror(err):
    """sl_strerror's text for an errno value (positive or negative)."""
    return _lib_.sl_strerror(-abs(err)).decode("ascii", "replace")


def _raise(r, detail=None):
    err = -r
    raise error_class(err)(err, strerror(err), detail or None)


def _text(raw):
    return raw.decode("ascii", "replace")


def _word(s, what="argument"):
    """str/bytes -> bytes for a char * argument; a NUL would cut it short silently, so refuse."""
    if isinstance(s, str):
        s = s.encode("utf-8")
    elif not isinstance(s, (bytes, bytearray)):
        raise TypeError("%s must be str, not %s" % (what, type(s).__name__))
    if b"\0" in s:
        raise InvalidValue(_errno.EINVAL, strerror(_errno.EINVAL), "%s contains a NUL byte"
                           % what)
    return bytes(s)


def _timeout_ms(timeout, default):
    """Seconds (float, None: default) -> whole milliseconds for the C calls."""
    if timeout is None:
        return default
    if timeout < 0:
        raise ValueError("timeout must be >= 0 seconds, or None")
    return int(timeout * _MS + 0.999)


class Meta(NamedTuple):
    """When and how a value was last updated (struct sl_meta)."""
    mono_ns: int                # CLOCK_MONOTONIC of the update
    real_ns: int                # CLOCK_REALTIME of the update
    age_ns: int                 # now - mono_ns (0 if never updated)
    sequence: int               # updates so far
    flags: int                  # SL_FLAG_*

    @property
    def valid(self):
        return bool(self.flags & SL_FLAG_VALID)

    @property
    def stale(self):
        return bool(self.flags & SL_FLAG_STALE)

    @property
    def outbound(self):
        return bool(self.flags & SL_FLAG_OUTBOUND)

    @property
    def repaired(self):
        return bool(self.flags & SL_FLAG_REPAIRED)


class VarInfo(NamedTuple):
    """A variable (struct sl_var_info); direction "in"/"out", type "string"/"long"/"double"."""
    id: int
    name: str
    direction: str
    type: str
    link: Optional[int]         # link index, or None
    peer: Optional[str]         # peer address, or None
    position: Optional[int]     # place in the peer's list, or None
    adhoc: bool                 # created at run time, not from the configuration


class LinkInfo(NamedTuple):
    """A link's state and counters (struct sl_link_info)."""
    index: int
    name: str
    protocol: str
    state: int
    state_name: str             # "" when its engine never set one; at most 31 bytes
    state_age_ns: int
    counters: dict              # name -> value, in the library's order
    state_text: str             # the whole state text, e.g. "down: FILE:LINE: message"


class DaemonInfo(NamedTuple):
    """The daemon behind the tables (struct sl_daemon_info)."""
    pid: int
    alive: bool
    epoch: int
    heartbeat_age_ns: int
    heartbeat_interval_ms: int
    started_real_ns: int
    counters: dict


def _event_fields(text):
    """"key=value key="quoted value" ..." -> {key: value}: a quoted value (a Pronto4 command's
    text) may hold spaces, with \\" and \\\\ inside it for a quote and a backslash; words
    without "=" are skipped."""
    fields, i, n = {}, 0, len(text)
    while i < n:
        if text[i] == " ":
            i += 1
            continue
        j = i
        while j < n and text[j] not in " =":
            j += 1
        if j >= n or text[j] != "=":
            i = j
            continue
        key, i = text[i:j], j + 1
        if i < n and text[i] == '"':
            value, i = [], i + 1
            while i < n and text[i] != '"':
                if text[i] == "\\" and i + 1 < n:
                    i += 1
                value.append(text[i])
                i += 1
            fields[key] = "".join(value)
            i += 1
        else:
            j = text.find(" ", i)
            j = n if j < 0 else j
            fields[key], i = text[i:j], j
    return fields


class Event(NamedTuple):
    """One event (struct sl_event); fields is text parsed as key=value words."""
    seq: int
    lost: int                   # events overwritten before this one could be read
    mono_ns: int
    real_ns: int
    type: str                   # e.g. "action", "link-state"
    link: Optional[str]         # link name, or None
    flags: int                  # SL_EVENT_*
    text: str                   # "key=value ..."

    @property
    def fields(self):
        return _event_fields(self.text)

    @property
    def truncated(self):
        return bool(self.flags & SL_EVENT_TRUNCATED)

    @property
    def restarted(self):
        return bool(self.flags & SL_EVENT_RESTARTED)


_DIRECTIONS = {SL_DIR_IN: "in", SL_DIR_OUT: "out"}
_TYPES = {SL_VAR_STRING: "string", SL_VAR_LONG: "long", SL_VAR_DOUBLE: "double"}


def _counters(info):
    return {info.counters[i].name.decode("ascii"): info.counters[i].value
            for i in range(min(info.counter_count, _lib.SL_COUNTERS_MAX))}


class Client:
    """A handle on one running instance (sl_open). Reads may run in many threads at once;
    close() must not run while another call does. Also a context manager."""

    def __init__(self, instance=None, runtime_dir=None, command_wait=None):
        """instance None: $SHAREDLINK_INSTANCE, else "default". runtime_dir: where the control
        socket is (for query and circe_*); rarely needed, the daemon publishes its socket path in
        its tables (see sl_set_runtime_dir). command_wait: seconds a command to a link that is
        down waits for it (default: fail at once)."""
        handle = ctypes.c_void_p()
        r = _lib_.sl_open(None if instance is None else _word(instance, "instance"),
                          _byref(handle))
        if r < 0:
            _raise(r, "opening instance %s" % (instance if instance is not None else "(default)"))
        self._h = handle
        self._ids = {}                  # name -> (id, type), resolved once: ids live as long
        self._changes = ctypes.c_uint32(0)
        self._seen = {}                 # name -> (sequence, flags) at the last wait()
        try:
            _lib.check_sizes(handle)
            # The change cursor starts now: a change after this wakes the first wait().
            _lib_.sl_wait(handle, _byref(self._changes), 0)
            if runtime_dir is not None:
                self.set_runtime_dir(runtime_dir)
            if command_wait is not None:
                self.set_command_wait(command_wait)
        except BaseException:
            self.close()
            raise

    # ---- lifetime ----

    def close(self):
        """Closes the handle (idempotent)."""
        h, self._h = getattr(self, "_h", None), None
        if h:
            _lib_.sl_close(h)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()

    def _handle(self):
        if not self._h:
            raise ValueError("sharedlink.Client: closed")
        return self._h

    # ---- names ----

    def _resolve(self, name):
        h = self._handle()
        vid = _lib_.sl_find(h, _word(name, "name"))
        if vid < 0:
            _raise(vid, "variable %s" % name)
        info = _lib.sl_var_info(size=ctypes.sizeof(_lib.sl_var_info))
        r = _lib_.sl_info(h, vid, _byref(info))
        if r < 0:
            _raise(r, "variable %s" % name)
        entry = (vid, info.type)
        self._ids[name] = entry
        return entry

    def find(self, name):
        """The variable's id (stable for the life of the client); NotFound if unknown."""
        return (self._ids.get(name) or self._resolve(name))[0]

    def __contains__(self, name):
        try:
            self.find(name)
        except NotFound:
            return False
        return True

    def info(self, name_or_id):
        """VarInfo of a variable, by name or id."""
        vid = self.find(name_or_id) if isinstance(name_or_id, str) else name_or_id
        info = _lib.sl_var_info(size=ctypes.sizeof(_lib.sl_var_info))
        r = _lib_.sl_info(self._handle(), vid, _byref(info))
        if r < 0:
            _raise(r, "variable id %d" % vid)
        peer = _text(info.peer)
        return VarInfo(vid, _text(info.name), _DIRECTIONS.get(info.direction, "?"),
                       _TYPES.get(info.type, "?"), info.link if info.link >= 0 else None,
                       peer or None, info.position if info.position >= 0 else None,
                       bool(info.flags & SL_VAR_ADHOC))

    def variables(self):
        """VarInfo of every variable (those a restarted daemon no longer has are left out)."""
        out = []
        for vid in range(max(_lib_.sl_count(self._handle()), 0)):
            try:
                out.append(self.info(vid))
            except NotFound:
                pass
        return out

    def names(self):
        return [v.name for v in self.variables()]

    # ---- reads ----

    def read(self, name):
        """(text, Meta) of a variable: its value as text ("" when never set: see meta.valid)."""
        r, buf, meta = self._read_slot((self._ids.get(name) or self._resolve(name))[0])
        if r < 0:
            _raise(r, "reading %s" % name)
        return (buf.raw[:r].decode("ascii", "replace"),
                Meta(meta.mono_ns, meta.real_ns, meta.age_ns, meta.sequence, meta.flags))

    def _read_slot(self, vid):
        """sl_read of id vid with its retries: (result, value buffer, sl_meta)."""
        buf = _value_buf()
        meta = _sl_meta()
        meta.size = _META_SIZE
        h = self._handle()
        for _ in range(READ_TRIES):
            r = _sl_read(h, vid, buf, _VALUE_SIZE, _byref(meta))
            if r != -_errno.EAGAIN:
                break
        return r, buf, meta

    def _number(self, fn, out, name, vid):
        h = self._handle()
        for _ in range(READ_TRIES):
            r = fn(h, vid, _byref(out), None)
            if r != -_errno.EAGAIN:
                break
        if r < 0:
            _raise(r, "reading %s" % name)
        return out.value

    def read_double(self, name):
        """The value as a float; NoData when not valid or empty, InvalidValue when not a number."""
        vid = (self._ids.get(name) or self._resolve(name))[0]
        out = _c_double()
        if _sl_read_double(self._h, vid, _byref(out), None) == 0:     # the fast path
            return out.value
        return self._number(_sl_read_double, out, name, vid)

    def read_long(self, name):
        """The value as an int (decimal); NoData, InvalidValue (not an integer, out of range)."""
        vid = (self._ids.get(name) or self._resolve(name))[0]
        out = _c_long()
        if _sl_read_long(self._h, vid, _byref(out), None) == 0:
            return out.value
        return self._number(_sl_read_long, out, name, vid)

    def __getitem__(self, name):
        """The value by the variable's declared type: float (double), int (long) or str; None
        when it has no valid value. A value that does not parse as its type is InvalidValue."""
        vid, vtype = self._ids.get(name) or self._resolve(name)
        if vtype == SL_VAR_DOUBLE:
            out = _c_double()
            r = _sl_read_double(self._h, vid, _byref(out), None)
            if r == 0:
                return out.value
            fn = _sl_read_double
        elif vtype == SL_VAR_LONG:
            out = _c_long()
            r = _sl_read_long(self._h, vid, _byref(out), None)
            if r == 0:
                return out.value
            fn = _sl_read_long
        else:
            text, meta = self.read(name)
            return text if meta.valid else None
        try:
            return self._number(fn, out, name, vid)
        except NoData:
            return None

    def get(self, name, default=None):
        """Like client[name], with default for an unknown name or no valid value."""
        try:
            value = self[name]
        except NotFound:
            return default
        return default if value is None else value

    # ---- writes ----

    def write(self, name, value, decimals=None):
        """Writes an outbound variable: str/bytes as given, int in decimal, float with that many
        decimals (None: the shortest text that reads back as the same float). PermissionDenied
        for an inbound variable or a user outside the daemon's group; InvalidValue when the
        value cannot go on the wire (printable ASCII except | [ ], at most 63 bytes) or is not
        of the variable's type (a long or a double variable), its detail saying why; the
        variable then keeps its value."""
        vid = (self._ids.get(name) or self._resolve(name))[0]
        h = self._handle()
        if isinstance(value, bool):
            raise TypeError("write %s: a bool is ambiguous; write 0/1 or text" % name)
        if isinstance(value, int):
            if not -2**63 <= value < 2**63:
                raise InvalidValue(_errno.ERANGE, strerror(_errno.ERANGE),
                                   "writing %s: %d does not fit a C long" % (name, value))
            r = _lib_.sl_write_long(h, vid, value)
        elif isinstance(value, float):
            r = _lib_.sl_write_double(h, vid, value, -1 if decimals is None else decimals)
        else:
            r = _lib_.sl_write(h, vid, _word(value, "value"))
        if r == -_errno.EINVAL:
            _raise(r, "writing %s: %s" % (name, self._write_refusal(h, vid, value, decimals)))
        if r < 0:
            _raise(r, "writing %s" % name)

    @staticmethod
    def _write_refusal(h, vid, value, decimals):
        """The library's reason for refusing value (sl_write_check), for the exception."""
        if isinstance(value, float):
            value = repr(value) if decimals is None else "%.*f" % (decimals, value)
        elif isinstance(value, int):
            value = str(value)
        reason = ctypes.create_string_buffer(_lib.SL_WRITE_REASON_SIZE)
        _lib_.sl_write_check(h, vid, _word(value, "value"), reason, len(reason))
        return _text(reason.value) or "value refused"

    __setitem__ = write

    # ---- waiting ----

    def _state(self, name):
        """(sequence, valid/stale flags) of a variable; None while it does not exist."""
        try:
            vid = (self._ids.get(name) or self._resolve(name))[0]
        except NotFound:
            return None                 # not yet (an ad hoc name): appearing is a change
        r, _, meta = self._read_slot(vid)
        if r == -_errno.ENOENT:
            return None                 # gone after a daemon restart: a change too
        if r < 0:
            _raise(r, "reading %s" % name)
        return (meta.sequence, meta.flags & (SL_FLAG_VALID | SL_FLAG_STALE))

    def wait(self, names=None, timeout=None, spin_us=None):
        """Waits until one of names (None: every variable) changed (a new value, or it became
        valid/stale) since the previous wait() on this client saw it, or timeout seconds passed
        (None: no limit). Returns the names that changed, [] on timeout. The first wait for a
        name compares with its state at that call: nothing is reported for the past.
        spin_us (0..SL_WAIT_SPIN_MAX_US): poll the table that long before each sleep
        (sl_wait_with with SL_WAIT_SPIN), for changes due within microseconds, at the price of
        a busy CPU while it spins; None: block at once (sl_wait)."""
        if isinstance(names, str):
            names = [names]
        opts = None
        if spin_us is not None:
            if not isinstance(spin_us, int) or not 0 <= spin_us <= _lib.SL_WAIT_SPIN_MAX_US:
                raise InvalidValue(_errno.EINVAL, strerror(_errno.EINVAL),
                                   "spin_us: 0..%d microseconds expected"
                                   % _lib.SL_WAIT_SPIN_MAX_US)
            opts = _lib.sl_wait_opts(size=ctypes.sizeof(_lib.sl_wait_opts),
                                     flags=_lib.SL_WAIT_SPIN, spin_us=spin_us)
        h = self._handle()
        deadline = None if timeout is None else time.monotonic() + max(timeout, 0.0)
        while True:
            watched = self.names() if names is None else names
            changed = []
            for name in watched:
                now = self._state(name)
                if name not in self._seen:
                    self._seen[name] = now
                elif self._seen[name] != now:
                    self._seen[name] = now
                    changed.append(name)
            if changed:
                return changed
            left = WAIT_SLICE_S if deadline is None else min(deadline - time.monotonic(),
                                                             WAIT_SLICE_S)
            if left <= 0:
                return []
            if opts is None:
                r = _lib_.sl_wait(h, _byref(self._changes), int(left * _MS + 0.999))
            else:
                r = _lib_.sl_wait_with(h, _byref(self._changes), int(left * _MS + 0.999),
                                       _byref(opts))
            if r < 0:
                _raise(r, "waiting for a change")

    # ---- events ----

    def events(self, follow=False, new=False, timeout=None):
        """A generator of Events, oldest retained first (new=True: only later ones). follow:
        keep waiting for more (until timeout seconds, None: forever); else stop when none are
        left. An overrun is never silent: an event's lost counts those overwritten before it.
        "Now" (for new, and the timeout) is this call, not the first next(): an event that
        happens in between is not missed."""
        h = self._handle()
        cursor = ctypes.c_uint64(0)
        changes = ctypes.c_uint32(0)
        deadline = None if timeout is None else time.monotonic() + max(timeout, 0.0)
        if new:
            r = _lib_.sl_events_now(h, _byref(cursor))
            if r < 0:
                _raise(r, "reading events")
        _lib_.sl_wait(h, _byref(changes), 0)
        return self._events(cursor, changes, follow, deadline)

    def _events(self, cursor, changes, follow, deadline):
        batch = (_lib.sl_event * EVENTS_BATCH)()
        while True:
            for ev in batch:
                ev.size = ctypes.sizeof(_lib.sl_event)
            n = _lib_.sl_events_read(self._handle(), _byref(cursor), batch, EVENTS_BATCH)
            if n < 0:
                _raise(n, "reading events")
            for ev in batch[:n]:
                yield Event(ev.seq, ev.lost, ev.mono_ns, ev.real_ns,
                            _text(ev.type_name) or "unknown", _text(ev.link_name) or None,
                            ev.flags, _text(ev.text))
            if n > 0:
                continue
            if not follow:
                return
            left = WAIT_SLICE_S if deadline is None else min(deadline - time.monotonic(),
                                                             WAIT_SLICE_S)
            if left <= 0:
                return
            r = _lib_.sl_wait(self._handle(), _byref(changes), int(left * _MS + 0.999))
            if r < 0:
                _raise(r, "waiting for events")

    # ---- links and the daemon ----

    def links(self):
        """LinkInfo of every link."""
        h = self._handle()
        out = []
        for i in range(max(_lib_.sl_link_count(h), 0)):
            info = _lib.sl_link_info()
            for _ in range(READ_TRIES):
                info.size = ctypes.sizeof(info)
                r = _lib_.sl_link_info(h, i, _byref(info))
                if r != -_errno.EAGAIN:
                    break
            if r < 0:
                _raise(r, "link %d" % i)
            out.append(LinkInfo(i, _text(info.name), _text(info.protocol), info.state,
                                _text(info.state_name), info.state_age_ns, _counters(info),
                                _text(info.state_text)))
        return out

    def link(self, name):
        """LinkInfo of the link called name; NotFound if none."""
        for link in self.links():
            if link.name == name:
                return link
        raise NotFound(_errno.ENOENT, strerror(_errno.ENOENT), "link %s" % name)

    def daemon(self):
        """DaemonInfo: pid, alive, epoch, heartbeat, daemon-wide counters."""
        info = _lib.sl_daemon_info(size=ctypes.sizeof(_lib.sl_daemon_info))
        r = _lib_.sl_daemon_info(self._handle(), _byref(info))
        if r < 0:
            _raise(r, "reading the daemon's state")
        return DaemonInfo(info.pid, bool(info.alive), info.epoch, info.heartbeat_age_ns,
                          info.heartbeat_interval_ms, info.started_real_ns, _counters(info))

    @property
    def alive(self):
        """True while the daemon runs (heartbeat recent, tables current)."""
        r = _lib_.sl_daemon_alive(self._handle())
        if r < 0:
            _raise(r, "checking the daemon")
        return bool(r)

    # ---- commands (control socket) ----

    def set_runtime_dir(self, path):
        """Directory of the control socket (None: $SHAREDLINK_RUNTIME_DIR or the default)."""
        r = _lib_.sl_set_runtime_dir(self._handle(), None if path is None else _word(path))
        if r < 0:
            _raise(r, "runtime directory %s" % path)

    def set_command_wait(self, seconds):
        """Commands to a link that is down wait up to this long for it (0: fail at once)."""
        r = _lib_.sl_set_command_wait(self._handle(), _timeout_ms(seconds, 0))
        if r < 0:
            _raise(r, "command wait %r" % seconds)

    def _command(self, fn, *args):
        reply = ctypes.create_string_buffer(_REPLY_SIZE)
        r = fn(self._handle(), *args, reply, _REPLY_SIZE)
        text = _text(reply.value)
        if r < 0:
            _raise(r, text)
        return r, text

    def request(self, line, timeout=None):
        """Sends one raw control request line; returns (reply text, [DATA line texts])."""
        data = []

        def on_data(text, arg):
            data.append(_text(text))
            return 0
        callback = _lib.sl_data_fn(on_data)
        r, text = self._command(_lib_.sl_request, _word(line, "request"),
                                _timeout_ms(timeout, 0), callback, None)
        return text, data

    def query(self, link, peer, name, timeout=None):
        """SharedLink query: asks node peer ("A".."P") on link for its variable name; the value.
        Timeout when the peer does not answer within timeout seconds (None: the daemon's)."""
        reply = ctypes.create_string_buffer(_REPLY_SIZE)
        r = _lib_.sl_query(self._handle(), _word(link, "link"), _word(peer, "peer"),
                           _word(name, "name"), _timeout_ms(timeout, 0), reply, _REPLY_SIZE)
        if r < 0:
            _raise(r, "query %s %s %s: %s" % (link, peer, name, _text(reply.value)))
        return _text(reply.raw[:r])

    def ping(self, link, peer, timeout=None):
        """SharedLink ping: sends P0 to node peer ("A".."P") on link; the round trip until its
        G0 in seconds (measured by the daemon). Timeout when no G0 comes within timeout seconds
        (None: the daemon's, 1 s); NotRunning when the link is down or goes down meanwhile."""
        reply = ctypes.create_string_buffer(_REPLY_SIZE)
        rtt_ns = ctypes.c_uint64(0)
        r = _lib_.sl_ping(self._handle(), _word(link, "link"), _word(peer, "peer"),
                          _timeout_ms(timeout, 0), ctypes.byref(rtt_ns), reply, _REPLY_SIZE)
        if r < 0:
            _raise(r, "ping %s %s: %s" % (link, peer, _text(reply.value)))
        return rtt_ns.value / 1e9

    def command(self, link, module, text=""):
        """Pronto4 module command: sends E<module>|D<text> to the pronto4 peer(s) of link, e.g.
        command("vehicle", "ServoPod", "0,TELEOP START"); the bare requests MUI, MUO, ML, MW
        (no text) go out bare. module: 1..63 letters, digits, _ . -;
        text: at most 63 bytes of printable ASCII without | [ ], words separated by single
        spaces. Returns once the frame is queued; NotConnected when the link is down."""
        r = _lib_.sl_command(self._handle(), _word(link, "link"), _word(module, "module"),
                             _word(text, "text"))
        if r < 0:
            _raise(r, "command %s %s %r" % (link, module, text))

    def circe_alert(self, link, addr):
        """CIRCE Alert: device addr signals itself."""
        self._command(_lib_.sl_circe_alert, _word(link, "link"), _word(addr, "address"))

    def circe_network_setup(self, link, addr, join=True, roles=0):
        """CIRCE Network Setup: addr joins (or leaves) the network with roles 0..127."""
        self._command(_lib_.sl_circe_network_setup, _word(link, "link"), _word(addr, "address"),
                      1 if join else 0, roles)

    def circe_device_setup(self, link, assign, dest=None, capabilities=None):
        """CIRCE Device Setup: gives address assign to the device at dest (None: the
        unconfigured one), with capabilities 0..127 when given."""
        self._command(_lib_.sl_circe_device_setup, _word(link, "link"), _word(assign, "address"),
                      0 if dest is None else 1, None if dest is None else _word(dest, "dest"),
                      0 if capabilities is None else 1, capabilities or 0)

    def circe_sync_clocks(self, link):
        """CIRCE Synchronize Clocks: {address: True (succeeded) / False (timed out)}."""
        results = {}

        def on_result(addr, succeeded, arg):
            results[_text(addr)] = bool(succeeded)
            return 0
        callback = _lib.sl_sync_fn(on_result)
        self._command(_lib_.sl_circe_sync_clocks, _word(link, "link"), callback, None)
        return results

    def circe_visualize(self, link, dests, current=None, next=None, start_timer=False,
                        primary_ms=None, secondary_ms=None, faults=None, refusals=None,
                        eliminated=None, placement=None):
        """CIRCE Visualize: shows the fields given (None: left alone) on displays dests (one
        address or a list)."""
        if isinstance(dests, (str, bytes)):
            dests = [dests]
        words = [_word(d, "dest") for d in dests]
        array = (ctypes.c_char_p * max(len(words), 1))(*words)
        v = _lib.sl_circe_visualize(size=ctypes.sizeof(_lib.sl_circe_visualize),
                                    dests=array, dest_count=len(words),
                                    start_timer=1 if start_timer else 0)
        for field, value in (("current", current), ("next", next), ("primary", primary_ms),
                             ("secondary", secondary_ms), ("faults", faults),
                             ("refusals", refusals), ("eliminated", eliminated),
                             ("placement", placement)):
            if value is not None:
                setattr(v, "has_" + field, 1)
                setattr(v, field + "_ms" if field in ("primary", "secondary") else field,
                        int(value))
        self._command(_lib_.sl_circe_visualize, _word(link, "link"), _byref(v))

    def circe_emulate_action(self, link, addr, keys=None, sensor_time_ms=None):
        """Mediator role (emulator): device addr reports an action (keys 0..65535, sensor time
        0..999999 ms, each when given)."""
        self._command(_lib_.sl_circe_emulate_action, _word(link, "link"), _word(addr, "address"),
                      0 if keys is None else 1, keys or 0,
                      0 if sensor_time_ms is None else 1, sensor_time_ms or 0)
