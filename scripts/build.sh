#!/usr/bin/env bash
# Installs dependencies and builds every target and test into $EKF_SLAM_BUILD (default build/).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
"$EKF_SLAM_ROOT/scripts/install_deps.sh"
cmake -S "$EKF_SLAM_ROOT" -B "$EKF_SLAM_BUILD" -DCMAKE_BUILD_TYPE=Release \
  -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCATKIN_ENABLE_TESTING=ON > "$EKF_SLAM_BUILD.configure.log" 2>&1 \
  || { cat "$EKF_SLAM_BUILD.configure.log"; exit 1; }
cmake --build "$EKF_SLAM_BUILD" -j"$(nproc)" --target all tests
