#!/usr/bin/env bash
# Localisation in a saved map (issue 10, docs/relocalisation.md "Saved map"): the whole
# Victoria Park run saves its map; then windows of the bag, from anywhere on the route, each run
# alone with --load-map map.txt --unknown-pose (starts lost, relocalises globally). Per window:
# scans until the first fix, the fix's distance to the full run's pose at that stamp (the issue's
# reference), the largest distance after it, and the same two against the window tracked from a
# known start in the saved map, and the distance to a map fit (the pose that best fits the
# known-start window's pairings with the saved map at the first well-fitting scan from the fix on).
# And a reference independent of the map: GPS. The full run's gps.csv holds the fixes moved into
# the map frame by the runner's one alignment (fitted to the full run's whole trajectory), so the
# window's fix and the full run's pose over the same seconds are judged with the same transform;
# per window the median error of the GPS antenna (the laser point) over the fixes the runner does
# not flag faulty in the GPS_SECONDS after the fix, and over the rest of the window.
# With SMOOTH=1 the full run is smoothed (--smooth, docs/smoothing.md): the windows localise in
# its map_smoothed.txt, and "the full run's pose" is its smoothed trajectory (the same frame as
# that map); GPS is moved into the map frame by the smoothed trajectory's own alignment.
# Prints a table and a summary line; writes OUT/windows.csv. Exits non-zero on a wrong fix.
#   scripts/saved_map_windows.sh [OUT]       default OUT: $EKF_SLAM_BUILD/saved_map_windows
# Env: WINDOW (60 s), STEP (120 s between window starts), RELOCALISER (ekf_slam/FGCBB),
#      GPS_SECONDS (5 s: the GPS fixes after the fix whose median error is the GPS column),
#      PARAMS (config/victoria_park.yaml; the windows' parameters, the full run's are always that),
#      VP_BAG (default $EKF_SLAM_BUILD/vp.bag, converted from $VP_DATA if missing),
#      SMOOTH (0; 1: the smoothed map and trajectory, above).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
source "$EKF_SLAM_DEVEL/setup.bash"
out=${1:-$EKF_SLAM_BUILD/saved_map_windows}
window=${WINDOW:-60}
step=${STEP:-120}
gps_seconds=${GPS_SECONDS:-5}
reloc=${RELOCALISER:-ekf_slam/FGCBB}
bag=${VP_BAG:-$EKF_SLAM_BUILD/vp.bag}
params=$EKF_SLAM_ROOT/config/victoria_park.yaml
window_params=${PARAMS:-$params}
if [[ ${SMOOTH:-0} == 1 ]]; then
  smooth_arg=--smooth
  export SMW_MAP=map_smoothed.txt SMW_TRAJ=trajectory_smoothed.csv
else
  smooth_arg=
  export SMW_MAP=map.txt SMW_TRAJ=trajectory.csv
fi
[[ -f $bag ]] || rosrun ekf_slam victoria_park_to_bag --data "$VP_DATA" --out "$bag" > /dev/null
mkdir -p "$out"
echo "full run (saves the map) ..."
rosrun ekf_slam ekf_slam_offline --bag "$bag" --params "$params" --out "$out/full" --no-plot \
  --no-progress $smooth_arg > "$out/full.log"
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
import bisect, csv, math, os, re, sys
import rosbag
out, params = sys.argv[1], sys.argv[2]
rows = list(csv.DictReader(open(f"{out}/full/{os.environ['SMW_TRAJ']}")))
stamps = [float(r["stamp"]) for r in rows]
text = open(params).read()
for s in open(f"{out}/starts.txt").read().split():
    with rosbag.Bag(f"{out}/window_{s}.bag") as b:  # its first message after the static tf
        first = next(t.to_sec() for topic, _, t in b.read_messages() if topic != "/tf_static")
        # The sensor offset, for the map fit below (planar: x, y, yaw of base_link -> laser).
        for _, m, _ in b.read_messages(topics=["/tf_static"]):
            for x in m.transforms:
                tr, q = x.transform.translation, x.transform.rotation
                yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
                open(f"{out}/sensor_offset.txt", "w").write(f"{tr.x} {tr.y} {yaw}")
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
    --relocaliser "$reloc" --load-map "$out/full/$SMW_MAP" --unknown-pose --out "$out/w_$s" \
    --no-plot --no-progress > "$out/w_$s.log" 2>&1 || echo "window $s: run failed (see $out/w_$s.log)"
  rosrun ekf_slam ekf_slam_offline --bag "$out/window_$s.bag" --params "$out/known_$s.yaml" \
    --load-map "$out/full/$SMW_MAP" --out "$out/k_$s" --no-plot --no-progress > "$out/k_$s.log" 2>&1 ||
    echo "window $s, known start: run failed (see $out/k_$s.log)"
  rm -f "$out/window_$s.bag"
done
/usr/bin/python3 - "$out" "$gps_seconds" <<'PY'
import bisect, csv, json, math, os, statistics, sys
out, gps_seconds = sys.argv[1], float(sys.argv[2])
def traj(path):
    rows = list(csv.DictReader(open(path)))
    return [float(r["stamp"]) for r in rows], [(float(r["x"]), float(r["y"]), float(r["yaw"])) for r in rows]
fs, fp = traj(f"{out}/full/{os.environ['SMW_TRAJ']}")
def at(s, p, t):
    i = min(max(bisect.bisect_left(s, t), 0), len(s) - 1)
    return p[i] if abs(s[i] - t) < 0.05 else None
def full_at(t):
    return at(fs, fp, t)
starts = open(f"{out}/starts.txt").read().split()
saved = {}
for line in open(f"{out}/full/{os.environ['SMW_MAP']}"):
    f = line.split()
    if len(f) >= 3 and not line.startswith(("#", "ekf_slam_map")):
        saved[int(f[0])] = (float(f[1]), float(f[2]))
ox, oy, oyaw = (float(v) for v in open(f"{out}/sensor_offset.txt").read().split())
# GPS in the map frame (the full run's alignment, inverted by the runner), without faulty fixes;
# none (NaN columns) for a bag without /gps.
gps_csv = f"{out}/full/gps.csv"
gps = [(float(g["stamp"]), (float(g["x_map"]), float(g["y_map"])))
       for g in csv.DictReader(open(gps_csv)) if g["faulty"] == "0"] if os.path.exists(gps_csv) else []
smoothing = json.load(open(f"{out}/full/metrics.json")).get("smoothing", {})
if os.environ["SMW_TRAJ"] != "trajectory.csv" and "gps_alignment" in smoothing:
    # The smoothed trajectory's own alignment (map = R^T (gps - t)), not the online one's.
    a = smoothing["gps_alignment"]
    c, si = math.cos(a["yaw"]), math.sin(a["yaw"])
    gps = [(t, (c * (x - a["x"]) + si * (y - a["y"]), -si * (x - a["x"]) + c * (y - a["y"])))
           for t, (x, y) in ((float(g["stamp"]), (float(g["x"]), float(g["y"])))
                             for g in csv.DictReader(open(gps_csv)) if g["faulty"] == "0")]
def antenna_at(s, p, t):
    """The laser point (the GPS antenna, as the runner takes it) interpolated linearly between the
    two scan poses around t; None outside the trajectory or across a gap of more than 1 s."""
    i = bisect.bisect_left(s, t)
    if i == len(s) or (s[i] != t and (i == 0 or s[i] - s[i - 1] > 1.0)):
        return None
    def laser(q):
        c, si = math.cos(q[2]), math.sin(q[2])
        return q[0] + c * ox - si * oy, q[1] + si * ox + c * oy
    a, b = laser(p[i]), laser(p[max(i - 1, 0)])
    w = 0.0 if s[i] == t else (s[i] - t) / (s[i] - s[i - 1])
    return a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1])
def gps_median(s, p, t0, t1):
    """(median distance to the good GPS fixes in [t0, t1], number of fixes) of trajectory s, p."""
    errs = [math.hypot(q[0] - g[0], q[1] - g[1]) for t, g in gps if t0 <= t <= t1
            for q in [antenna_at(s, p, t)] if q]
    return (statistics.median(errs) if errs else float("nan")), len(errs)
scan_of = {}
def map_fits(s):
    """(stamp, fitted base_link pose) per scan of the known-start window with a good fit."""
    scans = {}
    scan_of[s] = {}
    for a in csv.DictReader(open(f"{out}/k_{s}/associations.csv")):
        t = float(a["stamp"])
        scan_of[s][t] = int(a["scan"])
        lm = int(a["landmark_id"]) if a["landmark_id"] not in ("", None) else -1
        if a["decision"] != "paired" or lm not in saved:
            continue
        rg, b = float(a["range"]), float(a["bearing"]) + oyaw
        scans.setdefault(t, []).append(((ox + rg * math.cos(b), oy + rg * math.sin(b)), saved[lm]))
    for t in sorted(scans):
        pq = scans[t]
        if len(pq) < 3:
            continue
        n = len(pq)
        pcx, pcy = sum(p[0] for p, _ in pq) / n, sum(p[1] for p, _ in pq) / n
        qcx, qcy = sum(q[0] for _, q in pq) / n, sum(q[1] for _, q in pq) / n
        sxx = sum((p[0] - pcx) * (q[0] - qcx) + (p[1] - pcy) * (q[1] - qcy) for p, q in pq)
        sxy = sum((p[0] - pcx) * (q[1] - qcy) - (p[1] - pcy) * (q[0] - qcx) for p, q in pq)
        th = math.atan2(sxy, sxx)
        c, si = math.cos(th), math.sin(th)
        x, y = qcx - (c * pcx - si * pcy), qcy - (si * pcx + c * pcy)
        rms = math.sqrt(sum((c * p[0] - si * p[1] + x - q[0]) ** 2 + (si * p[0] + c * p[1] + y - q[1]) ** 2
                            for p, q in pq) / n)
        if rms < 0.5:
            yield t, (x, y, th)
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
        # Off the full run's pose at that time (which predates the loop closures that shaped the
        # saved map): not yet a wrong fix, see the two references below.
        r["off_full_run"] = bool(errs) and (errs[0][0] > 2.0 or errs[0][1] > 0.2)
        try:  # against the window tracked from a known start in the saved map
            ks, kp = traj(f"{out}/k_{s}/trajectory.csv")
            kerr = [math.hypot(p[0] - q[0], p[1] - q[1]) for t, p in zip(ts, tp)
                    if t >= stamp - 1e-9 for q in [at(ks, kp, t)] if q]
            r["known_fix_error_m"] = kerr[0] if kerr else float("nan")
            r["known_max_error_after_m"] = max(kerr) if kerr else float("nan")
        except OSError:
            r["known_fix_error_m"] = r["known_max_error_after_m"] = float("nan")
        # A third reference, free of any filter's prior: the pose that best fits, at one scan, the
        # known-start window's pairings with the saved map (closed-form 2D alignment), at the
        # first scan from the fix on where at least 3 pairings fit within 0.5 m RMS (the known
        # start's first scans can pair wrongly while its prior holds it near the full run's pose).
        r["map_fit_scan"], r["map_fit_error_m"] = "", float("nan")
        try:
            tp_at = dict(zip(ts, tp))
            for t, fitted in map_fits(s):
                if t >= stamp - 1e-9 and t in tp_at:
                    p = tp_at[t]
                    r["map_fit_scan"] = scan_of[s][t]
                    r["map_fit_error_m"] = math.hypot(p[0] - fitted[0], p[1] - fitted[1])
                    break
        except OSError:
            pass
        # GPS, the same transform for both: the window and the full run at the same fixes.
        end = ts[-1]
        r["gps_fix_error_m"], r["gps_fixes"] = gps_median(ts, tp, stamp, stamp + gps_seconds)
        r["gps_full_error_m"], n_full = gps_median(fs, fp, stamp, stamp + gps_seconds)
        if n_full != r["gps_fixes"]:  # the full run covers every stamp of the window
            r["gps_full_error_m"] = float("nan")
        r["gps_rest_error_m"], r["gps_rest_fixes"] = gps_median(ts, tp, stamp, end)
        r["gps_full_rest_error_m"], _ = gps_median(fs, fp, stamp, end)
    rows.append(r)
with open(f"{out}/windows.csv", "w") as f:
    keys = ["start", "scans", "fixed", "fix_scan", "fix_after_s", "fix_error_m", "max_error_after_m", "off_full_run",
            "known_fix_error_m", "known_max_error_after_m", "map_fit_scan", "map_fit_error_m", "gps_fixes",
            "gps_fix_error_m", "gps_full_error_m", "gps_rest_fixes", "gps_rest_error_m", "gps_full_rest_error_m"]
    w = csv.DictWriter(f, keys, extrasaction="ignore"); w.writeheader(); w.writerows(rows)
print("| window start [s] | scans | fixed at scan | after [s] | error at fix [m] | max error after [m] "
      "| known start: at fix [m] | known start: max after [m] | map fit: scan | map fit: error [m] "
      f"| GPS fixes in {gps_seconds:g} s | GPS: fix [m] | GPS: full run [m] | GPS, rest of window: fix [m] "
      "| GPS, rest of window: full run [m] |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for r in rows:
    if r.get("fixed"):
        print(f"| {r['start']} | {r['scans']} | {r['fix_scan']} | {r['fix_after_s']:.1f} | {r['fix_error_m']:.2f} "
              f"| {r['max_error_after_m']:.2f} | {r['known_fix_error_m']:.2f} | {r['known_max_error_after_m']:.2f} "
              f"| {r['map_fit_scan']} | {r['map_fit_error_m']:.2f} | {r['gps_fixes']} | {r['gps_fix_error_m']:.2f} "
              f"| {r['gps_full_error_m']:.2f} | {r['gps_rest_error_m']:.2f} | {r['gps_full_rest_error_m']:.2f} |")
    else:
        print(f"| {r['start']} | {r.get('scans', '-')} | never |" + " - |" * 12)
n = len(rows)
fixed = [r for r in rows if r.get("fixed")]
good = sum(1 for r in fixed if not r["off_full_run"] and r["fix_scan"] <= 10)
within10 = sum(1 for r in fixed if r["fix_scan"] <= 10)
within2 = sum(1 for r in fixed if r["fix_error_m"] <= 2.0)
known2 = sum(1 for r in fixed if r["known_fix_error_m"] <= 2.0)
fit2 = sum(1 for r in fixed if r["map_fit_error_m"] <= 2.0)
# A wrong fix: more than 2 m from every reference (the full run, the known-start window, the fit).
wrong = sum(1 for r in fixed if r["off_full_run"] and not r["known_fix_error_m"] <= 2.0
            and not r["map_fit_error_m"] <= 2.0)
print(f"\n{n} windows, {len(fixed)} fixed, {within10} within 10 scans; at the fix within 2 m of the "
      f"full run {within2}, of the known-start window {known2}, of the map fit {fit2}; "
      f"{wrong} wrong fixes (more than 2 m from all three); "
      f"{good} within 2 m and 0.2 rad of the full run after at most 10 scans ({100.0 * good / max(n, 1):.0f} %)")
# NaN compares false: a window without GPS fixes counts in neither.
with_gps = [r for r in fixed if r["gps_fix_error_m"] == r["gps_fix_error_m"]
            and r["gps_full_error_m"] == r["gps_full_error_m"]]
closer = sum(1 for r in with_gps if r["gps_fix_error_m"] < r["gps_full_error_m"])
gps2 = sum(1 for r in with_gps if r["gps_fix_error_m"] <= 2.0)
full2 = sum(1 for r in with_gps if r["gps_full_error_m"] <= 2.0)
rest = [r for r in fixed if r["gps_rest_error_m"] == r["gps_rest_error_m"]]
closer_rest = sum(1 for r in rest if r["gps_rest_error_m"] < r["gps_full_rest_error_m"])
print(f"GPS (median over the good fixes in the {gps_seconds:g} s after the fix, {len(with_gps)} windows with "
      f"fixes): the fix closer to GPS than the full run in {closer} of {len(with_gps)}; within 2 m of GPS: "
      f"the fix {gps2}, the full run {full2}; over the rest of the window the fix's track closer in "
      f"{closer_rest} of {len(rest)}")
if wrong:  # relocalisation must never give a confident wrong pose
    sys.exit(f"{wrong} wrong fixes")
PY
