#!/usr/bin/env bash
# The main demo: from a fresh Debian 12 machine, installs the dependencies, builds only what it
# runs (not the tests: scripts/test.sh builds those), converts the Victoria Park data ($VP_DATA, see
# scripts/env.sh; fetched by scripts/get_data.sh when it is missing) into a bag under build/, runs
# the offline runner with DJNN and prints the metrics and where the map picture is. Without the
# data (no network) it runs the simulated djnn_strong world instead (simulate, run, score against
# the truth).
#   scripts/demo.sh [ASSOCIATOR]      (default DJNN)
# Env: DEMO=simulation forces the simulated world; WORLD (djnn_strong), SEED (1).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
ASSOCIATOR=${1:-DJNN}

mode=${DEMO:-victoria_park}
if [[ $mode == victoria_park && ! -f "$VP_DATA/aa3_dr.mat" ]]; then
  echo "demo.sh: the Victoria Park data set is not in $VP_DATA; fetching it (scripts/get_data.sh)" >&2
  if ! "$EKF_SLAM_ROOT/scripts/get_data.sh"; then
    cat >&2 <<MSG
demo.sh: no Victoria Park data set (see above, and the README, "Data"). Running the simulated
  world ${WORLD:-djnn_strong} instead (set VP_DATA to a folder with the data set to use it).
MSG
    mode=simulation
  fi
fi

# Only what the demo runs: the offline runner and the converter (data set) or the simulator
# (simulated world), with the libraries they link and the plugins they load (dependencies of
# ekf_slam_ros). With Makefiles the targets are built one after the other, so the one with most
# dependencies goes first: its libraries compile two at a time.
if [[ $mode == simulation ]]; then
  targets="simulate ekf_slam_offline"
else
  targets="ekf_slam_offline victoria_park_to_bag"
fi
EKF_SLAM_TARGETS=$targets "$EKF_SLAM_ROOT/scripts/build.sh"
source "$EKF_SLAM_DEVEL/setup.bash"

if [[ $mode == simulation ]]; then
  world=${WORLD:-djnn_strong}
  seed=${SEED:-1}
  bag="$EKF_SLAM_BUILD/sim_${world}_${seed}.bag"
  rosrun ekf_slam simulate --world "$world" --seed "$seed" --out "$bag"
  params="${bag%.bag}.yaml"
  out="$EKF_SLAM_BUILD/sim_${world}_${seed}_$ASSOCIATOR"
else
  bag="$EKF_SLAM_BUILD/vp.bag"
  if [[ ! -f "$bag" || "$VP_DATA/aa3_dr.mat" -nt "$bag" ]]; then
    rosrun ekf_slam victoria_park_to_bag --data "$VP_DATA" --out "$bag"
  fi
  params="$EKF_SLAM_ROOT/config/victoria_park.yaml"
  out="$EKF_SLAM_BUILD/vp_$ASSOCIATOR"
fi
rosrun ekf_slam ekf_slam_offline --bag "$bag" --params "$params" --associator "$ASSOCIATOR" \
  --out "$out" > /dev/null

/usr/bin/python3 - "$out/metrics.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
print()
print(f"associator        {m['associator']}")
print(f"scans             {m['scans']}  ({m['odometry_messages']} odometry messages)")
print(f"landmarks         {m['landmarks']}")
if m.get("gps_rmse_m") is not None:
    print(f"GPS RMSE          {m['gps_rmse_m']:.2f} m after alignment ({m['gps_points']} fixes; "
          f"median error {m['gps_median_error_m']:.2f} m)")
t = m.get("truth")
if t:
    print(f"accuracy          {t['accuracy']:.4f}  (precision {t['precision']:.4f}, "
          f"recall {t['recall']:.4f}, F1 {t['f1']:.4f}; TP {t['tp']} FP {t['fp']} "
          f"FN {t['fn']} TN {t['tn']})")
    print(f"final map         {t['landmarks']} landmarks: {t['true_landmarks_mapped']} of "
          f"{t['true_landmarks_seen']} true landmarks seen, {t['spurious_landmarks']} spurious")
    print(f"pose RMSE         {t['pose_rmse_m']:.2f} m against the ground truth "
          f"(ANEES {t['anees']:.2f})")
print(f"processing time   {m['wall_time_s']:.2f} s (association {m['association_time_s']:.2f} s, "
      f"EKF update {m['update_time_s']:.2f} s); bag read {m['bag_read_s']:.2f} s")
PY
echo
echo "results:  $out/  (trajectory.csv, landmarks.csv, associations.csv, metrics.json)"
if [[ -f "$out/map.png" ]]; then
  echo "picture:  $out/map.png"
fi
