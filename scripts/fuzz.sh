#!/usr/bin/env bash
# libFuzzer campaign over the parsers of outside input (fuzz/fuzz_*.cpp).
#
#   scripts/fuzz.sh [seconds] [harness...]
#
# Installs clang-14 and libfuzzer-14-dev when missing, builds every harness (or those named)
# with -fsanitize=fuzzer,address,undefined in $GVF_FUZZ_DIR (default
# ~/.cache/grid_vision_fusion/fuzz), makes each seed corpus from test/data (copied there, the
# repository is never written), runs the harnesses two at a time for `seconds` each (default
# 600) and prints executions, seconds, corpus size and findings per harness. Findings (crash-*,
# leak-*, timeout-*, oom-* files; slow-unit-* ones are listed, not counted) are left in
# $GVF_FUZZ_DIR/<harness>/findings. Exits non-zero on any finding.
set -euo pipefail

REPO=$(cd "$(dirname "$0")/.." && pwd)
SECONDS_EACH=${1:-600}
shift || true
WORK=${GVF_FUZZ_DIR:-$HOME/.cache/grid_vision_fusion/fuzz}
ALL_HARNESSES=$(cd "$REPO/fuzz" && ls fuzz_*.cpp | sed 's/^fuzz_//; s/\.cpp$//')
HARNESSES=${*:-$ALL_HARNESSES}

if ! command -v clang++-14 > /dev/null || [ ! -e /usr/lib/llvm-14/lib/clang/14.0.6/lib/linux/libclang_rt.fuzzer-x86_64.a ]; then
  apt-get install -y clang-14 libfuzzer-14-dev
fi

# --- build: the parser sources once into an archive, then one binary per harness ------------
CXX=clang++-14
FLAGS=(-std=c++17 -g -O1 -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
  -I"$REPO/include" -I/usr/include/eigen3 $(pkg-config --cflags opencv4 yaml-cpp))
LIBS=($(pkg-config --libs opencv4 yaml-cpp) -lrostime -lcpp_common)
SOURCES=(src/detection/kitti_labels.cpp src/detection/detection_replay.cpp src/detection/yolo_detector.cpp
  src/kitti/kitti_calibration.cpp src/kitti/kitti_raw.cpp src/simulation/synthetic_scenario.cpp
  src/simulation/synthetic_world.cpp src/projection/box_projection.cpp src/ros/sensor_views.cpp)
mkdir -p "$WORK/obj"
objects=()
for source in "${SOURCES[@]}"; do
  object="$WORK/obj/$(basename "$source" .cpp).o"
  if [ ! -e "$object" ] || [ "$REPO/$source" -nt "$object" ] || [ -n "$(find "$REPO/include" -newer "$object" -name '*.h' | head -1)" ]; then
    echo "compiling $source"
    nice "$CXX" "${FLAGS[@]}" -c "$REPO/$source" -o "$object"
  fi
  objects+=("$object")
done
for harness in $HARNESSES; do
  binary="$WORK/bin/fuzz_$harness"
  mkdir -p "$WORK/bin"
  if [ ! -e "$binary" ] || [ -n "$(find "$REPO/fuzz" "$REPO/include" "$WORK/obj" -newer "$binary" -type f | head -1)" ]; then
    echo "building fuzz_$harness"
    nice "$CXX" "${FLAGS[@]}" -fsanitize=fuzzer "$REPO/fuzz/fuzz_$harness.cpp" "${objects[@]}" "${LIBS[@]}" \
      -o "$binary"
  fi
done

# --- seed corpora: files of test/data (and the repository's models and calibration) ---------
RAW=$REPO/test/data/kitti_raw_2011_09_26
DRIVE=$RAW/2011_09_26_drive_0001_sync
SEPARATOR=$'\n----\n'
seed() {  # seed <harness> <file>...: copies files into the harness's seed directory
  local harness=$1
  shift
  cp "$@" "$WORK/$harness/seeds/"
}
make_seeds() {
  local harness=$1 dir=$WORK/$1/seeds
  rm -rf "$dir"
  mkdir -p "$dir"
  if [ -d "$REPO/test/data/fuzz/$harness" ]; then
    find "$REPO/test/data/fuzz/$harness" -type f ! -name '*.md' -exec cp {} "$dir/" \;
  fi
  case $harness in
    kitti_labels)
      for f in "$REPO"/test/data/kitti_labels/*/* "$REPO"/test/data/kitti_object_samples/label_2/*; do
        cp "$f" "$dir/$(basename "$(dirname "$f")")_$(basename "$f")"
      done ;;
    kitti_object_calibration) seed "$harness" "$REPO"/test/data/kitti_object_samples/calib/* ;;
    kitti_raw_calibration)
      for calib in "$RAW" "$REPO/data/calibration/2011_09_26"; do
        { cat "$calib/calib_cam_to_cam.txt"; printf '%s' "$SEPARATOR"; cat "$calib/calib_velo_to_cam.txt"
          printf '%s' "$SEPARATOR"; cat "$calib/calib_imu_to_velo.txt"; } > "$dir/$(basename "$calib").txt"
      done ;;
    oxts) seed "$harness" $(ls "$DRIVE"/oxts/data/*.txt | head -20) ;;
    timestamps)
      for f in "$DRIVE"/*/timestamps*.txt; do cp "$f" "$dir/$(basename "$(dirname "$f")")_$(basename "$f")"; done ;;
    tracklets) seed "$harness" "$DRIVE/tracklet_labels.xml" ;;
    scenario) seed "$harness" "$REPO"/test/data/*.yaml "$REPO"/test/data/suite_short/*.yaml "$REPO"/config/scenarios/*.yaml ;;
    darknet_cfg) seed "$harness" "$REPO"/models/yolo/*.cfg ;;
    darknet_weights)
      for cfg in "$REPO"/models/yolo/*.cfg; do
        { cat "$cfg"; printf '%s' "$SEPARATOR"; printf '\0\0\0\0\2\0\0\0\0\0\0\0'; } > "$dir/$(basename "$cfg")"
      done ;;
    class_names) seed "$harness" "$REPO"/models/yolo/*.names ;;
    replay_labels)
      # 1242 x 375 image, default score 1, threshold 0.5, no class map, pattern "%06d.txt", index 7
      for f in "$REPO"/test/data/kitti_labels/*/* "$REPO"/test/data/kitti_object_samples/label_2/*; do
        { printf '\xda\x04\x77\x01\xff\x80\x00\x08%%06d.txt\x07\x00\x00\x00'; cat "$f"; } \
          > "$dir/$(basename "$(dirname "$f")")_$(basename "$f")"
      done ;;
  esac
}

# --- the campaign -----------------------------------------------------------------------------
run_one() {  # run_one <harness>: fuzzes it for SECONDS_EACH, its log in $WORK/<harness>/fuzz.log
  local harness=$1 dir=$WORK/$1
  mkdir -p "$dir/corpus" "$dir/findings"
  nice -n 19 "$WORK/bin/fuzz_$harness" "$dir/corpus" "$dir/seeds" -max_total_time="$SECONDS_EACH" \
    -max_len=65536 -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=30 -print_final_stats=1 \
    -artifact_prefix="$dir/findings/" > "$dir/fuzz.log" 2>&1 || true
}
for harness in $HARNESSES; do
  make_seeds "$harness"
  rm -rf "$WORK/$harness/findings"
done
pending=($HARNESSES)
while [ ${#pending[@]} -gt 0 ]; do
  run_one "${pending[0]}" &
  first=$!
  second=
  if [ ${#pending[@]} -gt 1 ]; then
    run_one "${pending[1]}" &
    second=$!
  fi
  wait $first ${second:+$second}
  pending=("${pending[@]:2}")
done

status=0
printf '%-26s %10s %8s %8s %9s\n' harness executions seconds corpus findings
for harness in $HARNESSES; do
  dir=$WORK/$harness
  executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$dir/fuzz.log" | tail -1)
  seconds=$(sed -n 's/^stat::.*//; s/^Done [0-9]* runs in \([0-9]*\) second.*/\1/p' "$dir/fuzz.log" | tail -1)
  corpus=$(find "$dir/corpus" -type f | wc -l)
  findings=$(find "$dir/findings" -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' -o -name 'oom-*' \) | wc -l)
  printf '%-26s %10s %8s %8s %9s\n' "$harness" "${executions:-?}" "${seconds:-?}" "$corpus" "$findings"
  find "$dir/findings" -type f -name 'slow-unit-*' -exec echo "  slow unit (not counted): {}" \;
  if [ "$findings" -gt 0 ] || [ -z "$executions" ]; then
    status=1
    find "$dir/findings" -type f ! -name 'slow-unit-*' -exec echo "  finding: {}" \;
    [ -n "$executions" ] || echo "  no statistics: see $dir/fuzz.log"
  fi
done
exit $status
