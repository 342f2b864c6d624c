// The SLAM data flow, orchestrated (slam_pipeline.h): each step is its own class.

#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <unordered_map>
#include <utility>
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/pose2d.h"
#include "ekf_slam/core/common/stopwatch.h"

#include "ekf_slam/core/feature_extraction/scan_geometry.h"
#include "ekf_slam/core/pipeline/map_file.h"

namespace ekf_slam {

namespace {

// On a successful relocalisation the pose covariance is first set to the relocaliser's times
// this (sigmas x 100): next to the observations it carries no information, so the EKF update
// with the pairings that follows re-derives the pose, its covariance and its cross-covariance
// with the map from the map and the scan alone (docs/relocalisation.md).
constexpr double kRelocalisedPriorInflation = 1e4;

// The config, checked before anything is built from it.
const PipelineConfig& validated(const PipelineConfig& config) {
  config.validate();
  return config;
}

CompressedEkfParams compressedParams(const PipelineConfig& c) {
  CompressedEkfParams p;
  p.area_size = c.cekf_area_size;
  p.margin = c.cekf_margin;
  p.slack = c.cekf_area_slack;
  p.reach = c.max_observation_range;
  return p;
}

}  // namespace

SlamPipeline::SlamPipeline(const PipelineConfig& config,
                           std::shared_ptr<DataAssociation> associator)
    : config_(validated(config)),
      associator_(std::move(associator)),
      filter_(config_.filter == "cekf", compressedParams(config_)),
      index_(config_.index_cell_size),
      book_(config_),
      delayed_(config_, filter_, model_, counters_),
      motion_(config_, filter_.ekf(), counters_),
      observations_(config_, counters_),
      mapper_(config_, filter_, index_, model_, book_, delayed_, counters_),
      monitor_(config_, filter_.ekf(), index_, model_, book_),
      recovery_(config_, filter_, motion_, model_, book_, counters_) {
  if (!associator_) throw std::invalid_argument("SlamPipeline: no associator given");
  history_.configure(config_.lost_onset_scans, config_.lost_onset_snapshots);
  EkfSlam& ekf = filter_.ekf();
  ekf.setLinearisation(config_.linearisation());
  ekf.setSecondOrderObservations(config_.second_order_observations);
  reset();
  counters_.resets = 0;
}

void SlamPipeline::reset() {
  const Eigen::Vector3d s = config_.initial_pose_sigma;
  filter_.ekf().reset(config_.initial_pose, s.cwiseProduct(s).asDiagonal(),
                      motion_.correction().prior());
  filter_.restart();
  index_.clear();
  index_.sync(filter_.ekf());
  book_.clear();
  book_.resetAge();
  delayed_.clear();
  associator_->reset();
  motion_.reset();
  observations_.reset();
  recovery_.reset();
  monitor_.reset();
  checkpoint_.drop();
  history_.clear();
  ++counters_.resets;
}

// --- inputs --------------------------------------------------------------------------------------

bool SlamPipeline::addOdometry(const OdometryInput& odom) { return motion_.add(odom); }

void SlamPipeline::setSensorOffset(const Eigen::Vector3d& offset) {
  model_.setSensorOffset(offset);
  filter_.setReach(config_.max_observation_range + offset.head<2>().norm());
}

void SlamPipeline::setFeatureExtractor(std::shared_ptr<FeatureExtractor> extractor) {
  observations_.setExtractor(std::move(extractor));
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
  const LaserScanData& scan = observations_.filtered(input, model_.sensorOffset());
  ScanReport report;
  if (observations_.repeats(stamp, input)) {
    report.duplicate = true;
    report.stamp = stamp;
    return report;
  }
  report.stamp = predictTo(stamp, &report);
  if (input.angle_max)
    report.geometry_error = scanGeometryError(input.ranges.size(), input.angle_min,
                                              *input.angle_max, input.angle_increment);
  if (report.geometry_error) {
    // Features would be placed at wrong bearings: the scan is only a time step.
    ++counters_.inconsistent_scans;
    numberScan(&report);
    return report;
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<Observation> observations;
  const bool usable = observations_.extract(scan, &observations, &report);
  report.extraction_s = secondsSince(t0);
  if (!usable) {
    // A sensor fault, not "nothing seen": the associator is not told (DJNN would count every
    // landmark in view as missed).
    ++counters_.empty_scans;
    numberScan(&report);
    return report;
  }
  // What the scan hid, for an associator that must not count a hidden landmark as missed. The
  // configured range noise stands for a beam's (it is the observations' default).
  occlusion_.assign(scan, observations_.extractor().featureRadius(), config_.sigma_range,
                    observations_.extractor().thinnestFeatureRadius());
  return associateAndUpdate(report.stamp, std::move(observations), std::move(report), &occlusion_);
}

ScanReport SlamPipeline::processObservations(double stamp, std::vector<Observation> observations) {
  ScanReport report;
  report.stamp = predictTo(stamp, &report);
  observations = observations_.check(std::move(observations), &report);
  return associateAndUpdate(report.stamp, std::move(observations), std::move(report));
}

// --- prediction ----------------------------------------------------------------------------------

double SlamPipeline::predictTo(double stamp, ScanReport* report) {
  stamp = motion_.advanceToScan(stamp, report);
  applyPendingMotion();
  return stamp;
}

void SlamPipeline::applyPendingMotion() const {
  if (!motion_.pending()) return;
  const MotionStep& step = motion_.step();
  recovery_.carry(step);
  if (checkpoint_.held) checkpoint_.scans.carry(step);
  if (history_.active()) history_.carry(step);
  motion_.applied();  // reads the filter's pose before the step
  filter_.predict(step);
}

void SlamPipeline::numberScan(ScanReport* report) {
  report->scan = scans_++;
  ++counters_.scans;
  motion_.takeMotion(report);
}

// --- one scan ------------------------------------------------------------------------------------

ScanReport SlamPipeline::associateAndUpdate(double stamp, std::vector<Observation> observations,
                                            ScanReport report, const ScanOcclusion* occlusion) {
  report.observations = std::move(observations);
  numberScan(&report);
  if (recovery_.lost()) {
    // The map is frozen: no association (the associator's state stays as it was), no landmark
    // added or removed, only the relocaliser.
    relocaliseLost(&report);
    recordScan(report, report.relocalised);
    return report;
  }
  mapper_.associate(*associator_, stamp, &report, occlusion);
  // A kidnap found by rule 3: the associator's decisions are not applied, the relocaliser's are.
  if (recovery_.active() && kidnapRefused(&report)) {
    recovery_.rememberPose(report);
    recordScan(report, report.relocalised);
    return report;
  }
  book_.countScan(static_cast<int>(report.observations.size()) >= config_.lost_min_observations);
  if (recovery_.active()) updateCheckpoint(report);
  if (recovery_.active() && history_.wantsSnapshot(report.scan) && !mapFrozen() &&
      !filter_.compressed())
    history_.addSnapshot(snapshot(report.scan));
  mapper_.apply(*associator_, {}, &report);
  if (checkpoint_.held) checkpoint_.scans.add(report.scan, motion_.odometry(), report.observations);
  if (recovery_.active()) checkLost(&report);
  recovery_.rememberPose(report);  // went lost at this scan: its pose is carried back at the fix
  recordScan(report, !report.lost || report.relocalised);
  return report;
}

// --- lost-robot recovery -------------------------------------------------------------------------

void SlamPipeline::setRelocaliser(std::shared_ptr<Relocaliser> relocaliser) {
  recovery_.setRelocaliser(std::move(relocaliser));
}

bool SlamPipeline::requestRelocalisation() {
  if (!recovery_.active()) return false;
  ++counters_.relocalisation_requests;
  if (!recovery_.lost()) enterLost();
  return true;
}

void SlamPipeline::injectPoseJump(const Eigen::Vector3d& delta) {
  if (!delta.allFinite()) return;
  applyPendingMotion();
  filter_.flush();
  filter_.ekf().setPose(filter_.ekf().pose() + delta);
}

void SlamPipeline::relocaliseLost(ScanReport* report) {
  bool resumed = false;
  if (const std::optional<RelocalisationResult> fix = recovery_.relocalise(report, &resumed)) {
    applyFix(*fix, report);
    return;
  }
  if (resumed) {
    report->lost_timeout = true;
    monitor_.resume();
  }
  recovery_.rememberPose(*report);
}

bool SlamPipeline::kidnapRefused(ScanReport* report) {
  std::string reason;
  switch (monitor_.refused(*report, &reason)) {
    case LostMonitor::Refusal::kNone:
      return false;
    case LostMonitor::Refusal::kSuppress:
      LostMonitor::suppressNew(&report->association, &counters_);
      return false;
    case LostMonitor::Refusal::kProbe:
      break;
  }
  // The relocaliser confirms on this scan (a probe): lost only when it puts the vehicle where
  // the estimate does not cover. A graph mismatch, or a filter merely inaccurate, is no kidnap.
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
  // The relocaliser agrees with the estimate: the streak ends. No answer: the streak goes on.
  // Either way the scan is applied as associated (a probe that finds no kidnap changes nothing).
  if (Recovery::usable(report->relocalisation, report->observations.size()))
    monitor_.refusalAnswered();
  return false;
}

void SlamPipeline::checkLost(ScanReport* report) {
  switch (monitor_.afterUpdate(report)) {
    case LostMonitor::Verdict::kLost:
      goLost(report);
      break;
    case LostMonitor::Verdict::kProbe: {
      // The rule that asked (rule 2), if any: named with the relocaliser's answer when lost.
      const std::string rule = std::move(report->lost_reason);
      report->lost_reason.clear();
      probe(report);
      if (report->became_lost && !rule.empty())
        report->lost_reason = rule + "; " + report->lost_reason;
      break;
    }
    case LostMonitor::Verdict::kTracking:
      break;
  }
}

void SlamPipeline::probe(ScanReport* report) {
  // The established map only: recent landmarks would explain the scan at the filter's (perhaps
  // wrong) pose. Read without a global update (filter cekf: the landmarks outside the active area
  // as of the last one), so that a probe that finds nothing leaves the filter as it was.
  std::vector<MapLandmark> map = ekf_slam::mapLandmarks(activeEkf(), book_);
  map.erase(std::remove_if(map.begin(), map.end(),
                           [this](const MapLandmark& l) { return book_.recent(l.id, scans_); }),
            map.end());
  const std::optional<RelocalisationResult> fix = recovery_.probe(map, report);
  if (!fix) return;
  // A kidnap found by a probe is a fix like any other: with relocalisation_confirmations the
  // pipeline goes lost and holds it until the next fixes agree.
  goLost(report);
  if (recovery_.confirm(*fix, report)) applyFix(*fix, report);
}

void SlamPipeline::goLost(ScanReport* report) {
  LostScans rolled_back;
  if (checkpoint_.held) {
    rollBack(report);
    rolled_back = std::move(checkpoint_.scans);
    history_.forgetFrom(checkpoint_.scan);
  }
  checkpoint_.drop();
  discardRecent(report);
  ++counters_.lost_events;
  report->became_lost = true;
  enterLost();
  if (!rolled_back.empty() && config_.lost_map_scans)
    recovery_.keepLostScans(std::move(rolled_back));
  if (report->rolled_back_scans > 0)
    report->lost_reason +=
        "; map rolled back " + std::to_string(report->rolled_back_scans) + " scans";
}

void SlamPipeline::updateCheckpoint(const ScanReport& report) {
  // The filter cekf would need a global update to copy its state: no checkpoint.
  if (!config_.lost_rollback || mapFrozen() || filter_.compressed()) return;
  int established = 0;
  const bool suspect = monitor_.suspect(report, &established);
  const std::int64_t now =
      config_.lost_recent_informative ? book_.informativeScans() : std::int64_t{report.scan};
  if (checkpoint_.held) {
    checkpoint_.established += established;
    checkpoint_.observations += static_cast<int>(report.observations.size());
    // A kidnap is taken to have happened at most lost_recent_scans ago (as discardRecent does);
    // and scans that pair well again (rule 4's share over those since) end the doubt.
    const bool well = !suspect && checkpoint_.established >=
                                      config_.lost_established_share * checkpoint_.observations;
    if (well || now - checkpoint_.origin > config_.lost_recent_scans) checkpoint_.drop();
  }
  if (checkpoint_.held || !suspect) return;
  checkpoint_ = snapshot(report.scan);
  checkpoint_.origin = now;
  checkpoint_.established = established;
  checkpoint_.observations = static_cast<int>(report.observations.size());
}

MapCheckpoint SlamPipeline::snapshot(std::uint32_t scan) const {
  MapCheckpoint c;
  const EkfSlam& ekf = filter_.ekf();
  const Eigen::Index n = ekf.mapEnd();
  c.mean = ekf.mean().head(n);
  c.covariance = ekf.storedCovariance().topLeftCorner(n, n);
  c.ids = ekf.landmarkIds();
  c.book = book_.entries();
  for (const LandmarkId id : ekf.landmarkIds()) c.evidence[id] = associator_->evidence(id);
  c.held = true;
  c.scan = scan;
  return c;
}

void SlamPipeline::rollBack(ScanReport* report) {
  const Eigen::Vector3d pose = filter_.ekf().pose();
  if (!restore(checkpoint_, report)) return;
  // The scans since, placed by their odometry back from the current estimate.
  checkpoint_.scans.reanchor(motion_.odometry(), pose);
  report->rolled_back_scans = static_cast<int>(report->scan - checkpoint_.scan + 1);
}

bool SlamPipeline::restore(const MapCheckpoint& checkpoint, ScanReport* report) {
  delayed_.clear();  // its clones leave the state (their poses are in doubt as well)
  EkfSlam& ekf = filter_.ekf();
  const Eigen::Vector3d pose = ekf.pose();
  const std::vector<LandmarkId> before = ekf.landmarkIds();
  if (checkpoint.mean.size() != 3 + ekf.correctionDim() + 2 * Eigen::Index(checkpoint.ids.size()))
    return false;
  // The correction states and the landmarks as they were (those made since go, those dropped
  // since come back); the pose keeps its estimate, uncorrelated with them: it was estimated with
  // what is undone, and a fix replaces it anyway.
  Eigen::VectorXd mean = checkpoint.mean;
  mean.head<3>() = pose;
  Eigen::MatrixXd P = checkpoint.covariance.selfadjointView<Eigen::Lower>();
  const Eigen::Index n = P.rows();
  P.topLeftCorner<3, 3>() = ekf.poseCovariance();
  P.topRightCorner(3, n - 3).setZero();
  P.bottomLeftCorner(n - 3, 3).setZero();
  // setState numbers new landmarks after its largest id: ids made since must not come again.
  const LandmarkId next = ekf.insertLandmark(Eigen::Vector2d::Zero(), Eigen::Matrix2d::Identity());
  ekf.setState(mean, P, checkpoint.ids);
  ekf.insertLandmark(Eigen::Vector2d::Zero(), Eigen::Matrix2d::Identity(), next);
  ekf.removeLandmark(next);
  filter_.restart();
  // Made since: gone with the scans that made them (the lost scans map them again at a fix).
  for (const LandmarkId id : before) {
    if (ekf.contains(id)) continue;
    book_.erase(id);
    report->removed.push_back(id);
    ++counters_.discarded_landmarks;
  }
  // The checkpoint's bookkeeping; dropped since (missed from the wrong pose): back, with the
  // associator's evidence as it was.
  for (const LandmarkId id : ekf.landmarkIds()) {
    const auto info = checkpoint.book.find(id);
    if (info != checkpoint.book.end()) book_.loaded(id, info->second);
    const auto e = checkpoint.evidence.find(id);
    const int evidence = e == checkpoint.evidence.end() ? 0 : e->second;
    if (std::find(before.begin(), before.end(), id) == before.end() ||
        associator_->evidence(id) < evidence)
      associator_->landmarkLoaded(id, static_cast<std::uint32_t>(std::max(evidence, 0)));
  }
  index_.sync(ekf);
  return true;
}

void SlamPipeline::enterLost(bool pose_unknown) {
  // Sightings kept back were taken from poses now in doubt.
  delayed_.clear();
  monitor_.restart();
  recovery_.enterLost(mapLandmarks(), pose_unknown);
}

void SlamPipeline::discardRecent(ScanReport* report) {
  // Recent landmarks may come from the wrong pose: the kidnap happened at most that long ago.
  std::vector<LandmarkId> ids;
  for (const LandmarkId id : filter_.ekf().landmarkIds()) {
    if (book_.recent(id, scans_)) ids.push_back(id);
  }
  mapper_.discard(ids, report);
}

void SlamPipeline::recordScan(const ScanReport& report, bool tracked) {
  if (!history_.active() || !recovery_.active()) return;
  TrackedHistory::Record r;
  r.scan = report.scan;
  r.stamp = report.stamp;
  r.odometry = motion_.odometry();
  r.estimate = motion_.pose();
  r.covariance = motion_.poseCovariance();
  r.tracked = tracked;
  history_.add(r, report.observations);
}

bool SlamPipeline::rollBackToOnset(const RelocalisationResult& fix, ScanReport* report) {
  if (!history_.active() || mapFrozen() || filter_.compressed()) return false;
  // The scans already undone (a lost event's rollback) or processed lost: the onset is looked
  // for before them.
  const std::uint32_t undone = std::min(recovery_.firstLostScan(report->scan), report->scan);
  const EkfSlam& ekf = filter_.ekf();
  const Eigen::Vector3d odometry_now = motion_.odometry();
  const Eigen::Vector3d estimate_now = motion_.pose();
  const std::vector<OnsetScan> scans =
      history_.hypotheses(fix.pose, fix.covariance, odometry_now, estimate_now.z(), undone);
  std::vector<OnsetLandmark> landmarks;
  landmarks.reserve(ekf.numLandmarks());
  for (int k = 0; k < static_cast<int>(ekf.numLandmarks()); ++k) {
    OnsetLandmark l;
    l.position = ekf.landmark(k);
    l.covariance = ekf.landmarkCovariance(k);
    l.created_scan = book_.info(ekf.landmarkIds()[k]).created_scan;
    landmarks.push_back(l);
  }
  OnsetParams params;
  params.pair_probability = config_.lost_map_pair_probability;
  params.max_range = config_.max_observation_range;
  params.field_of_view = config_.lost_field_of_view;
  params.min_score = config_.lost_onset_min_score;
  const KidnapOnset onset = estimateKidnapOnset(scans, landmarks, model_, params);
  if (!onset.found) return false;
  const MapCheckpoint* c = history_.snapshotAtOrBefore(onset.scan);
  // Worth it only when it undoes more scans tracked at a wrong pose than it re-maps right ones
  // (those between the kept state and the onset, carried back by the odometry).
  if (c == nullptr || onset.scan - c->scan >= undone - onset.scan) return false;
  const std::uint32_t from = c->scan;
  if (!restore(*c, report)) return false;
  // Every scan since is a lost scan now, placed by its odometry back from the estimate.
  LostScans lost = history_.scans().from(from);
  lost.reanchor(odometry_now, estimate_now);
  recovery_.keepLostScans(std::move(lost));
  history_.forgetFrom(from);
  ++counters_.onset_rollbacks;
  report->onset_scan = onset.scan;
  report->onset_rolled_back_from = from;
  report->rolled_back_scans = static_cast<int>(report->scan - from);
  report->lost_reason += (report->lost_reason.empty() ? "" : "; ") +
                         std::string("the kidnap began about scan ") + std::to_string(onset.scan) +
                         ": map rolled back to scan " + std::to_string(from);
  return true;
}

void SlamPipeline::addOnsetPath(std::uint32_t from, const Eigen::Vector3d& odometry_at_fix,
                                ScanReport* report) {
  // The tracked scans since the onset's state, up to those the fix re-derived already: carried
  // back from the fixed pose by their odometry.
  const std::uint32_t until =
      report->lost_path.empty() ? report->scan : report->lost_path.front().scan;
  const std::vector<LostPathPose> path =
      history_.path(from, until, composePose(motion_.pose(), inversePose(odometry_at_fix)));
  counters_.rederived_tracked_poses += path.size();
  report->lost_path.insert(report->lost_path.begin(), path.begin(), path.end());
}

void SlamPipeline::applyFix(const RelocalisationResult& fix, ScanReport* report) {
  const Eigen::Vector3d odometry_at_fix = motion_.odometry();
  const bool onset = rollBackToOnset(fix, report);
  const std::uint32_t onset_from = onset ? report->onset_rolled_back_from : report->scan;
  AssociationResult& a = report->association;
  a.resize(report->observations.size());
  EkfSlam& ekf = filter_.ekf();
  for (std::size_t i = 0; i < a.decision.size(); ++i) {
    if (fix.landmark[i] != kNoLandmark && ekf.contains(fix.landmark[i])) a.pair(i, fix.landmark[i]);
  }
  // The old pose is forgotten; the update with the pairings re-derives it, correlated with the
  // map as it should be (kRelocalisedPriorInflation). filter cekf: the whole state first.
  filter_.flush();
  const Eigen::Vector3d dead_reckoned = pose();
  ekf.replacePose(fix.pose, kRelocalisedPriorInflation * fix.covariance);
  // A window's older pairings join the update (those of landmarks still mapped).
  std::vector<Pairing> window = recovery_.takeWindowPairings();
  window.erase(std::remove_if(window.begin(), window.end(),
                              [&ekf](const Pairing& p) { return !ekf.contains(p.id); }),
               window.end());
  mapper_.apply(*associator_, window, report);
  if (!report->update_ok) {
    filter_.flush();
    ekf.replacePose(fix.pose, fix.covariance);  // uncorrelated, still valid
  }
  report->fix_pairings = static_cast<int>(window.size());
  for (const Decision d : a.decision) report->fix_pairings += d == Decision::kPaired;
  report->fix_correction = pose() - dead_reckoned;
  report->fix_correction.z() = wrapAngle(report->fix_correction.z());
  const LostScans lost = recovery_.takeLostScans();
  recovery_.fixed(dead_reckoned, report);
  if (onset) addOnsetPath(onset_from, odometry_at_fix, report);
  if (report->update_ok) mapSeenWhileLost(lost, dead_reckoned, report);
  monitor_.resume();
}

void SlamPipeline::mapSeenWhileLost(const LostScans& lost, const Eigen::Vector3d& dead_reckoned,
                                    ScanReport* report) {
  // Localization mode: the map stays as loaded.
  if (lost.empty() || mapFrozen()) return;
  // The whole state: the lost scans may lie anywhere in the map (filter cekf starts again).
  filter_.flush();
  EkfSlam& ekf = filter_.ekf();
  LostMappingParams params;
  params.pair_probability = config_.lost_map_pair_probability;
  params.new_probability = config_.lost_map_new_probability;
  params.min_sightings = config_.lost_map_min_sightings;
  const LostScanMapping m = mapLostScans(ekf, model_, lost, dead_reckoned, params, &index_);
  // The associator weighs each new landmark by its own rules over the lost scans (DJNN: its
  // evidence, misses included) and may have removed it by now.
  std::vector<char> kept(m.created.size(), 0);
  int n_kept = 0;
  for (std::size_t j = 0; j < m.created.size(); ++j) {
    const LandmarkId id = m.created[j];
    kept[j] =
        associator_->landmarkFromLostScans(id, ekf.landmarkCovariance(ekf.indexOf(id)), m.looks[j]);
    if (kept[j]) {
      ++n_kept;
    } else {
      ekf.removeLandmark(id);
      ++counters_.lost_map_removed;
    }
  }
  weighRecentOverLostScans(m, report);
  filter_.restart();
  estimatedLostPath(m, report);
  for (const LandmarkId id : m.paired) book_.paired(id, std::nan(""));
  for (std::size_t j = 0; j < m.created.size(); ++j) {
    if (!kept[j]) continue;
    book_.created(m.created[j], m.descriptors[j], report->scan);
    for (std::uint32_t k = 1; k < m.sightings[j]; ++k) book_.paired(m.created[j], std::nan(""));
  }
  index_.sync(ekf);
  report->lost_map_landmarks = n_kept;
  report->lost_map_pairings = static_cast<int>(m.paired.size());
}

void SlamPipeline::weighRecentOverLostScans(const LostScanMapping& m, ScanReport* report) {
  // The landmarks of the map before that were still recent when the lost scans began: tracking
  // would have gone on judging them over those scans (DJNN: its evidence, misses included), as
  // it judges the ones made from the lost scans. Established ones are left as they are (the lost
  // scans' gate pairs less than tracking does: weighed too, real trees go).
  if (m.poses.empty()) return;
  EkfSlam& ekf = filter_.ekf();
  index_.sync(ekf);
  const std::int64_t first = m.poses.back().first;  // newest first
  std::unordered_map<LandmarkId, std::vector<LostLook>> looks;
  std::vector<int> near;
  for (std::size_t s = m.poses.size(); s-- > 0;) {  // oldest first
    const Eigen::Vector3d sensor = model_.sensorPose(m.poses[s].second);
    near.clear();
    index_.query(ekf, sensor.head<2>(), config_.max_observation_range, &near);
    for (const int k : near) {
      const LandmarkId id = ekf.landmarkIds()[static_cast<std::size_t>(k)];
      const std::int64_t made = book_.info(id).created_scan;
      if (made < 0 || made >= first || first - made > config_.lost_recent_scans) continue;
      LostLook l;
      const std::vector<LandmarkId>& paired = m.paired_at[s];
      l.seen = std::find(paired.begin(), paired.end(), id) != paired.end();
      l.in_sensor = rotation2d(-sensor.z()) * (ekf.landmark(k) - sensor.head<2>());
      looks[id].push_back(l);
    }
  }
  std::vector<LandmarkId> ids;
  for (const auto& entry : looks) ids.push_back(entry.first);
  std::sort(ids.begin(), ids.end());  // the same order on every run
  for (const LandmarkId id : ids) {
    if (associator_->landmarkOverLostScans(id, ekf.landmarkCovariance(ekf.indexOf(id)), looks[id]))
      continue;
    ekf.removeLandmark(id);
    book_.erase(id);
    report->removed.push_back(id);
    ++counters_.lost_map_removed;
  }
}

void SlamPipeline::estimatedLostPath(const LostScanMapping& m, ScanReport* report) const {
  // The lost path so far is the fix carried back by the odometry alone. Each scan the mapping
  // carried the state back to has a better estimate (its pairings with the map); the scans in
  // between (no observations) move with the next newer one.
  if (m.poses.empty()) return;
  auto e = m.poses.begin();  // newest first
  bool have = false;
  Eigen::Vector3d correction = Eigen::Vector3d::Zero();  // estimate o carried^-1
  for (auto p = report->lost_path.rbegin(); p != report->lost_path.rend(); ++p) {
    while (e != m.poses.end() && e->first > p->scan) ++e;
    if (e != m.poses.end() && e->first == p->scan) {
      correction = composePose(e->second, inversePose(p->pose));
      have = true;
    }
    if (!have) continue;
    p->pose = composePose(correction, p->pose);
    p->pose.z() = wrapAngle(p->pose.z());
  }
}

// --- state ---------------------------------------------------------------------------------------

std::vector<MapLandmark> SlamPipeline::mapLandmarks() const {
  return ekf_slam::mapLandmarks(ekf(), book_);
}

// --- map files -----------------------------------------------------------------------------------

void SlamPipeline::saveMap(const std::string& path) const { saveMap(path, mapLandmarks()); }

void SlamPipeline::saveMap(const std::string& path, const std::vector<MapLandmark>& map) const {
  writeMapFile(path, map, book_);
}

void SlamPipeline::loadMap(const std::string& path, bool reset_pose, bool unknown_pose) {
  if (unknown_pose && !recovery_.active()) {
    throw std::runtime_error("map file '" + path +
                             "': an unknown pose needs a relocaliser (parameter relocaliser)");
  }
  const std::vector<MapEntry> entries = readMapFile(path);  // throws before any change
  applyPendingMotion();
  EkfSlam& ekf = filter_.ekf();
  Eigen::Vector3d pose = ekf.pose();
  Eigen::Matrix3d pose_cov = ekf.poseCovariance();
  // The correction estimates carry over (their variances; correlations with the old map go).
  CorrectionPrior correction = motion_.correction().prior();
  correction.mean = ekf.correction();
  correction.sigma = ekf.correctionCovariance().diagonal().cwiseSqrt();
  if (reset_pose) {
    const Eigen::Vector3d s = config_.initial_pose_sigma;
    pose = config_.initial_pose;
    pose_cov = s.cwiseProduct(s).asDiagonal();
  }
  ekf.reset(pose, pose_cov, correction);
  filter_.restart();
  book_.clear();
  delayed_.clear();
  for (const MapEntry& e : entries) {
    ekf.insertLandmark(e.position, e.cov, e.id);
    book_.loaded(e.id, e.info);
  }
  index_.clear();
  index_.sync(ekf);
  associator_->reset();
  for (const MapEntry& e : entries) associator_->landmarkLoaded(e.id, e.info.times_observed);
  recovery_.reset();  // not lost, and the history belongs to the map before
  if (unknown_pose) {
    ++counters_.relocalisation_requests;
    enterLost(/*pose_unknown=*/true);
  }
}

}  // namespace ekf_slam
