// Joint Compatibility Branch and Bound (Neira & Tardos 2001; seed 003 section 2.1).
#include "ekf_slam/core/association/jcbb.h"

#include <climits>
#include <cmath>

namespace ekf_slam {

void JcbbOptions::read(const ParameterReader& reader, bool default_prefer_least_distance) {
  joint_probability = reader.probability("joint_probability", 0.95);
  max_nodes = reader.integer("max_nodes", 100000, 1, INT_MAX);
  prefer_least_distance = reader.flag("prefer_least_distance", default_prefer_least_distance);
}

void JointCompatibilitySearch::setOptions(const JcbbOptions& options) {
  options_ = options;
  chi2_ = Chi2Table(options.joint_probability, 64);
}

bool JointCompatibilitySearch::canImprove(int max_pairings, double d2) const {
  // Bound: a branch that cannot reach more pairings than the best (or, with the seed 003
  // criterion, as many at a smaller D^2, which only grows along a branch) is pruned.
  if (max_pairings > best_k_) return true;
  return options_.prefer_least_distance && max_pairings == best_k_ && d2 < best_d2_;
}

const std::vector<int>& JointCompatibilitySearch::run(const AssociationContext& ctx,
                                                      const GatingTable& table) {
  ctx_ = &ctx;
  table_ = &table;
  stats_ = JcbbStats();
  const int m = static_cast<int>(ctx.numObservations());
  // Observations without any compatible landmark are unpaired in every hypothesis: leaving them
  // out of the tree changes nothing but the depth. The tree order is the observation order.
  active_.clear();
  for (int i = 0; i < m; ++i) {
    if (!table.compatible(i).empty()) active_.push_back(i);
  }
  const int na = static_cast<int>(active_.size());
  used_.assign(table.candidates().size(), 0);
  current_.assign(m, -1);
  best_ = current_;
  best_k_ = 0;
  best_d2_ = 0.0;
  pair_obs_.resize(na);
  pair_lm_.resize(na);
  if (L_.rows() < 2 * na) {
    L_.resize(2 * na, 2 * na);
    y_.resize(2 * na);
    B_.resize(2 * na, 2);
  }
  if (na > 0) search(0, 0, 0.0);
  stats_.pairings = best_k_;
  stats_.joint_distance = best_d2_;
  ctx_ = nullptr;
  table_ = nullptr;
  return best_;
}

void JointCompatibilitySearch::search(int level, int k, double d2) {
  if (++stats_.nodes > static_cast<std::size_t>(options_.max_nodes)) {
    stats_.budget_exhausted = true;
    return;
  }
  const int na = static_cast<int>(active_.size());
  if (level == na) return;
  const int obs = active_[level];
  const int n = 2 * k;
  const int remaining_after = na - level - 1;  // each of them has a candidate

  for (const GatedPair& g : table_->compatible(obs)) {
    if (!canImprove(k + 1 + remaining_after, d2)) break;
    if (used_[g.local]) continue;  // a landmark at most once per hypothesis

    // Extend the joint covariance by the new pairing: C = [S_H, B; B^T, S_ij], with B the
    // cross-covariance through pose and map. With S_H = L L^T, the new factor rows are
    // [ (L^-1 B)^T, chol(S_ij - (L^-1 B)^T (L^-1 B)) ] and D^2 grows by |y_c|^2.
    auto B = B_.topRows(n);
    for (int a = 0; a < k; ++a) {
      B_.block<2, 2>(2 * a, 0) =
          ctx_->innovationCovariance(pair_obs_[a], pair_lm_[a], obs, g.landmark);
    }
    if (n > 0) L_.topLeftCorner(n, n).triangularView<Eigen::Lower>().solveInPlace(B);
    Eigen::Matrix2d schur = g.S;
    Eigen::Vector2d r = g.v;
    if (n > 0) {
      schur.noalias() -= B.transpose() * B;
      r.noalias() -= B.transpose() * y_.head(n);
    }
    const double l00_sq = schur(0, 0);
    if (!(l00_sq > 0.0)) continue;
    const double l00 = std::sqrt(l00_sq);
    const double l10 = 0.5 * (schur(1, 0) + schur(0, 1)) / l00;
    const double l11_sq = schur(1, 1) - l10 * l10;
    if (!(l11_sq > 0.0)) continue;
    const double l11 = std::sqrt(l11_sq);
    const double y0 = r(0) / l00;
    const double y1 = (r(1) - l10 * y0) / l11;
    const double d2_new = d2 + y0 * y0 + y1 * y1;
    if (!(d2_new <= chi2_(2 * (k + 1)))) continue;  // joint compatibility, seed 003 eq. 7

    if (n > 0) L_.block(n, 0, 2, n) = B.transpose();
    L_(n, n) = l00;
    L_(n, n + 1) = 0.0;
    L_(n + 1, n) = l10;
    L_(n + 1, n + 1) = l11;
    y_(n) = y0;
    y_(n + 1) = y1;
    used_[g.local] = 1;
    pair_obs_[k] = obs;
    pair_lm_[k] = g.landmark;
    current_[obs] = g.landmark;
    // Every node is itself a valid hypothesis (the rest unpaired), so the best is recorded here;
    // this equals recording at the leaves and gives the budget fallback a useful answer.
    if (k + 1 > best_k_ ||
        (options_.prefer_least_distance && k + 1 == best_k_ && d2_new < best_d2_)) {
      best_ = current_;
      best_k_ = k + 1;
      best_d2_ = d2_new;
    }
    search(level + 1, k + 1, d2_new);
    used_[g.local] = 0;
    current_[obs] = -1;
    if (stats_.budget_exhausted) return;
  }
  // The star branch: observation `obs` unpaired.
  if (canImprove(k + remaining_after, d2)) search(level + 1, k, d2);
}

void JCBB::configure(const ParameterSource& params) {
  const ParameterReader reader(params);
  gating_.read(reader);
  JcbbOptions options;
  options.read(reader, /*default_prefer_least_distance=*/false);
  search_.setOptions(options);
  budget_exhaustions_ = 0;
}

AssociationResult JCBB::associate(const AssociationContext& ctx) {
  table_.build(ctx, gating_);
  const std::vector<int>& choice = search_.run(ctx, table_);
  if (search_.stats().budget_exhausted) ++budget_exhaustions_;
  AssociationResult result;
  applyHypothesis(ctx, table_, gating_, choice, &result);
  return result;
}

}  // namespace ekf_slam
