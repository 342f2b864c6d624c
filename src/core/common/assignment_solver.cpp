// Shortest augmenting paths with dual potentials, O(rows^2 cols).
#include "ekf_slam/core/common/assignment_solver.h"

#include <limits>

namespace ekf_slam {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

double AssignmentSolver::solve(const Eigen::MatrixXd& cost, std::vector<int>* row_to_col) {
  const int n = static_cast<int>(cost.rows());
  const int m = static_cast<int>(cost.cols());
  row_to_col->assign(n, -1);
  if (n == 0) return 0.0;
  if (n > m) return kInf;
  // 1-based columns with column 0 as the virtual start of each augmenting path; u, v are the
  // dual potentials (u_i + v_j <= c_ij), col_owner_[j] the row holding column j (1-based, 0 none).
  u_.assign(n + 1, 0.0);
  v_.assign(m + 1, 0.0);
  col_owner_.assign(m + 1, 0);
  way_.assign(m + 1, 0);
  for (int row = 1; row <= n; ++row) {
    // Dijkstra on reduced costs from `row` until a free column is reached.
    col_owner_[0] = row;
    int j0 = 0;
    min_slack_.assign(m + 1, kInf);
    visited_.assign(m + 1, 0);
    do {
      visited_[j0] = 1;
      const int i0 = col_owner_[j0];
      double delta = kInf;
      int j1 = -1;
      for (int j = 1; j <= m; ++j) {
        if (visited_[j]) continue;
        const double c = cost(i0 - 1, j - 1);
        if (c < kInf) {
          const double reduced = c - u_[i0] - v_[j];
          if (reduced < min_slack_[j]) {
            min_slack_[j] = reduced;
            way_[j] = j0;
          }
        }
        if (min_slack_[j] < delta) {
          delta = min_slack_[j];
          j1 = j;
        }
      }
      if (j1 < 0) {  // every reachable column is forbidden: no complete finite assignment
        row_to_col->assign(n, -1);
        return kInf;
      }
      for (int j = 0; j <= m; ++j) {
        if (visited_[j]) {
          u_[col_owner_[j]] += delta;
          v_[j] -= delta;
        } else {
          min_slack_[j] -= delta;
        }
      }
      j0 = j1;
    } while (col_owner_[j0] != 0);
    // Flip the augmenting path.
    do {
      const int j1 = way_[j0];
      col_owner_[j0] = col_owner_[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  double total = 0.0;
  for (int j = 1; j <= m; ++j) {
    if (col_owner_[j] != 0) {
      (*row_to_col)[col_owner_[j] - 1] = j - 1;
      total += cost(col_owner_[j] - 1, j - 1);
    }
  }
  return total;
}

}  // namespace ekf_slam
