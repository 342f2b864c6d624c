// Individual-compatibility nearest neighbour (seed 000 section 2, eq. 4-5).
#include "ekf_slam/core/association/nn.h"

#include <limits>

namespace ekf_slam {

int nearestNeighbour(const AssociationContext& ctx, int obs, const std::vector<int>& candidates,
                     double gate, const std::vector<char>* taken,
                     AssociationContext::Individual* best) {
  int best_j = -1;
  double best_score = std::numeric_limits<double>::infinity();
  for (int j : candidates) {
    if (taken && (*taken)[j]) continue;
    const AssociationContext::Individual ind = ctx.individual(obs, j);
    if (!(ind.mahalanobis <= gate)) continue;  // eq. 4
    // eq. 5: the likelihood-based distance, penalising landmarks with a large innovation
    // covariance that would otherwise win on M_ij alone. Strict < keeps the lowest index on ties.
    const double score = ind.mahalanobis + ind.log_det_S;
    if (score < best_score) {
      best_score = score;
      best_j = j;
      if (best) *best = ind;
    }
  }
  return best_j;
}

void NN::configure(const ParameterSource& params) {
  const ParameterReader reader(params);
  gating_.read(reader);
  mutual_exclusion_ = reader.flag("mutual_exclusion", false);
}

AssociationResult NN::associate(const AssociationContext& ctx) {
  // The table holds, per observation, the gated landmarks sorted by the eq. 5 score, so its first
  // entry is exactly nearestNeighbour() over the same candidates.
  table_.build(ctx, gating_);
  const int m = static_cast<int>(ctx.numObservations());
  choice_.assign(m, -1);
  for (int i = 0; i < m; ++i) {
    const auto& list = table_.compatible(i);
    if (!list.empty()) choice_[i] = list.front().landmark;
  }
  if (mutual_exclusion_) exclusiveNearestNeighbour(table_, &choice_);
  AssociationResult result;
  applyHypothesis(ctx, table_, gating_, choice_, &result);
  return result;
}

}  // namespace ekf_slam
