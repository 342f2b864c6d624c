#include "ekf_slam/core/association/djnn/mover_speed.h"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>

namespace ekf_slam {

namespace {
// A P_D of 1 would make one empty look proof: kept finite.
constexpr double kMaxPd = 0.999;
}  // namespace

void MoverSpeed::read(const ParameterReader& r) {
  const Params def;
  p_.learn_mover_speed = r.flag("learn_mover_speed", def.learn_mover_speed);
  p_.mover_speed_samples = r.integer("mover_speed_samples", def.mover_speed_samples, 1, 1000000);
  p_.mover_wait_budget = r.inRange("mover_wait_budget", def.mover_wait_budget, 0.0, 0.5);
  p_.mover_left_odds = r.inRange("mover_left_odds", def.mover_left_odds, 0.0, 1e12);
}

void MoverSpeed::configure(double tentative_timeout) {
  window_ = std::max(0.0, tentative_timeout);
  reset();
}

void MoverSpeed::reset() {
  pending_.clear();
  admitted_.clear();
  in_window_.clear();
  leavers_.clear();
  still_there_ = 0;
  scans_ = 0;
  mover_speeds_.clear();
  window_speeds_.clear();
  learned_ = 0.0;
  bound_ = 0.0;
}

double MoverSpeed::speed() const { return learned_ > 0.0 ? std::max(learned_, bound_) : 0.0; }

void MoverSpeed::beginScan(int m) {
  if (!on()) return;
  ++scans_;
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
                          const DjnnPaper& paper, const LocalScan& scan, int admit_evidence,
                          const StaticTest& test) {
  watchPlaces(ctx, result, paper, scan);
  if (admitted_.empty()) return;
  const EkfSlam& ekf = ctx.ekf();
  const std::vector<int>& cand = scan.cand;
  const double gate = paper.tentativeGate();
  for (std::size_t i = 0; i < result.decision.size(); ++i) {
    if (result.decision[i] != Decision::kPaired) continue;
    const auto it = admitted_.find(result.landmark[i]);
    if (it == admitted_.end()) continue;
    Admitted& a = it->second;
    ++a.pairings;
    a.last_paired = scans_;
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

  countMisses(ctx, paper, scan, admit_evidence);

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
    if (duplicate) continue;
    if (!(p_.mover_left_odds > 0.0)) {
      moverLeft(a.resolved_speed);
      continue;
    }
    // Its place is watched from the next scan on, its looks since its last pairing counted.
    Leaver l;
    l.position = ekf.landmark(k);
    l.covariance = ekf.landmarkCovariance(k);
    l.speed = a.resolved_speed;
    l.removed_at = ctx.stamp();
    l.log_odds = -a.misses * std::log1p(-std::min(paper.detectionProbability(), kMaxPd));
    if (!leftIfSure(l)) leavers_.push_back(l);
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

void MoverSpeed::countMisses(const AssociationContext& ctx, const DjnnPaper& paper,
                             const LocalScan& scan, int admit_evidence) {
  if (!(p_.mover_left_odds > 0.0) || scan.held) return;
  for (int k = 0; k < scan.candidates(); ++k) {
    const auto it = admitted_.find(ctx.landmarkId(scan.cand[k]));
    if (it == admitted_.end() || it->second.pairings >= admit_evidence) continue;
    Admitted& a = it->second;
    // The looks the evidence counter counts a miss for (a hidden landmark was out of view).
    if (a.last_paired == scans_) {
      a.misses = 0;
    } else if (paper.looksAt(ctx, scan, k)) {
      ++a.misses;
    }
  }
}

void MoverSpeed::watchPlaces(const AssociationContext& ctx, const AssociationResult& result,
                             const DjnnPaper& paper, const LocalScan& scan) {
  if (leavers_.empty() || scan.held) return;
  // A look that finds the place empty is 1 / (1 - P_D) times likelier if the object left.
  const double miss = -std::log1p(-std::min(paper.detectionProbability(), kMaxPd));
  const double gate = paper.tentativeGate();
  const Eigen::Vector3d pose = ctx.robotPose();
  const Eigen::Matrix3d P = ctx.ekf().poseCovariance();
  const std::vector<Observation>& obs = ctx.observations();
  std::size_t kept = 0;
  for (Leaver& l : leavers_) {
    if (ctx.stamp() - l.removed_at > window_) continue;  // never decided: no sample
    bool done = false;
    if (paper.inPenaltyRegion(DjnnPaper::inSensorFrame(scan, l.position))) {
      bool returned = false, admitted = false;
      for (std::size_t i = 0; i < obs.size(); ++i) {
        Matrix23d G;
        Eigen::Matrix2d C;
        const Eigen::Vector2d p =
            ctx.sightingPosition(pose, obs[i].z, obs[i].R, obs[i].kind, &G, &C);
        const Eigen::Matrix2d S = l.covariance + C + G * P * G.transpose();
        const Eigen::Vector2d d = p - l.position;
        if (d.dot(S.ldlt().solve(d)) > gate) continue;
        returned = true;
        admitted = admitted || (i < result.decision.size() && result.decision[i] == Decision::kNew);
      }
      if (admitted) {
        ++still_there_;  // a static point the map lost: it is mapped again
        done = true;
      } else if (returned) {
        l.log_odds = 0.0;  // something is there: perhaps the mover still, perhaps no mover
      } else {
        l.log_odds += miss;
        done = leftIfSure(l);
      }
    }
    if (!done) leavers_[kept++] = l;
  }
  leavers_.resize(kept);
}

bool MoverSpeed::leftIfSure(const Leaver& l) {
  if (l.log_odds < std::log(p_.mover_left_odds)) return false;
  moverLeft(l.speed);
  return true;
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
