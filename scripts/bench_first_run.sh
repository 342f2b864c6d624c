#!/usr/bin/env bash
# Benchmark (not a test): a new user's first run. In a fresh `git clone` of this repository (the
# ROS packages already installed) with an empty ccache (CCACHE_DIR in a new temporary folder),
# times scripts/demo.sh until it prints its result, then the full test build (scripts/build.sh:
# `all tests`) in the same clone, as scripts/test.sh starts with. Prints the figures of
# docs/benchmarks.md, "First run".
#   scripts/bench_first_run.sh [--overlay FILE]... [--keep]
#     --overlay FILE  copy FILE (a path relative to the repository) from this working tree into
#                     the clone first: the clone is of HEAD, without uncommitted changes
#     --keep          keep the temporary folder (clone, build, logs) and say where it is
# Env: VP_DATA (the data set; as scripts/env.sh sets it for this repository), DEMO, ASSOCIATOR
# (DJNN), BENCH_DIR (parent of the temporary folder, default /tmp).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"

overlay=()
keep=0
while (( $# )); do
  case $1 in
    --overlay) overlay+=("$2"); shift 2 ;;
    --keep) keep=1; shift ;;
    -h | --help) sed -n '2,13p' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) echo "bench_first_run.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done

work=$(mktemp -d "${BENCH_DIR:-/tmp}/bench_first_run.XXXXXX")
if (( keep )); then
  trap 'echo "kept: $work"' EXIT
else
  trap 'rm -rf "$work"' EXIT
fi
clone=$work/ekf_slam
git clone -q "$EKF_SLAM_ROOT" "$clone"
for f in "${overlay[@]}"; do
  mkdir -p "$(dirname "$clone/$f")"
  cp -p "$EKF_SLAM_ROOT/$f" "$clone/$f"
done

# A new user's environment: the clone's own build and devel folders, an empty ccache.
export CCACHE_DIR=$work/ccache
unset EKF_SLAM_BUILD EKF_SLAM_DEVEL EKF_SLAM_CMAKE_ARGS EKF_SLAM_TARGETS CCACHE_DISABLE
export VP_DATA
mkdir -p "$CCACHE_DIR"

now() { echo "${EPOCHREALTIME/,/.}"; }
# stamp START: prefixes every line of stdin with the seconds since START.
stamp() { local line; while IFS= read -r line; do printf '%8.1f %s\n' "$(bc <<< "$(now) - $1")" "$line"; done; }
secs() { printf '%.0f' "$(bc <<< "$2 - $1")"; }
mmss() { printf '%d min %02d s' $(($1 / 60)) $(($1 % 60)); }

echo "bench_first_run: $(date -Is), $(nproc) CPUs ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')), $(awk '/MemTotal/ {printf "%.0f GB", $2 / 1048576}' /proc/meminfo) RAM, load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "clone: $(git -C "$clone" log -1 --format='%h %cs') of $EKF_SLAM_ROOT${overlay:+, with ${#overlay[@]} working-tree files}; ccache: $(command -v ccache || echo 'not installed'); data: $VP_DATA"

t0=$(now)
# /usr/bin/time adds up the CPU time of every compiler: on a busy machine that stays put while the
# wall time grows, so it tells what the wall time would have been on two free cores.
(cd "$clone" && /usr/bin/time -f '%U %S' -o "$work/demo.cpu" scripts/demo.sh ${ASSOCIATOR:+"$ASSOCIATOR"}) 2>&1 \
  | stamp "$t0" > "$work/demo.log" \
  || { tail -40 "$work/demo.log"; echo "bench_first_run: scripts/demo.sh failed" >&2; exit 1; }
t1=$(now)
result=$(grep -m1 ' associator  ' "$work/demo.log" | awk '{print $1}') || true
# The build's last line: Ninja's "[N/N] ..." or make's "Built target ...".
built=$(grep -E '^ *[0-9.]+ (\[[0-9]+/[0-9]+\] |.*Built target )' "$work/demo.log" | tail -1 | awk '{print $1}') || true
echo
sed -n '/ associator  /,$p' "$work/demo.log" | cut -c10-
demo_s=$(secs "$t0" "$t1")
echo
cpu() { awk '{printf "%.0f", $1 + $2}' "$1"; }
echo "demo:        $(mmss "$demo_s") from the clone to its last line (result printed at ${result:-?} s;" \
  "install check, configure and build done at ${built:-?} s); CPU $(cpu "$work/demo.cpu") s"

t2=$(now)
(cd "$clone" && /usr/bin/time -f '%U %S' -o "$work/test_build.cpu" scripts/build.sh) 2>&1 \
  | stamp "$t2" > "$work/test_build.log" \
  || { tail -40 "$work/test_build.log"; echo "bench_first_run: scripts/build.sh failed" >&2; exit 1; }
t3=$(now)
test_s=$(secs "$t2" "$t3")
echo "test build:  $(mmss "$test_s") more for scripts/build.sh (all tests) after the demo;" \
  "$(mmss $((demo_s + test_s))) from the clone to every test built; CPU $(cpu "$work/test_build.cpu") s"
echo "generator:   $(grep -m1 '^CMAKE_GENERATOR:' "$clone/build/CMakeCache.txt" | cut -d= -f2)"
echo "objects:     $(find "$clone/build" -name '*.o' | wc -l) compiled; ccache: $(ccache -s 2> /dev/null | grep -E '^ *(Hits|Misses):' | tr -s ' ' | tr '\n' ';')"
echo "load after:  $(cut -d' ' -f1-3 /proc/loadavg)"
if (( keep )); then echo "logs: $work/demo.log, $work/test_build.log"; fi
