# Sourced by the scripts: a ROS environment that works on Debian 12 (see README).
# pyenv/venv pythons lack rospy and catkin_pkg: Debian's python must come first.
export PATH=/usr/bin:$PATH
export ROS_HOSTNAME=${ROS_HOSTNAME:-localhost}
EKF_SLAM_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
export EKF_SLAM_ROOT
# Build tree and devel space. The devel space must not lie under <package>/build/: rosrun ignores
# every executable there. Defaults: build/ and devel/ at the repository root, as in a catkin
# workspace; with EKF_SLAM_BUILD set elsewhere, the devel space goes inside it.
if [[ -n ${EKF_SLAM_BUILD:-} ]]; then
  export EKF_SLAM_DEVEL=${EKF_SLAM_DEVEL:-$EKF_SLAM_BUILD/devel}
else
  export EKF_SLAM_BUILD=$EKF_SLAM_ROOT/build
  export EKF_SLAM_DEVEL=${EKF_SLAM_DEVEL:-$EKF_SLAM_ROOT/devel}
fi
case "$EKF_SLAM_DEVEL/" in
  "$EKF_SLAM_ROOT/build/"*)
    echo "EKF_SLAM_DEVEL=$EKF_SLAM_DEVEL is under $EKF_SLAM_ROOT/build/, where rosrun finds nothing;" \
      "choose another folder" >&2
    return 2 2> /dev/null || exit 2 ;;
esac
export VP_DATA=${VP_DATA:-$(cd "$EKF_SLAM_ROOT/.." && pwd)/shared/data/victoria_park}
