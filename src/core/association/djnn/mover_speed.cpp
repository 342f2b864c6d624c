#include "ekf_slam/core/association/djnn/mover_speed.h"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>

namespace ekf_slam {

void MoverSpeed::read(const ParameterReader& r) {
  const Params def;
  p_.learn_mover_speed = r.flag("learn_mover_speed", def.learn_mover_speed);
  p_.mover_speed_samples = r.integer("mover_speed_samples", def.mover_speed_samples, 1, 1000000);
  p_.mover_wait_budget = r.inRange("mover_wait_budget", def.mover_wait_budget, 0.0, 0.5);
}

void MoverSpeed::configure(double tentative_timeout) {
  window_ = std::max(0.0, tentative_timeout);
  reset();
}

void MoverSpeed::reset() {
  pending_.clear();
  admitted_.clear();
  in_window_.clear();
  mover_speeds_.clear();
  window_speeds_.clear();
  learned_ = 0.0;
  bound_ = 0.0;
}

double MoverSpeed::speed() const { return learned_ > 0.0 ? std::max(learned_, bound_) : 0.0; }

void MoverSpeed::beginScan(int m) {
  if (!on()) return;
  pending_.assign(m, Admitted());
  for (Admitted& a : pending_) a.resolved_speed = -1.0;
}

void MoverSpeed::admitting(int obs, const Tentative& t, const StaticTest& test) {
  if (!on() || obs < 0 || obs >= static_cast<int>(pending_.size())) return;
  Admitted& a = pending_[obs];
  a.resolved_speed = test.resolvedSpeed(t);
  a.track_info = t.track_info;
  a.first_seen = t.first_seen;
}

void MoverSpeed::landmarkAdded(int obs, LandmarkId id) {
  if (!on() || obs < 0 || obs >= static_cast<int>(pending_.size())) return;
  if (pending_[obs].resolved_speed < 0.0) return;
  admitted_[id] = pending_[obs];
  if (window_ > 0.0 && p_.mover_wait_budget > 0.0) in_window_.push_back(id);
}

void MoverSpeed::scanDone(const AssociationContext& ctx, const AssociationResult& result,
                          const std::vector<int>& cand, double gate, int admit_evidence,
                          const StaticTest& test) {
  if (admitted_.empty()) return;
  const EkfSlam& ekf = ctx.ekf();
  for (std::size_t i = 0; i < result.decision.size(); ++i) {
    if (result.decision[i] != Decision::kPaired) continue;
    const auto it = admitted_.find(result.landmark[i]);
    if (it == admitted_.end()) continue;
    Admitted& a = it->second;
    ++a.pairings;
    if (!a.in_window) continue;
    // Only the information of the track counts (how well it would have resolved a velocity),
    // which needs the sighting's noise, not where it lies.
    const Observation& o = ctx.observations()[i];
    Matrix23d G;
    Eigen::Matrix2d C;
    ctx.sightingPosition(ctx.robotPose(), o.z, o.R, o.kind, &G, &C);
    StaticTest::addToTrack(&a.track_info, nullptr, Eigen::Vector2d::Zero(), C, ctx.stamp(),
                           a.first_seen);
  }

  for (LandmarkId id : result.remove) {
    const auto it = admitted_.find(id);
    if (it == admitted_.end()) continue;
    const Admitted a = it->second;
    admitted_.erase(it);
    // Established (paired as often as it took to admit it): a landmark, whatever removed it.
    if (a.pairings >= admit_evidence) continue;
    // Beside another landmark it was a duplicate of that one, not something that left.
    const int k = ekf.indexOf(id);
    if (k < 0) continue;
    bool duplicate = false;
    for (int j : cand) {
      if (j == k) continue;
      const Eigen::Vector2d d = ekf.landmark(k) - ekf.landmark(j);
      const Eigen::Matrix2d S = ekf.landmarkCovariance(k) + ekf.landmarkCovariance(j);
      duplicate = duplicate || d.dot(S.inverse() * d) <= gate;
    }
    if (!duplicate) moverLeft(a.resolved_speed);
  }

  // Windows that ended this scan (removed landmarks leave no sample: they were not mapped).
  std::size_t kept = 0;
  for (LandmarkId id : in_window_) {
    const auto it = admitted_.find(id);
    if (it == admitted_.end()) continue;
    if (ctx.stamp() - it->second.first_seen <= window_) {
      in_window_[kept++] = id;
      continue;
    }
    it->second.in_window = false;
    windowEnded(test.resolvedSpeed(it->second.track_info));
  }
  in_window_.resize(kept);
}

void MoverSpeed::moverLeft(double speed) {
  if (!std::isfinite(speed)) return;
  mover_speeds_.push_back(speed);
  if (static_cast<int>(mover_speeds_.size()) < p_.mover_speed_samples) return;
  // A mover that passed the test at resolved speed r moved slower than about r, anywhere below
  // it: half of it is its speed's middle. The median over movers: features pieced together from
  // several passes over tens of seconds resolve almost nothing and must not alone set the wait.
  std::vector<double> sorted = mover_speeds_;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  learned_ = 0.5 * sorted[sorted.size() / 2];
}

void MoverSpeed::windowEnded(double speed) {
  window_speeds_.push_back(speed);
  // The (1 - budget) quantile: the least speed that all but the budget's share of the windows
  // resolved. It needs 1 / budget windows to say anything.
  const double keep = 1.0 - p_.mover_wait_budget;
  const std::size_t n = window_speeds_.size();
  if (static_cast<double>(n) * p_.mover_wait_budget < 1.0 - 1e-9) return;
  const std::size_t k = std::min(
      n - 1, static_cast<std::size_t>(std::ceil(keep * static_cast<double>(n) - 1e-9)) - 1);
  std::vector<double> sorted = window_speeds_;
  std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
  bound_ = sorted[k];
}

}  // namespace ekf_slam
