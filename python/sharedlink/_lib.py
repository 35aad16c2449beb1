"""ctypes view of libsharedlink.so.1: the public header (include/sharedlink.h), mirrored.

Every struct, constant and prototype here copies the header. tests/python/layout.c prints the C
compiler's sizes, offsets and constants and python/tests/test_layout.py compares them with these,
so a header change that is not carried over fails `make check`. At run time, the first Client also
checks each struct's size against what the library accepts (the `size` member protocol: a struct
one byte short must be refused with -EINVAL, the full one accepted), see check_sizes().
"""
import ctypes
import ctypes.util
import errno
import os
import threading

# ---- constants (sharedlink.h) --------------------------------------------------------------

SL_NAME_SIZE = 48
SL_VALUE_SIZE = 64
SL_WRITE_REASON_SIZE = 160
SL_PEER_SIZE = 16
SL_LINK_NAME_SIZE = 32
SL_PROTOCOL_SIZE = 16
SL_STATE_NAME_SIZE = 32
SL_STATE_TEXT_SIZE = 256
SL_TYPE_NAME_SIZE = 24
SL_EVENT_TEXT_SIZE = 216
SL_COUNTERS_MAX = 64

SL_DIR_IN = 0
SL_DIR_OUT = 1

SL_VAR_STRING = 0
SL_VAR_LONG = 1
SL_VAR_DOUBLE = 2

SL_VAR_ADHOC = 0x1

SL_FLAG_VALID = 0x1
SL_FLAG_STALE = 0x2
SL_FLAG_OUTBOUND = 0x4
SL_FLAG_REPAIRED = 0x8

SL_EVENT_TRUNCATED = 0x1
SL_EVENT_RESTARTED = 0x2
SL_WAIT_SPIN = 0x1             # sl_wait_with: Client.wait(..., spin_us=N)
SL_WAIT_SPIN_MAX_US = 10000
SL_READ_BUSY_MS = 20
SL_CHANGED_ALL = 0x1           # sl_changed (C only so far: Client.wait reads every name)
SL_CHANGED_START = 0x2
SL_CHANGED_OVERRUN = 0x4
SL_CHANGED_REMAPPED = 0x8
SL_CHANGED_UNAVAILABLE = 0x10
SL_CHANGED_MORE = 0x100
SL_COUNTER_SHAREDLINK = 0x1
SL_COUNTER_CIRCE = 0x2
SL_COUNTER_DAEMON = 0x4

SL_RUNTIME_DIR_DEFAULT = "/run/sharedlink"
SL_REQUEST_LINE_MAX = 1023
SL_REQUEST_WORDS_MAX = 32
SL_REPLY_LINE_MAX = 4095
SL_REQUEST_TIMEOUT_MS = 5000
SL_WAIT_MAX_MS = 60000
SL_QUERY_TIMEOUT_MAX_MS = 60000
SL_CIRCE_ADDRESS_SIZE = 7
SL_CIRCE_DESTS_MAX = 92
SL_COMMAND_TEXT_MAX = 63
SL_COMMAND_WORDS_MAX = 28

# ---- structs ---------------------------------------------------------------------------------

c_size_t = ctypes.c_size_t
c_int = ctypes.c_int
c_uint = ctypes.c_uint
c_long = ctypes.c_long
c_u32 = ctypes.c_uint32
c_u64 = ctypes.c_uint64
c_char_p = ctypes.c_char_p


class sl_meta(ctypes.Structure):
    _fields_ = [
        ("size", c_size_t),
        ("mono_ns", c_u64),
        ("real_ns", c_u64),
        ("age_ns", c_u64),
        ("sequence", c_u64),
        ("flags", c_u32),
    ]


class sl_var_info(ctypes.Structure):
    _fields_ = [
        ("size", c_size_t),
        ("name", ctypes.c_char * SL_NAME_SIZE),
        ("direction", c_int),
        ("type", c_int),
        ("link", c_int),
        ("peer", ctypes.c_char * SL_PEER_SIZE),
        ("position", c_int),
        ("flags", c_u32),
    ]


class sl_counter(ctypes.Structure):
    _fields_ = [
        ("name", c_char_p),
        ("value", c_u64),
    ]


class sl_link_info(ctypes.Structure):
    _fields_ = [
        ("size", c_size_t),
        ("name", ctypes.c_char * SL_LINK_NAME_SIZE),
        ("protocol", ctypes.c_char * SL_PROTOCOL_SIZE),
        ("state", c_int),
        ("state_name", ctypes.c_char * SL_STATE_NAME_SIZE),
        ("state_age_ns", c_u64),
        ("counter_count", c_uint),
        ("counters", sl_counter * SL_COUNTERS_MAX),
        ("state_text", ctypes.c_char * SL_STATE_TEXT_SIZE),
    ]


class sl_daemon_info(ctypes.Structure):
    _fields_ = [
        ("size", c_size_t),
        ("pid", c_int),
        ("alive", c_int),
        ("epoch", c_u64),
        ("heartbeat_age_ns", c_u64),
        ("heartbeat_interval_ms", c_u32),
        ("started_real_ns", c_u64),
        ("counter_count", c_uint),
        ("counters", sl_counter * SL_COUNTERS_MAX),
    ]


class sl_wait_opts(ctypes.Structure):
    _fields_ = [
        ("size", c_size_t),
        ("flags", c_u32),
        ("spin_us", c_u32),
    ]


class sl_event(ctypes.Structure):
    _fields_ = [
        ("size", c_size_t),
        ("seq", c_u64),
        ("lost", c_u64),
        ("mono_ns", c_u64),
        ("real_ns", c_u64),
        ("type", c_int),
        ("type_name", ctypes.c_char * SL_TYPE_NAME_SIZE),
        ("link", c_int),
        ("link_name", ctypes.c_char * SL_LINK_NAME_SIZE),
        ("flags", c_u32),
        ("text", ctypes.c_char * SL_EVENT_TEXT_SIZE),
    ]


class sl_circe_visualize(ctypes.Structure):
    _fields_ = [
        ("size", c_size_t),
        ("dests", ctypes.POINTER(c_char_p)),
        ("dest_count", c_uint),
        ("has_current", c_int),
        ("current", c_int),
        ("has_next", c_int),
        ("next", c_int),
        ("start_timer", c_int),
        ("has_primary", c_int),
        ("primary_ms", c_long),
        ("has_secondary", c_int),
        ("secondary_ms", c_long),
        ("has_faults", c_int),
        ("faults", c_int),
        ("has_refusals", c_int),
        ("refusals", c_int),
        ("has_eliminated", c_int),
        ("eliminated", c_int),
        ("has_placement", c_int),
        ("placement", c_int),
    ]


STRUCTS = (sl_meta, sl_var_info, sl_counter, sl_link_info, sl_daemon_info, sl_event,
           sl_circe_visualize, sl_wait_opts)

sl_data_fn = ctypes.CFUNCTYPE(c_int, c_char_p, ctypes.c_void_p)
sl_sync_fn = ctypes.CFUNCTYPE(c_int, c_char_p, c_int, ctypes.c_void_p)

# ---- functions -------------------------------------------------------------------------------

_client_p = ctypes.c_void_p
_P = ctypes.POINTER
_REPLY = (ctypes.c_char_p, c_size_t)    # char *reply, size_t reply_size (a writable buffer)

PROTOTYPES = {
    "sl_open": (c_int, (c_char_p, _P(_client_p))),
    "sl_close": (_client_p, (_client_p,)),
    "sl_find": (c_int, (_client_p, c_char_p)),
    "sl_count": (c_int, (_client_p,)),
    "sl_info": (c_int, (_client_p, c_int, _P(sl_var_info))),
    "sl_read": (c_int, (_client_p, c_int, ctypes.c_char_p, c_size_t, _P(sl_meta))),
    "sl_read_double": (c_int, (_client_p, c_int, _P(ctypes.c_double), _P(sl_meta))),
    "sl_read_long": (c_int, (_client_p, c_int, _P(c_long), _P(sl_meta))),
    "sl_write": (c_int, (_client_p, c_int, c_char_p)),
    "sl_write_double": (c_int, (_client_p, c_int, ctypes.c_double, c_int)),
    "sl_write_long": (c_int, (_client_p, c_int, c_long)),
    "sl_write_check": (c_int, (_client_p, c_int, c_char_p, ctypes.c_char_p, c_size_t)),
    "sl_wait": (c_int, (_client_p, _P(c_u32), c_int)),
    "sl_wait_with": (c_int, (_client_p, _P(c_u32), c_int, _P(sl_wait_opts))),
    "sl_events_read": (c_int, (_client_p, _P(c_u64), _P(sl_event), c_size_t)),
    "sl_events_now": (c_int, (_client_p, _P(c_u64))),
    "sl_link_count": (c_int, (_client_p,)),
    "sl_link_info": (c_int, (_client_p, c_int, _P(sl_link_info))),
    "sl_daemon_info": (c_int, (_client_p, _P(sl_daemon_info))),
    "sl_daemon_alive": (c_int, (_client_p,)),
    "sl_strerror": (c_char_p, (c_int,)),
    "sl_set_runtime_dir": (c_int, (_client_p, c_char_p)),
    "sl_set_command_wait": (c_int, (_client_p, c_int)),
    "sl_request": (c_int, (_client_p, c_char_p, c_int, sl_data_fn, ctypes.c_void_p) + _REPLY),
    "sl_query": (c_int, (_client_p, c_char_p, c_char_p, c_char_p, c_int) + _REPLY),
    "sl_command": (c_int, (_client_p, c_char_p, c_char_p, c_char_p)),
    "sl_ping": (c_int, (_client_p, c_char_p, c_char_p, c_int, _P(c_u64)) + _REPLY),
    "sl_circe_alert": (c_int, (_client_p, c_char_p, c_char_p) + _REPLY),
    "sl_circe_network_setup": (c_int, (_client_p, c_char_p, c_char_p, c_int, c_int) + _REPLY),
    "sl_circe_device_setup": (c_int, (_client_p, c_char_p, c_char_p, c_int, c_char_p, c_int,
                                      c_int) + _REPLY),
    "sl_circe_sync_clocks": (c_int, (_client_p, c_char_p, sl_sync_fn, ctypes.c_void_p)
                             + _REPLY),
    "sl_circe_visualize": (c_int, (_client_p, c_char_p, _P(sl_circe_visualize)) + _REPLY),
    "sl_circe_emulate_action": (c_int, (_client_p, c_char_p, c_char_p, c_int, c_int, c_int,
                                        c_long) + _REPLY),
}

SONAME = "libsharedlink.so.1"


def _candidates():
    """Where to look, in order: $SHAREDLINK_LIB alone when set; else the path `make install`
    recorded, the soname through the dynamic loader, and what ctypes.util.find_library finds."""
    env = os.environ.get("SHAREDLINK_LIB")
    if env:
        return [env]
    found = []
    try:
        from . import _paths            # written by `make install` (PYTHONDIR), absent otherwise
        found.append(_paths.LIBRARY)
    except ImportError:
        pass
    found.append(SONAME)
    other = ctypes.util.find_library("sharedlink")
    if other and other not in found:
        found.append(other)
    return found


def load():
    """Loads the library and declares every prototype; ImportError says what was tried."""
    tried = []
    for path in _candidates():
        try:
            lib = ctypes.CDLL(path)
        except OSError as e:
            tried.append("%s (%s)" % (path, e))
            continue
        missing = [name for name in PROTOTYPES if not hasattr(lib, name)]
        if missing:
            tried.append("%s (no %s: not libsharedlink 1)" % (path, ", ".join(missing)))
            continue
        for name, (restype, argtypes) in PROTOTYPES.items():
            fn = getattr(lib, name)
            fn.restype = restype
            fn.argtypes = argtypes
        lib.path = path
        return lib
    raise ImportError("sharedlink: cannot load %s; tried: %s. Install sharedlink (make install) "
                      "or set SHAREDLINK_LIB to the library's path" % (SONAME, "; ".join(tried)))


lib = load()

# The hot reads again, without argtypes: ctypes' conversion of declared arguments costs about as
# much as the rest of the call. Only Client's read paths call these, always with the exact types
# (the handle as c_void_p, an int id, c_size_t sizes, byref pointers, None for NULL).
fast = ctypes.CDLL(lib.path)
for _name in ("sl_read", "sl_read_double", "sl_read_long"):
    getattr(fast, _name).restype = c_int

# ---- size check: the `size` member protocol ---------------------------------------------------

_checked = False
_checked_lock = threading.Lock()


# Structs that grew at their end since their first version: the library takes any size from the
# first version's up (an older caller's), so "one byte short" is checked against that one.
_FIRST_SIZE = {
    sl_link_info: sl_link_info.state_text.offset,
}


def _accepts(call, struct_type):
    """(short, full): what call returns for a struct whose size says one byte less than its first
    version's (ours, for most), and for ours."""
    out = []
    first = _FIRST_SIZE.get(struct_type, ctypes.sizeof(struct_type))
    for size in (first - 1, ctypes.sizeof(struct_type)):
        s = struct_type()
        s.size = size
        out.append(call(s))
    return out


def check_sizes(handle):
    """Once per process: every extensible struct has exactly the size this library expects.

    The library refuses a struct whose `size` is below its own sizeof (its first version's, for
    one that grew) with -EINVAL and accepts larger ones, so "one byte short is refused, ours is
    accepted" means ours is exactly its size: a mirror that drifted from the header fails here,
    before it could corrupt memory. (A grown struct's later fields are checked by
    tests/python/layout.c; an older library fills only what it knows of them.)"""
    global _checked
    if _checked:
        return
    with _checked_lock:
        if _checked:
            return
        reply = ctypes.create_string_buffer(SL_REPLY_LINE_MAX + 1)
        cursor = c_u64(0)
        change = c_u32(0)

        def visualize(v):
            reply.value = b""
            r = lib.sl_circe_visualize(handle, b"-", ctypes.byref(v), reply, len(reply))
            return (r, reply.value)

        checks = {
            sl_meta: lambda m: lib.sl_read(handle, -1, reply, len(reply), ctypes.byref(m)),
            sl_var_info: lambda i: lib.sl_info(handle, -1, ctypes.byref(i)),
            sl_link_info: lambda i: lib.sl_link_info(handle, -1, ctypes.byref(i)),
            sl_daemon_info: lambda i: lib.sl_daemon_info(handle, ctypes.byref(i)),
            # A local cursor: the reads it makes are thrown away.
            sl_event: lambda e: lib.sl_events_read(handle, ctypes.byref(cursor),
                                                   ctypes.byref(e), 1),
            # timeout 0, no flags: returns at once (0 or 1); a short size is -EINVAL.
            sl_wait_opts: lambda o: lib.sl_wait_with(handle, ctypes.byref(change), 0,
                                                     ctypes.byref(o)),
        }
        for struct_type, call in checks.items():
            short, full = _accepts(call, struct_type)
            if short != -errno.EINVAL or full == -errno.EINVAL:
                raise ImportError("sharedlink: struct %s differs from %s's (short: %d, full: %d)"
                                  % (struct_type.__name__, lib.path, short, full))
        # Visualize refuses both sizes (no destinations), but not for the same reason.
        short, full = _accepts(visualize, sl_circe_visualize)
        if short[0] != -errno.EINVAL or short == full:
            raise ImportError("sharedlink: struct sl_circe_visualize differs from %s's" % lib.path)
        _checked = True
