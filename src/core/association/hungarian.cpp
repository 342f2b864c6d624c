// Hungarian assignment baseline (seed 004).
#include "ekf_slam/core/association/hungarian.h"

#include <cmath>
#include <limits>

namespace ekf_slam {
namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

void Hungarian::configure(const ParameterSource& params) {
  const ParameterReader reader(params);
  gating_.read(reader);
}

AssociationResult Hungarian::associate(const AssociationContext& ctx) {
  table_.build(ctx, gating_);
  const int m = static_cast<int>(ctx.numObservations());
  choice_.assign(m, -1);

  // Only observations with a gated landmark and landmarks with a gated observation take part;
  // the others are unpaired in every assignment.
  rows_.clear();
  column_of_local_.assign(table_.candidates().size(), -1);
  landmark_of_column_.clear();
  for (int i = 0; i < m; ++i) {
    const auto& list = table_.compatible(i);
    if (list.empty()) continue;
    rows_.push_back(i);
    for (const GatedPair& g : list) {
      if (column_of_local_[g.local] < 0) {
        column_of_local_[g.local] = static_cast<int>(landmark_of_column_.size());
        landmark_of_column_.push_back(g.landmark);
      }
    }
  }
  const int nr = static_cast<int>(rows_.size());
  const int nl = static_cast<int>(landmark_of_column_.size());
  if (nr > 0) {
    cost_.setConstant(nr, nl + nr, kInf);
    for (int r = 0; r < nr; ++r) {
      for (const GatedPair& g : table_.compatible(rows_[r])) {
        cost_(r, column_of_local_[g.local]) = g.mahalanobis;
      }
      cost_(r, nl + r) = gating_.individual_gate;  // its own "unpaired" column
    }
    solver_.solve(cost_, &row_to_col_);
    for (int r = 0; r < nr; ++r) {
      const int c = row_to_col_[r];
      if (c >= 0 && c < nl) choice_[rows_[r]] = landmark_of_column_[c];
    }
  }
  AssociationResult result;
  applyHypothesis(ctx, table_, gating_, choice_, &result);
  return result;
}

}  // namespace ekf_slam
