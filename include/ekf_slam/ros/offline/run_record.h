// What an offline run keeps of each processed scan, in memory until the loop ends (so that the
// wall time measures the SLAM processing alone): the trajectory, every decision, the landmark
// trace, the timings, the relocalisations, what the smoother needs, and on a simulated bag the
// truth scores (RunScorer, as evaluate scores the same run).
#pragma once

#include <cstdint>
#include <memory>
#include <ostream>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/core/smoothing/smoothing_recorder.h"
#include "ekf_slam/evaluation/scoring/run_scorer.h"
#include "ekf_slam/ros/offline/bag_input.h"
#include "ekf_slam/ros/offline/offline_options.h"

namespace ekf_slam {

// One trajectory.csv row.
struct PoseRow {
  double stamp;
  Eigen::Vector3d pose;
  Eigen::Vector3d variance;    // diagonal of the pose covariance
  Eigen::Vector2d correction;  // odometry correction estimates (first correctionDim() used)
  Eigen::Vector2d correction_sd;
};
// One landmark_trace.csv row.
struct LandmarkTraceRow {
  std::uint32_t scan;
  double stamp;
  LandmarkId id;
  Eigen::Vector2d mean;
  Eigen::Vector3d cov;  // var_x, cov_xy, var_y
};
// One associations.csv row.
struct AssociationRow {
  std::uint32_t scan;
  std::uint32_t obs;
  double stamp;
  double range, bearing, diameter;
  Decision decision;
  LandmarkId landmark;
  std::int64_t truth_id;
  bool removal = false;  // a landmark removed after the scan (obs, range, ... empty)
};
// One relocalisation (metrics.json relocalisation_events).
struct RelocalisationEvent {
  std::uint32_t scan;
  double stamp;
  Eigen::Vector3d pose;
  int pairings;
  double joint_mahalanobis;
  std::uint64_t nodes;
  double time_us;
};

// One lost event, from going lost to its end (metrics.json lost_event_list).
struct LostEvent {
  std::uint32_t scan = 0;  // went lost after it (a forced start: the first scan processed lost)
  double stamp = 0.0;
  std::string reason;
  std::string end = "lost at end";  // "relocalised", "timeout" or "lost at end"
  std::uint32_t end_scan = 0;
  double end_stamp = 0.0;
  std::uint32_t scans_lost = 0;                          // processed lost until the end
  Eigen::Vector3d correction = Eigen::Vector3d::Zero();  // relocalised: fix minus estimate
  int pairings = 0;                                      // relocalised: paired in the fix
  // Relocalised with the map rolled back to the kidnap's onset (lost_onset_scans): the onset
  // and the scan whose kept state the map went back to; -1: none.
  std::int64_t onset_scan = -1;
  std::int64_t rolled_back_to = -1;
};

/// Stamps in full: epoch stamps (1.2e9 s) need 10 digits before the point and 9 after.
std::string stampText(double stamp);

class RunRecord {
 public:
  /// `bag`: for the truth of a simulated bag (its ground truth sorted by stamp).
  RunRecord(const OfflineOptions& options, const BagContents& bag, std::ostream& log);
  /// One processed scan; `input`: its observation set (truth ids), null for a laser scan.
  void add(const ScanReport& r, const SlamPipeline& pipeline, const ObservationsInput* input);
  /// Time jumped back and the map was reset: landmark ids start again, so does the scoring.
  void restartScoring();

  // The record.
  std::vector<PoseRow> poses;
  std::vector<AssociationRow> rows;
  std::vector<LandmarkTraceRow> trace;
  std::vector<StampedPoint> laser_track;
  /// The sensor track as estimated at each scan, before a relocalisation re-derived the lost
  /// ones.
  std::vector<StampedPoint> online_track;
  SmoothingRecorder smoothing;  ///< --smooth: what the batch smoother needs, scan by scan
  std::vector<double> association_us, update_us, relocalisation_us;
  std::vector<RelocalisationEvent> relocalisations;
  std::vector<LostEvent> lost_events;
  double extraction_s = 0.0, association_s = 0.0, update_s = 0.0;
  std::uint32_t scans = 0;
  /// A simulated bag: scored against its truth (score_scans: laser scans, truth by proximity).
  bool score = false, score_scans = false;
  std::unique_ptr<RunScorer> scorer;

 private:
  const OfflineOptions& o_;
  const BagContents& bag_;
  std::ostream& log_;
  std::unordered_map<LandmarkId, Eigen::Vector2d> true_map_;
  LandmarkId next_clutter_ = sim::kClutterIdBase;
  std::vector<std::int64_t> truth_;
};

}  // namespace ekf_slam
