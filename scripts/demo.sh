#!/usr/bin/env bash
# The main demo: from a fresh Debian 12 machine, installs the dependencies, builds, converts the
# Victoria Park data ($VP_DATA, see scripts/env.sh) into a bag under build/, runs the offline
# runner with DJNN and prints the metrics and where the map picture is.
#   scripts/demo.sh [ASSOCIATOR]      (default DJNN)
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
ASSOCIATOR=${1:-DJNN}

if [[ ! -f "$VP_DATA/aa3_dr.mat" ]]; then
  cat >&2 <<MSG
demo.sh: the Victoria Park data set was not found in $VP_DATA
  (needs aa3_dr.mat, aa3_gpsx.mat and victoria_park_ascii/; see the README, "Data").
  Set VP_DATA=/path/to/victoria_park and run again.
MSG
  exit 1
fi

"$EKF_SLAM_ROOT/scripts/build.sh"
source "$EKF_SLAM_BUILD/devel/setup.bash"

bag="$EKF_SLAM_BUILD/vp.bag"
if [[ ! -f "$bag" || "$VP_DATA/aa3_dr.mat" -nt "$bag" ]]; then
  rosrun ekf_slam victoria_park_to_bag --data "$VP_DATA" --out "$bag"
fi
out="$EKF_SLAM_BUILD/vp_$ASSOCIATOR"
rosrun ekf_slam ekf_slam_offline --bag "$bag" --params "$EKF_SLAM_ROOT/config/victoria_park.yaml" \
  --associator "$ASSOCIATOR" --out "$out"

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
print(f"processing time   {m['wall_time_s']:.2f} s (association {m['association_time_s']:.2f} s, "
      f"EKF update {m['update_time_s']:.2f} s); bag read {m['bag_read_s']:.2f} s")
PY
echo
echo "results:  $out/  (trajectory.csv, landmarks.csv, associations.csv, gps.csv, metrics.json)"
if [[ -f "$out/map.png" ]]; then
  echo "picture:  $out/map.png"
fi
