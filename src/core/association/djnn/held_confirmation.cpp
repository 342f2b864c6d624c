#include "ekf_slam/core/association/djnn/held_confirmation.h"

#include <Eigen/LU>

namespace ekf_slam {

void HeldConfirmation::read(const ParameterReader& r) {
  p_.held_confirmations = r.integer("held_confirmations", Params().held_confirmations, 0, 100);
}

// A joint hypothesis of a closure is, in effect, a pose correction: the mean world-frame offset
// of its paired observations' sources from their landmarks. Its covariance leaves the pose's own
// uncertainty out: that error is what the hypotheses disagree on, and it is shared by consecutive
// scans (the odometry between two scans adds little). What remains is each observation's noise
// mapped to the world (G_obs R G_obs^T) and its landmark's covariance (which cancels when two
// scans pair the same landmarks, so counting it is on the safe side), averaged over the n pairs.
HeldConfirmation::Lead HeldConfirmation::leadOf(const AssociationContext& ctx,
                                                const JointMlProblem& problem,
                                                const JointMlDecision& d) const {
  Lead lead;
  lead.valid = d.complete;
  if (!d.complete) return lead;
  int n = 0;
  for (std::size_t k = 0; k < problem.obs.size(); ++k) {
    const int j = d.best[k];
    if (j < 0) continue;  // not in the map or a remembered / live feature: no map landmark
    const int i = problem.obs[k];
    const Observation& o = ctx.observations()[i];
    Matrix23d G_pose;
    Eigen::Matrix2d G_obs;
    ctx.model().inverse(ctx.robotPose(), o.z, o.kind, &G_pose, &G_obs);
    lead.offset += G_obs * ctx.individual(i, j).v;
    lead.cov += G_obs * o.R * G_obs.transpose() + ctx.ekf().landmarkCovariance(j);
    ++n;
  }
  lead.paired = n > 0;
  if (n > 0) {
    lead.offset /= n;
    lead.cov /= static_cast<double>(n) * n;
  }
  return lead;
}

// Two leads agree when both pair nothing, or both pair and their corrections differ by no more
// than chi2(2, individual_probability) of the difference's covariance (the scans' noise is
// independent). An incomplete decision agrees with nothing.
bool HeldConfirmation::repeats(const Lead& lead, double gate) const {
  for (const Lead& prev : leads_) {
    if (!lead.valid || !prev.valid || lead.paired != prev.paired) return false;
    if (!lead.paired) continue;
    const Eigen::Vector2d e = lead.offset - prev.offset;
    if (e.dot((lead.cov + prev.cov).inverse() * e) > gate) return false;
  }
  return true;
}

void HeldConfirmation::keep(const Lead& lead) {
  leads_.push_back(lead);
  while (static_cast<int>(leads_.size()) > p_.held_confirmations) leads_.pop_front();
}

}  // namespace ekf_slam
