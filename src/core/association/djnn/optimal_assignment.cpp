#include "ekf_slam/core/association/djnn/optimal_assignment.h"

#include <cmath>
#include <cstddef>
#include <limits>

#include "ekf_slam/core/association/joint_ml.h"

namespace ekf_slam {

void OptimalAssignment::read(const ParameterReader& r) {
  p_.optimal_assignment = r.flag("optimal_assignment", Params().optimal_assignment);
  p_.assign_unpaired = r.flag("assign_unpaired", Params().assign_unpaired);
}

void OptimalAssignment::apply(const AssociationContext& ctx, const DjnnPaper& paper,
                              double null_cost, LocalScan* scan, DjnnStats* stats) {
  if (!p_.optimal_assignment) return;
  const int n = scan->candidates();
  // eq. 5's score of observation i with candidate c, +inf outside the paper's gate.
  constexpr double kForbidden = std::numeric_limits<double>::infinity();
  const auto score = [&](int i, int c) {
    double mahalanobis = 0.0, s = 0.0;
    if (scan->have_table) {
      s = paper.score(*scan, i, c, scan->v_bar, &mahalanobis);
    } else {
      const AssociationContext::Individual ind = ctx.individual(i, scan->cand[c]);
      mahalanobis = ind.mahalanobis;
      s = mahalanobis + ind.log_det_S;  // eq. 5
    }
    return mahalanobis <= paper.gate() ? s : kForbidden;
  };
  rows_.clear();
  for (int i = 0; i < scan->observations(); ++i) {
    if (scan->assign[i] >= 0) rows_.push_back(i);
  }
  const int paired = static_cast<int>(rows_.size());
  // The unpaired observations with a landmark in the gate, once "not in the map" has a cost;
  // their scores are kept for the cost matrix.
  unpaired_scores_.clear();
  if (p_.assign_unpaired && std::isfinite(null_cost)) {
    for (int i = 0; i < scan->observations(); ++i) {
      if (scan->assign[i] >= 0) continue;
      const std::size_t start = unpaired_scores_.size();
      bool gated = false;
      for (int c = 0; c < n; ++c) {
        unpaired_scores_.push_back(score(i, c));
        gated = gated || std::isfinite(unpaired_scores_.back());
      }
      if (gated) {
        rows_.push_back(i);
      } else {
        unpaired_scores_.resize(start);
      }
    }
  }
  const int rows = static_cast<int>(rows_.size());
  const int unpaired = rows - paired;
  // With one pairing, or one landmark, there is nothing to exchange (and, with no unpaired
  // observation in the gate, nothing to add).
  if (unpaired == 0 && (paired < 2 || n < 2)) return;
  // Columns: the candidates, then one "not in the map" per unpaired row (the paired rows stay
  // paired). eq. 5 leaves out -2 ln 2 pi of -2 ln N(v; 0, S); the null's cost does the same.
  const double log_2pi2 = 2.0 * std::log(2.0 * M_PI);
  cost_.setConstant(rows, n + unpaired, kForbidden);
  for (int a = 0; a < paired; ++a) {
    for (int c = 0; c < n; ++c) cost_(a, c) = score(rows_[a], c);
  }
  for (int a = paired; a < rows; ++a) {
    const int k = a - paired;
    for (int c = 0; c < n; ++c) cost_(a, c) = unpaired_scores_[static_cast<std::size_t>(k) * n + c];
    cost_(a, n + k) = unmappedCostAt(null_cost, ctx.observations()[rows_[a]]) - log_2pi2;
  }
  // Where the paper's pairing lies within the gate it is feasible, so the optimum is never worse;
  // where it used the wide gate (case 4) there may be no assignment within the gate, and it stays.
  if (!std::isfinite(solver_.solve(cost_, &row_to_col_))) return;
  for (int a = 0; a < rows; ++a) {
    int& assigned = scan->assign[rows_[a]];
    const int to = row_to_col_[a] < n ? row_to_col_[a] : -1;
    if (a < paired) {
      stats->reassigned += assigned != to;
    } else {
      stats->unpaired_assigned += to >= 0;
    }
    assigned = to;
  }
}

}  // namespace ekf_slam
