#!/usr/bin/env bash
# Soak test of the nodelet chain (doc/reliability.md): kitti_replay.launch at real-time rate with
# the replay detector over a long synthetic drive (config/synthetic_drive_long.yaml: 3000 frames),
# watched by scripts/soak_monitor.py (counts, memory, errors, drops) and latency_probe (the
# wall-clock latency from each frame's camera_info to its objects, in C++). Passes when no camera frame is lost between the bag and
# the objects, the nodelet manager's resident memory grows by less than 5 % between frame 500
# and the end, and no ERROR is logged. Images before the chain's first output (no grid exists yet)
# are counted apart.
#
# Usage: scripts/soak.sh [--output DIR] [--scenario FILE] [--frames N] [--rate R] [--keep | --reuse DIR]
#   --output DIR     work and result folder (default: soak_output/ in the repository)
#   --scenario FILE  the drive (default: config/synthetic_drive_long.yaml)
#   --frames N       only its first N frames (e.g. 900 for the overload series of doc/reliability.md)
#   --rate R         rosbag play rate (default 1: real time; above the chain's capacity: overload)
#   --keep           keep the drive and the bag (several GB for the default drive)
#   --reuse DIR      play the drive and bag an earlier --keep run left in DIR (not the --output
#                    folder) instead of writing them again: a series of rates in a fraction of
#                    the time
#   --model M --weights FILE   run the network (OpenCV DNN) instead of replaying the labels,
#                    e.g. models/yolo/yolov3-tiny.cfg and weights from `bench_yolo --write-weights`
#   -- ARG...        further kitti_replay.launch arguments, e.g. grid_config:=/tmp/grid.yaml
# Writes DIR/soak.json (figures), DIR/memory.csv (manager memory every 100 frames),
# DIR/latencies.csv (each frame's latency), DIR/replay.log.
set -eo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
workspace=${GVF_WORKSPACE:-${XDG_CACHE_HOME:-$HOME/.cache}/grid_vision_fusion/workspace}
out=$root/soak_output
scenario=$root/config/synthetic_drive_long.yaml
rate=1.0
keep=false
reuse=""
frames=()
detector=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --output) out=$(realpath -m "$2"); shift ;;
    --scenario) scenario=$(realpath "$2"); shift ;;
    --rate) rate=$2; shift ;;
    --frames) frames=(--frames "$2"); shift ;;
    --keep) keep=true ;;
    --reuse) reuse=$(realpath "$2"); shift ;;
    --model) detector+=(model:="$(realpath "$2")"); shift ;;
    --weights) detector+=(weights:="$(realpath "$2")"); shift ;;
    --) shift; detector+=("$@"); break ;;
    -h | --help) sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "soak: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
  shift
done
export PATH=/usr/bin:/bin:$PATH

GVF_WORKSPACE=$workspace GVF_BUILD_TESTS=0 "$root/scripts/build.sh" >/dev/null
# shellcheck disable=SC1091
source "$workspace/devel/setup.bash"
if [[ -n "$reuse" ]]; then
  [[ "$reuse" != "$out" ]] || { echo "soak: --reuse must name another folder than --output" >&2; exit 2; }
  [[ -f "$reuse/drive.bag" ]] || { echo "soak: no drive.bag in $reuse (run with --keep first)" >&2; exit 2; }
fi
rm -rf "$out" && mkdir -p "$out"
if [[ -n "$reuse" ]]; then
  bag=$reuse/drive.bag
  drive=$reuse/kitti/2011_09_26/2011_09_26_drive_9003_sync
  echo "[soak] playing the drive kept in $reuse"
else
  bag=$out/drive.bag
  drive=$out/kitti/2011_09_26/2011_09_26_drive_9003_sync
  echo "[soak] writing the drive of $scenario"
  start=$SECONDS
  rosrun grid_vision_fusion make_synthetic_drive --scenario "$scenario" --output "$out/kitti" --drive 9003 \
    "${frames[@]}"
  rosrun grid_vision_fusion kitti_to_bag --quiet --compression lz4 "$drive" "$bag"
  rm -rf "$drive/velodyne_points/data" "$drive/image_02/data"
  echo "[soak] drive and bag written in $((SECONDS - start)) s"
fi

port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://localhost:$port
echo "[soak] kitti_replay.launch at rate $rate (roslaunch on port $port, log in $out/replay.log)"
roslaunch -p "$port" grid_vision_fusion kitti_replay.launch bag:="$bag" rate:="$rate" \
  replay_directory:="$drive/label_2" start_delay:=10 player_required:=false "${detector[@]}" >"$out/replay.log" 2>&1 &
launch=$!
manager=""
for _ in $(seq 60); do  # the manager's process, once roslaunch has started it
  manager=$(pgrep -f "nodelet manager __name:=perception_manager" | head -n1 || true)
  [[ -n "$manager" ]] && break
  sleep 0.5
done
[[ -n "$manager" ]] || { kill "$launch"; echo "soak: the nodelet manager did not start: see $out/replay.log" >&2; exit 1; }
# The chain stays up after the bag (player_required:=false) until the monitor has its last
# messages and diagnostics, then the launch is ended.
rosrun grid_vision_fusion latency_probe --output "$out/latencies.csv" 2>>"$out/replay.log" &
probe=$!
python3 "$root/scripts/soak_monitor.py" --manager-pid "$manager" --samples "$out/memory.csv" \
  --summary "$out/monitor.json"
kill -INT "$probe" 2>/dev/null || true
wait "$probe" || true
kill -INT "$launch" 2>/dev/null || true
wait "$launch" || true
[[ "$keep" == true ]] || rm -rf "$out/drive.bag" "$out/kitti"

python3 - "$out" <<'PY'
import csv, json, sys
out = sys.argv[1]
monitor = json.load(open(out + "/monitor.json"))
latencies = sorted(float(r["latency_s"]) for r in csv.DictReader(open(out + "/latencies.csv")) if r["latency_s"])
quantile = lambda q: latencies[min(len(latencies) - 1, int(q * len(latencies)))] if latencies else None
monitor.update(latency_median_s=quantile(0.5), latency_p99_s=quantile(0.99), latency_frames=len(latencies))
rows = [r for r in csv.DictReader(open(out + "/memory.csv"))]
after_500 = [float(r["manager_rss_mib"]) for r in rows if int(r["objects_messages"]) >= 500]
growth = 100.0 * (after_500[-1] - after_500[0]) / after_500[0] if len(after_500) > 1 else float("nan")
lost = monitor["frames_lost"]
figures = dict(monitor, rss_frame_500_mib=after_500[0] if after_500 else None,
               rss_end_mib=after_500[-1] if after_500 else None, rss_growth_percent=growth)
json.dump(figures, open(out + "/soak.json", "w"), indent=1)
print("[soak] images %d, detections %d, projected grids %d (%d of them for a detected image), objects %d: "
      "%d frames lost after the first output (%d images before it)"
      % (monitor["images"], monitor["detections"], monitor["projected_grids"],
         monitor["detections_with_projected_grid"], monitor["objects"], lost, monitor["images_before_first_output"]))
if monitor["projected_grids_without_cells"]:
    print("[soak] %d projected grids without cells (the grid too old for the image), %d object arrays from them "
          "(boxes placed by their tracks or the ground, motion unknown)"
          % (monitor["projected_grids_without_cells"], monitor["objects_without_cells"]))
if monitor["latency_frames"]:
    print("[soak] wall-clock latency from a frame's arrival to its objects: median %.3f s, p99 %.3f s (%d frames)"
          % (monitor["latency_median_s"], monitor["latency_p99_s"], monitor["latency_frames"]))
print("[soak] manager resident memory frame 500 -> end: %s -> %s MiB (%+.1f %%)" %
      (figures["rss_frame_500_mib"], figures["rss_end_mib"], growth))
print("[soak] outputs per stage: %s" % ", ".join("%s %d" % (k, v) for k, v in sorted(monitor["outputs"].items())))
for stage, reasons in sorted(monitor["drops"].items()):
    print("[soak] %s dropped: %s" % (stage, ", ".join("%d %s" % (n, r) for r, n in sorted(reasons.items()))))
print("[soak] errors logged: %d" % len(monitor["errors"]))
for line in monitor["errors"][:20]:
    print("  " + line)
ok = lost == 0 and monitor["images"] > 0 and growth < 5.0 and not monitor["errors"]
print("[soak] %s" % ("passed" if ok else "FAILED"))
sys.exit(0 if ok else 1)
PY
