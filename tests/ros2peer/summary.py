"""The one runner of tests/ros2peer/test_*.py: unittest, then cmocka's two summary lines, which
tests/run-tests.sh sums so the check's total counts each case."""

import sys
import unittest


def run(module_name):
    """Runs the test cases of that module; returns the exit status (0: all passed)."""
    suite = unittest.defaultTestLoader.loadTestsFromModule(sys.modules[module_name])
    result = unittest.TextTestRunner(verbosity=2, stream=sys.stdout).run(suite)
    bad = len(result.failures) + len(result.errors)
    print("[  PASSED  ] %d test(s)." % (result.testsRun - bad))
    if bad:
        print("[  FAILED  ] %d test(s)" % bad)
    return 0 if result.wasSuccessful() and result.testsRun > 0 else 1
