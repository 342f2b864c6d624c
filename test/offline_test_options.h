// The offline runner's options for a test run: no plot, no progress line.
#pragma once

#include <string>

#include "ekf_slam/ros/offline/offline_runner.h"

namespace test_files {

inline ekf_slam::OfflineOptions quietOfflineOptions(const std::string& bag,
                                                    const std::string& params,
                                                    const std::string& out_dir) {
  ekf_slam::OfflineOptions o;
  o.bag_path = bag;
  o.params_path = params;
  o.out_dir = out_dir;
  o.plot = false;
  o.progress = false;
  return o;
}

}  // namespace test_files
