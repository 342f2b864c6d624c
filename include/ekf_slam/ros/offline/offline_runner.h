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

#include "ekf_slam/ros/offline/offline_options.h"

namespace ekf_slam {

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
