#!/usr/bin/env python3
"""Tests of scripts/summarize_test_results.py on hand-written result files: skipped cases
(gtest's GTEST_SKIP, unittest's skipTest, gtest cases that did not run) are listed and counted
apart, never as passed; failures, errors, unreadable files and failed rostest wrappers count as
failed; the last line stays `N passed, M failed`.

usage: test_summarize_test_results.py [--junit FILE]
"""
import os
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import junit_runner  # noqa: E402

SUMMARIZE = os.path.join(ROOT, "scripts", "summarize_test_results.py")

GTEST = """<?xml version="1.0" encoding="UTF-8"?>
<testsuites tests="4" failures="1" disabled="1" errors="0" name="AllTests">
  <testsuite name="Winograd" tests="4" failures="1" disabled="1" skipped="1" errors="0">
    <testcase name="Equal" status="run" result="completed" classname="Winograd" />
    <testcase name="NeedsAvx2" status="run" result="skipped" classname="Winograd">
      <skipped message="test/detection/test_yolo_onnx_model.cpp:150&#x0A;this CPU lacks AVX2/FMA"><![CDATA[
this CPU lacks AVX2/FMA]]></skipped>
    </testcase>
    <testcase name="DISABLED_Slow" status="notrun" result="suppressed" classname="Winograd" />
    <testcase name="Wrong" status="run" result="completed" classname="Winograd">
      <failure message="expected 1" type=""><![CDATA[expected 1]]></failure>
    </testcase>
  </testsuite>
</testsuites>
"""

PYTHON = """<?xml version="1.0" encoding="UTF-8"?>
<testsuite name="test_yolov5s_model" tests="3" failures="0" errors="1" skipped="1">
  <testcase classname="test_yolov5s_model.RealModelTest" name="test_finds_the_labelled_objects" time="0">
    <skipped message="the model is not fetched (no network)"/>
  </testcase>
  <testcase classname="test_yolov5s_model.RealModelTest" name="test_ok" time="0">
  </testcase>
  <testcase classname="test_yolov5s_model.RealModelTest" name="test_crash" time="0">
    <error message="error">Traceback</error>
  </testcase>
</testsuite>
"""

WRAPPER_OK = """<?xml version="1.0" encoding="utf-8"?>
<testsuite errors="0" failures="0" name="unittest.suite.TestSuite" tests="1" time="1.0">
  <testcase classname="rostest.runner.RosTest" name="test_nodelet" time="1.0"></testcase>
</testsuite>
"""

WRAPPER_FAILED = """<?xml version="1.0" encoding="utf-8"?>
<testsuite errors="0" failures="1" name="unittest.suite.TestSuite" tests="1" time="1.0">
  <testcase classname="rostest.runner.RosTest" name="test_crashed" time="1.0">
    <failure message="test [test_crashed] did not generate test results" type="AssertionError"/>
  </testcase>
</testsuite>
"""


class SummaryTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.results = os.path.join(self.dir.name, "test_results", "grid_vision_fusion")
        os.makedirs(self.results)

    def tearDown(self):
        self.dir.cleanup()

    def write(self, name, text):
        with open(os.path.join(self.results, name), "w") as f:
            f.write(text)

    def summarize(self):
        return subprocess.run([sys.executable, SUMMARIZE, os.path.dirname(self.results)], capture_output=True,
                              text=True)

    def test_skipped_cases_are_listed_and_not_passed(self):
        self.write("gtest-test_detection.xml", GTEST)
        self.write("python-test_yolov5s_model.xml", PYTHON)
        self.write("rostest-test_nodelet.xml", WRAPPER_OK)
        done = self.summarize()
        lines = done.stdout.strip().splitlines()
        self.assertEqual(lines[-1], "2 passed, 2 failed")
        self.assertEqual(lines[-2], "3 skipped")
        self.assertIn("SKIPPED: Winograd.NeedsAvx2 (test/detection/test_yolo_onnx_model.cpp:150 this CPU lacks "
                      "AVX2/FMA)", lines)
        self.assertIn("SKIPPED: Winograd.DISABLED_Slow (not run (suppressed))", lines)
        self.assertIn("SKIPPED: test_yolov5s_model.RealModelTest.test_finds_the_labelled_objects (the model is not "
                      "fetched (no network))", lines)
        self.assertIn("FAILED: Winograd.Wrong (gtest-test_detection.xml)", lines)
        self.assertIn("FAILED: test_yolov5s_model.RealModelTest.test_crash (python-test_yolov5s_model.xml)", lines)
        self.assertEqual(done.returncode, 1)

    def test_all_passed_or_skipped(self):
        self.write("python-test_yolov5s_model.xml", PYTHON.replace('<error message="error">Traceback</error>', ""))
        done = self.summarize()
        self.assertEqual(done.stdout.strip().splitlines()[-1], "2 passed, 0 failed")
        self.assertEqual(done.returncode, 0)

    def test_only_skipped_is_a_failure_of_the_run(self):
        self.write("python-only_skipped.xml", PYTHON.split("  <testcase classname=\"test_yolov5s_model.RealModelTest\" "
                                                            "name=\"test_ok\"")[0] + "</testsuite>\n")
        done = self.summarize()
        self.assertEqual(done.stdout.strip().splitlines()[-2:], ["1 skipped", "0 passed, 0 failed"])
        self.assertEqual(done.returncode, 1)

    def test_failed_wrapper_and_unreadable_file(self):
        self.write("rostest-test_crashed.xml", WRAPPER_FAILED)
        self.write("gtest-broken.xml", "<testsuites><testsuite")
        done = self.summarize()
        lines = done.stdout.strip().splitlines()
        self.assertEqual(lines[-1], "0 passed, 2 failed")
        self.assertNotIn("skipped", done.stdout)

    def test_junit_runner_writes_skip_reasons(self):
        # The Python tests' own JUnit files carry the reason the summary lists.
        class Sample(unittest.TestCase):
            def test_skip(self):
                self.skipTest("no model & no <network>")

        tests = [Sample("test_skip")]
        result = junit_runner.TimedResult(open(os.devnull, "w"), False, 0)
        unittest.TestSuite(tests).run(result)
        junit_runner.write_junit(os.path.join(self.results, "python-sample.xml"), "sample", result, tests)
        done = self.summarize()
        self.assertIn("(no model & no <network>)", done.stdout)
        self.assertEqual(done.stdout.strip().splitlines()[-1], "0 passed, 0 failed")


if __name__ == "__main__":
    sys.exit(junit_runner.main(__name__, __doc__.splitlines()[0]))
