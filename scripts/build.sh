#!/usr/bin/env bash
# Installs the Debian packages that are missing and builds grid_vision_fusion (with its tests'
# executables unless GVF_BUILD_TESTS=0) in a catkin workspace. Used by run_tests.sh and demo.sh.
#
# Usage: scripts/build.sh            (workspace in ~/.cache/grid_vision_fusion/workspace)
#        GVF_WORKSPACE=/path scripts/build.sh
#        GVF_CMAKE_ARGS="-DGVF_SANITIZE=ON" scripts/build.sh   (extra CMake arguments)
set -eo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# The workspace lives outside the repository: a workspace inside the package folder would make
# a symbolic-link loop (workspace/src/grid_vision_fusion -> the repository) that rosrun's search follows.
workspace=${GVF_WORKSPACE:-${XDG_CACHE_HOME:-$HOME/.cache}/grid_vision_fusion/workspace}
jobs=${GVF_JOBS:-$(nproc)}
# Debian's ROS tools need Debian's python3 (a pyenv python3 may come first on PATH).
export PATH=/usr/bin:/bin:$PATH

"$root/scripts/install_deps.sh"
mkdir -p "$workspace/src"
ln -sfn "$root" "$workspace/src/grid_vision_fusion"
cd "$workspace"
echo "[build] building in $workspace (catkin_make, $jobs jobs)"
# shellcheck disable=SC2086
catkin_make -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 ${GVF_CMAKE_ARGS:-} -j"$jobs"
if [[ "${GVF_BUILD_TESTS:-1}" != 0 ]]; then
  catkin_make tests -j"$jobs"
fi
