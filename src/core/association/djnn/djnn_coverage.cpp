// DJNN's coverage_cell rule (docs/djnn.md, "Where the sensor has looked"), kept apart from
// djnn.cpp.
#include <cmath>

#include "ekf_slam/core/association/djnn/djnn.h"

namespace ekf_slam {

namespace {
// Cells of the source's uncertainty ellipse beyond which the looks there are not worth telling
// apart: the whole mean is taken as "never looked" (the density of no coverage, conservative).
constexpr int kMaxQueryCells = 4096;
}  // namespace

// The sensor region of this (non-empty) scan, at the pose estimate it was associated from: the
// landmarks made at this time are placed from the same estimate, so the coverage lies in the
// map's frame as the map was built there.
void DJNN::recordCoverage() {
  if (p_.coverage_cell > 0.0) coverage_.addView(p_.sensor, sensor_pose_);
}

// A landmark (prior density landmark_density) at a place the sensor covered n times would have
// been detected with probability 1 - (1 - P_D)^n: the density of landmarks still unmapped there
// is landmark_density (1 - P_D)^n. The source's position is known only up to the pose and
// observation noise: the density is the mean over that Gaussian, so that a source that may lie
// in a place never looked at keeps most of the prior density (a conservative n).
double DJNN::unmappedDensityOf(const AssociationContext& ctx, int obs) const {
  if (p_.coverage_cell <= 0.0) return p_.landmark_density;
  const Observation& o = ctx.observations()[obs];
  Matrix23d G_pose;
  Eigen::Matrix2d G_obs;
  const Eigen::Vector2d source = ctx.model().inverse(ctx.robotPose(), o.z, o.kind, &G_pose, &G_obs);
  const Eigen::Matrix2d C =
      G_pose * ctx.ekf().poseCovariance() * G_pose.transpose() + G_obs * o.R * G_obs.transpose();
  return p_.landmark_density *
         coverage_.expectation(source, C, miss_table_, std::sqrt(gate_), kMaxQueryCells, 1.0);
}

}  // namespace ekf_slam
