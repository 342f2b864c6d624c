// Every setting of SlamPipeline, read in one place (readPipelineConfig). The node reads them over
// a NodeHandle, the tools from YAML, through the one pipeline builder (app/pipeline_builder.h):
// same names, same defaults (PipelineConfig's), same validation. Names and meanings:
// docs/parameters.md.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/common/sensor_model.h"
#include "ekf_slam/core/feature_extraction/tree_extractor.h"
#include "ekf_slam/core/filter/ekf_slam.h"  // Linearisation
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/odometry_correction.h"

namespace ekf_slam {

/// The relocaliser used when the configuration names none: it measured best with no wrong fix
/// (docs/relocalisation.md). The pipeline builder gives an associator with a relocaliser of its
/// own that one instead (defaultRelocaliserFor, app/pipeline_builder.h).
constexpr const char* kDefaultRelocaliser = "ekf_slam/FGCBB";

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
  /// On by default; the builder puts the associator's own relocaliser here when unset.
  std::string relocaliser = kDefaultRelocaliser;
  /// Lost rule 1: this many consecutive scans with >= lost_min_observations observations, yet
  /// not one paired with an established (not recent) landmark, and >= lost_min_expected map
  /// landmarks in view (within lost_view_range of the sensor, 0 = max_observation_range, and inside
  /// lost_field_of_view about its x axis). With fewer in view the relocaliser probes instead
  /// (docs/relocalisation.md). 0 disables the rule.
  int lost_unpaired_scans = 5;
  int lost_min_observations = 3;
  int lost_min_expected = 3;
  /// Rule 1 counts a scan as unpaired when fewer established landmarks were paired than this
  /// share of those in view (0: when none was, the rule as first written), and than this share
  /// of its observations. A sensor that sees most of what is in view (P_D near 1) can set about
  /// half its P_D: a kidnapped filter that sees many landmarks pairs a few by chance, which
  /// resets the count when the share is 0. The observations' share keeps a filter that explains
  /// what it sees from counting stale landmarks (movers an associator mapped) as missed.
  double lost_min_paired_share = 0.0;
  /// With lost_min_paired_share > 0, both shares are learned while tracking: each is the mean of
  /// what the scans paired over about this many scans (an exponential mean), and a scan counts
  /// as unpaired below half of it (at most lost_min_paired_share). Landmarks the sensor misses
  /// for long (occlusion) then lower what counts as unpaired; a kidnap pairs almost none. 0: the
  /// shares stay lost_min_paired_share.
  int lost_share_learning_scans = 100;
  /// Landmarks created fewer than this many scans ago are "recent": pairing them does not count
  /// for rule 1, they are not "in view", and they are discarded when the pipeline goes lost.
  int lost_recent_scans = 20;
  /// Count that age in informative scans only (tracked, >= lost_min_observations observations):
  /// where the scans hold few observations, landmarks mapped at a kidnapped pose would otherwise
  /// turn established before any rule could see enough to fire (docs/relocalisation.md).
  bool lost_recent_informative = false;
  double lost_view_range = 0.0;
  double lost_field_of_view = M_PI;
  /// "In view" also inside this convex polygon in the sensor frame (a camera's footprint, the
  /// trapezoid of a downward camera); empty: the range and the wedge alone. Parameter text
  /// "x1,y1; x2,y2; ..." (parsePolygon).
  std::vector<Eigen::Vector2d> lost_view_polygon;
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
  /// At a fix, the scans processed while lost are carried back from the fixed pose by their
  /// odometry, associated by a gate of their own (pair within chi2(2, lost_map_pair_probability)
  /// of exactly one landmark; new outside chi2(2, lost_map_new_probability) of all) and update
  /// the map; a new landmark stays when seen in lost_map_min_sightings of them
  /// (docs/relocalisation.md, "Nothing seen while lost is thrown away"). false: they are dropped.
  bool lost_map_scans = true;
  double lost_map_pair_probability = 0.99;
  double lost_map_new_probability = 0.9999;
  int lost_map_min_sightings = 3;
  /// Before a scan that pairs few of its observations with established landmarks (LostMonitor::
  /// suspect) the map is kept; at a lost event the map goes back to it and the scans since become
  /// lost scans (docs/relocalisation.md, "Rolling back to before the kidnap"). false: the scans
  /// tracked before the lost event keep what they did to the map.
  bool lost_rollback = true;
  /// At a fix, the kidnap's onset is looked for among the last this many scans (KidnapOnset):
  /// from it on the scans are explained better at the fix carried back by their odometry than at
  /// the filter's poses. When it comes before the scans already undone (lost_rollback), the map
  /// goes back to the filter's state kept at or before it and the scans since are mapped as lost
  /// scans (docs/relocalisation.md, "A kidnap found late"). 0: off. At most 1000.
  int lost_onset_scans = 600;
  /// ... the filter's state is kept this many times over that window (each a copy of the state:
  /// memory and time grow with it and with the map's size squared).
  int lost_onset_snapshots = 10;
  /// ... and an onset counts when at least this many observations are better explained from it on.
  double lost_onset_min_score = 10.0;
  double lost_nis_probability = 0.999;

  /// The filter: "ekf" (every step on the whole state) or "cekf", the compressed EKF
  /// (docs/cekf.md): steps on the active area only, the same result up to rounding.
  std::string filter = "ekf";
  double cekf_area_size = 50.0;  ///< CompressedEkfParams::area_size [m]
  double cekf_margin = 10.0;     ///< CompressedEkfParams::margin [m]
  double cekf_area_slack = 0.0;  ///< CompressedEkfParams::slack [m]
  /// Where the EKF's Jacobians are evaluated: "standard" (the current estimate),
  /// "first_estimate", the FEJ-EKF, "invariant", the right-invariant EKF (both filter ekf only),
  /// or "auto": with the full EKF, FEJ unless second_order_observations says far landmarks are
  /// first seen too poorly for a first estimate (there FEJ diverges), and there the invariant
  /// EKF, which needs none; the standard Jacobians with the compressed EKF
  /// (docs/consistency.md, "The default filter").
  std::string jacobians = "auto";
  /// What "auto" (or the explicit value) resolves to.
  Linearisation linearisation() const {
    if (jacobians == "first_estimate") return Linearisation::kFirstEstimate;
    if (jacobians == "invariant") return Linearisation::kInvariant;
    if (jacobians == "auto" && filter == "ekf")
      return second_order_observations ? Linearisation::kInvariant : Linearisation::kFirstEstimate;
    return Linearisation::kStandard;
  }
  /// Second-order terms of range-bearing observations (EKF2, docs/consistency.md): the mean and
  /// spread that the first-order prediction misses for a landmark known poorly across the line of
  /// sight, in the update, the associators' gates and the initialisation.
  bool second_order_observations = false;
  /// Apply an admitted feature's earlier sightings against clones of their poses
  /// (core/pipeline/delayed_sightings.h; filter ekf, slam mode), keeping at most max_pose_clones.
  bool delayed_sightings = true;
  int max_pose_clones = 40;
  /// Let the kept sighting of a feature seen once go when the associator reports it out of the
  /// sensor's reach (AssociationResult::out_of_reach_features): a feature seen once at the edge
  /// of the view and then driven past would otherwise hold its clone until the associator drops
  /// it. Features seen more than once keep their sightings.
  bool release_out_of_reach = true;
  /// A restarted feature's earlier sightings (AssociationResult::restarted_features) are applied
  /// at its admission when each lies within chi2(2, restarted_sighting_probability) of the
  /// landmark, after the run's own sightings.
  double restarted_sighting_probability = 0.999;

  /// Throws ParameterError naming the first invalid setting.
  void validate() const;
};

/// Reads and validates every pipeline parameter; unset ones keep PipelineConfig's default.
/// Throws ParameterError naming the (first) bad parameter.
PipelineConfig readPipelineConfig(const ParameterSource& params);

}  // namespace ekf_slam
