#!/usr/bin/env python3
"""How one stretch of the map moves over a run, against GPS and against the filter's covariance.

Reads a run of `ekf_slam_offline ... --landmark-trace` (OUT/landmark_trace.csv, trajectory.csv,
associations.csv, gps.csv) and a stretch of the route [FROM, TO) s; "the stretch's landmarks" are
those paired in it. Prints (docs/notes/2026-11-to-12-relocalisation-record.md, "With the smoothed map and trajectory"):

1. The map of the stretch against GPS over time. For each evaluation time T and each scan s of
   the stretch with a good GPS fix (the runner's gps.csv: moved into the map frame, `faulty` 0)
   within 0.11 s and at least 2 pairings: the sensor point of the online pose, moved by the mean
   change of its paired landmarks from scan s to T (so where the map at T puts the sensor), minus
   the GPS fix. Median distance and mean vector over the stretch; at T = the last scan this is the
   saved map, at T = the stretch itself the online pose.
2. A consistency test that needs no reference. For a landmark (no process noise), the estimate's
   change between t1 and t2 has covariance P(t1) - P(t2) in a consistent Kalman filter (the sum
   of the updates' K S K^T). Per landmark of the stretch: the change, sqrt of the largest
   eigenvalue of P(t1) - P(t2), and NEES = d^T (P(t1) - P(t2))^-1 d (chi2(2): 99 % 9.21).
3. The serial correlation of the measurement errors the filter takes as white: post-update
   residuals z - h(pose, landmark) of every pairing of the run (pose from trajectory.csv,
   landmark from the trace at that scan), correlated with the same landmark's residual k scans
   later.

    scripts/map_drift.py OUT --from 1300 --to 1380 [--times 1350,1436,1496] [--sensor 3.78,0.5]
"""
import argparse
import collections
import csv
import math
import sys

import numpy as np


def load(out):
    t = np.loadtxt(f"{out}/landmark_trace.csv", delimiter=",", skiprows=1)
    traj = np.loadtxt(f"{out}/trajectory.csv", delimiter=",", skiprows=1, usecols=(0, 1, 2, 3))
    gps = np.loadtxt(f"{out}/gps.csv", delimiter=",", skiprows=1, usecols=(0, 3, 4, 5), ndmin=2)
    pairs = []  # scan, stamp, landmark, range, bearing
    with open(f"{out}/associations.csv") as f:
        for r in csv.DictReader(f):
            if r["decision"] == "paired":
                pairs.append((int(r["scan"]), float(r["stamp"]), int(r["landmark_id"]),
                              float(r["range"]), float(r["bearing"])))
    return t, traj, gps, pairs


def sensor_point(pose, offset):
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([pose[0] + c * offset[0] - s * offset[1], pose[1] + s * offset[0] + c * offset[1]])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out")
    ap.add_argument("--from", dest="t0", type=float, required=True, help="stretch start [s]")
    ap.add_argument("--to", dest="t1", type=float, required=True, help="stretch end [s]")
    ap.add_argument("--times", default="", help="evaluation times [s], comma separated "
                    "(default: 8 evenly from the stretch's end to the last scan)")
    ap.add_argument("--sensor", default="3.78,0.5",
                    help="sensor position on the vehicle x,y [m] (Victoria Park's laser)")
    a = ap.parse_args()
    offset = [float(v) for v in a.sensor.split(",")]
    trace, traj, gps, pairs = load(a.out)

    scan_of_row = trace[:, 0].astype(np.int64)
    # (scan, id) -> row of the trace
    key = {(int(s), int(i)): k for k, (s, i) in enumerate(zip(scan_of_row, trace[:, 2]))}
    scan_stamp = dict(zip(scan_of_row.tolist(), trace[:, 1].tolist()))
    scans = np.array(sorted(scan_stamp))
    stamps = np.array([scan_stamp[s] for s in scans])
    last = int(scans[-1])
    # trajectory.csv has one row per scan, in scan order
    pose_of_scan = {i: traj[i, 1:4] for i in range(len(traj))}

    by_scan = collections.defaultdict(list)
    for s, st, lid, rg, br in pairs:
        by_scan[s].append((lid, rg, br))
    stretch = set(lid for s, st, lid, rg, br in pairs if a.t0 <= st < a.t1)

    def scan_at(t):
        i = np.searchsorted(stamps, t, side="right") - 1
        return int(scans[max(i, 0)])

    if a.times:
        times = [float(v) for v in a.times.split(",")]
    else:
        times = list(np.linspace(a.t1, stamps[-1], 8))
    eval_scans = sorted(set([scan_at(a.t1)] + [scan_at(t) for t in times] + [last]))

    # 1. against GPS
    items = []
    for s, plist in by_scan.items():
        st = scan_stamp.get(s)
        if st is None or not (a.t0 <= st < a.t1) or s >= len(traj):
            continue
        k = np.searchsorted(gps[:, 0], st)
        best = None
        for j in (k - 1, k):
            if 0 <= j < len(gps) and abs(gps[j, 0] - st) <= 0.11 and gps[j, 3] == 0:
                best = j
        ids = [lid for lid, _, _ in plist if (s, lid) in key]
        if best is None or len(ids) < 2:
            continue
        items.append((s, sensor_point(pose_of_scan[s], offset), gps[best, 1:3], ids))
    print(f"stretch {a.t0:.0f}-{a.t1:.0f} s: {len(stretch)} landmarks paired in it, "
          f"{len(items)} scans with a GPS fix and >= 2 pairings")
    if items:
        e = [np.linalg.norm(p - g) for _, p, g, _ in items]
        print(f"  online pose against GPS: median {np.median(e):.2f} m")
        print("  1. the stretch's map at T against GPS (where it puts the sensor):")
        for T in eval_scans:
            err = []
            for s, p, g, ids in items:
                if s > T:
                    continue
                c = [i for i in ids if (T, i) in key]
                if len(c) < 2:
                    continue
                d = np.mean([trace[key[(T, i)], 3:5] - trace[key[(s, i)], 3:5] for i in c], axis=0)
                err.append(p + d - g)
            if err:
                err = np.array(err)
                print(f"     T {scan_stamp[T]:7.1f} s (scan {T}): median {np.median(np.hypot(*err.T)):.2f} m,"
                      f" mean vector ({err[:, 0].mean():+.2f}, {err[:, 1].mean():+.2f}) m, {len(err)} scans")

    # 2. change against P(t1) - P(t2)
    print("  2. the stretch's landmarks from t1 to t2: median change, median sqrt(largest eig of "
          "P(t1) - P(t2)), median NEES (chi2(2) 99 %: 9.21), share of NEES > 9.21:")
    spans = list(zip(eval_scans[:-1], eval_scans[1:])) + [(eval_scans[0], last)]
    for s1, s2 in spans:
        rows = []
        for i in stretch:
            if (s1, i) not in key or (s2, i) not in key:
                continue
            r1, r2 = trace[key[(s1, i)]], trace[key[(s2, i)]]
            P1 = np.array([[r1[5], r1[6]], [r1[6], r1[7]]])
            P2 = np.array([[r2[5], r2[6]], [r2[6], r2[7]]])
            d, C = r2[3:5] - r1[3:5], P1 - P2
            w = np.linalg.eigvalsh(C)
            nees = float(d @ np.linalg.solve(C, d)) if w.min() > 1e-9 else math.inf
            rows.append((np.linalg.norm(d), math.sqrt(max(w.max(), 0.0)), nees))
        if rows:
            r = np.array(rows)
            print(f"     {scan_stamp[s1]:7.1f} -> {scan_stamp[s2]:7.1f} s: {len(r)} landmarks, change "
                  f"{np.median(r[:, 0]):.2f} m, allowed sd {np.median(r[:, 1]):.2f} m, NEES "
                  f"{np.median(r[:, 2]):.1f}, {np.mean(r[:, 2] > 9.21):.0%} > 9.21")

    # 3. residual autocorrelation over the run
    res = collections.defaultdict(dict)  # landmark -> scan -> (range, bearing) residual
    for s, plist in by_scan.items():
        if s >= len(traj):
            continue
        sp = sensor_point(pose_of_scan[s], offset)
        yaw = pose_of_scan[s][2]
        for lid, rg, br in plist:
            k = key.get((s, lid))
            if k is None:
                continue
            dx, dy = trace[k, 3] - sp[0], trace[k, 4] - sp[1]
            vb = (br - (math.atan2(dy, dx) - yaw) + math.pi) % (2 * math.pi) - math.pi
            res[lid][s] = (rg - math.hypot(dx, dy), vb)
    allr = np.array([v for d in res.values() for v in d.values()])
    print(f"  3. post-update residuals of the run's {len(allr)} pairings: rms range "
          f"{math.sqrt(np.mean(allr[:, 0] ** 2)):.3f} m, bearing {math.sqrt(np.mean(allr[:, 1] ** 2)):.4f} rad;"
          " correlation with the same landmark's k scans later:")
    for lag in (1, 2, 5, 10, 20, 50):
        x, y = [], []
        for d in res.values():
            for s, v in d.items():
                w = d.get(s + lag)
                if w is not None:
                    x.append(v)
                    y.append(w)
        if len(x) > 10:
            x, y = np.array(x), np.array(y)
            print(f"     k = {lag:2d}: range {np.corrcoef(x[:, 0], y[:, 0])[0, 1]:.2f}, "
                  f"bearing {np.corrcoef(x[:, 1], y[:, 1])[0, 1]:.2f} ({len(x)} pairs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
