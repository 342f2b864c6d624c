#!/usr/bin/env bash
# Kidnap campaign (issue 34, item 5): never a confident wrong pose, with recovery as it ships.
#
#   scripts/kidnap_campaign.sh OUT        RUNS=2 WORLDS='*' RELOCALISER= JOBS=2 VP=1
#   REPORT_ONLY=1 scripts/kidnap_campaign.sh OUT     the table again from OUT's runs
#
# 1. evaluate on every simulated world (WORLDS: a list or prefixes with '*') with the default
#    associator and, RELOCALISER empty, the relocaliser the configuration brings (FGCBB; none in
#    fiducials, whose parameters turn it off); RELOCALISER=ekf_slam/FGCBB forces one everywhere.
# 2. ekf_slam_offline on Victoria Park ($VP_BAG, else build/vp.bag) without a kidnap and with
#    --kidnap at 10 places. A fix is wrong when the pose after it is over 2 m or 0.2 rad from the
#    run without a kidnap at the same scan; "within 2 s": fixed at most 2 s after the kidnap.
# Prints the table (also OUT/campaign.md): wrong fixes, recoveries within 2 s, and false lost
# events (lost events in runs without a kidnap).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
source "$EKF_SLAM_DEVEL/setup.bash"
out=${1:?usage: scripts/kidnap_campaign.sh OUT}
mkdir -p "$out"
reloc=()
[[ -n ${RELOCALISER:-} ]] && reloc=(--relocaliser "$RELOCALISER")

if [[ -z ${REPORT_ONLY:-} ]]; then
rosrun ekf_slam evaluate --world "${WORLDS:-*}" --runs "${RUNS:-2}" --jobs "${JOBS:-2}" \
  --associators ekf_slam/DJNN "${reloc[@]}" --no-progress --out "$out/worlds" > /dev/null \
  2> "$out/worlds.log"

if [[ ${VP:-1} == 1 ]]; then
  bag=${VP_BAG:-$EKF_SLAM_BUILD/vp.bag}
  [[ -f $bag ]] || rosrun ekf_slam victoria_park_to_bag --data "$VP_DATA" --out "$bag" > /dev/null
  vp() {  # vp NAME ARGS...
    local name=$1
    shift
    rosrun ekf_slam ekf_slam_offline --bag "$bag" --params "$EKF_SLAM_ROOT/config/victoria_park.yaml" \
      --out "$out/vp_$name" --no-plot --no-progress "${reloc[@]}" "$@" > "$out/vp_$name.log" 2>&1
  }
  vp none
  # Ten places along the run, jumps of 15-36 m and 0.8-3 rad.
  for k in 1000:20,-10,1.0 1700:-15,-15,2.0 2000:30,-20,1.5 3000:-25,15,2.0 3500:15,-25,-1.2 \
    4000:-15,10,-0.8 5000:15,15,-2.5 6000:20,20,3.0 6500:-20,10,1.0 7000:10,-20,3.0; do
    vp "${k%%:*}" --kidnap "$k"
    echo "$k" > "$out/vp_${k%%:*}.kidnap"
  done
fi
fi

/usr/bin/python3 - "$out" <<'PY' | tee "$out/campaign.md"
import csv, json, math, pathlib, sys
out = pathlib.Path(sys.argv[1])
def num(text, empty=0):  # results.csv leaves a column empty where it does not apply
    return float(text) if text not in ("", "nan") else empty
head = ("| {} | runs | lost events | false lost events | fixes | wrong fixes (map) | "
        "recovered within 2 s (map) |")
rows = list(csv.DictReader(open(out / "worlds" / "results.csv")))
by_world = {}
for r in rows:
    by_world.setdefault(r["world"], []).append(r)
tot = dict(runs=0, lost=0, false=0, fixes=0, wrong=0, wrong_map=0, fast=0, fast_map=0, kidnapped=0)
lines = []
for world, rs in sorted(by_world.items()):
    kidnap = "kidnap" in world
    n = len(rs)
    lost = int(sum(num(r["lost_events"]) for r in rs))
    fixes = int(sum(num(r["relocalisations"]) for r in rs))
    wrong = int(sum(num(r["wrong_relocalisations"]) for r in rs))
    wrong_map = int(sum(num(r["wrong_relocalisations_map"]) for r in rs))
    within = lambda r, m: num(r["recovery_scans" + m], -1) >= 0 and num(r["recovery_s" + m], math.inf) <= 2.0
    fast = sum(1 for r in rs if kidnap and within(r, ""))
    fast_map = sum(1 for r in rs if kidnap and within(r, "_map"))
    false = 0 if kidnap else lost
    lines.append(f"| {world} | {n} | {lost} | {false} | {fixes} | {wrong} ({wrong_map}) | "
                 + (f"{fast} ({fast_map}) of {n}" if kidnap else "-") + " |")
    for k, v in dict(runs=n, lost=lost, false=false, fixes=fixes, wrong=wrong, wrong_map=wrong_map,
                     fast=fast, fast_map=fast_map, kidnapped=n if kidnap else 0).items():
        tot[k] += v
print(head.format("worlds"))
print("|---|---|---|---|---|---|---|")
print(f"| all {len(by_world)} | {tot['runs']} | {tot['lost']} | **{tot['false']}** | {tot['fixes']} | "
      f"**{tot['wrong']}** ({tot['wrong_map']}) | {tot['fast']} ({tot['fast_map']}) of {tot['kidnapped']} |")
print()
print(head.format("world"))
print("|---|---|---|---|---|---|---|")
print("\n".join(lines))
vp = out / "vp_none"
if vp.exists():
    def load(name):
        d = out / f"vp_{name}"
        traj = list(csv.DictReader(open(d / "trajectory.csv")))
        return json.load(open(d / "metrics.json")), traj
    ref, ref_traj = load("none")
    print()
    print("| Victoria Park `--kidnap` | lost at | fixed at | fixed within 2 s | wrong fix | landmarks | GPS RMSE [m] |")
    print("|---|---|---|---|---|---|---|")
    print(f"| none | {ref['counters']['lost_events']} lost events | - | - | - | {ref['landmarks']} | {ref['gps_rmse_m']:.3f} |")
    for log in sorted(out.glob("vp_*.log")):
        name = log.stem[3:]
        if name == "none":
            continue
        m, traj = load(name)
        kidnap = (out / f"vp_{name}.kidnap").read_text().strip()
        scan = int(name)
        t0 = float(traj[scan]["stamp"])
        events = m.get("lost_event_list", [])
        lost_at = ", ".join(str(e["scan"]) for e in events) or "never"
        fixed = [e for e in events if e["end"] == "relocalised"]
        fixed_at = ", ".join(str(e["end_scan"]) for e in fixed) or "-"
        fast = any(e["end_stamp"] - t0 <= 2.0 for e in fixed)
        wrong = 0
        for e in fixed:
            a, b = traj[e["end_scan"]], ref_traj[e["end_scan"]]
            d = math.hypot(float(a["x"]) - float(b["x"]), float(a["y"]) - float(b["y"]))
            yaw = abs(math.remainder(float(a["yaw"]) - float(b["yaw"]), 2 * math.pi))
            wrong += d > 2.0 or yaw > 0.2
        print(f"| `{kidnap}` | {lost_at} | {fixed_at} | {'yes' if fast else 'no'} | {wrong} | "
              f"{m['landmarks']} | {m['gps_rmse_m']:.3f} |")
PY
