// DJNN extension "shift test" (shift_test; docs/djnn.md): in a periodic layout (markers every
// 0.8 m along a corridor) a pose error of a spacing or more makes the scan fit its neighbours
// nearly as well: each observation's NN (and eq. 6's common compensation) is then a guess. The
// joint likelihood with the full covariance (pose correlation included) weighs the whole scan
// against the same scan shifted: each shift is the displacement from a paired landmark to
// another candidate within the gate of its observation, applied to every pairing. A shift more
// likely by more than shift_margin (-2 ln of the likelihood ratio) replaces the pairing; one
// within the margin leaves the pairings that differ undecided (rejected).
#pragma once

#include <vector>

#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class ShiftTest {
 public:
  struct Params {
    bool shift_test = false;
    double shift_margin = 6.0;
  };
  void read(const ParameterReader& r);
  const Params& params() const { return p_; }
  bool on() const { return p_.shift_test; }
  /// On scan->assign; `gate`: the individual gate, `candidate_gate`: the ambiguity gate.
  void apply(const AssociationContext& ctx, double gate, double candidate_gate, LocalScan* scan,
             DjnnStats* stats) const;

 private:
  /// -2 ln likelihood of the paired observations of scan->assign taking `h` (-1: left unpaired,
  /// charged as a pairing at the edge of the gate), jointly.
  static double jointCost(const AssociationContext& ctx, const LocalScan& scan,
                          const std::vector<int>& h, double gate);
  Params p_;
};

}  // namespace ekf_slam
