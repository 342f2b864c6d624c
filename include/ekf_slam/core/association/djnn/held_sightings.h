// DJNN extension "held sightings join their landmark" (held_sightings; docs/djnn.md): while the
// joint decision holds a loop closure (JointDecision), a held observation feeds a tentative
// feature that is never admitted (RememberedFeatures' held birth). Once the closure is decided the
// same object's next sighting pairs with its map landmark, and the held feature, no longer seen,
// is dropped with its sightings: at `fiducials` they were a third of the sightings of mapped
// markers the filter never used. This part hands them over instead: a live feature born held that
// lies within the tentative gate of a sighting paired this scan is that landmark's. The pairing
// names it (AssociationResult::feature) and the pipeline applies its kept sightings against
// their pose clones (core/pipeline/delayed_sightings.h); the feature ends.
#pragma once

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class HeldSightings {
 public:
  struct Params {
    bool held_sightings = true;
  };
  void read(const ParameterReader& r);
  const Params& params() const { return p_; }
  bool on() const { return p_.held_sightings; }
  /// For each observation paired in `result`: the nearest live feature born held, not sighted
  /// this scan and within the tentative gate of the sighting, joins the landmark
  /// (result->feature; the feature is dropped, its key in result->ended_features).
  void join(const AssociationContext& ctx, const LocalScan& scan, FeatureRules* rules,
            DjnnPaper* paper, AssociationResult* result, DjnnStats* stats) const;

 private:
  Params p_;
};

}  // namespace ekf_slam
