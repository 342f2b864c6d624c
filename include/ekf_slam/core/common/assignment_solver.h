// Optimal one-to-one assignment (Kuhn-Munkres), shared by the Hungarian associator and the RRW&SC
// graph matcher.
#pragma once

#include <vector>

#include <Eigen/Core>

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

}  // namespace ekf_slam
