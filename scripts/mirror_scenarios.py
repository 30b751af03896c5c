#!/usr/bin/env python3
"""Writes the mirror images of scenario files (the YAML format of make_synthetic_drive): every
position's y and every heading and turn rate negated, the road's centre line too, the ground's
left and right verges swapped, the INS's heading drift negated, and the seed moved by
--seed-offset. A drive the filter was not tuned on, with the same traffic: the bends
turn the other way, the parked rows and the pedestrians change sides, the lidar and the camera
see every object from the other side and the lidar's noise differs. Scenarios that take the
ego's motion from a recorded drive (a "# suite-from-drive:" line) are skipped: a recorded drive
cannot be mirrored.

usage: mirror_scenarios.py [--seed-offset N] [--prefix TEXT] IN_DIR OUT_DIR

Score the result with scripts/evaluate_suite.sh --scenario-dir OUT_DIR.
Exit status: 0, 1 on bad input (a file that is not a scenario, an unknown motion key).
"""
import argparse
import glob
import os
import sys

import yaml

MOTION_KEYS = ("parked", "waypoints", "constant_turn")
ENTRY_KEYS = ("type", "size", "color", "yaw", "shape") + MOTION_KEYS


class ScenarioError(Exception):
    pass


def mirror_pose(pose, where):
    if not isinstance(pose, dict) or "y" not in pose:
        raise ScenarioError("%s: expected a mapping with y" % where)
    pose["y"] = -pose["y"]
    for key in ("yaw", "yaw_rate"):
        if key in pose:
            pose[key] = -pose[key]


def mirror_motion(entry, where):
    """Mirrors the motion of an ego or actor entry in place."""
    unknown = sorted(set(entry) - set(ENTRY_KEYS))
    if unknown:
        raise ScenarioError("%s: unknown keys %s" % (where, unknown))
    if "yaw" in entry:
        entry["yaw"] = -entry["yaw"]
    for key in ("parked", "constant_turn"):
        if key in entry:
            mirror_pose(entry[key], "%s.%s" % (where, key))
    for i, point in enumerate(entry.get("waypoints", [])):
        if not isinstance(point, list) or len(point) not in (3, 4):
            raise ScenarioError("%s.waypoints[%d]: expected [t, x, y] or [t, x, y, yaw]" % (where, i))
        point[2] = -point[2]
        if len(point) == 4:
            point[3] = -point[3]


def mirror(scenario, seed_offset, source):
    """Returns the mirror image of the scenario mapping `scenario` (modified in place)."""
    if not isinstance(scenario, dict) or "ego" not in scenario:
        raise ScenarioError("%s: not a scenario (no ego)" % source)
    scenario["seed"] = int(scenario.get("seed", 42)) + seed_offset
    road = scenario.get("road")
    if isinstance(road, dict) and "center_y" in road:
        road["center_y"] = -road["center_y"]
    ground = scenario.get("ground")
    if isinstance(ground, dict):
        left, right = ground.pop("verge_rise_left", None), ground.pop("verge_rise_right", None)
        if right is not None:
            ground["verge_rise_left"] = right
        if left is not None:
            ground["verge_rise_right"] = left
    ins = scenario.get("ins_error")
    if isinstance(ins, dict) and "yaw_drift_rate" in ins:
        ins["yaw_drift_rate"] = -ins["yaw_drift_rate"]
    mirror_motion(scenario["ego"], "%s: ego" % source)
    for i, actor in enumerate(scenario.get("actors") or []):
        mirror_motion(actor, "%s: actors[%d]" % (source, i))
    for i, box in enumerate(scenario.get("scenery") or []):
        mirror_pose(box, "%s: scenery[%d]" % (source, i))
    return scenario


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed-offset", type=int, default=7919, help="added to every seed (default 7919)")
    parser.add_argument("--prefix", default="mirrored_", help="prefix of the written file names")
    parser.add_argument("input", help="folder of scenario YAML files")
    parser.add_argument("output", help="folder to write the mirrored files to (created)")
    args = parser.parse_args(argv)
    files = sorted(glob.glob(os.path.join(args.input, "*.yaml")))
    if not files:
        print("mirror_scenarios: no *.yaml in %s" % args.input, file=sys.stderr)
        return 1
    os.makedirs(args.output, exist_ok=True)
    written = 0
    for path in files:
        with open(path) as f:
            text = f.read()
        if "# suite-from-drive:" in text:
            print("mirror_scenarios: skipping %s (its ego comes from a recorded drive)" % path)
            continue
        try:
            scenario = mirror(yaml.safe_load(text), args.seed_offset, path)
        except (ScenarioError, yaml.YAMLError, TypeError, ValueError) as e:
            print("mirror_scenarios: %s" % e, file=sys.stderr)
            return 1
        out = os.path.join(args.output, args.prefix + os.path.basename(path))
        with open(out, "w") as f:
            f.write("# The mirror image of %s (scripts/mirror_scenarios.py, seed offset %d).\n" %
                    (os.path.basename(path), args.seed_offset))
            yaml.safe_dump(scenario, f, default_flow_style=None, sort_keys=False, width=120)
        written += 1
    print("mirror_scenarios: %d scenarios written to %s" % (written, args.output))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
