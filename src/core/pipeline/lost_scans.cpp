#include "ekf_slam/core/pipeline/lost_scans.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>
#include <utility>

#include <Eigen/Cholesky>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/chi2.h"
#include "ekf_slam/core/common/pose2d.h"

namespace ekf_slam {

void LostScans::add(std::uint32_t scan, const Eigen::Vector3d& pose,
                    std::vector<Observation> observations) {
  if (observations.empty()) return;
  if (scans_.size() >= kMaxScans) scans_.pop_front();
  scans_.push_back(
      {scan, pose, std::move(observations), Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Zero()});
}

void LostScans::carry(const MotionStep& step) {
  if (scans_.empty()) return;
  Scan& s = scans_.back();
  s.Q = step.F * s.Q * step.F.transpose() + step.Q;
  s.F = step.F * s.F;
}

void LostScans::dropFrom(std::uint32_t scan) {
  while (!scans_.empty() && scans_.back().scan >= scan) {
    const Scan dropped = std::move(scans_.back());
    scans_.pop_back();
    if (scans_.empty()) break;
    // The odometry to the dropped scan, then from it to now.
    Scan& s = scans_.back();
    s.Q = dropped.F * s.Q * dropped.F.transpose() + dropped.Q;
    s.F = dropped.F * s.F;
  }
}

void LostScans::dropBefore(std::uint32_t scan) {
  while (!scans_.empty() && scans_.front().scan < scan) scans_.pop_front();
}

LostScans LostScans::from(std::uint32_t scan) const {
  LostScans out;
  for (const Scan& s : scans_)
    if (s.scan >= scan) out.scans_.push_back(s);
  return out;
}

void LostScans::reanchor(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  const Eigen::Vector3d t = composePose(to, inversePose(from));
  for (Scan& s : scans_) {
    s.pose = composePose(t, s.pose);
    s.pose.z() = wrapAngle(s.pose.z());
  }
}

namespace {

// The vehicle state moved from the later scan's pose back to `s`: x_s = x_later (+) delta, delta
// the dead-reckoned odometry undone. Its Jacobian [I J(p_s - p_later); 0 1] is the inverse of the
// forward one, so the noise is F Q F^T with Q the forward odometry's, turned by the fix's heading
// correction into the estimate's frame.
bool carryBack(EkfSlam& ekf, const LostScans::Scan& s, const Eigen::Vector3d& later_dead_reckoned) {
  const Eigen::Vector3d later = ekf.pose();
  const Eigen::Vector3d delta = composePose(inversePose(later_dead_reckoned), s.pose);
  MotionStep step;
  step.pose = composePose(later, delta);
  step.pose.z() = wrapAngle(step.pose.z());
  step.F.setIdentity();
  step.F(0, 2) = -(step.pose.y() - later.y());
  step.F(1, 2) = step.pose.x() - later.x();
  Eigen::Matrix3d T = Eigen::Matrix3d::Identity();
  T.topLeftCorner<2, 2>() = rotation2d(wrapAngle(later.z() - later_dead_reckoned.z()));
  step.Q = step.F * T * s.Q * T.transpose() * step.F.transpose();
  step.Q = 0.5 * (step.Q + step.Q.transpose());
  step.corrections = ekf.correctionDim();
  return ekf.predict(step);
}

// Squared Mahalanobis distance of observation o to landmark k at the current pose, with the
// joint covariance of pose and landmark; infinity when it cannot be computed.
double distance2(const EkfSlam& ekf, const RangeBearingModel& model, const Observation& o, int k) {
  Matrix23d Hx;
  Eigen::Matrix2d Hm;
  const Eigen::Vector2d m = ekf.landmark(k);
  const Eigen::Vector2d zh = model.predict(ekf.pose(), m, o.kind, &Hx, &Hm);
  const Eigen::Vector2d v = RangeBearingModel::innovation(o.z, zh, o.kind);
  const auto P = ekf.storedCovariance();
  const int r = ekf.stateRow(k);
  // The vehicle rows are current in every column, each landmark's own block too.
  const Eigen::Matrix3d Pvv = P.topLeftCorner<3, 3>();
  const Eigen::Matrix<double, 3, 2> Pvm = P.block<3, 2>(0, r);
  const Eigen::Matrix2d Pmm = ekf.landmarkCovariance(k);
  const Eigen::Matrix2d S = Hx * Pvv * Hx.transpose() + Hx * Pvm * Hm.transpose() +
                            Hm * Pvm.transpose() * Hx.transpose() + Hm * Pmm * Hm.transpose() + o.R;
  const Eigen::LDLT<Eigen::Matrix2d> ldlt(S);
  if (ldlt.info() != Eigen::Success || !v.allFinite())
    return std::numeric_limits<double>::infinity();
  const double d2 = v.dot(ldlt.solve(v));
  return std::isfinite(d2) && d2 >= 0.0 ? d2 : std::numeric_limits<double>::infinity();
}

// How far beyond an observation's range a landmark may lie and still be compared with it: a
// generous margin for the pose; those further away are not worth the covariance.
constexpr double kReachMargin = 20.0;

// The state indices, ascending, of the landmarks within an observation's range plus kReachMargin
// of the sensor for some observation of `observations`: the landmarks the exact test in
// mapLostScans can let through, from the index (synced), not the whole map. The query's radius
// is the largest reach widened by a relative 1e-9 and an absolute 1e-9 m, far above the rounding
// of the distance and of the query's cell bounds, so it contains every landmark within any
// observation's reach; the caller applies the exact test to each. A non-finite range (the old
// test let every landmark through) takes every landmark.
std::vector<int> landmarksInReach(const EkfSlam& ekf, const LandmarkIndex& index,
                                  const Eigen::Vector2d& sensor,
                                  const std::vector<Observation>& observations) {
  std::vector<int> out;
  double reach = 0.0;
  for (const Observation& o : observations) {
    const double r = RangeBearingModel::range(o.z, o.kind) + kReachMargin;
    if (!std::isfinite(r)) {
      out.resize(ekf.numLandmarks());
      for (std::size_t k = 0; k < out.size(); ++k) out[k] = static_cast<int>(k);
      return out;
    }
    reach = std::max(reach, r);
  }
  index.query(ekf, sensor, reach * (1.0 + 1e-9) + 1e-9, &out);
  // The order of the map (the old loop's), so that everything downstream is the same.
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

LostScanMapping mapLostScans(EkfSlam& ekf, const RangeBearingModel& model, const LostScans& lost,
                             const Eigen::Vector3d& dead_reckoned_now,
                             const LostMappingParams& params, LandmarkIndex* index) {
  LostScanMapping out;
  if (lost.empty()) return out;
  LandmarkIndex local;
  if (index == nullptr) index = &local;
  const double pair_gate = chi2Quantile(params.pair_probability, 2);
  const double new_gate = chi2Quantile(params.new_probability, 2);
  const CloneId now = ekf.addClone();
  std::vector<LandmarkId> created;
  std::vector<std::uint32_t> seen;
  std::vector<double> descriptor_sum;
  std::vector<int> descriptor_count;
  Eigen::Vector3d later = dead_reckoned_now;
  std::vector<Eigen::Vector3d> sensor_poses;      // per scan carried back to, newest first
  std::vector<std::vector<std::size_t>> seen_at;  // per created landmark: those scans' indices
  // Newest first: each step carries the state back by one stretch of odometry.
  for (auto s = lost.scans().rbegin(); s != lost.scans().rend(); ++s) {
    if (!carryBack(ekf, *s, later)) break;
    later = s->pose;
    ++out.scans;
    sensor_poses.push_back(model.sensorPose(ekf.pose()));
    const Eigen::Vector2d sensor = sensor_poses.back().head<2>();
    // The previous scan's update moved landmarks and added some: O(n), as after any update.
    index->sync(ekf);
    const std::vector<int> reach = landmarksInReach(ekf, *index, sensor, s->observations);
    // Candidates within the pairing gate; an observation with two is ambiguous and left alone.
    std::vector<std::tuple<double, std::size_t, LandmarkId>> candidates;
    std::vector<int> in_gate(s->observations.size(), 0);
    std::vector<bool> near(s->observations.size(), false);
    for (std::size_t i = 0; i < s->observations.size(); ++i) {
      const Observation& o = s->observations[i];
      const double range = RangeBearingModel::range(o.z, o.kind);
      for (const int k : reach) {
        // Far beyond the observation: not worth the covariance (a generous margin for the pose).
        if ((ekf.landmark(k) - sensor).norm() > range + kReachMargin) continue;
        const double d2 = distance2(ekf, model, o, k);
        if (d2 <= new_gate) near[i] = true;
        if (d2 > pair_gate) continue;
        ++in_gate[i];
        candidates.emplace_back(d2, i, ekf.landmarkIds()[k]);
      }
    }
    std::sort(candidates.begin(), candidates.end());
    std::vector<Pairing> pairings;
    std::vector<bool> used_obs(s->observations.size(), false);
    std::vector<LandmarkId> used_landmarks;
    for (const auto& [d2, i, id] : candidates) {
      if (in_gate[i] != 1 || used_obs[i]) continue;
      if (std::find(used_landmarks.begin(), used_landmarks.end(), id) != used_landmarks.end())
        continue;
      used_obs[i] = true;
      used_landmarks.push_back(id);
      const Observation& o = s->observations[i];
      pairings.push_back(Pairing{id, o.z, o.R, o.kind});
    }
    if (!pairings.empty() && !ekf.update(pairings, model)) pairings.clear();
    out.poses.emplace_back(s->scan, ekf.pose());
    out.paired_at.emplace_back();
    for (const Pairing& p : pairings) out.paired_at.back().push_back(p.id);
    for (const Pairing& p : pairings) {
      const auto c = std::find(created.begin(), created.end(), p.id);
      if (c == created.end()) {
        out.paired.push_back(p.id);
        continue;
      }
      const std::size_t j = static_cast<std::size_t>(c - created.begin());
      ++seen[j];
      seen_at[j].push_back(sensor_poses.size() - 1);
    }
    // What no landmark explains is new: initialised at this scan's pose, which carries the
    // odometry chain's correlation with the fixed pose and the map.
    for (std::size_t i = 0; i < s->observations.size(); ++i) {
      if (used_obs[i] || near[i]) continue;
      const Observation& o = s->observations[i];
      const LandmarkId id = ekf.addLandmark(o.z, o.R, model, o.kind);
      if (id == kNoLandmark) continue;
      created.push_back(id);
      seen.push_back(1);
      seen_at.push_back({sensor_poses.size() - 1});
      descriptor_sum.push_back(std::isfinite(o.descriptor) ? o.descriptor : 0.0);
      descriptor_count.push_back(std::isfinite(o.descriptor) ? 1 : 0);
    }
    // Descriptors of the pairings with the new landmarks.
    for (std::size_t i = 0; i < s->observations.size(); ++i) {
      if (!used_obs[i] || !std::isfinite(s->observations[i].descriptor)) continue;
      for (const Pairing& p : pairings) {
        if (p.z != s->observations[i].z) continue;
        const auto c = std::find(created.begin(), created.end(), p.id);
        if (c == created.end()) break;
        const std::size_t j = static_cast<std::size_t>(c - created.begin());
        descriptor_sum[j] += s->observations[i].descriptor;
        ++descriptor_count[j];
        break;
      }
    }
  }
  ekf.restorePose(now);
  // A feature seen in too few lost scans may be clutter: removed (marginalised; what its
  // sightings told the other states stays).
  for (std::size_t j = 0; j < created.size(); ++j) {
    if (static_cast<int>(seen[j]) < params.min_sightings) {
      ekf.removeLandmark(created[j]);
      ++out.dropped;
      continue;
    }
    out.created.push_back(created[j]);
    out.sightings.push_back(seen[j]);
    // Oldest first: the scans were carried back to newest first.
    const Eigen::Vector2d m = ekf.landmark(ekf.indexOf(created[j]));
    std::vector<LostLook> looks(sensor_poses.size());
    for (std::size_t k = 0; k < sensor_poses.size(); ++k) {
      const Eigen::Vector3d& s = sensor_poses[sensor_poses.size() - 1 - k];
      looks[k].in_sensor = rotation2d(-s.z()) * (m - s.head<2>());
    }
    for (std::size_t k : seen_at[j]) looks[sensor_poses.size() - 1 - k].seen = true;
    out.looks.push_back(std::move(looks));
    out.descriptors.push_back(descriptor_count[j] > 0 ? descriptor_sum[j] / descriptor_count[j]
                                                      : std::nan(""));
  }
  return out;
}

}  // namespace ekf_slam
