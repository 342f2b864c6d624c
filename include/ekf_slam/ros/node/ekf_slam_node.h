// The ekf_slam node: a thin ROS shell around SlamPipeline. It reads every parameter in one place
// (readParameters), puts the inputs in stamp order with InputSequencer, hands them to the
// pipeline and publishes the results:
//
//   scan (LaserScan) / observations (LandmarkObservationArray) / odom (Odometry)
//     -> (receiving thread) inbox -> (processing thread) InputSequencer
//     -> SlamPipeline (extract -> associate -> EKF update)
//     -> ~pose, ~path, ~landmarks (markers), ~map, ~associations, tf map -> odom, /diagnostics
//
// Parameters, topics and services: docs/node.md.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <std_srvs/Empty.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <Eigen/Core>

#include "ekf_slam/LandmarkObservationArray.h"
#include "ekf_slam/LoadMap.h"
#include "ekf_slam/SaveMap.h"
#include "ekf_slam/app/node_config.h"
#include "ekf_slam/app/pipeline_builder.h"
#include "ekf_slam/core/pipeline/input_sequencer.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/ros/node/markers.h"
#include "ekf_slam/ros/plugin_loader.h"

namespace ekf_slam {

class EkfSlamNode {
 public:
  /// Reads the parameters, loads the associator and connects. Throws UnknownAssociatorError
  /// (listing the available names), ParameterError or std::runtime_error.
  EkfSlamNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~EkfSlamNode();

  /// Processes inputs until ROS shuts down. Messages are received on a thread of their own
  /// (a slow scan never stalls the reception of odometry); the caller's thread processes them
  /// in arrival order and serves the timers and services.
  void spin();

  const SlamPipeline& pipeline() const { return *pipeline_; }
  /// One line of counters (inputs received, processed, skipped, late, ...).
  std::string summary() const;

 private:
  /// The scan payload of the sequencer: a laser scan or a set of external observations.
  struct SensorInput {
    sensor_msgs::LaserScan::ConstPtr scan;
    LandmarkObservationArray::ConstPtr observations;
    ros::WallTime received;  ///< for the processing latency
  };
  /// A message as received, waiting for the processing thread.
  struct Inbound {
    nav_msgs::Odometry::ConstPtr odom;
    sensor_msgs::LaserScan::ConstPtr scan;
    LandmarkObservationArray::ConstPtr observations;
    ros::WallTime received;
  };
  /// Messages missing by header.seq, per input (transport drops or upstream losses).
  struct SeqGaps {
    std::uint64_t missing = 0;
    /// header.seq of the first message ever received: that many were published before this
    /// node received any (it started late, or a fast publisher such as `rosbag play -r 100`
    /// without -d sent them before the subscription was connected).
    std::uint64_t before_first = 0;
    std::uint32_t last = 0;
    bool have = false;
    bool seen = false;
    /// Returns the number of messages missing before this one.
    std::uint64_t check(std::uint32_t seq);
  };
  /// Input rates over the last diagnostics period.
  struct RateWindow {
    std::uint64_t count = 0, at_last_report = 0;
  };

  /// Every parameter, in one place.
  void readParameters();

  // Receiving thread: queue the message, nothing else.
  void receive(Inbound in);
  // Processing thread.
  void handle(const Inbound& in);
  void handleOdometry(const nav_msgs::Odometry::ConstPtr& msg);
  void handleScan(const sensor_msgs::LaserScan::ConstPtr& msg, ros::WallTime received);
  void handleObservations(const LandmarkObservationArray::ConstPtr& msg, ros::WallTime received);

  /// Common checks of a sensor message: stamp and the sensor's pose on base_link from tf.
  bool acceptSensor(const std_msgs::Header& header, const char* topic);
  void enqueue(double stamp, SensorInput input);
  void warnStatus(SequencerStatus status, double stamp, const char* what);
  /// Hands every released item to the pipeline.
  void drain();
  void process(const SensorInput& input, double stamp);
  /// Warns about odometry the pipeline just rejected (non-finite, implausible, no orientation).
  void warnRejectedOdometry();
  void publish(const ScanReport& report);
  /// map -> odom from the pose at the last scan and odom -> base_frame at its stamp.
  void updateMapToOdom();
  void sendMapTransform(const ros::Time& stamp);
  /// The latched outputs (~map, ~landmarks, ~path): always the current state, subscribers or not.
  void publishMapOutputs();
  void onInputTimer(const ros::WallTimerEvent&);
  void onVisualizationTimer(const ros::WallTimerEvent&);
  void onTransformTimer(const ros::WallTimerEvent&);
  void holdOdomTransform(const ros::Time& stamp);
  void onDiagnosticsTimer(const ros::WallTimerEvent&);
  void resetAll(const std::string& why);

  bool resetService(std_srvs::Empty::Request&, std_srvs::Empty::Response&);
  bool saveMapService(SaveMap::Request& req, SaveMap::Response& res);
  bool loadMapService(LoadMap::Request& req, LoadMap::Response& res);
  bool relocaliseService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res);
  /// Logs what the recovery did at this scan (lost, relocalised).
  void reportRecovery(const ScanReport& report);

  ros::NodeHandle nh_, pnh_;
  NodeConfig config_;
  PipelineConfig pipeline_config_;

  PluginlibFactory plugins_;
  PipelineParts parts_;  ///< the configured plugins (app/pipeline_builder.h)
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

  // Reception: its own callback queue and thread; the inbox hands messages over.
  ros::CallbackQueue input_queue_;
  std::unique_ptr<ros::AsyncSpinner> input_spinner_;
  mutable std::mutex inbox_mutex_;
  std::condition_variable inbox_cv_;
  std::deque<Inbound> inbox_;
  std::uint64_t inbox_overflow_ = 0;  ///< guarded by inbox_mutex_
  std::size_t inbox_peak_ = 0;        ///< guarded by inbox_mutex_

  ros::Subscriber odom_sub_, scan_sub_, observations_sub_;
  ros::Publisher pose_pub_, path_pub_, markers_pub_, map_pub_, associations_pub_, diagnostics_pub_;
  ros::Publisher correction_pub_;  // ~odometry_correction (AEKF states), when configured
  ros::ServiceServer reset_srv_, save_srv_, load_srv_, relocalise_srv_;
  ros::WallTimer input_timer_, visualization_timer_, transform_timer_, diagnostics_timer_;

  nav_msgs::Path path_;
  bool visualization_dirty_ = false;
  ros::Time last_stamp_;  ///< stamp of the last processed scan
  /// Latest released odometry (for odom -> base_link at the scan stamp).
  bool have_odometry_ = false;
  OdometryInput last_odometry_;
  ros::WallTime last_input_;

  // map -> odom: the pose at the last scan waits for odom -> base_frame at its stamp.
  bool map_base_pending_ = false;
  ros::Time map_base_stamp_;
  Eigen::Vector3d map_base_ = Eigen::Vector3d::Zero();
  ros::WallTime map_base_since_;
  bool have_map_odom_ = false;
  Eigen::Vector3d map_odom_ = Eigen::Vector3d::Zero();
  ros::Time last_tf_stamp_;            ///< newest map transform sent (stamps must increase)
  std::uint32_t lost_since_scan_ = 0;  ///< the scan of the last lost event (for logs)
  // odom -> base_frame as last broadcast from an odometry message (publish_odom_tf), held after
  // the odometry stops with hold_odom_tf.
  bool have_odom_tf_ = false;
  Eigen::Vector3d odom_tf_pose_ = Eigen::Vector3d::Zero();
  ros::Time odom_tf_stamp_;  ///< of the last message, or the last held broadcast
  ros::WallTime odom_tf_received_;
  bool odom_tf_held_ = false;  ///< holding now (logged once per stop)

  // Inputs that needed handling, reported with warnings, on /diagnostics and at exit.
  std::uint64_t scans_received_ = 0;
  std::uint64_t scans_processed_ = 0;
  std::uint64_t odometry_received_ = 0;
  std::uint64_t skipped_no_tf_ = 0;
  std::uint64_t skipped_bad_stamp_ = 0;
  std::uint64_t odom_frame_mismatches_ = 0;
  std::uint64_t odom_tf_fallbacks_ = 0;  ///< map -> odom from the Odometry pose, tf missing
  SeqGaps scan_gaps_, odom_gaps_, observation_gaps_;
  RateWindow scan_rate_, odom_rate_;
  ros::WallTime last_diagnostics_;
  double latency_sum_ = 0.0, latency_max_ = 0.0;  ///< since the last diagnostics report [s]
  std::uint64_t latency_count_ = 0;
  std::uint64_t flushes_ = 0;
  std::uint64_t resets_ = 0;
  PipelineCounters warned_;  ///< counters at the last odometry warning
};

/// The whole node: construct, spin, report. Returns the process exit code (non-zero when the
/// node cannot start, e.g. an unknown associator). ros::init must have been called.
int runEkfSlamNode();

}  // namespace ekf_slam
