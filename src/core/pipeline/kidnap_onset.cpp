#include "ekf_slam/core/pipeline/kidnap_onset.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <utility>

#include <Eigen/Cholesky>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/chi2.h"
#include "ekf_slam/core/common/pose2d.h"

namespace ekf_slam {

namespace {

// The fix carried back agrees with the filter's pose inside chi2(3) at this probability (as a
// probe's kidnap test and Recovery::rederiveTracked).
constexpr double kAgreeProbability = 0.999;

// Landmarks binned by cell, for the few near each scan.
class Grid {
 public:
  Grid(const std::vector<OnsetLandmark>& landmarks, double cell) : cell_(cell) {
    for (std::size_t i = 0; i < landmarks.size(); ++i)
      cells_[key(cellOf(landmarks[i].position.x()), cellOf(landmarks[i].position.y()))].push_back(
          static_cast<int>(i));
  }
  void near(const Eigen::Vector2d& c, double radius, std::vector<int>* out) const {
    out->clear();
    const std::int64_t x0 = cellOf(c.x() - radius), x1 = cellOf(c.x() + radius);
    const std::int64_t y0 = cellOf(c.y() - radius), y1 = cellOf(c.y() + radius);
    for (std::int64_t x = x0; x <= x1; ++x) {
      for (std::int64_t y = y0; y <= y1; ++y) {
        const auto it = cells_.find(key(x, y));
        if (it != cells_.end()) out->insert(out->end(), it->second.begin(), it->second.end());
      }
    }
  }

 private:
  std::int64_t cellOf(double v) const { return static_cast<std::int64_t>(std::floor(v / cell_)); }
  static std::int64_t key(std::int64_t x, std::int64_t y) { return x * 73856093 ^ y * 19349663; }
  double cell_;
  std::unordered_map<std::int64_t, std::vector<int>> cells_;
};

// The landmarks the scan's observations pair at `pose` (nearest within the gate, each landmark
// once): the scans that made them.
void pairedCreations(const std::vector<Observation>& observations, const Eigen::Vector3d& pose,
                     const Eigen::Matrix3d& pose_covariance,
                     const std::vector<OnsetLandmark>& landmarks, const Grid& grid,
                     const RangeBearingModel& model, double gate, const OnsetParams& params,
                     std::vector<std::pair<std::int64_t, double>>* created) {
  created->clear();
  // Candidates: within the observation's reach of the sensor, plus the pose's 3-sigma lever.
  double reach = 0.0;
  for (const Observation& o : observations) {
    const Eigen::Vector2d p = RangeBearingModel::sensorPoint(o.z, o.kind);
    reach = std::max(reach, p.norm());
  }
  const Eigen::Vector3d sensor = model.sensorPose(pose);
  const double sigma = std::sqrt(std::max(0.0, pose_covariance.topLeftCorner<2, 2>().trace()));
  const double yaw_sigma = std::sqrt(std::max(0.0, pose_covariance(2, 2)));
  std::vector<int> near;
  grid.near(sensor.head<2>(), reach * (1.0 + 3.0 * yaw_sigma) + 3.0 * sigma + 5.0, &near);
  std::vector<char> taken(near.size(), 0);
  for (const Observation& o : observations) {
    double best = gate;
    int best_j = -1;
    double best_log_density = 0.0;
    for (std::size_t j = 0; j < near.size(); ++j) {
      if (taken[j]) continue;
      const OnsetLandmark& l = landmarks[near[j]];
      Matrix23d Hx;
      Eigen::Matrix2d Hm;
      const Eigen::Vector2d zh = model.predict(pose, l.position, o.kind, &Hx, &Hm);
      const Eigen::Vector2d v = RangeBearingModel::innovation(o.z, zh, o.kind);
      const Eigen::Matrix2d S =
          Hx * pose_covariance * Hx.transpose() + Hm * l.covariance * Hm.transpose() + o.R;
      const Eigen::LDLT<Eigen::Matrix2d> ldlt(S);
      if (ldlt.info() != Eigen::Success) continue;
      const double d2 = v.dot(ldlt.solve(v));
      if (std::isfinite(d2) && d2 < best) {
        best = d2;
        best_j = static_cast<int>(j);
        best_log_density =
            -0.5 * d2 - std::log(2.0 * M_PI) - 0.5 * ldlt.vectorD().array().log().sum();
      }
    }
    if (best_j < 0) continue;
    // Against a new feature's density (uniform over what the sensor sees): what the pairing
    // explains beyond a new landmark; no better than that, it explains nothing.
    const double area = o.kind == MeasurementKind::kCartesian
                            ? 0.5 * params.field_of_view * params.max_range * params.max_range
                            : params.field_of_view * params.max_range;
    const double gain = best_log_density + std::log(area);
    if (!(gain > 0.0)) continue;
    taken[best_j] = 1;
    created->emplace_back(landmarks[near[best_j]].created_scan, gain);
  }
}

}  // namespace

KidnapOnset estimateKidnapOnset(const std::vector<OnsetScan>& scans,
                                const std::vector<OnsetLandmark>& landmarks,
                                const RangeBearingModel& model, const OnsetParams& params) {
  KidnapOnset out;
  if (scans.empty() || landmarks.empty()) return out;
  const double gate = chi2Quantile(params.pair_probability, 2);
  const double agree = chi2Quantile(kAgreeProbability, 3);
  const Grid grid(landmarks, 10.0);
  // Candidate i is the onset scans[i].scan. A pairing in scan i with a landmark made at scan c
  // counts for every candidate j <= i whose onset is after c (c < scans[j].scan): +1 at the
  // carried-back pose, -1 at the filter's. Added up as a difference array over the candidates.
  const std::size_t n = scans.size();
  std::vector<double> diff(n + 1, 0.0);
  std::vector<std::pair<std::int64_t, double>> created;
  const auto count = [&](std::size_t i, double sign) {
    for (const auto& [c, gain] : created) {
      // The first candidate whose onset comes after c.
      const auto first = std::upper_bound(
          scans.begin(), scans.begin() + static_cast<std::ptrdiff_t>(i) + 1, c,
          [](std::int64_t value, const OnsetScan& s) { return value < std::int64_t{s.scan}; });
      const std::size_t j = static_cast<std::size_t>(first - scans.begin());
      if (j > i) continue;
      diff[j] += sign * gain;
      diff[i + 1] -= sign * gain;
    }
  };
  // The onset lies after the newest scan where the fix carried back agrees with the filter's
  // pose: there the hypotheses are one, and the filter was right (whatever the covariances, which
  // a likelihood ratio would weigh: the fix's is the smaller near it). Before such a scan the
  // carried-back poses have drifted with the odometry and tell nothing.
  std::size_t first = 0;
  for (std::size_t i = n; i-- > 0;) {
    const OnsetScan& s = scans[i];
    Eigen::Vector3d d = s.carried - s.estimate;
    d.z() = wrapAngle(d.z());
    const Eigen::LDLT<Eigen::Matrix3d> S(s.estimate_covariance + s.carried_covariance);
    if (S.info() == Eigen::Success && d.dot(S.solve(d)) <= agree) {
      first = i + 1;
      break;
    }
  }
  for (std::size_t i = first; i < n; ++i) {
    const OnsetScan& s = scans[i];
    if (s.observations == nullptr || s.observations->empty()) continue;
    pairedCreations(*s.observations, s.carried, s.carried_covariance, landmarks, grid, model, gate,
                    params, &created);
    count(i, +1.0);
    pairedCreations(*s.observations, s.estimate, s.estimate_covariance, landmarks, grid, model,
                    gate, params, &created);
    count(i, -1.0);
  }
  double score = 0.0;
  double best = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < first; ++i) score += diff[i];
  for (std::size_t i = first; i < n; ++i) {
    score += diff[i];
    if (score >= best) {  // the latest of equal scores
      best = score;
      out.scan = scans[i].scan;
    }
  }
  out.score = best;
  out.found = best >= params.min_score;
  return out;
}

// --- TrackedHistory
// -------------------------------------------------------------------------------

void TrackedHistory::configure(int max_scans, int snapshots) {
  max_scans_ = std::max(max_scans, 0);
  spacing_ = std::max(1, max_scans_ / std::max(snapshots, 1));
  clear();
}

void TrackedHistory::clear() {
  records_.clear();
  scans_.clear();
  snapshots_.clear();
  last_snapshot_ = -1;
}

void TrackedHistory::add(const Record& record, const std::vector<Observation>& observations) {
  if (!active()) return;
  records_.push_back(record);
  scans_.add(record.scan, record.odometry, observations);
  const std::int64_t oldest = std::int64_t{record.scan} - max_scans_;
  while (!records_.empty() && std::int64_t{records_.front().scan} <= oldest) records_.pop_front();
  if (oldest >= 0) scans_.dropBefore(static_cast<std::uint32_t>(oldest + 1));
  while (!snapshots_.empty() && std::int64_t{snapshots_.front().scan} <= oldest)
    snapshots_.pop_front();
}

bool TrackedHistory::wantsSnapshot(std::uint32_t scan) const {
  return active() && (last_snapshot_ < 0 || std::int64_t{scan} - last_snapshot_ >= spacing_);
}

void TrackedHistory::addSnapshot(MapCheckpoint snapshot) {
  last_snapshot_ = snapshot.scan;
  snapshot.scans.clear();
  snapshots_.push_back(std::move(snapshot));
}

void TrackedHistory::forgetFrom(std::uint32_t scan) {
  for (Record& r : records_) r.tracked = r.tracked && r.scan < scan;
  while (!snapshots_.empty() && snapshots_.back().scan >= scan) snapshots_.pop_back();
  last_snapshot_ = snapshots_.empty() ? -1 : std::int64_t{snapshots_.back().scan};
}

std::vector<OnsetScan> TrackedHistory::hypotheses(const Eigen::Vector3d& fix,
                                                  const Eigen::Matrix3d& fix_covariance,
                                                  const Eigen::Vector3d& odometry_now,
                                                  double estimate_yaw, std::uint32_t before) const {
  std::vector<OnsetScan> out;
  Eigen::Matrix3d Q = Eigen::Matrix3d::Zero();  // the odometry's noise from a scan to now
  Eigen::Matrix3d Phi = Eigen::Matrix3d::Identity();
  auto r = records_.rbegin();
  const auto& kept = scans_.scans();
  for (auto s = kept.rbegin(); s != kept.rend(); ++s) {  // newest first
    Q += Phi * s->Q * Phi.transpose();
    Phi = Phi * s->F;
    if (s->scan >= before) continue;
    while (r != records_.rend() && r->scan > s->scan) ++r;
    if (r == records_.rend() || r->scan != s->scan || !r->tracked) continue;
    const Eigen::Vector3d v = composePose(inversePose(odometry_now), s->pose);
    OnsetScan o;
    o.scan = s->scan;
    o.estimate = r->estimate;
    o.estimate_covariance = r->covariance;
    o.carried = composePose(fix, v);
    o.carried.z() = wrapAngle(o.carried.z());
    o.carried_covariance = carriedCovariance(fix, fix_covariance, v, estimate_yaw, Q);
    o.observations = &s->observations;
    out.push_back(o);
  }
  std::reverse(out.begin(), out.end());
  return out;
}

std::vector<LostPathPose> TrackedHistory::path(std::uint32_t from, std::uint32_t until,
                                               const Eigen::Vector3d& to_fixed) const {
  std::vector<LostPathPose> out;
  for (const Record& r : records_) {
    if (r.scan < from || r.scan >= until) continue;
    Eigen::Vector3d p = composePose(to_fixed, r.odometry);
    p.z() = wrapAngle(p.z());
    out.push_back({r.scan, r.stamp, p, /*tracked=*/true});
  }
  return out;
}

const MapCheckpoint* TrackedHistory::snapshotAtOrBefore(std::uint32_t scan) const {
  for (auto s = snapshots_.rbegin(); s != snapshots_.rend(); ++s)
    if (s->scan <= scan) return &*s;
  return nullptr;
}

}  // namespace ekf_slam
