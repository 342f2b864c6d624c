#!/usr/bin/env bash
# Resolves every dependency key of package.xml with rosdep against Debian's own keys, offline:
# Debian's python3-rosdep2 database (the ROS packages) plus rosdep/debian12.yaml (the system
# libraries, as rosdep's base.yaml maps them). Prints the Debian packages and fails on any key
# that does not resolve. With --install, installs them (rosdep install --from-paths).
#   scripts/rosdep_check.sh [--install]
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
command -v rosdep > /dev/null || {
  apt-get install -y -qq --no-install-recommends python3-rosdep2 > /dev/null
}
work=$(mktemp -d /tmp/ekf_slam_rosdep.XXXXXX)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/sources.list.d"
cat > "$work/sources.list.d/10-debian.list" << LIST
yaml file:///usr/share/python3-rosdep2/debian.yaml debian
yaml file://$EKF_SLAM_ROOT/rosdep/debian12.yaml
LIST
# No rosdistro index offline: an empty one (the ROS keys come from debian.yaml above).
cat > "$work/index.yaml" << INDEX
%YAML 1.1
---
type: index
version: 4
distributions: {}
INDEX
export ROSDEP_SOURCE_PATH=$work/sources.list.d ROSDISTRO_INDEX_URL=file://$work/index.yaml
export ROS_HOME=$work/ros_home
rosdep update --include-eol-distros > "$work/update.log" 2>&1 || { cat "$work/update.log"; exit 1; }
if [[ ${1:-} == --install ]]; then
  rosdep install --from-paths "$EKF_SLAM_ROOT" --ignore-src -y --rosdistro debian
else
  # Every key of package.xml, resolved (rosdep exits non-zero on the first that is not).
  keys=$(rosdep keys --from-paths "$EKF_SLAM_ROOT" --ignore-src --rosdistro debian)
  # shellcheck disable=SC2086
  rosdep resolve $keys --rosdistro debian | grep -v '^#' | tr ' ' '\n' | sort -u | tr '\n' ' '
  echo
  echo "rosdep: $(echo $keys | wc -w) keys resolved to Debian packages"
fi
