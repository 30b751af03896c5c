#!/usr/bin/env bash
# The test command: installs the Debian packages that are missing, builds grid_vision_fusion in
# a catkin workspace, runs every test (gtest, rostest, launch-file checks) and prints
# `N passed, M failed` last. Exits non-zero when a build step or any test fails.
#
# Usage: scripts/run_tests.sh              (workspace in ~/.cache/grid_vision_fusion/workspace)
#        scripts/run_tests.sh --sanitize   (AddressSanitizer + UndefinedBehaviorSanitizer build
#                                           in ~/.cache/grid_vision_fusion/workspace_sanitize)
#        GVF_WORKSPACE=/path scripts/run_tests.sh
#        GVF_TEST_TIMEOUT=seconds   (the tests' time limit, default 1200; then they count as failed)
set -o pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
sanitize=0
case "${1:-}" in
  --sanitize) sanitize=1 ;;
  "") ;;
  *) echo "usage: $0 [--sanitize]" >&2; exit 2 ;;
esac
# The workspace lives outside the repository: a workspace inside the package folder would make
# a symbolic-link loop (workspace/src/grid_vision_fusion -> the repository) that rosrun's search follows.
cache=${XDG_CACHE_HOME:-$HOME/.cache}/grid_vision_fusion
if ((sanitize)); then
  workspace=${GVF_WORKSPACE:-$cache/workspace_sanitize}
  export GVF_CMAKE_ARGS="-DGVF_SANITIZE=ON ${GVF_CMAKE_ARGS:-}"
else
  workspace=${GVF_WORKSPACE:-$cache/workspace}
fi
jobs=${GVF_JOBS:-$(nproc)}
export PATH=/usr/bin:/bin:$PATH

fail() {
  echo "[run_tests] $1" >&2
  echo "0 passed, 1 failed"
  exit 1
}

GVF_WORKSPACE=$workspace "$root/scripts/build.sh" || fail "installing the dependencies or building failed"
# shellcheck disable=SC1091
source "$workspace/devel/setup.bash" || fail "cannot source $workspace/devel/setup.bash"
cd "$workspace" || fail "cannot enter $workspace"
rm -rf "$workspace/build/test_results"
reports=$workspace/sanitizer_reports
if ((sanitize)); then
  # The nodelet manager is not instrumented: the sanitizer runtime must be loaded first into it,
  # as into every process that may load the plugin library. The test launch files set it as
  # LD_PRELOAD of their nodes only: preloaded into rostest itself (Python, with the master's
  # threads in it), gcc 12's runtime can hang a fork for good (doc/reliability.md). Leak checking
  # stays off because it would report the Python interpreters' own allocations at exit.
  rm -rf "$reports" && mkdir -p "$reports"
  GVF_TEST_PRELOAD="$(realpath "$(gcc -print-file-name=libasan.so)")" || fail "no libasan (gcc's AddressSanitizer runtime)"
  export GVF_TEST_PRELOAD
  # AddressSanitizer writes its reports into $reports. UndefinedBehaviorSanitizer (built with
  # -fno-sanitize-recover=all) aborts the process and prints to stderr: gcc's runtime ignores
  # log_path when both sanitizers are linked, so undefined behaviour fails the test that ran it.
  # scripts/asan.supp: a known use-after-free in Debian's nodelet library at shutdown.
  export ASAN_OPTIONS="detect_leaks=0:abort_on_error=1:log_path=$reports/asan:suppressions=$root/scripts/asan.supp"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
fi
echo "[run_tests] running the tests"
# A run that hangs (make waits for a process that never ends) is stopped after GVF_TEST_TIMEOUT
# seconds and counts as one failed test. Nodes that rostest started in sessions of their own
# are found by the token every process of this run inherits.
limit=${GVF_TEST_TIMEOUT:-1200}
export GVF_TEST_RUN="run_tests-$$-$(date +%s%N)"
# run_tests exits 0 even when tests fail: the verdict comes from the result files below.
timeout --kill-after=30 "$limit" catkin_make run_tests -j"$jobs"
status=$?
if ((status == 124 || status == 137)); then
  echo "[run_tests] the tests did not end within ${limit} s (GVF_TEST_TIMEOUT); still running:" >&2
  leftovers=()
  for environ in /proc/[0-9]*/environ; do
    pid=${environ#/proc/}
    pid=${pid%/environ}
    if ((pid != $$)) && grep -qzxF "GVF_TEST_RUN=$GVF_TEST_RUN" "$environ" 2>/dev/null; then
      leftovers+=("$pid")
      echo "  $pid: $(tr '\0' ' ' < "/proc/$pid/cmdline" 2>/dev/null | cut -c1-200)" >&2
    fi
  done
  ((${#leftovers[@]} == 0)) || kill -KILL "${leftovers[@]}" 2>/dev/null
  mkdir -p "$workspace/build/test_results/grid_vision_fusion"
  cat > "$workspace/build/test_results/grid_vision_fusion/run_tests-timeout.xml" << EOF
<?xml version="1.0" encoding="UTF-8"?>
<testsuite name="run_tests" tests="1" failures="1" errors="0">
  <testcase classname="run_tests" name="ended_within_${limit}_s"><failure message="stopped after ${limit} s"/></testcase>
</testsuite>
EOF
fi
catkin_test_results "$workspace/build/test_results" || true
if ((sanitize)); then
  # A report of a process whose failure no test saw (a tool run by a script, a nodelet whose
  # test still passed) counts as a failed test.
  python3 "$root/scripts/summarize_test_results.py" "$workspace/build/test_results" --sanitizer-reports "$reports"
else
  python3 "$root/scripts/summarize_test_results.py" "$workspace/build/test_results"
fi
