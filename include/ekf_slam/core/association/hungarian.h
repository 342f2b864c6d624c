// Optimal one-to-one assignment on gated Mahalanobis costs, the Hungarian baseline of seed 004
// (Gamallo et al.; ALGORITHMS.md section 7): observations x (candidate landmarks + one dummy
// "unpaired" column per observation). A pairing costs M_ij when M_ij <= chi2(2, p) and is
// forbidden otherwise; leaving observation i unpaired costs the gate chi2(2, p) (its own dummy).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/gating.h"
#include "ekf_slam/core/association/data_association.h"

namespace ekf_slam {

/// Minimum-cost assignment of every row of a rows x cols cost matrix (rows <= cols) to a distinct
/// column; +inf entries are forbidden. Shortest augmenting paths with dual potentials
/// (Kuhn-Munkres in the Jonker-Volgenant form), O(rows^2 cols). Returns the total cost and fills
/// row_to_col, or returns +inf (row_to_col all -1) when no finite assignment exists.
class AssignmentSolver {
 public:
  double solve(const Eigen::MatrixXd& cost, std::vector<int>* row_to_col);

 private:
  std::vector<double> u_, v_, min_slack_;
  std::vector<int> col_owner_, way_;
  std::vector<char> visited_;
};

/// Parameters: GatingParameters only (the dummy cost is the individual gate).
class Hungarian : public DataAssociation {
 public:
  void configure(const ParameterSource& params) override;
  std::string name() const override { return "Hungarian"; }
  AssociationResult associate(const AssociationContext& ctx) override;
  void reset() override {}

  const GatingParameters& gating() const { return gating_; }

 private:
  GatingParameters gating_;
  GatingTable table_;
  AssignmentSolver solver_;
  Eigen::MatrixXd cost_;
  std::vector<int> rows_, column_of_local_, landmark_of_column_, row_to_col_, choice_;
};

}  // namespace ekf_slam
