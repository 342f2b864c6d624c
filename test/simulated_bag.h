// A simulated world's bag and its YAML, written into a temporary folder for one test, and the
// offline runner's options for a run on it (tests of the runner that need no data set).
#pragma once

#include <sstream>
#include <string>

#include "ekf_slam/ros/offline_runner.h"
#include "ekf_slam/ros/simulation_bag.h"
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

}  // namespace test_files
