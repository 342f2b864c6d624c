// ParameterSource over the ROS parameter server, for configuring ROS-free algorithms from a node.
#pragma once

#include <string>
#include <vector>

#include <ros/node_handle.h>

#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

/// Reads parameters from the namespace of a NodeHandle, typically the associator's own namespace
/// (e.g. RosParameterSource(ros::NodeHandle("~DJNN")) reads /ekf_slam/DJNN/...). Integers are
/// accepted where a double is asked for; any other type mismatch throws ParameterError with the
/// fully qualified name.
class RosParameterSource : public ParameterSource {
 public:
  explicit RosParameterSource(const ros::NodeHandle& nh) : nh_(nh) {}
  /// Namespace `ns` relative to `parent`, e.g. (private handle, "DJNN").
  RosParameterSource(const ros::NodeHandle& parent, const std::string& ns) : nh_(parent, ns) {}

  bool get(const std::string& name, double* value) const override;
  bool get(const std::string& name, int* value) const override;
  bool get(const std::string& name, bool* value) const override;
  bool get(const std::string& name, std::string* value) const override;
  /// e.g. "/ekf_slam/DJNN/individual_probability".
  std::string qualify(const std::string& name) const override { return nh_.resolveName(name); }
  /// Parameters directly in the namespace (not those of sub-namespaces), relative names.
  std::vector<std::string> names() const;

  const ros::NodeHandle& nodeHandle() const { return nh_; }

 private:
  ros::NodeHandle nh_;
};

}  // namespace ekf_slam
