// The node's own settings: frames, transforms, timers, queues, markers (docs/node.md). ROS-free,
// so that every entry point reads and validates the same keys: a node's YAML is accepted by the
// offline runner, evaluate and the tools, and a misspelt key is an error in all of them.
#pragma once

#include <string>

#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

/// How the landmarks look in rviz (~landmarks).
struct MarkerStyle {
  double default_diameter = 0.3;  ///< cylinder diameter when a landmark's is unknown [m]
  double height = 1.0;            ///< cylinder height [m]
  double text_size = 2.0;         ///< height of the id labels [m]: readable at the default zoom
  bool show_ids = true;
  bool show_ellipses = true;
};

/// The node's own settings (the pipeline's are PipelineConfig, each plugin's its own).
struct NodeConfig {
  std::string map_frame = "map";
  std::string odom_frame = "odom";
  std::string base_frame = "base_link";
  bool publish_tf = true;            ///< map -> odom (or map -> base_frame, see below)
  bool publish_map_to_base = false;  ///< no odom frame: publish map -> base_frame instead
  bool publish_odom_tf = false;      ///< broadcast odom -> base_frame from each odometry message
  /// With publish_odom_tf: once no odometry came for input_timeout, keep broadcasting its last
  /// pose on the transform timer, so that a tf listener started after a replay has the whole
  /// tree. For replays only: on a robot it would make a dead odometry source look alive.
  bool hold_odom_tf = false;
  double transform_tolerance = 0.1;  ///< map -> odom is stamped this much ahead [s]
  /// Wall period of the timer that republishes the latest map -> odom (gmapping's and
  /// slam_toolbox's transform_publish_period); 0: only after each scan [s].
  double transform_publish_period = 0.05;
  double visualization_rate = 5.0;  ///< ~landmarks and ~path, wall-clock Hz; 0: every scan
  double diagnostics_period = 1.0;  ///< /diagnostics, wall seconds; 0: off
  double input_timeout = 1.0;       ///< wall seconds without input before pending ones flush
  /// Subscriber queues, and the bound of the node's own inbox between the receiving thread and
  /// the processing thread (overflow is counted and warned about, never silent).
  int queue_size = 100000;
  std::string map_file;  ///< default path of ~save_map / ~load_map
  /// A map to load at start-up (empty: none); with initial_map_unknown_pose the robot starts
  /// lost in it and the relocaliser finds it (localisation in a saved map).
  std::string initial_map;
  bool initial_map_unknown_pose = false;
  MarkerStyle markers;
};

/// The node's own parameters from `params` (defaults and checks as documented in docs/node.md).
/// Throws ParameterError naming a bad one.
NodeConfig readNodeConfig(const ParameterSource& params);

}  // namespace ekf_slam
