// The offline runner: replays a bag through the same conversions, InputSequencer and SlamPipeline
// as the node, without a ROS master and as fast as the CPU allows, and writes the run's results
// (trajectory, map, associations, GPS fixes, metrics, a picture) to a folder.
// docs/victoria_park.md.
//
//   rosrun ekf_slam ekf_slam_offline --bag FILE --out DIR [--params YAML] [--associator NAME]
//                                    [--relocaliser NAME] [--load-map FILE [--unknown-pose]]
//                                    [--kidnap SCAN:DX,DY,DYAW ...] [--smooth]
//                                    [--dump-problem SCAN] [--no-plot] [--no-progress]
//                                    [--scan-topic T] [--odom-topic T] [--observations-topic T]
//                                    [--gps-topic T] [--ground-truth-topic T]
//                                    [--true-map-topic T] [--base-frame F]
//
// Every run also writes its final map as DIR/map.txt in the ~save_map format
// (SlamPipeline::saveMap), so that runs chain: --load-map DIR/map.txt. With a relocaliser
// (--relocaliser or the YAML's `relocaliser`) the pipeline recovers from a lost pose
// (docs/relocalisation.md); metrics.json then lists every relocalisation.
//
// When every observation of the bag carries a truth id (bags written by `simulate`), the run is
// scored against the truth as `evaluate` scores it (RunScorer): metrics.json gets a "truth"
// object and associations.csv a truth_id column.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
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
  /// Plugin name ("DJNN" or "ekf_slam/DJNN"); empty: the YAML's `associator`, else the default.
  std::string associator;
  /// Relocaliser plugin ("FGCBB" or "ekf_slam/FGCBB"); empty: the YAML's `relocaliser`, else
  /// none (recovery off).
  std::string relocaliser;
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

/// Command line (without the program name). Returns false and sets *error on bad arguments;
/// sets *help for --help.
bool parseOfflineArguments(const std::vector<std::string>& args, OfflineOptions* options,
                           bool* help, std::string* error);
void printOfflineUsage(std::ostream& out, const std::string& program);

/// Runs the whole replay. Throws std::runtime_error (bag, tf, output folder, parameters, pipeline
/// errors, naming the file or parameter), UnknownPluginError (listing the available names).
/// Warnings (plot skipped, pipeline counters) go to `log`.
OfflineSummary runOffline(const OfflineOptions& options, std::ostream& log);

/// The whole command: parse, run, print a summary. Returns the process exit code (0 ok, 1 run
/// error, 2 bad arguments).
int offlineMain(int argc, char** argv);

}  // namespace ekf_slam
