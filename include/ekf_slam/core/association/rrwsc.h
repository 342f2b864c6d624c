// RRW&SC data association (seed 004; ALGORITHMS.md section 7): the scan and the landmarks in the
// sensor's reach are matched as two graphs by RrwscMatcher (shape context, pairwise distances,
// reweighted random walks, Hungarian discretisation), then each match is gated against the
// filter before it is used as an update; when the graph confirms the prior, the pairs are the
// filter's joint maximum-likelihood assignment, and a landmark the filter has lost is removed.
// Parameters and decisions: docs/association.md, "RRWSC".
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/association/gating.h"
#include "ekf_slam/core/association/hungarian.h"
#include "ekf_slam/core/graph_matching/rrwsc_matcher.h"

namespace ekf_slam {

class RRWSC : public DataAssociation {
 public:
  /// Counters since configure()/reset().
  struct Stats {
    std::uint64_t scans = 0;         ///< associate() calls with observations and landmarks
    std::uint64_t matched = 0;       ///< observations the graph matching paired
    std::uint64_t incompatible = 0;  ///< of those, rejected by the filter gate
    std::uint64_t iterations = 0;    ///< random-walk iterations, summed
    std::uint64_t unclaimed = 0;     ///< unmatched, rejected next to an unclaimed landmark
    std::uint64_t refined = 0;       ///< scans whose matching the filter's joint ML re-chose
    std::uint64_t changed = 0;       ///< observations whose landmark that changed
    std::uint64_t retired = 0;       ///< landmarks removed as lost (stale_scans)
  };

  void configure(const ParameterSource& params) override;
  std::string name() const override { return "RRWSC"; }
  AssociationResult associate(const AssociationContext& ctx) override;
  void reset() override {
    stats_ = Stats();
    stale_.clear();
  }

  const GatingParameters& gating() const { return gating_; }
  const RrwscParams& params() const { return params_; }
  const Stats& stats() const { return stats_; }
  const RrwscMatcher& matcher() const { return matcher_; }
  bool jointRefinement() const { return joint_refinement_; }

 private:
  /// Re-chooses match_ as the filter's joint maximum-likelihood one-to-one assignment among the
  /// gated pairs (docs/association.md, "RRWSC", step 8).
  void refine(int m, int n);
  /// The landmark nobody claimed of least M within unclaimed_gate of observation i, or -1.
  int nearestUnclaimed(int i, int n) const;
  /// Removes the landmarks held back for stale_scans_ scans (docs/association.md, step 10).
  void retireStale(const AssociationContext& ctx, int n, AssociationResult* result);

  GatingParameters gating_;
  RrwscParams params_;
  RrwscMatcher matcher_;
  MatchInput input_;
  std::vector<int> candidates_, match_;
  std::vector<double> min_mahalanobis_;
  std::vector<char> claimed_;      ///< per local landmark: matched by some observation
  double unclaimed_gate_ = 100.0;  ///< M below which an unmatched observation next to an
                                   ///< unclaimed landmark is rejected, not new
  /// Once the graph confirms the prior, the assignment is the filter's joint ML (step 8).
  bool joint_refinement_ = true;
  AssignmentSolver solver_;
  Eigen::MatrixXd cost_;
  std::vector<int> row_to_col_, graph_match_, landmark_of_col_;
  std::vector<char> held_;  ///< per local landmark: an unmatched return was held back for it
  /// Scans in a row (with the prior confirmed) a landmark went unclaimed with a return held back
  /// for it; removed at stale_scans_ (0: never).
  int stale_scans_ = 10;
  std::unordered_map<LandmarkId, int> stale_;
  Stats stats_;
};

}  // namespace ekf_slam
