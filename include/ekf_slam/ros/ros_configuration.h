// The node's Configuration: the parameter server under its private namespace. Top-level
// parameters are ~name, a plugin's section is ~<short name>/ (e.g. ~DJNN/gate), the scan filter
// chain is ~scan_filter_chain: the same layout as config/*.yaml loaded with rosparam.
#pragma once

#include <string>
#include <vector>

#include <ros/node_handle.h>

#include "ekf_slam/app/configuration.h"

namespace ekf_slam {

class RosConfiguration : public Configuration {
 public:
  explicit RosConfiguration(const ros::NodeHandle& private_nh) : nh_(private_nh) {}
  ParameterSection top() const override;
  ParameterSection section(const std::string& short_name) const override;
  std::vector<ScanFilterSpec> scanFilterChain() const override;

 private:
  ros::NodeHandle nh_;
};

}  // namespace ekf_slam
