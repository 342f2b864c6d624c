// Individual-compatibility nearest neighbour, NN / ICNN (ALGORITHMS.md section 2; seed 000 eq.
// 4-5): for each observation, among the landmarks with M_ij <= chi2(2, p), the one with the least
// M_ij + ln|S_ij|.
#pragma once

#include <string>
#include <vector>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/association/gating.h"

namespace ekf_slam {

/// The NN choice for one observation among `candidates` (state-order landmark indices), skipping
/// those with taken[j] != 0 when `taken` is given (indexed by state-order landmark index). Returns
/// the landmark index or -1; fills `best` when non-null. Shared by NN, DJNN and NNJCBB.
int nearestNeighbour(const AssociationContext& ctx, int obs, const std::vector<int>& candidates,
                     double gate, const std::vector<char>* taken = nullptr,
                     AssociationContext::Individual* best = nullptr);

/// Parameters (besides GatingParameters):
///   mutual_exclusion (false)  false: the paper's NN baseline, several observations may take one
///                             landmark (interference is left in, seed 000 section 2); true: a
///                             landmark goes to its least-score claimant, the others retry NN on
///                             the landmarks nobody holds.
class NN : public DataAssociation {
 public:
  void configure(const ParameterSource& params) override;
  std::string name() const override { return "NN"; }
  AssociationResult associate(const AssociationContext& ctx) override;
  void reset() override {}

  const GatingParameters& gating() const { return gating_; }
  bool mutualExclusion() const { return mutual_exclusion_; }

 private:
  GatingParameters gating_;
  bool mutual_exclusion_ = false;
  GatingTable table_;
  std::vector<int> choice_;
};

}  // namespace ekf_slam
