#include "ekf_slam/ros/ros_configuration.h"

#include <memory>

#include "ekf_slam/ros/extractor_loader.h"
#include "ekf_slam/ros/ros_parameter_source.h"

namespace ekf_slam {

ParameterSection RosConfiguration::top() const {
  auto source = std::make_shared<RosParameterSource>(nh_);
  return {source, source->names()};
}

ParameterSection RosConfiguration::section(const std::string& short_name) const {
  auto source = std::make_shared<RosParameterSource>(nh_, short_name);
  return {source, source->names()};
}

std::vector<ScanFilterSpec> RosConfiguration::scanFilterChain() const {
  return readScanFilterChain(nh_);
}

}  // namespace ekf_slam
