// The node's services (~reset, ~relocalise, ~save_map, ~load_map) and its recovery log.
#include <string>

#include "ekf_slam/ros/node/ekf_slam_node.h"

namespace ekf_slam {

bool EkfSlamNode::resetService(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  // Inputs already queued belong to the old run.
  const std::size_t dropped = sequencer_->pending();
  sequencer_->clear();
  resetAll("~reset called; " + std::to_string(dropped) + " queued inputs discarded");
  return true;
}

bool EkfSlamNode::relocaliseService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  res.success = pipeline_->requestRelocalisation();
  res.message = res.success ? "lost on request: the next scans are relocalised with " +
                                  pipeline_config_.relocaliser
                            : "no relocaliser configured (parameter ~relocaliser)";
  ROS_INFO("ekf_slam: ~relocalise: %s", res.message.c_str());
  return true;
}

void EkfSlamNode::reportRecovery(const ScanReport& report) {
  if (report.became_lost) {
    ROS_WARN("ekf_slam: lost at scan %u (%s): map frozen, relocalising with %s", report.scan,
             report.lost_reason.c_str(), pipeline_config_.relocaliser.c_str());
  }
  if (report.relocalised) {
    const Eigen::Vector3d p = pipeline_->pose();
    ROS_INFO("ekf_slam: relocalised at scan %u: pose (%.2f, %.2f, %.3f rad), %d pairings",
             report.scan, p.x(), p.y(), p.z(), report.relocalisation.hypothesis_size);
  }
}

bool EkfSlamNode::saveMapService(SaveMap::Request& req, SaveMap::Response& res) {
  const std::string path = req.path.empty() ? config_.map_file : req.path;
  if (path.empty()) {
    res.success = false;
    res.message = "no path given and ~map_file is not set";
    return true;
  }
  try {
    pipeline_->saveMap(path);
    res.success = true;
    res.message =
        "saved " + std::to_string(pipeline_->ekf().numLandmarks()) + " landmarks to " + path;
    ROS_INFO("ekf_slam: %s", res.message.c_str());
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    ROS_ERROR("ekf_slam: save_map: %s", e.what());
  }
  return true;
}

bool EkfSlamNode::loadMapService(LoadMap::Request& req, LoadMap::Response& res) {
  const std::string path = req.path.empty() ? config_.map_file : req.path;
  if (path.empty()) {
    res.success = false;
    res.message = "no path given and ~map_file is not set";
    return true;
  }
  try {
    pipeline_->loadMap(path, req.reset_pose, req.unknown_pose);
    res.success = true;
    res.message =
        "loaded " + std::to_string(pipeline_->ekf().numLandmarks()) + " landmarks from " + path;
    ROS_INFO("ekf_slam: %s", res.message.c_str());
    markers_.reset();
    visualization_dirty_ = true;
    publishMapOutputs();
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    ROS_ERROR("ekf_slam: load_map: %s", e.what());
  }
  return true;
}

}  // namespace ekf_slam
