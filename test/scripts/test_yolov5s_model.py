#!/usr/bin/env python3
"""Tests of the real YOLOv5s converted by scripts/fetch_model.sh (yolov5s-640x192.onnx and
yolov5s-640x640.onnx) on the KITTI object samples of test/data/kitti_object_samples, with OpenCV's
DNN and the preprocessing and decoding of YoloDetector (letterbox with grey 0.5 borders, RGB in
[0, 1], onnx_layout pixels: score = objectness x class probability, per-class NMS at 0.45):

* every labelled car, truck, pedestrian and cyclist (KITTI occlusion < 3) is found: a detection
  of a matching COCO class (truck: truck or bus; cyclist: person or bicycle) with a score above
  0.25 and an IoU above 0.5 with the label's box;
* the 640x192 and 640x640 models agree: the same objects found, their boxes overlapping.

The models are not in the repository (GPL/AGPL weights, fetched at use time). When one is
absent the tests that need it are SKIPPED with the command that fetches it; they never pass.
The model folder: $GVF_MODEL_DIR, default ${XDG_CACHE_HOME:-~/.cache}/grid_vision_fusion/models.
More labelled frames (e.g. 000000, a pedestrian): $GVF_KITTI_OBJECT_DIR, a folder with image_2/
and label_2/ like test/data/kitti_object_samples.

usage: test_yolov5s_model.py [--junit FILE]
"""
import glob
import os
import sys
import time
import unittest

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import junit_runner  # noqa: E402

try:
    import cv2
except ImportError:
    cv2 = None

SAMPLES = os.path.join(ROOT, "test", "data", "kitti_object_samples")
CLASS_NAMES = os.path.join(ROOT, "models", "yolo", "coco.names")
SCORE_THRESHOLD = 0.25
NMS_THRESHOLD = 0.45
# KITTI type -> the COCO classes that count as finding it.
MATCHING_CLASSES = {"Car": {"car"}, "Truck": {"truck", "bus"}, "Pedestrian": {"person"},
                    "Cyclist": {"person", "bicycle"}}


def model_dir():
    default = os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "grid_vision_fusion",
                           "models")
    return os.environ.get("GVF_MODEL_DIR") or default


def iou(a, b):
    """Intersection over union of two boxes (x_min, y_min, x_max, y_max)."""
    w = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    h = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = w * h
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union > 0 else 0.0


def frames():
    """(frame id, image path, labelled objects [(type, box)]) of every sample frame."""
    folders = [SAMPLES] + ([os.environ["GVF_KITTI_OBJECT_DIR"]] if os.environ.get("GVF_KITTI_OBJECT_DIR") else [])
    found = {}
    for folder in folders:
        for label_path in sorted(glob.glob(os.path.join(folder, "label_2", "*.txt"))):
            frame = os.path.splitext(os.path.basename(label_path))[0]
            image = os.path.join(folder, "image_2", frame + ".png")
            if frame in found or not os.path.isfile(image):
                continue
            objects = []
            with open(label_path) as f:
                for line in f:
                    fields = line.split()
                    if len(fields) >= 15 and fields[0] in MATCHING_CLASSES and int(fields[2]) < 3:
                        objects.append((fields[0], tuple(float(v) for v in fields[4:8])))
            found[frame] = (image, objects)
    return [(frame,) + found[frame] for frame in sorted(found)]


class Detector:
    """YoloDetector's ONNX path (letterbox, forward, decode with onnx_layout pixels, NMS) in Python."""

    def __init__(self, path, width, height):
        self.net = cv2.dnn.readNetFromONNX(path)
        self.width, self.height = width, height
        with open(CLASS_NAMES) as f:
            self.names = [line.strip() for line in f if line.strip()]
        self.seconds = []

    def detect(self, image_bgr):
        h, w = image_bgr.shape[:2]
        scale = min(self.width / w, self.height / h)
        rw = min(max(int(round(w * scale)), 1), self.width)
        rh = min(max(int(round(h * scale)), 1), self.height)
        px, py = (self.width - rw) // 2, (self.height - rh) // 2
        canvas = np.full((self.height, self.width, 3), 0.5, np.float32)
        resized = cv2.resize(image_bgr, (rw, rh), interpolation=cv2.INTER_LINEAR)
        canvas[py:py + rh, px:px + rw] = resized.astype(np.float32) / 255.0
        self.net.setInput(cv2.dnn.blobFromImage(canvas, 1.0, swapRB=True))
        start = time.perf_counter()
        rows = self.net.forward()[0]
        self.seconds.append(time.perf_counter() - start)
        scores = rows[:, 4:5] * rows[:, 5:]
        detections = []
        for class_id in range(scores.shape[1]):
            keep = np.nonzero(scores[:, class_id] >= SCORE_THRESHOLD)[0]
            if keep.size == 0:
                continue
            boxes = [(float(r[0] - r[2] / 2), float(r[1] - r[3] / 2), float(r[2]), float(r[3])) for r in rows[keep]]
            chosen = cv2.dnn.NMSBoxes(boxes, scores[keep, class_id].tolist(), SCORE_THRESHOLD, NMS_THRESHOLD)
            for i in np.array(chosen).flatten():
                x, y, bw, bh = boxes[i]
                box = (np.clip((x - px) * w / rw, 0, w), np.clip((y - py) * h / rh, 0, h),
                       np.clip((x + bw - px) * w / rw, 0, w), np.clip((y + bh - py) * h / rh, 0, h))
                detections.append((self.names[class_id], float(scores[keep[i], class_id]), box))
        return sorted(detections, key=lambda d: -d[1])


class RealModelTest(unittest.TestCase):
    """The real model, when it has been fetched."""

    detectors = {}

    def setUp(self):
        self.assertIsNotNone(cv2, "python3-opencv is not installed (scripts/install_deps.sh installs it)")

    def detector(self, width, height):
        path = os.path.join(model_dir(), "yolov5s-%dx%d.onnx" % (width, height))
        if not os.path.isfile(path):
            option = "" if (width, height) == (640, 192) else "--input %dx%d " % (width, height)
            self.skipTest("%s is not there: fetch it with scripts/fetch_model.sh %syolov5s (npm registry; "
                          "GVF_MODEL_DIR names another folder)" % (path, option))
        if (width, height) not in self.detectors:
            self.detectors[(width, height)] = Detector(path, width, height)
        return self.detectors[(width, height)]

    def best_match(self, detections, kitti_type, box):
        candidates = [(iou(box, d[2]), d) for d in detections if d[0] in MATCHING_CLASSES[kitti_type]]
        return max(candidates, key=lambda c: c[0]) if candidates else (0.0, None)

    def check_labelled_objects(self, width, height):
        detector = self.detector(width, height)
        samples = frames()
        self.assertGreaterEqual(len(samples), 2, "no KITTI samples in %s" % SAMPLES)
        checked = 0
        for frame, image_path, objects in samples:
            detections = detector.detect(cv2.imread(image_path))
            for kitti_type, box in objects:
                overlap, match = self.best_match(detections, kitti_type, box)
                print("  %dx%d %s %-10s IoU %.2f %s" % (width, height, frame, kitti_type, overlap,
                                                        "%s %.2f" % match[:2] if match else "not found"))
                with self.subTest(frame=frame, type=kitti_type, box=box):
                    self.assertGreater(overlap, 0.5, "%s %s %s not found: %s" % (frame, kitti_type, box, detections))
                checked += 1
        self.assertGreaterEqual(checked, 3)
        print("  %dx%d: %.0f ms per forward pass (median of %d, %d threads)" %
              (width, height, 1000 * np.median(detector.seconds), len(detector.seconds), cv2.getNumThreads()))

    def test_640x192_finds_the_labelled_objects(self):
        self.check_labelled_objects(640, 192)

    def test_640x640_finds_the_labelled_objects(self):
        self.check_labelled_objects(640, 640)

    def test_640x192_agrees_with_640x640(self):
        wide, square = self.detector(640, 192), self.detector(640, 640)
        for frame, image_path, objects in frames():
            image = cv2.imread(image_path)
            a, b = wide.detect(image), square.detect(image)
            # Each confident detection of one model is found by the other: same class, same place.
            for ours, theirs, label in ((a, b, "640x192"), (b, a, "640x640")):
                for name, score, box in ours:
                    if score < 0.5:
                        continue
                    overlaps = [iou(box, d[2]) for d in theirs if d[0] == name]
                    with self.subTest(frame=frame, model=label, detection=(name, round(score, 2))):
                        self.assertTrue(overlaps and max(overlaps) > 0.7,
                                        "%s: %s %.2f %s of %s has no counterpart: %s" %
                                        (frame, name, score, box, label, theirs))
            # The labelled objects get nearly the same box from both.
            for kitti_type, box in objects:
                overlap_a, match_a = self.best_match(a, kitti_type, box)
                overlap_b, match_b = self.best_match(b, kitti_type, box)
                if match_a and match_b:
                    print("  %s %-10s 640x192 %s %.2f IoU %.2f | 640x640 %s %.2f IoU %.2f | between %.2f" %
                          (frame, kitti_type, match_a[0], match_a[1], overlap_a, match_b[0], match_b[1], overlap_b,
                           iou(match_a[2], match_b[2])))
                    self.assertGreater(iou(match_a[2], match_b[2]), 0.8)


if __name__ == "__main__":
    sys.exit(junit_runner.main(__name__, __doc__.splitlines()[0]))
