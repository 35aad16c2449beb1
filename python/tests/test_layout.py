"""The ctypes mirror (sharedlink/_lib.py) against the C compiler's view of the header, printed by
tests/python/layout.c ($SHAREDLINK_LAYOUT): every struct's size, every member's offset, and
every constant, so a header change not carried over to the binding fails here."""
import os
import re
import subprocess
import unittest

from sharedlink import _lib


def c_layout():
    path = os.environ.get("SHAREDLINK_LAYOUT")
    if not path:
        raise AssertionError("SHAREDLINK_LAYOUT is not set (make check sets it)")
    out = subprocess.run([path], capture_output=True, text=True, timeout=30, check=True).stdout
    sizes, offsets, consts = {}, {}, {}
    for line in out.splitlines():
        kind, name, value = line.split(" ", 2)
        {"size": sizes, "offset": offsets, "const": consts}[kind][name] = value
    return sizes, offsets, consts


class TestLayout(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.sizes, cls.offsets, cls.consts = c_layout()

    def test_struct_sizes(self):
        mirrored = {s.__name__: s for s in _lib.STRUCTS}
        self.assertEqual(set(mirrored), set(self.sizes))
        for name, struct in mirrored.items():
            self.assertEqual(_lib.ctypes.sizeof(struct), int(self.sizes[name]), name)

    def test_member_offsets(self):
        mirrored = {}
        for struct in _lib.STRUCTS:
            for field in struct._fields_:
                mirrored["%s.%s" % (struct.__name__, field[0])] = getattr(struct, field[0]).offset
        self.assertEqual(set(mirrored), set(self.offsets))
        for name, offset in mirrored.items():
            self.assertEqual(offset, int(self.offsets[name]), name)

    def test_constants(self):
        self.assertGreater(len(self.consts), 20)
        for name, value in self.consts.items():
            mine = getattr(_lib, name)
            want = value.strip('"') if isinstance(mine, str) else int(value)
            self.assertEqual(mine, want, name)

    def test_every_header_constant_is_printed(self):
        # Every SL_ define of the header that is a number or a string reaches the comparison.
        header = os.path.join(os.path.dirname(__file__), "..", "..", "include", "sharedlink.h")
        with open(header) as f:
            defined = set(re.findall(r"^#define\s+(SL_[A-Z0-9_]+)\s+\S", f.read(), re.M))
        self.assertEqual(defined, set(self.consts))


if __name__ == "__main__":
    unittest.main()
