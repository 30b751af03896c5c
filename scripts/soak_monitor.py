#!/usr/bin/env python3
"""Watches a running nodelet chain for scripts/soak.sh: counts the camera frames, detections and
objects messages (and the projected grids without cells: the grid too old for the image),
samples the nodelet manager's resident memory, and collects every ERROR or FATAL that reaches
/rosout and the stages' drops by reason from /diagnostics. Writes CSV samples and a JSON summary
when the bag has been played (the player's node leaves the graph) or on SIGINT. The latency is
measured by latency_probe (C++): this Python monitor, its threads taking turns on the interpreter
lock, noted arrivals late under overload.

A frame is its camera_info, which the bag plays with the scan and the image of the same stamp: the
monitor does not subscribe to the images themselves (1.4 MB each, deserialised in Python), which
would take CPU from the chain it measures, most of all under overload (--rate above capacity).
"""
import argparse
import json
import os
import signal
import struct
import time

import rosgraph
import rospy
from diagnostic_msgs.msg import DiagnosticArray
from rosgraph_msgs.msg import Log


def header_stamp(msg):
    """The header stamp of a serialized message that starts with a std_msgs/Header."""
    _seq, secs, nsecs = struct.unpack_from("<III", msg._buff, 0)
    return secs * 1000000000 + nsecs


def projected_cells(msg):
    """The number of cells of a serialized ProjectedGrid (the length of its u array)."""
    buff = msg._buff

    def skip_string(offset):
        (length,) = struct.unpack_from("<I", buff, offset)
        return offset + 4 + length

    offset = skip_string(12)  # header: seq, stamp, frame_id
    offset = skip_string(offset + 8)  # grid_stamp, grid_frame_id
    offset += 4 + 4 + 4 + 3 * 8 + 12 * 8 + 4  # image size, resolution, camera_position, grid_to_image, ground_z
    return struct.unpack_from("<I", buff, offset)[0]


def resident_mib(pid):
    with open("/proc/%d/status" % pid) as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--manager-pid", type=int, required=True)
    parser.add_argument("--camera-info", default="/kitti/camera_color_left/camera_info")
    parser.add_argument("--samples", required=True, help="CSV file of the memory samples")
    parser.add_argument("--summary", required=True, help="JSON summary file")
    parser.add_argument("--every", type=int, default=100, help="objects messages between samples")
    parser.add_argument("--player", default="/player", help="node that plays the bag")
    args = parser.parse_args(rospy.myargv()[1:])

    # "images": camera frames (camera_infos); a frame's objects need its detections and its projected grid.
    counts = {"images": 0, "detections": 0, "projected_grids": 0, "objects": 0}
    stamps = {name: set() for name in counts}
    errors = []
    samples = open(args.samples, "w")
    samples.write("objects_messages,wall_s,manager_rss_mib\n")
    start = time.time()

    without_cells = set()  # stamps of the projected grids without cells (the grid too old for the image)

    def counter(name):
        def callback(msg):
            counts[name] += 1
            stamps[name].add(header_stamp(msg))
            if name == "projected_grids" and projected_cells(msg) == 0:
                without_cells.add(header_stamp(msg))
            if name == "objects" and counts["objects"] % args.every == 0:
                samples.write("%d,%.1f,%.2f\n" % (counts["objects"], time.time() - start,
                                                  resident_mib(args.manager_pid)))
                samples.flush()
        return callback

    drops = {}  # diagnostic status name -> {reason: inputs dropped so far}, from the latest report
    outputs = {}  # diagnostic status name -> messages published so far

    def on_diagnostics(msg):
        for status in msg.status:
            values = {kv.key: kv.value for kv in status.values}
            if "outputs" in values:
                outputs[status.name] = int(values["outputs"])
            reasons = {key[len("dropped: "):]: int(value.split()[0])
                       for key, value in values.items() if key.startswith("dropped: ")}
            if reasons:
                drops[status.name] = reasons

    def on_log(msg):
        if msg.level >= Log.ERROR:
            errors.append("%s: %s" % (msg.name, msg.msg))

    rospy.init_node("soak_monitor", disable_signals=True)
    rospy.Subscriber("/detections", rospy.AnyMsg, counter("detections"), queue_size=None)
    rospy.Subscriber("/projected_grid", rospy.AnyMsg, counter("projected_grids"), queue_size=None)
    rospy.Subscriber("/objects", rospy.AnyMsg, counter("objects"), queue_size=None)
    rospy.Subscriber(args.camera_info, rospy.AnyMsg, counter("images"), queue_size=None)
    rospy.Subscriber("/rosout_agg", Log, on_log, queue_size=1000)
    rospy.Subscriber("/diagnostics", DiagnosticArray, on_diagnostics, queue_size=100)

    stop = {"now": False}
    signal.signal(signal.SIGINT, lambda *_: stop.update(now=True))
    signal.signal(signal.SIGTERM, lambda *_: stop.update(now=True))
    master = rosgraph.Master("/soak_monitor")
    seen_player = False
    while not stop["now"]:
        time.sleep(1.0)
        try:
            nodes = {n for group in master.getSystemState() for _, names in group for n in names}
            alive = args.player in nodes
        except Exception:  # the master went away: the launch has ended
            alive = False
        seen_player = seen_player or alive
        if seen_player and not alive:
            time.sleep(3.0)  # the last messages in flight
            break
    # Images before the chain's first output met a chain still starting (no grid yet).
    first = min(stamps["objects"]) if stamps["objects"] else None
    lost = sorted(t for t in stamps["images"] if first is not None and t > first and t not in stamps["objects"])
    summary = dict(counts, errors=errors, wall_s=time.time() - start,
                   images_before_first_output=sum(1 for t in stamps["images"] if first is None or t < first),
                   detections_with_projected_grid=len(stamps["detections"] & stamps["projected_grids"]),
                   projected_grids_without_cells=len(without_cells),
                   objects_without_cells=len(stamps["objects"] & without_cells),
                   frames_lost=len(lost), lost_stamps_ns=lost[:100], drops=drops,
                   outputs=outputs)
    with open(args.summary, "w") as out:
        json.dump(summary, out, indent=1)
    samples.close()
    # rospy's threads may block on a master that has gone: leave without waiting for them.
    os._exit(0)


if __name__ == "__main__":
    main()
