#!/usr/bin/env python3
"""Measures how a trained YOLO detector errs on real labelled frames and prints the figures and
the replay backend's noise parameters (the `replay/noise/...` keys of config/yolo_detector.yaml,
doc/detector_noise.md) fitted to them.

usage: calibrate_detector_noise.py --model M.onnx [--input 640x192] DIR [DIR ...]
       calibrate_detector_noise.py --detections DETS.txt DIR [DIR ...]
  DIR holds image_2/*.png and label_2/*.txt (KITTI object layout); the frames of all DIRs are
  pooled by file name (the first DIR holding a name wins).
  --model M.onnx        run YoloDetector's ONNX path (re-done in Python, below) on the images
  --detections FILE     take the detections from FILE instead ("frame label score x_min y_min
                        x_max y_max" per line, e.g. written by --write-detections, by the C++
                        YoloDetector, or by the replay backend with its noise on): no model run
  --class-names FILE    the model's class names (default models/yolo/coco.names)
  --min-score S         the lowest score kept and modelled (default 0.05)
  --score-threshold S   the detector's score_threshold (default 0.5)
  --json FILE           every figure and the fitted parameters
  --write-detections FILE, --frames N (the first N frames only), --check-cpp FILE (compare the
                        Python detections with the C++ YoloDetector's, same format)

The detector: OpenCV DNN with YoloDetector's preprocessing and decoding (letterbox with grey 0.5
borders, RGB in [0, 1], NCHW; output rows cx, cy, w, h in input pixels, objectness, class
probabilities; score = objectness x class probability, every class of a row a candidate;
per-class NMS at 0.45), config/yolo_detector.yaml's rider_merge (a bicycle or motorbike with a
person over it is one cyclist box, as mergeRiders() in src/detection/yolo_detector.cpp) and
class_map (car, truck, bus -> van, person -> pedestrian; other classes dropped).

Matching, per frame, class-agnostic (the class confusion is measured on the matches), labels of
the types Car, Van, Truck, Pedestrian, Person_sitting, Cyclist, Tram, Misc:
  1. full box: detections by decreasing score, each to the unmatched label of largest IoU >= 0.5;
  2. partial box: each detection left, by decreasing score, to the label left unmatched by 1
     and 2 of largest IoU >= 0.1 (the visible part of an occluded car, the rider of a cyclist);
  3. the rest: ignored when more than half of it lies inside a DontCare region (KITTI's rule);
     "extra" when IoU >= 0.1 with a label found by 1 or 2 (a second box on one object: another
     class, a part); "background" otherwise (false positives).
A label is "found" by a full or a partial box, "missed" otherwise. Edge errors (detection -
label, px; + right / down) come from the full boxes, leaving out edges within 2 px of the image
border (boxes cut by the border).

The model fitted (what the replay backend's noise draws, doc/detector_noise.md):
  * detection: a latent logit score z = offset[vehicle|person] + height_slope * ln(h / 50 px)
    + occlusion offset + truncation * truncated + N(0, sigma^2); score = score_max * sigmoid(z);
    no box when the score is below min_score. Fitted by maximum likelihood (censored below
    min_score) over the labels of car, van, truck, pedestrian, person_sitting and cyclist.
    The score_threshold then drops the low scores, as it does with the network.
  * box edges: edge error = bias * h + N(0, sigma_px^2 + (sigma_fraction * h)^2), with
    probability tail_probability the deviation scaled by tail_scale (h = label height); fitted
    on the vehicles, the people's deviations scaled by person_scale.
  * partial boxes: probability by occlusion level; width kept uniform in [width_min, width_max]
    of the label's, on its left or right.
  * class confusion among car/van/truck and pedestrian/cyclist, extra boxes, background false
    positives (Poisson per image at min_score, logit-normal scores, log-normal heights).
"""
import argparse
import glob
import json
import math
import os
import sys

import numpy as np

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
NMS_THRESHOLD = 0.45
CLASS_MAP = {"car": "car", "truck": "truck", "bus": "van", "person": "pedestrian"}
RIDER_MERGE = {"bicycle": "cyclist", "motorbike": "cyclist"}
RIDER_CLASS = "person"
LABELLED = ["Car", "Van", "Truck", "Pedestrian", "Person_sitting", "Cyclist", "Tram", "Misc"]
# The types the replay backend publishes under the five labels of the detector.
EXPECTED = {"Car": "car", "Van": "van", "Truck": "truck", "Pedestrian": "pedestrian",
            "Person_sitting": "pedestrian", "Cyclist": "cyclist"}
OUT_LABELS = ["car", "van", "truck", "pedestrian", "cyclist"]
VEHICLES = ("car", "van", "truck")
HEIGHT_BINS = [25.0, 40.0, 60.0, 100.0]  # px: bins <25, 25-40, 40-60, 60-100, >=100
REFERENCE_HEIGHT = 50.0  # px, where the detection offsets apply
SCORE_QUANTILES = [i / 10.0 for i in range(11)]
BORDER_PX = 2.0
EDGES = ("left", "top", "right", "bottom")


# ---- geometry -------------------------------------------------------------------------------------
def iou(a, b):
    w = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    h = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = w * h
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union > 0 else 0.0


def inside_fraction(det, region):
    w = max(0.0, min(det[2], region[2]) - max(det[0], region[0]))
    h = max(0.0, min(det[3], region[3]) - max(det[1], region[1]))
    area = (det[2] - det[0]) * (det[3] - det[1])
    return w * h / area if area > 0 else 0.0


def height_bin(h):
    for i, edge in enumerate(HEIGHT_BINS):
        if h < edge:
            return i
    return len(HEIGHT_BINS)


def bin_names():
    edges = [0] + [int(e) for e in HEIGHT_BINS]
    return ["%d-%d" % (edges[i], edges[i + 1]) for i in range(len(HEIGHT_BINS))] + [">=%d" % HEIGHT_BINS[-1]]


# ---- statistics -----------------------------------------------------------------------------------
def robust_sigma(values):
    values = np.asarray(values, float)
    if values.size == 0:
        return float("nan")
    return float(1.4826 * np.median(np.abs(values - np.median(values))))


def quantiles(values):
    values = np.asarray(values, float)
    return [round(float(q), 3) for q in np.quantile(values, SCORE_QUANTILES)] if values.size else []


def norm_cdf(x):
    return 0.5 * (1.0 + np.vectorize(math.erf)(np.asarray(x, float) / math.sqrt(2.0)))


def log_norm_cdf(x):
    x = np.asarray(x, float)
    out = np.log(np.maximum(norm_cdf(x), 1e-300))
    # Asymptotic form far in the lower tail, where the CDF underflows.
    low = x < -30
    out[low] = -0.5 * x[low] ** 2 - np.log(-x[low]) - 0.5 * math.log(2 * math.pi)
    return out


def logit(p):
    p = np.clip(np.asarray(p, float), 1e-6, 1 - 1e-6)
    return np.log(p / (1 - p))


def nelder_mead(f, x0, step=0.5, iterations=4000, tolerance=1e-9):
    """Minimises f from x0 (numpy only): the simplex method."""
    n = len(x0)
    simplex = [np.array(x0, float)] + [np.array(x0, float) + step * np.eye(n)[i] for i in range(n)]
    values = [f(x) for x in simplex]
    for _ in range(iterations):
        order = np.argsort(values)
        simplex, values = [simplex[i] for i in order], [values[i] for i in order]
        if abs(values[-1] - values[0]) < tolerance * (1 + abs(values[0])):
            break
        centroid = np.mean(simplex[:-1], axis=0)
        reflected = centroid + (centroid - simplex[-1])
        fr = f(reflected)
        if fr < values[0]:
            expanded = centroid + 2 * (centroid - simplex[-1])
            fe = f(expanded)
            simplex[-1], values[-1] = (expanded, fe) if fe < fr else (reflected, fr)
        elif fr < values[-2]:
            simplex[-1], values[-1] = reflected, fr
        else:
            contracted = centroid + 0.5 * (simplex[-1] - centroid)
            fc = f(contracted)
            if fc < values[-1]:
                simplex[-1], values[-1] = contracted, fc
            else:
                simplex = [simplex[0] + 0.5 * (s - simplex[0]) for s in simplex]
                values = [f(s) for s in simplex]
    best = int(np.argmin(values))
    return simplex[best], values[best]


def table(rows, header):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(out)


# ---- the detector ---------------------------------------------------------------------------------
class Detector:
    """YoloDetector's ONNX path (onnx_layout pixels, letterbox) in Python."""

    def __init__(self, model, width, height, class_names, min_score):
        import cv2
        self.cv2 = cv2
        self.net = cv2.dnn.readNetFromONNX(model)
        self.width, self.height, self.min_score = width, height, min_score
        with open(class_names) as f:
            self.names = [line.strip() for line in f if line.strip()]

    def detect(self, image_bgr):
        cv2 = self.cv2
        h, w = image_bgr.shape[:2]
        scale = min(self.width / w, self.height / h)
        rw = min(max(int(round(w * scale)), 1), self.width)
        rh = min(max(int(round(h * scale)), 1), self.height)
        px, py = (self.width - rw) // 2, (self.height - rh) // 2
        canvas = np.full((self.height, self.width, 3), 0.5, np.float32)
        canvas[py:py + rh, px:px + rw] = cv2.resize(image_bgr, (rw, rh), interpolation=cv2.INTER_LINEAR) / 255.0
        self.net.setInput(cv2.dnn.blobFromImage(canvas, 1.0, swapRB=True))
        rows = self.net.forward()[0]
        sx, sy = rw / w, rh / h
        detections = []
        for class_id, coco in enumerate(self.names):
            if coco not in CLASS_MAP and coco not in RIDER_MERGE:
                continue
            scores = rows[:, 4] * rows[:, 5 + class_id]
            keep = np.nonzero((rows[:, 4] > 0) & (scores >= self.min_score))[0]
            if keep.size == 0:
                continue
            boxes = [(float(r[0] - r[2] / 2), float(r[1] - r[3] / 2), float(r[2]), float(r[3])) for r in rows[keep]]
            chosen = cv2.dnn.NMSBoxes(boxes, scores[keep].tolist(), self.min_score, NMS_THRESHOLD)
            for i in np.array(chosen).flatten():
                x, y, bw, bh = boxes[i]
                box = (float(np.clip((x - px) / sx, 0, w)), float(np.clip((y - py) / sy, 0, h)),
                       float(np.clip((x + bw - px) / sx, 0, w)), float(np.clip((y + bh - py) / sy, 0, h)))
                if box[2] > box[0] and box[3] > box[1]:
                    detections.append({"label": coco, "score": float(scores[keep[i]]), "box": box})
        return published_detections(detections)


def published_detections(detections):
    """The detector's labelling of boxes labelled by COCO class: riders merged, then CLASS_MAP."""
    vehicles = sorted((d for d in detections if d["label"] in RIDER_MERGE), key=lambda d: -d["score"])
    riders = [d for d in detections if d["label"] == RIDER_CLASS]
    used, published = set(), []
    for vehicle in vehicles:
        vx0, vy0, vx1, vy1 = vehicle["box"]
        best, widest = None, 0.0
        for rider in riders:
            rx0, ry0, rx1, ry1 = rider["box"]
            centre = 0.5 * (rx0 + rx1)
            overlap = min(rx1, vx1) - max(rx0, vx0)
            if (id(rider) not in used and vx0 <= centre <= vx1 and ry0 < vy0 and ry1 > vy0 + 0.2 * (vy1 - vy0)
                    and overlap > widest):
                best, widest = rider, overlap
        if best is None:
            continue
        used.update((id(vehicle), id(best)))
        rx0, ry0, rx1, ry1 = best["box"]
        published.append({"label": RIDER_MERGE[vehicle["label"]], "score": max(vehicle["score"], best["score"]),
                          "box": (min(vx0, rx0), min(vy0, ry0), max(vx1, rx1), max(vy1, ry1))})
    published += [dict(d, label=CLASS_MAP[d["label"]]) for d in detections
                  if id(d) not in used and d["label"] in CLASS_MAP]
    published.sort(key=lambda d: -d["score"])
    return published


def read_detections(path):
    by_frame = {}
    with open(path) as f:
        for number, line in enumerate(f, 1):
            fields = line.split()
            if not fields:
                continue
            if len(fields) != 7:
                sys.exit("calibrate_detector_noise: %s:%d: expected 7 fields" % (path, number))
            by_frame.setdefault(fields[0], []).append(
                {"label": fields[1], "score": float(fields[2]), "box": tuple(float(v) for v in fields[3:7])})
    return by_frame


def read_labels(path):
    labels = []
    with open(path) as f:
        for line in f:
            fields = line.split()
            if len(fields) >= 15:
                labels.append({"type": fields[0], "truncated": float(fields[1]), "occluded": int(float(fields[2])),
                               "box": tuple(float(v) for v in fields[4:8])})
    return labels


def find_frames(folders):
    frames = {}
    for folder in folders:
        for label_path in sorted(glob.glob(os.path.join(folder, "label_2", "*.txt"))):
            name = os.path.splitext(os.path.basename(label_path))[0]
            image_path = os.path.join(folder, "image_2", name + ".png")
            if name not in frames and os.path.isfile(image_path):
                frames[name] = (image_path, label_path)
    return [(name,) + frames[name] for name in sorted(frames)]


def image_size(path):
    """Width and height of a PNG from its header (no decoding)."""
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        import cv2
        h, w = cv2.imread(path).shape[:2]
        return w, h
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


# ---- matching -------------------------------------------------------------------------------------
def match_frame(detections, labels):
    """Labels of LABELLED types with 'found' (the detection or None) and 'how' ('full', 'partial',
    None); each detection gets its 'kind' (full, partial, dontcare, extra, background)."""
    objects = [dict(l, found=None, how=None) for l in labels if l["type"] in LABELLED]
    dontcare = [l["box"] for l in labels if l["type"] == "DontCare"]
    detections = sorted(detections, key=lambda d: -d["score"])
    for d in detections:
        d["kind"] = None
    # Full boxes first (IoU >= 0.5), then what is left as partial boxes (IoU >= 0.1).
    for kind, min_iou in (("full", 0.5), ("partial", 0.1)):
        for d in detections:
            if d["kind"] is not None:
                continue
            best, best_iou = None, min_iou
            for o in objects:
                if o["found"] is None:
                    overlap = iou(d["box"], o["box"])
                    if overlap >= best_iou:
                        best, best_iou = o, overlap
            if best is not None:
                best["found"], best["how"] = d, kind
                d["kind"], d["iou"] = kind, best_iou
    for d in detections:
        if d["kind"] is not None:
            continue
        top = max([iou(d["box"], o["box"]) for o in objects if o["found"] is not None] or [0.0])
        if any(inside_fraction(d["box"], r) > 0.5 for r in dontcare):
            d["kind"] = "dontcare"
        elif top >= 0.1:
            d["kind"] = "extra"
        else:
            d["kind"] = "background"
    return objects


# ---- fits -----------------------------------------------------------------------------------------
def detection_covariates(o):
    """One row of the detection model's design: the five label offsets, ln(h / 50 px), occlusion
    1 and 2 (and 3), truncation."""
    h = o["box"][3] - o["box"][1]
    label = EXPECTED[o["type"]]
    occ = o["occluded"]
    return [1.0 if label == l else 0.0 for l in OUT_LABELS] + [
        math.log(max(h, 1.0) / REFERENCE_HEIGHT), 1.0 if occ == 1 else 0.0, 1.0 if occ >= 2 else 0.0,
        o["truncated"]]


COVARIATE_KEYS = OUT_LABELS + ["height_slope", "occlusion1", "occlusion2", "truncation"]


def fit_detection(objects, min_score, score_max, cuts):
    """The two parts of the detection model (see the module's docstring):
    presence: logistic regression of "the label has a box of score >= min_score" (its full box at
      any score, or its partial box at the score threshold: partial boxes below it are mostly
      stray low-score boxes overlapping it), by Newton's method;
    score: least squares of logit(score / score_max) of the boxes present, and the residual sigma.
    A weak prior (sd 3) keeps the offsets of classes with few labels finite."""
    x = np.array([detection_covariates(o) for o in objects])
    present = np.array([o["fit_score"] is not None for o in objects], float)
    ridge = np.eye(x.shape[1]) / 9.0
    beta = np.zeros(x.shape[1])
    for _ in range(100):
        p = 1.0 / (1.0 + np.exp(-(x @ beta)))
        gradient = x.T @ (present - p) - ridge @ beta
        hessian = (x * (p * (1 - p))[:, None]).T @ x + ridge
        step = np.linalg.solve(hessian, gradient)
        beta += step
        if np.max(np.abs(step)) < 1e-10:
            break
    xs = x[present > 0]
    scores = np.array([o["fit_score"] for o in objects if o["fit_score"] is not None])
    z = logit(np.minimum(scores, score_max * 0.999) / score_max)
    gamma = np.linalg.solve(xs.T @ xs + ridge, xs.T @ z)
    sigma = float(np.sqrt(np.mean((z - xs @ gamma) ** 2)))
    # The scores are skewed (many near the model's ceiling, a long tail down to the min score):
    # a least-squares normal misplaces the share above a threshold. The fit that is used is
    # interval-censored maximum likelihood on the score bins of `cuts`, which weighs the
    # thresholds that matter (0.4 to 0.6) and not the shape far from them.
    bounds = np.array([-np.inf] + [float(logit(c / score_max)) for c in cuts] + [np.inf])
    bins = np.searchsorted(np.array(cuts), scores, side="right")
    lo, hi = bounds[bins], bounds[bins + 1]
    k = x.shape[1]

    def nll(theta):
        mu, sd = xs @ theta[:k], math.exp(theta[k])
        mass = norm_cdf((hi - mu) / sd) - norm_cdf((lo - mu) / sd)
        return -float(np.sum(np.log(np.maximum(mass, 1e-300)))) + float(theta[:k] @ ridge @ theta[:k]) / 2

    theta, _ = nelder_mead(nll, list(gamma) + [math.log(sigma)], iterations=20000)
    for _ in range(3):
        theta, _ = nelder_mead(nll, theta, step=0.2, iterations=20000)
    gamma, sigma = theta[:k], float(math.exp(theta[k]))
    fitted = {"presence": {k: float(v) for k, v in zip(COVARIATE_KEYS, beta)},
              "score": dict({k: float(v) for k, v in zip(COVARIATE_KEYS, gamma)}, sigma=sigma)}
    return fitted, x


def predicted_found(fitted, x, threshold, score_max):
    """P(a box with a score >= threshold) of each label under the fitted model."""
    beta = np.array([fitted["presence"][k] for k in COVARIATE_KEYS])
    gamma = np.array([fitted["score"][k] for k in COVARIATE_KEYS])
    present = 1.0 / (1.0 + np.exp(-(x @ beta)))
    if threshold >= score_max:
        return np.zeros(len(x))
    cut = float(logit(threshold / score_max))
    return present * (1.0 - norm_cdf((cut - x @ gamma) / fitted["score"]["sigma"]))


def fit_sigma(sizes, errors):
    """Least squares of e^2 = a^2 + (b h)^2 on binned robust variances: (a [px], b [fraction])."""
    sizes, errors = np.asarray(sizes, float), np.asarray(errors, float)
    order = np.argsort(sizes)
    groups = np.array_split(order, max(1, min(6, sizes.size // 15)))
    s2, v = [], []
    for g in groups:
        if g.size >= 5:
            s2.append(np.median(sizes[g]) ** 2)
            v.append(robust_sigma(errors[g]) ** 2)
    s2, v = np.array(s2), np.array(v)
    if s2.size < 2:
        return robust_sigma(errors), 0.0
    coef, *_ = np.linalg.lstsq(np.stack([np.ones_like(s2), s2], 1), v, rcond=None)
    a2, b2 = coef
    if b2 < 0:
        return math.sqrt(max(float(np.mean(v)), 0.0)), 0.0
    if a2 < 0:
        return 0.0, math.sqrt(float(np.sum(v * s2) / np.sum(s2 * s2)))
    return math.sqrt(a2), math.sqrt(b2)


def fit_scale_mixture(r, iterations=200):
    """EM of (1 - p) N(0, s1^2) + p N(0, s2^2) on r: (s1, s2, p)."""
    r = np.asarray(r, float)
    s1, s2, p = 1.0, 3.0, 0.1
    for _ in range(iterations):
        a = (1 - p) * np.exp(-0.5 * (r / s1) ** 2) / s1
        b = p * np.exp(-0.5 * (r / s2) ** 2) / s2
        w = b / np.maximum(a + b, 1e-300)
        p = float(np.clip(np.mean(w), 1e-4, 0.5))
        s1 = math.sqrt(float(np.sum((1 - w) * r * r) / max(np.sum(1 - w), 1e-9)))
        s2 = math.sqrt(float(np.sum(w * r * r) / max(np.sum(w), 1e-9)))
        if s2 < s1:
            s2 = s1
    return s1, s2, p


def fit_truncated_normal(values, floor):
    """Mean and sigma of a normal truncated below `floor`, by maximum likelihood."""
    values = np.asarray(values, float)

    def nll(theta):
        mu, sigma = theta[0], math.exp(theta[1])
        tail = 1.0 - norm_cdf((floor - mu) / sigma)
        return -float(np.sum(-0.5 * ((values - mu) / sigma) ** 2 - math.log(sigma)) -
                      values.size * math.log(max(float(tail), 1e-300)))

    theta, _ = nelder_mead(nll, [float(np.mean(values)), math.log(max(float(np.std(values)), 0.1))])
    return float(theta[0]), float(math.exp(theta[1]))


# ---- main -----------------------------------------------------------------------------------------
def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+")
    parser.add_argument("--model")
    parser.add_argument("--detections")
    parser.add_argument("--input", default="640x192")
    parser.add_argument("--class-names", default=os.path.join(ROOT, "models", "yolo", "coco.names"))
    parser.add_argument("--min-score", type=float, default=0.05)
    parser.add_argument("--score-max", type=float, default=0.95,
                        help="the largest score the model gives (scores = score_max * sigmoid(z))")
    parser.add_argument("--score-threshold", type=float, default=0.5)
    parser.add_argument("--score-cuts", type=lambda v: [float(c) for c in v.split(",")], default=[0.4, 0.5, 0.6],
                        help="score bins of the score model's fit (comma-separated)")
    parser.add_argument("--fp-fit-floor", type=float, default=0.2,
                        help="the false positives' score model is fitted to their scores above this")
    parser.add_argument("--json")
    parser.add_argument("--write-detections")
    parser.add_argument("--check-cpp")
    parser.add_argument("--frames", type=int, default=0)
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")
    args = parser.parse_args()
    if bool(args.model) == bool(args.detections):
        parser.error("give --model or --detections")
    frames = find_frames(args.folders)
    if args.frames:
        frames = frames[:args.frames]
    if not frames:
        sys.exit("calibrate_detector_noise: no image_2/label_2 frames in " + " ".join(args.folders))

    detections_of = {}
    if args.model:
        import cv2
        width, height = (int(v) for v in args.input.lower().split("x"))
        detector = Detector(args.model, width, height, args.class_names, args.min_score)
        for i, (name, image_path, _) in enumerate(frames):
            detections_of[name] = detector.detect(cv2.imread(image_path))
            if not args.quiet:
                sys.stderr.write("\r[%d/%d] %s" % (i + 1, len(frames), name))
        if not args.quiet:
            sys.stderr.write("\n")
    else:
        detections_of = read_detections(args.detections)
    written = ["%s %s %.4f %.2f %.2f %.2f %.2f" % ((name, d["label"], d["score"]) + tuple(d["box"]))
               for name, _, _ in frames for d in detections_of.get(name, [])]
    if args.write_detections:
        with open(args.write_detections, "w") as f:
            f.write("\n".join(written) + "\n")

    thr, names = args.score_threshold, bin_names()
    objects, kept_dets, sizes = [], [], []
    for name, image_path, label_path in frames:
        w, h = image_size(image_path)
        labels = read_labels(label_path)
        dets = [dict(d, frame=name) for d in detections_of.get(name, []) if d["score"] >= args.min_score]
        published = [dict(d) for d in dets if d["score"] >= thr]
        high = match_frame(published, labels)
        low = match_frame(dets, labels)
        for o, lo in zip(high, low):
            o.update(frame=name, image_width=w, image_height=h, low=lo["found"], low_how=lo["how"])
            # The score of the box that finds the label at the threshold, else of its full box below it.
            o["fit_score"] = (o["found"]["score"] if o["found"] is not None else
                              lo["found"]["score"] if lo["how"] == "full" else None)
        objects += high
        kept_dets.append((name, w, h, published, dets))
        sizes.append((w, h))
    n_images = len(frames)
    source = os.path.basename(args.model) + " at " + args.input if args.model else args.detections
    print("# Detector calibration: %s, %d frames (%s .. %s), score threshold %.2f\n" %
          (source, n_images, frames[0][0], frames[-1][0], thr))
    if args.check_cpp:
        check_cpp(args.check_cpp, written)
    out = {"source": source, "frames": [f[0] for f in frames], "score_threshold": thr, "min_score": args.min_score,
           "score_max": args.score_max}

    modelled = [o for o in objects if o["type"] in EXPECTED]
    hgt = lambda o: o["box"][3] - o["box"][1]  # noqa: E731

    # ---- misses ------------------------------------------------------------------------------------
    def miss_row(group, key):
        n = len(group)
        full = sum(1 for o in group if o["how"] == "full")
        partial = sum(1 for o in group if o["how"] == "partial")
        missed = n - full - partial
        low_missed = sum(1 for o in group if o["fit_score"] is None)
        rate = lambda k: "%.3f" % (k / n) if n else "-"  # noqa: E731
        return [key, n, full, partial, missed, rate(missed), rate(n - full), rate(low_missed)]

    header = ["labels", "n", "full box", "partial box", "missed", "miss rate", "no full box",
              "missed at min score (no full box at any score, no partial box at the threshold)"]
    print("## Found and missed labels at the score threshold (Car, Van, Truck, Pedestrian, Person_sitting, "
          "Cyclist)\n")
    groups = [("all", modelled)]
    groups += [("height " + b + " px", [o for o in modelled if height_bin(hgt(o)) == i]) for i, b in enumerate(names)]
    groups += [("occluded %d" % k, [o for o in modelled if o["occluded"] == k]) for k in range(4)]
    groups += [(key, [o for o in modelled if lo <= o["truncated"] < hi])
               for lo, hi, key in ((0.0, 1e-4, "truncated 0"), (1e-4, 0.3, "truncated (0, 0.3)"),
                                   (0.3, 1.01, "truncated >= 0.3"))]
    groups += [(t, [o for o in objects if o["type"] == t]) for t in LABELLED]
    for vehicle in (True, False):
        kind = "vehicles" if vehicle else "people"
        sub = [o for o in modelled if (EXPECTED[o["type"]] in VEHICLES) == vehicle]
        groups += [("%s, clear, %s px" % (kind, b),
                    [o for o in sub if height_bin(hgt(o)) == i and o["occluded"] == 0 and o["truncated"] < 1e-4])
                   for i, b in enumerate(names)]
    print(table([miss_row(g, k) for k, g in groups], header) + "\n")
    out["misses"] = {k: miss_row(g, k)[1:5] for k, g in groups}

    # ---- class confusion ---------------------------------------------------------------------------
    print("## Class of the found labels (full and partial boxes; truth type x detected label)\n")
    rows, confusion = [], {}
    for t in LABELLED:
        found = [o["found"]["label"] for o in objects if o["type"] == t and o["found"] is not None]
        counts = [found.count(l) for l in OUT_LABELS]
        confusion[t] = dict(zip(OUT_LABELS, counts))
        rows.append([t] + counts + [len(found)])
    print(table(rows, ["truth \\ detected"] + OUT_LABELS + ["found"]) + "\n")
    out["confusion"] = confusion

    # ---- box edges ---------------------------------------------------------------------------------
    # Fitted on the vehicles (most of the labels); the deviations of the people's edges, relative
    # to their height, are smaller (narrow boxes): one factor, person_scale, for all four.
    print("## Box edges of the full boxes, detection - label [px] (+: right, down); edges at the image "
          "border left out\n")

    def edge_errors(e_index, vehicles):
        hs, errs = [], []
        for o in modelled:
            if o["how"] != "full" or (EXPECTED[o["type"]] in VEHICLES) != vehicles:
                continue
            t, d = o["box"], o["found"]["box"]
            limit = o["image_width"] if e_index in (0, 2) else o["image_height"]
            if min(t[e_index], limit - t[e_index]) < BORDER_PX or min(d[e_index], limit - d[e_index]) < BORDER_PX:
                continue
            hs.append(t[3] - t[1])
            errs.append(d[e_index] - t[e_index])
        return np.array(hs), np.array(errs)

    edge_rows, edge_fit, by_height_rows, person_ratios = [], {}, {b: [b] for b in names}, []
    for e_index, edge in enumerate(EDGES):
        for vehicles in (True, False):
            hs, errs = edge_errors(e_index, vehicles)
            frac = errs / hs
            if errs.size == 0:
                if vehicles:
                    sys.exit("calibrate_detector_noise: no full box of a vehicle with its %s edge off the image "
                             "border: nothing to fit" % edge)
                edge_rows.append([edge, "people", 0] + ["-"] * 9)
                continue
            if vehicles:
                bias = float(np.median(frac))
                a, b = fit_sigma(hs, errs - bias * hs)
                if a > 1e-9 or b > 1e-9:
                    r = (errs - bias * hs) / np.sqrt(a * a + (b * hs) ** 2)
                    s1, s2, p = fit_scale_mixture(r)
                else:  # no spread at all (hand-made data)
                    s1, s2, p = 1.0, 1.0, 0.0
                edge_fit[edge] = {"bias": bias, "sigma_px": s1 * a, "sigma_fraction": s1 * b,
                                  "tail_probability": p, "tail_scale": s2 / s1, "n": int(errs.size)}
                vehicle_spread = float(np.mean(np.abs(frac - bias)))
                fit = "%.2f px, %.3f h" % (s1 * a, s1 * b)
                tails = "%.3f x %.1f" % (p, s2 / s1)
            else:
                if vehicle_spread <= 0.0:
                    fit, tails = "-", ""
                else:
                    ratio = float(np.mean(np.abs(frac - edge_fit[edge]["bias"]))) / vehicle_spread
                    if ratio > 0.0:
                        person_ratios.append(ratio)
                    fit, tails = "mean abs deviation %.2f x the vehicles'" % ratio, ""
            q = np.quantile(frac, [0.01, 0.05, 0.25, 0.5, 0.75, 0.95, 0.99])
            edge_rows.append([edge, "vehicles" if vehicles else "people", errs.size, "%+.2f" % np.mean(errs),
                              "%+.2f" % np.median(errs), "%.2f" % robust_sigma(errs), "%.2f" % np.std(errs),
                              "%+.3f" % np.median(frac), "%.3f" % robust_sigma(frac),
                              " ".join("%+.2f" % v for v in q), fit, tails])
        hs_all = np.concatenate([edge_errors(e_index, v)[0] for v in (True, False)])
        errs_all = np.concatenate([edge_errors(e_index, v)[1] for v in (True, False)])
        for i, bname in enumerate(names):
            sel = np.array([height_bin(v) == i for v in hs_all], bool)
            by_height_rows[bname].append("%+.1f / %.1f (%d)" % (np.median(errs_all[sel]), robust_sigma(errs_all[sel]),
                                                                sel.sum()) if sel.sum() else "-")
    person_scale = float(np.exp(np.mean(np.log(person_ratios)))) if person_ratios else 1.0
    print(table(edge_rows, ["edge", "labels", "n", "mean", "median", "sigma (1.48 MAD)", "std", "median / h",
                            "sigma / h", "quantiles / h 1 5 25 50 75 95 99 %", "core sigma fit",
                            "tails: probability x scale"]) + "\n")
    print("person_scale (geometric mean of the people's ratios): %.3f\n" % person_scale)
    print("By label height, all labels, median / sigma (1.48 MAD) [px] (n):\n")
    print(table(list(by_height_rows.values()), ["height px"] + list(EDGES)) + "\n")
    ious = [o["found"]["iou"] for o in modelled if o["how"] == "full"]
    print("IoU of the full boxes with their labels: median %.3f, 10th percentile %.3f\n" %
          (np.median(ious), np.quantile(ious, 0.1)))
    edge_fit["person_scale"] = person_scale
    out["edges"] = edge_fit

    # ---- partial boxes -----------------------------------------------------------------------------
    print("## Partial boxes (found labels at the score threshold)\n")
    rows, partial_fit = [], {}
    for k in range(3):
        found = [o for o in modelled if o["found"] is not None and min(o["occluded"], 2) == k]
        partial = [o for o in found if o["how"] == "partial"]
        partial_fit["occlusion%d" % k] = len(partial) / len(found) if found else 0.0
        rows.append(["occluded %d%s" % (k, "+" if k == 2 else ""), len(found), len(partial),
                     "%.3f" % partial_fit["occlusion%d" % k]])
    print(table(rows, ["labels", "found", "partial", "share"]) + "\n")
    partial = [o for o in modelled if o["how"] == "partial"]
    width_ratio = [min(1.0, (o["found"]["box"][2] - o["found"]["box"][0]) / (o["box"][2] - o["box"][0]))
                   for o in partial]
    if width_ratio:
        partial_fit["width_min"] = float(np.quantile(width_ratio, 0.1))
        partial_fit["width_max"] = float(np.quantile(width_ratio, 0.8))
        print("Width of a partial box / the label's: quantiles %s\n" % quantiles(width_ratio))
    out["partial"] = partial_fit

    # ---- extra boxes and false positives -----------------------------------------------------------
    found_count = sum(1 for o in modelled if o["found"] is not None)
    print("## Extra boxes and false positives at the score threshold (%d images)\n" % n_images)
    rows, fp_out = [], {}
    for kind in ("extra", "background", "dontcare"):
        group = [d for _, _, _, published, _ in kept_dets for d in published if d["kind"] == kind]
        heights = [d["box"][3] - d["box"][1] for d in group]
        fp_out[kind] = {"count": len(group), "per_image": len(group) / n_images,
                        "classes": {l: sum(1 for d in group if d["label"] == l) for l in OUT_LABELS}}
        rows.append([kind, len(group), "%.3f" % (len(group) / n_images),
                     ", ".join("%s %d" % (l, c) for l, c in fp_out[kind]["classes"].items() if c),
                     "%.0f / %.0f / %.0f" % tuple(np.quantile(heights, [0.1, 0.5, 0.9])) if heights else "-"])
    print(table(rows, ["kind", "count", "per image", "classes", "height 10/50/90 % [px]"]) + "\n")
    print("Extra boxes per found label: %d / %d = %.3f\n" % (fp_out["extra"]["count"], found_count,
                                                             fp_out["extra"]["count"] / max(found_count, 1)))
    # One logit-normal score model for background and extra boxes, fitted to the scores above
    # --fp-fit-floor (the tail that a threshold acts on); the rates at the min score follow from it.
    back = [(d, w, h) for _, w, h, _, dets in kept_dets for d in dets if d["kind"] == "background"]
    extra = [d for _, _, _, _, dets in kept_dets for d in dets if d["kind"] == "extra"]
    found_low = sum(1 for o in modelled if o["fit_score"] is not None)
    fp_fit, extra_rate = {}, 0.0
    if back:
        floor = args.fp_fit_floor
        tail_scores = np.array([d["score"] for d, _, _ in back if d["score"] >= floor] +
                               [d["score"] for d in extra if d["score"] >= floor])
        z = logit(np.minimum(tail_scores, args.score_max * 0.999) / args.score_max)
        mu, sigma = fit_truncated_normal(z, float(logit(floor / args.score_max)))

        def tail(t):
            return 1.0 - float(norm_cdf((logit(t / args.score_max) - mu) / sigma))

        scale = tail(args.min_score) / tail(floor)
        back_rate = sum(1 for d, _, _ in back if d["score"] >= floor) / n_images * scale
        extra_rate = sum(1 for d in extra if d["score"] >= floor) / max(found_low, 1) * scale
        heights = np.array([d["box"][3] - d["box"][1] for d, _, _ in back])
        bottoms = np.array([d["box"][3] / h for d, _, h in back])
        aspects = {g: [(d["box"][2] - d["box"][0]) / (d["box"][3] - d["box"][1]) for d, _, _ in back
                       if (d["label"] in VEHICLES) == (g == "vehicle")] for g in ("vehicle", "person")}
        classes = {l: sum(1 for d, _, _ in back if d["label"] == l) / len(back) for l in OUT_LABELS}
        high = [d for d, _, _ in back if d["score"] >= thr]
        fp_fit = {"rate": back_rate, "score_mean": mu, "score_sigma": sigma,
                  "height_median": float(np.median(heights)), "height_sigma": float(np.std(np.log(heights))),
                  "bottom_min": float(np.quantile(bottoms, 0.05)), "bottom_max": float(np.quantile(bottoms, 0.95)),
                  "vehicle_aspect": float(np.median(aspects["vehicle"])) if aspects["vehicle"] else 1.5,
                  "person_aspect": float(np.median(aspects["person"])) if aspects["person"] else 0.5,
                  "classes": classes}
        print("Scores of the background and extra boxes above %.2f (%d): logit(score / score_max) fitted "
              "N(%.2f, %.2f^2) truncated there. Background boxes per image: measured %.3f at %.2f, %.3f at the "
              "threshold; the model %.3f at %.2f, %.3f at the threshold (%.2f per image at the min score %.2f). Extra "
              "boxes per found label: measured %.3f at the threshold, the model %.3f (%.3f at the min score)\n"
              % (floor, tail_scores.size, mu, sigma, sum(1 for d, _, _ in back if d["score"] >= floor) / n_images,
                 floor, len(high) / n_images, back_rate * tail(floor) / tail(args.min_score), floor,
                 back_rate * tail(thr) / tail(args.min_score), back_rate, args.min_score,
                 sum(1 for d in extra if d["score"] >= thr) / max(found_low, 1),
                 extra_rate * tail(thr) / tail(args.min_score), extra_rate))
        print("Background boxes: heights median %.0f px, sigma of ln %.2f; bottom edge at %.2f-%.2f of the image "
              "height (5-95 %%); width / height median %.2f (car, van, truck), %.2f (pedestrian, cyclist); classes "
              "%s\n" % (fp_fit["height_median"], fp_fit["height_sigma"], fp_fit["bottom_min"], fp_fit["bottom_max"],
                         fp_fit["vehicle_aspect"], fp_fit["person_aspect"],
                         ", ".join("%s %.2f" % (l, c) for l, c in classes.items())))
        if high:
            listed = ["%s %s %.2f h %.0f at (%.0f, %.0f)" % (d["frame"], d["label"], d["score"],
                                                           d["box"][3] - d["box"][1], (d["box"][0] + d["box"][2]) / 2,
                                                           d["box"][3]) for d in high]
            print("Background false positives at the threshold: " + ", ".join(listed) + "\n")
    out["false_positives"] = fp_out

    # ---- scores ------------------------------------------------------------------------------------
    print("## Scores of the found labels and of the false positives, down to the min score %.2f\n" % args.min_score)
    rows = [["found labels", sum(1 for o in modelled if o["fit_score"] is not None)] +
            quantiles([o["fit_score"] for o in modelled if o["fit_score"] is not None])]
    for i, bname in enumerate(names):
        s = [o["fit_score"] for o in modelled if o["fit_score"] is not None and height_bin(hgt(o)) == i]
        rows.append(["found, height " + bname, len(s)] + (quantiles(s) or ["-"] * 11))
    for kind in ("extra", "background"):
        s = [d["score"] for _, _, _, _, dets in kept_dets for d in dets if d["kind"] == kind]
        rows.append(["false positives " + kind, len(s)] + (quantiles(s) or ["-"] * 11))
    print(table(rows, ["", "n"] + ["q%d" % int(q * 100) for q in SCORE_QUANTILES]) + "\n")

    # ---- the latent detection model ----------------------------------------------------------------
    fitted, x = fit_detection(modelled, args.min_score, args.score_max, args.score_cuts)
    p_thr = predicted_found(fitted, x, thr, args.score_max)
    p_low = predicted_found(fitted, x, args.min_score, args.score_max)
    print("## The detection model fitted (presence of a box, then its logit score)\n")
    for part in ("presence", "score"):
        print("%s: %s\n" % (part, ", ".join("%s %.3f" % kv for kv in fitted[part].items())))
    rows = []
    for key, group in groups:
        idx = [i for i, o in enumerate(modelled) if any(o is g for g in group)]
        if not idx:
            continue
        n = len(idx)
        measured = sum(1 for i in idx if modelled[i]["found"] is None) / n
        measured_low = sum(1 for i in idx if modelled[i]["fit_score"] is None) / n
        rows.append([key, n, "%.3f" % measured, "%.3f" % (1 - np.mean(p_thr[idx])), "%.3f" % measured_low,
                     "%.3f" % (1 - np.mean(p_low[idx]))])
    print(table(rows, ["labels", "n", "missed at threshold", "model", "missed at min score", "model"]) + "\n")

    # ---- the parameters ----------------------------------------------------------------------------
    confusion_fit = {}
    for truth, alternatives in (("Car", ("van", "truck")), ("Van", ("car", "truck")), ("Truck", ("car", "van")),
                                ("Pedestrian", ("cyclist",)), ("Cyclist", ("pedestrian",))):
        row = confusion[truth]
        total = sum(row.values())
        for alt in alternatives:
            confusion_fit["%s_to_%s" % (EXPECTED[truth], alt)] = row[alt] / total if total else 0.0
    params = {"min_score": args.min_score, "score_max": args.score_max, "detection": fitted, "box": edge_fit,
              "partial": partial_fit, "confusion": confusion_fit,
              "extra_rate": extra_rate, "false_positives": fp_fit}
    out["parameters"] = params
    print("## The replay noise parameters (config/yolo_detector.yaml, replay: noise:)\n")
    print("```yaml\n" + yaml_block(params) + "```")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0


def yaml_block(p):
    lines = ["noise:", "  min_score: %.2f" % p["min_score"], "  score_max: %.3f" % p["score_max"]]
    for part in ("presence", "score"):
        lines += ["  %s:" % part] + ["    %s: %.3f" % kv for kv in p["detection"][part].items()]
    lines += ["  box:"]
    for edge, fit in p["box"].items():
        if edge == "person_scale":
            lines += ["    person_scale: %.3f" % fit]
            continue
        lines += ["    %s:" % edge] + ["      %s: %.3f" % (k, v) for k, v in fit.items() if k != "n"]
    lines += ["  partial:"] + ["    %s: %.3f" % kv for kv in p["partial"].items()]
    lines += ["  confusion:"] + ["    %s: %.3f" % kv for kv in p["confusion"].items()]
    lines += ["  extra_rate: %.3f" % p["extra_rate"]]
    fp = p["false_positives"]
    if fp:
        lines += ["  false_positives:"] + ["    %s: %.3f" % (k, v) for k, v in fp.items() if k != "classes"]
        lines += ["    %s: %.3f" % (l, v) for l, v in fp["classes"].items()]
    return "\n".join(lines) + "\n"


def check_cpp(path, written):
    """Compares the Python detections with the C++ ones (same frames, same format)."""
    def parse(lines):
        by_frame = {}
        for line in lines:
            f = line.split()
            if len(f) == 7:
                by_frame.setdefault(f[0], []).append((f[1], float(f[2]), tuple(float(v) for v in f[3:7])))
        return by_frame
    with open(path) as f:
        cpp = parse(f.read().splitlines())
    py = parse(written)
    worst_box, worst_score, unmatched, compared = 0.0, 0.0, 0, 0
    for frame, dets in cpp.items():
        for label, score, box in dets:
            candidates = [d for d in py.get(frame, []) if d[0] == label]
            best = max(candidates, key=lambda d: iou(d[2], box)) if candidates else None
            if best is None or iou(best[2], box) < 0.99:
                unmatched += 1
                continue
            compared += 1
            worst_box = max(worst_box, max(abs(a - b) for a, b in zip(best[2], box)))
            worst_score = max(worst_score, abs(best[1] - score))
    extra = sum(len(v) for k, v in py.items() if k in cpp) - compared
    print("C++ check: %d detections of %d frames compared with the Python ones: largest box difference %.3f px, "
          "largest score difference %.4f; %d C++ detections without a Python one, %d Python ones without a C++ one\n"
          % (compared, len(cpp), worst_box, worst_score, unmatched, extra))


if __name__ == "__main__":
    sys.exit(main())
