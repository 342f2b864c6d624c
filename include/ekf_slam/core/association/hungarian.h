// Optimal one-to-one assignment on gated Mahalanobis costs, the Hungarian baseline of seed 004
// (Gamallo et al.; ALGORITHMS.md section 7): observations x (candidate landmarks + one dummy
// "unpaired" column per observation). A pairing costs M_ij when M_ij <= chi2(2, p) and is
// forbidden otherwise; leaving observation i unpaired costs the gate chi2(2, p) (its own dummy).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/association/gating.h"
#include "ekf_slam/core/common/assignment_solver.h"

namespace ekf_slam {

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
