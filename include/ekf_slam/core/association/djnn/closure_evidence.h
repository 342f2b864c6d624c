// DJNN extension "closure evidence" (closure_margin; docs/djnn.md, "A closure decided on the
// evidence of its held scans"): a loop closure is decided only once its hypothesis leads on the
// evidence of every scan since it was first held, on top of the scan's own joint_margin. A
// closure hypothesis is, in effect, a pose correction against the old map: the mean offset of
// the scan's sources from the old landmarks it pairs them with. Each correction the joint
// decision proposes (its best's, its alternatives') is kept and followed from scan to scan; each
// closure scan adds to every one the cost of its cheapest hypothesis implying it. A per-scan
// margin retested at every held scan is passed once by noise (the record of 1 Dec 2026); the
// sum keeps that one scan from deciding against the scans before it.
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/pose_correction.h"
#include "ekf_slam/core/association/joint_ml.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class ClosureEvidence {
 public:
  struct Params {
    double closure_margin = 10.0;  ///< -2 ln likelihood ratio; 0: off
  };
  void read(const ParameterReader& r);
  const Params& params() const { return p_; }
  bool on() const { return p_.closure_margin > 0.0; }
  /// The search margin the joint decision needs for the rivals to be reported.
  double searchMargin(double joint_margin) const;
  void clear() {
    entries_.clear();
    unseen_ = 0.0;
  }

  /// Adds one closure scan (`sources`: its observations', correctionSources). `old(j)`:
  /// landmark state index j was last paired before the loop closure age (a pairing with it is
  /// part of the correction: the pose correction against the old map). `gate`: chi2(2) of two
  /// corrections that agree. `search_margin`: how far above its best the decision searched the
  /// alternatives. True when the scan's joint best implies the correction that leads every other
  /// by closure_margin, or closes nothing.
  bool add(const AssociationContext& ctx, const JointMlProblem& problem,
           const std::vector<CorrectionSource>& sources, const JointMlDecision& d,
           const std::function<bool(int)>& old, double gate, double search_margin);

 private:
  struct Entry {
    PoseCorrection correction;
    double score = 0.0;  ///< summed cost over the closure's scans above each scan's best
  };

  Params p_;
  std::vector<Entry> entries_;
  double unseen_ = 0.0;  ///< what a correction not yet proposed has summed at least
};

}  // namespace ekf_slam
