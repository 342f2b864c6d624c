#!/usr/bin/env bash
# The mutation fuzz of replay_association's problem files (test/test_replay_fuzz.cpp) with more
# cases than CI's 3000: scripts/fuzz_replay.sh [CASES] (default 100000, about 1 min here).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cmake --build "$EKF_SLAM_BUILD" --target tests_app -j2 > /dev/null
EKF_SLAM_FUZZ_CASES=${1:-100000} "$EKF_SLAM_DEVEL/lib/ekf_slam/tests_app" --gtest_filter="ReplayFuzz.*"
