#!/usr/bin/env python3
"""Summarises the evaluations of a scenario suite run (scripts/evaluate_suite.sh) into
suite_report.md and suite_report.json, and checks them against thresholds.

Input per scenario: the evaluation folder that `evaluate` wrote (its matches.csv: one line per
ground-truth object matched by class and IoU within the range, with the truth motion, the truth
speed band, the predicted motion and the state errors; its metrics.json for the tracking
figures, when it has them). Output, per scenario and over all of them, per class: the motion
confusion with the moving objects split by truth speed band (0.5-1, 1-3, > 3 m/s), the position,
speed and heading errors (median, 90th percentile), the headline figures of issue 11 (moving
objects >= 1 m/s found dynamic, overall and per class; static objects found static) and of
issue 12 (errors over all classes, motion right, id switches per 100 matched object-frames,
MOTA, IDF1, motion flickers), and how well the published P(dynamic) is calibrated (when
matches.csv carries it: a reliability table, the Brier score, the expected calibration error).

usage: suite_report.py --output DIR --scenario NAME EVAL_DIR SECONDS [--scenario ...]
                       [--wall-time S] [--cpu TEXT] [--thresholds FILE] [--junit FILE]

Exit status: 0, 1 on bad input, 3 when a threshold is not met (the reports are written anyway).
Python 3 standard library only.
"""
import argparse
import csv
import json
import math
import os
import sys
import tempfile

MOTIONS = ("unknown", "static", "dynamic")
BANDS = ("static", "0.5-1", "1-3", ">3", "unknown")
BAND_TITLES = {"static": "static", "0.5-1": "moving 0.5-1 m/s", "1-3": "moving 1-3 m/s",
               ">3": "moving > 3 m/s", "unknown": "truth unknown"}
MOVING_TARGET_BANDS = ("1-3", ">3")  # truth speed >= 1 m/s
HEADLINE_CLASSES = ("car", "van", "truck", "pedestrian", "cyclist")
CSV_COLUMNS = ("frame", "label", "truth_motion", "predicted_motion", "truth_band", "truth_speed_mps",
               "longitudinal_m", "position_error_m", "speed_error_mps", "heading_error_rad", "truth_id",
               "track_id")
OPTIONAL_CSV_COLUMNS = ("p_dynamic",)  # evaluate writes it; an output of an older evaluate lacks it
CALIBRATION_BINS = 10
THRESHOLD_KEYS = {"min_moving_dynamic", "min_moving_dynamic_per_class", "min_static_static",
                  "min_class_matches", "max_dynamic_latency_p90_s"}


class InputError(Exception):
    pass


def quantile(sorted_values, q):
    """Linear interpolation between closest ranks, as errorStats() of the evaluation."""
    rank = q * (len(sorted_values) - 1)
    lower = int(math.floor(rank))
    upper = min(lower + 1, len(sorted_values) - 1)
    return sorted_values[lower] + (rank - lower) * (sorted_values[upper] - sorted_values[lower])


def error_stats(values):
    values = sorted(values)
    if not values:
        return {"count": 0, "median": None, "p90": None}
    return {"count": len(values), "median": quantile(values, 0.5), "p90": quantile(values, 0.9)}


def read_matches(path):
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            if tuple(reader.fieldnames or ()) not in (CSV_COLUMNS, CSV_COLUMNS + OPTIONAL_CSV_COLUMNS):
                raise InputError("%s: unexpected columns %s (expected %s[,%s])" % (
                    path, reader.fieldnames, ",".join(CSV_COLUMNS), ",".join(OPTIONAL_CSV_COLUMNS)))
            rows = []
            for line, row in enumerate(reader, start=2):
                if row["truth_motion"] not in MOTIONS or row["predicted_motion"] not in MOTIONS \
                        or row["truth_band"] not in BANDS:
                    raise InputError("%s:%d: unknown motion or band" % (path, line))
                rows.append(row)
            return rows
    except OSError as error:
        raise InputError("cannot read %s: %s" % (path, error))


def number(text):
    return float(text) if text != "" else None


class Tally:
    """Predicted-motion counts per truth band and the errors of a set of matches."""

    def __init__(self):
        self.counts = {band: {m: 0 for m in MOTIONS} for band in BANDS}
        self.position, self.speed, self.heading = [], [], []

    def add(self, row):
        self.counts[row["truth_band"]][row["predicted_motion"]] += 1
        for values, key, scale in ((self.position, "position_error_m", 1.0),
                                   (self.speed, "speed_error_mps", 1.0),
                                   (self.heading, "heading_error_rad", 180.0 / math.pi)):
            value = number(row[key])
            if value is not None:
                values.append(value * scale)

    def total(self, bands=BANDS):
        return sum(sum(self.counts[b].values()) for b in bands)

    def right(self, bands):
        """Matches of `bands` whose predicted motion is the truth's (static for static)."""
        return sum(self.counts[b]["static" if b == "static" else "dynamic"] for b in bands)

    def to_json(self):
        return {"by_truth_band": {b: dict(self.counts[b]) for b in BANDS if sum(self.counts[b].values())},
                "matches": self.total(),
                "position_error_m": error_stats(self.position),
                "speed_error_mps": error_stats(self.speed),
                "heading_error_deg": error_stats(self.heading)}


TRACKING_COUNTS = ("ground_truth", "matches", "false_positives", "misses", "id_switches", "fragmentations",
                   "truth_tracks", "mostly_tracked", "mostly_lost", "idtp", "idfp", "idfn", "motion_changes",
                   "motion_flickers", "flickering_tracks")


def read_tracking(folder):
    """The "tracking" object of the folder's metrics.json, or None (no file, or no tracking figures)."""
    path = os.path.join(folder, "metrics.json")
    if not os.path.exists(path):
        return None
    try:
        with open(path) as f:
            metrics = json.load(f)
    except (OSError, ValueError) as error:
        raise InputError("cannot read %s: %s" % (path, error))
    tracking = metrics.get("tracking") if isinstance(metrics, dict) else None
    if tracking is None:
        return None
    if not isinstance(tracking, dict) or any(not isinstance(tracking.get(k), int) for k in TRACKING_COUNTS):
        raise InputError("%s: \"tracking\" lacks one of the counts %s" % (path, ", ".join(TRACKING_COUNTS)))
    out = {k: tracking[k] for k in TRACKING_COUNTS}
    latencies = tracking.get("dynamic_latency_tracks", [])
    if not isinstance(latencies, list) or any(
            not isinstance(l, dict) or not isinstance(l.get("label"), str) or
            not (l.get("latency_s") is None or isinstance(l.get("latency_s"), (int, float))) for l in latencies):
        raise InputError("%s: \"dynamic_latency_tracks\" is not a list of {label, latency_s}" % path)
    out["latency"] = [(l["label"], l["latency_s"]) for l in latencies]
    return out


def latency_stats(latencies, label=None):
    """Count, median, 90th percentile (nearest rank) and worst of the times to the first dynamic
    verdict of `latencies` [(label, seconds or None)] of `label` (None: all), and how many were never
    reported dynamic (None, counted as infinite)."""
    values = sorted(float("inf") if s is None else s for l, s in latencies if label is None or l == label)
    if not values:
        return {"count": 0, "median_s": None, "p90_s": None, "worst_s": None, "never": 0}

    def rank(q):
        value = values[min(len(values) - 1, int(math.ceil(q * len(values))) - 1)]
        return None if math.isinf(value) else value
    return {"count": len(values), "median_s": rank(0.5), "p90_s": rank(0.9),
            "worst_s": None if math.isinf(values[-1]) else values[-1],
            "never": sum(1 for v in values if math.isinf(v))}


def latency_table(latencies):
    def s(value):
        return "never" if value is None else "%.1f" % value
    lines = ["| class | moving objects | median [s] | 90th percentile [s] | worst [s] | never dynamic |",
             "|---|---|---|---|---|---|"]
    for label in [None] + sorted({l for l, _ in latencies}):
        st = latency_stats(latencies, label)
        lines.append("| %s | %d | %s | %s | %s | %d |" % (label or "all", st["count"], s(st["median_s"]),
                                                          s(st["p90_s"]), s(st["worst_s"]), st["never"]))
    return lines


def tracking_summary(parts):
    """Summed counts of several evaluations' tracking figures with MOTA, IDF1 and the rates."""
    parts = [p for p in parts if p is not None]
    if not parts:
        return None
    t = {k: sum(p[k] for p in parts) for k in TRACKING_COUNTS}
    t["latency"] = [l for p in parts for l in p.get("latency", [])]
    t["dynamic_latency"] = {label or "all": latency_stats(t["latency"], label)
                            for label in [None] + sorted({l for l, _ in t["latency"]})}
    t["mota"] = (1.0 - (t["misses"] + t["false_positives"] + t["id_switches"]) / t["ground_truth"]
                 if t["ground_truth"] else None)
    t["idf1"] = (2.0 * t["idtp"] / (2 * t["idtp"] + t["idfp"] + t["idfn"]) if t["idtp"] else 0.0)
    t["id_switches_per_100"] = 100.0 * t["id_switches"] / t["matches"] if t["matches"] else None
    return t


def calibration(rows):
    """Reliability of the published P(dynamic) over the matches with a static or dynamic truth and a
    P(dynamic): per bin of width 1 / CALIBRATION_BINS the matches, the truly moving ones and the mean
    P(dynamic); the Brier score and the expected calibration error (as evaluate's report)."""
    bins = [{"low": b / CALIBRATION_BINS, "high": (b + 1) / CALIBRATION_BINS, "count": 0, "dynamic": 0, "p_sum": 0.0}
            for b in range(CALIBRATION_BINS)]
    squared, total = 0.0, 0
    for row in rows:
        p = number(row.get("p_dynamic") or "")
        if row["truth_motion"] not in ("static", "dynamic") or p is None or not 0.0 <= p <= 1.0:
            continue
        truth = 1.0 if row["truth_motion"] == "dynamic" else 0.0
        b = bins[min(int(p * CALIBRATION_BINS), CALIBRATION_BINS - 1)]
        b["count"] += 1
        b["dynamic"] += int(truth)
        b["p_sum"] += p
        squared += (p - truth) ** 2
        total += 1
    for b in bins:
        b["mean_p"] = b.pop("p_sum") / b["count"] if b["count"] else None
    if not total:
        return {"matches": 0, "brier": None, "expected_calibration_error": None, "bins": bins}
    ece = sum(b["count"] / total * abs(b["mean_p"] - b["dynamic"] / b["count"]) for b in bins if b["count"])
    return {"matches": total, "brier": squared / total, "expected_calibration_error": ece, "bins": bins}


def calibration_table(c):
    lines = ["Matches with a static or dynamic truth, by the published P(dynamic): a calibrated probability has "
             "as many truly moving objects in a bin as its mean P(dynamic) says. Brier score %.4f, expected "
             "calibration error %.4f, %d matches." % (c["brier"], c["expected_calibration_error"], c["matches"]), "",
             "| P(dynamic) | matches | mean P(dynamic) | truly moving [%] |", "|---|---|---|---|"]
    for b in c["bins"]:
        lines.append("| %.1f-%.1f | %d | %s | %s |" % (
            b["low"], b["high"], b["count"], "%.3f" % b["mean_p"] if b["count"] else "-",
            "%.1f" % (100.0 * b["dynamic"] / b["count"]) if b["count"] else "-"))
    return lines


def motion_right(tallies):
    """Matches whose truth is static or dynamic (any speed band) and whose predicted motion is it."""
    bands = ("static", "0.5-1", "1-3", ">3")
    return fraction(sum(t.right(bands) for t in tallies.values()), sum(t.total(bands) for t in tallies.values()))


def tracking_table(named):
    lines = ["| run | matched | motion right [%] | ID switches | per 100 matched | fragmentations | MOTA [%] | "
             "IDF1 [%] | motion changes | flickers | flickering tracks |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, t, right in named:
        if t is None:
            continue
        lines.append("| %s | %d | %s | %d | %.2f | %d | %.1f | %.1f | %d | %d | %d |" % (
            name, t["matches"], percent(right), t["id_switches"], t["id_switches_per_100"] or 0.0,
            t["fragmentations"], 100.0 * (t["mota"] or 0.0), 100.0 * t["idf1"], t["motion_changes"],
            t["motion_flickers"], t["flickering_tracks"]))
    return lines


def fraction(found, total):
    return {"found": found, "total": total, "fraction": (found / total) if total else None}


def headline(tallies):
    """Issue 11's figures from per-class tallies."""
    all_classes = Tally()
    for tally in tallies.values():
        for band in BANDS:
            for m in MOTIONS:
                all_classes.counts[band][m] += tally.counts[band][m]
    out = {"moving_ge1_dynamic": fraction(all_classes.right(MOVING_TARGET_BANDS),
                                          all_classes.total(MOVING_TARGET_BANDS)),
           "moving_ge1_dynamic_by_class": {},
           "moving_0.5-1_dynamic": fraction(all_classes.right(("0.5-1",)), all_classes.total(("0.5-1",))),
           "static_static": fraction(all_classes.right(("static",)), all_classes.total(("static",)))}
    for label in sorted(set(HEADLINE_CLASSES) | set(tallies)):
        tally = tallies.get(label, Tally())
        out["moving_ge1_dynamic_by_class"][label] = fraction(tally.right(MOVING_TARGET_BANDS),
                                                             tally.total(MOVING_TARGET_BANDS))
    return out


def summarise(rows):
    tallies = {}
    for row in rows:
        tallies.setdefault(row["label"], Tally()).add(row)
    return tallies


def percent(f):
    return "-" if f["fraction"] is None else "%.1f" % (100.0 * f["fraction"])


def stat(s, decimals):
    if not s["count"]:
        return "-"
    return "%.*f / %.*f" % (decimals, s["median"], decimals, s["p90"])


def motion_table(tallies):
    lines = ["| class | truth | matches | -> unknown | -> static | -> dynamic | right [%] |",
             "|---|---|---|---|---|---|---|"]
    for label in sorted(tallies):
        tally = tallies[label]
        for band in BANDS:
            c = tally.counts[band]
            n = sum(c.values())
            if not n:
                continue
            right = "-" if band == "unknown" else percent(fraction(tally.right((band,)), n))
            lines.append("| %s | %s | %d | %d | %d | %d | %s |" % (label, BAND_TITLES[band], n, c["unknown"],
                                                                  c["static"], c["dynamic"], right))
    return lines


def all_classes(tallies):
    """One tally of every class's matches."""
    total = Tally()
    for t in tallies.values():
        for band in BANDS:
            for m in MOTIONS:
                total.counts[band][m] += t.counts[band][m]
        total.position += t.position
        total.speed += t.speed
        total.heading += t.heading
    return total


def error_table(tallies):
    lines = ["| class | matches | position [m] median / p90 | speed [m/s] median / p90 | "
             "heading [deg] median / p90 (both dynamic) |", "|---|---|---|---|---|"]
    rows = [(label, tallies[label]) for label in sorted(tallies)]
    if len(rows) > 1:
        rows.append(("all classes", all_classes(tallies)))
    for label, t in rows:
        lines.append("| %s | %d | %s | %s | %s |" % (label, t.total(), stat(error_stats(t.position), 2),
                                                      stat(error_stats(t.speed), 2),
                                                      stat(error_stats(t.heading), 1)))
    return lines


def headline_table(h, thresholds):
    def target(key, label=None):
        value = thresholds.get(key)
        if isinstance(value, dict):
            value = value.get(label)
        elif label is not None and label not in HEADLINE_CLASSES:
            value = None
        return "" if value is None else "%.1f" % (100.0 * value)

    lines = ["| figure | found | of | % | threshold [%] |", "|---|---|---|---|---|"]
    f = h["moving_ge1_dynamic"]
    lines.append("| moving >= 1 m/s found dynamic, all classes | %d | %d | %s | %s |"
                 % (f["found"], f["total"], percent(f), target("min_moving_dynamic")))
    for label, f in h["moving_ge1_dynamic_by_class"].items():
        lines.append("| moving >= 1 m/s found dynamic, %s | %d | %d | %s | %s |"
                     % (label, f["found"], f["total"], percent(f), target("min_moving_dynamic_per_class", label)))
    f = h["static_static"]
    lines.append("| static found static | %d | %d | %s | %s |" % (f["found"], f["total"], percent(f),
                                                                 target("min_static_static")))
    f = h["moving_0.5-1_dynamic"]
    lines.append("| moving 0.5-1 m/s found dynamic (reported, not targeted) | %d | %d | %s | |"
                 % (f["found"], f["total"], percent(f)))
    return lines


def check(h, thresholds, tracking=None):
    """The threshold checks: list of (name, passed, message)."""
    checks = []
    limit = thresholds.get("max_dynamic_latency_p90_s")
    if limit is not None:
        st = latency_stats(tracking["latency"] if tracking else [])
        ok = st["count"] > 0 and st["p90_s"] is not None and st["p90_s"] <= limit + 1e-9
        checks.append(("dynamic_latency_p90", ok, "dynamic_latency_p90: %s s over %d moving objects %s %.2f s" % (
            "never" if st["p90_s"] is None else "%.2f" % st["p90_s"], st["count"], "<=" if ok else ">", limit)))

    def add(name, f, minimum):
        if f["total"] == 0:
            checks.append((name, False, "%s: no match to measure (threshold %.3f)" % (name, minimum)))
            return
        ok = f["fraction"] >= minimum
        checks.append((name, ok, "%s: %d of %d = %.3f %s %.3f" % (name, f["found"], f["total"], f["fraction"],
                                                                   ">=" if ok else "<", minimum)))

    if thresholds.get("min_moving_dynamic") is not None:
        add("moving_ge1_dynamic", h["moving_ge1_dynamic"], thresholds["min_moving_dynamic"])
    per_class = thresholds.get("min_moving_dynamic_per_class")
    if per_class is not None:
        least = thresholds.get("min_class_matches", 1)
        if not isinstance(per_class, dict):
            per_class = {label: per_class for label in HEADLINE_CLASSES}
        for label, minimum in sorted(per_class.items()):
            f = h["moving_ge1_dynamic_by_class"].get(label, fraction(0, 0))
            if f["total"] >= max(least, 1):
                add("moving_ge1_dynamic_" + label, f, minimum)
    if thresholds.get("min_static_static") is not None:
        add("static_static", h["static_static"], thresholds["min_static_static"])
    return checks


def read_thresholds(path):
    if not path:
        return {}
    try:
        with open(path) as f:
            values = json.load(f)
    except (OSError, ValueError) as error:
        raise InputError("cannot read the thresholds %s: %s" % (path, error))
    if not isinstance(values, dict):
        raise InputError("%s: expected a JSON object" % path)
    values = {k: v for k, v in values.items() if not k.startswith("_")}  # "_comment" keys
    unknown = set(values) - THRESHOLD_KEYS
    if unknown:
        raise InputError("%s: unknown keys %s (known: %s)" % (path, sorted(unknown), sorted(THRESHOLD_KEYS)))
    def fraction_ok(value):
        return isinstance(value, (int, float)) and not isinstance(value, bool) and 0 <= value <= 1

    for key, value in values.items():
        if key == "min_class_matches":
            ok = isinstance(value, int) and not isinstance(value, bool) and value >= 0
        elif key == "min_moving_dynamic_per_class" and isinstance(value, dict):
            ok = bool(value) and all(fraction_ok(v) for v in value.values())
        else:
            ok = fraction_ok(value)
        if not ok:
            raise InputError("%s: %s must be a fraction in [0, 1] (min_moving_dynamic_per_class: or an object "
                             "class -> fraction; min_class_matches: an integer >= 0)" % (path, key))
    return values


def junit(checks, scenarios):
    from xml.sax.saxutils import escape, quoteattr
    failures = sum(1 for _, ok, _ in checks if not ok)
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             '<testsuite name="scenario_suite" tests="%d" failures="%d" errors="0">' % (len(checks), failures)]
    for name, ok, message in checks:
        lines.append('  <testcase classname="scenario_suite" name=%s time="0">' % quoteattr(name))
        if not ok:
            lines.append('    <failure message=%s>%s</failure>' % (quoteattr(message), escape(message)))
        lines.append("  </testcase>")
    lines.append("  <system-out>%s</system-out>" % escape("scenarios: " + ", ".join(scenarios)))
    lines.append("</testsuite>")
    return "\n".join(lines) + "\n"


def write_atomically(path, text):
    directory = os.path.dirname(os.path.abspath(path))
    os.makedirs(directory, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".tmp_" + os.path.basename(path))
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", required=True, help="folder for suite_report.md and suite_report.json")
    parser.add_argument("--scenario", nargs=3, action="append", metavar=("NAME", "EVAL_DIR", "SECONDS"),
                        required=True, help="a scenario, the evaluate output folder, its wall time")
    parser.add_argument("--wall-time", type=float, help="wall time of the whole run [s]")
    parser.add_argument("--jobs", type=int, help="scenarios run in parallel")
    parser.add_argument("--cpu", default="", help="CPU model, for the report")
    parser.add_argument("--thresholds", help="JSON object with any of " + ", ".join(sorted(THRESHOLD_KEYS)) +
                        " (keys starting with _ are comments)")
    parser.add_argument("--junit", help="also write the threshold checks as a JUnit XML file")
    args = parser.parse_args(argv)
    try:
        thresholds = read_thresholds(args.thresholds)
        scenarios = []
        for name, folder, seconds in args.scenario:
            try:
                seconds = float(seconds)
            except ValueError:
                raise InputError("scenario %s: SECONDS must be a number, got %r" % (name, seconds))
            rows = read_matches(os.path.join(folder, "matches.csv"))
            scenarios.append((name, seconds, rows, read_tracking(folder)))
    except InputError as error:
        print("suite_report: %s" % error, file=sys.stderr)
        return 1

    overall_rows = [row for _, _, rows, _ in scenarios for row in rows]
    overall = summarise(overall_rows)
    overall_headline = headline(overall)
    overall_tracking = tracking_summary([t for _, _, _, t in scenarios])
    overall_all = all_classes(overall)
    checks = check(overall_headline, thresholds, overall_tracking)

    report = {"matching": "ground truth matched by class and IoU >= 0.5, objects up to 30 m ahead "
                          "(evaluate's defaults); truth dynamic above 0.5 m/s",
              "cpu": args.cpu, "wall_time_s": args.wall_time, "jobs": args.jobs,
              "headline": overall_headline,
              "overall": {label: t.to_json() for label, t in sorted(overall.items())},
              "all_classes": overall_all.to_json(), "motion_right": motion_right(overall),
              "tracking": overall_tracking, "p_dynamic_calibration": calibration(overall_rows),
              "scenarios": [], "thresholds": thresholds,
              "checks": [{"name": n, "passed": ok, "message": m} for n, ok, m in checks]}
    md = ["# Scenario suite report", "",
          "%d scenarios; objects matched to the ground truth by class and IoU >= 0.5, up to 30 m ahead; "
          "truth dynamic above 0.5 m/s; detector: replay of the drives' labels (oracle boxes)." % len(scenarios)]
    if args.wall_time is not None:
        md.append("Wall time %.0f s%s%s." % (args.wall_time, " with %d jobs" % args.jobs if args.jobs else "",
                                             " on " + args.cpu if args.cpu else ""))
    md += ["", "## Headline (issue 11's figures)", ""] + headline_table(overall_headline, thresholds)
    if checks:
        md += ["", "Thresholds: " + ("all met" if all(ok for _, ok, _ in checks) else "NOT MET: " + "; ".join(
            m for _, ok, m in checks if not ok)) + "."]
    md += ["", "## All scenarios: motion per class and truth speed band", ""] + motion_table(overall)
    md += ["", "## All scenarios: state errors per class", ""] + error_table(overall)
    if overall_tracking is not None:
        md += ["", "## Tracking (issue 12)", "",
               "Motion right: matches with a static or dynamic truth whose reported motion is the truth's. "
               "ID switches, fragmentations, MOTA, IDF1: CLEAR MOT and identity measures against the tracklets "
               "(evaluate's metrics.json). Flickers: a reported motion change less than 2 s after the previous "
               "one of the same object while its truth motion is constant.", ""]
        md += tracking_table([("all scenarios", overall_tracking, motion_right(overall))] +
                             [(name, tracking_summary([t]), motion_right(summarise(rows)))
                              for name, _, rows, t in scenarios])
        md += ["", "## Time to the first dynamic verdict", "",
               "Per moving object (truth at 1 m/s or more in a matched frame): the time from that first "
               "match to its first match reported dynamic; never dynamic counts as infinite.", ""]
        md += latency_table(overall_tracking["latency"])
    if report["p_dynamic_calibration"]["matches"]:
        md += ["", "## P(dynamic) calibration", ""] + calibration_table(report["p_dynamic_calibration"])
    md += ["", "## Per scenario", "",
           "| scenario | matches | moving >= 1 m/s found dynamic [%] | static found static [%] | "
           "moving 0.5-1 m/s found dynamic [%] | wall time [s] |", "|---|---|---|---|---|---|"]
    details = []
    for name, seconds, rows, tracking in scenarios:
        tallies = summarise(rows)
        h = headline(tallies)
        report["scenarios"].append({"name": name, "wall_time_s": seconds, "matches": len(rows), "headline": h,
                                    "classes": {label: t.to_json() for label, t in sorted(tallies.items())},
                                    "motion_right": motion_right(tallies),
                                    "tracking": tracking_summary([tracking])})
        md.append("| %s | %d | %s (%d/%d) | %s (%d/%d) | %s (%d/%d) | %.0f |" % (
            name, len(rows), percent(h["moving_ge1_dynamic"]), h["moving_ge1_dynamic"]["found"],
            h["moving_ge1_dynamic"]["total"], percent(h["static_static"]), h["static_static"]["found"],
            h["static_static"]["total"], percent(h["moving_0.5-1_dynamic"]), h["moving_0.5-1_dynamic"]["found"],
            h["moving_0.5-1_dynamic"]["total"], seconds))
        details += ["", "### %s" % name, ""] + motion_table(tallies) + [""] + error_table(tallies)
    md += details

    try:
        os.makedirs(args.output, exist_ok=True)
        write_atomically(os.path.join(args.output, "suite_report.json"), json.dumps(report, indent=2) + "\n")
        write_atomically(os.path.join(args.output, "suite_report.md"), "\n".join(md) + "\n")
        if args.junit:
            write_atomically(args.junit, junit(checks, [s[0] for s in scenarios]))
    except OSError as error:
        print("suite_report: cannot write the report: %s" % error, file=sys.stderr)
        return 1
    for _, ok, message in checks:
        print("suite_report: %s %s" % ("ok    " if ok else "FAILED", message))
    return 0 if all(ok for _, ok, _ in checks) else 3


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
