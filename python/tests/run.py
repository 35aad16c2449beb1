#!/usr/bin/env python3
"""Runs the Python binding's tests for `make check`: pytest when it is importable, else unittest
(the tests are unittest cases, so both run the same ones), and ends with cmocka's summary lines,
which tests/run-tests.sh adds to the check total. Nothing is skipped silently: a skipped test
(the unprivileged-user one when not run as root) is listed with its reason, and counts neither
as passed nor as failed, as cmocka's skips.

Environment (set by the Makefile): SHAREDLINK_LIB (the library the binding loads),
SHAREDLINK_BUILD (whose sharedlinkd and slctl run), SHAREDLINK_LAYOUT (the layout printer).
"""
import os
import sys
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [os.path.dirname(HERE), HERE]     # the package under test, then the helpers


def run_pytest(pytest):
    class Count:
        def __init__(self):
            self.passed = self.failed = 0
            self.skipped = []

        def pytest_runtest_logreport(self, report):
            if report.when == "call" and report.passed:
                self.passed += 1
            elif report.failed:
                self.failed += 1    # a failed setup or teardown counts too
            elif report.skipped:
                self.skipped.append("%s: %s" % (report.nodeid, report.longrepr[-1]))

        def pytest_collectreport(self, report):
            if report.failed:
                self.failed += 1

    count = Count()
    code = pytest.main(["-p", "no:cacheprovider", "-q", HERE], plugins=[count])
    if code != 0 and count.failed == 0:
        count.failed = 1            # e.g. nothing collected, or an internal error
    return "pytest " + pytest.__version__, count.passed, count.failed, count.skipped


def run_unittest():
    suite = unittest.defaultTestLoader.discover(HERE, pattern="test_*.py", top_level_dir=HERE)
    result = unittest.TextTestRunner(verbosity=2, stream=sys.stdout).run(suite)
    failed = len(result.failures) + len(result.errors) + len(result.unexpectedSuccesses)
    skipped = ["%s: %s" % (test.id(), why) for test, why in result.skipped]
    return ("unittest (pytest is not installed)", result.testsRun - failed - len(skipped), failed,
            skipped)


def main():
    try:
        import pytest
    except ImportError:
        pytest = None
    runner, passed, failed, skipped = run_pytest(pytest) if pytest else run_unittest()
    print("python %s, %s, library %s" % (sys.version.split()[0], runner,
                                         os.environ.get("SHAREDLINK_LIB", "(default search)")))
    for line in skipped:
        print("[  SKIPPED ] %s" % line)
    if failed:
        print("[  FAILED  ] %d test(s)" % failed)
    print("[  PASSED  ] %d test(s)." % passed)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
