#!/usr/bin/env python3
"""Paired comparison of two `evaluate` outputs, seed by seed.

    scripts/compare_runs.py BEFORE AFTER [--associator DJNN] [--after-associator NAME]

BEFORE and AFTER are `evaluate --out` folders (their results.csv), or comma-separated lists of
them (e.g. the same command on --seed 1, 21 and 41), pooled. Runs are paired by world and seed,
so a change is judged on the same simulated data. Per world and metric it prints the means, the
ratio of the means, in how many seeds AFTER is lower or higher, the geometric mean of the
per-seed ratios, and the two-sided sign test's p-value over the seeds that differ.

Why: a ratio of 20-run means is driven by the one or two runs that fail (a wrong loop closure, an
over-confident filter's tail). The paired counts show whether a change moves most seeds or a few.
With --after-associator the two sides can be two associators of one folder, e.g.
`compare_runs.py OUT OUT --associator truth --after-associator truth_delayed`.

--self-test checks the arithmetic on made-up runs and exits non-zero if it is wrong.
"""
import argparse
import csv
import math
import os
import sys
import tempfile

# (column or ratio, label)
METRICS = [
    ("pose_ate_aligned_m", "ATE aligned [m]"),
    ("anees", "ANEES"),
    ("accuracy", "accuracy"),
    ("f1", "F1"),
    (("landmarks_created", "true_landmarks_seen"), "created / true seen"),
    ("sightings_used", "sightings used"),
]


def load(paths, associator):
    """{(world, seed): row} of one associator over the folders in `paths` (comma-separated)."""
    runs = {}
    for path in paths.split(","):
        name = os.path.join(path, "results.csv") if os.path.isdir(path) else path
        with open(name, newline="") as f:
            for row in csv.DictReader(f):
                if row["associator"] == associator:
                    runs[(row["world"], int(row["seed"]))] = row
    return runs


def value(row, metric):
    try:
        if isinstance(metric, tuple):
            den = float(row[metric[1]])
            return float(row[metric[0]]) / den if den > 0 else math.nan
        return float(row[metric])
    except (KeyError, ValueError):
        return math.nan


def sign_test(lower, higher):
    """Two-sided p-value of `lower` against `higher` under a fair coin (ties left out)."""
    n = lower + higher
    if n == 0:
        return 1.0
    k = min(lower, higher)
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2.0**n
    return min(1.0, 2.0 * tail)


def compare(before, after):
    """Rows of (world, label, n, mean before, mean after, lower, higher, geo ratio, p)."""
    out = []
    for world in sorted({w for w, _ in before} & {w for w, _ in after}):
        seeds = sorted(s for w, s in before if w == world and (w, s) in after)
        for metric, label in METRICS:
            pairs = [(value(before[(world, s)], metric), value(after[(world, s)], metric)) for s in seeds]
            pairs = [(a, b) for a, b in pairs if math.isfinite(a) and math.isfinite(b)]
            if not pairs:
                continue
            lower = sum(1 for a, b in pairs if b < a)
            higher = sum(1 for a, b in pairs if b > a)
            logs = [math.log(b / a) for a, b in pairs if a > 0 and b > 0]
            geo = math.exp(sum(logs) / len(logs)) if logs else math.nan
            mean_a = sum(a for a, _ in pairs) / len(pairs)
            mean_b = sum(b for _, b in pairs) / len(pairs)
            out.append((world, label, len(pairs), mean_a, mean_b, lower, higher, geo,
                        sign_test(lower, higher)))
    return out


def fmt(x):
    return "n/a" if not math.isfinite(x) else (f"{x:.4f}" if abs(x) < 10 else f"{x:.1f}")


def report(rows, title):
    print(f"# {title}\n")
    print("| world | metric | seeds | before | after | after / before | after lower / higher "
          "| geometric mean of ratios | sign test p |")
    print("|---|---|---|---|---|---|---|---|---|")
    for world, label, n, a, b, lower, higher, geo, p in rows:
        ratio = b / a if a != 0 else math.nan
        print(f"| {world} | {label} | {n} | {fmt(a)} | {fmt(b)} | {fmt(ratio)} | {lower} / {higher} "
              f"| {fmt(geo)} | {p:.3f} |")


def self_test():
    header = ("world,associator,seed,pose_ate_aligned_m,anees,accuracy,f1,landmarks_created,"
              "true_landmarks_seen,sightings_used\n")
    with tempfile.TemporaryDirectory() as d:
        a, b = os.path.join(d, "a"), os.path.join(d, "b")
        os.makedirs(a)
        os.makedirs(b)
        with open(os.path.join(a, "results.csv"), "w") as f:
            f.write(header)
            for s in range(1, 11):
                f.write(f"w,DJNN,{s},1.0,2.0,0.9,0.9,10,10,0.9\n")
        with open(os.path.join(b, "results.csv"), "w") as f:
            f.write(header)
            # Nine seeds a little better, one far worse: the mean says worse, the seeds better.
            for s in range(1, 10):
                f.write(f"w,DJNN,{s},0.9,2.0,0.9,0.9,11,10,0.95\n")
            f.write("w,DJNN,10,3.0,2.0,0.9,0.9,10,10,0.95\n")
            f.write("w,DJNN,11,5.0,2.0,0.9,0.9,10,10,0.95\n")  # no pair: left out
        rows = {r[1]: r for r in compare(load(a, "DJNN"), load(b, "DJNN"))}
    ate = rows["ATE aligned [m]"]
    checks = [
        (ate[2] == 10, "seeds paired"),
        (abs(ate[4] - 1.11) < 1e-9, "mean after"),
        ((ate[5], ate[6]) == (9, 1), "lower / higher"),
        (abs(ate[7] - math.exp((9 * math.log(0.9) + math.log(3.0)) / 10)) < 1e-12, "geometric mean"),
        (abs(ate[8] - 22 / 1024) < 1e-12, "sign test"),
        (rows["ANEES"][5:7] == (0, 0) and rows["ANEES"][8] == 1.0, "ties"),
        (abs(rows["created / true seen"][4] - 1.09) < 1e-9, "ratio metric"),
    ]
    failed = [name for ok, name in checks if not ok]
    for name in failed:
        print(f"compare_runs self-test: {name} wrong", file=sys.stderr)
    print("compare_runs self-test: " + ("FAILED" if failed else "passed"))
    return 1 if failed else 0


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("before", nargs="?", help="evaluate --out folder(s), comma-separated")
    p.add_argument("after", nargs="?", help="evaluate --out folder(s), comma-separated")
    p.add_argument("--associator", default="DJNN", help="the associator compared (default DJNN)")
    p.add_argument("--after-associator", help="the one on the AFTER side, if another")
    p.add_argument("--self-test", action="store_true", help="check the arithmetic and exit")
    args = p.parse_args()
    if args.self_test:
        return self_test()
    if not args.before or not args.after:
        p.error("BEFORE and AFTER are needed")
    after_name = args.after_associator or args.associator
    before = load(args.before, args.associator)
    after = load(args.after, after_name)
    rows = compare(before, after)
    if not rows:
        print(f"no world and seed of {args.associator} in both", file=sys.stderr)
        return 1
    report(rows, f"{args.associator} ({args.before}) against {after_name} ({args.after})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
