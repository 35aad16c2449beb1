"""Prints where `make install` puts the Python package for a PREFIX (argv[1]): the first
directory on this Python's own sys.path under PREFIX/lib that holds packages (Debian:
/usr/lib/python3/dist-packages for /usr, /usr/local/lib/python3.N/dist-packages for /usr/local),
else the site-packages the standard scheme names under PREFIX (then PYTHONPATH must include it)."""
import sys
import sysconfig

prefix = sys.argv[1].rstrip("/") or "/"
for entry in sys.path:
    if entry.startswith(prefix + "/lib/") and entry.endswith("-packages"):
        print(entry)
        break
else:
    print(sysconfig.get_path("purelib", "posix_prefix", vars={"base": prefix, "platbase": prefix}))
