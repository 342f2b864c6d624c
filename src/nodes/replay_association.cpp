// replay_association --problem FILE --associator NAME [--params YAML]
//
// Runs one associator, loaded through pluginlib exactly as the SLAM node loads it, on a saved
// association problem (docs/replay_association.md) and prints one line per observation,
// "obs_index landmark_index" (-1 when unpaired), then "joint_mahalanobis D2".
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <stdexcept>
#include <string>

#include "ekf_slam/app/association_problem.h"
#include "ekf_slam/app/pipeline_builder.h"
#include "ekf_slam/app/yaml_configuration.h"
#include "ekf_slam/ros/plugin_loader.h"

namespace {

const char* kUsage =
    "usage: replay_association --problem FILE.json --associator NAME [--params FILE.yaml]\n"
    "  NAME: a plugin name such as ekf_slam/DJNN (or just DJNN)\n"
    "  FILE.yaml: the node's parameter file: the associator's parameters in the section named\n"
    "             after it (e.g. DJNN:), the pipeline's at the top level (checked, not used)\n";

}  // namespace

int main(int argc, char** argv) {
  std::string problem_file, associator, params_file;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      std::cout << kUsage;
      return 0;
    }
    std::string* target = arg == "--problem"      ? &problem_file
                          : arg == "--associator" ? &associator
                          : arg == "--params"     ? &params_file
                                                  : nullptr;
    if (target == nullptr || i + 1 >= argc) {
      std::cerr << "replay_association: bad argument '" << arg << "'\n" << kUsage;
      return 2;
    }
    *target = argv[++i];
  }
  if (problem_file.empty() || associator.empty()) {
    std::cerr << "replay_association: --problem and --associator are required\n" << kUsage;
    return 2;
  }

  try {
    const auto problem = ekf_slam::readAssociationProblem(problem_file);
    // The parameter file as every entry point reads it (app/pipeline_builder.h): the pipeline's
    // keys at the top level, the associator's in its section; the problem's gate alphas apply
    // where that section does not set the same parameter.
    const std::string lookup = ekf_slam::pluginLookupName(associator);
    ekf_slam::YamlConfiguration configuration(params_file);
    configuration.setOverride("", "associator", lookup);
    for (const auto& [name, value] : ekf_slam::problemParameters(problem, lookup))
      configuration.setDefault(ekf_slam::pluginShortName(lookup), name, value);
    const auto assoc =
        ekf_slam::buildPipeline(configuration, ekf_slam::PluginlibFactory()).associator;
    const auto replay = ekf_slam::replayAssociation(problem, *assoc);
    // Only finite results are printed: an infinite distance means the problem is degenerate
    // (a singular innovation covariance), which a caller must not take for an answer.
    if (!std::isfinite(replay.joint_mahalanobis)) {
      throw std::runtime_error(problem_file + ": the joint Mahalanobis distance of " + associator +
                               "'s pairings is not finite (singular innovation covariance?)");
    }
    for (std::size_t i = 0; i < replay.landmark.size(); ++i) {
      std::printf("%zu %d\n", i, replay.landmark[i]);
    }
    std::printf("joint_mahalanobis %.9g\n", replay.joint_mahalanobis);
  } catch (const std::exception& e) {
    std::cerr << "replay_association: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
