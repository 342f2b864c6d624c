// DJNN extension "held confirmations" (held_confirmations; docs/djnn.md, "A held closure decided
// only on a lead that repeats"): a scan that follows held scans of a loop closure decides it only
// if its joint best implies the same pose correction as the joint best of each of the last that
// many held scans; else it is held too. One held scan's noise passing the margin no longer
// decides a closure.
#pragma once

#include <deque>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/pose_correction.h"
#include "ekf_slam/core/association/joint_ml.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class HeldConfirmation {
 public:
  struct Params {
    int held_confirmations = 0;  ///< 0: off
  };
  /// The pose correction a scan's joint best implies, over every map landmark it pairs.
  struct Lead {
    bool valid = false;  ///< a complete decision
    PoseCorrection correction;
  };
  void read(const ParameterReader& r);
  const Params& params() const { return p_; }
  /// Parameters read elsewhere (DJNN switching to the missed-detection profile mid-run).
  void setParams(const Params& p) { p_ = p; }
  bool on() const { return p_.held_confirmations > 0; }
  void clear() { leads_.clear(); }
  bool empty() const { return leads_.empty(); }

  Lead leadOf(const AssociationContext& ctx, const JointMlProblem& problem,
              const std::vector<CorrectionSource>& sources, const JointMlDecision& d) const;
  /// True when `lead` agrees with every kept lead within chi2(2) = `gate`.
  bool repeats(const Lead& lead, double gate) const;
  /// Keeps the lead of a held scan (the last held_confirmations of them).
  void keep(const Lead& lead);

 private:
  Params p_;
  std::deque<Lead> leads_;
};

}  // namespace ekf_slam
