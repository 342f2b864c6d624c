// A simulated world's bag and its YAML, written into a temporary folder for one test, and the
// offline runner's options for a run on it, and a reader of the trajectories it writes (tests of
// the runner that need no data set).
#pragma once

#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <Eigen/Core>

#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/tools/simulation_bag.h"
#include "offline_test_options.h"
#include "test_files.h"

namespace test_files {

struct SimulatedBag {
  explicit SimulatedBag(const std::string& world) {
    ekf_slam::SimulationBagOptions o;
    o.world = world;
    o.out_path = (dir.path() / (world + ".bag")).string();
    o.markers = false;
    std::ostringstream log;
    summary = ekf_slam::writeSimulationBag(o, log);
  }
  ekf_slam::OfflineOptions options(const std::string& out) const {
    return quietOfflineOptions(summary.bag_path, summary.params_path, (dir.path() / out).string());
  }
  TempDir dir;
  ekf_slam::SimulationBagSummary summary;
};

/// (stamp -> x, y) of a CSV the runner writes whose first columns are stamp, x, y
/// (trajectory.csv, trajectory_smoothed.csv, ground_truth.csv).
inline std::map<double, Eigen::Vector2d> positions(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::map<double, Eigen::Vector2d> out;
  while (std::getline(in, line)) {
    double t = 0.0, x = 0.0, y = 0.0;
    if (std::sscanf(line.c_str(), "%lf,%lf,%lf", &t, &x, &y) == 3) out[t] = {x, y};
  }
  return out;
}

}  // namespace test_files
