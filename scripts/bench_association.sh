#!/usr/bin/env bash
# Builds and runs the association benchmark (bench/bench_association.cpp) and prints a markdown
# table of the median CPU time per associate() call (context construction included), in us.
#   scripts/bench_association.sh [extra Google Benchmark flags, e.g. --benchmark_filter=DJNN]
# Build folder: $EKF_SLAM_BUILD (default build/). Raw results: $EKF_SLAM_BUILD/bench_association.json
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
if [[ ! -f "$EKF_SLAM_BUILD/CMakeCache.txt" ]]; then
  cmake -S "$EKF_SLAM_ROOT" -B "$EKF_SLAM_BUILD" -DCMAKE_BUILD_TYPE=Release \
    -DCATKIN_DEVEL_PREFIX="$EKF_SLAM_DEVEL" -DPYTHON_EXECUTABLE=/usr/bin/python3 > "$EKF_SLAM_BUILD.configure.log" 2>&1 \
    || { cat "$EKF_SLAM_BUILD.configure.log"; exit 1; }
fi
cmake --build "$EKF_SLAM_BUILD" --target bench_association -j"$(nproc)" > /dev/null
bin=$(find "$EKF_SLAM_DEVEL/lib" -name bench_association -type f | head -n1)
[[ -x "$bin" ]] || { echo "bench_association was not built (libbenchmark-dev missing?)"; exit 1; }
json="$EKF_SLAM_BUILD/bench_association.json"
"$bin" --benchmark_repetitions=3 --benchmark_report_aggregates_only=true \
  --benchmark_out="$json" --benchmark_out_format=json "$@" >&2

build_type=$(grep -m1 '^CMAKE_BUILD_TYPE' "$EKF_SLAM_BUILD/CMakeCache.txt" | cut -d= -f2)
echo "Machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')," \
  "build type ${build_type:-Release (the root CMakeLists default)}"
/usr/bin/python3 - "$json" <<'PY'
import json, sys, collections
runs = json.load(open(sys.argv[1]))["benchmarks"]
table = collections.OrderedDict()
obs = []
for r in runs:
    if r.get("aggregate_name") != "median":
        continue
    name, n, m, *variant = r["run_name"].split("/")
    n, m = int(n.split(":")[1]), int(m.split(":")[1])
    if variant:  # e.g. drift:x5
        n = f"{n} ({variant[0].replace(':', ' ')})"
    if m not in obs:
        obs.append(m)
    table.setdefault((name, n), {})[m] = r
obs.sort()
head = ["associator", "landmarks"] + [f"{m} obs [us]" for m in obs] + \
       [f"correct ({m} obs)" for m in obs] + [f"M_ij evals ({m} obs)" for m in obs] + \
       [f"JCBB nodes ({m} obs)" for m in obs]
print("| " + " | ".join(head) + " |")
print("|" + "---|" * len(head))
for (name, n), row in sorted(table.items(), key=lambda kv: (kv[0][0], len(str(kv[0][1])), str(kv[0][1]))):
    t = [f"{row[m]['cpu_time']:.1f}" if m in row else "-" for m in obs]
    c = [f"{row[m]['correct']:.3f}" if m in row else "-" for m in obs]
    e = [f"{row[m]['evals']:.0f}" if m in row else "-" for m in obs]
    # JCBB's search size; a '!' marks a node budget hit (the result was not exact).
    j = [(f"{row[m]['jcbb_nodes']:.0f}" + ("!" if row[m]["budget_hit"] else ""))
         if m in row and name in ("JCBB", "NNJCBB") else "-" for m in obs]
    if name == "ContextOnly":  # associates nothing: only its time means something
        c = e = ["-"] * len(obs)
    print("| " + " | ".join([name, str(n)] + t + c + e + j) + " |")
PY
