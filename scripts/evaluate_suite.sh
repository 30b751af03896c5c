#!/usr/bin/env bash
# Scores the scenario suite: every scenario of config/scenarios/ (or --scenario-dir) goes through
# make_synthetic_drive -> kitti_to_bag -> run_pipeline (replay detector: the drive's own label_2,
# i.e. oracle boxes) -> evaluate, then scripts/suite_report.py writes suite_report.md and
# suite_report.json: per scenario and per class the motion confusion of the matched objects
# within 30 m, moving ones split by truth speed (0.5-1, 1-3, > 3 m/s), the position, speed and
# heading errors, and issue 11's headline figures. See doc/scenario_suite.md.
#
# Usage: scripts/evaluate_suite.sh [options]
#   --scenarios a,b       only these scenarios (file names without .yaml)
#   --output DIR          output folder (default: suite_output/ in the repository)
#   --keep                keep the drives and bags (DIR/work/<scenario>/)
#   --workspace DIR       catkin workspace with the built package (default: $GVF_WORKSPACE or
#                         ~/.cache/grid_vision_fusion/workspace; build it with scripts/build.sh)
#   --devel DIR           its devel space, if not WORKSPACE/devel
#   -j, --jobs N          scenarios run in parallel (default 2); each run_pipeline gets
#                         max(1, cores / N) grid threads unless --param dynamic_grid/threads=...
#   --scenario-dir DIR    folder of scenario YAML files (default: config/scenarios)
#   --config-dir DIR      the nodes' parameter files for run_pipeline (default: the package's
#                         config/), to score a tuned configuration
#   --param NODE/KEY=V    one parameter for run_pipeline on top of the files (its --param),
#                         e.g. --param fusion/motion_vote=cluster; repeatable
#   --reuse DIR           score again the drives and bags that an earlier --keep run left in
#                         DIR/work/ (no make_synthetic_drive, no kitti_to_bag): a tuning loop in
#                         a fraction of the time; DIR must not be the --output folder
#   --thresholds FILE     JSON thresholds (e.g. config/scenarios/targets.json): exit 3 when one
#                         is not met
#   --junit FILE          also write the threshold checks as JUnit XML (for the test command)
#   -h, --help            this text
#
# Output: DIR/suite_report.md, DIR/suite_report.json, DIR/scenarios/<name>/ (evaluate's output:
# report.md, metrics.json, matches.csv, plots), DIR/logs/<name>.log. On a failure no report is
# written (only the logs stay) and the exit status is 1; 2 for bad arguments.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
workspace=${GVF_WORKSPACE:-${XDG_CACHE_HOME:-$HOME/.cache}/grid_vision_fusion/workspace}
devel=""
out=$root/suite_output
scenario_dir=$root/config/scenarios
jobs=2
keep=false
only=""
thresholds=""
junit=""
config_dir=""
reuse=""
params=()
export PATH=/usr/bin:/bin:$PATH

usage_error() {
  echo "evaluate_suite: $1 (see --help)" >&2
  exit 2
}

absolute() { [[ "$1" = /* ]] && echo "$1" || echo "$PWD/$1"; }

while [[ $# -gt 0 ]]; do
  case "$1" in
    -h | --help)
      sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'
      exit 0
      ;;
    --keep) keep=true ;;
    --scenarios | --output | --workspace | --devel | -j | --jobs | --scenario-dir | --thresholds | --junit | --config-dir | \
      --param | --reuse)
      [[ $# -ge 2 ]] || usage_error "$1 needs a value"
      case "$1" in
        --scenarios) only=$2 ;;
        --output) out=$(absolute "$2") ;;
        --workspace) workspace=$(absolute "$2") ;;
        --devel) devel=$(absolute "$2") ;;
        -j | --jobs) jobs=$2 ;;
        --scenario-dir) scenario_dir=$(absolute "$2") ;;
        --thresholds) thresholds=$(absolute "$2") ;;
        --junit) junit=$(absolute "$2") ;;
        --config-dir) config_dir=$(absolute "$2") ;;
        --param) params+=("$2") ;;
        --reuse) reuse=$(absolute "$2") ;;
      esac
      shift
      ;;
    *) usage_error "unknown argument $1" ;;
  esac
  shift
done

[[ "$jobs" =~ ^[1-9][0-9]*$ ]] || usage_error "--jobs needs a positive integer, got '$jobs'"
[[ -d "$scenario_dir" ]] || usage_error "no scenario folder $scenario_dir"
[[ -z "$thresholds" || -f "$thresholds" ]] || usage_error "no thresholds file $thresholds"
[[ -z "$config_dir" || -d "$config_dir" ]] || usage_error "no config folder $config_dir"
[[ -z "$reuse" || -d "$reuse/work" ]] || usage_error "no kept drives in $reuse/work (run with --keep first)"
[[ -z "$reuse" || "$reuse" != "$out" ]] || usage_error "--reuse needs another --output folder than $reuse"
pipeline_options=()
[[ -z "$config_dir" ]] || pipeline_options=(--config-dir "$config_dir")
# Parallel scenarios share the cores: one grid thread per core and scenario (the grid's output
# does not depend on its thread count), unless a --param sets it; later --param options win.
pipeline_options+=(--param "dynamic_grid/threads=$(((jobs < $(nproc)) ? $(nproc) / jobs : 1))")
for param in "${params[@]}"; do pipeline_options+=(--param "$param"); done

# The scenarios: every *.yaml of the folder, sorted, or the --scenarios subset in its order.
mapfile -t available < <(find "$scenario_dir" -maxdepth 1 -name '*.yaml' -printf '%f\n' | sed 's/\.yaml$//' | sort)
[[ ${#available[@]} -gt 0 ]] || usage_error "no *.yaml scenario in $scenario_dir"
if [[ -n "$only" ]]; then
  IFS=',' read -r -a names <<<"$only"
  for name in "${names[@]}"; do
    [[ -f "$scenario_dir/$name.yaml" ]] ||
      usage_error "unknown scenario '$name'; available: $(IFS=,; echo "${available[*]}")"
  done
  [[ ${#names[@]} -gt 0 ]] || usage_error "--scenarios lists no scenario"
  if [[ $(printf '%s\n' "${names[@]}" | sort | uniq -d) ]]; then usage_error "--scenarios names one twice"; fi
else
  names=("${available[@]}")
fi

devel=${devel:-$workspace/devel}
tools=$devel/lib/grid_vision_fusion
for tool in make_synthetic_drive kitti_to_bag run_pipeline evaluate; do
  [[ -x "$tools/$tool" ]] || {
    echo "evaluate_suite: $tools/$tool is missing: build the package first (scripts/build.sh)" \
      "or give --workspace" >&2
    exit 1
  }
done
set +u  # ROS's setup scripts read unset variables
# shellcheck disable=SC1091
source "$devel/setup.bash"
set -u

# Fresh outputs: only what this script writes is removed.
mkdir -p "$out"
rm -rf "$out/scenarios" "$out/work" "$out/logs" "$out/suite_report.md" "$out/suite_report.json"
mkdir -p "$out/scenarios" "$out/work" "$out/logs"
calibration=$root/data/calibration/2011_09_26
cpu="$(grep -m1 "model name" /proc/cpuinfo | cut -d: -f2 | sed "s/^ *//" || true), $(nproc) cores"

# Runs one scenario; its steps log to logs/<name>.log; the last line of logs/<name>.status says
# "ok SECONDS" or "failed STEP".
run_scenario() {
  local name=$1 file=$scenario_dir/$1.yaml
  local log=$out/logs/$name.log status=$out/logs/$name.status work=$out/work/$name
  local source=${reuse:+$reuse/work/$1}
  source=${source:-$work}
  local drive=$source/kitti/2011_09_26/2011_09_26_drive_9001_sync start=$SECONDS from_drive
  mkdir -p "$work"
  : >"$log"
  step() {
    local what=$1
    shift
    echo "== $what: $*" >>"$log"
    if ! nice "$@" >>"$log" 2>&1; then
      echo "failed $what" >"$status"
      return 1
    fi
  }
  local synth=(--output "$work/kitti" --scenario "$file" --calibration "$calibration")
  from_drive=$(sed -n 's/^# suite-from-drive: *//p' "$file" | head -n1)
  if [[ -n "$from_drive" ]]; then
    [[ "$from_drive" = /* ]] || from_drive=$root/$from_drive
    synth+=(--from-drive "$from_drive")
  fi
  if [[ -n "$reuse" ]]; then
    [[ -f "$source/drive.bag" ]] || step "reuse: no $source/drive.bag" false || return 1
  else
    step make_synthetic_drive "$tools/make_synthetic_drive" "${synth[@]}" || return 1
    step kitti_to_bag "$tools/kitti_to_bag" --quiet "$drive" "$work/drive.bag" || return 1
    if [[ "$keep" != true ]]; then  # the pipeline reads the bag, evaluate the metadata
      rm -rf "$drive/image_02/data" "$drive/velodyne_points/data"
    fi
  fi
  step run_pipeline "$tools/run_pipeline" --bag "$source/drive.bag" --output "$work/objects.bag" \
    --backend replay --replay-directory "$drive/label_2" "${pipeline_options[@]}" || return 1
  step evaluate "$tools/evaluate" --drive "$drive" --detections "$work/objects.bag" \
    --output "$out/scenarios/$name" || return 1
  [[ "$keep" == true ]] || rm -rf "$work"
  echo "ok $((SECONDS - start))" >"$status"
}

declare -A running=()  # pid -> scenario
failed=""
done_count=0
suite_start=$SECONDS

# shellcheck disable=SC2317  # called by the trap
cleanup_on_signal() {
  for pid in "${!running[@]}"; do  # the scenario's current step, then its shell
    pkill -TERM -P "$pid" 2>/dev/null || true
    kill "$pid" 2>/dev/null || true
  done
  wait 2>/dev/null || true
  rm -rf "$out/work" "$out/scenarios"
  echo "evaluate_suite: interrupted" >&2
  exit 130
}
trap cleanup_on_signal INT TERM

report_finished() {
  local pid=$1 name=${running[$1]} result
  unset "running[$pid]"
  done_count=$((done_count + 1))
  result=$(cat "$out/logs/$name.status" 2>/dev/null || echo "failed (no status)")
  if [[ "$result" == ok\ * ]]; then
    printf '[%d/%d] %s ... %s s\n' "$done_count" "${#names[@]}" "$name" "${result#ok }"
  else
    printf '[%d/%d] %s ... FAILED at %s (see %s)\n' "$done_count" "${#names[@]}" "$name" "${result#failed }" \
      "$out/logs/$name.log"
    [[ -n "$failed" ]] || failed="$name: ${result#failed } failed, see $out/logs/$name.log"
  fi
}

wait_one() {
  local pid=""
  wait -n -p pid "${!running[@]}" || true
  [[ -n "$pid" ]] && report_finished "$pid"
}

echo "evaluate_suite: ${#names[@]} scenarios from $scenario_dir, $jobs in parallel, output in $out"
for name in "${names[@]}"; do
  [[ -z "$failed" ]] || break
  while [[ ${#running[@]} -ge $jobs ]]; do wait_one; done
  [[ -z "$failed" ]] || break
  run_scenario "$name" &
  running[$!]=$name
done
while [[ ${#running[@]} -gt 0 ]]; do wait_one; done
wall=$((SECONDS - suite_start))

if [[ -n "$failed" ]]; then
  echo "evaluate_suite: scenario $failed" >&2
  rm -rf "$out/scenarios"
  [[ "$keep" == true ]] || rm -rf "$out/work"
  if [[ -n "$junit" ]]; then
    message="scenario $failed"
    python3 - "$junit" "$message" <<'EOF'
import sys
from xml.sax.saxutils import escape, quoteattr
import os
path, message = sys.argv[1], sys.argv[2]
os.makedirs(os.path.dirname(path), exist_ok=True)
with open(path, "w") as f:
    f.write('<?xml version="1.0" encoding="UTF-8"?>\n<testsuite name="scenario_suite" tests="1" failures="1" errors="0">\n'
            '  <testcase classname="scenario_suite" name="pipeline" time="0">\n'
            '    <failure message=%s>%s</failure>\n  </testcase>\n</testsuite>\n' % (quoteattr(message), escape(message)))
EOF
  fi
  exit 1
fi
[[ "$keep" == true ]] || rm -rf "$out/work"

args=(--output "$out" --wall-time "$wall" --jobs "$jobs" --cpu "$cpu")
for name in "${names[@]}"; do
  seconds=$(cut -d' ' -f2 "$out/logs/$name.status")
  args+=(--scenario "$name" "$out/scenarios/$name" "$seconds")
done
[[ -z "$thresholds" ]] || args+=(--thresholds "$thresholds")
[[ -z "$junit" ]] || args+=(--junit "$junit")
status=0
python3 "$root/scripts/suite_report.py" "${args[@]}" || status=$?
if [[ $status -eq 1 ]]; then
  rm -f "$out/suite_report.md" "$out/suite_report.json"
  echo "evaluate_suite: the report could not be made" >&2
  exit 1
fi
echo "evaluate_suite: ${#names[@]} scenarios in $wall s; $out/suite_report.md, $out/suite_report.json"
sed -n '/^## Headline/,/^## All scenarios: motion/p' "$out/suite_report.md" | sed '$d'
exit "$status"
