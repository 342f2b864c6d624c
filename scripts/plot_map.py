#!/usr/bin/python3
"""Draws the map of an offline run (ekf_slam_offline --out DIR) into DIR/map.png.

    /usr/bin/python3 scripts/plot_map.py DIR [--out FILE.png] [--title TEXT]

Reads DIR/trajectory.csv, DIR/landmarks.csv, DIR/gps.csv (optional; the x_map, y_map columns are
the fixes moved into the map frame by the best rigid alignment), DIR/ground_truth.csv and
DIR/true_landmarks.csv (optional, simulated bags) and DIR/metrics.json (optional, for the
title). Axes in metres, equal aspect. Exit status 3 when matplotlib is missing.
"""
import argparse
import csv
import json
import math
import os
import sys


def read_csv(path):
    if not os.path.exists(path):
        return None
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def column(rows, name):
    return [float(r[name]) for r in rows]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dir", help="output folder of ekf_slam_offline")
    parser.add_argument("--out", help="picture to write (default DIR/map.png)")
    parser.add_argument("--title", help="title (default: from metrics.json)")
    parser.add_argument("--dpi", type=int, default=110)
    args = parser.parse_args()

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.collections import EllipseCollection
    except ImportError:
        print("plot_map.py: matplotlib is missing (apt-get install python3-matplotlib)",
              file=sys.stderr)
        return 3

    traj = read_csv(os.path.join(args.dir, "trajectory.csv"))
    lms = read_csv(os.path.join(args.dir, "landmarks.csv"))
    if traj is None or lms is None:
        print(f"plot_map.py: {args.dir} lacks trajectory.csv or landmarks.csv", file=sys.stderr)
        return 1
    gps = read_csv(os.path.join(args.dir, "gps.csv"))
    truth_path = read_csv(os.path.join(args.dir, "ground_truth.csv"))
    truth_map = read_csv(os.path.join(args.dir, "true_landmarks.csv"))
    metrics = {}
    metrics_path = os.path.join(args.dir, "metrics.json")
    if os.path.exists(metrics_path):
        with open(metrics_path) as f:
            metrics = json.load(f)

    fig, ax = plt.subplots(figsize=(10, 8))
    if gps and "x_map" in gps[0]:
        used = [r for r in gps if r["x_map"] not in ("", "nan")]
        ax.plot(column(used, "x_map"), column(used, "y_map"), ".", color="tab:orange",
                markersize=2.5, alpha=0.6, label=f"GPS fixes, aligned ({len(used)})", zorder=1)
    if truth_path:
        ax.plot(column(truth_path, "x"), column(truth_path, "y"), ":", color="black",
                linewidth=0.8, label="true path", zorder=1)
    if truth_map:
        ax.plot(column(truth_map, "x"), column(truth_map, "y"), "o", markerfacecolor="none",
                color="gray", markersize=5, markeredgewidth=0.6,
                label=f"true landmarks ({len(truth_map)})", zorder=1)
    ax.plot(column(traj, "x"), column(traj, "y"), "-", color="tab:blue", linewidth=0.8,
            label=f"vehicle (base_link), {len(traj)} scans", zorder=2)
    if lms:
        x, y = column(lms, "x"), column(lms, "y")
        # 3-sigma ellipses of the landmark covariances (metres, drawn in data units).
        widths, heights, angles = [], [], []
        for r in lms:
            a, b, c = float(r["var_x"]), float(r["cov_xy"]), float(r["var_y"])
            tr, det = a + c, a * c - b * b
            disc = math.sqrt(max(tr * tr / 4 - det, 0.0))
            l1, l2 = tr / 2 + disc, max(tr / 2 - disc, 0.0)
            widths.append(2 * 3 * math.sqrt(max(l1, 0.0)))
            heights.append(2 * 3 * math.sqrt(l2))
            angles.append(math.degrees(0.5 * math.atan2(2 * b, a - c)))
        ax.add_collection(EllipseCollection(widths, heights, angles, units="xy",
                                            offsets=list(zip(x, y)), transOffset=ax.transData,
                                            facecolors="none", edgecolors="tab:green",
                                            linewidths=0.5, alpha=0.7, zorder=3))
        ax.plot(x, y, "+", color="darkgreen", markersize=4, markeredgewidth=0.8,
                label=f"landmarks ({len(lms)}), 3-sigma ellipses", zorder=4)
    if traj:
        ax.plot([float(traj[0]["x"])], [float(traj[0]["y"])], "k^", markersize=7, label="start",
                zorder=5)

    if args.title:
        title = args.title
    else:
        assoc = metrics.get("associator", "?")
        parts = [f"{metrics.get('scans', len(traj))} scans", f"{len(lms)} landmarks"]
        if metrics.get("gps_rmse_m") is not None:
            parts.append(f"GPS RMSE {metrics['gps_rmse_m']:.2f} m (aligned, "
                         f"{metrics.get('gps_points', '?')} fixes)")
        truth = metrics.get("truth")
        if truth:
            parts.append(f"accuracy {truth['accuracy']:.3f}, {truth['spurious_landmarks']} spurious")
            if truth.get("pose_rmse_m") is not None:
                parts.append(f"pose RMSE {truth['pose_rmse_m']:.2f} m")
        if metrics.get("wall_time_s") is not None:
            parts.append(f"{metrics['wall_time_s']:.2f} s")
        title = f"EKF-SLAM, {assoc}: " + ", ".join(parts)
    ax.set_title(title, fontsize=11)
    ax.set_xlabel("x [m] (map frame)")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, linewidth=0.3, alpha=0.5)
    ax.legend(loc="best", fontsize=9, markerscale=2)
    fig.tight_layout()
    out = args.out or os.path.join(args.dir, "map.png")
    fig.savefig(out, dpi=args.dpi)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
