# Sourced by the scripts: a ROS environment that works on Debian 12 (see README).
# pyenv/venv pythons lack rospy and catkin_pkg: Debian's python must come first.
export PATH=/usr/bin:$PATH
export ROS_HOSTNAME=${ROS_HOSTNAME:-localhost}
EKF_SLAM_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
export EKF_SLAM_ROOT
export EKF_SLAM_BUILD=${EKF_SLAM_BUILD:-$EKF_SLAM_ROOT/build}
export VP_DATA=${VP_DATA:-$(cd "$EKF_SLAM_ROOT/.." && pwd)/shared/data/victoria_park}
