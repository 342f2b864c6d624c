// DJNN's landmark_spacing rule (docs/djnn.md, "The other failing seeds"), kept apart from
// djnn.cpp.
#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "ekf_slam/core/association/djnn/djnn.h"

namespace ekf_slam {

// "Not in the map" stands for clutter or a landmark the map does not hold yet (density
// landmark_density). Landmarks keep a least distance from each other: an observation whose source
// is, with probability individual_probability, within that distance of a candidate landmark can
// be that landmark or clutter, not another landmark. With the pose known to centimetres a
// revisited marker otherwise ties with "an unmapped marker just there" whenever its innovation is
// a little large (D^2 of 5-9: every observation of a loop-closure scan is held that way); with
// the pose uncertain by a marker spacing the source may lie anywhere near and nothing changes.
bool DJNN::withinSpacing(const AssociationContext& ctx, int obs,
                         const std::vector<int>& landmarks) const {
  if (p_.landmark_spacing <= 0.0 || landmarks.empty()) return false;
  const Observation& o = ctx.observations()[obs];
  Matrix23d G_pose;
  Eigen::Matrix2d G_obs;
  ctx.model().inverse(ctx.robotPose(), o.z, o.kind, &G_pose, &G_obs);
  const double k = std::sqrt(gate_);  // chi2(2, individual_probability)
  for (int j : landmarks) {
    const AssociationContext::Individual ind = ctx.individual(obs, j);
    // Where the source lies relative to the landmark's estimate, in metres, and how well known.
    const Eigen::Vector2d d = G_obs * ind.v;
    if (d.norm() >= p_.landmark_spacing) continue;
    const Eigen::Matrix2d C = G_obs * ind.S * G_obs.transpose();
    const double sigma = std::sqrt(
        std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(C, Eigen::EigenvaluesOnly)
                          .eigenvalues()
                          .maxCoeff()));
    if (d.norm() + k * sigma < p_.landmark_spacing) return true;
  }
  return false;
}

double DJNN::unmappedCostOf(const AssociationContext& ctx, int obs,
                            const std::vector<int>& gated) const {
  if (withinSpacing(ctx, obs, gated)) return -2.0 * std::log(p_.sensor.clutter_density);
  // The coverage query only when the spacing rule did not decide.
  return -2.0 * std::log(unmappedDensityOf(ctx, obs) + p_.sensor.clutter_density);
}

}  // namespace ekf_slam
