// NN + JCBB hybrid (seed 003 section 2.2; ALGORITHMS.md section 5): NN first; JCBB (with mutual
// exclusion and, among the hypotheses with the most pairings, the least joint Mahalanobis
// distance) when NN's result interferes, and optionally every N scans.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/association/gating.h"
#include "ekf_slam/core/association/jcbb.h"

namespace ekf_slam {

/// Parameters (besides GatingParameters and JcbbOptions, whose prefer_least_distance defaults to
/// true here, the paper's optimal criterion):
///   interference_threshold (0.0)  JCBB runs when the share of paired observations that interfere
///                                 (share a landmark with another) exceeds it; 0 = on any
///                                 interference (the paper). Below it, interference is settled by
///                                 mutual exclusion alone.
///   jcbb_every_n_scans     (0)    also run JCBB when this many scans passed since it last ran
///                                 (0 = never on a schedule)
class NNJCBB : public DataAssociation {
 public:
  void configure(const ParameterSource& params) override;
  std::string name() const override { return "NNJCBB"; }
  AssociationResult associate(const AssociationContext& ctx) override;
  /// Clears the step counter and the statistics.
  void reset() override;

  const GatingParameters& gating() const { return gating_; }
  const JcbbOptions& options() const { return search_.options(); }
  double interferenceThreshold() const { return interference_threshold_; }
  int jcbbEveryNScans() const { return every_n_; }

  /// Scans since configure()/reset().
  std::size_t steps() const { return steps_; }
  /// Scans since JCBB last ran.
  int stepsSinceJcbb() const { return since_jcbb_; }
  /// associate() calls that ran JCBB, and how many of them hit the node budget.
  std::size_t jcbbRuns() const { return jcbb_runs_; }
  std::size_t budgetExhaustions() const { return budget_exhaustions_; }
  /// Whether the last associate() ran JCBB, and its statistics if so.
  bool lastRanJcbb() const { return last_ran_jcbb_; }
  const JcbbStats& lastStats() const { return search_.stats(); }

 private:
  GatingParameters gating_;
  JointCompatibilitySearch search_;
  double interference_threshold_ = 0.0;
  int every_n_ = 0;

  std::size_t steps_ = 0;
  int since_jcbb_ = 0;
  std::size_t jcbb_runs_ = 0;
  std::size_t budget_exhaustions_ = 0;
  bool last_ran_jcbb_ = false;

  GatingTable table_;
  std::vector<int> choice_;
  std::vector<int> counts_;
};

}  // namespace ekf_slam
