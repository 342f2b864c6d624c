#!/usr/bin/env bash
# Headless rviz screenshot of ekf_slam on Victoria Park: converts the data set into a bag, plays
# it fast through launch/victoria_park.launch under Xvfb and grabs the screen with ImageMagick
# late in the run (rviz running from the start, the vehicle still driving), when the bag's clock
# reaches LEAD data seconds before its end. Not part of the test suite (about two minutes).
# Needs the optional packages:
#   EKF_SLAM_WITH_RVIZ=1 scripts/install_deps.sh
# Usage: scripts/rviz_screenshot.sh [OUT.png]      (after scripts/build.sh)
#   env RATE (playback rate, default 25), END (last data second, default: the whole run),
#   LEAD (data seconds before the end, default 40), LATE=1 (start rviz only after the playback
#   and shoot then: shows that the latched outputs and the held tf give the whole view),
#   ASSOCIATOR (default ekf_slam/DJNN), GPS_X / GPS_Y / GPS_YAW (see the launch file),
#   VERBOSE=1 (print the launch log). The log, with the node's exit summary, is kept in
#   /tmp/ekf_slam_rviz_screenshot.log. Look at the picture: rviz's "Global Status" must be OK.
set -eo pipefail

source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
OUT=${1:-$EKF_SLAM_ROOT/docs/images/rviz_victoria_park.png}
RATE=${RATE:-25}
ASSOCIATOR=${ASSOCIATOR:-ekf_slam/DJNN}
PORT=${PORT:-11731}
DISPLAY_NUM=${DISPLAY_NUM:-97}

# shellcheck disable=SC1091
source "$EKF_SLAM_DEVEL/setup.bash"
export ROS_MASTER_URI=http://localhost:$PORT DISPLAY=:$DISPLAY_NUM
for tool in Xvfb rviz import; do
  command -v $tool > /dev/null || { echo "missing $tool: EKF_SLAM_WITH_RVIZ=1 scripts/install_deps.sh" >&2; exit 1; }
done

TMP=$(mktemp -d /tmp/ekf_slam_rviz.XXXXXX)
PIDS=()
cleanup() {
  for pid in "${PIDS[@]}"; do kill -INT "$pid" 2> /dev/null || true; done
  sleep 2
  for pid in "${PIDS[@]}"; do kill -KILL "$pid" 2> /dev/null || true; done
  # The node's warnings and its exit summary (scans received / processed / skipped).
  cp "$TMP/launch.log" /tmp/ekf_slam_rviz_screenshot.log 2> /dev/null || true
  rm -rf "$TMP"
}
trap cleanup EXIT

BAG=$TMP/vp.bag
"$EKF_SLAM_DEVEL/lib/ekf_slam/victoria_park_to_bag" --out "$BAG" ${END:+--end "$END"} | tail -1
# Data seconds in the bag and its last stamp, for the waits below.
SPAN=$(rosbag info -y -k duration "$BAG")
BAG_END=$(rosbag info -y -k end "$BAG")
LEAD=${LEAD:-40}

Xvfb :$DISPLAY_NUM -screen 0 1280x720x24 +extension GLX +render -noreset > "$TMP/xvfb.log" 2>&1 &
PIDS+=($!)
sleep 2
roslaunch -p "$PORT" ekf_slam victoria_park.launch bag:="$BAG" rate:="$RATE" \
  associator:="$ASSOCIATOR" rviz:="$([[ -n $LATE ]] && echo false || echo true)" ${GPS_X:+gps_x:=$GPS_X} ${GPS_Y:+gps_y:=$GPS_Y} ${GPS_YAW:+gps_yaw:=$GPS_YAW} \
  > "$TMP/launch.log" 2>&1 &
PIDS+=($!)

# The bag's clock (the player keeps /clock running after the bag: --keep-alive), 0 until then.
clock() { timeout 5 rostopic echo -n 1 -p /clock 2> /dev/null | awk -F, 'NR == 2 { print $2 / 1e9 }'; }
# Startup (rviz takes a while under llvmpipe), the -d 2 delay, then the playback.
LIMIT=$(python3 -c "print(int(60 + 2 * $SPAN / $RATE))")
echo "playing ${SPAN%.*} s of data at ${RATE}x"
if [[ -n $LATE ]]; then
  TARGET=$(python3 -c "print($BAG_END + 2 * $RATE)")  # some wall seconds after the bag
else
  TARGET=$(python3 -c "print($BAG_END - $LEAD)")
fi
SECONDS=0
until python3 -c "import sys; sys.exit(0 if float('${NOW:-0}' or 0) >= $TARGET else 1)"; do
  ((SECONDS < LIMIT)) || { echo "the clock never reached ${TARGET} s (at ${NOW:-none})" >&2; exit 1; }
  sleep 0.5
  NOW=$(clock || true)  # no master or no /clock yet
done
echo "bag clock at ${NOW} s (bag ends at ${BAG_END%.*} s)"
if [[ -n $LATE ]]; then
  # The run is over: a subscriber that comes now gets the map only if the outputs are latched
  # and current, and the vehicle's frames only if tf is still published.
  echo "playback over; starting rviz now"
  rviz -d "$EKF_SLAM_ROOT/rviz/ekf_slam.rviz" > "$TMP/rviz.log" 2>&1 &
  PIDS+=($!)
  sleep 20
fi
[[ -n "$VERBOSE" ]] && tail -40 "$TMP/launch.log"
mkdir -p "$(dirname "$OUT")"
import -window root "$TMP/shot.png"
# 256 colours keep the PNG small; the picture is flat colours anyway.
convert "$TMP/shot.png" -colors 256 "PNG8:$OUT"
echo "wrote $OUT ($(du -k "$OUT" | cut -f1) KB)"
