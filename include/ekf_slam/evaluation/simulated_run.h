// One simulated run scored against its ground truth (ALGORITHMS.md section 9), ROS-free.
//
// The same SlamPipeline the node and the offline runner drive is fed a sim::Simulation directly
// (no bag in between): odometry samples -> addOdometry, observation sets -> processObservations.
// Scored by RunScorer (scoring/run_scorer.h), as `ekf_slam_offline` scores a simulated bag, so
// `evaluate` (Monte Carlo over seeds) and a bag of the same run report the same numbers.
//
//   sim::World world = sim::makeWorld("djnn_weak");
//   PipelineConfig config = sim::pipelineConfigFor(world);
//   auto djnn = std::make_shared<Djnn>();
//   djnn->configure(MapParameterSource(sim::associatorParametersFor(world, "DJNN")));
//   RunMetrics m = runSimulation(world, /*seed=*/1, config, djnn);
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/evaluation/scoring/run_scorer.h"
#include "ekf_slam/evaluation/simulation/simulator.h"
#include "ekf_slam/evaluation/world_parameters.h"

namespace ekf_slam {
namespace sim {

/// Stamps of a simulated bag are the simulation's plus this offset [s]: a zero stamp means "no
/// stamp" in ROS (rosbag refuses it, the node skips it). runSimulation uses the same offset, so
/// a bag run and a direct run see the same times.
constexpr double kStampOffset = 1.0;

/// The stamp a bag gives back for simulation stamp `sim_stamp`: sim_stamp + kStampOffset held as
/// whole seconds and nanoseconds (ros::Time's fromSec, then toSec). runSimulation feeds these, so
/// that a direct run and the run of its bag (ekf_slam_offline, the node) are the same run to the
/// last bit.
double stampOnBag(double sim_stamp);
/// A pose as a bag's message gives it back: its yaw through the message's quaternion
/// (yawQuaternion, then quaternionYaw).
Eigen::Vector3d poseOnBag(const Eigen::Vector3d& pose);
/// An odometry sample as a bag gives it back (stampOnBag, poseOnBag).
OdometryInput odometryOnBag(const OdometrySample& sample);

}  // namespace sim

/// The true associations, for simulated runs (evaluation side, not an estimator): pairs each
/// observation with the map landmark created from the same truth id, initialises unseen static
/// landmarks, rejects movers and clutter. runSimulation hands it the truth ids of every set
/// before the pipeline associates it; in a laser world, where the features come out of the
/// pipeline's extractor, a truth function finds them from the observations being associated.
/// What isolates the filter from the association (e.g. the consistency of AEKF against EKF,
/// docs/results.md); `evaluate --associators truth`.
///
/// "truth_delayed" (`evaluate --associators truth_delayed`): the same pairings, but a landmark
/// enters the map only at its admit_sightings-th sighting (DJNN's admit_evidence, 7 by default),
/// the earlier ones kept as tentative sightings and applied at admission as DJNN's are
/// (core/pipeline/delayed_sightings.h). It isolates what the wait costs the estimate from what
/// the association costs it.
class KnownAssociation : public DataAssociation {
 public:
  /// admit_sightings 1: every landmark at its first sighting ("truth").
  explicit KnownAssociation(int admit_sightings = 1, std::string name = "truth")
      : admit_sightings_(admit_sightings), name_(std::move(name)) {}
  /// Reads admit_sightings (its section: `--set truth_delayed/admit_sightings=N`).
  void configure(const ParameterSource& params) override;
  std::string name() const override { return name_; }
  void setTruth(std::vector<LandmarkId> truth) { truth_ = std::move(truth); }
  /// The truth of the observations being associated, computed when they are (laser worlds:
  /// truthByProximity from the true sensor pose); replaces setTruth's.
  using TruthFunction = std::function<std::vector<LandmarkId>(const std::vector<Observation>&)>;
  void setTruthFunction(TruthFunction f) { truth_of_ = std::move(f); }
  AssociationResult associate(const AssociationContext& context) override;
  void landmarkAdded(int obs, LandmarkId id) override;
  /// A loaded map's ids are taken as truth ids (bench_cekf's prior maps).
  void landmarkLoaded(LandmarkId id, std::uint32_t) override { landmark_of_[id] = id; }
  void reset() override {
    landmark_of_.clear();
    sightings_.clear();
  }

 private:
  int admit_sightings_;
  std::string name_;
  std::map<LandmarkId, int> sightings_;  // truth id -> sightings while not yet in the map
  std::vector<LandmarkId> truth_;        // of the observations being associated
  TruthFunction truth_of_;
  std::map<LandmarkId, LandmarkId> landmark_of_;  // truth id -> map landmark id
};

/// Called after every processed scan of a run (tests, tools).
using ScanObserver = std::function<void(const ScanReport&, const SlamPipeline&)>;

/// Feeds a simulation to a pipeline as the offline runner feeds a simulated bag: every odometry
/// sample to addOdometry (with the bag's stamp offset sim::kStampOffset), every observation set
/// to `on_set`, which processes it. Stops at the simulation's end or when on_set returns false.
void feedSimulation(sim::Simulation& simulation, SlamPipeline& pipeline,
                    const std::function<bool(const sim::ObservationSet&)>& on_set);

/// runSimulation's loop on a pipeline the caller set up (associator, relocaliser, sensor offset,
/// feature extractor): feeds it world + seed and scores it. A laser world's scans (sim::laserWorld)
/// are ray-cast at the true sensor pose and go through the pipeline's extractor; an extracted
/// feature's truth is the landmark within kLaserTruthDistance of where it points, else clutter.
/// `known`: the pipeline's associator when it is KnownAssociation (in a laser world it gets a
/// truth function: the extracted features' truth is found as the scorer finds it).
/// `on_scan` (may be empty) sees every processed scan after it is scored.
RunMetrics runSimulationOn(SlamPipeline* pipeline, const sim::World& world, std::uint64_t seed,
                           KnownAssociation* known = nullptr,
                           std::vector<double>* nees_per_scan = nullptr,
                           std::vector<Eigen::Vector2d>* errors_per_scan = nullptr,
                           const ScanObserver& on_scan = {});
/// Runs world + seed through a fresh SlamPipeline with `associator` (configured already; it is
/// reset first) and scores it. Stamps carry sim::kStampOffset. `nees_per_scan` and
/// `errors_per_scan`, when given, receive RunScorer::neesPerScan() and errorsPerScan().
/// `relocaliser` (configured; may be null) switches lost-robot recovery on; the world's kidnaps
/// are marked for the recovery metrics. A laser world gets its extractor (sim::extractorFor).
/// Throws what SlamPipeline and Simulation throw.
RunMetrics runSimulation(const sim::World& world, std::uint64_t seed, const PipelineConfig& config,
                         std::shared_ptr<DataAssociation> associator,
                         std::vector<double>* nees_per_scan = nullptr,
                         std::vector<Eigen::Vector2d>* errors_per_scan = nullptr,
                         std::shared_ptr<Relocaliser> relocaliser = nullptr);

}  // namespace ekf_slam
