#!/usr/bin/env bash
# Installs dependencies and builds every target and test: build tree $EKF_SLAM_BUILD (default
# build/), devel space $EKF_SLAM_DEVEL (default devel/; `source devel/setup.bash` afterwards).
# Extra CMake arguments: $EKF_SLAM_CMAKE_ARGS (e.g. -DEKF_SLAM_NATIVE=ON).
# Targets: $EKF_SLAM_TARGETS (default "all tests"; scripts/demo.sh builds only what it runs).
# ccache is the compiler launcher when it is installed (EKF_SLAM_CCACHE=0 turns that off; a
# launcher given in EKF_SLAM_CMAKE_ARGS wins). A new build tree uses Ninja when it is installed
# (it overlaps the libraries' compiles; 2 cores: docs/benchmarks.md, "First run"), else Unix
# Makefiles; EKF_SLAM_GENERATOR chooses. An existing tree keeps its generator.
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
"$EKF_SLAM_ROOT/scripts/install_deps.sh"
mkdir -p "$EKF_SLAM_BUILD"
launcher=-DCMAKE_CXX_COMPILER_LAUNCHER=
if command -v ccache > /dev/null; then
  [[ ${EKF_SLAM_CCACHE:-1} == 0 ]] || launcher=-DCMAKE_CXX_COMPILER_LAUNCHER=ccache
  # Without these ccache does not cache a file built with a precompiled header (CMakeLists.txt).
  sloppiness=$(ccache -k sloppiness 2> /dev/null || true)
  export CCACHE_SLOPPINESS=${sloppiness:+$sloppiness,}pch_defines,time_macros
  # Depend mode: a miss runs no extra preprocessor pass (the compiler's -MD output names the
  # inputs), so a first build with an empty cache costs about what one without ccache does.
  [[ -n ${CCACHE_DEPEND:-}${CCACHE_NODEPEND:-} ]] || export CCACHE_DEPEND=1
fi
generator=()
if [[ ! -f $EKF_SLAM_BUILD/CMakeCache.txt ]]; then
  if [[ -n ${EKF_SLAM_GENERATOR:-} ]]; then
    generator=(-G "$EKF_SLAM_GENERATOR")
  elif command -v ninja > /dev/null; then
    generator=(-G Ninja)
  fi
fi
cmake "${generator[@]}" -S "$EKF_SLAM_ROOT" -B "$EKF_SLAM_BUILD" -DCMAKE_BUILD_TYPE=Release \
  -DCATKIN_DEVEL_PREFIX="$EKF_SLAM_DEVEL" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DCATKIN_ENABLE_TESTING=ON "$launcher" ${EKF_SLAM_CMAKE_ARGS:-} > "$EKF_SLAM_BUILD/configure.log" 2>&1 \
  || { cat "$EKF_SLAM_BUILD/configure.log"; exit 1; }
# shellcheck disable=SC2086  # a list of target names
cmake --build "$EKF_SLAM_BUILD" -j"$(nproc)" --target ${EKF_SLAM_TARGETS:-all tests}
