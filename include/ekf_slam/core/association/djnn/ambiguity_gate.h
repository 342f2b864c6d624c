// DJNN extension "ambiguity gate" (ambiguity_probability; docs/djnn.md): an observation left
// unpaired although it lies within chi2(2, ambiguity_probability) of a local landmark, plain or
// compensated by the scan's v_bar, must not seed a duplicate of that landmark: it is rejected
// rather than made tentative. At the individual gate's probability (the default) it applies only
// where interference was resolved.
#pragma once

#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class AmbiguityGate {
 public:
  struct Params {
    double ambiguity_probability = 0.999;  ///< >= individual_probability
  };
  void read(const ParameterReader& r, double individual_probability);
  const Params& params() const { return p_; }
  double gate() const { return gate_; }
  /// Marks the unpaired observations within the gate (scan->gated).
  void apply(const AssociationContext& ctx, const DjnnPaper& paper, LocalScan* scan) const;

 private:
  Params p_;
  double gate_ = 0.0;
};

}  // namespace ekf_slam
