// DJNN extension "ambiguity gate" (ambiguity_probability; docs/djnn.md): an observation left
// unpaired although it lies within chi2(2, ambiguity_probability) of a local landmark, plain or
// compensated by the scan's v_bar, must not seed a duplicate of that landmark: it is rejected
// rather than made tentative. At the individual gate's probability (the default) it applies only
// where interference was resolved. With tentative_ambiguity the same gate guards the features not
// yet in the map: a sighting outside a tentative feature's gate but within this wider one is
// withheld (neither a second feature nor a miss of the first).
#pragma once

#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class AmbiguityGate {
 public:
  struct Params {
    double ambiguity_probability = 0.999;  ///< >= individual_probability
    bool tentative_ambiguity = true;
  };
  void read(const ParameterReader& r, double individual_probability);
  const Params& params() const { return p_; }
  double gate() const { return gate_; }
  /// The wide gate for tentative features: chi2(2, ambiguity_probability) when
  /// tentative_ambiguity is on and it is wider than the tentative gate, else 0 (off).
  double tentativeGate(double tentative_gate) const {
    return p_.tentative_ambiguity && gate_ > tentative_gate ? gate_ : 0.0;
  }
  /// Marks the unpaired observations within the gate (scan->gated).
  void apply(const AssociationContext& ctx, const DjnnPaper& paper, LocalScan* scan) const;

 private:
  Params p_;
  double gate_ = 0.0;
};

}  // namespace ekf_slam
