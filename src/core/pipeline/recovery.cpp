#include "ekf_slam/core/pipeline/recovery.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <string>

#include <Eigen/Cholesky>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/chi2.h"
#include "ekf_slam/core/common/pose2d.h"
#include "ekf_slam/core/common/stopwatch.h"
#include "ekf_slam/core/relocalisation/geometric_constraints.h"

namespace ekf_slam {

namespace {

// The lost path kept for re-deriving (ScanReport::lost_path): the newest this many scans, about
// half an hour of Victoria Park's; the older ones are forgotten, not corrected.
constexpr std::size_t kMaxLostPath = 10000;
// A probe's pose is a kidnap when the filter's estimate does not cover it: its difference from
// the estimate, with both covariances, beyond chi2(3) at this probability.
constexpr double kProbeProbability = 0.999;

}  // namespace

Recovery::Recovery(const PipelineConfig& config, const FilterBackend& filter,
                   const MotionPredictor& motion, const RangeBearingModel& model,
                   const LandmarkBook& book, PipelineCounters& counters)
    : config_(config),
      filter_(filter),
      motion_(motion),
      model_(model),
      book_(book),
      counters_(counters),
      window_(config.relocalisation_window_scans) {}

void Recovery::setRelocaliser(std::shared_ptr<Relocaliser> relocaliser) {
  relocaliser_ = std::move(relocaliser);
  if (!relocaliser_) lost_ = false;
}

void Recovery::reset() {
  lost_ = false;
  tracked_.clear();
  seen_while_lost_.clear();
}

void Recovery::enterLost(const std::vector<MapLandmark>& map, bool pose_unknown) {
  lost_ = true;
  pose_unknown_ = pose_unknown;
  lost_scans_ = 0;
  scans_lost_ = 0;
  held_.clear();
  window_.clear();  // scans from before are at a pose now in doubt
  lost_path_.clear();
  seen_while_lost_.clear();
  if (pose_unknown) tracked_.clear();  // a new map: the scans before say nothing about the pose
  relocaliser_->setMap(map);           // frozen until found
}

void Recovery::carry(const MotionStep& step) {
  if (lost_ && !window_.empty()) window_.addMotion(step.F, step.Q);
  if (lost_) seen_while_lost_.carry(step);
  if (!tracked_.empty()) {
    TrackedPose& t = tracked_.back();
    t.Q = step.F * t.Q * step.F.transpose() + step.Q;
    t.F = step.F * t.F;
  }
  for (HeldFix& h : held_) h.Q = step.F * h.Q * step.F.transpose() + step.Q;
}

bool Recovery::usable(const RelocalisationResult& r, std::size_t n) {
  return r.status == RelocalisationStatus::kFound && r.pose.allFinite() &&
         r.covariance.allFinite() && r.landmark.size() == n;
}

std::optional<RelocalisationResult> Recovery::probe(const std::vector<MapLandmark>& map,
                                                    ScanReport* report) {
  if (map.size() < 3) return std::nullopt;
  relocaliser_->setMap(map);
  ++counters_.probes;
  const RelocalisationResult r = callRelocaliser(report);
  if (!usable(r, report->observations.size())) return std::nullopt;
  const EkfSlam& ekf = filter_.ekf();
  Eigen::Vector3d d = r.pose - ekf.pose();
  d.z() = wrapAngle(d.z());
  const Eigen::Matrix3d S = ekf.poseCovariance() + r.covariance;
  if (d.dot(S.ldlt().solve(d)) <= chi2Quantile(kProbeProbability, 3))
    return std::nullopt;  // the filter agrees
  report->lost_reason = "nothing established paired; the relocaliser puts the vehicle " +
                        std::to_string(d.head<2>().norm()) + " m from the estimate";
  return r;
}

RelocalisationResult Recovery::callRelocaliser(ScanReport* report) {
  report->relocalisation_attempted = true;
  ++counters_.relocalisation_attempts;
  window_pairings_.clear();
  window_first_scan_ = report->scan;
  const auto t0 = std::chrono::steady_clock::now();
  report->relocalisation =
      window_.size() > 1 && lost_
          ? relocaliseWindow(report)
          : relocaliser_->relocalise(report->observations, model_.sensorOffset(), nullptr);
  report->relocalisation_s = secondsSince(t0);
  const RelocalisationResult& r = report->relocalisation;
  if (r.status == RelocalisationStatus::kAmbiguous) {
    ++counters_.relocalisations_ambiguous;
  } else if (!usable(r, report->observations.size())) {
    ++counters_.relocalisations_not_found;
  }
  return r;
}

RelocalisationResult Recovery::relocaliseWindow(ScanReport* report) {
  const Eigen::Vector3d now = motion_.pose();
  window_.push(report->scan, now, report->observations);
  const std::vector<CarriedScan> scans = window_.carried(now);
  if (scans.empty())
    return relocaliser_->relocalise(report->observations, model_.sensorOffset(), nullptr);
  RelocalisationResult r = relocaliser_->relocaliseWindow(scans, model_.sensorOffset(), nullptr);
  // The current scan's pairings are the report's (it is the last scan unless it saw nothing); the
  // older scans' go into the update as observations carried into the current sensor frame, with
  // the filter's own R grown by the odometry's covariance.
  const std::size_t older =
      r.landmark.size() - std::min(r.landmark.size(), report->observations.size());
  const Eigen::Vector3d& offset = model_.sensorOffset();
  const Eigen::Matrix2d Rs = rotation2d(offset.z());
  std::size_t k = 0;
  for (std::size_t s = 0; s < scans.size() && scans[s].scan != report->scan && k < older; ++s) {
    for (const Observation& o : scans[s].observations) {
      if (k >= older) break;
      const LandmarkId id = r.landmark[k++];
      if (id == kNoLandmark || r.status != RelocalisationStatus::kFound) continue;
      const std::vector<ObservedPoint> p =
          observedPoints({o}, offset, std::numeric_limits<double>::infinity());
      if (p.empty()) continue;
      Eigen::Vector2d x = p[0].p;
      Eigen::Matrix2d C = p[0].cov;
      carryPoint(scans[s].origin, scans[s].origin_covariance, &x, &C);
      window_pairings_.push_back(Pairing{id, Rs.transpose() * (x - offset.head<2>()),
                                         Rs.transpose() * C * Rs, MeasurementKind::kCartesian});
    }
  }
  r.landmark.erase(r.landmark.begin(), r.landmark.begin() + static_cast<std::ptrdiff_t>(older));
  window_first_scan_ = scans.front().scan;
  return r;
}

std::optional<RelocalisationResult> Recovery::relocalise(ScanReport* report, bool* resumed) {
  *resumed = false;
  report->lost = true;
  ++scans_lost_;
  report->association.resize(report->observations.size());
  const RelocalisationResult r = callRelocaliser(report);
  if (usable(r, report->observations.size()) && confirm(r, report)) return r;
  // Not found for too long (the rule fired wrongly, or the vehicle left the map): tracking
  // resumes from the dead-reckoned estimate rather than freezing the map forever.
  if (!pose_unknown_ && config_.lost_max_scans > 0 && ++lost_scans_ >= config_.lost_max_scans) {
    ++counters_.lost_timeouts;
    report->lost_reason = "no relocalisation in " + std::to_string(lost_scans_) +
                          " scans: tracking resumes from the estimate";
    lost_ = false;
    *resumed = true;
    held_.clear();
    lost_path_.clear();  // tracking resumes from the dead-reckoned path: nothing to correct
    seen_while_lost_.clear();
    tracked_.clear();
  }
  return std::nullopt;
}

bool Recovery::confirm(const RelocalisationResult& r, ScanReport* report) {
  if (confirmedFix(r, window_first_scan_, report->scan)) return true;
  ++counters_.relocalisations_unconfirmed;
  report->lost_reason += (report->lost_reason.empty() ? "" : "; ") + std::string("held: fix ") +
                         std::to_string(held_.empty() ? 0 : held_.back().count) + " of " +
                         std::to_string(config_.relocalisation_confirmations + 1) +
                         " that must agree";
  return false;
}

bool Recovery::confirmedFix(const RelocalisationResult& r, std::uint32_t first_scan,
                            std::uint32_t last_scan) {
  const Eigen::Vector3d estimate = motion_.pose();
  // The held fix that this one confirms: the most confirmed (then the newest) that agrees.
  HeldFix* match = nullptr;
  bool repeats = false;
  for (HeldFix& h : held_) {
    if (!agrees(h, r)) continue;
    // A fix from scans the held one used repeats its data, and would repeat a chance alignment:
    // it does not confirm that one.
    if (first_scan <= h.last_scan) {
      repeats = true;
    } else if (match == nullptr || h.count >= match->count) {
      match = &h;
    }
  }
  // Agreeing only with fixes whose scans it shares: neither a confirmation nor a new place.
  if (match == nullptr && repeats) return false;
  HeldFix fix{r.pose,    estimate,     match ? match->count + 1 : 1,
              last_scan, r.covariance, Eigen::Matrix3d::Zero()};
  if (match) held_.erase(held_.begin() + (match - held_.data()));
  if (static_cast<int>(held_.size()) >= config_.relocalisation_held_fixes)
    held_.erase(held_.begin());
  held_.push_back(fix);
  if (fix.count <= config_.relocalisation_confirmations) return false;
  held_.clear();
  return true;
}

bool Recovery::agrees(const HeldFix& h, const RelocalisationResult& r) const {
  // The held fix moved by the odometry since: the estimate integrates it while lost.
  const Eigen::Vector3d u = composePose(inversePose(h.estimate), motion_.pose());
  const Eigen::Vector3d moved = composePose(h.pose, u);
  Eigen::Vector3d d = moved - r.pose;
  d.z() = wrapAngle(d.z());
  const double p = config_.relocalisation_confirm_probability;
  if (p <= 0.0) {
    return d.head<2>().norm() <= config_.relocalisation_confirm_distance &&
           std::abs(d.z()) <= config_.relocalisation_confirm_angle;
  }
  const Eigen::Matrix3d S =
      carriedCovariance(h.pose, h.covariance, u, h.estimate.z(), h.Q) + r.covariance;
  return d.dot(S.ldlt().solve(d)) <= chi2Quantile(p, 3);
}

std::vector<Pairing> Recovery::takeWindowPairings() {
  std::vector<Pairing> out = std::move(window_pairings_);
  window_pairings_.clear();
  return out;
}

void Recovery::fixed(const Eigen::Vector3d& dead_reckoned, ScanReport* report) {
  // The scans processed while lost were dead-reckoned from a wrong pose, but the odometry
  // between each of them and this scan holds: carried back from the fixed pose they are where
  // the vehicle was (docs/relocalisation.md, "The lost path").
  const Eigen::Vector3d to_fixed = composePose(motion_.pose(), inversePose(dead_reckoned));
  // And the tracked scans before going lost that the fix contradicts: the kidnap happened before
  // a rule or probe could see it.
  report->lost_path = rederiveTracked(dead_reckoned);
  counters_.rederived_tracked_poses += report->lost_path.size();
  tracked_.clear();
  report->lost_path.reserve(report->lost_path.size() + lost_path_.size());
  for (LostPathPose p : lost_path_) {
    p.pose = composePose(to_fixed, p.pose);
    p.pose.z() = wrapAngle(p.pose.z());
    report->lost_path.push_back(p);
  }
  counters_.lost_path_poses += lost_path_.size();
  report->lost_scans = scans_lost_;
  lost_path_.clear();
  ++counters_.relocalisations;
  report->relocalised = true;
  lost_ = false;
}

void Recovery::rememberPose(const ScanReport& report) {
  if (!relocaliser_) return;
  if (lost_) {
    if (lost_path_.size() >= kMaxLostPath) lost_path_.pop_front();
    lost_path_.push_back({report.scan, report.stamp, motion_.pose()});
    // Only what was not applied: the scan that made the rule fire was tracked.
    if (report.lost && config_.lost_map_scans)
      seen_while_lost_.add(report.scan, motion_.pose(), report.observations);
    return;
  }
  tracked_.push_back({report.scan, report.stamp, book_.informativeScans(), motion_.pose(),
                      motion_.poseCovariance(), motion_.odometry(), Eigen::Matrix3d::Identity(),
                      Eigen::Matrix3d::Zero()});
  // Only the scans a rule or probe could still take for the start of a kidnap: those within
  // lost_recent_scans (in the same count as LandmarkBook::recent).
  const auto old = [this, &report](const TrackedPose& t) {
    return config_.lost_recent_informative
               ? book_.informativeScans() - t.informative > config_.lost_recent_scans
               : static_cast<std::int64_t>(report.scan) - t.scan > config_.lost_recent_scans;
  };
  while (!tracked_.empty() && (old(tracked_.front()) || tracked_.size() > kMaxLostPath))
    tracked_.pop_front();
}

std::vector<LostPathPose> Recovery::rederiveTracked(const Eigen::Vector3d& dead_reckoned) const {
  std::vector<LostPathPose> path;
  const Eigen::Vector3d fixed = motion_.pose();
  const Eigen::Matrix3d P = motion_.poseCovariance();
  const double gate = chi2Quantile(kProbeProbability, 3);
  // Newest first, up to the first scan whose estimate the carried-back fix agrees with: there the
  // estimate was still right, and every older one with it. Q: the current pose's covariance given
  // that scan's by the odometry, Phi: d now / d (the newer scan), chained back one scan at a time.
  Eigen::Matrix3d Q = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d Phi = Eigen::Matrix3d::Identity();
  for (auto t = tracked_.rbegin(); t != tracked_.rend(); ++t) {
    Q += Phi * t->Q * Phi.transpose();
    Phi = Phi * t->F;
    const Eigen::Vector3d v = composePose(inversePose(motion_.odometry()), t->odometry);
    Eigen::Vector3d carried = composePose(fixed, v);
    carried.z() = wrapAngle(carried.z());
    Eigen::Vector3d d = carried - t->pose;
    d.z() = wrapAngle(d.z());
    // carried = fixed o v, the odometry's noise turned from the dead-reckoned frame.
    const Eigen::Matrix3d S = t->covariance + carriedCovariance(fixed, P, v, dead_reckoned.z(), Q);
    if (d.dot(S.ldlt().solve(d)) <= gate) break;
    path.push_back({t->scan, t->stamp, carried, /*tracked=*/true});
  }
  std::reverse(path.begin(), path.end());
  return path;
}

}  // namespace ekf_slam
