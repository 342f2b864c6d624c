// Shared gating, new-landmark policy and mutual exclusion for the gated associators.
#include "ekf_slam/core/association/gating.h"

#include <algorithm>
#include <limits>

#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {
namespace {

// Position of landmark `index` in the sorted candidate list.
int localIndex(const std::vector<int>& candidates, int index) {
  const auto it = std::lower_bound(candidates.begin(), candidates.end(), index);
  return static_cast<int>(it - candidates.begin());
}

}  // namespace

void GatingParameters::read(const ParameterReader& reader, double individual_default) {
  individual_probability = reader.probability("individual_probability", individual_default);
  individual_gate = chi2Quantile(individual_probability, 2);
  candidate_margin = reader.nonNegative("candidate_margin", 5.0);
  new_landmark_probability = reader.probability("new_landmark_probability", 0.9999);
  if (new_landmark_probability < individual_probability) {
    reader.fail("new_landmark_probability",
                "must be >= individual_probability (a new landmark inside the pairing gate of "
                "an existing one would duplicate it)");
  }
  new_landmark_gate = chi2Quantile(new_landmark_probability, 2);
}

void GatingTable::build(const AssociationContext& ctx, const GatingParameters& params) {
  num_obs_ = ctx.numObservations();
  candidates_ = ctx.candidateLandmarks(params.candidate_margin);
  if (compatible_.size() < num_obs_) compatible_.resize(num_obs_);
  min_mahalanobis_.assign(num_obs_, std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < num_obs_; ++i) {
    std::vector<GatedPair>& list = compatible_[i];
    list.clear();
    for (std::size_t c = 0; c < candidates_.size(); ++c) {
      const int j = candidates_[c];
      const AssociationContext::Individual ind = ctx.individual(static_cast<int>(i), j);
      min_mahalanobis_[i] = std::min(min_mahalanobis_[i], ind.mahalanobis);
      if (!(ind.mahalanobis <= params.individual_gate)) continue;
      list.push_back(GatedPair{j, static_cast<int>(c), ind.mahalanobis,
                               ind.mahalanobis + ind.log_det_S, ind.v, ind.S});
    }
    // Candidates are in ascending index order, so a stable sort breaks ties by index.
    std::stable_sort(list.begin(), list.end(),
                     [](const GatedPair& a, const GatedPair& b) { return a.score < b.score; });
  }
}

void applyHypothesis(const AssociationContext& ctx, const GatingTable& table,
                     const GatingParameters& params, const std::vector<int>& choice,
                     AssociationResult* result) {
  const std::size_t m = ctx.numObservations();
  result->resize(m);
  for (std::size_t i = 0; i < m; ++i) {
    if (choice[i] >= 0) {
      result->pair(i, ctx.landmarkId(choice[i]));
    } else {
      result->decision[i] = unpairedDecision(table.minMahalanobis(static_cast<int>(i)), params);
    }
  }
}

int countInterfering(const GatingTable& table, const std::vector<int>& choice,
                     std::vector<int>* counts) {
  const std::vector<int>& cand = table.candidates();
  counts->assign(cand.size(), 0);
  for (int j : choice) {
    if (j >= 0) ++(*counts)[localIndex(cand, j)];
  }
  int interfering = 0;
  for (int j : choice) {
    if (j >= 0 && (*counts)[localIndex(cand, j)] > 1) ++interfering;
  }
  return interfering;
}

void exclusiveNearestNeighbour(const GatingTable& table, std::vector<int>* choice) {
  // Iterated like DJNN's interference rule (seed 000 section 3.2, without the innovation
  // correction): each contested landmark stays with its least-score claimant; the others retry
  // NN on the landmarks nobody holds; repeat until no landmark is claimed twice. The set of held
  // landmarks only grows, so this ends after at most #candidates rounds.
  const std::vector<int>& cand = table.candidates();
  const int m = static_cast<int>(choice->size());
  std::vector<int> holder(cand.size(), -1);  // observation holding each candidate, -1 none
  std::vector<double> score(m, 0.0);         // score of each observation's current choice
  std::vector<char> taken(cand.size(), 0);
  auto scoreOf = [&](int i, int j) {
    for (const GatedPair& g : table.compatible(i)) {
      if (g.landmark == j) return g.score;
    }
    return std::numeric_limits<double>::infinity();
  };
  for (int i = 0; i < m; ++i) {
    if ((*choice)[i] >= 0) score[i] = scoreOf(i, (*choice)[i]);
  }
  for (;;) {
    std::fill(holder.begin(), holder.end(), -1);
    bool contested = false;
    std::vector<int> losers;
    for (int i = 0; i < m; ++i) {
      const int j = (*choice)[i];
      if (j < 0) continue;
      const int c = localIndex(cand, j);
      taken[c] = 1;
      const int h = holder[c];
      if (h < 0) {
        holder[c] = i;
      } else {
        contested = true;
        // Least score wins; on a tie the earlier observation keeps it.
        if (score[i] < score[h]) {
          holder[c] = i;
          losers.push_back(h);
        } else {
          losers.push_back(i);
        }
      }
    }
    if (!contested) return;
    for (int i : losers) {
      (*choice)[i] = -1;
      for (const GatedPair& g : table.compatible(i)) {
        if (!taken[g.local]) {
          (*choice)[i] = g.landmark;
          score[i] = g.score;
          break;
        }
      }
    }
  }
}

}  // namespace ekf_slam
