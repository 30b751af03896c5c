#!/usr/bin/env python3
"""Tests of scripts/calibrate_detector_noise.py on hand-made frames (label files, detection files
and PNG headers written by the test; no model run): the matching (full and partial boxes,
DontCare, extra boxes, background false positives), the counts of misses and confusions, and
the fitted edge bias and spread against the ones the detections were made with.

usage: test_calibrate_detector_noise.py [--junit FILE]
"""
import json
import os
import struct
import subprocess
import sys
import tempfile
import unittest

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import calibrate_detector_noise as calibrate  # noqa: E402
import junit_runner  # noqa: E402

SCRIPT = os.path.join(ROOT, "scripts", "calibrate_detector_noise.py")
FRAMES = 60


def png_header(width, height):
    """The first 24 bytes of a PNG (signature, IHDR length and type, width, height): all that the
    script reads of an image when it is given detections."""
    return b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + struct.pack(">II", width, height)


def label_line(kind, box, occluded=0, truncated=0.0):
    return "%s %.2f %d 0.00 %.2f %.2f %.2f %.2f 1.5 1.6 4.0 0.0 1.6 10.0 0.0\n" % ((kind, truncated, occluded) + box)


def det_line(frame, label, score, box):
    return "%s %s %.4f %.2f %.2f %.2f %.2f\n" % ((frame, label, score) + box)


class CalibrationTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.TemporaryDirectory()
        root = cls.dir.name
        os.makedirs(os.path.join(root, "image_2"))
        os.makedirs(os.path.join(root, "label_2"))
        rng = np.random.default_rng(3)
        detections = []
        cls.bottom_errors = []
        for f in range(FRAMES):
            frame = "%06d" % f
            with open(os.path.join(root, "image_2", frame + ".png"), "wb") as out:
                out.write(png_header(1242, 375))
            car = (300.0, 150.0, 420.0, 230.0)       # 80 px high
            car2 = (700.0, 160.0, 800.0, 220.0)      # 60 px high
            van = (900.0, 140.0, 1000.0, 230.0)
            pedestrian = (520.0, 120.0, 560.0, 220.0)
            dontcare = (1100.0, 150.0, 1200.0, 200.0)
            with open(os.path.join(root, "label_2", frame + ".txt"), "w") as out:
                out.write(label_line("Car", car))
                out.write(label_line("Car", car2, occluded=1))
                out.write(label_line("Van", van))
                out.write(label_line("Pedestrian", pedestrian))
                out.write("DontCare -1 -1 -10 %.2f %.2f %.2f %.2f -1 -1 -1 -1000 -1000 -1000 -10\n" % dontcare)
            # Every full vehicle box's bottom edge off by -0.03 h +- 0.04 h (the fraction kept).
            def bottom(box):
                fraction = -0.03 + 0.04 * rng.standard_normal()
                cls.bottom_errors.append(fraction)
                return box[:3] + (box[3] + fraction * (box[3] - box[1]),)

            detections.append(det_line(frame, "car", 0.85, bottom(car)))
            # The second car: a partial box (its left half) every other frame, else its box.
            if f % 2:
                detections.append(det_line(frame, "car", 0.7, (car2[0], car2[1], car2[0] + 45.0, car2[3])))
            else:
                detections.append(det_line(frame, "car", 0.7, bottom(car2)))
            # The van: published as a car.
            detections.append(det_line(frame, "car", 0.8, bottom(van)))
            # The pedestrian: found in one frame of three (score 0.6), else a low score only.
            detections.append(det_line(frame, "pedestrian", 0.6 if f % 3 == 0 else 0.2, pedestrian))
            # Inside the DontCare region (ignored); a background box every 4th frame; an extra box.
            detections.append(det_line(frame, "car", 0.9, (1110.0, 155.0, 1150.0, 190.0)))
            if f % 4 == 0:
                detections.append(det_line(frame, "cyclist", 0.55, (50.0, 250.0, 90.0, 330.0)))
            if f % 10 == 0:
                detections.append(det_line(frame, "truck", 0.52, (330.0, 150.0, 400.0, 230.0)))
        cls.detections = os.path.join(root, "dets.txt")
        with open(cls.detections, "w") as out:
            out.writelines(detections)
        cls.json = os.path.join(root, "out.json")
        command = [sys.executable, SCRIPT, "--quiet", "--detections", cls.detections, "--json", cls.json, root]
        cls.completed = subprocess.run(command, capture_output=True, text=True)
        with open(cls.json) as f:
            cls.figures = json.load(f)

    @classmethod
    def tearDownClass(cls):
        cls.dir.cleanup()

    def test_runs_and_prints_the_parameters(self):
        self.assertEqual(self.completed.returncode, 0, self.completed.stderr)
        self.assertIn("## Found and missed labels", self.completed.stdout)
        self.assertIn("```yaml\nnoise:", self.completed.stdout)
        for key in ("presence:", "score:", "bottom:", "person_scale:", "confusion:", "false_positives:"):
            self.assertIn(key, self.completed.stdout)

    def test_misses_partial_boxes_and_confusion(self):
        n, full, partial, missed = self.figures["misses"]["all"]
        self.assertEqual(n, 4 * FRAMES)
        self.assertEqual(partial, FRAMES // 2, "the second car's half box")
        self.assertEqual(missed, FRAMES - FRAMES // 3, "the pedestrian below the threshold in 2 of 3 frames")
        self.assertEqual(full, n - partial - missed)
        self.assertEqual(self.figures["confusion"]["Van"]["car"], FRAMES)
        self.assertEqual(self.figures["confusion"]["Car"]["car"], 2 * FRAMES)

    def test_false_positives_by_kind(self):
        fp = self.figures["false_positives"]
        self.assertEqual(fp["dontcare"]["count"], FRAMES)
        self.assertEqual(fp["background"]["count"], FRAMES // 4)
        self.assertEqual(fp["background"]["classes"]["cyclist"], FRAMES // 4)
        self.assertEqual(fp["extra"]["count"], FRAMES // 10)

    def test_edge_bias_and_spread(self):
        bottom = self.figures["edges"]["bottom"]
        errors = np.array(self.bottom_errors)
        self.assertAlmostEqual(bottom["bias"], float(np.median(errors)), delta=2e-3)
        # The model's spread at a height of 80 px, as a fraction of it, against the errors'.
        core = np.hypot(bottom["sigma_px"] / 80.0, bottom["sigma_fraction"])
        spread = core * np.sqrt(1 - bottom["tail_probability"] + bottom["tail_probability"] * bottom["tail_scale"] ** 2)
        self.assertAlmostEqual(spread, float(np.std(errors)), delta=0.008)
        self.assertAlmostEqual(self.figures["edges"]["top"]["bias"], 0.0, delta=1e-6)

    def test_riders_merged_as_the_detector_does(self):
        # The same boxes as test/ros/test_node_params.cpp's rider test of the C++ detector.
        def box(label, score, b):
            return {"label": label, "score": score, "box": b}
        published = calibrate.published_detections([
            box("bicycle", 0.6, (90, 100, 160, 170)), box("person", 0.8, (100, 40, 140, 150)),
            box("bicycle", 0.9, (400, 100, 460, 170)), box("person", 0.5, (300, 40, 340, 170)),
            box("motorbike", 0.7, (600, 100, 700, 170)), box("person", 0.7, (620, 30, 680, 140))])
        self.assertEqual([(d["label"], d["score"], d["box"]) for d in published],
                         [("cyclist", 0.8, (90, 40, 160, 170)), ("cyclist", 0.7, (600, 30, 700, 170)),
                          ("pedestrian", 0.5, (300, 40, 340, 170))])

    def test_iou_and_bad_input(self):
        self.assertAlmostEqual(calibrate.iou((0, 0, 10, 10), (5, 0, 15, 10)), 1.0 / 3.0)
        self.assertAlmostEqual(calibrate.inside_fraction((0, 0, 10, 10), (5, 0, 20, 20)), 0.5)
        bad = os.path.join(self.dir.name, "bad.txt")
        with open(bad, "w") as f:
            f.write("000000 car 0.5 1 2 3\n")
        result = subprocess.run([sys.executable, SCRIPT, "--detections", bad, self.dir.name], capture_output=True,
                                text=True)
        self.assertNotEqual(result.returncode, 0)
        self.assertIn("bad.txt:1: expected 7 fields", result.stderr)
        result = subprocess.run([sys.executable, SCRIPT, "--detections", bad, os.path.join(self.dir.name, "image_2")],
                                capture_output=True, text=True)
        self.assertIn("no image_2/label_2 frames", result.stderr)


if __name__ == "__main__":
    sys.exit(junit_runner.main(__name__, __doc__.splitlines()[0]))
