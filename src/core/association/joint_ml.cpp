// Joint maximum-likelihood assignment by branch and bound. See joint_ml.h and docs/djnn.md.
#include "ekf_slam/core/association/joint_ml.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/LU>

namespace ekf_slam {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// "Not in the map" for entry k (its own cost when the problem gives one per entry), in the
// entry's measurement space.
double nullCost(const AssociationContext& ctx, const JointMlProblem& p, int k) {
  const double per_m2 = p.null_costs.empty() ? p.null_cost : p.null_costs[k];
  return unmappedCostAt(per_m2, ctx.observations()[p.obs[k]]);
}

// Depth-first search over the observations (fewest options first), each option ordered by its
// individual cost so that good hypotheses are met early and the bound prunes the rest.
class Search {
 public:
  Search(const AssociationContext& ctx, const JointMlProblem& problem)
      : ctx_(ctx), problem_(problem), log_2pi2_(2.0 * std::log(2.0 * M_PI)) {
    const int m = static_cast<int>(problem.obs.size());
    order_.resize(m);
    for (int k = 0; k < m; ++k) order_[k] = k;
    std::stable_sort(order_.begin(), order_.end(), [&](int a, int b) {
      return problem.candidates[a].size() < problem.candidates[b].size();
    });
    options_.resize(m);
    null_.resize(m);
    for (int k = 0; k < m; ++k) null_[k] = nullCost(ctx, problem, k);
    suffix_bound_.assign(m + 1, 0.0);
    for (int d = m - 1; d >= 0; --d) {
      const int k = order_[d];
      const int obs = problem.obs[k];
      std::vector<std::pair<double, Option>> scored{{null_[k], Option{-1, -1, -1, 0.0}}};
      for (int j : problem.candidates[k]) {
        const AssociationContext::Individual ind = ctx.individual(obs, j);
        scored.emplace_back(ind.mahalanobis + ind.log_det_S + log_2pi2_, Option{j, obs, j, 0.0});
      }
      if (!problem.extra.empty()) {
        for (const JointMlExtra& e : problem.extra[k]) {
          const AssociationContext::Individual ind = ctx.individual(e.obs, e.landmark);
          scored.emplace_back(ind.mahalanobis + ind.log_det_S + log_2pi2_ + e.cost,
                              Option{-2 - e.target, e.obs, e.landmark, e.cost});
        }
      }
      std::stable_sort(scored.begin(), scored.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
      for (const auto& s : scored) options_[d].push_back(s.second);
      // A pairing's cost given the others is D^2 + ln|S_cond| + 2 ln 2 pi with S_cond >= R:
      // at least ln|R| + 2 ln 2 pi. "Not in the map" costs null_cost.
      const double det_r = ctx.observations()[obs].R.determinant();
      const double pair_bound = det_r > 0.0 ? std::log(det_r) + log_2pi2_ : -kInf;
      suffix_bound_[d] = suffix_bound_[d + 1] + std::min(null_[k], pair_bound);
    }
  }

  // Least-cost hypothesis below `limit`, with entry `forbid_entry` (or -1) not taking
  // `forbid_value`. Returns false if the node budget ran out.
  bool run(double limit, int forbid_entry, int forbid_value, std::vector<int>* best,
           double* best_cost, std::size_t* nodes) {
    limit_ = limit;
    forbid_entry_ = forbid_entry;
    forbid_value_ = forbid_value;
    found_ = false;
    nodes_ = 0;
    aborted_ = false;
    current_.assign(order_.size(), -1);
    pairs_.clear();
    values_.clear();
    const Eigen::Index rows = 2 * static_cast<Eigen::Index>(order_.size());
    if (L_.rows() < rows) {
      L_.resize(rows, rows);
      y_.resize(rows);
      cross_.resize(rows, 2);
    }
    joint_cost_.assign(order_.size() + 1, 0.0);
    descend(0, 0.0, 0.0, 0.0);
    *nodes += nodes_;
    if (found_) {
      *best = best_;
      *best_cost = limit_;
    }
    return !aborted_;
  }

  bool found() const { return found_; }

 private:
  // `nulls`: the "not in the map" costs taken so far; `charged`: the options' own costs
  // (JointMlExtra::cost).
  void descend(int d, double cost, double nulls, double charged) {
    if (aborted_) return;
    if (++nodes_ > problem_.max_nodes) {
      aborted_ = true;
      return;
    }
    if (!(cost + suffix_bound_[d] < limit_)) return;
    const int m = static_cast<int>(order_.size());
    if (d == m) {
      limit_ = cost;
      best_ = current_;
      found_ = true;
      return;
    }
    const int k = order_[d];
    for (const Option& o : options_[d]) {
      if (k == forbid_entry_ && o.value == forbid_value_) continue;
      current_[k] = o.value;
      if (o.value == -1) {
        const double null = null_[k];
        descend(d + 1, cost + null, nulls + null, charged);
        continue;
      }
      bool used = false;
      for (int v : values_) used = used || v == o.value;
      if (used) continue;
      pairs_.emplace_back(o.obs, o.landmark);
      values_.push_back(o.value);
      const double c = extendJointCost() + log_2pi2_ * static_cast<double>(pairs_.size()) + nulls +
                       charged + o.cost;
      descend(d + 1, c, nulls, charged + o.cost);
      pairs_.pop_back();
      values_.pop_back();
    }
    current_[k] = -1;
  }

  // jointInnovationCost of pairs_, from that of pairs_ without its last pairing: the joint
  // innovation's Cholesky factor L and y = L^-1 v along the search path gain two rows,
  // B = L^-1 C (C the new pairing's covariance with the others), L22 = chol(D - B^T B) and
  // y2 = L22^-1 (v_new - B^T y). O(p^2) per node where building S and factoring it is O(p^3).
  double extendJointCost() {
    const Eigen::Index p = static_cast<Eigen::Index>(pairs_.size()) - 1, r = 2 * p;
    const auto [obs, lm] = pairs_.back();
    const Observation& o = ctx_.observations()[obs];
    const Eigen::Vector2d v =
        RangeBearingModel::innovation(o.z, ctx_.prediction(lm, o.kind).z_hat, o.kind);
    Eigen::Matrix2d D = ctx_.innovationCovariance(obs, lm, obs, lm);
    D = 0.5 * (D + D.transpose()).eval();
    auto B = cross_.topRows(r);
    ctx_.innovationCovariances(pairs_, static_cast<std::size_t>(p), obs, lm, B);
    // B = L^-1 B by forward substitution, column by column of L (contiguous): Eigen's general
    // triangular solver is built for wide right-hand sides and costs most of the search on this
    // two-column one.
    for (Eigen::Index c = 0; c < r; ++c) {
      const double* Lc = L_.col(c).data();
      B(c, 0) /= Lc[c];
      B(c, 1) /= Lc[c];
      const double b0 = B(c, 0), b1 = B(c, 1);
      for (Eigen::Index a = c + 1; a < r; ++a) {
        B(a, 0) -= Lc[a] * b0;
        B(a, 1) -= Lc[a] * b1;
      }
    }
    const Eigen::Matrix2d Sc = D - B.transpose() * B;
    const Eigen::Vector2d w = v - B.transpose() * y_.head(r);
    if (!(Sc(0, 0) > 0.0)) return joint_cost_[p + 1] = kInf;
    const double l00 = std::sqrt(Sc(0, 0)), l10 = Sc(1, 0) / l00;
    const double s11 = Sc(1, 1) - l10 * l10;
    if (!(s11 > 0.0)) return joint_cost_[p + 1] = kInf;
    const double l11 = std::sqrt(s11);
    L_.block(r, 0, 2, r) = B.transpose();
    L_.block<2, 2>(r, r) << l00, 0.0, l10, l11;
    const double y0 = w(0) / l00, y1 = (w(1) - l10 * y0) / l11;
    y_.segment<2>(r) << y0, y1;
    const double c = joint_cost_[p] + y0 * y0 + y1 * y1 + 2.0 * std::log(l00) + 2.0 * std::log(l11);
    return joint_cost_[p + 1] = std::isfinite(c) ? c : kInf;
  }

  /// One option of an entry: its value in the decision (landmark index, -1 for none, -2 - target)
  /// and the pairing it makes (observation and landmark of the context).
  struct Option {
    int value;
    int obs;
    int landmark;
    double cost;  ///< JointMlExtra::cost
  };

  const AssociationContext& ctx_;
  const JointMlProblem& problem_;
  const double log_2pi2_;
  std::vector<int> order_;                    ///< search depth -> entry of problem.obs
  std::vector<std::vector<Option>> options_;  ///< per depth, best first
  std::vector<double> null_;                  ///< per entry: "not in the map" (nullCost)
  std::vector<double> suffix_bound_;          ///< per depth: least cost of the entries from there
  double limit_ = kInf;
  int forbid_entry_ = -1, forbid_value_ = -2;
  bool found_ = false, aborted_ = false;
  std::size_t nodes_ = 0;
  std::vector<int> current_, best_;
  std::vector<std::pair<int, int>> pairs_;
  std::vector<int> values_;  ///< the values of pairs_, for the one-to-one check
  // extendJointCost's factor along the path (rows 2 p, 2 p + 1 for pairs_[p]), the new
  // pairing's cross-covariance, and the joint cost per path length.
  Eigen::MatrixXd L_, cross_;
  Eigen::VectorXd y_;
  std::vector<double> joint_cost_;
};

}  // namespace

double jointInnovationCost(const AssociationContext& ctx,
                           const std::vector<std::pair<int, int>>& pairs) {
  if (pairs.empty()) return 0.0;
  Eigen::VectorXd v;
  Eigen::MatrixXd S;
  ctx.jointInnovation(pairs, &v, &S);
  const Eigen::LLT<Eigen::MatrixXd> llt(S);
  if (llt.info() != Eigen::Success) return kInf;
  double log_det = 0.0;
  for (int k = 0; k < S.rows(); ++k) log_det += 2.0 * std::log(llt.matrixL()(k, k));
  return v.dot(llt.solve(v)) + log_det;
}

double unmappedCostAt(double cost_per_m2, const Observation& o) {
  if (o.kind != MeasurementKind::kRangeBearing) return cost_per_m2;
  // The density r * lambda: -2 ln r on top (a return at the sensor itself has none; floored).
  constexpr double kMinRange = 1e-3;  // [m]
  return cost_per_m2 - 2.0 * std::log(std::max(o.z(0), kMinRange));
}

JointMlDecision jointMaximumLikelihood(const AssociationContext& ctx, const JointMlProblem& problem,
                                       double margin) {
  const int m = static_cast<int>(problem.obs.size());
  JointMlDecision out;
  out.best.assign(m, -1);
  out.alternative_cost.assign(m, kInf);
  out.alternative.assign(m, {});
  out.best_cost = 0.0;  // everything out of the map: always a hypothesis
  for (int k = 0; k < m; ++k) out.best_cost += nullCost(ctx, problem, k);
  if (m == 0) {
    out.complete = true;
    return out;
  }
  Search search(ctx, problem);
  out.complete = search.run(kInf, -1, -2, &out.best, &out.best_cost, &out.nodes);
  if (!out.complete) return out;
  // Each observation's decision against the best hypothesis that decides it otherwise.
  for (int k = 0; k < m; ++k) {
    std::vector<int> alt;
    double cost = kInf;
    if (!search.run(out.best_cost + margin, k, out.best[k], &alt, &cost, &out.nodes)) {
      out.complete = false;
      return out;
    }
    if (search.found()) {
      out.alternative_cost[k] = cost;
      out.alternative[k] = std::move(alt);
    }
  }
  return out;
}

}  // namespace ekf_slam
