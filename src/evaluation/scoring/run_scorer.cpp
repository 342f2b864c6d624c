#include "ekf_slam/evaluation/scoring/run_scorer.h"

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/pose2d.h"

namespace ekf_slam {

namespace {

PoseError errorAfter(const RigidTransform2& align, const Eigen::Vector3d& estimate,
                     const Eigen::Vector3d& true_pose) {
  PoseError e;
  e.position = (align.apply(estimate.head<2>()) - true_pose.head<2>()).norm();
  e.heading = std::abs(wrapAngle(estimate.z() + align.yaw - true_pose.z()));
  return e;
}

}  // namespace

std::optional<RigidTransform2> RunScorer::mapAlignment(const EkfSlam& map) const {
  // Per static truth identity, the oldest landmark holding it (its position). After a kidnap only
  // landmarks made before it count: a map rebuilt around the kidnapped pose (DJNN's exit rule
  // removing the old one) must not make a displaced pose look recovered.
  const bool after_kidnap = kidnapped_ || kidnap_pending_;
  std::unordered_map<LandmarkId, std::pair<LandmarkId, Eigen::Vector2d>> oldest;
  for (std::size_t k = 0; k < map.numLandmarks(); ++k) {
    const LandmarkId id = map.landmarkIds()[k];
    if (after_kidnap && id > last_id_before_kidnap_) continue;
    LandmarkId truth = -1;
    if (!scorer_.identity(id, &truth) || true_map_.count(truth) == 0) continue;
    const Eigen::Vector2d position = map.landmark(static_cast<int>(k));
    const auto [it, added] = oldest.try_emplace(truth, id, position);
    if (!added && id < it->second.first) it->second = {id, position};
  }
  if (oldest.size() < kMinAlignmentLandmarks) return std::nullopt;
  std::vector<Eigen::Vector2d> from, to;
  from.reserve(oldest.size());
  to.reserve(oldest.size());
  for (const auto& [truth, landmark] : oldest) {
    from.push_back(landmark.second);
    to.push_back(true_map_.at(truth));
  }
  return alignRigid2D(from, to);
}

PoseError RunScorer::mapRelativeError(const EkfSlam& map, const Eigen::Vector3d& estimate,
                                      const Eigen::Vector3d& true_pose) const {
  const std::optional<RigidTransform2> align = mapAlignment(map);
  return align ? errorAfter(*align, estimate, true_pose) : PoseError();
}

bool RunScorer::needsMap(const ScanReport& report) const {
  const bool before = expect_kidnap_ && !kidnapped_ && !kidnap_pending_;
  const bool after = (kidnapped_ || kidnap_pending_) && !(recovered_map_ && map_window_passed_);
  return !true_map_.empty() && (report.relocalised || before || after);
}

void RunScorer::addScan(const ScanReport& report, const std::vector<LandmarkId>& truth,
                        const Eigen::Vector3d& estimate, const Eigen::Matrix3d& cov,
                        const Eigen::Vector3d* true_pose, const EkfSlam* map) {
  if (truth.size() != report.observations.size()) {
    throw std::invalid_argument("RunScorer: " + std::to_string(truth.size()) + " truth ids for " +
                                std::to_string(report.observations.size()) + " observations");
  }
  scorer_.addScan(truth, report.association, report.removed);
  if (!report.delayed_sightings.empty()) {
    std::vector<std::pair<LandmarkId, LandmarkId>> applied;
    for (const DelayedSighting& d : report.delayed_sightings) {
      const auto it = recent_truth_.find(d.scan);
      if (it != recent_truth_.end() && d.observation < static_cast<int>(it->second.size()))
        applied.emplace_back(d.landmark, it->second[d.observation]);
    }
    scorer_.addDelayedSightings(applied);
  }
  // Kept as long as a sighting may be held back (max_pose_clones scans at most: 10000 bounds
  // any setting).
  constexpr std::size_t kRecentScans = 10000;
  recent_truth_[report.scan] = truth;
  while (recent_truth_.size() > kRecentScans) recent_truth_.erase(recent_truth_.begin());
  ++scans_;
  observations_ += truth.size();
  association_s_ += report.association_s;
  update_s_ += report.update_s;
  if (!have_first_) {
    have_first_ = true;
    first_stamp_ = report.stamp;
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Decided before this scan changes the kidnap state, as the caller decided.
  const std::optional<RigidTransform2> align =
      map != nullptr && true_pose != nullptr && needsMap(report) ? mapAlignment(*map)
                                                                 : std::nullopt;
  if (kidnap_pending_) {
    kidnap_pending_ = false;
    kidnapped_ = true;
    kidnap_scan_ = scans_ - 1;
    kidnap_stamp_ = report.stamp;
    error_before_kidnap_ = last_error_;
    error_before_kidnap_map_ = last_error_map_;
  }
  if (report.relocalised) {
    ++relocalisations_;
    if (true_pose != nullptr) {
      const auto wrong = [&](const PoseError& e) {
        return e.position > kWrongRelocalisationDistance || e.heading > kWrongRelocalisationAngle;
      };
      const Eigen::Vector3d& p = report.relocalisation.pose;
      wrong_relocalisations_ += wrong(errorAfter(RigidTransform2(), p, *true_pose));
      if (align) wrong_relocalisations_map_ += wrong(errorAfter(*align, p, *true_pose));
    }
  }
  // NaN where not measured (no map, or too few identified landmarks).
  const double in_map = align ? errorAfter(*align, estimate, *true_pose).position : nan;
  if (!kidnapped_ && map != nullptr) {
    last_error_map_ = in_map;
    // Landmark ids only grow: the newest one so far bounds the map made before the kidnap.
    for (const LandmarkId id : map->landmarkIds())
      last_id_before_kidnap_ = std::max(last_id_before_kidnap_, id);
  }
  if (kidnapped_ && !recovered_map_ && in_map < kRecoveredDistance) {
    recovered_map_ = true;
    recovery_scans_map_ = static_cast<std::int64_t>(scans_ - 1 - kidnap_scan_);
    recovery_s_map_ = report.stamp - kidnap_stamp_;
  }
  if (kidnapped_ && !map_window_passed_ && report.stamp - kidnap_stamp_ >= kRecoveryWindow - 1e-6) {
    map_window_passed_ = true;
    error_after_kidnap_map_ = in_map;
  }
  double nees = nan;
  Eigen::Vector2d error = Eigen::Vector2d::Constant(nees);
  if (true_pose != nullptr) {
    const double distance = (estimate.head<2>() - true_pose->head<2>()).norm();
    if (kidnapped_ && !recovered_ && distance < kRecoveredDistance) {
      recovered_ = true;
      recovery_scans_ = static_cast<std::int64_t>(scans_ - 1 - kidnap_scan_);
      recovery_s_ = report.stamp - kidnap_stamp_;
    }
    if (recovered_) {
      after_sum_ += distance * distance;
      ++after_n_;
    }
    if (kidnapped_ && std::isnan(error_after_kidnap_) &&
        report.stamp - kidnap_stamp_ >= kRecoveryWindow - 1e-6)
      error_after_kidnap_ = distance;
    last_error_ = distance;
    nees = pose_.add(estimate, cov, *true_pose);
    estimates_.push_back(estimate);
    truths_.push_back(*true_pose);
    error << distance, std::abs(wrapAngle(estimate(2) - (*true_pose)(2)));
    if (std::isfinite(nees) && report.stamp - first_stamp_ >= nees_skip_s_) {
      nees_sum_ += nees;
      ++nees_n_;
    }
  }
  nees_.push_back(nees);
  errors_.push_back(error);
}

void RunScorer::markKidnap() {
  if (!kidnapped_) kidnap_pending_ = true;  // the first kidnap is the one timed
}

RunMetrics RunScorer::metrics(const SlamPipeline* pipeline) const {
  RunMetrics m;
  m.counts = scorer_.counts();
  m.map = scorer_.mapScore();
  m.scans = scans_;
  m.observations = observations_;
  m.unknown_pairings = scorer_.unknownPairings();
  m.identity_switches = scorer_.identitySwitches();
  const bool have_pose = pose_.count() > 0;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  m.pose_rmse_m = have_pose ? pose_.positionRmse() : nan;
  m.heading_rmse_rad = have_pose ? pose_.headingRmse() : nan;
  m.anees = nees_n_ > 0 ? nees_sum_ / static_cast<double>(nees_n_) : nan;
  // Aligned trajectory (ATE) and map: one rigid transform, fitted on the positions.
  RigidTransform2 align;
  if (!estimates_.empty()) {
    std::vector<Eigen::Vector2d> from, to;
    from.reserve(estimates_.size());
    to.reserve(truths_.size());
    for (std::size_t i = 0; i < estimates_.size(); ++i) {
      from.push_back(estimates_[i].head<2>());
      to.push_back(truths_[i].head<2>());
    }
    align = alignRigid2D(from, to);
    double sum_pos2 = 0.0, sum_yaw2 = 0.0;
    for (std::size_t i = 0; i < from.size(); ++i) {
      sum_pos2 += (align.apply(from[i]) - to[i]).squaredNorm();
      const double dyaw = wrapAngle(estimates_[i].z() + align.yaw - truths_[i].z());
      sum_yaw2 += dyaw * dyaw;
    }
    const double n_pose = static_cast<double>(from.size());
    m.pose_ate_aligned_m = std::sqrt(sum_pos2 / n_pose);
    m.heading_rmse_aligned_rad = std::sqrt(sum_yaw2 / n_pose);
  }
  m.nees_scans = nees_n_;
  const double n = scans_ > 0 ? static_cast<double>(scans_) : 1.0;
  m.association_us_mean = 1e6 * association_s_ / n;
  m.update_us_mean = 1e6 * update_s_ / n;
  if (pipeline != nullptr) {
    m.rejected_updates = pipeline->counters().rejected_updates;
    const EkfSlam& ekf = pipeline->ekf();
    m.correction_names = pipeline->odometryCorrection().names();
    m.correction = ekf.correction();
    m.correction_sigma = ekf.correctionCovariance().diagonal().cwiseSqrt();
    m.lost_events = pipeline->counters().lost_events;
    double sum2 = 0.0;
    for (std::size_t k = 0; k < ekf.numLandmarks() && !true_map_.empty(); ++k) {
      LandmarkId truth = -1;
      if (!scorer_.identity(ekf.landmarkIds()[k], &truth)) continue;
      const auto it = true_map_.find(truth);
      if (it == true_map_.end()) continue;
      sum2 += (align.apply(ekf.landmark(static_cast<int>(k))) - it->second).squaredNorm();
      ++m.map_rmse_landmarks;
    }
    if (m.map_rmse_landmarks > 0)
      m.map_rmse_aligned_m = std::sqrt(sum2 / static_cast<double>(m.map_rmse_landmarks));
  }
  m.relocalisations = relocalisations_;
  m.wrong_relocalisations = wrong_relocalisations_;
  m.recovery_scans = recovery_scans_;
  m.recovery_s = recovery_s_;
  m.pose_rmse_after_recovery_m =
      after_n_ > 0 ? std::sqrt(after_sum_ / static_cast<double>(after_n_)) : nan;
  m.error_before_kidnap_m = error_before_kidnap_;
  m.error_after_kidnap_m = error_after_kidnap_;
  m.recovery_scans_map = recovery_scans_map_;
  m.recovery_s_map = recovery_s_map_;
  m.error_before_kidnap_map_m = error_before_kidnap_map_;
  m.error_after_kidnap_map_m = error_after_kidnap_map_;
  m.wrong_relocalisations_map = wrong_relocalisations_map_;
  return m;
}

// --- truthByProximity ---

std::vector<LandmarkId> truthByProximity(
    const Eigen::Vector3d& true_sensor_pose, const std::vector<Observation>& observations,
    const std::vector<std::pair<LandmarkId, Eigen::Vector2d>>& landmarks,
    LandmarkId* next_clutter) {
  std::vector<LandmarkId> truth;
  truth.reserve(observations.size());
  for (const Observation& o : observations) {
    const Eigen::Vector2d p =
        composePose(true_sensor_pose,
                    Eigen::Vector3d(o.z(0) * std::cos(o.z(1)), o.z(0) * std::sin(o.z(1)), 0.0))
            .head<2>();
    LandmarkId id = (*next_clutter)--;
    for (const auto& [landmark, position] : landmarks) {
      if ((position - p).norm() < kLaserTruthDistance) id = landmark;
    }
    truth.push_back(id);
  }
  return truth;
}

}  // namespace ekf_slam
