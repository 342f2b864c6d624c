#!/usr/bin/env bash
# Localisation in a saved map (issue 10, docs/relocalisation.md "Saved map"): the whole
# Victoria Park run saves its map; then windows of the bag, from anywhere on the route, each run
# alone with --load-map map.txt --unknown-pose (starts lost, relocalises globally). Per window:
# scans until the first fix, the fix's distance to the full run's pose at that stamp (the issue's
# reference), the largest distance after it, and the same two against the window tracked from a
# known start in the saved map. Prints a table and a summary line; writes OUT/windows.csv.
#   scripts/saved_map_windows.sh [OUT]       default OUT: $EKF_SLAM_BUILD/saved_map_windows
# Env: WINDOW (60 s), STEP (120 s between window starts), RELOCALISER (ekf_slam/FGCBB),
#      PARAMS (config/victoria_park.yaml; the windows' parameters, the full run's are always that),
#      VP_BAG (default $EKF_SLAM_BUILD/vp.bag, converted from $VP_DATA if missing).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
source "$EKF_SLAM_DEVEL/setup.bash"
out=${1:-$EKF_SLAM_BUILD/saved_map_windows}
window=${WINDOW:-60}
step=${STEP:-120}
reloc=${RELOCALISER:-ekf_slam/FGCBB}
bag=${VP_BAG:-$EKF_SLAM_BUILD/vp.bag}
params=$EKF_SLAM_ROOT/config/victoria_park.yaml
window_params=${PARAMS:-$params}
[[ -f $bag ]] || rosrun ekf_slam victoria_park_to_bag --data "$VP_DATA" --out "$bag" > /dev/null
mkdir -p "$out"
echo "full run (saves the map) ..."
rosrun ekf_slam ekf_slam_offline --bag "$bag" --params "$params" --out "$out/full" --no-plot \
  --no-progress > "$out/full.log"
# The windows, cut in one pass over the bag (the static tf goes into every window).
/usr/bin/python3 - "$bag" "$out" "$window" "$step" <<'PY'
import sys, rosbag
bag_path, out, window, step = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
with rosbag.Bag(bag_path) as b:
    t0, t1 = b.get_start_time(), b.get_end_time()
    starts = []
    s = t0 + 10.0
    while s + window <= t1:
        starts.append(s)
        s += step
    static = [(t, m, ts) for t, m, ts in b.read_messages(topics=["/tf_static"])]
    bags = [rosbag.Bag(f"{out}/window_{int(s)}.bag", "w") for s in starts]
    for i, s in enumerate(starts):
        for t, m, ts in static:
            bags[i].write(t, m, ts)
    for topic, msg, ts in b.read_messages():
        if topic == "/tf_static":
            continue
        for i, s in enumerate(starts):
            if s <= ts.to_sec() < s + window:
                bags[i].write(topic, msg, ts)
    for x in bags:
        x.close()
print(" ".join(str(int(s)) for s in starts), file=open(f"{out}/starts.txt", "w"))
PY
# The second reference: the same window tracked in the saved map from a known start (the full
# run's pose at the window's start, 1 m / 0.05 rad of doubt), so in the saved map's frame. The
# full run's pose at a time came before the loop closures that later moved the map.
/usr/bin/python3 - "$out" "$window_params" <<'PY'
import bisect, csv, re, sys
import rosbag
out, params = sys.argv[1], sys.argv[2]
rows = list(csv.DictReader(open(f"{out}/full/trajectory.csv")))
stamps = [float(r["stamp"]) for r in rows]
text = open(params).read()
for s in open(f"{out}/starts.txt").read().split():
    with rosbag.Bag(f"{out}/window_{s}.bag") as b:  # its first message after the static tf
        first = next(t.to_sec() for topic, _, t in b.read_messages() if topic != "/tf_static")
    r = rows[min(bisect.bisect_left(stamps, first), len(rows) - 1)]
    t = text
    for key, value in (("initial_pose_x", r["x"]), ("initial_pose_y", r["y"]), ("initial_pose_yaw", r["yaw"]),
                       ("initial_pose_sigma_x", "1.0"), ("initial_pose_sigma_y", "1.0"),
                       ("initial_pose_sigma_yaw", "0.05")):
        t, n = re.subn(rf"^{key}:.*$", f"{key}: {value}", t, flags=re.M)
        if n != 1:
            sys.exit(f"{params}: no single line for {key}")
    open(f"{out}/known_{s}.yaml", "w").write(t)
PY
for s in $(cat "$out/starts.txt"); do
  rosrun ekf_slam ekf_slam_offline --bag "$out/window_$s.bag" --params "$window_params" \
    --relocaliser "$reloc" --load-map "$out/full/map.txt" --unknown-pose --out "$out/w_$s" \
    --no-plot --no-progress > "$out/w_$s.log" 2>&1 || echo "window $s: run failed (see $out/w_$s.log)"
  rosrun ekf_slam ekf_slam_offline --bag "$out/window_$s.bag" --params "$out/known_$s.yaml" \
    --load-map "$out/full/map.txt" --out "$out/k_$s" --no-plot --no-progress > "$out/k_$s.log" 2>&1 ||
    echo "window $s, known start: run failed (see $out/k_$s.log)"
  rm -f "$out/window_$s.bag"
done
/usr/bin/python3 - "$out" <<'PY'
import bisect, csv, json, math, sys
out = sys.argv[1]
def traj(path):
    rows = list(csv.DictReader(open(path)))
    return [float(r["stamp"]) for r in rows], [(float(r["x"]), float(r["y"]), float(r["yaw"])) for r in rows]
fs, fp = traj(f"{out}/full/trajectory.csv")
def at(s, p, t):
    i = min(max(bisect.bisect_left(s, t), 0), len(s) - 1)
    return p[i] if abs(s[i] - t) < 0.05 else None
def full_at(t):
    return at(fs, fp, t)
starts = open(f"{out}/starts.txt").read().split()
rows = []
for s in starts:
    try:
        m = json.load(open(f"{out}/w_{s}/metrics.json"))
    except OSError:
        rows.append(dict(start=s, fixed=False, note="run failed")); continue
    ev = m.get("relocalisation_events", [])
    ts, tp = traj(f"{out}/w_{s}/trajectory.csv")
    r = dict(start=s, scans=m.get("scans"), fixed=bool(ev))
    if ev:
        stamp = ev[0]["stamp"]
        r["fix_scan"] = ev[0]["scan"]
        r["fix_after_s"] = stamp - ts[0]
        errs = []
        for t, p in zip(ts, tp):
            if t < stamp - 1e-9: continue
            q = full_at(t)
            if q: errs.append((math.hypot(p[0] - q[0], p[1] - q[1]), abs(math.remainder(p[2] - q[2], 2 * math.pi))))
        r["fix_error_m"] = errs[0][0] if errs else float("nan")
        r["max_error_after_m"] = max(e[0] for e in errs) if errs else float("nan")
        r["wrong"] = bool(errs) and (errs[0][0] > 2.0 or errs[0][1] > 0.2)
        try:  # against the window tracked from a known start in the saved map
            ks, kp = traj(f"{out}/k_{s}/trajectory.csv")
            kerr = [math.hypot(p[0] - q[0], p[1] - q[1]) for t, p in zip(ts, tp)
                    if t >= stamp - 1e-9 for q in [at(ks, kp, t)] if q]
            r["known_fix_error_m"] = kerr[0] if kerr else float("nan")
            r["known_max_error_after_m"] = max(kerr) if kerr else float("nan")
        except OSError:
            r["known_fix_error_m"] = r["known_max_error_after_m"] = float("nan")
    rows.append(r)
with open(f"{out}/windows.csv", "w") as f:
    keys = ["start", "scans", "fixed", "fix_scan", "fix_after_s", "fix_error_m", "max_error_after_m", "wrong",
            "known_fix_error_m", "known_max_error_after_m"]
    w = csv.DictWriter(f, keys, extrasaction="ignore"); w.writeheader(); w.writerows(rows)
print("| window start [s] | scans | fixed at scan | after [s] | error at fix [m] | max error after [m] "
      "| known start: at fix [m] | known start: max after [m] |")
print("|---|---|---|---|---|---|---|---|")
for r in rows:
    if r.get("fixed"):
        print(f"| {r['start']} | {r['scans']} | {r['fix_scan']} | {r['fix_after_s']:.1f} | {r['fix_error_m']:.2f} "
              f"| {r['max_error_after_m']:.2f} | {r['known_fix_error_m']:.2f} | {r['known_max_error_after_m']:.2f} |")
    else:
        print(f"| {r['start']} | {r.get('scans', '-')} | never | - | - | - | - | - |")
n = len(rows)
good = sum(1 for r in rows if r.get("fixed") and not r["wrong"] and r["fix_scan"] <= 10 and r["fix_error_m"] <= 2.0)
within10 = sum(1 for r in rows if r.get("fixed") and r["fix_scan"] <= 10)
within2 = sum(1 for r in rows if r.get("fixed") and r["fix_error_m"] <= 2.0)
known2 = sum(1 for r in rows if r.get("fixed") and r["known_fix_error_m"] <= 2.0)
known_wrong = sum(1 for r in rows if r.get("wrong") and not r["known_fix_error_m"] <= 2.0)
wrong = sum(1 for r in rows if r.get("wrong"))
print(f"\n{n} windows: {good} within 2 m after at most 10 scans ({100.0 * good / max(n, 1):.0f} %), "
      f"{sum(1 for r in rows if r.get('fixed'))} fixed at all, {wrong} wrong fixes; "
      f"{within10} fixed within 10 scans, {within2} within 2 m of the full run at the fix, "
      f"{known2} within 2 m of the known-start window; "
      f"{known_wrong} of the wrong fixes also more than 2 m from the known-start window")
PY
