"""Runs the unittest cases of a test module and writes a JUnit XML file for catkin's
test_results folder: one <testcase> per test, with <failure> (a failed assertion), <error> (an
exception) or <skipped message="..."> (skipped, with its reason), so that
scripts/summarize_test_results.py counts and lists skipped tests apart from passed ones.
"""
import argparse
import os
import sys
import time
import unittest
from xml.sax.saxutils import escape, quoteattr


class TimedResult(unittest.TextTestResult):
    """A text result that also keeps each test's duration."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.durations = {}
        self._started = 0.0

    def startTest(self, test):
        self._started = time.monotonic()
        super().startTest(test)

    def stopTest(self, test):
        self.durations[test.id()] = time.monotonic() - self._started
        super().stopTest(test)


def flatten(suite):
    for test in suite:
        if isinstance(test, unittest.TestSuite):
            yield from flatten(test)
        else:
            yield test


def write_junit(path, suite_name, result, tests):
    failures = {test.id(): text for test, text in result.failures}
    errors = {test.id(): text for test, text in result.errors}
    skipped = {test.id(): reason for test, reason in result.skipped}
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             '<testsuite name=%s tests="%d" failures="%d" errors="%d" skipped="%d">' %
             (quoteattr(suite_name), len(tests), len(failures), len(errors), len(skipped))]
    for test in tests:
        classname, name = test.id().rsplit(".", 1)
        if classname.startswith("__main__."):
            classname = suite_name + classname[len("__main__"):]
        lines.append('  <testcase classname=%s name=%s time="%.3f">' %
                     (quoteattr(classname), quoteattr(name), result.durations.get(test.id(), 0.0)))
        if test.id() in failures:
            lines.append('    <failure message="failed">%s</failure>' % escape(failures[test.id()]))
        elif test.id() in errors:
            lines.append('    <error message="error">%s</error>' % escape(errors[test.id()]))
        elif test.id() in skipped:
            lines.append("    <skipped message=%s/>" % quoteattr(skipped[test.id()]))
        lines.append("  </testcase>")
    lines.append("</testsuite>")
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main(module_name, description, configure=None):
    """Parses --junit FILE (and what `configure(parser)` adds), runs the module's tests, writes
    the JUnit file; returns the exit status. configure returns a function taking the parsed
    arguments, called before the tests run."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--junit", metavar="FILE", help="write the results as JUnit XML")
    apply = configure(parser) if configure else None
    args = parser.parse_args()
    if apply:
        apply(args)
    module = sys.modules[module_name]
    tests = list(flatten(unittest.defaultTestLoader.loadTestsFromModule(module)))
    runner = unittest.TextTestRunner(verbosity=2, resultclass=TimedResult)
    result = runner.run(unittest.TestSuite(tests))
    if args.junit:
        write_junit(args.junit, os.path.splitext(os.path.basename(module.__file__))[0], result, tests)
    return 0 if result.wasSuccessful() else 1
