// What the pipeline says about each scan (ScanReport), what it counted over the run
// (PipelineCounters), and the poses a relocalisation re-derives (LostPathPose): the pipeline's
// outputs, which the node publishes, the offline runner writes and the scorers read.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/filter/observation.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace ekf_slam {

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

/// An earlier scan's sighting of a feature applied when the feature was admitted
/// (core/pipeline/delayed_sightings.h).
struct DelayedSighting {
  std::uint32_t scan = 0;  ///< ScanReport::scan of the sighting
  int observation = 0;     ///< its index in that scan's observations
  LandmarkId landmark = kNoLandmark;
};

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
  /// Its shares from the odometry model's translation and rotation noise terms (MotionStep::
  /// Q_translation, Q_rotation), for noise calibration; the rest is additive noise.
  Eigen::Matrix3d motion_covariance_translation = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d motion_covariance_rotation = Eigen::Matrix3d::Zero();
  double nis = 0.0;  ///< of the batch update
  int nis_dof = 0;
  /// The earlier sightings of this scan's new landmarks, applied in a second batch update, and
  /// its NIS.
  std::vector<DelayedSighting> delayed_sightings;
  double delayed_nis = 0.0;
  int delayed_nis_dof = 0;
  bool update_ok = true;  ///< false when the EKF rejected the update

  // Lost-robot recovery.
  bool lost = false;         ///< the filter was lost at this scan: relocalised, not associated
  bool became_lost = false;  ///< the lost rule fired after this scan (map frozen from now on)
  std::string lost_reason;   ///< which rule, for logs
  bool relocalisation_attempted = false;
  bool relocalised = false;  ///< found: pose replaced, paired, tracking resumes
  /// At a relocalisation: the pose after the fix's update minus the estimate before it (x, y,
  /// yaw wrapped), the observations paired in that update (the window's included), and the scans
  /// processed lost before it; for the user's log (docs/relocalisation.md, "Telling the user").
  Eigen::Vector3d fix_correction = Eigen::Vector3d::Zero();
  int fix_pairings = 0;
  std::uint32_t lost_scans = 0;
  /// At a relocalisation with lost_map_scans: landmarks mapped from what the lost scans saw, and
  /// their pairings with landmarks mapped before.
  int lost_map_landmarks = 0;
  int lost_map_pairings = 0;
  /// lost_max_scans reached at this scan: tracking resumed from the dead-reckoned estimate.
  bool lost_timeout = false;
  /// Went lost with a checkpoint held (lost_rollback): the scans since it, this one included,
  /// whose updates were undone.
  int rolled_back_scans = 0;
  /// At a fix (lost_onset_scans): the scan the kidnap began at, about, and the scan the map went
  /// back to before it (its kept state); 0 when the onset rolled nothing back.
  std::uint32_t onset_scan = 0;
  std::uint32_t onset_rolled_back_from = 0;
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
  /// Earlier sightings applied when their feature was admitted; batch updates of them the EKF
  /// refused; sightings let go because their pose clone was the oldest past max_pose_clones.
  std::uint64_t delayed_sightings = 0;
  std::uint64_t rejected_delayed_updates = 0;
  std::uint64_t dropped_sightings = 0;
  /// Kept sightings let go because their feature, seen once, was out of the sensor's reach
  /// (release_out_of_reach).
  std::uint64_t out_of_reach_sightings = 0;
  /// Of delayed_sightings: a restarted feature's earlier sightings that fit its landmark.
  std::uint64_t restarted_sightings = 0;
  /// Landmarks mapped from the lost scans, or still recent when they began, that the associator's
  /// rules had removed by the fix (DataAssociation::landmarkFromLostScans, landmarkOverLostScans).
  std::uint64_t lost_map_removed = 0;
  /// Fixes whose kidnap began before the scans undone already: the map went back to before it
  /// (lost_onset_scans).
  std::uint64_t onset_rollbacks = 0;
};

}  // namespace ekf_slam
