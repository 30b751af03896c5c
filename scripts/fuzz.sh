#!/usr/bin/env bash
# libFuzzer campaign over the parsers of outside input (fuzz/<folder>/fuzz_*.cpp).
#
#   scripts/fuzz.sh [seconds] [harness...]
#   scripts/fuzz.sh --ci [seconds]
#
# Installs clang-14 and its runtime libraries (libFuzzer) when missing, configures the package
# with clang-14 and -DGVF_FUZZ=ON in $GVF_FUZZ_DIR/build (default GVF_FUZZ_DIR:
# ${XDG_CACHE_HOME:-~/.cache}/grid_vision_fusion/fuzz) and builds the fuzz_<harness> target of
# every harness (or of those named): the package libraries it links with
# -fsanitize=fuzzer-no-link,address,undefined, the harness with -fsanitize=fuzzer
# (fuzz/fuzz.cmake). Then it makes each seed corpus from test/data (copied there, the repository
# is never written), runs the harnesses two at a time for `seconds` each (default 600) and prints
# executions, seconds, corpus size and findings per harness. Findings (crash-*, leak-*, timeout-*,
# oom-* files; slow-unit-* ones are listed, not counted) are left in
# $GVF_FUZZ_DIR/<harness>/findings. Exits non-zero on any finding.
#
# --ci (.ci/run): every harness, 10 s each unless `seconds` is given, and a last line
# `N passed, M failed` (a harness passes when its run found nothing; a failed build is one failure).
set -euo pipefail

REPO=$(cd "$(dirname "$0")/.." && pwd)
CI=0
if [ "${1:-}" = --ci ]; then
  CI=1
  shift
fi
SECONDS_EACH=${1:-$((CI ? 10 : 600))}
shift || true
WORK=${GVF_FUZZ_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/grid_vision_fusion/fuzz}
BUILD=$WORK/build
JOBS=${GVF_JOBS:-$(nproc)}
ALL_HARNESSES=$(cd "$REPO/fuzz" && printf '%s\n' */fuzz_*.cpp | sed 's#^.*/fuzz_##; s/\.cpp$//' | sort)
HARNESSES=${*:-$ALL_HARNESSES}
# Debian's ROS tools need Debian's python3 (a pyenv python3 may come first on PATH).
export PATH=/usr/bin:/bin:$PATH

usage() {
  echo "usage: $0 [seconds] [harness...] | $0 --ci [seconds]" >&2
  exit 2
}
[[ $SECONDS_EACH =~ ^[0-9]+$ ]] || usage
if ((CI)) && [ $# -gt 0 ]; then
  usage
fi
for harness in $HARNESSES; do
  compgen -G "$REPO/fuzz/*/fuzz_$harness.cpp" > /dev/null || { echo "no harness fuzz/*/fuzz_$harness.cpp" >&2; usage; }
done
fail() {  # fail <message>: a step before the runs failed
  echo "[fuzz] $1" >&2
  if ((CI)); then
    echo "0 passed, 1 failed"
  fi
  exit 1
}

# --- build: the package with clang-14 and -DGVF_FUZZ=ON, only the harnesses and their libraries --
"$REPO/scripts/install_deps.sh" || fail "installing the dependencies failed"
if ! command -v clang++-14 > /dev/null ||
  [ ! -e "$(clang-14 --print-runtime-dir)/libclang_rt.fuzzer-$(uname -m).a" ]; then
  SUDO=
  [ "$(id -u)" -eq 0 ] || SUDO=sudo
  export DEBIAN_FRONTEND=noninteractive
  { $SUDO apt-get update -qq && $SUDO apt-get install -y -qq --no-install-recommends clang-14 libclang-rt-14-dev; } ||
    fail "installing clang-14 and libclang-rt-14-dev failed"
fi
rm -rf "${WORK:?}/obj" "${WORK:?}/bin"  # the hand-compiled build of this script before the CMake one
mkdir -p "$BUILD"
# A build directory configured from another checkout (another worktree) is started afresh.
if [ -e "$BUILD/CMakeCache.txt" ] &&
  ! grep -qxF "CMAKE_HOME_DIRECTORY:INTERNAL=$REPO" "$BUILD/CMakeCache.txt"; then
  echo "[fuzz] $BUILD was configured from another source folder: starting it afresh"
  rm -rf "$BUILD" && mkdir -p "$BUILD"
fi
start=$(date +%s)
echo "[fuzz] configuring $BUILD (clang-14, -DGVF_FUZZ=ON; log: $WORK/configure.log)"
CC=clang-14 CXX=clang++-14 nice cmake -S "$REPO" -B "$BUILD" -DGVF_FUZZ=ON -DCMAKE_BUILD_TYPE=Debug \
  -DCATKIN_ENABLE_TESTING=OFF -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
  > "$WORK/configure.log" 2>&1 || { tail -n 40 "$WORK/configure.log"; fail "configuring failed"; }
configured=$(date +%s)
targets=()
for harness in $HARNESSES; do
  targets+=("fuzz_$harness")
done
echo "[fuzz] building ${#targets[@]} harnesses ($JOBS jobs; log: $WORK/build.log)"
nice cmake --build "$BUILD" --target "${targets[@]}" -j "$JOBS" > "$WORK/build.log" 2>&1 ||
  { tail -n 60 "$WORK/build.log"; fail "building the harnesses failed"; }
grep -E '^\[ *[0-9]+%\] (Building|Linking)' "$WORK/build.log" | sed 's/^\[ *[0-9]*%\] /  /' || true
built=$(date +%s)

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
  nice -n 19 "$BUILD/fuzz/fuzz_$harness" "$dir/corpus" "$dir/seeds" -max_total_time="$SECONDS_EACH" \
    -max_len=65536 -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=30 -print_final_stats=1 \
    -artifact_prefix="$dir/findings/" > "$dir/fuzz.log" 2>&1 || true
}
for harness in $HARNESSES; do
  make_seeds "$harness"
  rm -rf "$WORK/$harness/findings"
done
pending=($HARNESSES)
echo "[fuzz] running ${#pending[@]} harnesses for $SECONDS_EACH s each, two at a time"
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
ran=$(date +%s)

status=0
passed=0
failed=0
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
    failed=$((failed + 1))
    find "$dir/findings" -type f ! -name 'slow-unit-*' -exec echo "  finding: {}" \;
    [ -n "$executions" ] || echo "  no statistics: see $dir/fuzz.log"
    if ((CI)); then
      tail -n 40 "$dir/fuzz.log" | sed 's/^/  | /'
    fi
  else
    passed=$((passed + 1))
  fi
done
echo "[fuzz] configure $((configured - start)) s, build $((built - configured)) s, runs $((ran - built)) s"
if ((CI)); then
  echo "$passed passed, $failed failed"
fi
exit $status
