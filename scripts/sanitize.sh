#!/usr/bin/env bash
# AddressSanitizer + UndefinedBehaviorSanitizer build of the whole package, outside the package
# folder, then every gtest (ctest's gtest entries; the rostests need a master and are left out)
# and a full Victoria Park run through the offline runner. Fails on any sanitizer report.
#
#   scripts/sanitize.sh                      # build folder $EKF_SLAM_SANITIZE_BUILD
#   EKF_SLAM_SANITIZE_BUILD=/tmp/asan EKF_SLAM_SANITIZE_JOBS=1 scripts/sanitize.sh
#   SANITIZE_TESTS=tests_offline scripts/sanitize.sh     # a ctest regex instead of every gtest
#
# About 15 min of CPU for the build on 2 cores (no ccache hits: other flags); not part of CI
# (docs/faults.md).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
build=${EKF_SLAM_SANITIZE_BUILD:-/tmp/ekf_slam_sanitize}
case "$build/" in
  "$EKF_SLAM_ROOT/"*) echo "EKF_SLAM_SANITIZE_BUILD must lie outside $EKF_SLAM_ROOT" >&2; exit 2 ;;
esac
devel=$build/devel
flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
"$EKF_SLAM_ROOT/scripts/install_deps.sh"
mkdir -p "$build"
cmake -S "$EKF_SLAM_ROOT" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCATKIN_DEVEL_PREFIX="$devel" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DCATKIN_ENABLE_TESTING=ON ${EKF_SLAM_CMAKE_ARGS:-} > "$build/configure.log" 2>&1 \
  || { cat "$build/configure.log"; exit 1; }
cmake --build "$build" -j"${EKF_SLAM_SANITIZE_JOBS:-2}" --target all tests

# Any report stops the program with a non-zero status; leaks in ROS's own libraries (class
# loaders, static registries) are not ours to fix, so leak checking is off.
export ASAN_OPTIONS=detect_leaks=0:abort_on_error=0:halt_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
source "$devel/setup.bash"
log=$build/sanitize.log
: > "$log"
status=0
(cd "$build" && ctest --output-on-failure --timeout 1800 -R "gtest_${SANITIZE_TESTS:-}") \
  2>&1 | tee -a "$log" || status=1

if [[ -f $VP_DATA/aa3_dr.mat ]]; then
  "$devel/lib/ekf_slam/victoria_park_to_bag" --data "$VP_DATA" --out "$build/vp.bag" | tee -a "$log"
  "$devel/lib/ekf_slam/ekf_slam_offline" --bag "$build/vp.bag" \
    --params "$EKF_SLAM_ROOT/config/victoria_park.yaml" --out "$build/vp" --no-plot --no-progress \
    > "$build/vp_metrics.json" 2> >(tee -a "$log" >&2) || status=1
else
  echo "sanitize.sh: no Victoria Park data in $VP_DATA: the full run was skipped" | tee -a "$log"
  [[ ${CI:-} == true ]] && status=1
fi
if grep -qE "ERROR: AddressSanitizer|runtime error:|ERROR: LeakSanitizer" "$log"; then
  echo "sanitize.sh: sanitizer reports in $log" >&2
  status=1
fi
echo "sanitize.sh: $([[ $status == 0 ]] && echo clean || echo FAILED) (log: $log)"
exit $status
