// Joint Compatibility Branch and Bound (Neira & Tardos 2001; ALGORITHMS.md section 3; seed 003
// section 2.1, eq. 7): interpretation-tree search for the hypothesis with the most pairings whose
// joint innovation passes D^2 <= chi2(2k, p) with the full joint covariance.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/association/gating.h"
#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {

/// Options of the search (read by JCBB and NNJCBB):
///   joint_probability     (0.95)    D^2 <= chi2(2k, p) for a hypothesis with k pairings
///   max_nodes             (100000)  node budget; when spent, the best hypothesis found so far
///                                   (jointly compatible by construction) is returned and
///                                   JcbbStats::budget_exhausted is set
///   prefer_least_distance (JCBB false, NNJCBB true)  among hypotheses with the most pairings keep
///                                   the one with the least D^2 (seed 003's optimal criterion)
///                                   instead of the first found (Neira & Tardos)
struct JcbbOptions {
  double joint_probability = 0.95;
  int max_nodes = 100000;
  bool prefer_least_distance = false;

  void read(const ParameterReader& reader, bool default_prefer_least_distance);
};

/// What one search did.
struct JcbbStats {
  std::size_t nodes = 0;          ///< interpretation-tree nodes visited
  bool budget_exhausted = false;  ///< stopped by max_nodes; the result is the best so far
  int pairings = 0;               ///< pairings of the returned hypothesis
  double joint_distance = 0.0;    ///< its D^2
};

/// The branch and bound itself, shared by JCBB and NNJCBB. The joint distance is grown
/// incrementally: the Cholesky factor L of the hypothesis' innovation covariance and
/// y = L^-1 v are extended by one 2-row block per pairing (O(k^2) per node, no re-inversion),
/// and D^2 = |y|^2. Buffers are kept between scans.
class JointCompatibilitySearch {
 public:
  void setOptions(const JcbbOptions& options);
  const JcbbOptions& options() const { return options_; }

  /// Searches over the individually compatible pairs of `table`. Returns choice[i] = state-order
  /// landmark index or -1, one per observation; each landmark at most once.
  const std::vector<int>& run(const AssociationContext& ctx, const GatingTable& table);
  const JcbbStats& stats() const { return stats_; }

 private:
  void search(int level, int k, double d2);
  bool canImprove(int max_pairings, double d2) const;

  JcbbOptions options_;
  Chi2Table chi2_{0.95, 64};

  // Per-run state.
  const AssociationContext* ctx_ = nullptr;
  const GatingTable* table_ = nullptr;
  std::vector<int> active_;    // observations with at least one compatible landmark
  std::vector<char> used_;     // per candidate (GatedPair::local): in the hypothesis
  std::vector<int> pair_obs_;  // pairings of the current hypothesis, in tree order
  std::vector<int> pair_lm_;
  std::vector<int> current_;  // per observation: landmark index or -1
  std::vector<int> best_;
  int best_k_ = 0;
  double best_d2_ = 0.0;
  Eigen::MatrixXd L_;  // lower Cholesky factor, top-left 2k x 2k in use
  Eigen::VectorXd y_;  // L^-1 v, first 2k in use
  Eigen::MatrixXd B_;  // scratch: cross-covariance of a new pairing, 2k x 2
  JcbbStats stats_;
};

class JCBB : public DataAssociation {
 public:
  void configure(const ParameterSource& params) override;
  std::string name() const override { return "JCBB"; }
  AssociationResult associate(const AssociationContext& ctx) override;
  void reset() override { budget_exhaustions_ = 0; }

  const GatingParameters& gating() const { return gating_; }
  const JcbbOptions& options() const { return search_.options(); }
  /// Statistics of the last associate() call.
  const JcbbStats& lastStats() const { return search_.stats(); }
  /// How many associate() calls hit the node budget since configure()/reset().
  std::size_t budgetExhaustions() const { return budget_exhaustions_; }

 private:
  GatingParameters gating_;
  JointCompatibilitySearch search_;
  GatingTable table_;
  std::size_t budget_exhaustions_ = 0;
};

}  // namespace ekf_slam
