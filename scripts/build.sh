#!/usr/bin/env bash
# Installs dependencies and builds every target and test: build tree $EKF_SLAM_BUILD (default
# build/), devel space $EKF_SLAM_DEVEL (default devel/; `source devel/setup.bash` afterwards).
# Extra CMake arguments: $EKF_SLAM_CMAKE_ARGS (e.g. -DCMAKE_CXX_COMPILER_LAUNCHER=ccache).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
"$EKF_SLAM_ROOT/scripts/install_deps.sh"
mkdir -p "$EKF_SLAM_BUILD"
cmake -S "$EKF_SLAM_ROOT" -B "$EKF_SLAM_BUILD" -DCMAKE_BUILD_TYPE=Release \
  -DCATKIN_DEVEL_PREFIX="$EKF_SLAM_DEVEL" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DCATKIN_ENABLE_TESTING=ON ${EKF_SLAM_CMAKE_ARGS:-} > "$EKF_SLAM_BUILD/configure.log" 2>&1 \
  || { cat "$EKF_SLAM_BUILD/configure.log"; exit 1; }
cmake --build "$EKF_SLAM_BUILD" -j"$(nproc)" --target all tests
