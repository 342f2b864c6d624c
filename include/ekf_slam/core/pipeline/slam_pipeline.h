// The whole SLAM data flow, ROS-free, driven the same way by the node and the offline runner:
//   odometry -> predict;  scan -> extract trees -> observations -> associate -> update /
//   initialise / remove.
// Inputs must arrive in stamp order (InputSequencer puts them in order); the pipeline predicts to
// the exact stamp of each scan before using it.
//
// Prediction is lazy: the motion steps of the odometry messages between two scans are composed
// into one MotionStep (F = F2 F1, Q = F2 Q1 F2^T + Q2, exact; with odometry correction states
// their Jacobians and noise compose along, see compose()) and applied to the EKF once, right
// before the scan is associated. Per-message work is O(1) and allocation-free; the O(n) EKF
// prediction runs once per scan. pose() / poseCovariance() include the pending motion; ekf()
// applies it first (so it is always current).
//
// Time handling (docs/parameters.md, "Input ordering"):
//  - twist mode: the twist of message k holds over [t_k, t_k+1] (zero-order hold, as
//    victoria_park_to_bag integrates its /odom poses). Before the first odometry message the
//    vehicle is assumed still.
//  - pose_delta mode: the increment between consecutive odometry poses drives PoseDeltaModel. A
//    scan between two messages is reached by extrapolating the last odometry pose with that
//    message's twist (exact arc); the next increment then starts from the extrapolated pose, so
//    the increments still add up to the odometry's own.
//  - non-finite odometry: rejected and counted. Odometry older than the filter time (late, or a
//    backwards jump): skipped and counted (its interval is already predicted).
//  - a scan older than the filter time (late): processed at the filter's current time, counted,
//    flagged in ScanReport::late.
#pragma once

#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/common/chi2.h"
#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/feature_extraction/feature_extractor.h"
#include "ekf_slam/core/feature_extraction/scan_filter_chain.h"
#include "ekf_slam/core/feature_extraction/tree_extractor.h"
#include "ekf_slam/core/filter/compressed_ekf.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/filter/odometry_correction.h"
#include "ekf_slam/core/filter/landmark_index.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"
#include "ekf_slam/core/relocalisation/scan_window.h"

namespace ekf_slam {

/// Every setting of the pipeline. The ROS side fills it from parameters (one place), the offline
/// runner from the same YAML; defaults here are the documented defaults.
struct PipelineConfig {
  /// Which part of nav_msgs/Odometry drives the prediction: "twist" (v, w held until the next
  /// message) or "pose_delta" (increments between consecutive odometry poses).
  std::string odometry_mode = "twist";
  /// "slam": build the map; "localization": use the map as it is (loaded with loadMap): no
  /// landmark is created or removed, paired landmarks are still refined by the updates.
  std::string mode = "slam";
  TwistParams twist;
  PoseDeltaParams pose_delta;
  /// Odometry correction states in the filter (AEKF; twist mode only): odometry_correction.h.
  OdometryCorrectionParams correction;

  double sigma_range = 0.5;                   ///< default observation noise [m]
  double sigma_bearing = 1.0 * M_PI / 180.0;  ///< [rad]
  double max_observation_range = 30.0;        ///< trees farther away are not used [m]
  double min_observation_range = 1.0;         ///< nor closer ones [m]
  /// TreeExtractor's parameters (top-level names extractor_*): the extractor SlamPipeline uses
  /// until setFeatureExtractor() gives it another.
  TreeExtractorParams extractor;
  /// Feature extractor plugin the shells load (parameter `extractor`); docs/feature_extraction.md.
  std::string feature_extractor = "ekf_slam/TreeExtractor";

  Eigen::Vector3d initial_pose = Eigen::Vector3d::Zero();        ///< map frame
  Eigen::Vector3d initial_pose_sigma = Eigen::Vector3d::Zero();  ///< std devs (x, y, yaw)
  double index_cell_size = 10.0;                                 ///< spatial index grid [m]
  /// Odometry gaps longer than this are predicted across but reported (warning) [s].
  double max_odometry_gap = 1.0;
  /// Odometry whose twist exceeds these is rejected as implausible (counted apart from
  /// non-finite values): no ground vehicle this pipeline serves drives faster [m/s], [rad/s].
  double max_speed = 100.0;
  double max_yaw_rate = 10.0;

  /// InputSequencer: items older than (newest stamp - max_latency) are released without waiting
  /// for odometry [s]; a stamp older than the newest by more than time_jump_threshold is a jump
  /// back in time (the shells reset) [s].
  double max_latency = 0.5;
  double time_jump_threshold = 1.0;

  /// Lost-robot recovery (docs/relocalisation.md). The shells load the plugin named here and
  /// hand it over with SlamPipeline::setRelocaliser; empty: off (the filter never goes lost).
  std::string relocaliser;
  /// Lost rule 1: this many consecutive scans with >= lost_min_observations observations, yet
  /// not one paired with an established (not recent) landmark, and >= lost_min_expected map
  /// landmarks in view (within lost_view_range of the sensor, 0 = max_observation_range, and inside
  /// lost_field_of_view about its x axis). With fewer in view the relocaliser probes instead
  /// (docs/relocalisation.md). 0 disables the rule.
  int lost_unpaired_scans = 5;
  int lost_min_observations = 3;
  int lost_min_expected = 3;
  /// Rule 1 counts a scan as unpaired when fewer established landmarks were paired than this
  /// share of those in view (0: when none was, the rule as first written). A sensor that sees
  /// most of what is in view (P_D near 1) can set about half its P_D: a kidnapped filter that
  /// sees many landmarks pairs a few by chance, which resets the count when the share is 0.
  double lost_min_paired_share = 0.0;
  /// Landmarks created fewer than this many scans ago are "recent": pairing them does not count
  /// for rule 1, they are not "in view", and they are discarded when the pipeline goes lost.
  int lost_recent_scans = 20;
  /// Count that age in informative scans only (tracked, >= lost_min_observations observations):
  /// where the scans hold few observations, landmarks mapped at a kidnapped pose would otherwise
  /// turn established before any rule could see enough to fire (docs/relocalisation.md).
  bool lost_recent_informative = false;
  double lost_view_range = 0.0;
  double lost_field_of_view = M_PI;
  /// Lost rule 2: this many consecutive scans whose batch NIS exceeds chi2(2k,
  /// lost_nis_probability) (k paired observations). 0 disables the rule.
  int lost_nis_scans = 5;
  /// Lost rule 3: this many consecutive scans in which the associator recognised at least
  /// lost_min_observations observations as map landmarks without the pose, yet the filter gate
  /// refused them (AssociationResult::gate_refused), more of them than it paired: the pose is
  /// wrong. At the last scan the relocaliser is asked at once (a probe): a pose the estimate
  /// does not cover is a kidnap, lost, and the scan is relocalised instead of applied; otherwise
  /// it is applied. Scans of the streak without such an answer create no landmark. Only
  /// associators that fill gate_refused (RRWSC) can trigger it. 0 disables the rule.
  int lost_rejected_scans = 1;
  /// Lost rule 4: over the last lost_share_window scans with >= lost_min_observations
  /// observations and >= lost_min_expected established landmarks in view, fewer than
  /// lost_established_share of their observations paired with established landmarks. A tracking
  /// filter explains most of what it sees in mapped ground by the map; a kidnapped one pairs one
  /// or two a scan by chance (which restarts rule 1's count). 0 disables the rule.
  int lost_share_window = 0;
  double lost_established_share = 0.15;
  /// Rule 4's probe: a tracked scan with >= lost_min_observations observations and established
  /// landmarks in view, of whose observations fewer than lost_established_share paired with
  /// established landmarks, and no rule fired: the relocaliser probes (lost only when it puts the
  /// vehicle where the estimate does not cover, as rule 1's probe). false: off.
  bool lost_share_probe = false;
  /// Lost this many scans without a relocalisation: tracking resumes from the dead-reckoned
  /// estimate (the map unfreezes). 0: stay lost until found (localisation in a saved map).
  int lost_max_scans = 50;
  /// While lost (and for a kidnap a probe finds), a fix is applied only after this many further
  /// fixes agree with it (moved by the odometry between them, within
  /// relocalisation_confirm_distance / _angle): a chance alignment of a few trees rarely repeats
  /// from the next viewpoint. 0: the first fix is applied.
  int relocalisation_confirmations = 0;
  double relocalisation_confirm_distance = 2.0;
  double relocalisation_confirm_angle = 0.2;
  /// How many unconfirmed fixes are held at once: a new fix confirms whichever agrees with it
  /// (the oldest is dropped when full), so a chance alignment between two right fixes no longer
  /// replaces the first. 1: only the latest.
  int relocalisation_held_fixes = 1;
  /// In (0, 1): a fix agrees with a held one by a chi2(3) test at this probability on their
  /// difference, with the two fixes' covariances and the odometry's between them, instead of the
  /// fixed distance / angle (a long turn then tolerates more, a short gap less). 0: fixed.
  double relocalisation_confirm_probability = 0.0;
  /// While lost, the relocaliser sees the observations of the last this many scans (with
  /// observations, all since going lost), carried into the current frame by the odometry with its
  /// covariance (docs/relocalisation.md, "A window of scans"); a fix confirms a held one only if
  /// their windows share no scan. 1: the current scan alone.
  int relocalisation_window_scans = 1;
  double lost_nis_probability = 0.999;

  /// The filter: "ekf" (every step on the whole state) or "cekf", the compressed EKF
  /// (docs/cekf.md): steps on the active area only, the same result up to rounding.
  std::string filter = "ekf";
  double cekf_area_size = 50.0;  ///< CompressedEkfParams::area_size [m]
  double cekf_margin = 10.0;     ///< CompressedEkfParams::margin [m]
  double cekf_area_slack = 0.0;  ///< CompressedEkfParams::slack [m]
  /// Where the EKF's Jacobians are evaluated: "standard" (the current estimate) or
  /// "first_estimate", the FEJ-EKF (docs/consistency.md; filter ekf only).
  std::string jacobians = "standard";
  /// Second-order terms of range-bearing observations (EKF2, docs/consistency.md): the mean and
  /// spread that the first-order prediction misses for a landmark known poorly across the line of
  /// sight, in the update, the associators' gates and the initialisation.
  bool second_order_observations = false;

  /// Throws ParameterError naming the first invalid setting.
  void validate() const;
};

/// One odometry message.
struct OdometryInput {
  double stamp = 0.0;
  Eigen::Vector2d twist = Eigen::Vector2d::Zero();  ///< (v, w) of base_link
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();   ///< (x, y, yaw) in the odometry frame
  /// False when the message's orientation carries no rotation (an all-zero or non-finite
  /// quaternion): its pose cannot drive pose_delta mode.
  bool orientation_valid = true;
};

/// Per-landmark bookkeeping next to the EKF.
struct LandmarkInfo {
  double diameter = std::numeric_limits<double>::quiet_NaN();  ///< running mean descriptor
  std::uint32_t times_observed = 0;                            ///< scans it was paired in
  int descriptor_count = 0;
  std::int64_t created_scan = -1;         ///< scan that initialised it; -1: loaded from a map file
  std::int64_t created_informative = -1;  ///< informative scans before it (lost_recent_informative)
};

/// The pose of a scan processed while lost, re-derived once the pipeline is relocalised.
struct LostPathPose {
  std::uint32_t scan = 0;
  double stamp = 0.0;
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();
  /// Tracked before going lost, yet its estimate disagrees with the fix carried back to it: the
  /// estimate went wrong before a rule saw it (docs/relocalisation.md, "The lost path").
  bool tracked = false;
};

/// Applies a ScanReport::lost_path to a trajectory kept by the caller: rows [0, end) in stamp
/// order, `stamp(i)` the stamp of row i, `set(i, pose)` replaces its pose. A row is matched
/// within 1 us (stamps may have gone through ros::Time); rows without a lost pose are left alone.
template <class Stamp, class Set>
void applyLostPath(const std::vector<LostPathPose>& path, std::size_t end, Stamp stamp, Set set) {
  constexpr double kTolerance = 1e-6;
  std::size_t i = end;
  for (auto p = path.rbegin(); p != path.rend(); ++p) {
    while (i > 0 && stamp(i - 1) > p->stamp + kTolerance) --i;
    if (i == 0 || stamp(i - 1) < p->stamp - kTolerance) continue;
    --i;
    set(i, p->pose);
  }
}

/// What happened in one scan.
struct ScanReport {
  bool late = false;  ///< stamp was older than the filter: used time()
  /// The scan repeats the previous one (same stamp, angles and ranges): dropped, nothing done.
  bool duplicate = false;
  /// Why the scan's geometry was rejected (scanGeometryError), or nullptr.
  const char* geometry_error = nullptr;
  int invalid_observations = 0;  ///< non-finite observations dropped
  int invalid_decisions = 0;     ///< associator output fixed up (treated as rejected)
  double stamp = 0.0;
  std::uint32_t scan = 0;                 ///< 0-based count of processed scans
  std::vector<Observation> observations;  ///< after extraction and range filtering
  /// processObservations only: index of each kept observation in the input (invalid ones are
  /// dropped), e.g. to look up its truth id. Empty for processScan.
  std::vector<std::uint32_t> input_index;
  AssociationResult association;    ///< kNew entries carry the new landmark's id
  std::vector<LandmarkId> removed;  ///< landmarks removed after this scan
  double extraction_s = 0.0;        ///< wall times
  double association_s = 0.0;
  double update_s = 0.0;
  /// The odometry since the previous scan: the motion in that scan's vehicle frame (the filter's
  /// prediction, less its start) and its covariance (the process noise in that frame), for a
  /// batch smoother (core/smoothing/). False for the first scan after construction or reset().
  bool has_motion = false;
  Eigen::Vector3d motion = Eigen::Vector3d::Zero();
  Eigen::Matrix3d motion_covariance = Eigen::Matrix3d::Zero();
  double nis = 0.0;  ///< of the batch update
  int nis_dof = 0;
  bool update_ok = true;  ///< false when the EKF rejected the update

  // Lost-robot recovery.
  bool lost = false;         ///< the filter was lost at this scan: relocalised, not associated
  bool became_lost = false;  ///< the lost rule fired after this scan (map frozen from now on)
  std::string lost_reason;   ///< which rule, for logs
  bool relocalisation_attempted = false;
  bool relocalised = false;             ///< found: pose replaced, paired, tracking resumes
  RelocalisationResult relocalisation;  ///< of the attempt
  double relocalisation_s = 0.0;        ///< wall time of the relocaliser call
  int landmarks_expected = 0;           ///< map landmarks in view (lost rule 1), when tracking
  /// Relocalised: the poses of the scans processed while lost (oldest first), carried back from
  /// this scan's pose by the odometry between them, preceded by those of the tracked scans before
  /// going lost whose estimate the carried-back fix contradicts (`tracked`; docs/relocalisation.md,
  /// "The lost path").
  std::vector<LostPathPose> lost_path;
};

/// Counters of inputs that needed handling (reported by the shells as warnings).
struct PipelineCounters {
  std::uint64_t odometry = 0;
  std::uint64_t scans = 0;
  std::uint64_t odometry_gaps = 0;            ///< gaps longer than max_odometry_gap
  std::uint64_t rejected_odometry = 0;        ///< non-finite values
  std::uint64_t implausible_odometry = 0;     ///< twist beyond max_speed / max_yaw_rate
  std::uint64_t invalid_orientations = 0;     ///< pose_delta: a quaternion with no rotation
  std::uint64_t inconsistent_scans = 0;       ///< angles contradict the beams: prediction only
  std::uint64_t duplicate_scans = 0;          ///< repeats of the previous scan: dropped
  std::uint64_t rejected_updates = 0;         ///< EKF refused the batch update
  std::uint64_t invalid_ranges = 0;           ///< NaN / negative beams seen by the extractor
  std::uint64_t scans_before_odometry = 0;    ///< processed with no odometry yet (no prediction)
  std::uint64_t late_odometry = 0;            ///< older than the filter time: skipped
  std::uint64_t late_scans = 0;               ///< older than the filter time: used at time()
  std::uint64_t empty_scans = 0;              ///< no beams, no valid beam or a bad angle
  std::uint64_t invalid_observations = 0;     ///< non-finite observations dropped
  std::uint64_t invalid_associations = 0;     ///< associator results fixed up (bad size, bad id)
  std::uint64_t failed_initialisations = 0;   ///< kNew the EKF could not initialise
  std::uint64_t invalid_stamps = 0;           ///< scans with a non-finite stamp (used at time())
  std::uint64_t resets = 0;                   ///< reset() calls
  std::uint64_t lost_events = 0;              ///< the lost rule fired
  std::uint64_t relocalisation_requests = 0;  ///< requestRelocalisation() / loadMap(unknown pose)
  std::uint64_t relocalisation_attempts = 0;  ///< relocaliser calls (while lost, and probes)
  /// Relocaliser calls while tracking: rule 1's streak with no landmark in view (new ground, or a
  /// kidnap the filter takes for new ground).
  std::uint64_t probes = 0;
  std::uint64_t relocalisations = 0;  ///< found: the pose was replaced
  std::uint64_t relocalisations_ambiguous = 0;
  std::uint64_t lost_timeouts = 0;  ///< lost_max_scans reached: tracking resumed unrelocalised
  std::uint64_t relocalisations_not_found = 0;
  std::uint64_t relocalisations_unconfirmed = 0;  ///< found, held for confirmation
  std::uint64_t lost_path_poses = 0;  ///< lost scans' poses re-derived at a relocalisation
  /// Tracked scans before going lost re-derived at a relocalisation (LostPathPose::tracked).
  std::uint64_t rederived_tracked_poses = 0;
  /// Recent landmarks (lost_recent_scans) removed when the pipeline went lost (they may come
  /// from a pose now taken to be wrong).
  std::uint64_t discarded_landmarks = 0;
  /// New landmarks not created because their scan met lost rule 3 (kidnapped scans).
  std::uint64_t suppressed_new = 0;
  /// Localization mode: new landmarks and removals the associator asked for, not applied.
  std::uint64_t frozen_new = 0;
  std::uint64_t frozen_removals = 0;
  /// Odometry correction states pushed past their bounds by an update (clamped back), and
  /// updates refused because a correction variance would have become non-positive (these are
  /// also in rejected_updates).
  std::uint64_t clamped_corrections = 0;
  std::uint64_t refused_correction_updates = 0;
};

class SlamPipeline {
 public:
  /// Throws ParameterError on an invalid config. The associator must be configured already.
  SlamPipeline(const PipelineConfig& config, std::shared_ptr<DataAssociation> associator);

  /// Back to the initial pose with an empty map and no time, not lost; the associator is reset
  /// too. Counters and the scan number keep counting (they describe the whole run).
  void reset();

  // --- lost-robot recovery (docs/relocalisation.md) -----------------------------------------
  /// The relocaliser (configured already) used while lost; null switches recovery off.
  void setRelocaliser(std::shared_ptr<Relocaliser> relocaliser);
  const Relocaliser* relocaliser() const { return relocaliser_.get(); }
  /// Forces the lost state: the map freezes and every following scan is relocalised globally
  /// until one is found. Returns false (nothing changes) without a relocaliser.
  bool requestRelocalisation();
  /// Moves the pose estimate by `delta` (map frame x, y, yaw) without telling the covariance:
  /// what an unmodelled jump of the odometry (a kidnap) does to the filter. For the offline
  /// runner's --kidnap and tests.
  void injectPoseJump(const Eigen::Vector3d& delta);
  /// True from the moment the lost rule fires (or a request) until a relocalisation succeeds.
  bool lost() const { return lost_; }

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
  const FeatureExtractor& featureExtractor() const { return *extractor_; }
  /// Filters applied to every scan before extraction (empty by default).
  void setScanFilter(ScanFilterChain chain) { scan_filter_ = std::move(chain); }
  const ScanFilterChain& scanFilter() const { return scan_filter_; }
  /// Observations from an external extractor or a simulator. Observations whose R is all zeros
  /// get the configured default noise.
  ScanReport processObservations(double stamp, std::vector<Observation> observations);

  // --- state --------------------------------------------------------------------------------
  /// The filter, with any pending odometry applied first (O(n) when some is pending). With
  /// filter cekf the whole state is brought up to date first (a global update when an area is
  /// open): per-scan readers of the pose or the correction states use activeEkf().
  const EkfSlam& ekf() const {
    applyPendingMotion();
    if (cekf_) cekf_->flush();
    return ekf_;
  }
  /// The filter without a global update: its pose, correction states and the landmarks of the
  /// active area are current, with filter cekf the others may not be (the same as ekf() with
  /// filter ekf).
  const EkfSlam& activeEkf() const {
    applyPendingMotion();
    return ekf_;
  }
  /// Count the EKF's updates per shape (N, d) (EkfSlam::recordUpdateShapes; benchmarks only).
  void recordUpdateShapes(bool on) { ekf_.recordUpdateShapes(on); }
  /// The compressed filter (filter cekf), else null.
  const CompressedEkf* compressedEkf() const { return cekf_.get(); }
  CompressedEkf* compressedEkf() { return cekf_.get(); }
  /// Current pose estimate at time(), including odometry not yet applied to the EKF. O(1).
  Eigen::Vector3d pose() const { return pending_steps_ > 0 ? pending_.pose : ekf_.pose(); }
  /// Its covariance, F P_vv F^T + Q of the pending motion. O(1).
  Eigen::Matrix3d poseCovariance() const;
  const DataAssociation& associator() const { return *associator_; }
  const RangeBearingModel& observationModel() const { return model_; }
  /// The odometry correction model (mode none: no states). Its estimates: ekf().correction().
  const OdometryCorrection& odometryCorrection() const { return correction_; }
  /// The map as a relocaliser takes it (ids, positions, marginal covariances, diameters).
  std::vector<MapLandmark> mapLandmarks() const;
  /// Bookkeeping of a landmark (a default LandmarkInfo for an unknown id).
  const LandmarkInfo& landmarkInfo(LandmarkId id) const;
  const PipelineCounters& counters() const { return counters_; }
  const PipelineConfig& config() const { return config_; }
  /// Stamp the filter has been predicted to (NaN before any input).
  double time() const { return time_; }
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
  /// Advances the pending motion from time_ to `stamp` with the held odometry (no EKF work).
  void advanceTo(double stamp);
  /// Advances to `stamp` and applies the pending motion to the EKF. Handles late stamps and
  /// scans before any input; returns the stamp actually used.
  double predictTo(double stamp, ScanReport* report);
  /// One motion step of the held odometry over dt, composed into pending_.
  void composeStep(double dt);
  void composePoseDelta(const Eigen::Vector3d& delta);
  /// pending_ <- step o pending_ (a non-finite step is counted as rejected odometry).
  void compose(const MotionStep& step);
  void applyPendingMotion() const;
  // Gives the report the next scan number and the odometry since the previous scan.
  void numberScan(ScanReport* report);
  ScanReport associateAndUpdate(double stamp, std::vector<Observation> observations,
                                ScanReport report);
  /// Makes a result usable whatever the associator returned; returns the number of fixes.
  int sanitise(std::size_t n, AssociationResult* result);
  /// EKF update with the paired observations, then new landmarks, then removals.
  void applyAssociation(ScanReport* report);
  /// While lost: one relocaliser call; on success the pose is replaced and the pairings applied.
  void relocaliseScan(ScanReport* report);
  /// The lost rules after a tracked scan.
  void checkLost(ScanReport* report);
  /// Lost rule 3 on the association, before it is applied; true when it fired: the relocaliser
  /// found a kidnap on this scan (probe), the pipeline is lost and the associator's decisions
  /// must not be applied (the fix, when confirmed, has been).
  bool checkRefused(ScanReport* report);
  /// Created fewer than lost_recent_scans scans ago (loaded landmarks never are).
  bool recent(LandmarkId id) const;
  /// Established (not recent) map landmarks in view of the sensor at the estimated pose.
  int landmarksInView() const;
  /// Removes the recent landmarks (they may come from a wrong pose).
  void discardRecent(ScanReport* report);
  /// Unpaired scans with nothing in view: relocalises without freezing the map, and applies the
  /// result only when the filter's estimate does not cover it (a kidnap into "new ground").
  void probe(ScanReport* report);
  RelocalisationResult callRelocaliser(ScanReport* report);
  static bool usable(const RelocalisationResult& r, std::size_t n);
  /// Replaces the pose (docs/relocalisation.md) and updates with the relocaliser's pairings.
  void applyRelocalisation(const RelocalisationResult& r, ScanReport* report);
  /// Freezes the map and hands it to the relocaliser. pose_unknown: no lost_max_scans timeout
  /// (the estimate means nothing).
  void enterLost(bool pose_unknown = false);

  PipelineConfig config_;
  std::shared_ptr<DataAssociation> associator_;
  mutable EkfSlam ekf_;  // mutable: ekf() applies the pending motion
  // filter cekf: runs the steps on ekf_'s active area (mutable: ekf() brings ekf_ up to date).
  mutable std::unique_ptr<CompressedEkf> cekf_;
  LandmarkIndex index_;
  RangeBearingModel model_;
  std::shared_ptr<FeatureExtractor> extractor_;
  ScanFilterChain scan_filter_;
  LaserScanData filtered_scan_;  // workspace of the filter chain
  TwistModel twist_model_;
  PoseDeltaModel pose_delta_model_;
  OdometryCorrection correction_;
  std::unordered_map<LandmarkId, LandmarkInfo> info_;
  PipelineCounters counters_;
  double time_ = std::numeric_limits<double>::quiet_NaN();
  bool have_odometry_ = false;
  OdometryInput last_odom_;
  /// pose_delta mode: odometry-frame pose at time_ (last_odom_.pose extrapolated to time_).
  Eigen::Vector3d odom_pose_at_time_ = Eigen::Vector3d::Zero();
  std::uint32_t scans_ = 0;
  // The previous scan, to recognise a repeat of it.
  double last_scan_stamp_ = std::numeric_limits<double>::quiet_NaN();
  double last_scan_angle_min_ = 0.0, last_scan_angle_increment_ = 0.0;
  std::vector<float> last_scan_ranges_;

  // Composed motion since the last EKF prediction (pose at time_, F, Q).
  mutable MotionStep pending_;
  mutable int pending_steps_ = 0;

  // Per-scan workspaces (kept to avoid reallocating).
  std::vector<Pairing> pairings_;

  // Lost-robot recovery.
  std::shared_ptr<Relocaliser> relocaliser_;
  bool lost_ = false;
  int lost_scans_ = 0;  // relocalisation attempts since lost
  // A fix awaiting confirmation (relocalisation_confirmations): its pose, the estimate at that
  // scan, how many agreeing fixes it has had, and the newest scan it used.
  struct HeldFix {
    Eigen::Vector3d pose;
    Eigen::Vector3d estimate;
    int count;
    std::uint32_t last_scan;
    Eigen::Matrix3d covariance;  // the fix's
    Eigen::Matrix3d Q;           // the current estimate's given `estimate` (odometry, map frame)
  };
  // Oldest first, at most relocalisation_held_fixes (mutable: the odometry grows their Q).
  mutable std::vector<HeldFix> held_;
  // Whether fix r agrees with held fix h moved by the odometry to the current estimate.
  bool agrees(const HeldFix& h, const RelocalisationResult& r) const;
  bool confirmedFix(const RelocalisationResult& r, std::uint32_t first_scan,
                    std::uint32_t last_scan);
  // Applies a found fix of the last callRelocaliser() once confirmed (true); else holds it,
  // counted, and says so in the report. Its scans are window_first_scan_ .. the report's.
  bool applyIfConfirmed(const RelocalisationResult& r, ScanReport* report);
  // relocalisation_window_scans > 1: the scans since going lost (mutable: the odometry reaches it
  // in applyPendingMotion); the carried observations the last window call paired, ready for the
  // update, and the window's oldest scan.
  mutable ScanWindow window_;
  std::vector<Pairing> window_pairings_;
  std::vector<Pairing> carried_;  // joined to the next update (applyRelocalisation's only)
  std::uint32_t window_first_scan_ = 0;
  /// One relocaliser call on the window (the current scan last); returns the current scan's part.
  RelocalisationResult relocaliseWindow(ScanReport* report);
  bool pose_unknown_ = false;
  // The dead-reckoned pose of each scan since going lost (at most kMaxLostPath, the newest), for
  // ScanReport::lost_path.
  std::deque<LostPathPose> lost_path_;
  void rememberLostPose(const ScanReport& report);  // while lost: the scan's pose, for the above
  // The tracked scans of the last lost_recent_scans (the horizon within which rule and probe take
  // a kidnap to have happened, as discardRecent does), kept while tracking and frozen while lost:
  // at the fix those whose estimate the fix carried back by the odometry contradicts are re-derived
  // too (ScanReport::lost_path, `tracked`).
  struct TrackedPose {
    std::uint32_t scan;
    double stamp;
    std::int64_t informative;  // informative_scans_ at the scan (lost_recent_informative)
    Eigen::Vector3d pose;      // the estimate after the scan's update
    Eigen::Matrix3d covariance;
    Eigen::Vector3d odometry;  // odometry_ at the scan
    // The odometry from this scan to the next one's (the newest: to now), composed as pending_:
    // next = f(this), F = df/dthis, Q its noise (map frame). One composition per prediction,
    // into the newest only; rederiveTracked chains them.
    Eigen::Matrix3d F;
    Eigen::Matrix3d Q;
  };
  mutable std::deque<TrackedPose> tracked_;  // mutable: the odometry grows the newest's F, Q
  // The odometry alone integrated (the estimate's motion without updates, jumps or fixes), in an
  // arbitrary frame: the relative motion between any two scans, tracked or lost.
  mutable Eigen::Vector3d odometry_ = Eigen::Vector3d::Zero();
  // The odometry since the last numbered scan (ScanReport::motion); valid once a scan was
  // numbered since construction or reset().
  mutable Eigen::Vector3d motion_ = Eigen::Vector3d::Zero();
  mutable Eigen::Matrix3d motion_covariance_ = Eigen::Matrix3d::Zero();
  bool motion_valid_ = false;
  void rememberPose(const ScanReport& report);  // lost: rememberLostPose; else tracked_
  // At a fix (the pose already updated, `dead_reckoned` the estimate before): the newest tracked
  // scans whose estimate disagrees with the fix carried back, oldest first.
  std::vector<LostPathPose> rederiveTracked(const Eigen::Vector3d& dead_reckoned) const;
  int unpaired_streak_ = 0;
  int nis_streak_ = 0;
  int refused_streak_ = 0;
  std::deque<std::pair<int, int>> share_window_;  // rule 4: (established paired, observations)
  std::int64_t informative_scans_ = 0;            // lost_recent_informative
  Chi2Table nis_chi2_;
};

}  // namespace ekf_slam
