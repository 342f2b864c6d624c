// Writes a simulated world (ekf_slam/evaluation/simulation/simulator.h, docs/simulation.md) into a
// ROS bag that the node and the offline runner consume as they consume a real one, plus a parameter
// YAML:
//
//   rosrun ekf_slam simulate --world tiny --out /tmp/tiny.bag       # also writes /tmp/tiny.yaml
//   rosrun ekf_slam ekf_slam_offline --bag /tmp/tiny.bag --params /tmp/tiny.yaml --out /tmp/run
//   roslaunch ekf_slam simulation.launch bag:=/tmp/tiny.bag
//
// Topics (stamps = simulation stamp + sim::kStampOffset, header.seq = index on the topic):
//   /odom              nav_msgs/Odometry     odom -> base_link, noisy odometry, per control step
//   /observations      ekf_slam/LandmarkObservationArray  frame laser, with truth ids
//   /scan              sensor_msgs/LaserScan  frame laser, with intensities: laser worlds
//                      (sim::laserWorld, e.g. beacons) instead of /observations
//   /ground_truth      nav_msgs/Odometry     map -> base_link, true pose and twist
//   /true_map          ekf_slam/LandmarkArray  frame map, the static landmarks, latched
//   /movers            ekf_slam/LandmarkArray  frame map, true movers per observation set (if any)
//   /true_map_markers  visualization_msgs/MarkerArray  the static landmarks for rviz, latched
//   /movers_markers    visualization_msgs/MarkerArray  the movers for rviz (if any)
//   /tf_static         tf2_msgs/TFMessage    base_link -> laser (world.sensor.offset), latched
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "ekf_slam/evaluation/simulated_run.h"

namespace ekf_slam {

struct SimulationBagOptions {
  std::string world;                   ///< a name of sim::worldNames()
  std::optional<std::uint64_t> seed;   ///< unset: the world's default_seed
  std::string out_path;                ///< the .bag to write (overwritten)
  std::string params_path;             ///< empty: defaultParamsPath(out_path)
  bool write_params = true;            ///< false: no YAML (--no-params)
  std::optional<double> clutter_rate;  ///< overrides world.clutter_rate
  std::optional<int> movers;           ///< overrides world.movers.count
  /// Overrides the sensor's detection probability, the same everywhere in view.
  std::optional<double> detection_probability;
  bool markers = true;  ///< also write the rviz marker topics
  /// --true-noise, for checking noise calibration (docs/calibration.md): the observations carry
  /// no covariance (the parameter file's sigma_range and sigma_bearing apply) and the file's
  /// odometry noise is the simulator's own (sim::trueNoiseParametersFor; twist worlds only).
  bool true_noise = false;
};

/// What was written (the numbers simulateMain prints).
struct SimulationBagSummary {
  std::string world;
  std::uint64_t seed = 0;
  std::string bag_path;
  std::string params_path;   ///< empty when no YAML was written
  double first_stamp = 0.0;  ///< bag clock [s] (simulation stamp + sim::kStampOffset)
  double last_stamp = 0.0;
  double duration_s = 0.0;                ///< simulated time covered
  std::size_t odometry = 0;               ///< /odom messages (= /ground_truth messages)
  std::size_t observation_sets = 0;       ///< /observations messages
  std::size_t scans = 0;                  ///< /scan messages (laser worlds: instead of those)
  std::size_t observations = 0;           ///< returns in them ...
  std::size_t landmark_observations = 0;  ///< ... of static landmarks
  std::size_t mover_observations = 0;     ///< ... of movers
  std::size_t clutter_observations = 0;   ///< ... clutter
  std::size_t landmarks = 0;              ///< static landmarks of the world
  std::size_t movers = 0;
  int kidnaps = 0;  ///< kidnap events that happened during the run
};

/// `path` with a trailing ".bag" replaced by ".yaml" (appended when it has none).
std::string defaultParamsPath(const std::string& bag_path);

/// The parameter file for a world: pipeline parameters (sim::pipelineParametersFor) at the top
/// level, each associator's world-dependent ones (sim::associatorParametersFor) in its section,
/// DJNN's always, in the layout of config/simulation.yaml. `header_comment` lines lead the file.
/// A laser world's `extractor` (sim::extractorFor) adds `extractor:` and its section.
std::string simulationParamsYaml(
    const std::string& world_name, const std::map<std::string, std::string>& pipeline,
    const std::map<std::string, std::map<std::string, std::string>>& associators,
    const std::vector<std::string>& header_comment, const sim::ExtractorSetup& extractor = {});

/// simulationParamsYaml for `world` with its own pipeline, associator and extractor parameters:
/// what `simulate` writes beside the bag (and config/<world>.yaml holds for the shipped worlds).
std::string worldParamsYaml(const sim::World& world, const std::vector<std::string>& header_comment,
                            bool true_noise = false);

/// Simulates and writes the bag (and the YAML unless !write_params). Throws
/// std::invalid_argument for an unknown world or invalid overrides and std::runtime_error when a
/// file cannot be written (a partial bag is removed). Notes go to `log`.
SimulationBagSummary writeSimulationBag(const SimulationBagOptions& options, std::ostream& log);

/// What the command line asks for.
enum class SimulateAction { kRun, kHelp, kList };

/// Command line of `simulate` (args without the program name). Returns false and sets *error on
/// bad arguments (an unknown world lists the known ones).
bool parseSimulateArguments(const std::vector<std::string>& args, SimulationBagOptions* options,
                            SimulateAction* action, std::string* error);
void printSimulateUsage(std::ostream& out, const std::string& program);
/// One line per world: name and description.
void printWorldList(std::ostream& out);

/// The whole command: parse, simulate, write, print a summary. Returns the process exit code (0
/// ok, 1 runtime error, 2 bad arguments).
int simulateMain(int argc, char** argv);

}  // namespace ekf_slam
