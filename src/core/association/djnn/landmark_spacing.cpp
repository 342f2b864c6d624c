#include "ekf_slam/core/association/djnn/landmark_spacing.h"

#include <algorithm>
#include <cmath>

#include "ekf_slam/core/common/decompositions.h"

namespace ekf_slam {

void LandmarkSpacing::read(const ParameterReader& r, double clutter_density) {
  p_.landmark_spacing = r.nonNegative("landmark_spacing", Params().landmark_spacing);
  if (p_.landmark_spacing > 0.0 && clutter_density <= 0.0) {
    r.fail("landmark_spacing", "needs clutter_density > 0 (the only \"not in the map\" it leaves)");
  }
}

// With the pose known to centimetres a revisited marker otherwise ties with "an unmapped marker
// just there" whenever its innovation is a little large (D^2 of 5-9: every observation of a
// loop-closure scan is held that way); with the pose uncertain by a marker spacing the source may
// lie anywhere near and nothing changes.
bool LandmarkSpacing::within(const AssociationContext& ctx, int obs,
                             const std::vector<int>& landmarks, double gate) const {
  if (p_.landmark_spacing <= 0.0 || landmarks.empty()) return false;
  const Observation& o = ctx.observations()[obs];
  Matrix23d G_pose;
  Eigen::Matrix2d G_obs;
  ctx.model().inverse(ctx.robotPose(), o.z, o.kind, &G_pose, &G_obs);
  const double k = std::sqrt(gate);
  for (int j : landmarks) {
    const AssociationContext::Individual ind = ctx.individual(obs, j);
    // Where the source lies relative to the landmark's estimate, in metres, and how well known.
    const Eigen::Vector2d d = G_obs * ind.v;
    if (d.norm() >= p_.landmark_spacing) continue;
    const Eigen::Matrix2d C = G_obs * ind.S * G_obs.transpose();
    const double sigma = std::sqrt(std::max(0.0, symmetricEigenvalues(C).maxCoeff()));
    if (d.norm() + k * sigma < p_.landmark_spacing) return true;
  }
  return false;
}

}  // namespace ekf_slam
