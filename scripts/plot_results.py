#!/usr/bin/python3
"""Draws the curves of scripts/reproduce_papers.sh from evaluate's output folders.

    /usr/bin/python3 scripts/plot_results.py OUT [--images DIR]

OUT holds rrw_noise/, rrw_kidnap/, rrw_occlusion/ (accuracy against K, mean with the 10-90 %
spread of the runs; seed 004's three experiments), aekf/ (Monte Carlo average NEES of the pose
per scan with its 95 % band; seed 001 paper 5) and aekf_ekf/ + aekf_aekf/ (the paper's figures 3
and 4: pose RMSE and average NEES over time, plain EKF against AEKF on the same seeds). Folders
that are missing are skipped. PNGs go to OUT (or --images DIR). Exit status 3 when matplotlib is
missing.
"""
import argparse
import csv
import os
import sys
from collections import defaultdict

EXPERIMENTS = [
    ("rrw_noise", "rrw_noise_", "noise multiplier K", "seed 004: noise x K"),
    ("rrw_kidnap", "rrw_kidnap_", "kidnapping distance [m] (4.6 K)", "seed 004: kidnapping"),
    ("rrw_occlusion", "rrw_occlusion_", "occluded landmarks K", "seed 004: dynamic occlusion"),
]


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def quantile(values, q):
    v = sorted(values)
    return v[min(len(v) - 1, int(q * (len(v) - 1) + 0.5))]


def finish(plt, fig, axes, images, name, legend_size=9):
    """Grid and legend on every axis, then the PNG images/name.png; returns its path."""
    for ax in axes:
        ax.grid(True, linewidth=0.3, alpha=0.5)
        ax.legend(fontsize=legend_size)
    fig.tight_layout()
    png = os.path.join(images, f"{name}.png")
    fig.savefig(png, dpi=100)
    plt.close(fig)
    return png


def plot_sweep(plt, out_dir, name, prefix, xlabel, title, images):
    path = os.path.join(out_dir, name, "results.csv")
    if not os.path.exists(path):
        return None
    runs = defaultdict(list)  # (associator, K) -> accuracies
    for r in read_rows(path):
        k = int(r["world"][len(prefix):])
        runs[(r["associator"], k)].append(float(r["accuracy"]))
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for assoc in sorted({a for a, _ in runs}):
        ks = sorted(k for a, k in runs if a == assoc)
        xs = [4.6 * k if name == "rrw_kidnap" else k for k in ks]
        mean = [sum(runs[(assoc, k)]) / len(runs[(assoc, k)]) for k in ks]
        lo = [quantile(runs[(assoc, k)], 0.1) for k in ks]
        hi = [quantile(runs[(assoc, k)], 0.9) for k in ks]
        line, = ax.plot(xs, mean, "o-", markersize=4, label=assoc)
        ax.fill_between(xs, lo, hi, color=line.get_color(), alpha=0.15, linewidth=0)
    n = len(next(iter(runs.values())))
    ax.set_title(f"{title} ({n} runs per point)", fontsize=10)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("association accuracy (mean, 10-90 % band)")
    ax.set_ylim(0.0, 1.02)
    return finish(plt, fig, [ax], images, name)


def plot_nees(plt, out_dir, images):
    path = os.path.join(out_dir, "aekf", "nees.csv")
    if not os.path.exists(path):
        return None
    series = defaultdict(list)
    for r in read_rows(path):
        series[r["associator"]].append(
            (int(r["scan"]), float(r["anees"]), float(r["band_lower"]), float(r["band_upper"])))
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    band = None
    for assoc, rows in sorted(series.items()):
        rows.sort()
        ax.semilogy([r[0] for r in rows], [r[1] for r in rows], "-", linewidth=0.8,
                    label=f"EKF + {assoc}")
        band = rows
    if band:
        ax.fill_between([r[0] for r in band], [r[2] for r in band], [r[3] for r in band],
                        color="gray", alpha=0.25, linewidth=0, label="95 % band")
    ax.set_title("seed 001 paper 5 world: average NEES of the pose", fontsize=10)
    ax.set_xlabel("observation set (0.2 s)")
    ax.set_ylabel("ANEES (log)")
    return finish(plt, fig, [ax], images, "aekf_nees")


def plot_aekf(plt, out_dir, images, period=0.2):
    """Plain EKF vs AEKF: position RMSE, heading RMSE and ANEES (with its band) over time."""
    runs = {}  # "EKF, NN" -> rows sorted by time
    for label, folder in (("EKF", "aekf_ekf"), ("AEKF", "aekf_aekf")):
        path = os.path.join(out_dir, folder, "nees.csv")
        if not os.path.exists(path):
            continue
        for r in read_rows(path):
            runs.setdefault(f"{label}, {r['associator']}", []).append(
                (int(r["scan"]) * period, float(r["anees"]), float(r["band_lower"]),
                 float(r["band_upper"]), float(r["position_rmse_m"]),
                 float(r["heading_rmse_rad"]), int(r["runs"])))
    if not runs:
        return None
    fig, axes = plt.subplots(3, 1, figsize=(6.4, 8.4), sharex=True)
    for label, rows in sorted(runs.items()):
        rows.sort()
        t = [r[0] for r in rows]
        style = "-" if label.startswith("AEKF") else "--"
        axes[0].semilogy(t, [r[4] for r in rows], style, linewidth=0.8, label=label)
        axes[1].semilogy(t, [r[5] for r in rows], style, linewidth=0.8, label=label)
        axes[2].semilogy(t, [r[1] for r in rows], style, linewidth=0.8, label=label)
    band = sorted(next(iter(runs.values())))
    axes[2].fill_between([r[0] for r in band], [r[2] for r in band], [r[3] for r in band],
                         color="gray", alpha=0.3, linewidth=0,
                         label=f"95 % band, {band[0][6]} runs, 3 dof")
    axes[1].axhline(0.03, color="k", linewidth=0.5, linestyle=":")  # the paper's 0.03 rad
    axes[0].set_ylabel("position RMSE [m] (log)")
    axes[1].set_ylabel("heading RMSE [rad] (log)")
    axes[2].set_ylabel("average NEES (log)")
    axes[2].set_xlabel("time [s]")
    axes[0].set_title(f"seed 001 paper 5 world: EKF vs AEKF ({band[0][6]} Monte Carlo runs)",
                      fontsize=10)
    return finish(plt, fig, axes, images, "aekf_vs_ekf", legend_size=7)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="folder of scripts/reproduce_papers.sh")
    parser.add_argument("--images", help="where the PNGs go (default OUT)")
    args = parser.parse_args()
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("plot_results.py: matplotlib is missing (apt-get install python3-matplotlib)",
              file=sys.stderr)
        return 3
    images = args.images or args.out
    os.makedirs(images, exist_ok=True)
    for name, prefix, xlabel, title in EXPERIMENTS:
        png = plot_sweep(plt, args.out, name, prefix, xlabel, title, images)
        if png:
            print(png)
    for png in (plot_nees(plt, args.out, images), plot_aekf(plt, args.out, images)):
        if png:
            print(png)
    return 0


if __name__ == "__main__":
    sys.exit(main())
