// The node's services (~reset, ~relocalise, ~save_map, ~load_map) and its recovery log.
#include <algorithm>
#include <cmath>
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
  if (res.success) lost_since_scan_ = static_cast<std::uint32_t>(pipeline_->counters().scans);
  res.message = res.success ? "lost on request: the next scans are relocalised with " +
                                  pipeline_config_.relocaliser
                            : "recovery is off (parameter ~relocaliser is \"\")";
  ROS_INFO("ekf_slam: ~relocalise: %s", res.message.c_str());
  return true;
}

void EkfSlamNode::reportRecovery(const ScanReport& report) {
  // Once per event: going lost, and its end (a fix or the timeout); nothing per scan between.
  if (report.became_lost) {
    lost_since_scan_ = report.scan;
    const Eigen::Matrix3d P = pipeline_->poseCovariance();
    ROS_WARN(
        "ekf_slam: LOST at scan %u (%s): map frozen, relocalising with %s; the pose is dead "
        "reckoned from here (position sd %.2f m, growing with the odometry)",
        report.scan, report.lost_reason.c_str(), pipeline_config_.relocaliser.c_str(),
        std::sqrt(std::max(0.0, P(0, 0) + P(1, 1))));
  }
  if (report.relocalised) {
    const Eigen::Vector3d p = pipeline_->pose();
    const Eigen::Vector3d& d = report.fix_correction;
    ROS_INFO(
        "ekf_slam: relocalised at scan %u after %u scans lost (since scan %u): correction %.2f m, "
        "%.3f rad, %d pairings used (%d in the relocaliser's hypothesis); pose (%.2f, %.2f, "
        "%.3f rad); from what the lost scans saw: %d landmarks mapped, %d pairings",
        report.scan, report.lost_scans, lost_since_scan_, d.head<2>().norm(), d.z(),
        report.fix_pairings, report.relocalisation.hypothesis_size, p.x(), p.y(), p.z(),
        report.lost_map_landmarks, report.lost_map_pairings);
    if (report.onset_scan > 0)
      ROS_INFO(
          "ekf_slam: the kidnap began about scan %u, before any rule saw it: the map went back to "
          "scan %u and every scan since was mapped again from the fix",
          report.onset_scan, report.onset_rolled_back_from);
  }
  if (report.lost_timeout) {
    ROS_WARN("ekf_slam: no relocalisation at scan %u (lost since scan %u): %s", report.scan,
             lost_since_scan_, report.lost_reason.c_str());
  }
  // /diagnostics says so at once, not at the next period (a fix may come sooner).
  if ((report.became_lost || report.relocalised || report.lost_timeout) &&
      config_.diagnostics_period > 0.0)
    onDiagnosticsTimer(ros::WallTimerEvent());
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
    lost_since_scan_ = static_cast<std::uint32_t>(pipeline_->counters().scans);
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
