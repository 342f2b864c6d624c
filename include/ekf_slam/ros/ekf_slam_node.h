// The ekf_slam node: a thin ROS shell around SlamPipeline. It reads every parameter in one place
// (readParameters), puts the inputs in stamp order with InputSequencer, hands them to the
// pipeline and publishes the results:
//
//   scan (LaserScan) / observations (LandmarkObservationArray) / odom (Odometry)
//     -> InputSequencer -> SlamPipeline (extract -> associate -> EKF update)
//     -> ~pose, ~path, ~landmarks (markers), ~map, ~associations, tf map -> odom
//
// Parameters, topics and services: docs/node.md.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <std_srvs/Empty.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <Eigen/Core>

#include "ekf_slam/LandmarkObservationArray.h"
#include "ekf_slam/LoadMap.h"
#include "ekf_slam/SaveMap.h"
#include "ekf_slam/core/input_sequencer.h"
#include "ekf_slam/core/slam_pipeline.h"
#include "ekf_slam/ros/associator_loader.h"
#include "ekf_slam/ros/markers.h"

namespace ekf_slam {

/// The node's own settings (the pipeline's are PipelineConfig, the associator's its own).
struct NodeConfig {
  std::string associator = AssociatorLoader::kDefault;
  std::string map_frame = "map";
  std::string odom_frame = "odom";
  std::string base_frame = "base_link";
  bool publish_tf = true;            ///< map -> odom (or map -> base_frame, see below)
  bool publish_map_to_base = false;  ///< no odom frame: publish map -> base_frame instead
  bool publish_odom_tf = false;      ///< broadcast odom -> base_frame from each odometry message
  double transform_tolerance = 0.1;  ///< map -> odom is stamped this much after the scan [s]
  double visualization_rate = 5.0;   ///< ~landmarks and ~path, wall-clock Hz; 0: every scan
  double input_timeout = 1.0;        ///< wall seconds without input before pending ones flush
  int queue_size = 1000;             ///< subscriber queues (roscpp drops silently on overflow)
  std::string map_file;              ///< default path of ~save_map / ~load_map
  MarkerStyle markers;
};

class EkfSlamNode {
 public:
  /// Reads the parameters, loads the associator and connects. Throws UnknownAssociatorError
  /// (listing the available names), ParameterError or std::runtime_error.
  EkfSlamNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~EkfSlamNode();

  const SlamPipeline& pipeline() const { return *pipeline_; }
  /// One line of counters (inputs received, processed, skipped, late, ...).
  std::string summary() const;

 private:
  /// The scan payload of the sequencer: a laser scan or a set of external observations.
  struct SensorInput {
    sensor_msgs::LaserScan::ConstPtr scan;
    LandmarkObservationArray::ConstPtr observations;
  };

  /// Every parameter, in one place.
  void readParameters();

  void odomCallback(const nav_msgs::Odometry::ConstPtr& msg);
  void scanCallback(const sensor_msgs::LaserScan::ConstPtr& msg);
  void observationsCallback(const LandmarkObservationArray::ConstPtr& msg);

  /// Common checks of a sensor message: stamp and the sensor's pose on base_link from tf.
  bool acceptSensor(const std_msgs::Header& header, const char* topic);
  void enqueue(double stamp, SensorInput input);
  void warnStatus(SequencerStatus status, double stamp, const char* what);
  /// Hands every released item to the pipeline.
  void drain();
  void process(const SensorInput& input, double stamp);
  void publish(const ScanReport& report);
  void publishTransform(const ros::Time& stamp);
  void publishVisualization();
  void onInputTimer(const ros::WallTimerEvent&);
  void onVisualizationTimer(const ros::WallTimerEvent&);
  void resetAll(const std::string& why);

  bool resetService(std_srvs::Empty::Request&, std_srvs::Empty::Response&);
  bool saveMapService(SaveMap::Request& req, SaveMap::Response& res);
  bool loadMapService(LoadMap::Request& req, LoadMap::Response& res);

  ros::NodeHandle nh_, pnh_;
  NodeConfig config_;
  PipelineConfig pipeline_config_;

  AssociatorLoader loader_;
  std::shared_ptr<DataAssociation> associator_;
  std::unique_ptr<SlamPipeline> pipeline_;
  std::unique_ptr<InputSequencer<SensorInput>> sequencer_;
  LandmarkMarkers markers_;

  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  /// Sensor poses on base_link by frame id (looked up once per frame).
  std::unordered_map<std::string, Eigen::Vector3d> sensor_offsets_;
  std::string current_sensor_frame_;
  std::unordered_set<std::string> tf_waited_;  ///< frames whose first tf lookup has waited

  ros::Subscriber odom_sub_, scan_sub_, observations_sub_;
  ros::Publisher pose_pub_, path_pub_, markers_pub_, map_pub_, associations_pub_;
  ros::Publisher correction_pub_;  // ~odometry_correction (AEKF states), when configured
  ros::ServiceServer reset_srv_, save_srv_, load_srv_;
  ros::WallTimer input_timer_, visualization_timer_;

  nav_msgs::Path path_;
  bool visualization_dirty_ = false;
  ros::Time last_stamp_;  ///< stamp of the last processed scan
  /// Latest released odometry (for odom -> base_link at the scan stamp).
  bool have_odometry_ = false;
  OdometryInput last_odometry_;
  ros::WallTime last_input_;

  // Inputs that needed handling, reported with warnings and in the shutdown summary.
  std::uint64_t scans_received_ = 0;
  std::uint64_t scans_processed_ = 0;
  std::uint64_t skipped_no_tf_ = 0;
  std::uint64_t skipped_bad_stamp_ = 0;
  std::uint64_t upstream_gaps_ = 0;  ///< scans missing by header.seq (transport or upstream)
  std::uint32_t last_scan_seq_ = 0;
  bool have_scan_seq_ = false;
  std::uint64_t flushes_ = 0;
};

/// The whole node: construct, spin, report. Returns the process exit code (non-zero when the
/// node cannot start, e.g. an unknown associator). ros::init must have been called.
int runEkfSlamNode();

}  // namespace ekf_slam
