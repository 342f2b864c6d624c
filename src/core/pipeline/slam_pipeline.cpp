// The SLAM data flow: odometry -> (composed) prediction; scan -> trees -> observations ->
// association -> EKF update / initialisation / removal. See slam_pipeline.h.
#include "ekf_slam/core/pipeline/slam_pipeline.h"

#include "ekf_slam/core/common/pose2d.h"

#include "ekf_slam/core/feature_extraction/tree_feature_extractor.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/relocalisation/geometric_constraints.h"
#include "ekf_slam/core/feature_extraction/scan_geometry.h"

namespace ekf_slam {

namespace {

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

bool finite(const MotionStep& s) {
  return s.pose.allFinite() && s.F.allFinite() && s.Q.allFinite() && s.Fc.allFinite() &&
         s.Qvc.allFinite() && s.Qc.allFinite();
}

constexpr const char* kMapHeader = "ekf_slam_map 1";

// On a successful relocalisation the pose covariance is first set to the relocaliser's times
// this (sigmas x 100): next to the observations it carries no information, so the EKF update
// with the pairings that follows re-derives the pose, its covariance and its cross-covariance
// with the map from the map and the scan alone (docs/relocalisation.md).
constexpr double kRelocalisedPriorInflation = 1e4;
// The lost path kept for re-deriving (ScanReport::lost_path): the newest this many scans, about
// half an hour of Victoria Park's; the older ones are forgotten, not corrected.
constexpr std::size_t kMaxLostPath = 10000;
// A probe's pose is a kidnap when the filter's estimate does not cover it: its difference from
// the estimate, with both covariances, beyond chi2(3) at this probability.
constexpr double kProbeProbability = 0.999;

// Covariance of anchor o u, u the motion an estimate with heading `estimate_yaw` integrated
// (Q its noise, in that estimate's map frame): d/d anchor = [I, S R u_xy; 0 1] (S the 90 degree
// turn), and Q turned from the estimate's frame into the anchor's. A held fix moved to now
// (agrees) and a fix carried back to a tracked scan (rederiveTracked) are both this.
Eigen::Matrix3d carriedCovariance(const Eigen::Vector3d& anchor, const Eigen::Matrix3d& anchor_cov,
                                  const Eigen::Vector3d& u, double estimate_yaw,
                                  const Eigen::Matrix3d& Q) {
  const Eigen::Vector2d lever = rotation2d(anchor.z()) * u.head<2>();
  Eigen::Matrix3d Ja = Eigen::Matrix3d::Identity();
  Ja(0, 2) = -lever.y();
  Ja(1, 2) = lever.x();
  Eigen::Matrix3d Jr = Eigen::Matrix3d::Identity();
  Jr.topLeftCorner<2, 2>() = rotation2d(anchor.z() - estimate_yaw);
  return Ja * anchor_cov * Ja.transpose() + Jr * Q * Jr.transpose();
}

}  // namespace

SlamPipeline::SlamPipeline(const PipelineConfig& config,
                           std::shared_ptr<DataAssociation> associator)
    : config_(config),
      associator_(std::move(associator)),
      index_(config.index_cell_size),
      extractor_(std::make_shared<TreeFeatureExtractor>(config.extractor)),
      twist_model_(config.twist),
      pose_delta_model_(config.pose_delta),
      correction_(config.correction),
      window_(config.relocalisation_window_scans) {
  config_.validate();
  if (!associator_) throw std::invalid_argument("SlamPipeline: no associator given");
  nis_chi2_ = Chi2Table(config_.lost_nis_probability, 64);
  if (config_.filter == "cekf") {
    CompressedEkfParams p;
    p.area_size = config_.cekf_area_size;
    p.margin = config_.cekf_margin;
    p.slack = config_.cekf_area_slack;
    p.reach = config_.max_observation_range;
    cekf_ = std::make_unique<CompressedEkf>(&ekf_, p);
  }
  ekf_.setLinearisation(config_.jacobians == "first_estimate" ? Linearisation::kFirstEstimate
                                                              : Linearisation::kStandard);
  ekf_.setSecondOrderObservations(config_.second_order_observations);
  reset();
  counters_.resets = 0;
}

void SlamPipeline::reset() {
  const Eigen::Vector3d s = config_.initial_pose_sigma;
  ekf_.reset(config_.initial_pose, s.cwiseProduct(s).asDiagonal(), correction_.prior());
  if (cekf_) cekf_->reset();
  index_.clear();
  index_.sync(ekf_);
  info_.clear();
  associator_->reset();
  time_ = std::numeric_limits<double>::quiet_NaN();
  have_odometry_ = false;
  last_odom_ = OdometryInput();
  last_scan_stamp_ = std::numeric_limits<double>::quiet_NaN();
  last_scan_ranges_.clear();
  odom_pose_at_time_.setZero();
  pending_steps_ = 0;
  motion_valid_ = false;
  motion_.setZero();
  motion_covariance_.setZero();
  lost_ = false;
  unpaired_streak_ = nis_streak_ = refused_streak_ = 0;
  share_window_.clear();
  informative_scans_ = 0;
  tracked_.clear();
  ++counters_.resets;
}

// --- lost-robot recovery -------------------------------------------------------------------------

void SlamPipeline::setRelocaliser(std::shared_ptr<Relocaliser> relocaliser) {
  relocaliser_ = std::move(relocaliser);
  if (!relocaliser_) lost_ = false;
}

bool SlamPipeline::requestRelocalisation() {
  if (!relocaliser_) return false;
  ++counters_.relocalisation_requests;
  if (!lost_) enterLost();
  return true;
}

void SlamPipeline::injectPoseJump(const Eigen::Vector3d& delta) {
  if (!delta.allFinite()) return;
  applyPendingMotion();
  if (cekf_) cekf_->flush();
  ekf_.setPose(ekf_.pose() + delta);
}

std::vector<MapLandmark> SlamPipeline::mapLandmarks() const {
  const EkfSlam& ekf = this->ekf();
  std::vector<MapLandmark> map(ekf.numLandmarks());
  for (std::size_t k = 0; k < map.size(); ++k) {
    MapLandmark& l = map[k];
    l.id = ekf.landmarkIds()[k];
    l.position = ekf.landmark(static_cast<int>(k));
    l.covariance = ekf.landmarkCovariance(static_cast<int>(k));
    l.descriptor = landmarkInfo(l.id).diameter;
  }
  return map;
}

void SlamPipeline::enterLost(bool pose_unknown) {
  lost_ = true;
  pose_unknown_ = pose_unknown;
  lost_scans_ = 0;
  held_.clear();
  unpaired_streak_ = nis_streak_ = refused_streak_ = 0;
  share_window_.clear();
  window_.clear();  // scans from before are at a pose now in doubt
  lost_path_.clear();
  if (pose_unknown) tracked_.clear();    // a new map: the scans before say nothing about the pose
  relocaliser_->setMap(mapLandmarks());  // frozen until found
}

bool SlamPipeline::recent(LandmarkId id) const {
  const auto it = info_.find(id);
  if (it == info_.end() || it->second.created_scan < 0) return false;
  if (config_.lost_recent_informative)
    return informative_scans_ - it->second.created_informative <= config_.lost_recent_scans;
  return static_cast<std::int64_t>(scans_) - it->second.created_scan <= config_.lost_recent_scans;
}

void SlamPipeline::checkLost(ScanReport* report) {
  const AssociationResult& a = report->association;
  const int n = static_cast<int>(report->observations.size());
  // Rule 1: observations, none paired with an established landmark, for several scans. Pairings
  // with recent landmarks do not count: a kidnapped filter maps the place it is in anew, and
  // pairs with what it has just mapped.
  int established = 0;
  for (std::size_t i = 0; i < a.decision.size(); ++i)
    established += a.decision[i] == Decision::kPaired && !recent(a.landmark[i]);
  // lost_min_paired_share > 0: a few chance pairings among many landmarks in view still count
  // as unpaired.
  const bool share_rule = config_.lost_min_paired_share > 0.0;
  if (share_rule) report->landmarks_expected = landmarksInView();
  if (established > 0 &&
      established >= config_.lost_min_paired_share * report->landmarks_expected) {
    unpaired_streak_ = 0;
  } else if (n >= config_.lost_min_observations) {
    ++unpaired_streak_;
  }
  // Rule 2: the paired observations persistently disagree with the filter.
  const int paired =
      static_cast<int>(std::count(a.decision.begin(), a.decision.end(), Decision::kPaired));
  if (paired > 0 && report->update_ok) {
    nis_streak_ = report->nis > nis_chi2_(report->nis_dof) ? nis_streak_ + 1 : 0;
  }
  const bool unpaired =
      config_.lost_unpaired_scans > 0 && unpaired_streak_ >= config_.lost_unpaired_scans;
  if (unpaired && !share_rule) report->landmarks_expected = landmarksInView();
  const bool rule1 = unpaired && report->landmarks_expected >= config_.lost_min_expected;
  const bool rule2 = config_.lost_nis_scans > 0 && nis_streak_ >= config_.lost_nis_scans;
  // Rule 4: over the last lost_share_window scans with established landmarks in view, too few
  // observations explained by them. Chance pairings (one or two a scan among many landmarks in
  // view) restart rule 1's count but hardly raise this share (docs/relocalisation.md).
  bool rule4 = false;
  if (config_.lost_share_window > 0 && n >= config_.lost_min_observations) {
    if (!share_rule && !unpaired) report->landmarks_expected = landmarksInView();
    if (report->landmarks_expected >= config_.lost_min_expected) {
      share_window_.emplace_back(established, n);
      if (share_window_.size() > static_cast<std::size_t>(config_.lost_share_window))
        share_window_.pop_front();
      int window_established = 0, window_observations = 0;
      for (const auto& [e, o] : share_window_) {
        window_established += e;
        window_observations += o;
      }
      rule4 = share_window_.size() == static_cast<std::size_t>(config_.lost_share_window) &&
              window_established < config_.lost_established_share * window_observations;
      if (rule4) {
        report->lost_reason = std::to_string(window_established) + " of " +
                              std::to_string(window_observations) +
                              " observations paired with established landmarks in " +
                              std::to_string(config_.lost_share_window) + " scans";
      }
    }
  }
  // Rule 4's probe: a scan with established landmarks in view of which it explains under
  // lost_established_share by them (rule 4's share, one scan), with too few scans or too few in
  // view for a rule to call it lost. A kidnap shows at once as such a scan (Victoria Park: one
  // chance pairing of 8-10 observations), yet so does a tracking filter among trees the laser
  // misses, so the relocaliser decides, as for rule 1 with few in view.
  bool share_probe = false;
  if (config_.lost_share_probe && !rule1 && !rule2 && !rule4 &&
      n >= std::max(config_.lost_min_observations, 1) &&
      established < config_.lost_established_share * n) {
    if (config_.lost_share_window <= 0) report->landmarks_expected = landmarksInView();
    share_probe = report->landmarks_expected > 0;
  }
  if (rule1 || rule2 || rule4) {
    if (rule1 || rule2) {
      report->lost_reason =
          rule1 ? (share_rule ? "under " + std::to_string(config_.lost_min_paired_share) +
                                    " of the established landmarks in view paired for "
                              : std::string("no established landmark paired for ")) +
                      std::to_string(unpaired_streak_) + " scans, " +
                      std::to_string(report->landmarks_expected) + " in view"
                : "NIS above chi2(2k, " + std::to_string(config_.lost_nis_probability) + ") for " +
                      std::to_string(nis_streak_) + " scans";
    }
    discardRecent(report);
    ++counters_.lost_events;
    report->became_lost = true;
    enterLost();
    return;
  }
  // Nothing established paired and nothing established in view: new ground, or a kidnap into a
  // place the filter takes for new ground. The relocaliser tells them apart: a confident pose in
  // the established map that the filter's estimate does not cover is a kidnap.
  if (unpaired || share_probe) probe(report);
}

bool SlamPipeline::checkRefused(ScanReport* report) {
  if (config_.lost_rejected_scans <= 0) return false;
  AssociationResult& a = report->association;
  const int paired =
      static_cast<int>(std::count(a.decision.begin(), a.decision.end(), Decision::kPaired));
  // Rule 3: the associator recognised these landmarks without the pose, and the filter refused
  // them, more than it paired. Seen at the first scan after a kidnap, while rule 1 waits for
  // several scans (and chance pairings restart it).
  if (a.gate_refused < std::max(config_.lost_min_observations, 1) || a.gate_refused <= paired) {
    refused_streak_ = 0;
    return false;
  }
  // Its unrecognised observations would start landmarks at the wrong pose: a second copy of the
  // map that the filter would then track.
  const auto suppressNew = [&a, this] {
    for (Decision& d : a.decision) {
      if (d != Decision::kNew) continue;
      d = Decision::kRejected;
      ++counters_.suppressed_new;
    }
  };
  if (++refused_streak_ < config_.lost_rejected_scans) {
    suppressNew();
    return false;
  }
  // The relocaliser confirms on this scan (a probe): lost only when it puts the vehicle where
  // the estimate does not cover. A graph mismatch, or a filter merely inaccurate, is no kidnap.
  const std::string reason =
      std::to_string(a.gate_refused) + " observations recognised but refused by the filter gate (" +
      std::to_string(paired) + " paired) for " + std::to_string(refused_streak_) + " scans";
  probe(report);
  if (report->became_lost) {
    report->lost_reason = reason + "; " + report->lost_reason;
    if (!report->relocalised) {
      // The fix is held for confirmation: nothing of this scan is applied.
      report->lost = true;
      report->association.resize(report->observations.size());
    }
    return true;
  }
  if (usable(report->relocalisation, report->observations.size())) {
    refused_streak_ = 0;  // the relocaliser agrees with the estimate: applied as associated
  } else {
    suppressNew();  // no answer: the doubt, and the streak, stay
  }
  return false;
}

int SlamPipeline::landmarksInView() const {
  const Eigen::Vector3d sensor = model_.sensorPose(ekf_.pose());
  const double range =
      config_.lost_view_range > 0.0 ? config_.lost_view_range : config_.max_observation_range;
  std::vector<int> near;
  index_.query(ekf_, sensor.head<2>(), range, &near);
  int expected = 0;
  for (const int k : near) {
    if (recent(ekf_.landmarkIds()[k])) continue;  // they say nothing about being lost
    const Eigen::Vector2d d = ekf_.landmark(k) - sensor.head<2>();
    expected += std::abs(wrapAngle(std::atan2(d.y(), d.x()) - sensor.z())) <=
                0.5 * config_.lost_field_of_view;
  }
  return expected;
}

void SlamPipeline::discardRecent(ScanReport* report) {
  // Recent landmarks may come from the wrong pose: the kidnap happened at most that long ago.
  std::vector<LandmarkId> ids;
  for (const LandmarkId id : ekf_.landmarkIds()) {
    if (recent(id)) ids.push_back(id);
  }
  for (const LandmarkId id : ids) {
    if (cekf_ ? cekf_->removeLandmark(id) : ekf_.removeLandmark(id)) {
      info_.erase(id);
      report->removed.push_back(id);
      ++counters_.discarded_landmarks;
    }
  }
  index_.sync(ekf_);
}

void SlamPipeline::probe(ScanReport* report) {
  // The established map only: recent landmarks would explain the scan at the filter's (perhaps
  // wrong) pose.
  std::vector<MapLandmark> map = mapLandmarks();
  map.erase(
      std::remove_if(map.begin(), map.end(), [this](const MapLandmark& l) { return recent(l.id); }),
      map.end());
  if (map.size() < 3) return;
  relocaliser_->setMap(map);
  ++counters_.probes;
  const RelocalisationResult r = callRelocaliser(report);
  if (!usable(r, report->observations.size())) return;
  Eigen::Vector3d d = r.pose - ekf_.pose();
  d.z() = wrapAngle(d.z());
  const Eigen::Matrix3d S = ekf_.poseCovariance() + r.covariance;
  if (d.dot(S.ldlt().solve(d)) <= chi2Quantile(kProbeProbability, 3)) return;  // the filter agrees
  report->lost_reason = "nothing established paired; the relocaliser puts the vehicle " +
                        std::to_string(d.head<2>().norm()) + " m from the estimate";
  discardRecent(report);
  ++counters_.lost_events;
  report->became_lost = true;
  // A kidnap found by a probe is a fix like any other: with relocalisation_confirmations the
  // pipeline goes lost and holds it until the next fixes agree.
  enterLost();
  applyIfConfirmed(r, report);
}

RelocalisationResult SlamPipeline::callRelocaliser(ScanReport* report) {
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

RelocalisationResult SlamPipeline::relocaliseWindow(ScanReport* report) {
  const Eigen::Vector3d now = pose();
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

bool SlamPipeline::usable(const RelocalisationResult& r, std::size_t n) {
  return r.status == RelocalisationStatus::kFound && r.pose.allFinite() &&
         r.covariance.allFinite() && r.landmark.size() == n;
}

void SlamPipeline::relocaliseScan(ScanReport* report) {
  report->lost = true;
  report->association.resize(report->observations.size());
  const RelocalisationResult r = callRelocaliser(report);
  if (usable(r, report->observations.size()) && applyIfConfirmed(r, report)) return;
  // Not found for too long (the rule fired wrongly, or the vehicle left the map): tracking
  // resumes from the dead-reckoned estimate rather than freezing the map forever.
  if (!pose_unknown_ && config_.lost_max_scans > 0 && ++lost_scans_ >= config_.lost_max_scans) {
    ++counters_.lost_timeouts;
    report->lost_reason = "no relocalisation in " + std::to_string(lost_scans_) +
                          " scans: tracking resumes from the estimate";
    lost_ = false;
    unpaired_streak_ = nis_streak_ = 0;
    held_.clear();
    lost_path_.clear();  // tracking resumes from the dead-reckoned path: nothing to correct
    tracked_.clear();
  }
  rememberPose(*report);
}

void SlamPipeline::rememberLostPose(const ScanReport& report) {
  if (!lost_) return;
  if (lost_path_.size() >= kMaxLostPath) lost_path_.pop_front();
  lost_path_.push_back({report.scan, report.stamp, pose()});
}

void SlamPipeline::rememberPose(const ScanReport& report) {
  if (!relocaliser_) return;
  if (lost_) {
    rememberLostPose(report);
    return;
  }
  tracked_.push_back({report.scan, report.stamp, informative_scans_, pose(), poseCovariance(),
                      odometry_, Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Zero()});
  // Only the scans a rule or probe could still take for the start of a kidnap: those within
  // lost_recent_scans (in the same count as recent()).
  const auto old = [this, &report](const TrackedPose& t) {
    return config_.lost_recent_informative
               ? informative_scans_ - t.informative > config_.lost_recent_scans
               : static_cast<std::int64_t>(report.scan) - t.scan > config_.lost_recent_scans;
  };
  while (!tracked_.empty() && (old(tracked_.front()) || tracked_.size() > kMaxLostPath))
    tracked_.pop_front();
}

std::vector<LostPathPose> SlamPipeline::rederiveTracked(
    const Eigen::Vector3d& dead_reckoned) const {
  std::vector<LostPathPose> path;
  const Eigen::Vector3d fixed = pose();
  const Eigen::Matrix3d P = poseCovariance();
  const double gate = chi2Quantile(kProbeProbability, 3);
  // Newest first, up to the first scan whose estimate the carried-back fix agrees with: there the
  // estimate was still right, and every older one with it. Q: the current pose's covariance given
  // that scan's by the odometry, Phi: d now / d (the newer scan), chained back one scan at a time.
  Eigen::Matrix3d Q = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d Phi = Eigen::Matrix3d::Identity();
  for (auto t = tracked_.rbegin(); t != tracked_.rend(); ++t) {
    Q += Phi * t->Q * Phi.transpose();
    Phi = Phi * t->F;
    const Eigen::Vector3d v = composePose(inversePose(odometry_), t->odometry);
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

bool SlamPipeline::applyIfConfirmed(const RelocalisationResult& r, ScanReport* report) {
  if (confirmedFix(r, window_first_scan_, report->scan)) {
    applyRelocalisation(r, report);
    return true;
  }
  ++counters_.relocalisations_unconfirmed;
  report->lost_reason += (report->lost_reason.empty() ? "" : "; ") + std::string("held: fix ") +
                         std::to_string(held_.empty() ? 0 : held_.back().count) + " of " +
                         std::to_string(config_.relocalisation_confirmations + 1) +
                         " that must agree";
  return false;
}

bool SlamPipeline::confirmedFix(const RelocalisationResult& r, std::uint32_t first_scan,
                                std::uint32_t last_scan) {
  const Eigen::Vector3d estimate = pose();
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

bool SlamPipeline::agrees(const HeldFix& h, const RelocalisationResult& r) const {
  // The held fix moved by the odometry since: the estimate integrates it while lost.
  const Eigen::Vector3d u = composePose(inversePose(h.estimate), pose());
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

void SlamPipeline::applyRelocalisation(const RelocalisationResult& r, ScanReport* report) {
  AssociationResult& a = report->association;
  a.resize(report->observations.size());
  for (std::size_t i = 0; i < a.decision.size(); ++i) {
    if (r.landmark[i] != kNoLandmark && ekf_.contains(r.landmark[i])) a.pair(i, r.landmark[i]);
  }
  // The old pose is forgotten; the update with the pairings re-derives it, correlated with the
  // map as it should be (kRelocalisedPriorInflation). filter cekf: the whole state first.
  if (cekf_) cekf_->flush();
  const Eigen::Vector3d dead_reckoned = pose();
  ekf_.replacePose(r.pose, kRelocalisedPriorInflation * r.covariance);
  carried_ = std::move(window_pairings_);  // a window's older pairings join the update
  window_pairings_.clear();
  applyAssociation(report);
  carried_.clear();
  if (!report->update_ok) {
    if (cekf_) cekf_->flush();
    ekf_.replacePose(r.pose, r.covariance);  // uncorrelated, still valid
  }
  // The scans processed while lost were dead-reckoned from a wrong pose, but the odometry
  // between each of them and this scan holds: carried back from the fixed pose they are where
  // the vehicle was (docs/relocalisation.md, "The lost path").
  const Eigen::Vector3d to_fixed = composePose(pose(), inversePose(dead_reckoned));
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
  lost_path_.clear();
  ++counters_.relocalisations;
  report->relocalised = true;
  lost_ = false;
  unpaired_streak_ = nis_streak_ = 0;
}

void SlamPipeline::setSensorOffset(const Eigen::Vector3d& offset) {
  model_.setSensorOffset(offset);
  if (cekf_) cekf_->setReach(config_.max_observation_range + offset.head<2>().norm());
}

// --- prediction ----------------------------------------------------------------------------------

Eigen::Matrix3d SlamPipeline::poseCovariance() const {
  if (pending_steps_ == 0) return ekf_.poseCovariance();
  const Eigen::Matrix3d Pvv = ekf_.poseCovariance();
  Eigen::Matrix3d P = pending_.F * Pvv * pending_.F.transpose() + pending_.Q;
  if (const int k = pending_.corrections; k > 0) {
    // [F Fc] P_aa [F Fc]^T + Q: the cross and correction blocks of the vehicle part.
    const auto Pf = ekf_.storedCovariance();  // a view: its vehicle rows are current
    using Cols = Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kMaxCorrectionStates>;
    const Cols FPvc = pending_.F * Pf.block(0, 3, 3, k);
    const Cols Fc = pending_.Fc.leftCols(k);
    P += FPvc * Fc.transpose() + Fc * FPvc.transpose() + Fc * Pf.block(3, 3, k, k) * Fc.transpose();
  }
  return 0.5 * (P + P.transpose());
}

void SlamPipeline::applyPendingMotion() const {
  if (pending_steps_ == 0) return;
  if (lost_ && !window_.empty()) window_.addMotion(pending_.F, pending_.Q);
  // The odometry alone, for re-deriving past poses from a fix (rederiveTracked), and since the
  // last scan, for a smoother (ScanReport::motion).
  const Eigen::Vector3d delta = composePose(inversePose(ekf_.pose()), pending_.pose);
  odometry_ = composePose(odometry_, delta);
  motion_covariance_ =
      carriedCovariance(motion_, motion_covariance_, delta, ekf_.pose().z(), pending_.Q);
  motion_ = composePose(motion_, delta);
  if (!tracked_.empty()) {
    TrackedPose& t = tracked_.back();
    t.Q = pending_.F * t.Q * pending_.F.transpose() + pending_.Q;
    t.F = pending_.F * t.F;
  }
  for (HeldFix& h : held_) h.Q = pending_.F * h.Q * pending_.F.transpose() + pending_.Q;
  // Steps are checked when composed, so this cannot fail.
  if (cekf_) {
    cekf_->predict(pending_);
  } else {
    ekf_.predict(pending_);
  }
  pending_steps_ = 0;
}

void SlamPipeline::numberScan(ScanReport* report) {
  report->scan = scans_++;
  ++counters_.scans;
  report->has_motion = motion_valid_;
  report->motion = motion_;
  report->motion_covariance = motion_covariance_;
  motion_valid_ = true;
  motion_.setZero();
  motion_covariance_.setZero();
}

void SlamPipeline::compose(const MotionStep& s) {
  if (!finite(s)) {
    ++counters_.rejected_odometry;
    return;
  }
  if (pending_steps_ == 0) {
    pending_ = s;
  } else if (s.corrections == 0) {
    // P' = F2 (F1 P F1^T + Q1) F2^T + Q2 = (F2 F1) P (F2 F1)^T + (F2 Q1 F2^T + Q2): exact, and
    // the pose-map block F2 F1 P_vm likewise.
    pending_.pose = s.pose;
    pending_.Q = s.F * pending_.Q * s.F.transpose() + s.Q;
    pending_.F = s.F * pending_.F;
  } else {
    // With correction states c (constant in a prediction, plus a random walk) each step is
    // A = [F Fc; 0 I] with noise N = [Q Qvc; Qvc^T Qc]; A2 A1 and A2 N1 A2^T + N2 give
    //   F = F2 F1, Fc = F2 Fc1 + Fc2, Qc = Qc1 + Qc2, Qvc = F2 Qvc1 + Fc2 Qc1 (+ Qvc2),
    //   Q = F2 Q1 F2^T + F2 Qvc1 Fc2^T + Fc2 Qvc1^T F2^T + Fc2 Qc1 Fc2^T + Q2.
    const Eigen::Matrix<double, 3, 2> F2Qvc1 = s.F * pending_.Qvc;
    pending_.pose = s.pose;
    pending_.Q = s.F * pending_.Q * s.F.transpose() + F2Qvc1 * s.Fc.transpose() +
                 s.Fc * F2Qvc1.transpose() + s.Fc * pending_.Qc * s.Fc.transpose() + s.Q;
    pending_.Qvc = F2Qvc1 + s.Fc * pending_.Qc + s.Qvc;
    pending_.Qc += s.Qc;
    pending_.Fc = s.F * pending_.Fc + s.Fc;
    pending_.F = s.F * pending_.F;
  }
  ++pending_steps_;
}

void SlamPipeline::composeStep(double dt) {
  if (correction_.dim() == 0) {
    compose(twist_model_.step(pose(), last_odom_.twist, dt));
    return;
  }
  // The twist the vehicle drove according to the current correction estimate (a prediction
  // does not move the estimate, so the EKF's mean is current even with motion pending); the
  // pose's Jacobian w.r.t. the states is G dtwist'/dc.
  Eigen::Matrix2d J;
  const Eigen::Vector2d u = correction_.apply(last_odom_.twist, ekf_.correction(), &J);
  Eigen::Matrix<double, 3, 2> G;
  MotionStep s = twist_model_.step(pose(), u, dt, &G);
  s.corrections = correction_.dim();
  s.Fc = G * J;
  s.Qc = correction_.randomWalk(dt);
  compose(s);
}

void SlamPipeline::composePoseDelta(const Eigen::Vector3d& delta) {
  compose(pose_delta_model_.step(pose(), delta));
}

void SlamPipeline::advanceTo(double stamp) {
  if (std::isfinite(time_) && have_odometry_) {
    const double dt = stamp - time_;
    if (dt > 0.0) {
      if (config_.odometry_mode == "pose_delta") {
        // Where the odometry would be at `stamp`: its last pose moved on with its twist.
        const Eigen::Vector3d extrapolated =
            twist_model_.predict(odom_pose_at_time_, last_odom_.twist, dt);
        composePoseDelta(PoseDeltaModel::between(odom_pose_at_time_, extrapolated));
        odom_pose_at_time_ = extrapolated;
      } else {
        composeStep(dt);
      }
    }
  }
  // Before the first odometry message the vehicle is taken to be still.
  time_ = stamp;
}

bool SlamPipeline::addOdometry(const OdometryInput& odom) {
  const bool pose_delta = config_.odometry_mode == "pose_delta";
  if (!std::isfinite(odom.stamp) || !odom.twist.allFinite() ||
      (pose_delta && !odom.pose.allFinite())) {
    ++counters_.rejected_odometry;
    return false;
  }
  // Finite but physically impossible (1e300 m/s would move the pose to infinity): not driven.
  if (std::abs(odom.twist(0)) > config_.max_speed ||
      std::abs(odom.twist(1)) > config_.max_yaw_rate) {
    ++counters_.implausible_odometry;
    return false;
  }
  if (pose_delta && !odom.orientation_valid) {
    ++counters_.invalid_orientations;
    return false;
  }
  if (std::isfinite(time_) && odom.stamp < time_) {
    ++counters_.late_odometry;
    return false;
  }
  ++counters_.odometry;
  if (have_odometry_) {
    if (odom.stamp - last_odom_.stamp > config_.max_odometry_gap) ++counters_.odometry_gaps;
    if (pose_delta) {
      composePoseDelta(PoseDeltaModel::between(odom_pose_at_time_, odom.pose));
      time_ = odom.stamp;
    } else {
      advanceTo(odom.stamp);  // the previous twist holds up to this message
    }
  } else {
    time_ = odom.stamp;
    have_odometry_ = true;
  }
  last_odom_ = odom;
  odom_pose_at_time_ = odom.pose;
  return true;
}

double SlamPipeline::predictTo(double stamp, ScanReport* report) {
  if (!std::isfinite(stamp)) {
    ++counters_.invalid_stamps;
    report->late = true;
    stamp = std::isfinite(time_) ? time_ : 0.0;
  } else if (std::isfinite(time_) && stamp < time_) {
    ++counters_.late_scans;
    report->late = true;
    stamp = time_;
  }
  if (!have_odometry_) ++counters_.scans_before_odometry;
  advanceTo(stamp);
  applyPendingMotion();
  return stamp;
}

// --- scans ---------------------------------------------------------------------------------------

void SlamPipeline::setFeatureExtractor(std::shared_ptr<FeatureExtractor> extractor) {
  extractor_ =
      extractor ? std::move(extractor) : std::make_shared<TreeFeatureExtractor>(config_.extractor);
}

ScanReport SlamPipeline::processScan(double stamp, const std::vector<float>& ranges,
                                     double angle_min, double angle_increment,
                                     std::optional<double> angle_max) {
  LaserScanData scan;
  scan.ranges = ranges;
  scan.angle_min = angle_min;
  scan.angle_increment = angle_increment;
  scan.angle_max = angle_max;
  return processScan(stamp, scan);
}

ScanReport SlamPipeline::processScan(double stamp, const LaserScanData& input) {
  // A scan the extractor or a filter cannot use at all is a configuration error: it throws
  // before anything changes, so the caller can say so and the state stays as it was.
  const LaserScanData* scan = &input;
  if (!scan_filter_.empty()) {
    filtered_scan_ = input;
    scan_filter_.apply(&filtered_scan_, model_.sensorOffset());
    scan = &filtered_scan_;
  }
  extractor_->checkScan(*scan);
  const std::vector<float>& ranges = scan->ranges;
  const double angle_min = input.angle_min, angle_increment = input.angle_increment;

  ScanReport report;
  // A repeat of the previous scan (a duplicated message, a driver publishing twice) would be
  // used twice, counting every tree as two sightings.
  if (stamp == last_scan_stamp_ && angle_min == last_scan_angle_min_ &&
      angle_increment == last_scan_angle_increment_ && input.ranges == last_scan_ranges_) {
    ++counters_.duplicate_scans;
    report.duplicate = true;
    report.stamp = stamp;
    return report;
  }
  last_scan_stamp_ = stamp;
  last_scan_angle_min_ = angle_min;
  last_scan_angle_increment_ = angle_increment;
  last_scan_ranges_ = input.ranges;
  report.stamp = predictTo(stamp, &report);
  if (input.angle_max)
    report.geometry_error =
        scanGeometryError(input.ranges.size(), angle_min, *input.angle_max, angle_increment);
  if (report.geometry_error) {
    // Trees would be placed at wrong bearings: the scan is only a time step.
    ++counters_.inconsistent_scans;
    numberScan(&report);
    return report;
  }

  const auto t0 = std::chrono::steady_clock::now();
  int invalid = 0;
  for (const float r : ranges) {
    // +inf is a valid "no return" (REP 117); NaN and negative values are not.
    if (std::isnan(r) || r < 0.0f) ++invalid;
  }
  counters_.invalid_ranges += invalid;
  const bool usable = !ranges.empty() && invalid < static_cast<int>(ranges.size()) &&
                      std::isfinite(scan->angle_min) && std::isfinite(scan->angle_increment) &&
                      scan->angle_increment != 0.0;
  std::vector<Observation> observations;
  if (usable) {
    const Eigen::Matrix2d R = Eigen::Vector2d(config_.sigma_range * config_.sigma_range,
                                              config_.sigma_bearing * config_.sigma_bearing)
                                  .asDiagonal();
    for (Observation& o : extractor_->extract(*scan)) {
      const double range = o.z(0);
      if (!(range >= config_.min_observation_range && range <= config_.max_observation_range))
        continue;
      if (o.R.isZero(0.0)) o.R = R;
      // A plugin's output is checked like any external observation.
      if (!(o.z.allFinite() && o.R.allFinite() && o.R(0, 0) > 0.0 && o.R(1, 1) > 0.0 &&
            o.R.determinant() > 0.0 && !std::isinf(o.descriptor))) {
        ++report.invalid_observations;
        continue;
      }
      observations.push_back(o);
    }
    counters_.invalid_observations += report.invalid_observations;
  }
  report.extraction_s = secondsSince(t0);
  if (!usable) {
    // No beams (or no valid beam, or no geometry): a sensor fault, not "nothing seen", so the
    // associator is not told (DJNN would count every landmark in view as missed).
    ++counters_.empty_scans;
    numberScan(&report);
    return report;
  }
  return associateAndUpdate(report.stamp, std::move(observations), std::move(report));
}

namespace {

// The default covariance is (sigma_range, sigma_bearing); a Cartesian observation gets it
// carried to (x, y) at its own point, J R J^T with J = d(x, y) / d(range, bearing).
Eigen::Matrix2d defaultCovariance(const Observation& o, const Eigen::Matrix2d& R_range_bearing) {
  if (o.kind != MeasurementKind::kCartesian) return R_range_bearing;
  const double r = o.z.norm();
  const double c = r > 0.0 ? o.z.x() / r : 1.0;
  const double s = r > 0.0 ? o.z.y() / r : 0.0;
  Eigen::Matrix2d J;
  J << c, -r * s, s, r * c;
  return J * R_range_bearing * J.transpose();
}

}  // namespace

ScanReport SlamPipeline::processObservations(double stamp, std::vector<Observation> observations) {
  ScanReport report;
  report.stamp = predictTo(stamp, &report);
  const Eigen::Matrix2d R_default = Eigen::Vector2d(config_.sigma_range * config_.sigma_range,
                                                    config_.sigma_bearing * config_.sigma_bearing)
                                        .asDiagonal();
  std::size_t kept = 0;
  report.input_index.reserve(observations.size());
  for (std::size_t i = 0; i < observations.size(); ++i) {
    Observation o = observations[i];
    if (o.R.isZero(0.0)) o.R = defaultCovariance(o, R_default);
    const bool ok = o.z.allFinite() && (o.kind == MeasurementKind::kCartesian || o.z(0) >= 0.0) &&
                    o.R.allFinite() && o.R(0, 0) > 0.0 && o.R(1, 1) > 0.0 &&
                    o.R.determinant() > 0.0 && !std::isinf(o.descriptor);
    if (!ok) {
      ++report.invalid_observations;
      continue;
    }
    observations[kept++] = o;
    report.input_index.push_back(static_cast<std::uint32_t>(i));
  }
  observations.resize(kept);
  counters_.invalid_observations += report.invalid_observations;
  return associateAndUpdate(report.stamp, std::move(observations), std::move(report));
}

int SlamPipeline::sanitise(std::size_t n, AssociationResult* r) {
  int fixes = 0;
  if (r->decision.size() != n || r->landmark.size() != n) {
    r->resize(n);  // unusable: everything rejected, nothing removed
    return static_cast<int>(n) + 1;
  }
  for (std::size_t i = 0; i < n; ++i) {
    switch (r->decision[i]) {
      case Decision::kPaired:
        if (!ekf_.contains(r->landmark[i])) {
          r->decision[i] = Decision::kRejected;
          r->landmark[i] = kNoLandmark;
          ++fixes;
        }
        break;
      case Decision::kNew:
      case Decision::kTentative:
      case Decision::kRejected:
        r->landmark[i] = kNoLandmark;
        break;
      default:  // not a Decision at all
        r->decision[i] = Decision::kRejected;
        r->landmark[i] = kNoLandmark;
        ++fixes;
    }
  }
  std::size_t kept = 0;
  for (std::size_t k = 0; k < r->remove.size(); ++k) {
    const LandmarkId id = r->remove[k];
    bool duplicate = false;
    for (std::size_t j = 0; j < kept; ++j) duplicate = duplicate || r->remove[j] == id;
    if (!ekf_.contains(id) || duplicate) {
      ++fixes;
      continue;
    }
    r->remove[kept++] = id;
  }
  r->remove.resize(kept);
  return fixes;
}

ScanReport SlamPipeline::associateAndUpdate(double stamp, std::vector<Observation> observations,
                                            ScanReport report) {
  report.observations = std::move(observations);
  numberScan(&report);
  const std::vector<Observation>& obs = report.observations;
  const std::size_t n = obs.size();
  if (lost_) {
    // The map is frozen: no association (the associator's state stays as it was), no landmark
    // added or removed, only the relocaliser.
    relocaliseScan(&report);
    return report;
  }

  // Association, on the predicted state.
  index_.sync(ekf_);
  // filter cekf: the associators read only the active area's entries, so a landmark outside
  // it within their reach brings everything up to date first (docs/cekf.md).
  if (cekf_ && cekf_->prepare(index_, model_.sensorPose(ekf_.pose()).head<2>(),
                              config_.max_observation_range + config_.cekf_margin))
    index_.sync(ekf_);
  const auto t0 = std::chrono::steady_clock::now();
  {
    const AssociationContext context(ekf_, model_, index_, obs, stamp);
    report.association = associator_->associate(context);
  }
  report.association_s = secondsSince(t0);
  report.invalid_decisions = sanitise(n, &report.association);
  if (report.invalid_decisions > 0) ++counters_.invalid_associations;
  // A kidnap found by rule 3: the associator's decisions are not applied, the relocaliser's are.
  if (relocaliser_ && checkRefused(&report)) {
    rememberPose(report);
    return report;
  }
  informative_scans_ += static_cast<int>(n) >= config_.lost_min_observations;
  applyAssociation(&report);
  if (relocaliser_) checkLost(&report);
  rememberPose(report);  // went lost at this scan: its pose is carried back at the fix too
  return report;
}

void SlamPipeline::applyAssociation(ScanReport* report) {
  const std::vector<Observation>& obs = report->observations;
  const std::size_t n = obs.size();
  AssociationResult& result = report->association;
  if (mapFrozen()) {
    // The map is used, not rebuilt: what the associator would add or delete is only counted.
    for (Decision& d : result.decision) {
      if (d != Decision::kNew) continue;
      d = Decision::kRejected;
      ++counters_.frozen_new;
    }
    counters_.frozen_removals += result.remove.size();
    result.remove.clear();
  }
  const auto t0 = std::chrono::steady_clock::now();
  // 1. One batch update with every paired observation (the original measurements).
  pairings_.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (result.decision[i] == Decision::kPaired)
      pairings_.push_back(Pairing{result.landmark[i], obs[i].z, obs[i].R, obs[i].kind});
  }
  pairings_.insert(pairings_.end(), carried_.begin(), carried_.end());
  report->nis_dof = 2 * static_cast<int>(pairings_.size());
  const Eigen::Vector3d prior = ekf_.pose();
  report->update_ok = cekf_ ? cekf_->update(pairings_, model_, &report->nis)
                            : ekf_.update(pairings_, model_, &report->nis);
  counters_.clamped_corrections = ekf_.correctionClamps();
  counters_.refused_correction_updates = ekf_.correctionRefusals();
  if (!report->update_ok) {
    ++counters_.rejected_updates;
    report->nis = 0.0;
  } else {
    if (!pairings_.empty()) associator_->poseCorrected(prior, ekf_.pose());
    for (std::size_t i = 0; i < n; ++i) {
      if (result.decision[i] != Decision::kPaired) continue;
      LandmarkInfo& info = info_[result.landmark[i]];
      ++info.times_observed;
      if (std::isfinite(obs[i].descriptor)) {
        ++info.descriptor_count;
        info.diameter =
            info.descriptor_count == 1
                ? obs[i].descriptor
                : info.diameter + (obs[i].descriptor - info.diameter) / info.descriptor_count;
      }
    }
  }

  // 2. New landmarks, from the updated pose.
  for (std::size_t i = 0; i < n; ++i) {
    if (result.decision[i] != Decision::kNew) continue;
    const LandmarkId id = cekf_ ? cekf_->addLandmark(obs[i].z, obs[i].R, model_, obs[i].kind)
                                : ekf_.addLandmark(obs[i].z, obs[i].R, model_, obs[i].kind);
    if (id == kNoLandmark) {
      ++counters_.failed_initialisations;
      result.decision[i] = Decision::kRejected;
      continue;
    }
    associator_->landmarkAdded(static_cast<int>(i), id);
    result.landmark[i] = id;
    LandmarkInfo& info = info_[id];
    info.times_observed = 1;
    info.created_scan = report->scan;
    info.created_informative = informative_scans_;
    if (std::isfinite(obs[i].descriptor)) {
      info.diameter = obs[i].descriptor;
      info.descriptor_count = 1;
    }
  }

  // 3. Removals.
  for (const LandmarkId id : result.remove) {
    if (cekf_ ? cekf_->removeLandmark(id) : ekf_.removeLandmark(id)) {
      report->removed.push_back(id);
      info_.erase(id);
    }
  }
  index_.sync(ekf_);
  report->update_s = secondsSince(t0);
}

const LandmarkInfo& SlamPipeline::landmarkInfo(LandmarkId id) const {
  static const LandmarkInfo kUnknown;
  const auto it = info_.find(id);
  return it == info_.end() ? kUnknown : it->second;
}

// --- map files -----------------------------------------------------------------------------------

void SlamPipeline::saveMap(const std::string& path) const { saveMap(path, mapLandmarks()); }

void SlamPipeline::saveMap(const std::string& path, const std::vector<MapLandmark>& map) const {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("map file '" + path + "': cannot open for writing");
  out << kMapHeader << "\n"
      << "# " << map.size() << " landmarks; map frame, metres\n"
      << "# id x y cov_xx cov_xy cov_yy diameter times_observed\n";
  char line[512];
  for (const MapLandmark& l : map) {
    const Eigen::Vector2d& m = l.position;
    const Eigen::Matrix2d& C = l.covariance;
    const LandmarkInfo& info = landmarkInfo(l.id);
    // %.17g: doubles round-trip exactly.
    std::snprintf(line, sizeof(line), "%lld %.17g %.17g %.17g %.17g %.17g %.17g %u\n",
                  static_cast<long long>(l.id), m.x(), m.y(), C(0, 0), C(0, 1), C(1, 1),
                  info.diameter, info.times_observed);
    out << line;
  }
  out.flush();
  if (!out) throw std::runtime_error("map file '" + path + "': write failed");
}

namespace {

struct MapEntry {
  LandmarkId id;
  Eigen::Vector2d position;
  Eigen::Matrix2d cov;
  LandmarkInfo info;
};

bool parseDouble(const std::string& token, double* v) {
  char* end = nullptr;
  *v = std::strtod(token.c_str(), &end);
  return !token.empty() && *end == '\0';
}

bool parseInteger(const std::string& token, long long* v) {
  char* end = nullptr;
  errno = 0;
  *v = std::strtoll(token.c_str(), &end, 10);
  return !token.empty() && *end == '\0' && errno == 0;
}

std::vector<MapEntry> readMapFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("map file '" + path + "': cannot open");
  const auto fail = [&path](int line, const std::string& what) {
    throw std::runtime_error("map file '" + path + "' line " + std::to_string(line) + ": " + what);
  };
  std::vector<MapEntry> entries;
  std::map<LandmarkId, int> line_of;
  std::string text;
  int line = 0;
  while (std::getline(in, text)) {
    ++line;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (line == 1) {
      if (text != kMapHeader)
        fail(1, "expected the header '" + std::string(kMapHeader) + "', got '" + text + "'");
      continue;
    }
    std::istringstream fields(text);
    std::vector<std::string> tok;
    for (std::string t; fields >> t;) tok.push_back(t);
    if (tok.empty() || tok[0][0] == '#') continue;
    if (tok.size() != 8) {
      fail(line, "expected 8 fields (id x y cov_xx cov_xy cov_yy diameter times_observed), got " +
                     std::to_string(tok.size()));
    }
    MapEntry e;
    long long id = 0, times = 0;
    if (!parseInteger(tok[0], &id) || id < 0) fail(line, "bad id '" + tok[0] + "'");
    e.id = id;
    double v[6];
    const char* names[6] = {"x", "y", "cov_xx", "cov_xy", "cov_yy", "diameter"};
    for (int k = 0; k < 6; ++k) {
      if (!parseDouble(tok[1 + k], &v[k]) || (k < 5 && !std::isfinite(v[k])))
        fail(line, std::string("bad ") + names[k] + " '" + tok[1 + k] + "'");
    }
    if (!parseInteger(tok[7], &times) || times < 0 || times > 0xffffffffLL)
      fail(line, "bad times_observed '" + tok[7] + "'");
    e.position = Eigen::Vector2d(v[0], v[1]);
    e.cov << v[2], v[3], v[3], v[4];
    if (!(v[2] > 0.0 && v[4] > 0.0 && v[2] * v[4] - v[3] * v[3] > 0.0))
      fail(line, "covariance is not positive definite");
    if (std::isinf(v[5]) || v[5] < 0.0) fail(line, "bad diameter '" + tok[6] + "'");
    e.info.diameter = v[5];
    e.info.descriptor_count = std::isnan(v[5]) ? 0 : 1;
    e.info.times_observed = static_cast<std::uint32_t>(times);
    const auto seen = line_of.emplace(e.id, line);
    if (!seen.second) {
      fail(line, "duplicate id " + std::to_string(e.id) + " (first on line " +
                     std::to_string(seen.first->second) + ")");
    }
    entries.push_back(e);
  }
  if (line == 0) fail(1, "empty file (expected the header '" + std::string(kMapHeader) + "')");
  return entries;
}

}  // namespace

void SlamPipeline::loadMap(const std::string& path, bool reset_pose, bool unknown_pose) {
  if (unknown_pose && !relocaliser_) {
    throw std::runtime_error("map file '" + path +
                             "': an unknown pose needs a relocaliser (parameter relocaliser)");
  }
  const std::vector<MapEntry> entries = readMapFile(path);  // throws before any change
  applyPendingMotion();
  Eigen::Vector3d pose = ekf_.pose();
  Eigen::Matrix3d pose_cov = ekf_.poseCovariance();
  // The correction estimates carry over (their variances; correlations with the old map go).
  CorrectionPrior correction = correction_.prior();
  correction.mean = ekf_.correction();
  correction.sigma = ekf_.correctionCovariance().diagonal().cwiseSqrt();
  if (reset_pose) {
    const Eigen::Vector3d s = config_.initial_pose_sigma;
    pose = config_.initial_pose;
    pose_cov = s.cwiseProduct(s).asDiagonal();
  }
  ekf_.reset(pose, pose_cov, correction);
  if (cekf_) cekf_->reset();
  info_.clear();
  for (const MapEntry& e : entries) {
    ekf_.insertLandmark(e.position, e.cov, e.id);
    info_[e.id] = e.info;
  }
  index_.clear();
  index_.sync(ekf_);
  associator_->reset();
  for (const MapEntry& e : entries) associator_->landmarkLoaded(e.id, e.info.times_observed);
  lost_ = false;
  tracked_.clear();  // the history belongs to the map before
  if (unknown_pose) {
    ++counters_.relocalisation_requests;
    enterLost(/*pose_unknown=*/true);
  }
}

}  // namespace ekf_slam
