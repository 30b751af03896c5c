#!/usr/bin/env bash
# The test command: installs the Debian packages that are missing, builds grid_vision_fusion in
# a catkin workspace, runs every test (gtest, rostest, launch-file checks) and prints
# `N passed, M failed` last. Exits non-zero when a build step or any test fails.
#
# Usage: scripts/run_tests.sh            (workspace in ~/.cache/grid_vision_fusion/workspace)
#        GVF_WORKSPACE=/path scripts/run_tests.sh
set -o pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# The workspace lives outside the repository: a workspace inside the package folder would make
# a symbolic-link loop (workspace/src/grid_vision_fusion -> the repository) that rosrun's search follows.
workspace=${GVF_WORKSPACE:-${XDG_CACHE_HOME:-$HOME/.cache}/grid_vision_fusion/workspace}
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
echo "[run_tests] running the tests"
# run_tests exits 0 even when tests fail: the verdict comes from the result files below.
catkin_make run_tests -j"$jobs"
catkin_test_results "$workspace/build/test_results" || true
python3 "$root/scripts/summarize_test_results.py" "$workspace/build/test_results"
