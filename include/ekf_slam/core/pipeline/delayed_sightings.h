// No sighting wasted (docs/djnn.md, "Delayed sightings"): an associator that waits for several
// sightings before it admits a feature (DJNN's evidence counter, which keeps movers out of the
// map) marks them kTentative with a feature key. Each such scan clones the pose into the state
// (EkfSlam::addClone), and the sightings are kept with the clone of the pose they were taken
// from. When the feature is admitted, the landmark is created from its last sighting as before
// and the earlier ones are applied in one batch update against their clones (so too when the
// associator finds a feature to be a landmark already mapped: AssociationResult::feature of a
// pairing); a feature that is dropped only lets its clones go, which leaves the state exactly as
// if it had never been seen.
// A feature restarted by the associator (AssociationResult::restarted_features: DJNN's static test
// found its sightings not one static point) keeps its earlier runs' sightings aside. At admission,
// after the run's own batch, each of them that lies within the gate
// (restarted_sighting_probability) of the landmark is applied in a second batch: a static point's
// chance failure loses nothing, and a mover's earlier track stays out.
// The clones cost 3 state rows each: at most max_pose_clones are kept (the oldest go first), and
// a feature seen once that the associator reports out of the sensor's reach lets its sighting go
// (release_out_of_reach): it is most likely clutter or a passer-by, and its clone would otherwise
// stay in every update until it ends (DJNN keeps such a feature up to its timeout).
#pragma once

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/filter/filter_backend.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/pipeline/scan_report.h"

namespace ekf_slam {

class DelayedSightings {
 public:
  DelayedSightings(const PipelineConfig& config, FilterBackend& filter,
                   const RangeBearingModel& model, PipelineCounters& counters)
      : config_(config), filter_(filter), model_(model), counters_(counters) {}

  /// On: delayed_sightings, the full EKF (the compressed one keeps no clones) and slam mode.
  bool enabled() const;
  /// After the scan's update and its new landmarks (kNew entries carry their ids): every new
  /// landmark's earlier sightings, and those of features that joined a paired landmark, in one
  /// batch update against their clones (report->delayed_sightings, delayed_nis). True when the
  /// state changed.
  bool admit(ScanReport* report);
  /// Keeps this scan's sightings of tentative features against a clone of the current pose, lets
  /// the ended features go, and those out of reach (release_out_of_reach), and drops the oldest
  /// clones beyond max_pose_clones.
  void keep(const ScanReport& report);
  /// Lets every sighting and clone go (reset, lost, a map loaded).
  void clear();

  std::size_t features() const { return features_.size(); }

 private:
  struct Kept {
    CloneId clone;
    std::uint32_t scan;
    int observation;
    Eigen::Vector2d z;
    Eigen::Matrix2d R;
    MeasurementKind kind;
  };
  void release(std::vector<Kept>* sightings);
  /// Releases feature f's run and earlier runs.
  void end(FeatureKey f);
  /// The earlier runs' sightings of the features admitted this scan that fit their landmarks, in
  /// a second batch (after the runs' own).
  bool applyEarlierRuns(ScanReport* report);
  void dropOldestClone();

  const PipelineConfig& config_;
  FilterBackend& filter_;
  const RangeBearingModel& model_;
  PipelineCounters& counters_;
  std::unordered_map<FeatureKey, std::vector<Kept>> features_;
  std::unordered_map<FeatureKey, std::vector<Kept>> earlier_;  // restarted runs, by live run
  std::vector<std::pair<FeatureKey, LandmarkId>> joined_;      // this scan's admissions
  std::unordered_map<CloneId, int> uses_;                      // sightings per clone
  std::vector<Pairing> batch_;                                 // per-scan workspaces
  std::vector<FeatureKey> admitted_;
};

}  // namespace ekf_slam
