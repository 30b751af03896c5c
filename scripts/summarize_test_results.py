#!/usr/bin/env python3
"""Counts the test cases of a catkin test_results folder and prints `N passed, M failed`.

gtest, rosunit (the gtest results of rostests), roslaunch-check and the Python tests' JUnit files
are counted case by case. A skipped case (a <skipped> element: GTEST_SKIP, unittest's skipTest;
or a gtest case that did not run, status="notrun") is neither passed nor failed: it is listed as
`SKIPPED: name (reason)` and counted on a line `K skipped` before the last line. A rostest
wrapper file only counts when it failed: then the test process crashed or timed out before
writing its own results. With --sanitizer-reports DIR, every report file that the
AddressSanitizer or UndefinedBehaviorSanitizer runtime wrote there counts as a failure too.
The last line is always `N passed, M failed` (.ci/run reads it). Exits 1 when anything failed
or nothing passed.
"""
import argparse
import glob
import os
import sys
import xml.etree.ElementTree as ET


PASSED, FAILED, SKIPPED = "passed", "failed", "skipped"


def cases(path):
    """(name, outcome, skip reason) of every test case of a JUnit file."""
    root = ET.parse(path).getroot()
    for case in root.iter("testcase"):
        name = "%s.%s" % (case.get("classname", ""), case.get("name", ""))
        skipped = case.find("skipped")
        if case.find("failure") is not None or case.find("error") is not None:
            yield name, FAILED, ""
        elif skipped is not None:
            reason = (skipped.get("message") or skipped.text or "").strip()
            yield name, SKIPPED, " ".join(reason.split()) or "no reason given"
        elif case.get("status") == "notrun":
            yield name, SKIPPED, "not run (%s)" % case.get("result", "disabled")
        else:
            yield name, PASSED, ""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", help="the catkin test_results folder")
    parser.add_argument("--sanitizer-reports", metavar="DIR", help="folder of sanitizer log files")
    args = parser.parse_args()
    files = sorted(glob.glob(os.path.join(args.results, "**", "*.xml"), recursive=True))
    passed, failed, skipped = 0, [], []
    reports = glob.glob(os.path.join(args.sanitizer_reports, "*")) if args.sanitizer_reports else []
    for report in sorted(reports):
        with open(report, errors="replace") as text:
            sys.stderr.write("--- %s\n%s\n" % (report, "".join(text.readlines()[:40])))
        failed.append("sanitizer report %s" % report)
    for path in files:
        wrapper = os.path.basename(path).startswith("rostest-")
        try:
            results = list(cases(path))
        except ET.ParseError as error:
            results = [("unreadable result file %s: %s" % (path, error), FAILED, "")]
        for name, outcome, reason in results:
            if outcome == FAILED:
                failed.append("%s (%s)" % (name, os.path.basename(path)))
            elif wrapper:
                continue
            elif outcome == SKIPPED:
                skipped.append("%s (%s)" % (name, reason))
            else:
                passed += 1
    for name in skipped:
        print("SKIPPED: " + name)
    for name in failed:
        print("FAILED: " + name)
    if skipped:
        print("%d skipped" % len(skipped))
    print("%d passed, %d failed" % (passed, len(failed)))
    sys.exit(1 if failed or passed == 0 else 0)


if __name__ == "__main__":
    main()
