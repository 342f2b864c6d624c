// DJNN extension "joint decision at loop closures" (loop_closure_age, joint_margin; docs/djnn.md,
// "Closing the loops"). Back on landmarks last paired long ago, the pose error can be a landmark
// spacing or more: NN (with eq. 6's compensation) then picks one of several
// hypotheses that fit nearly equally, and a wrong one corrupts the map for good. The joint
// maximum-likelihood assignment over the gated candidates, "not in the map" scored by the
// densities (landmark_density + clutter_density), decides each observation only when every
// hypothesis deciding it otherwise is joint_margin less likely; the rest are held (neither
// paired nor a new landmark), but for a pairing with a landmark tracked within loop_closure_age
// whose only rival leaves it out of the map ("not in the map", a remembered or a live feature):
// it decides no closure. With it on, the density test runs only on the other scans. Works with
// the remembered features, landmark spacing and held confirmations.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "ekf_slam/core/association/djnn/closure_evidence.h"
#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/held_confirmation.h"
#include "ekf_slam/core/association/djnn/landmark_spacing.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/association/djnn/remembered_features.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class JointDecision {
 public:
  struct Params {
    double loop_closure_age = 60.0;  ///< [s]; 0: off
    double joint_margin = 6.0;
  };
  /// What the decision reads of DJNN's other parts.
  struct Parts {
    const DjnnPaper& paper;
    double ambiguity_gate;
    double unmapped_cost;  ///< -2 ln of "not in the map" per m^2 (UnmappedReturns::density)
    double clutter_density;
    const LandmarkSpacing& spacing;
    RememberedFeatures& remembered;
    HeldConfirmation& confirmation;
  };

  /// `unmapped_density`: a density of "not in the map" is known (landmark_density, its online
  /// estimate, or clutter_density); needed when on. Without one, loop_closure_age set by the user
  /// (`age_set`) is an error and the default is off.
  void read(const ParameterReader& r, bool unmapped_density, bool age_set);
  const Params& params() const { return p_; }
  bool on() const { return p_.loop_closure_age > 0.0; }
  void reset();

  /// The scan's decision when a gated landmark was last paired longer than loop_closure_age ago
  /// (true; scan->assign, gated, force_new and held as decided); false, changing nothing but the
  /// candidates, otherwise.
  bool decide(const AssociationContext& ctx, const Parts& parts, LocalScan* scan, DjnnStats* stats);
  /// Paired within loop_closure_age of `stamp`.
  bool recentlyPaired(LandmarkId id, double stamp) const;
  /// The scan's outcome: its pairings are the landmarks' latest, its removals are gone.
  void record(const AssociationResult& result, double stamp);
  void landmarkAdded(LandmarkId id, double stamp) { last_paired_[id] = stamp; }

 private:
  /// Adds to the candidates those of `near` (the landmarks a pose error of three standard
  /// deviations could bring into view) that gate with an observation.
  void widenCandidates(const AssociationContext& ctx, const std::vector<int>& near, double gate,
                       LocalScan* scan) const;
  /// A closure is no longer held: count the streak, forget the leads it kept.
  void endHeldStreak(HeldConfirmation* confirmation, DjnnStats* stats);

  Params p_;
  ClosureEvidence evidence_;
  std::unordered_map<LandmarkId, double> last_paired_;  ///< stamp
  std::uint64_t held_streak_ = 0;  ///< consecutive joint scans with something held
};

}  // namespace ekf_slam
