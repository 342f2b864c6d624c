#!/usr/bin/env bash
# calibrate_noise against the known answer (docs/calibration.md): each simulated world is written
# with `simulate --true-noise` (observations without covariance, the simulator's own noise in the
# YAML), then calibrated from a file whose odometry sigmas are ODOMETRY times and observation
# sigmas OBSERVATION times the simulator's; prints the calibrated values over the true ones.
#   scripts/calibration_worlds.sh [ODOMETRY OBSERVATION [WORLD:SEED ...]]
# Default: 2 0.5 djnn_weak:1 djnn_strong:1 arena:1 fiducials:1 rrw_noise_1:1 (after
# scripts/build.sh; about a minute of CPU per world on 2 cores).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
source "$EKF_SLAM_DEVEL/setup.bash"
odometry=${1:-2}
observation=${2:-0.5}
shift 2 2> /dev/null || true
worlds=("$@")
[[ ${#worlds[@]} -gt 0 ]] || worlds=(djnn_weak:1 djnn_strong:1 arena:1 fiducials:1 rrw_noise_1:1)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-14s %4s  %s\n' world seed "calibrated / true (file started at x$odometry odometry, x$observation observations)"
for ws in "${worlds[@]}"; do
  world=${ws%%:*} seed=${ws##*:}
  rosrun ekf_slam simulate --world "$world" --seed "$seed" --true-noise --no-markers \
    --out "$tmp/$world.bag" > /dev/null
  # The deliberately wrong values: the true ones scaled (odometry keys only where the world's
  # odometry noise is known exactly, i.e. twist worlds).
  sets=$(python3 - "$tmp/$world.yaml" "$odometry" "$observation" << 'EOF'
import sys, yaml
p = yaml.safe_load(open(sys.argv[1]))
odo, obs = float(sys.argv[2]), float(sys.argv[3])
keys = {"sigma_range": obs, "sigma_bearing": obs}
if p.get("twist_steering_wheelbase", 0) > 0:
    keys.update({"twist_sigma_v": odo, "twist_sigma_w_per_v": odo})
print(" ".join("--set %s=%.17g" % (k, f * float(p[k])) for k, f in keys.items()))
EOF
)
  # shellcheck disable=SC2086
  nice rosrun ekf_slam calibrate_noise --bag "$tmp/$world.bag" --params "$tmp/$world.yaml" \
    --out "$tmp/$world" --no-progress $sets > "$tmp/$world.log" 2>&1 \
    || { cat "$tmp/$world.log"; exit 1; }
  python3 - "$tmp/$world.yaml" "$tmp/$world/calibration.json" "$world" "$seed" << 'EOF'
import sys, json, yaml
truth = yaml.safe_load(open(sys.argv[1]))
c = json.load(open(sys.argv[2]))
after = c["runs"][-1]["values"]
first, last = c["runs"][0], c["runs"][-1]
keys = ["sigma_range", "sigma_bearing"]
if truth.get("twist_steering_wheelbase", 0) > 0:
    keys = ["twist_sigma_v", "twist_sigma_w_per_v"] + keys
term = {"twist_sigma_v": "odometry translation", "twist_sigma_w_per_v": "odometry rotation",
        "sigma_range": "range", "sigma_bearing": "bearing"}
cells = ["%s %.3f%s" % (k, after[k] / float(truth[k]),
                        "" if term[k] in c.get("factors", {}) else " (undetermined)") for k in keys]
print("%-14s %4s  %s; NIS/dof %.2f -> %.2f, in band %.2f -> %.2f; %s, %d runs" % (
    sys.argv[3], sys.argv[4], ", ".join(cells), first["nis_mean_per_dof"],
    last["nis_mean_per_dof"], first["nis_share_in_95_band"], last["nis_share_in_95_band"],
    "converged" if c["converged"] else "NOT converged", len(c["runs"]) - 1))
EOF
done
