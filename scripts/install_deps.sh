#!/usr/bin/env bash
# Installs the Debian packages ekf_slam needs (ROS 1 from Debian 12's own archive, no /opt/ros).
# Skips apt entirely when everything is already installed.
set -eo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config libgtest-dev libbenchmark-dev libeigen3-dev
  ros-core-dev libtf2-ros-dev pluginlib-dev python3-rostest rosbash
  python3-sensor-msgs python3-nav-msgs python3-geometry-msgs python3-visualization-msgs
  python3-tf2-msgs libdiagnostic-msgs-dev python3-diagnostic-msgs python3-std-srvs tf2-tools
  catkin-lint python3-rosdep2
  libmatio-dev nlohmann-json3-dev libyaml-cpp-dev python3-matplotlib
)
if [[ "${EKF_SLAM_WITH_RVIZ:-0}" == 1 ]]; then
  PACKAGES+=(rviz xvfb xauth imagemagick libgl1-mesa-dri)
fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "Installing: ${missing[*]}"
  SUDO=""
  [[ $(id -u) -ne 0 ]] && SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
