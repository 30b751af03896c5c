#!/usr/bin/env bash
# The demo: on a fresh Debian 12 machine, installs what is missing, builds, generates the
# default synthetic drive (with ground truth), converts it to a bag, runs the real nodelet chain
# on it through kitti_replay.launch (rosbag play on simulated time), records the objects, and
# leaves in demo_output/: the recorded bag, the annotated frames and a video of objects/image,
# the evaluation against the ground truth, and a summary on the terminal.
#
# Usage: scripts/demo.sh [--rviz]        (output in demo_output/, or $GVF_DEMO_OUTPUT)
set -eo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
workspace=${GVF_WORKSPACE:-${XDG_CACHE_HOME:-$HOME/.cache}/grid_vision_fusion/workspace}
out=${GVF_DEMO_OUTPUT:-$root/demo_output}
rviz=false
for arg in "$@"; do
  case "$arg" in
    --rviz) rviz=true ;;
    -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
    *) echo "demo: unknown argument $arg (see --help)" >&2; exit 2 ;;
  esac
done
export PATH=/usr/bin:/bin:$PATH

step() { echo; echo "=== demo: $*"; }

step "1/6 dependencies and build"
if [[ "$rviz" == true ]]; then "$root/scripts/install_deps.sh" --with-rviz; fi
GVF_WORKSPACE=$workspace GVF_BUILD_TESTS=0 "$root/scripts/build.sh"
# shellcheck disable=SC1091
source "$workspace/devel/setup.bash"

rm -rf "$out"
mkdir -p "$out"
# rosbag record stops (and the chain's objects are lost) when less than 1 GiB is free; the drive,
# its bag and the recording take about 0.5 GiB more.
free_mib=$(df --output=avail -BM "$out" | tail -1 | tr -dc '0-9')
if (( free_mib < 1536 )); then
  echo "demo: only $free_mib MiB free under $out; the demo needs 1536 MiB (rosbag record stops" \
    "below 1 GiB). Free some space or set GVF_DEMO_OUTPUT to a folder on another disk." >&2
  exit 1
fi
drive=$out/kitti/2011_09_26/2011_09_26_drive_9001_sync

step "2/6 synthetic drive (config/synthetic_drive.yaml) in the KITTI raw layout"
rosrun grid_vision_fusion make_synthetic_drive --output "$out/kitti"

step "3/6 conversion to a bag (kitti2bag topics and frames)"
rosrun grid_vision_fusion kitti_to_bag --compression lz4 "$drive" "$out/synthetic_drive.bag"

step "4/6 the nodelet chain on the bag: kitti_replay.launch (detector: replay of the drive's labels)"
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')
echo "roslaunch on port $port, log in $out/replay.log"
roslaunch -p "$port" grid_vision_fusion kitti_replay.launch bag:="$out/synthetic_drive.bag" \
  replay_directory:="$drive/label_2" rviz:="$rviz" record:="$out/objects.bag" \
  record_topics:="/objects /objects/markers /objects/image /detections /grid/occupancy /tf /tf_static" \
  > "$out/replay.log" 2>&1
[[ -f "$out/objects.bag" ]] || { echo "demo: no recording: see $out/replay.log" >&2; exit 1; }

step "5/6 what the chain found: objects per frame, motion counts, overlay frames and video"
rosrun grid_vision_fusion bag_summary --bag "$out/objects.bag" --frames-dir "$out/frames" \
  --video "$out/objects.avi" | tee "$out/summary.txt"

step "6/6 against the ground truth of the drive (like the paper: P/R/F1, mAP within 30 m; and beyond)"
rosrun grid_vision_fusion evaluate --drive "$drive" --detections "$out/objects.bag" \
  --output "$out/evaluation" > "$out/evaluate.log" 2>&1 || { cat "$out/evaluate.log" >&2; exit 1; }
sed -n '/## Motion classification/,$p' "$out/evaluation/report.md" | tee -a "$out/summary.txt"

echo
echo "=== demo: done. In $out:"
echo "  objects.bag            the recorded run (objects, markers, overlay images, detections, grid)"
echo "  frames/, objects.avi   the objects/image overlay: boxes static blue / dynamic green"
echo "  evaluation/            metrics.json, report.md, PR curves, error histograms, Cartucho folders"
echo "  summary.txt            this summary"
