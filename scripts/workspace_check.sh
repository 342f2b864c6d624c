#!/usr/bin/env bash
# The catkin workspace flow, as a ROS user runs it, on a clone of this repository in a fresh
# workspace: rosdep install, build (catkin_make, or catkin build from catkin_tools), tools with
# rosrun from the devel space, the tests (catkin build only: `catkin test`), install, the same
# tools from the install space (plugins, launch files, configs included).
# 10-20 minutes on 2 cores (a full build, twice with the tests); not part of scripts/test.sh
# (the CI budget), its figures are in docs/benchmarks.md, "Workspace builds".
#   scripts/workspace_check.sh [--tool catkin_make|catkin_tools] [WORKSPACE]
#     --tool        catkin_make (default) or catkin_tools (`catkin build`, Debian's catkin-tools,
#                   installed by this script when missing)
#     WORKSPACE     default: a new folder under /tmp, removed after
#   EKF_SLAM_WS_TESTS=0 leaves out `catkin test` (about 1250 test cases, run one after the other)
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
tool=catkin_make
if [[ ${1:-} == --tool ]]; then
  tool=$2
  shift 2
fi
case $tool in
  catkin_make | catkin_tools) ;;
  *) echo "workspace_check.sh: --tool is catkin_make or catkin_tools, not '$tool'" >&2; exit 2 ;;
esac
ws=${1:-$(mktemp -d /tmp/ekf_slam_ws.XXXXXX)}
[[ -n ${1:-} ]] || trap 'rm -rf "$ws"' EXIT
mkdir -p "$ws/src"
git clone -q "$EKF_SLAM_ROOT" "$ws/src/ekf_slam"
cd "$ws"
step() { echo; echo "== $*"; }

step "rosdep install --from-paths src --ignore-src (offline, Debian's keys)"
src/ekf_slam/scripts/rosdep_check.sh --install

cmake_args=(-DCMAKE_BUILD_TYPE=Release -DPYTHON_EXECUTABLE=/usr/bin/python3)
if [[ $tool == catkin_tools ]]; then
  if ! command -v catkin > /dev/null; then
    step "apt-get install catkin-tools"
    SUDO=""
    [[ $(id -u) -ne 0 ]] && SUDO=sudo
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends catkin-tools
  fi
  # The install space is chosen before the first build: catkin_tools refuses to switch a built
  # workspace to --install without `catkin clean`. The devel space is built all the same.
  step "catkin init; catkin config --install --cmake-args ...; catkin build"
  catkin init > /dev/null
  catkin config --install --cmake-args "${cmake_args[@]}" > /dev/null
  catkin build --no-status -j"$(nproc)" > build.log 2>&1 || { tail -40 build.log; exit 1; }
else
  step "catkin_make"
  catkin_make -j"$(nproc)" "${cmake_args[@]}" > build.log 2>&1 || { tail -40 build.log; exit 1; }
fi

try_space() {  # try_space SPACE: the package's tools and files from that space
  (
    source "$ws/$1/setup.bash"
    set -x
    rospack find ekf_slam
    rosrun ekf_slam simulate --list | sed -n 1,3p  # sed reads it all: no SIGPIPE under pipefail
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

if [[ $tool == catkin_tools ]]; then
  # catkin test builds the package's test targets and runs them (ctest through catkin's
  # run_tests); catkin_test_results reads the results, as `catkin test` returns 0 on failures
  # in some versions.
  step "catkin test"
  [[ ${EKF_SLAM_WS_TESTS:-1} == 0 ]] && echo "skipped (EKF_SLAM_WS_TESTS=0)" || (
    source devel/setup.bash
    export ROS_HOSTNAME=localhost VP_DATA
    catkin test --no-status ekf_slam --make-args -j"$(nproc)" > test.log 2>&1 || { tail -60 test.log; exit 1; }
    catkin_test_results build/ekf_slam/test_results || { tail -60 test.log; exit 1; }
  )
else
  step "catkin_make install"
  catkin_make install -j"$(nproc)" > install.log 2>&1 || { tail -40 install.log; exit 1; }
fi
step "from the install space"
try_space install
echo
echo "workspace flow ($tool): OK ($ws)"
