#include "ekf_slam/core/association/djnn/held_confirmation.h"

namespace ekf_slam {

void HeldConfirmation::read(const ParameterReader& r) {
  p_.held_confirmations = r.integer("held_confirmations", Params().held_confirmations, 0, 100);
}

HeldConfirmation::Lead HeldConfirmation::leadOf(const AssociationContext& ctx,
                                                const JointMlProblem& problem,
                                                const std::vector<CorrectionSource>& sources,
                                                const JointMlDecision& d) const {
  Lead lead;
  lead.valid = d.complete;
  if (d.complete) {
    // Remembered and live features (< 0) are no map landmark; every map landmark counts.
    lead.correction = poseCorrection(ctx, problem, sources, d.best, [](int) { return true; });
  }
  return lead;
}

// An incomplete decision agrees with nothing.
bool HeldConfirmation::repeats(const Lead& lead, double gate) const {
  for (const Lead& prev : leads_) {
    if (!lead.valid || !prev.valid || !correctionsAgree(lead.correction, prev.correction, gate))
      return false;
  }
  return true;
}

void HeldConfirmation::keep(const Lead& lead) {
  leads_.push_back(lead);
  while (static_cast<int>(leads_.size()) > p_.held_confirmations) leads_.pop_front();
}

}  // namespace ekf_slam
