// The offline runner: replays a bag through the same conversions, InputSequencer and SlamPipeline
// as the node, without a ROS master and as fast as the CPU allows, and writes the run's results
// (trajectory, map, associations, GPS fixes, metrics, a picture) to a folder.
// docs/victoria_park.md.
//
//   rosrun ekf_slam ekf_slam_offline --bag FILE --out DIR [--params YAML] [--associator NAME]
//                                    [--dump-problem SCAN] [--no-plot] [--no-progress]
//                                    [--scan-topic T] [--odom-topic T] [--observations-topic T]
//                                    [--gps-topic T] [--ground-truth-topic T]
//                                    [--true-map-topic T] [--base-frame F]
//
// When every observation of the bag carries a truth id (bags written by `simulate`), the run is
// scored against the truth as `evaluate` scores it (RunScorer): metrics.json gets a "truth"
// object and associations.csv a truth_id column.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace ekf_slam {

struct OfflineOptions {
  std::string bag_path;
  std::string out_dir;
  /// YAML with the pipeline parameters at the top level and each associator's under its short
  /// name (config/victoria_park.yaml); empty: every default.
  std::string params_path;
  /// Plugin name ("DJNN" or "ekf_slam/DJNN"); empty: the YAML's `associator`, else the default.
  std::string associator;
  /// 0-based scan whose association problem is written to DIR/problem_<SCAN>.json.
  std::optional<std::uint32_t> dump_problem_scan;
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
  double gps_rmse_m = -1.0;  ///< < 0 without GPS
  std::string metrics_json;  ///< the text of metrics.json
};

/// Command line (without the program name). Returns false and sets *error on bad arguments;
/// sets *help for --help.
bool parseOfflineArguments(const std::vector<std::string>& args, OfflineOptions* options,
                           bool* help, std::string* error);
void printOfflineUsage(std::ostream& out, const std::string& program);

/// Runs the whole replay. Throws std::runtime_error (bag, tf, output folder, parameters, pipeline
/// errors, naming the file or parameter), UnknownAssociatorError (listing the available names).
/// Warnings (plot skipped, pipeline counters) go to `log`.
OfflineSummary runOffline(const OfflineOptions& options, std::ostream& log);

/// The whole command: parse, run, print a summary. Returns the process exit code (0 ok, 1 run
/// error, 2 bad arguments).
int offlineMain(int argc, char** argv);

}  // namespace ekf_slam
