// What an offline run is asked to do (the command line's options) and what it reports.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/pipeline/slam_pipeline.h"

namespace ekf_slam {

struct OfflineOptions {
  std::string bag_path;
  std::string out_dir;
  /// YAML with the pipeline parameters at the top level and each associator's under its short
  /// name (config/victoria_park.yaml); empty: every default.
  std::string params_path;
  /// Values that replace the file's (section "" = the top level), as --associator does: for
  /// tools that rerun a bag with changed parameters (calibrate_noise).
  struct Override {
    std::string section, name, value;
  };
  std::vector<Override> overrides;
  /// Plugin name ("DJNN" or "ekf_slam/DJNN"); empty: the YAML's `associator`, else the default.
  std::string associator;
  /// Relocaliser plugin ("FGCBB" or "ekf_slam/FGCBB"), "" for none (recovery off); unset: the
  /// YAML's `relocaliser`, else the associator's (defaultRelocaliserFor: FGCBB, RRWSC for RRWSC).
  std::optional<std::string> relocaliser;
  /// A map file (~save_map format) loaded before the first scan; empty: start with no map.
  std::string load_map;
  /// With load_map: the pose in that map is unknown, the run starts lost (needs a relocaliser).
  bool unknown_pose = false;
  /// Pose jumps injected before a scan (SlamPipeline::injectPoseJump), to test recovery.
  struct Kidnap {
    std::uint32_t scan = 0;                          ///< 0-based processed scan
    Eigen::Vector3d jump = Eigen::Vector3d::Zero();  ///< map frame dx, dy [m], dyaw [rad]
  };
  std::vector<Kidnap> kidnaps;
  /// 0-based scan whose association problem is written to DIR/problem_<SCAN>.json.
  std::optional<std::uint32_t> dump_problem_scan;
  /// Every landmark's mean and covariance after every scan, to DIR/landmark_trace.csv: how the
  /// map moves over the run (scripts/map_drift.py). Large (about 1.1 million rows for Victoria
  /// Park); with filter cekf every scan brings the whole map up to date (the same estimates,
  /// slower).
  bool landmark_trace = false;
  /// After the run, the batch smoother (core/smoothing/, docs/smoothing.md) re-estimates every
  /// scan pose and landmark from all of the run's odometry and pairings:
  /// DIR/trajectory_smoothed.csv, DIR/map_smoothed.txt (~save_map format) and metrics.json
  /// "smoothing". Not with load_map (the loaded map's own information would be dropped).
  bool smooth = false;
  std::string scan_topic = "/scan";
  std::string odom_topic = "/odom";
  std::string observations_topic = "/observations";
  std::string gps_topic = "/gps";
  std::string tf_static_topic = "/tf_static";
  /// nav_msgs/Odometry with the true pose (simulated bags): pose metrics in metrics.json "truth".
  std::string ground_truth_topic = "/ground_truth";
  /// ekf_slam/LandmarkArray, latched, with the true landmarks (simulated bags): for the picture.
  std::string true_map_topic = "/true_map";
  std::string base_frame = "base_link";
  /// Called after every processed scan (not from the command line: for tools built on the
  /// runner, e.g. relocalisation_experiment).
  std::function<void(const ScanReport&, const SlamPipeline&)> on_scan;
  /// Called once after the last scan, before the outputs are written (the pipeline as it ends).
  std::function<void(const SlamPipeline&)> on_finish;
  bool plot = true;      ///< run scripts/plot_map.py
  bool progress = true;  ///< progress bar, only when stderr is a terminal
};

/// The numbers of a run (also written to DIR/metrics.json).
struct OfflineSummary {
  std::string associator;
  std::uint64_t scans = 0;
  std::uint64_t odometry = 0;
  std::size_t landmarks = 0;
  double wall_time_s = 0.0;
  double gps_rmse_m = -1.0;           ///< < 0 without GPS
  std::uint64_t relocalisations = 0;  ///< PipelineCounters::relocalisations
  std::string metrics_json;           ///< the text of metrics.json
};

}  // namespace ekf_slam
