#include "ekf_slam/core/association/djnn/optimal_assignment.h"

#include <cmath>
#include <limits>

namespace ekf_slam {

void OptimalAssignment::read(const ParameterReader& r) {
  p_.optimal_assignment = r.flag("optimal_assignment", Params().optimal_assignment);
}

void OptimalAssignment::apply(const AssociationContext& ctx, const DjnnPaper& paper,
                              LocalScan* scan, DjnnStats* stats) {
  if (!p_.optimal_assignment) return;
  rows_.clear();
  for (int i = 0; i < scan->observations(); ++i) {
    if (scan->assign[i] >= 0) rows_.push_back(i);
  }
  const int n = scan->candidates();
  // With one pairing, or one landmark, there is nothing to exchange.
  if (rows_.size() < 2 || n < 2) return;
  constexpr double kForbidden = std::numeric_limits<double>::infinity();
  cost_.resize(static_cast<Eigen::Index>(rows_.size()), n);
  for (std::size_t a = 0; a < rows_.size(); ++a) {
    for (int c = 0; c < n; ++c) {
      double mahalanobis = 0.0, score = 0.0;
      if (scan->have_table) {
        score = paper.score(*scan, rows_[a], c, scan->v_bar, &mahalanobis);
      } else {
        const AssociationContext::Individual ind = ctx.individual(rows_[a], scan->cand[c]);
        mahalanobis = ind.mahalanobis;
        score = mahalanobis + ind.log_det_S;  // eq. 5
      }
      cost_(static_cast<Eigen::Index>(a), c) = mahalanobis <= paper.gate() ? score : kForbidden;
    }
  }
  // Where the paper's pairing lies within the gate it is feasible, so the optimum is never worse;
  // where it used the wide gate (case 4) there may be no assignment within the gate, and it stays.
  if (!std::isfinite(solver_.solve(cost_, &row_to_col_))) return;
  for (std::size_t a = 0; a < rows_.size(); ++a) {
    int& assigned = scan->assign[rows_[a]];
    stats->reassigned += assigned != row_to_col_[a];
    assigned = row_to_col_[a];
  }
}

}  // namespace ekf_slam
