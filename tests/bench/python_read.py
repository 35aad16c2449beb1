#!/usr/bin/env python3
"""`make bench`: what a read costs from Python, next to the C call it wraps, in one run.

Starts the optimised sharedlinkd (python/tests/daemon.py: SharedLink node A <-> node B on a pty),
sets a double on node A and waits until node B has it, then times, on that inbound variable:
C sl_read / sl_read_double through libsharedlink.so.1 (tests/bench/read_loop.c), and the Python
binding's client.read_double(name), client[name] and client.read(name), with a Python call that
does nothing as the interpreter's floor. Each figure is the best (lowest) mean of BEST_OF rounds.
"""
import os
import subprocess
import sys
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path[:0] = [os.path.join(ROOT, "python"), os.path.join(ROOT, "python", "tests")]

import sharedlink                       # noqa: E402
from daemon import Daemon, build_dir    # noqa: E402

C_ROUNDS = 2000000
PY_ROUNDS = 200000
BEST_OF = 5
NAME = "b.AutoGpsLat"
WAIT_S = 15.0


def per_call(fn, arg):
    best = float("inf")
    for _ in range(BEST_OF):
        t0 = time.perf_counter_ns()
        for _ in range(PY_ROUNDS):
            fn(arg)
        best = min(best, (time.perf_counter_ns() - t0) / PY_ROUNDS)
    return best


class Nothing:
    def read(self, name):
        return None


def main():
    if hasattr(os, "sched_setaffinity") and len(os.sched_getaffinity(0)) > 1:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})   # as bench_shm: one CPU
    with Daemon("bench") as d, sharedlink.Client(d.instance) as c:
        c["a.AutoGpsLat"] = 40.12345678
        deadline = time.monotonic() + WAIT_S
        while c.get(NAME) != 40.12345678:
            if time.monotonic() > deadline:
                sys.exit("python_read: %s never arrived; daemon log:\n%s" % (NAME, d.log()))
            c.wait([NAME], timeout=deadline - time.monotonic())
        out = subprocess.run([os.path.join(build_dir(), "bench", "read_loop"), d.instance, NAME,
                              str(C_ROUNDS)], capture_output=True, text=True, check=True,
                             timeout=300).stdout
        cfig = {k: float(v) for k, v in (line.split() for line in out.splitlines())}
        figures = [
            ("C sl_read (63-byte buffer, no meta)", cfig["sl_read"]),
            ("C sl_read_double", cfig["sl_read_double"]),
            ("Python: a method call that does nothing", per_call(Nothing().read, NAME)),
            ("Python client.read_double(name)", per_call(c.read_double, NAME)),
            ("Python client[name] (double)", per_call(c.__getitem__, NAME)),
            ("Python client.read(name) -> (text, meta)", per_call(c.read, NAME)),
        ]
    base = cfig["sl_read"]
    print("python %s, %s, load %s" % (sys.version.split()[0], sharedlink._lib.lib.path,
                                       open("/proc/loadavg").read().split(" ", 3)[:3]))
    print("%-44s %10s   %s" % ("ns per read of %s" % NAME, "mean ns", "x C sl_read"))
    for what, ns in figures:
        print("%-44s %10.1f   %8.1fx" % (what, ns, ns / base))


if __name__ == "__main__":
    main()
