#!/usr/bin/env bash
# catkin_lint --strict -W2 on the tracked files (a copy named after the package, without the
# build and devel folders, whose outputs would read as uninstalled executables).
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
command -v catkin_lint > /dev/null || apt-get install -y -qq --no-install-recommends catkin-lint > /dev/null
work=$(mktemp -d /tmp/ekf_slam_lint.XXXXXX)
trap 'rm -rf "$work"' EXIT
mkdir "$work/ekf_slam"
git -C "$EKF_SLAM_ROOT" ls-files -z --cached --others --exclude-standard \
  | (cd "$EKF_SLAM_ROOT" && xargs -0 tar -cf - 2> /dev/null) | tar -xf - -C "$work/ekf_slam"
out=$(catkin_lint --strict -W2 "$work/ekf_slam" 2>&1 | grep -v '^catkin_lint: ' || true)
if [[ -n $out ]]; then
  echo "$out"
  exit 1
fi
echo "catkin_lint --strict -W2: clean"
