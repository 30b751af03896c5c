#!/usr/bin/env python3
"""Tests of scripts/suite_report.py (the scenario suite's summary) on small hand-made
matches.csv files, of scripts/mirror_scenarios.py (mirrored drives) and of
scripts/evaluate_suite.sh's handling of bad input (with --devel: the devel space of a built
catkin workspace).

usage: test_suite_report.py [--junit FILE] [--devel DIR]
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import unittest
from xml.sax.saxutils import escape, quoteattr

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import mirror_scenarios  # noqa: E402
import suite_report  # noqa: E402

HEADER = ("frame,label,truth_motion,predicted_motion,truth_band,truth_speed_mps,longitudinal_m,"
          "position_error_m,speed_error_mps,heading_error_rad,truth_id,track_id\n")
DEVEL = None


def row(label, truth, predicted, band, speed=0.0, position="1.000", speed_error="0.100", heading=""):
    return "f,%s,%s,%s,%s,%.3f,10.00,%s,%s,%s,3,4\n" % (label, truth, predicted, band, speed, position, speed_error,
                                                        heading)


class TempDirTest(unittest.TestCase):
    """A test case with a fresh temporary folder, self.tmp, removed after each test."""

    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.tmp = self.dir.name

    def tearDown(self):
        self.dir.cleanup()


class SuiteReportTest(TempDirTest):
    def scenario(self, name, rows):
        folder = os.path.join(self.tmp, name)
        os.makedirs(folder)
        with open(os.path.join(folder, "matches.csv"), "w") as f:
            f.write(HEADER + "".join(rows))
        return ["--scenario", name, folder, "12"]

    def thresholds(self, values):
        path = os.path.join(self.tmp, "thresholds.json")
        with open(path, "w") as f:
            json.dump(values, f)
        return path

    def run_report(self, args):
        out = os.path.join(self.tmp, "out")
        return suite_report.main(["--output", out] + args), out

    def two_scenarios(self):
        a = self.scenario("a", [row("car", "static", "static", "static"),
                                row("car", "static", "dynamic", "static"),
                                row("car", "dynamic", "dynamic", ">3", 8.0, heading="0.0175"),
                                row("car", "dynamic", "static", "1-3", 1.5),
                                row("pedestrian", "dynamic", "dynamic", "1-3", 1.2, heading="0.0349"),
                                row("pedestrian", "dynamic", "static", "0.5-1", 0.7)])
        b = self.scenario("b", [row("car", "dynamic", "unknown", ">3", 5.0, position="", speed_error=""),
                                row("cyclist", "dynamic", "dynamic", ">3", 4.0, position="3.000"),
                                row("car", "unknown", "static", "unknown")])
        return a + b

    def test_quantiles_as_the_evaluation(self):
        # errorStats() of the evaluation: 0 0 1 sqrt(2) 4 -> median 1, p90 sqrt(2) + .6 (4 - sqrt(2)).
        s = suite_report.error_stats([4.0, 0.0, 1.0, math.sqrt(2.0), 0.0])
        self.assertEqual(s["count"], 5)
        self.assertAlmostEqual(s["median"], 1.0)
        self.assertAlmostEqual(s["p90"], math.sqrt(2.0) + 0.6 * (4.0 - math.sqrt(2.0)))
        self.assertEqual(suite_report.error_stats([])["count"], 0)

    def test_headline_and_tables(self):
        status, out = self.run_report(self.two_scenarios())
        self.assertEqual(status, 0)
        with open(os.path.join(out, "suite_report.json")) as f:
            report = json.load(f)
        h = report["headline"]
        # Moving >= 1 m/s: car >3 (dynamic), car 1-3 (static), pedestrian 1-3 (dynamic), car >3
        # (unknown), cyclist >3 (dynamic) -> 3 of 5; the 0.5-1 and unknown bands are left out.
        self.assertEqual((h["moving_ge1_dynamic"]["found"], h["moving_ge1_dynamic"]["total"]), (3, 5))
        self.assertEqual(h["moving_ge1_dynamic_by_class"]["car"], {"found": 1, "total": 3, "fraction": 1 / 3})
        self.assertEqual(h["moving_ge1_dynamic_by_class"]["van"]["total"], 0)  # listed, absent
        self.assertEqual((h["static_static"]["found"], h["static_static"]["total"]), (1, 2))
        self.assertEqual((h["moving_0.5-1_dynamic"]["found"], h["moving_0.5-1_dynamic"]["total"]), (0, 1))
        car = report["overall"]["car"]
        self.assertEqual(car["matches"], 6)
        self.assertEqual(car["by_truth_band"][">3"], {"unknown": 1, "static": 0, "dynamic": 1})
        self.assertEqual(car["by_truth_band"]["unknown"], {"unknown": 0, "static": 1, "dynamic": 0})
        self.assertEqual(car["position_error_m"]["count"], 5)  # one match without a state
        self.assertAlmostEqual(report["overall"]["pedestrian"]["heading_error_deg"]["median"], 2.0, places=2)
        self.assertEqual([s["name"] for s in report["scenarios"]], ["a", "b"])
        self.assertEqual(report["scenarios"][1]["headline"]["moving_ge1_dynamic"]["total"], 2)
        with open(os.path.join(out, "suite_report.md")) as f:
            md = f.read()
        self.assertIn("| moving >= 1 m/s found dynamic, all classes | 3 | 5 | 60.0 |", md)
        self.assertIn("| car | moving 1-3 m/s | 1 | 0 | 1 | 0 | 0.0 |", md)
        self.assertIn("| a | 6 | 66.7 (2/3) | 50.0 (1/2) | 0.0 (0/1) | 12 |", md)
        self.assertIn("### b", md)

    def test_tracking_figures_are_summed(self):
        # Scenario a: 10 ground-truth object-frames, 8 matched, 1 FP, 2 missed, 1 id switch;
        # b: 5, 5 matched, 0 FP, 0 missed, 0 switches. Sums: GT 15, matched 13, FP 1, missed 2,
        # switches 1 -> MOTA 1 - 4/15, switches per 100 matched 100/13; IDTP 8 + 5, IDFP 1 + 0,
        # IDFN 2 + 0 -> IDF1 26 / 29.
        args = self.two_scenarios()
        counts = {k: 0 for k in suite_report.TRACKING_COUNTS}
        for folder, values in ((args[2], dict(ground_truth=10, matches=8, false_positives=1, misses=2,
                                              id_switches=1, idtp=8, idfp=1, idfn=2, motion_flickers=1)),
                               (args[6], dict(ground_truth=5, matches=5, idtp=5))):
            with open(os.path.join(folder, "metrics.json"), "w") as f:
                json.dump({"tracking": dict(counts, **values)}, f)
        status, out = self.run_report(args)
        self.assertEqual(status, 0)
        with open(os.path.join(out, "suite_report.json")) as f:
            report = json.load(f)
        t = report["tracking"]
        self.assertEqual((t["ground_truth"], t["matches"], t["id_switches"], t["motion_flickers"]), (15, 13, 1, 1))
        self.assertAlmostEqual(t["mota"], 1.0 - 4.0 / 15.0)
        self.assertAlmostEqual(t["id_switches_per_100"], 100.0 / 13.0)
        self.assertAlmostEqual(t["idf1"], 26.0 / 29.0)
        # Motion right over the static and dynamic truths: a has static->static, dynamic->dynamic
        # twice of 6; b has the cyclist of 2 (the truth-unknown car is left out) -> 4 of 8.
        self.assertEqual((report["motion_right"]["found"], report["motion_right"]["total"]), (4, 8))
        self.assertEqual(report["scenarios"][1]["tracking"]["mota"], 1.0)
        with open(os.path.join(out, "suite_report.md")) as f:
            md = f.read()
        self.assertIn("## Tracking (issue 12)", md)
        self.assertIn("| all scenarios | 13 | 50.0 | 1 | 7.69 | 0 | 73.3 | 89.7 | 0 | 1 | 0 |", md)
        self.assertIn("| all classes | 9 |", md)
        # A metrics.json without the tracking figures leaves them out; a broken one is an error.
        with open(os.path.join(args[6], "metrics.json"), "w") as f:
            json.dump({"tracking": {"matches": 1}}, f)
        self.assertEqual(self.run_report(args)[0], 1)

    def test_p_dynamic_calibration_over_the_scenarios(self):
        # Scenario a from evaluate without the p_dynamic column (older output): no probabilities.
        # Scenario b with it: 0.05 static, 0.15 static and dynamic, 0.95 and 1.0 dynamic (bin 9 closed),
        # an unknown truth and an empty field left out.
        a = self.scenario("a", [row("car", "static", "static", "static")])
        folder = os.path.join(self.tmp, "b")
        os.makedirs(folder)
        rows = [("static", "static", 0.05), ("static", "static", 0.15), ("dynamic", "1-3", 0.15),
                ("dynamic", ">3", 0.95), ("dynamic", ">3", 1.0), ("unknown", "unknown", 0.5)]
        with open(os.path.join(folder, "matches.csv"), "w") as f:
            f.write(HEADER.rstrip("\n") + ",p_dynamic\n")
            for truth, band, p in rows:
                f.write("f,car,%s,static,%s,2.000,10.00,1.000,0.100,,3,4,%.4f\n" % (truth, band, p))
            f.write("f,car,dynamic,static,>3,5.000,10.00,1.000,0.100,,3,4,\n")
        status, out = self.run_report(a + ["--scenario", "b", folder, "12"])
        self.assertEqual(status, 0)
        with open(os.path.join(out, "suite_report.json")) as f:
            c = json.load(f)["p_dynamic_calibration"]
        self.assertEqual(c["matches"], 5)
        self.assertEqual([(b["count"], b["dynamic"]) for b in c["bins"] if b["count"]], [(1, 0), (2, 1), (2, 2)])
        self.assertAlmostEqual(c["bins"][9]["mean_p"], 0.975)
        self.assertAlmostEqual(c["brier"], (0.05 ** 2 + 0.15 ** 2 + 0.85 ** 2 + 0.05 ** 2) / 5)
        self.assertAlmostEqual(c["expected_calibration_error"], 0.2 * 0.05 + 0.4 * 0.35 + 0.4 * 0.025)
        with open(os.path.join(out, "suite_report.md")) as f:
            md = f.read()
        self.assertIn("## P(dynamic) calibration", md)
        self.assertIn("| 0.1-0.2 | 2 | 0.150 | 50.0 |", md)

        # Only outputs without probabilities: no section.
        status, out = self.run_report(a)
        with open(os.path.join(out, "suite_report.md")) as f:
            self.assertNotIn("calibration", f.read())

    def test_thresholds_pass_and_fail(self):
        args = self.two_scenarios()
        junit = os.path.join(self.tmp, "junit.xml")
        ok = self.thresholds({"_comment": "x", "min_moving_dynamic": 0.6, "min_static_static": 0.5})
        self.assertEqual(self.run_report(args + ["--thresholds", ok, "--junit", junit])[0], 0)
        with open(junit) as f:
            self.assertIn('tests="2" failures="0"', f.read())
        # Per class with a minimum number of matches: car (3 matches) is checked and fails,
        # pedestrian (1) and cyclist (1) are not.
        bad = self.thresholds({"min_moving_dynamic_per_class": {"car": 0.5, "pedestrian": 0.9, "cyclist": 0.9},
                               "min_class_matches": 2})
        status, out = self.run_report(args + ["--thresholds", bad, "--junit", junit])
        self.assertEqual(status, 3)
        with open(junit) as f:
            xml = f.read()
        self.assertIn('tests="1" failures="1"', xml)
        self.assertIn("moving_ge1_dynamic_car: 1 of 3 = 0.333 &lt; 0.500", xml)
        self.assertTrue(os.path.exists(os.path.join(out, "suite_report.md")))  # written anyway
        one_for_all = self.thresholds({"min_moving_dynamic_per_class": 0.9})
        status, _ = self.run_report(args + ["--thresholds", one_for_all, "--junit", junit])
        self.assertEqual(status, 3)
        with open(junit) as f:
            self.assertIn('tests="3" failures="1"', f.read())  # car fails; pedestrian, cyclist 1 of 1

    def test_bad_input(self):
        args = self.two_scenarios()
        self.assertEqual(self.run_report(args + ["--thresholds", self.thresholds({"min_typo": 0.5})])[0], 1)
        self.assertEqual(self.run_report(args + ["--thresholds", self.thresholds({"min_static_static": 2})])[0], 1)
        folder = os.path.join(self.tmp, "broken")
        os.makedirs(folder)
        with open(os.path.join(folder, "matches.csv"), "w") as f:
            f.write("frame,label\nf,car\n")
        status, out = self.run_report(["--scenario", "broken", folder, "1"])
        self.assertEqual(status, 1)
        self.assertFalse(os.path.exists(os.path.join(out, "suite_report.md")))
        self.assertEqual(self.run_report(["--scenario", "missing", os.path.join(self.tmp, "nowhere"), "1"])[0], 1)


class EvaluateSuiteScriptTest(unittest.TestCase):
    def setUp(self):
        if not DEVEL:
            self.skipTest("no --devel: evaluate_suite.sh's checks need the built tools")

    def run_suite(self, *args):
        return subprocess.run([os.path.join(ROOT, "scripts", "evaluate_suite.sh"), "--devel", DEVEL] +
                              list(args), capture_output=True, text=True)

    def test_unknown_scenario_is_a_usage_error(self):
        with tempfile.TemporaryDirectory() as tmp:
            result = self.run_suite("--scenarios", "no_such_scenario", "--output", tmp)
            self.assertEqual(result.returncode, 2)
            self.assertIn("unknown scenario 'no_such_scenario'; available: ", result.stderr)
            self.assertIn("pedestrians_crossing", result.stderr)

    def test_a_failing_step_names_the_scenario_and_its_log(self):
        with tempfile.TemporaryDirectory() as tmp:
            scenarios = os.path.join(tmp, "scenarios")
            os.makedirs(scenarios)
            with open(os.path.join(scenarios, "broken.yaml"), "w") as f:
                f.write("duration: 1.0\n")  # no ego: make_synthetic_drive refuses it
            out = os.path.join(tmp, "out")
            result = self.run_suite("--scenario-dir", scenarios, "--output", out)
            self.assertEqual(result.returncode, 1)
            log = os.path.join(out, "logs", "broken.log")
            self.assertIn("scenario broken: make_synthetic_drive failed, see " + log, result.stderr)
            self.assertIn("[1/1] broken ... FAILED at make_synthetic_drive", result.stdout)
            with open(log) as f:
                self.assertIn("missing key 'ego'", f.read())
            self.assertEqual(sorted(os.listdir(out)), ["logs"])  # no report, no partial outputs

    def test_reuse_needs_kept_drives_and_another_output(self):
        with tempfile.TemporaryDirectory() as tmp:
            result = self.run_suite("--reuse", tmp, "--output", os.path.join(tmp, "out"))
            self.assertEqual(result.returncode, 2)
            self.assertIn("no kept drives in %s/work (run with --keep first)" % tmp, result.stderr)
            os.makedirs(os.path.join(tmp, "work"))
            result = self.run_suite("--reuse", tmp, "--output", tmp)
            self.assertEqual(result.returncode, 2)
            self.assertIn("--reuse needs another --output folder than " + tmp, result.stderr)
            # A scenario the kept run did not keep: its step fails, naming the missing bag.
            out = os.path.join(tmp, "out")
            result = self.run_suite("--reuse", tmp, "--output", out, "--scenarios", "pedestrians_crossing")
            self.assertEqual(result.returncode, 1)
            self.assertIn("scenario pedestrians_crossing: reuse: no %s/work/pedestrians_crossing/drive.bag failed"
                          % tmp, result.stderr)


SCENARIO = """# suite-from-drive: marker only in the skipped copy
seed: 5
duration: 2.0
road: {center_y: 1.0, half_width: 7.0, lane_width: 3.5}
ego:
  waypoints: [[0.0, 0.0, -1.75], [2.0, 10.0, -1.5]]
actors:
  - {type: Car, size: [4.0, 1.8, 1.5], color: "#884EA0", parked: {x: 20.0, y: -5.2, yaw: 0.1}}
  - {type: Car, size: [4.0, 1.8, 1.5], color: "#CA6F1E", yaw: 0.2, waypoints: [[0.0, 30.0, 3.0, 0.2], [2.0, 26.0, 3.5, 0.3]]}
  - {type: Cyclist, size: [1.8, 0.6, 1.7], color: "#F1C40F", constant_turn: {x: 5.0, y: 2.0, yaw: 0.3, speed: 4.0, yaw_rate: 0.05}}
scenery:
  - {x: 10.0, y: -14.0, yaw: 0.0, size: [60.0, 8.0, 12.0], color: "#A89F91"}
"""


class MirrorScenariosTest(TempDirTest):
    def write(self, name, text):
        os.makedirs(os.path.join(self.tmp, "in"), exist_ok=True)
        with open(os.path.join(self.tmp, "in", name), "w") as f:
            f.write(text)

    def test_every_y_heading_and_turn_rate_is_negated(self):
        import yaml
        original = yaml.safe_load(SCENARIO)
        mirrored = mirror_scenarios.mirror(yaml.safe_load(SCENARIO), 100, "test")
        self.assertEqual(mirrored["seed"], 105)
        self.assertEqual(mirrored["road"]["center_y"], -1.0)
        self.assertEqual(mirrored["ego"]["waypoints"], [[0.0, 0.0, 1.75], [2.0, 10.0, 1.5]])
        self.assertEqual(mirrored["actors"][0]["parked"], {"x": 20.0, "y": 5.2, "yaw": -0.1})
        self.assertEqual(mirrored["actors"][1]["yaw"], -0.2)
        self.assertEqual(mirrored["actors"][1]["waypoints"], [[0.0, 30.0, -3.0, -0.2], [2.0, 26.0, -3.5, -0.3]])
        self.assertEqual(mirrored["actors"][2]["constant_turn"],
                         {"x": 5.0, "y": -2.0, "yaw": -0.3, "speed": 4.0, "yaw_rate": -0.05})
        self.assertEqual(mirrored["scenery"][0]["y"], 14.0)
        # Mirrored twice (the seed moved back): the original.
        self.assertEqual(mirror_scenarios.mirror(mirrored, -100, "test"), original)

    def test_files_recorded_drives_and_bad_input(self):
        self.write("a.yaml", SCENARIO.split("\n", 1)[1])
        self.write("from_drive.yaml", SCENARIO)
        out = os.path.join(self.tmp, "out")
        self.assertEqual(mirror_scenarios.main(["--seed-offset", "1", os.path.join(self.tmp, "in"), out]), 0)
        self.assertEqual(os.listdir(out), ["mirrored_a.yaml"])  # the recorded drive is skipped
        self.write("bad.yaml", "ego:\n  waypoints: [[0.0, 0.0]]\n")
        self.assertEqual(mirror_scenarios.main([os.path.join(self.tmp, "in"), out]), 1)
        self.write("bad.yaml", "ego:\n  flying: {x: 0.0, y: 0.0}\n")
        self.assertEqual(mirror_scenarios.main([os.path.join(self.tmp, "in"), out]), 1)
        self.assertEqual(mirror_scenarios.main([os.path.join(self.tmp, "nowhere"), out]), 1)

    def test_the_simulator_drives_the_mirrored_short_suite(self):
        if not DEVEL:
            self.skipTest("no --devel: make_synthetic_drive is needed")
        out = os.path.join(self.tmp, "mirrored")
        self.assertEqual(mirror_scenarios.main([os.path.join(ROOT, "test", "data", "suite_short"), out]), 0)
        names = sorted(os.listdir(out))
        self.assertEqual(len(names), 2)
        for name in names:
            result = subprocess.run([os.path.join(DEVEL, "lib", "grid_vision_fusion", "make_synthetic_drive"),
                                     "--scenario", os.path.join(out, name), "--frames", "1",
                                     "--calibration", os.path.join(ROOT, "data", "calibration", "2011_09_26"),
                                     "--output", os.path.join(self.tmp, "drive_" + name)],
                                    capture_output=True, text=True)
            self.assertEqual(result.returncode, 0, result.stderr)


def write_junit(path, result, tests):
    failed = {test.id(): message for test, message in result.failures + result.errors}
    skipped = {test.id() for test, _ in result.skipped}
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             '<testsuite name="test_suite_report" tests="%d" failures="%d" errors="0">' % (len(tests), len(failed))]
    for test in tests:
        classname, name = test.id().rsplit(".", 1)
        lines.append('  <testcase classname=%s name=%s time="0">' % (quoteattr(classname), quoteattr(name)))
        if test.id() in failed:
            lines.append('    <failure message="failed">%s</failure>' % escape(failed[test.id()]))
        elif test.id() in skipped:
            lines.append("    <skipped/>")
        lines.append("  </testcase>")
    lines.append("</testsuite>")
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    global DEVEL
    parser = argparse.ArgumentParser()
    parser.add_argument("--junit")
    parser.add_argument("--devel")
    args = parser.parse_args()
    DEVEL = args.devel
    suite = unittest.defaultTestLoader.loadTestsFromModule(sys.modules[__name__])
    tests = []

    def flatten(s):
        for t in s:
            if isinstance(t, unittest.TestSuite):
                flatten(t)
            else:
                tests.append(t)

    flatten(suite)
    result = unittest.TextTestRunner(verbosity=2).run(unittest.TestSuite(tests))
    if args.junit:
        write_junit(args.junit, result, tests)
    return 0 if result.wasSuccessful() else 1


if __name__ == "__main__":
    sys.exit(main())
