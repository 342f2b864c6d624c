#!/usr/bin/env bash
# The catkin workspace flow, as a ROS user runs it, on a clone of this repository in a fresh
# workspace: rosdep install, catkin_make, tools with rosrun from the devel space, catkin_make
# install, the same from the install space (plugins, launch files, configs included).
# About 10 minutes on 2 cores (a full build); not part of scripts/test.sh.
#   scripts/workspace_check.sh [WORKSPACE]    (default: a new folder under /tmp, removed after)
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
ws=${1:-$(mktemp -d /tmp/ekf_slam_ws.XXXXXX)}
[[ -n ${1:-} ]] || trap 'rm -rf "$ws"' EXIT
mkdir -p "$ws/src"
git clone -q "$EKF_SLAM_ROOT" "$ws/src/ekf_slam"
cd "$ws"
step() { echo; echo "== $*"; }

step "rosdep install --from-paths src --ignore-src (offline, Debian's keys)"
src/ekf_slam/scripts/rosdep_check.sh --install

step "catkin_make"
catkin_make -j"$(nproc)" -DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3 > build.log 2>&1 \
  || { tail -40 build.log; exit 1; }

try_space() {  # try_space SPACE: the package's tools and files from that space
  (
    source "$ws/$1/setup.bash"
    set -x
    rospack find ekf_slam
    rosrun ekf_slam simulate --list | head -3
    rosrun ekf_slam simulate --world tiny --seed 1 --out "$ws/tiny_$1.bag" | tail -1
    rosrun ekf_slam ekf_slam_offline --bag "$ws/tiny_$1.bag" --params "$ws/tiny_$1.yaml" \
      --out "$ws/out_$1" --no-plot --no-progress | tail -2
    rosrun ekf_slam replay_association --problem "$ws/src/ekf_slam/test/data/shifted_row.json" \
      --associator ekf_slam/JCBB | tail -2
    roslaunch --ros-args ekf_slam ekf_slam.launch > /dev/null
    roslaunch --ros-args ekf_slam victoria_park.launch > /dev/null
    roslaunch --ros-args ekf_slam simulation.launch > /dev/null
    ls "$(rospack find ekf_slam)/config/robot.yaml" "$(rospack find ekf_slam)/config/victoria_park.yaml"
  )
}
step "from the devel space"
try_space devel

step "catkin_make install"
catkin_make install -j"$(nproc)" > install.log 2>&1 || { tail -40 install.log; exit 1; }
step "from the install space"
try_space install
echo
echo "workspace flow: OK ($ws)"
