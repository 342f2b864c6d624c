#include "ekf_slam/core/association/djnn/shift_test.h"

#include <limits>
#include <utility>

#include "ekf_slam/core/association/joint_ml.h"

namespace ekf_slam {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

void ShiftTest::read(const ParameterReader& r) {
  const Params def;
  p_.shift_test = r.flag("shift_test", def.shift_test);
  p_.shift_margin = r.nonNegative("shift_margin", def.shift_margin);
}

double ShiftTest::jointCost(const AssociationContext& ctx, const LocalScan& scan,
                            const std::vector<int>& h, double gate) {
  std::vector<std::pair<int, int>> pairs;
  double cost = 0.0;
  for (int i = 0; i < static_cast<int>(h.size()); ++i) {
    if (scan.assign[i] < 0) continue;  // not part of the scan's pairing
    if (h[i] >= 0) {
      pairs.emplace_back(i, scan.cand[h[i]]);
    } else {
      // Left unpaired: charged as a pairing at the edge of the gate.
      cost += gate + ctx.individual(i, scan.cand[scan.assign[i]]).log_det_S;
    }
  }
  return cost + jointInnovationCost(ctx, pairs);
}

void ShiftTest::apply(const AssociationContext& ctx, double gate, double candidate_gate,
                      LocalScan* scan, DjnnStats* stats) const {
  if (!p_.shift_test) return;
  std::vector<int>& assign = scan->assign;
  const std::vector<int>& cand = scan->cand;
  const int m = static_cast<int>(assign.size());
  const int n = static_cast<int>(cand.size());
  const EkfSlam& ekf = ctx.ekf();
  int paired = 0;
  for (int a : assign) paired += a >= 0;
  if (paired == 0) return;
  const double base = jointCost(ctx, *scan, assign, gate);
  double best = kInf;
  std::vector<int> best_h, h(m);
  std::vector<Eigen::Vector2d> tried;
  for (int i = 0; i < m; ++i) {
    if (assign[i] < 0) continue;
    for (int c = 0; c < n; ++c) {
      if (c == assign[i] || ctx.individual(i, cand[c]).mahalanobis > candidate_gate) continue;
      const Eigen::Vector2d d = ekf.landmark(cand[c]) - ekf.landmark(cand[assign[i]]);
      bool seen = false;
      for (const Eigen::Vector2d& t : tried) seen = seen || (t - d).norm() < 1e-6;
      if (seen) continue;
      tried.push_back(d);
      std::vector<char> used(n, 0);
      for (int k = 0; k < m; ++k) {
        h[k] = -1;
        if (assign[k] < 0) continue;
        const Eigen::Vector2d target = ekf.landmark(cand[assign[k]]) + d;
        double nearest = kInf;
        for (int c2 = 0; c2 < n; ++c2) {
          if (used[c2] || ctx.individual(k, cand[c2]).mahalanobis > candidate_gate) continue;
          const double dist = (ekf.landmark(cand[c2]) - target).squaredNorm();
          if (dist < nearest) {
            nearest = dist;
            h[k] = c2;
          }
        }
        if (h[k] >= 0) used[h[k]] = 1;
      }
      if (h == assign) continue;
      const double cost = jointCost(ctx, *scan, h, gate);
      if (cost < best) {
        best = cost;
        best_h = h;
      }
    }
  }
  if (best_h.empty() || best > base + p_.shift_margin) return;  // the pairing stands out
  if (best < base - p_.shift_margin) {
    assign = best_h;  // a shift is clearly likelier
    ++stats->shifts_taken;
    return;
  }
  // Both likely: the pairings that differ are not decided on this scan.
  for (int i = 0; i < m; ++i) {
    if (assign[i] >= 0 && best_h[i] != assign[i]) {
      assign[i] = -1;
      scan->gated[i] = 1;
    }
  }
  ++stats->shifts_ambiguous;
}

}  // namespace ekf_slam
