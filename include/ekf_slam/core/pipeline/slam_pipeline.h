// The whole SLAM data flow, ROS-free, driven the same way by the node, the offline runner and the
// test bench. SlamPipeline only orchestrates; each step has its own class:
//
//   odometry -> MotionPredictor (composed lazily) -> FilterBackend::predict, once per scan
//   scan     -> ObservationBuilder (filter chain, extractor, checks) -> observations
//            -> lost?  Recovery (relocaliser) -> a fix -> applyFix (pose, pairings, lost path)
//               else   MapUpdater::associate -> LostMonitor rule 3 -> MapUpdater::apply
//                      (batch update, new landmarks and their DelayedSightings, removals,
//                      LandmarkBook; this scan's tentative sightings kept against a pose clone)
//                      -> LostMonitor rules 1, 2, 4 -> lost, or a Recovery probe
//            -> ScanReport (published by the node, written by the runner, scored by the bench)
//
// Inputs must arrive in stamp order (InputSequencer puts them in order); the pipeline predicts to
// the exact stamp of each scan before using it (time handling: motion_predictor.h).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/feature_extraction/feature_extractor.h"
#include "ekf_slam/core/feature_extraction/scan_filter_chain.h"
#include "ekf_slam/core/filter/compressed_ekf.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/filter_backend.h"
#include "ekf_slam/core/filter/landmark_index.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/filter/odometry_correction.h"
#include "ekf_slam/core/pipeline/delayed_sightings.h"
#include "ekf_slam/core/pipeline/kidnap_onset.h"
#include "ekf_slam/core/pipeline/landmark_book.h"
#include "ekf_slam/core/pipeline/lost_monitor.h"
#include "ekf_slam/core/pipeline/map_checkpoint.h"
#include "ekf_slam/core/pipeline/map_updater.h"
#include "ekf_slam/core/pipeline/motion_predictor.h"
#include "ekf_slam/core/pipeline/observation_builder.h"
#include "ekf_slam/core/pipeline/odometry_input.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/pipeline/recovery.h"
#include "ekf_slam/core/pipeline/scan_report.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace ekf_slam {

class SlamPipeline {
 public:
  /// Throws ParameterError on an invalid config. The associator must be configured already.
  SlamPipeline(const PipelineConfig& config, std::shared_ptr<DataAssociation> associator);
  // Its parts refer to each other: a pipeline stays where it was built.
  SlamPipeline(const SlamPipeline&) = delete;
  SlamPipeline& operator=(const SlamPipeline&) = delete;

  /// Back to the initial pose with an empty map and no time, not lost; the associator is reset
  /// too. Counters and the scan number keep counting (they describe the whole run).
  void reset();

  // --- lost-robot recovery (docs/relocalisation.md) -----------------------------------------
  /// The relocaliser (configured already) used while lost; null switches recovery off.
  void setRelocaliser(std::shared_ptr<Relocaliser> relocaliser);
  const Relocaliser* relocaliser() const { return recovery_.relocaliser(); }
  /// Forces the lost state: the map freezes and every following scan is relocalised globally
  /// until one is found. Returns false (nothing changes) without a relocaliser.
  bool requestRelocalisation();
  /// Moves the pose estimate by `delta` (map frame x, y, yaw) without telling the covariance:
  /// what an unmodelled jump of the odometry (a kidnap) does to the filter. For the offline
  /// runner's --kidnap and tests.
  void injectPoseJump(const Eigen::Vector3d& delta);
  /// True from the moment the lost rule fires (or a request) until a relocalisation succeeds.
  bool lost() const { return recovery_.lost(); }

  /// Sensor pose on base_link (x, y, yaw), e.g. from tf. Used from the next scan on.
  void setSensorOffset(const Eigen::Vector3d& offset);
  const Eigen::Vector3d& sensorOffset() const { return model_.sensorOffset(); }

  /// Odometry, in stamp order. Returns false (and counts it) for a non-finite message, a twist
  /// beyond max_speed / max_yaw_rate (implausible_odometry), a pose without orientation in
  /// pose_delta mode (invalid_orientations) or one older than time() (late_odometry). O(1), no
  /// allocation.
  bool addOdometry(const OdometryInput& odom);

  /// A laser scan: beam i at angle_min + i * angle_increment. Predicts to `stamp`, filters the
  /// beams (scan filter chain), extracts the features, associates, updates. Throws
  /// ScanFormatError, before any state changes, for a scan the extractor or a filter cannot use
  /// (e.g. no intensities for BeaconExtractor). With angle_max (sensor_msgs/LaserScan's) the
  /// geometry is checked first (scanGeometryError): an inconsistent scan is used for prediction
  /// only and counted (inconsistent_scans, ScanReport::geometry_error). A scan equal to the
  /// previous one (stamp, angles, ranges) is dropped and counted (duplicate_scans,
  /// ScanReport::duplicate).
  ScanReport processScan(double stamp, const LaserScanData& scan);
  /// The same for a scan without intensities or range limits.
  ScanReport processScan(double stamp, const std::vector<float>& ranges, double angle_min,
                         double angle_increment, std::optional<double> angle_max = std::nullopt);

  /// The feature extractor (configured already) for processScan; the default is TreeExtractor
  /// with config.extractor. Null restores the default.
  void setFeatureExtractor(std::shared_ptr<FeatureExtractor> extractor);
  const FeatureExtractor& featureExtractor() const { return observations_.extractor(); }
  /// Filters applied to every scan before extraction (empty by default).
  void setScanFilter(ScanFilterChain chain) { observations_.setScanFilter(std::move(chain)); }
  const ScanFilterChain& scanFilter() const { return observations_.scanFilter(); }
  /// Observations from an external extractor or a simulator. Observations whose R is all zeros
  /// get the configured default noise.
  ScanReport processObservations(double stamp, std::vector<Observation> observations);

  // --- state --------------------------------------------------------------------------------
  /// The filter, with any pending odometry applied first (O(n) when some is pending). With
  /// filter cekf the whole state is brought up to date first (a global update when an area is
  /// open): per-scan readers of the pose or the correction states use activeEkf().
  const EkfSlam& ekf() const {
    applyPendingMotion();
    filter_.flush();
    return filter_.ekf();
  }
  /// The filter without a global update: its pose, correction states and the landmarks of the
  /// active area are current, with filter cekf the others may not be (the same as ekf() with
  /// filter ekf).
  const EkfSlam& activeEkf() const {
    applyPendingMotion();
    return filter_.ekf();
  }
  /// Count the EKF's updates per shape (N, d) (EkfSlam::recordUpdateShapes; benchmarks only).
  void recordUpdateShapes(bool on) { filter_.ekf().recordUpdateShapes(on); }
  /// The compressed filter (filter cekf), else null.
  const CompressedEkf* compressedEkf() const { return filter_.compressed(); }
  CompressedEkf* compressedEkf() { return filter_.compressed(); }
  /// Current pose estimate at time(), including odometry not yet applied to the EKF. O(1).
  Eigen::Vector3d pose() const { return motion_.pose(); }
  /// Its covariance, F P_vv F^T + Q of the pending motion. O(1).
  Eigen::Matrix3d poseCovariance() const { return motion_.poseCovariance(); }
  const DataAssociation& associator() const { return *associator_; }
  const RangeBearingModel& observationModel() const { return model_; }
  /// The odometry correction model (mode none: no states). Its estimates: ekf().correction().
  const OdometryCorrection& odometryCorrection() const { return motion_.correction(); }
  /// The map as a relocaliser takes it (ids, positions, marginal covariances, diameters).
  std::vector<MapLandmark> mapLandmarks() const;
  /// Bookkeeping of a landmark (a default LandmarkInfo for an unknown id).
  const LandmarkInfo& landmarkInfo(LandmarkId id) const { return book_.info(id); }
  const PipelineCounters& counters() const { return counters_; }
  const PipelineConfig& config() const { return config_; }
  /// Stamp the filter has been predicted to (NaN before any input).
  double time() const { return motion_.time(); }
  /// True when the map must not change (localization mode).
  bool mapFrozen() const { return config_.mode == "localization"; }

  // --- map files ----------------------------------------------------------------------------
  /// Writes the landmarks (id, x, y, covariance, diameter, times observed) as plain text: a
  /// header line "ekf_slam_map 1", '#' comment lines, then one landmark per line
  ///   id x y cov_xx cov_xy cov_yy diameter times_observed
  /// (diameter "nan" when unknown). Throws std::runtime_error when the file cannot be written.
  void saveMap(const std::string& path) const;
  /// The same file for other estimates of the map's landmarks (e.g. a smoother's): positions and
  /// covariances from `map`, diameter and times observed from the pipeline's bookkeeping by id.
  void saveMap(const std::string& path, const std::vector<MapLandmark>& map) const;
  /// Replaces the map with a saved one; loaded landmarks keep their ids and covariances and are
  /// uncorrelated with the pose and each other. The pose keeps its estimate and covariance
  /// unless reset_pose (then: the initial pose). The associator is reset and told of every loaded
  /// landmark with its times_observed (DJNN keeps them as established landmarks). With
  /// unknown_pose the pipeline starts lost: the next scans are relocalised globally in the loaded
  /// map (needs a relocaliser). Throws std::runtime_error naming the file and line (or the
  /// missing relocaliser); the state is unchanged on error.
  void loadMap(const std::string& path, bool reset_pose, bool unknown_pose = false);

 private:
  /// Predicts the filter to `stamp` (late or non-finite stamps: to time()); returns the stamp
  /// used.
  double predictTo(double stamp, ScanReport* report);
  void applyPendingMotion() const;
  /// Gives the report the next scan number and the odometry since the previous scan.
  void numberScan(ScanReport* report);
  /// `occlusion`: what the scan hid (null for point observations).
  ScanReport associateAndUpdate(double stamp, std::vector<Observation> observations,
                                ScanReport report, const ScanOcclusion* occlusion = nullptr);
  /// While lost: one relocaliser call; a confirmed fix is applied.
  void relocaliseLost(ScanReport* report);
  /// Lost rule 3 on the association, before it is applied; true when it fired: the relocaliser
  /// found a kidnap on this scan (a probe), the pipeline is lost and the associator's decisions
  /// must not be applied (the fix, when confirmed, has been).
  bool kidnapRefused(ScanReport* report);
  /// Lost rules 1, 2 and 4 after a tracked scan, and their probe.
  void checkLost(ScanReport* report);
  /// The relocaliser in the established map: a fix the estimate does not cover is a kidnap.
  void probe(ScanReport* report);
  /// The lost rule fired: recent landmarks discarded, lost (the map frozen).
  void goLost(ScanReport* report);
  void enterLost(bool pose_unknown = false);
  /// Removes the recent landmarks (they may come from a wrong pose).
  void discardRecent(ScanReport* report);
  /// Before a tracked scan's update: keeps the map before a suspect scan, drops it once the scans
  /// since pair well again or it is older than lost_recent_scans (lost_rollback).
  void updateCheckpoint(const ScanReport& report);
  /// Going lost with a checkpoint held: the map as it was, the scans since kept as lost scans.
  void rollBack(ScanReport* report);
  /// The filter's map, bookkeeping and the associator's evidence before scan `scan`.
  MapCheckpoint snapshot(std::uint32_t scan) const;
  /// The map as `c` kept it; the pose keeps its estimate, uncorrelated with it.
  bool restore(const MapCheckpoint& c, ScanReport* report);
  /// Keeps a processed scan for lost_onset_scans (and, before a tracked scan's update, the state).
  void recordScan(const ScanReport& report, bool tracked);
  /// At a fix: when the kidnap began before the scans already undone (KidnapOnset), the map goes
  /// back to before it and every scan since becomes a lost scan. True when it did.
  bool rollBackToOnset(const RelocalisationResult& fix, ScanReport* report);
  /// The trajectory of the scans tracked from `from` on that the fix did not re-derive already.
  void addOnsetPath(std::uint32_t from, const Eigen::Vector3d& odometry_at_fix, ScanReport* report);
  /// Replaces the pose with a relocaliser's fix and updates with its pairings
  /// (docs/relocalisation.md); the scans processed while lost get their re-derived poses.
  void applyFix(const RelocalisationResult& fix, ScanReport* report);
  /// After a fix: maps what the scans processed lost saw (lost_map_scans; LostScans).
  void mapSeenWhileLost(const LostScans& lost, const Eigen::Vector3d& dead_reckoned,
                        ScanReport* report);
  /// The map's landmarks still recent when the lost scans began, weighed by the associator's
  /// rules over them (DataAssociation::landmarkOverLostScans).
  void weighRecentOverLostScans(const LostScanMapping& m, ScanReport* report);
  /// The lost path's poses replaced by those the mapping of the lost scans estimated.
  void estimatedLostPath(const LostScanMapping& m, ScanReport* report) const;

  PipelineConfig config_;
  std::shared_ptr<DataAssociation> associator_;
  PipelineCounters counters_;
  // mutable: ekf() applies the pending motion (and, with the CEKF, brings the whole state up to
  // date), which the motion, the filter and the recovery's carried scans take part in.
  mutable FilterBackend filter_;
  LandmarkIndex index_;
  RangeBearingModel model_;
  LandmarkBook book_;
  DelayedSightings delayed_;
  mutable MotionPredictor motion_;
  ObservationBuilder observations_;
  ScanOcclusion occlusion_;  // of the scan being processed (workspace)
  MapUpdater mapper_;
  LostMonitor monitor_;
  mutable Recovery recovery_;
  // mutable: the odometry since carries its scans along (applyPendingMotion).
  mutable MapCheckpoint checkpoint_;
  // mutable: likewise (lost_onset_scans).
  mutable TrackedHistory history_;
  std::uint32_t scans_ = 0;
};

}  // namespace ekf_slam
