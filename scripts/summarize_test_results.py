#!/usr/bin/env python3
"""Counts the test cases of a catkin test_results folder and prints `N passed, M failed`.

gtest, rosunit (the gtest results of rostests) and roslaunch-check files are counted case by
case. A rostest wrapper file only counts when it failed: then the test process crashed or timed
out before writing its own results. With --sanitizer-reports DIR, every report file that the
AddressSanitizer or UndefinedBehaviorSanitizer runtime wrote there counts as a failure too.
Exits 1 when anything failed or nothing ran.
"""
import argparse
import glob
import os
import sys
import xml.etree.ElementTree as ET


def cases(path):
    root = ET.parse(path).getroot()
    for case in root.iter("testcase"):
        failed = case.find("failure") is not None or case.find("error") is not None
        name = "%s.%s" % (case.get("classname", ""), case.get("name", ""))
        yield name, failed


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", help="the catkin test_results folder")
    parser.add_argument("--sanitizer-reports", metavar="DIR", help="folder of sanitizer log files")
    args = parser.parse_args()
    files = sorted(glob.glob(os.path.join(args.results, "**", "*.xml"), recursive=True))
    passed, failed = 0, []
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
            results = [("unreadable result file %s: %s" % (path, error), True)]
        for name, bad in results:
            if bad:
                failed.append("%s (%s)" % (name, os.path.basename(path)))
            elif not wrapper:
                passed += 1
    for name in failed:
        print("FAILED: " + name)
    print("%d passed, %d failed" % (passed, len(failed)))
    sys.exit(1 if failed or passed == 0 else 0)


if __name__ == "__main__":
    main()
