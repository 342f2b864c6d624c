#include "ekf_slam/evaluation/simulated_run.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/coverage_grid.h"
#include "ekf_slam/core/common/pose2d.h"
#include "ekf_slam/core/feature_extraction/beacon_extractor.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/evaluation/scoring/trajectory_metrics.h"
#include "ekf_slam/evaluation/simulation/laser_scan_simulator.h"

namespace ekf_slam {
namespace sim {

double stampOnBag(double sim_stamp) {
  // ros::TimeBase::fromSec and toSec, without ROS.
  const double t = sim_stamp + kStampOffset;
  std::uint64_t sec = static_cast<std::uint32_t>(static_cast<std::int64_t>(std::floor(t)));
  std::uint64_t nsec = static_cast<std::uint32_t>(std::round((t - static_cast<double>(sec)) * 1e9));
  sec += nsec / 1000000000ull;
  nsec %= 1000000000ull;
  return static_cast<double>(sec) + 1e-9 * static_cast<double>(nsec);
}

Eigen::Vector3d poseOnBag(const Eigen::Vector3d& pose) {
  const Eigen::Vector4d q = yawQuaternion(pose.z());
  return {pose.x(), pose.y(), quaternionYaw(q(0), q(1), q(2), q(3))};
}

OdometryInput odometryOnBag(const OdometrySample& sample) {
  return {stampOnBag(sample.stamp), sample.twist, poseOnBag(sample.pose)};
}

}  // namespace sim

// --- KnownAssociation ----------------------------------------------------------------------------

AssociationResult KnownAssociation::associate(const AssociationContext& context) {
  AssociationResult r;
  r.resize(context.numObservations());
  for (std::size_t i = 0; i < context.numObservations() && i < truth_.size(); ++i) {
    if (!sim::isStaticLandmark(truth_[i])) continue;  // movers and clutter: rejected
    const auto it = landmark_of_.find(truth_[i]);
    if (it != landmark_of_.end() && context.ekf().contains(it->second)) {
      r.pair(i, it->second);
    } else {
      r.decision[i] = Decision::kNew;
    }
  }
  return r;
}

void KnownAssociation::landmarkAdded(int obs, LandmarkId id) {
  if (obs >= 0 && static_cast<std::size_t>(obs) < truth_.size()) landmark_of_[truth_[obs]] = id;
}

// --- RunScorer -----------------------------------------------------------------------------------

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

// --- runSimulation -------------------------------------------------------------------------------

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

void feedSimulation(sim::Simulation& simulation, SlamPipeline& pipeline,
                    const std::function<bool(const sim::ObservationSet&)>& on_set) {
  for (auto e = simulation.next(); e != sim::Simulation::Event::kEnd; e = simulation.next()) {
    if (e == sim::Simulation::Event::kOdometry) {
      pipeline.addOdometry(sim::odometryOnBag(simulation.odometry()));
    } else if (!on_set(simulation.observations())) {
      return;
    }
  }
}

RunMetrics runSimulationOn(SlamPipeline* pipeline, const sim::World& world, std::uint64_t seed,
                           KnownAssociation* known, std::vector<double>* nees_per_scan,
                           std::vector<Eigen::Vector2d>* errors_per_scan,
                           const ScanObserver& on_scan) {
  const std::optional<sim::CarPark> laser_world = sim::laserWorld(world.name);
  if (laser_world && known != nullptr) {
    throw std::invalid_argument("the true associations need truth ids before association; world '" +
                                world.name + "' extracts its features from scans");
  }
  std::optional<sim::LaserScanSimulator> laser;
  if (laser_world) laser.emplace(laser_world->laser, laser_world->scene);
  sim::Random laser_noise(sim::Random::streamSeed(seed, sim::kLaserNoiseStream));
  LandmarkId clutter = sim::kClutterIdBase;
  std::vector<std::pair<LandmarkId, Eigen::Vector2d>> beacons;
  for (std::size_t k = 0; k < world.landmarks.size(); ++k)
    beacons.emplace_back(static_cast<LandmarkId>(k), world.landmarks[k]);

  int kidnaps = 0;
  sim::Simulation simulation(world, seed);
  RunScorer scorer;
  scorer.setTrueMap({beacons.begin(), beacons.end()});
  if (!world.kidnaps.empty()) scorer.expectKidnap();
  std::vector<LandmarkId> truth;
  feedSimulation(simulation, *pipeline, [&](const sim::ObservationSet& set) {
    if (simulation.kidnapsApplied() > kidnaps) {
      kidnaps = simulation.kidnapsApplied();
      scorer.markKidnap();
    }
    truth.clear();
    ScanReport report;
    // Scored against the true pose as a bag's /ground_truth holds it (the offline runner's).
    const Eigen::Vector3d true_pose = sim::poseOnBag(set.true_pose);
    if (laser) {
      // The simulator's point observations are ignored: the laser sees the scene.
      const Eigen::Vector3d sensor = composePose(set.true_pose, world.sensor.offset);
      report = pipeline->processScan(sim::stampOnBag(set.stamp), laser->scan(sensor, &laser_noise));
      truth = truthByProximity(composePose(true_pose, world.sensor.offset), report.observations,
                               beacons, &clutter);
    } else {
      const std::vector<LandmarkId> all = set.truthIds();
      if (known != nullptr) known->setTruth(all);  // the pipeline keeps every valid observation
      report = pipeline->processObservations(sim::stampOnBag(set.stamp), set.toObservations());
      for (const std::uint32_t i : report.input_index) truth.push_back(all[i]);
    }
    // activeEkf(): after a processed scan no motion is pending, so reading it changes nothing
    // (a dropped duplicate scan returns before the prediction: not read then).
    const bool read_map = scorer.needsMap(report) && !report.duplicate;
    scorer.addScan(report, truth, pipeline->pose(), pipeline->poseCovariance(), &true_pose,
                   read_map ? &pipeline->activeEkf() : nullptr);
    if (on_scan) on_scan(report, *pipeline);
    return true;
  });
  if (nees_per_scan != nullptr) *nees_per_scan = scorer.neesPerScan();
  if (errors_per_scan != nullptr) *errors_per_scan = scorer.errorsPerScan();
  return scorer.metrics(pipeline);
}

RunMetrics runSimulation(const sim::World& world, std::uint64_t seed, const PipelineConfig& config,
                         std::shared_ptr<DataAssociation> associator,
                         std::vector<double>* nees_per_scan,
                         std::vector<Eigen::Vector2d>* errors_per_scan,
                         std::shared_ptr<Relocaliser> relocaliser) {
  const auto t0 = std::chrono::steady_clock::now();
  associator->reset();
  auto* known = dynamic_cast<KnownAssociation*>(associator.get());
  SlamPipeline pipeline(config, std::move(associator));
  pipeline.setSensorOffset(world.sensor.offset);
  pipeline.setRelocaliser(std::move(relocaliser));
  const sim::ExtractorSetup extractor = sim::extractorFor(world);
  if (extractor.name == "BeaconExtractor") {
    auto beacons = std::make_shared<BeaconExtractor>();
    beacons->configure(MapParameterSource(extractor.parameters));
    pipeline.setFeatureExtractor(beacons);
  }
  RunMetrics m = runSimulationOn(&pipeline, world, seed, known, nees_per_scan, errors_per_scan);
  m.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return m;
}

}  // namespace ekf_slam
