#!/usr/bin/env bash
# Full EKF against the compressed EKF (filter cekf, docs/cekf.md), printed as the tables of
# docs/benchmarks.md ("Compressed EKF") and docs/benchmarks_vp.md:
#  1. vp: Victoria Park, whole run, per associator and area size: wall and update time (best of
#     RUNS), largest difference of the trajectory and of the map from the full EKF's;
#  2. city: the `city` world (true associations, bench_cekf) at N >= 20 000: both filters start at
#     drive time CITY_START on a map holding every landmark observed before it (bench_cekf
#     --start-at) and run CITY_SCANS scans (the full EKF EKF_SCANS), CEKF per area size in
#     CITY_AREAS: CPU time per scan, peak memory (/usr/bin/time -v), the global updates and why;
#  3. city_drive: the drive itself from the start, CEKF, DRIVE_SCANS scans (0: the whole hour).
#   scripts/bench_cekf.sh [vp] [city] [city_drive]       (default: vp city)
# Env: RUNS (3), VP_ASSOCIATORS ("DJNN JCBB"), VP_AREAS ("25 50 100"), VP_BAG, CITY_START (2600),
#      CITY_SCANS (1000), CITY_AREAS ("50 100 150"), CITY_SLACK (0), EKF_SCANS (300),
#      DRIVE_SCANS (20000), DRIVE_AREA (150), DRIVE_SLACK (5), CITY_EVERY (100).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
RUNS=${RUNS:-3}
VP_BAG=${VP_BAG:-$EKF_SLAM_BUILD/vp.bag}
parts=("$@")
((${#parts[@]})) || parts=(vp city)
[[ -f "$EKF_SLAM_DEVEL/setup.bash" ]] || { echo "no build in $EKF_SLAM_BUILD: run scripts/build.sh"; exit 1; }
source "$EKF_SLAM_DEVEL/setup.bash"
out="$EKF_SLAM_BUILD/bench_cekf"
mkdir -p "$out"
echo "Machine: $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"

vp() {
  if [[ ! -f "$VP_BAG" ]]; then
    rosrun ekf_slam victoria_park_to_bag --data "$VP_DATA" --out "$VP_BAG" >&2
  fi
  local configs=(ekf)
  for a in ${VP_AREAS:-25 50 100}; do configs+=("cekf_$a"); done
  for assoc in ${VP_ASSOCIATORS:-DJNN JCBB}; do
    for c in "${configs[@]}"; do
      local yaml="$out/vp_$c.yaml"
      if [[ $c == ekf ]]; then
        cp "$EKF_SLAM_ROOT/config/victoria_park.yaml" "$yaml"
      else
        sed -e "s/^filter: .*/filter: cekf/" -e "s/^cekf_area_size: .*/cekf_area_size: ${c#cekf_}/" \
          "$EKF_SLAM_ROOT/config/victoria_park.yaml" > "$yaml"
      fi
      for ((r = 1; r <= RUNS; ++r)); do
        rosrun ekf_slam ekf_slam_offline --bag "$VP_BAG" --params "$yaml" --associator "$assoc" \
          --out "$out/vp_${assoc}_$c.$r" --no-plot --no-progress > /dev/null
      done
    done
  done
  echo
  echo "Victoria Park, whole run, best of $RUNS by wall time"
  /usr/bin/python3 - "$out" "$RUNS" "${VP_ASSOCIATORS:-DJNN JCBB}" "${configs[@]}" <<'PY'
import csv, json, sys
out, runs, assocs, configs = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(), sys.argv[4:]
def rows(path):
    with open(path) as f:
        return [r for r in csv.reader(f) if r and not r[0].startswith("#")]
def numeric(table):
    head, body = table[0], table[1:]
    return head, [[float(x) for x in r] for r in body]
print("| associator | filter | wall [s] | update [s] | landmarks | GPS RMSE [m] | max pose diff [m] | max map diff [m] |")
print("|---|---|---|---|---|---|---|---|")
for a in assocs:
    ref = None
    for c in configs:
        ms = [(json.load(open(f"{out}/vp_{a}_{c}.{r}/metrics.json")), r) for r in range(1, runs + 1)]
        m, r = min(ms, key=lambda x: x[0]["wall_time_s"])
        d = f"{out}/vp_{a}_{c}.{r}"
        th, traj = numeric(rows(f"{d}/trajectory.csv"))
        lh, lms = numeric(rows(f"{d}/landmarks.csv"))
        if ref is None:
            ref = (traj, lms)
            pd = md = 0.0
        else:
            pd = max(max(abs(x[1] - y[1]), abs(x[2] - y[2])) for x, y in zip(ref[0], traj)) \
                if len(traj) == len(ref[0]) else float("inf")
            md = max(max(abs(x[1] - y[1]), abs(x[2] - y[2])) for x, y in zip(ref[1], lms)) \
                if len(lms) == len(ref[1]) else float("inf")
        name = "full EKF" if c == "ekf" else f"CEKF {c[5:]} m"
        print(f"| {a} | {name} | {m['wall_time_s']:.3f} | {m['update_time_s']:.3f} | {m['landmarks']} "
              f"| {m.get('gps_rmse_m') or float('nan'):.2f} | {pd:.1e} | {md:.1e} |")
PY
}

# Closures by reason, mean scans between them, mean A at the opening (bench_cekf --closures).
closures() {
  /usr/bin/python3 - "$1" <<'PY'
import csv, sys
from collections import Counter
rows = [r for r in csv.DictReader(open(sys.argv[1])) if r["reason"] != "flush"]
gaps = [int(b["scan"]) - int(a["scan"]) for a, b in zip(rows, rows[1:])]
n_a0 = [int(r["opened_states"]) for r in rows]
print(f"global updates {len(rows)} {dict(Counter(r['reason'] for r in rows))}, "
      f"every {sum(gaps) / max(1, len(gaps)):.0f} scans, A at the opening {sum(n_a0) / max(1, len(n_a0)):.0f} states")
PY
}

city() {
  local bench="$EKF_SLAM_DEVEL/lib/ekf_slam/bench_cekf" start=${CITY_START:-2600}
  local common=(--world city --start-at "$start" --every "${CITY_EVERY:-100}"
    --prior-map "$out/city_prior.map")
  for a in ${CITY_AREAS:-50 100 150}; do
    echo
    echo "city from $start s, CEKF (area $a m, slack ${CITY_SLACK:-0} m), ${CITY_SCANS:-1000} scans"
    /usr/bin/time -v "$bench" "${common[@]}" --filter cekf --area "$a" --slack "${CITY_SLACK:-0}" \
      --max-scans "${CITY_SCANS:-1000}" \
      --closures "$out/city_cekf_$a.csv" 2> "$out/city_cekf_$a.time" | tee "$out/city_cekf_$a.txt"
    grep "Maximum resident" "$out/city_cekf_$a.time"
    closures "$out/city_cekf_$a.csv"
  done
  echo
  echo "city from $start s, full EKF, ${EKF_SCANS:-300} scans"
  /usr/bin/time -v "$bench" "${common[@]}" --filter ekf --max-scans "${EKF_SCANS:-300}" \
    2> "$out/city_ekf.time" | tee "$out/city_ekf.txt"
  grep "Maximum resident" "$out/city_ekf.time"
}

city_drive() {
  local bench="$EKF_SLAM_DEVEL/lib/ekf_slam/bench_cekf"
  echo
  echo "city drive, CEKF (area ${DRIVE_AREA:-150} m, slack ${DRIVE_SLACK:-5} m), ${DRIVE_SCANS:-20000} scans (0: all)"
  /usr/bin/time -v "$bench" --world city --filter cekf --area "${DRIVE_AREA:-150}" --slack "${DRIVE_SLACK:-5}" \
    --max-scans "${DRIVE_SCANS:-20000}" --every 1000 --closures "$out/city_drive.csv" \
    2> "$out/city_drive.time" | tee "$out/city_drive.txt"
  grep "Maximum resident" "$out/city_drive.time"
  closures "$out/city_drive.csv"
}

for p in "${parts[@]}"; do "$p"; done
