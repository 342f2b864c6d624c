#!/usr/bin/env bash
# Measures the live node's intake: plays a bag (default: the whole Victoria Park set, converted
# into $EKF_SLAM_BUILD/vp.bag) with `rosbag play --clock -r RATE` into the ekf_slam node on a
# master of its own, stops the node, and compares its exit summary with the bag's counts. Fails
# when a message neither reached the node nor was counted as lost (docs/node.md, Throughput).
#
#   scripts/node_throughput.sh [RATE] [BAG]      # default rate 100
#   PLAY_DELAY=2 scripts/node_throughput.sh      # rosbag play -d 2: waits for the subscribers
#   PLAY_QUEUE=100 scripts/node_throughput.sh    # rosbag play's own default outgoing queue
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
source "$EKF_SLAM_DEVEL/setup.bash"
rate=${1:-100}
bag=${2:-$EKF_SLAM_BUILD/vp.bag}
[[ -f $bag ]] || rosrun ekf_slam victoria_park_to_bag --data "$VP_DATA" --out "$bag" > /dev/null
work=$(mktemp -d /tmp/ekf_slam_throughput_XXXXXX)
export ROS_MASTER_URI=http://localhost:$((20000 + RANDOM % 20000))
pids=()
cleanup() { for p in "${pids[@]}"; do kill -INT "$p" 2> /dev/null || true; done; wait; }
trap cleanup EXIT
roscore -p "${ROS_MASTER_URI##*:}" > "$work/roscore.log" 2>&1 &
pids+=($!)
until rosparam set use_sim_time true 2> /dev/null; do sleep 0.2; done
rosparam load "$EKF_SLAM_ROOT/config/victoria_park.yaml" /ekf_slam
# The sequencer's windows scale with the rate, as victoria_park.launch does.
rosrun ekf_slam ekf_slam __name:=ekf_slam _publish_odom_tf:=true \
  _max_latency:="$(awk "BEGIN{print 0.5 * $rate}")" \
  _time_jump_threshold:="$(awk "BEGIN{print 2 * $rate}")" > "$work/node.log" 2>&1 &
node=$!
pids+=($node)
sleep 3
start=$(date +%s)
rosbag play -q --clock -d "${PLAY_DELAY:-0}" --queue="${PLAY_QUEUE:-100000}" -r "$rate" "$bag" > "$work/play.log" 2>&1
wall=$(( $(date +%s) - start ))
sleep 3  # input_timeout: the last scans are processed
rosservice call /ekf_slam/save_map "path: '$work/node_map.txt'" > "$work/save_map.log" 2>&1 ||
  cat "$work/save_map.log" >&2
# rosrun execs the node, so $node is its pid: fields 14 and 15 of stat are utime and stime.
read -r utime stime < <(awk '{print $14, $15}' "/proc/$node/stat")
cpu=$(awk "BEGIN{printf \"%.2f s user + %.2f s system\", $utime / $(getconf CLK_TCK), $stime / $(getconf CLK_TCK)}")
kill -INT "$node"
wait "$node" || true
summary=$(grep "scans received" "$work/node.log" | tail -1)
echo "played $bag at -r $rate in $wall s wall; node CPU $cpu"
echo "node: $summary"
read -r scans odom < <(rosbag info -y -k topics "$bag" | /usr/bin/python3 -c '
import sys, yaml
t = {x["topic"]: x["messages"] for x in yaml.safe_load(sys.stdin)}
print(t.get("/scan", 0), t.get("/odom", 0))')
echo "bag: $scans scans, $odom odometry messages"
get() { echo "$summary" | grep -oP "$1 \K[0-9]+" | head -1; }
scans_in=$(get "scans received")
scan_gaps=$(get "missing upstream \(seq gaps\)")
odom_in=$(get "odometry received")
odom_gaps=$(echo "$summary" | grep -oP "odometry received [0-9]+, missing \(seq gaps\) \K[0-9]+")
odom_first=$(echo "$summary" | grep -oP "odometry received .*?before the first \(seq\) \K[0-9]+")
scan_first=$(get "before the first \(seq\)")
overflow=$(get "inbox overflow")
echo "odometry: received $odom_in + missing (seq gaps) $odom_gaps + before the first $odom_first of $odom; inbox overflow $overflow"
echo "scans: received $scans_in + missing (seq gaps) $scan_gaps + before the first $scan_first of $scans"
if (( odom_in + odom_gaps + odom_first != odom || scans_in + scan_gaps + scan_first != scans )); then
  echo "node_throughput.sh: messages lost without a count" >&2
  exit 1
fi
if [[ ${COMPARE_OFFLINE:-1} != 0 && -f $work/node_map.txt ]]; then
  rosrun ekf_slam ekf_slam_offline --bag "$bag" --params "$EKF_SLAM_ROOT/config/victoria_park.yaml" \
    --out "$work/offline" --no-plot --no-progress > "$work/offline.log" 2>&1
  /usr/bin/python3 - "$work/node_map.txt" "$work/offline/map.txt" <<'PY'
import math, sys
def load(path):  # ~save_map format: id x y ... per line after the comments
    return [tuple(map(float, l.split()[1:3])) for l in open(path)
            if l.strip() and not l.startswith(("#", "ekf_slam_map"))]
node, off = load(sys.argv[1]), load(sys.argv[2])
dist = sorted(min(math.dist(p, q) for q in off) for p in node) if off else []
pct = lambda f: dist[min(len(dist) - 1, int(f * len(dist)))] if dist else float("nan")
print(f"map: node {len(node)} landmarks, offline {len(off)}; node to nearest offline landmark: "
      f"median {pct(0.5):.3g} m, p95 {pct(0.95):.3g} m, max {dist[-1] if dist else float('nan'):.3g} m, "
      f"{sum(d > 1.0 for d in dist)} farther than 1 m")
PY
fi
rm -rf "$work"
