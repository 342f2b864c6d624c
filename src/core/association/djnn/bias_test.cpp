#include "ekf_slam/core/association/djnn/bias_test.h"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>

#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {

namespace {
constexpr int kMaxPairings = 1000000;
constexpr std::size_t kScaleScans = 100;  // scans the consistency scale remembers
}  // namespace

void BiasTest::read(const ParameterReader& r) {
  const Params def;
  p_.bias_test = r.flag("bias_test", def.bias_test);
  p_.bias_probability = r.probability("bias_probability", def.bias_probability);
  p_.bias_window = r.inRange("bias_window", def.bias_window, 1.0, 1.0e6);
  p_.bias_min_pairings = r.integer("bias_min_pairings", def.bias_min_pairings, 1, kMaxPairings);
  p_.bias_keep_pairings = r.integer("bias_keep_pairings", def.bias_keep_pairings, 0, kMaxPairings);
  p_.bias_consistency_scale = r.flag("bias_consistency_scale", def.bias_consistency_scale);
}

void BiasTest::configure() {
  gate_ = chi2Quantile(p_.bias_probability, 2);
  decay_ = 1.0 - 1.0 / p_.bias_window;
}

void BiasTest::test(const AssociationContext& ctx, LocalScan* scan, AssociationResult* result,
                    DjnnPaper* paper, DjnnStats* stats) {
  if (!p_.bias_test) return;
  const int m = scan->observations();
  // Every pairing's discounted sum first, then the scale they share, then the decisions.
  stat_.assign(m, -1.0);
  stat_sorted_.clear();
  for (int i = 0; i < m; ++i) {
    const int k = scan->assign[i];
    if (k < 0) continue;
    stat_[i] = accumulate(ctx, i, scan->cand[k]);
    if (stat_[i] >= 0.0) stat_sorted_.push_back(stat_[i]);
  }
  if (p_.bias_consistency_scale && stat_sorted_.size() >= 3) {
    std::nth_element(stat_sorted_.begin(), stat_sorted_.begin() + stat_sorted_.size() / 2,
                     stat_sorted_.end());
    // The median over the last kScaleScans scans: a persistent over-confidence, not a burst of
    // wrong pairings (a kidnap before it is noticed), which the test must still see.
    const double ratio = stat_sorted_[stat_sorted_.size() / 2] / (2.0 * std::log(2.0));
    if (ratios_.size() < kScaleScans) ratios_.resize(kScaleScans);
    ratios_[scans_ % kScaleScans] = ratio;
    ++scans_;
    window_.assign(ratios_.begin(), ratios_.begin() + std::min<std::size_t>(scans_, kScaleScans));
    std::nth_element(window_.begin(), window_.begin() + window_.size() / 2, window_.end());
    scale_ = std::max(1.0, window_[window_.size() / 2]);
  }
  for (int i = 0; i < m; ++i) {
    const int k = scan->assign[i];
    if (k < 0 || !(stat_[i] > gate_ * scale_)) continue;
    const LandmarkId id = ctx.landmarkId(scan->cand[k]);
    result->decision[i] = Decision::kRejected;
    result->landmark[i] = kNoLandmark;
    scan->assign[i] = -1;
    scan->gated[i] = 1;
    scan->count[k] = 0;
    Bias& b = bias_[id];
    if (p_.bias_keep_pairings > 0 && b.pairings >= p_.bias_keep_pairings) {
      // Established by many unbiased pairings: something moving past it, not the landmark.
      b = Bias();
      b.pairings = p_.bias_keep_pairings;
      ++stats->biased_kept;
      continue;
    }
    result->remove.push_back(id);
    paper->forget(id);
    bias_.erase(id);
    ++stats->removed;
    ++stats->biased_removed;
  }
}

// The innovation v of a static landmark in a consistent filter is white with covariance S, so a
// discounted sum of them stays within chi2(2); a landmark dragged along by a mover sees the
// mover's displacement in every innovation. Summed in the world frame (G = d(position)/dz = H_m^-1)
// because the sensor frame turns between scans. Where the filter is over-confident (far
// landmarks under wide bearing noise, seed 004's worlds) every landmark's sum leaves chi2(2)
// alike, and the test would remove true landmarks: the median statistic of a scan's pairings
// (robust to the few a mover spoils) over chi2(2)'s median, 2 ln 2, measures that, and its
// median over the last 100 scans (at least 1) scales the gate.
double BiasTest::accumulate(const AssociationContext& ctx, int obs, int j) {
  const AssociationContext::Individual ind = ctx.individual(obs, j);
  Matrix23d G_pose;
  Eigen::Matrix2d G_obs;
  const Observation& o = ctx.observations()[obs];
  ctx.model().inverse(ctx.robotPose(), o.z, o.kind, &G_pose, &G_obs);
  Bias& b = bias_[ctx.landmarkId(j)];
  b.sum = decay_ * b.sum + G_obs * ind.v;
  b.cov = (decay_ * decay_) * b.cov + G_obs * ind.S * G_obs.transpose();
  ++b.pairings;
  if (b.pairings < p_.bias_min_pairings) return -1.0;
  return b.sum.dot(b.cov.inverse() * b.sum);
}

void BiasTest::sweep(const EkfSlam& ekf) {
  if (bias_.size() > 2 * ekf.numLandmarks() + 64) {
    for (auto it = bias_.begin(); it != bias_.end();) {
      it = ekf.contains(it->first) ? std::next(it) : bias_.erase(it);
    }
  }
}

}  // namespace ekf_slam
