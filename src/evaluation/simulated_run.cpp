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

void KnownAssociation::configure(const ParameterSource& params) {
  admit_sightings_ =
      ParameterReader(params).integer("admit_sightings", admit_sightings_, 1, 1000000);
  reset();
}

AssociationResult KnownAssociation::associate(const AssociationContext& context) {
  if (truth_of_) truth_ = truth_of_(context.observations());
  AssociationResult r;
  r.resize(context.numObservations());
  for (std::size_t i = 0; i < context.numObservations() && i < truth_.size(); ++i) {
    if (!sim::isStaticLandmark(truth_[i])) continue;  // movers and clutter: rejected
    const auto it = landmark_of_.find(truth_[i]);
    if (it != landmark_of_.end() && context.ekf().contains(it->second)) {
      r.pair(i, it->second);
      continue;
    }
    // The truth id names the feature, so its sightings join the landmark it becomes.
    r.feature[i] = truth_[i];
    const bool admitted = admit_sightings_ <= 1 || ++sightings_[truth_[i]] >= admit_sightings_;
    r.decision[i] = admitted ? Decision::kNew : Decision::kTentative;
    if (admitted) sightings_.erase(truth_[i]);
  }
  return r;
}

void KnownAssociation::landmarkAdded(int obs, LandmarkId id) {
  if (obs >= 0 && static_cast<std::size_t>(obs) < truth_.size()) landmark_of_[truth_[obs]] = id;
}

// --- runSimulation -------------------------------------------------------------------------------

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
  // A laser world's true associations: the extracted features' truth as the scorer finds it
  // (clutter and movers are rejected whatever their id, so the ids it counts down do not matter).
  Eigen::Vector3d true_sensor = Eigen::Vector3d::Zero();
  LandmarkId known_clutter = sim::kClutterIdBase;
  if (laser_world && known != nullptr) {
    known->setTruthFunction([&](const std::vector<Observation>& observations) {
      return truthByProximity(true_sensor, observations, beacons, &known_clutter);
    });
  }
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
      true_sensor = composePose(true_pose, world.sensor.offset);
      report = pipeline->processScan(sim::stampOnBag(set.stamp), laser->scan(sensor, &laser_noise));
      truth = truthByProximity(true_sensor, report.observations, beacons, &clutter);
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
