#include "ekf_slam/ros/ekf_slam_node.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <sstream>

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <std_msgs/Float64MultiArray.h>
#include <visualization_msgs/MarkerArray.h>

#include "ekf_slam/AssociationStats.h"
#include "ekf_slam/LandmarkArray.h"
#include "ekf_slam/core/angles.h"
#include "ekf_slam/core/parameters.h"
#include "ekf_slam/core/pipeline_config.h"
#include "ekf_slam/ros/conversions.h"
#include "ekf_slam/ros/ros_parameter_source.h"

namespace ekf_slam {

namespace {

// Planar rigid transforms (x, y, yaw): a * b and a^-1.
Eigen::Vector3d compose(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double c = std::cos(a.z()), s = std::sin(a.z());
  return Eigen::Vector3d(a.x() + c * b.x() - s * b.y(), a.y() + s * b.x() + c * b.y(),
                         std::atan2(std::sin(a.z() + b.z()), std::cos(a.z() + b.z())));
}

Eigen::Vector3d inverse(const Eigen::Vector3d& a) {
  const double c = std::cos(a.z()), s = std::sin(a.z());
  return Eigen::Vector3d(-c * a.x() - s * a.y(), s * a.x() - c * a.y(), -a.z());
}

// Pose of a unicycle moving with twist (v, w) for dt from `pose` (exact arc).
Eigen::Vector3d extrapolate(const Eigen::Vector3d& pose, const Eigen::Vector2d& twist, double dt) {
  const double v = twist.x(), w = twist.y(), th = pose.z();
  if (std::abs(w * dt) < 1e-9) {
    return Eigen::Vector3d(pose.x() + v * dt * std::cos(th), pose.y() + v * dt * std::sin(th), th);
  }
  const double th2 = th + w * dt;
  return Eigen::Vector3d(pose.x() + v / w * (std::sin(th2) - std::sin(th)),
                         pose.y() - v / w * (std::cos(th2) - std::cos(th)),
                         std::atan2(std::sin(th2), std::cos(th2)));
}

geometry_msgs::TransformStamped toTransformMsg(const Eigen::Vector3d& t, const std::string& parent,
                                               const std::string& child, const ros::Time& stamp) {
  geometry_msgs::TransformStamped msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = parent;
  msg.child_frame_id = child;
  msg.transform.translation.x = t.x();
  msg.transform.translation.y = t.y();
  msg.transform.translation.z = 0.0;
  msg.transform.rotation.z = std::sin(0.5 * t.z());
  msg.transform.rotation.w = std::cos(0.5 * t.z());
  return msg;
}

// "ekf_slam/DJNN" -> "DJNN": the associator's parameter namespace.
std::string shortName(const std::string& lookup_name) {
  const std::size_t slash = lookup_name.rfind('/');
  return slash == std::string::npos ? lookup_name : lookup_name.substr(slash + 1);
}

// How long the first message of a sensor frame waits for its transform [wall s].
constexpr double kFirstTfWait = 1.0;

}  // namespace

EkfSlamNode::EkfSlamNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), tf_listener_(tf_buffer_) {
  readParameters();

  // Scan -> observations -> association -> EKF update: the pipeline owns the whole flow.
  pipeline_ = std::make_unique<SlamPipeline>(pipeline_config_, associator_);
  InputSequencerConfig seq;
  seq.max_latency = pipeline_config_.max_latency;
  seq.time_jump_threshold = pipeline_config_.time_jump_threshold;
  sequencer_ = std::make_unique<InputSequencer<SensorInput>>(seq);
  markers_ = LandmarkMarkers(config_.markers);

  pose_pub_ = pnh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 10);
  path_pub_ = pnh_.advertise<nav_msgs::Path>("path", 1, true);
  markers_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("landmarks", 1, true);
  map_pub_ = pnh_.advertise<LandmarkArray>("map", 1, true);
  associations_pub_ = pnh_.advertise<AssociationStats>("associations", 100);
  correction_pub_ = pnh_.advertise<std_msgs::Float64MultiArray>("odometry_correction", 10);

  reset_srv_ = pnh_.advertiseService("reset", &EkfSlamNode::resetService, this);
  save_srv_ = pnh_.advertiseService("save_map", &EkfSlamNode::saveMapService, this);
  load_srv_ = pnh_.advertiseService("load_map", &EkfSlamNode::loadMapService, this);

  // Large queues: roscpp drops on overflow without telling anyone, and a scan that takes long
  // must not cost the odometry in between.
  const auto hints = ros::TransportHints().tcpNoDelay();
  odom_sub_ = nh_.subscribe("odom", config_.queue_size, &EkfSlamNode::odomCallback, this, hints);
  scan_sub_ = nh_.subscribe("scan", config_.queue_size, &EkfSlamNode::scanCallback, this, hints);
  observations_sub_ = nh_.subscribe("observations", config_.queue_size,
                                    &EkfSlamNode::observationsCallback, this, hints);

  last_input_ = ros::WallTime::now();
  const double check = std::min(0.25, 0.5 * config_.input_timeout);
  input_timer_ = nh_.createWallTimer(ros::WallDuration(check), &EkfSlamNode::onInputTimer, this);
  if (config_.visualization_rate > 0.0) {
    visualization_timer_ = nh_.createWallTimer(ros::WallDuration(1.0 / config_.visualization_rate),
                                               &EkfSlamNode::onVisualizationTimer, this);
  }
  path_.header.frame_id = config_.map_frame;

  ROS_INFO("ekf_slam: associator %s, odometry_mode %s, frames %s -> %s -> %s%s",
           config_.associator.c_str(), pipeline_config_.odometry_mode.c_str(),
           config_.map_frame.c_str(), config_.odom_frame.c_str(), config_.base_frame.c_str(),
           config_.publish_map_to_base ? " (publishing map -> base)" : "");
}

EkfSlamNode::~EkfSlamNode() = default;

void EkfSlamNode::readParameters() {
  const RosParameterSource source(pnh_);
  const ParameterReader p(source);
  config_.associator =
      AssociatorLoader::lookupName(p.text("associator", AssociatorLoader::kDefault));
  config_.map_frame = p.text("map_frame", config_.map_frame);
  config_.odom_frame = p.text("odom_frame", config_.odom_frame);
  config_.base_frame = p.text("base_frame", config_.base_frame);
  config_.publish_tf = p.flag("publish_tf", config_.publish_tf);
  config_.publish_map_to_base = p.flag("publish_map_to_base", config_.publish_map_to_base);
  config_.publish_odom_tf = p.flag("publish_odom_tf", config_.publish_odom_tf);
  config_.transform_tolerance = p.nonNegative("transform_tolerance", config_.transform_tolerance);
  config_.visualization_rate = p.nonNegative("visualization_rate", config_.visualization_rate);
  config_.input_timeout = p.positive("input_timeout", config_.input_timeout);
  config_.queue_size = p.integer("queue_size", config_.queue_size, 1, 1000000);
  config_.map_file = p.text("map_file", config_.map_file);
  config_.markers.default_diameter =
      p.positive("marker_default_diameter", config_.markers.default_diameter);
  config_.markers.height = p.positive("marker_height", config_.markers.height);
  config_.markers.show_ids = p.flag("marker_show_ids", config_.markers.show_ids);
  config_.markers.show_ellipses = p.flag("marker_show_covariance", config_.markers.show_ellipses);
  for (const std::string* frame : {&config_.map_frame, &config_.odom_frame, &config_.base_frame}) {
    if (frame->empty()) p.fail("frames", "frame names must not be empty");
  }

  // The pipeline's parameters (docs/parameters.md), the same names as the offline runner's YAML.
  pipeline_config_ = readPipelineConfig(source);

  // The associator reads its own namespace, e.g. ~DJNN/individual_probability.
  associator_ =
      loader_.create(config_.associator, RosParameterSource(pnh_, shortName(config_.associator)));
}

// --- inputs ---------------------------------------------------------------------------------

void EkfSlamNode::odomCallback(const nav_msgs::Odometry::ConstPtr& msg) {
  last_input_ = ros::WallTime::now();
  if (msg->header.stamp.isZero()) {
    ++skipped_bad_stamp_;
    ROS_WARN_THROTTLE(5.0, "ekf_slam: odometry with a zero stamp skipped (%lu inputs so far)",
                      static_cast<unsigned long>(skipped_bad_stamp_));
    return;
  }
  const OdometryInput odom = toOdometryInput(*msg);
  if (config_.publish_odom_tf && odom.pose.allFinite()) {
    tf_broadcaster_.sendTransform(
        toTransformMsg(odom.pose, config_.odom_frame, config_.base_frame, msg->header.stamp));
  }
  warnStatus(sequencer_->addOdometry(odom), odom.stamp, "odometry");
  drain();
}

void EkfSlamNode::scanCallback(const sensor_msgs::LaserScan::ConstPtr& msg) {
  last_input_ = ros::WallTime::now();
  ++scans_received_;
  // header.seq counts the publisher's messages: a gap means scans lost on the way (queue
  // overflow in transport, or upstream), which roscpp would not report.
  if (have_scan_seq_ && msg->header.seq > last_scan_seq_ + 1 &&
      msg->header.seq - last_scan_seq_ < 1000000u) {
    upstream_gaps_ += msg->header.seq - last_scan_seq_ - 1;
    ROS_WARN_THROTTLE(5.0, "ekf_slam: %lu scans missing so far (header.seq gaps)",
                      static_cast<unsigned long>(upstream_gaps_));
  }
  have_scan_seq_ = msg->header.seq != 0;
  last_scan_seq_ = msg->header.seq;
  if (!acceptSensor(msg->header, "scan")) return;
  SensorInput in;
  in.scan = msg;
  enqueue(msg->header.stamp.toSec(), std::move(in));
}

void EkfSlamNode::observationsCallback(const LandmarkObservationArray::ConstPtr& msg) {
  last_input_ = ros::WallTime::now();
  ++scans_received_;
  if (!acceptSensor(msg->header, "observations")) return;
  SensorInput in;
  in.observations = msg;
  enqueue(msg->header.stamp.toSec(), std::move(in));
}

bool EkfSlamNode::acceptSensor(const std_msgs::Header& header, const char* topic) {
  if (header.stamp.isZero()) {
    // A zero stamp would read as a jump back in time and reset the map.
    ++skipped_bad_stamp_;
    ROS_WARN_THROTTLE(5.0, "ekf_slam: %s message with a zero stamp skipped (%lu inputs so far)",
                      topic, static_cast<unsigned long>(skipped_bad_stamp_));
    return false;
  }
  if (sensor_offsets_.count(header.frame_id)) return true;
  // First message of this frame: the sensor's mounting on base_link (assumed rigid).
  if (header.frame_id == config_.base_frame) {
    sensor_offsets_[header.frame_id] = Eigen::Vector3d::Zero();
    return true;
  }
  // The first message of a frame often races the latched /tf_static (both are published at
  // start): give the listener's own thread a moment, once per frame, on the wall clock (sim
  // time may be paused).
  if (tf_waited_.insert(header.frame_id).second) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(kFirstTfWait);
    while (ros::WallTime::now() < deadline &&
           !tf_buffer_.canTransform(config_.base_frame, header.frame_id, ros::Time(0))) {
      ros::WallDuration(0.005).sleep();
    }
  }
  try {
    const geometry_msgs::TransformStamped t =
        tf_buffer_.lookupTransform(config_.base_frame, header.frame_id, ros::Time(0));
    const Eigen::Vector3d offset = toPose2(t.transform);
    if (!offset.allFinite()) throw tf2::TransformException("non-finite transform");
    sensor_offsets_[header.frame_id] = offset;
    ROS_INFO("ekf_slam: sensor frame %s at (%.3f, %.3f, %.3f rad) on %s", header.frame_id.c_str(),
             offset.x(), offset.y(), offset.z(), config_.base_frame.c_str());
    return true;
  } catch (const tf2::TransformException& e) {
    ++skipped_no_tf_;
    ROS_WARN_THROTTLE(2.0, "ekf_slam: no transform %s -> %s yet (%s); %lu %s messages skipped",
                      config_.base_frame.c_str(), header.frame_id.c_str(), e.what(),
                      static_cast<unsigned long>(skipped_no_tf_), topic);
    return false;
  }
}

void EkfSlamNode::enqueue(double stamp, SensorInput input) {
  warnStatus(sequencer_->addScan(stamp, std::move(input)), stamp, "scan");
  drain();
}

void EkfSlamNode::warnStatus(SequencerStatus status, double stamp, const char* what) {
  const SequencerCounters& c = sequencer_->counters();
  switch (status) {
    case SequencerStatus::kQueued:
      break;
    case SequencerStatus::kLate:
      ROS_WARN_THROTTLE(5.0,
                        "ekf_slam: late %s (stamp %.3f, already past %.3f): handled out of order "
                        "(late so far: %lu odometry, %lu scans)",
                        what, stamp, sequencer_->core().lastReleasedStamp(),
                        static_cast<unsigned long>(c.late_odometry),
                        static_cast<unsigned long>(c.late_scans));
      break;
    case SequencerStatus::kTimeJump:
      ROS_WARN("ekf_slam: time jumped backwards (%s stamp %.3f): resetting (bag restarted?)", what,
               stamp);
      break;
    case SequencerStatus::kInvalidStamp:
      ROS_WARN_THROTTLE(5.0, "ekf_slam: %s with a non-finite stamp dropped (%lu so far)", what,
                        static_cast<unsigned long>(c.invalid_stamps));
      break;
  }
}

void EkfSlamNode::drain() {
  InputSequencer<SensorInput>::Item item;
  while (sequencer_->next(&item)) {
    switch (item.kind) {
      case SequencerCore::Kind::kOdometry:
        if (pipeline_->addOdometry(item.odometry)) {
          have_odometry_ = true;
          last_odometry_ = item.odometry;
        }
        break;
      case SequencerCore::Kind::kScan:
        process(item.scan, item.stamp);
        break;
      case SequencerCore::Kind::kTimeJump:
        resetAll("time jumped backwards");
        break;
    }
  }
}

void EkfSlamNode::process(const SensorInput& input, double stamp) {
  const std::string& frame =
      input.scan ? input.scan->header.frame_id : input.observations->header.frame_id;
  if (frame != current_sensor_frame_) {
    pipeline_->setSensorOffset(sensor_offsets_.at(frame));
    current_sensor_frame_ = frame;
  }
  const std::uint64_t invalid_before = pipeline_->counters().invalid_ranges;
  const std::uint64_t empty_before = pipeline_->counters().empty_scans;
  ScanReport report;
  try {
    if (input.scan) {
      const sensor_msgs::LaserScan& s = *input.scan;
      report = pipeline_->processScan(stamp, s.ranges, s.angle_min, s.angle_increment);
    } else {
      report = pipeline_->processObservations(stamp, toObservations(*input.observations));
    }
  } catch (const std::exception& e) {
    // The pipeline guards its state; whatever went wrong, this input is lost, not the node.
    ROS_ERROR_THROTTLE(5.0, "ekf_slam: input at %.3f failed: %s", stamp, e.what());
    return;
  }
  ++scans_processed_;
  const PipelineCounters& c = pipeline_->counters();
  if (c.invalid_ranges > invalid_before) {
    ROS_WARN_THROTTLE(10.0, "ekf_slam: scans contain NaN or negative ranges (%lu beams so far)",
                      static_cast<unsigned long>(c.invalid_ranges));
  }
  if (c.empty_scans > empty_before) {
    ROS_WARN_THROTTLE(5.0,
                      "ekf_slam: scan without beams or with non-finite angles: used for "
                      "prediction only (%lu so far)",
                      static_cast<unsigned long>(c.empty_scans));
  }
  if (report.invalid_observations > 0) {
    ROS_WARN_THROTTLE(5.0, "ekf_slam: %lu non-finite observations dropped so far",
                      static_cast<unsigned long>(c.invalid_observations));
  }
  if (!report.update_ok) {
    ROS_WARN_THROTTLE(5.0, "ekf_slam: EKF rejected a batch update (%lu so far)",
                      static_cast<unsigned long>(c.rejected_updates));
  }
  if (report.late) {
    ROS_WARN_THROTTLE(5.0, "ekf_slam: scan at %.3f older than the filter: used at %.3f (%lu)",
                      stamp, pipeline_->time(), static_cast<unsigned long>(c.late_scans));
  }
  publish(report);
}

// --- outputs --------------------------------------------------------------------------------

void EkfSlamNode::publish(const ScanReport& report) {
  // Outputs are stamped at the time the filter is at (the scan's, unless it came late).
  const double t = std::isfinite(pipeline_->time()) ? pipeline_->time() : report.stamp;
  const ros::Time stamp(t);
  last_stamp_ = stamp;
  const Eigen::Vector3d pose = pipeline_->pose();
  const Eigen::Matrix3d P = pipeline_->poseCovariance();

  geometry_msgs::PoseStamped ps;
  ps.header.frame_id = config_.map_frame;
  ps.header.stamp = stamp;
  ps.pose = toPoseMsg(pose);
  path_.header.stamp = stamp;
  path_.poses.push_back(ps);

  if (pose_pub_.getNumSubscribers() > 0) {
    geometry_msgs::PoseWithCovarianceStamped msg;
    msg.header = ps.header;
    msg.pose.pose = ps.pose;
    msg.pose.covariance = toCovarianceMsg(P);
    pose_pub_.publish(msg);
  }
  if (associations_pub_.getNumSubscribers() > 0) {
    associations_pub_.publish(toAssociationStats(
        report, config_.associator, pipeline_->ekf().numLandmarks(), config_.map_frame, stamp));
  }
  if (map_pub_.getNumSubscribers() > 0) {
    map_pub_.publish(toLandmarkArray(*pipeline_, config_.map_frame, stamp));
  }
  const std::vector<std::string> names = pipeline_->odometryCorrection().names();
  if (!names.empty() && correction_pub_.getNumSubscribers() > 0) {
    // Odometry correction states (AEKF): [estimates..., std devs...]; the layout names them.
    std_msgs::Float64MultiArray msg;
    msg.layout.dim.resize(2);
    msg.layout.dim[0].label = "estimate,sd";
    msg.layout.dim[0].size = 2;
    msg.layout.dim[0].stride = 2 * names.size();
    msg.layout.dim[1].size = names.size();
    msg.layout.dim[1].stride = names.size();
    for (const std::string& n : names)
      msg.layout.dim[1].label += (msg.layout.dim[1].label.empty() ? "" : ",") + n;
    const EkfSlam& ekf = pipeline_->ekf();
    const Eigen::Vector2d sd = ekf.correctionCovariance().diagonal().cwiseSqrt();
    for (std::size_t i = 0; i < names.size(); ++i) msg.data.push_back(ekf.correction()(i));
    for (std::size_t i = 0; i < names.size(); ++i) msg.data.push_back(sd(i));
    correction_pub_.publish(msg);
  }
  if (config_.publish_tf) publishTransform(stamp);

  visualization_dirty_ = true;
  if (config_.visualization_rate <= 0.0) publishVisualization();
}

void EkfSlamNode::publishTransform(const ros::Time& stamp) {
  const Eigen::Vector3d map_base = pipeline_->pose();
  const ros::Time tf_stamp = stamp + ros::Duration(config_.transform_tolerance);
  if (config_.publish_map_to_base) {
    tf_broadcaster_.sendTransform(
        toTransformMsg(map_base, config_.map_frame, config_.base_frame, tf_stamp));
    return;
  }
  if (!have_odometry_) {
    ROS_WARN_THROTTLE(10.0, "ekf_slam: no odometry yet: %s -> %s not published",
                      config_.map_frame.c_str(), config_.odom_frame.c_str());
    return;
  }
  // REP-105: map -> odom = (map -> base) * (odom -> base)^-1, both at the scan stamp; the odometry
  // pose is carried from its last message to the stamp with that message's twist.
  const double dt = stamp.toSec() - last_odometry_.stamp;
  const Eigen::Vector3d odom_base =
      dt > 0.0 ? extrapolate(last_odometry_.pose, last_odometry_.twist, dt) : last_odometry_.pose;
  const Eigen::Vector3d map_odom = compose(map_base, inverse(odom_base));
  if (!map_odom.allFinite()) return;
  tf_broadcaster_.sendTransform(
      toTransformMsg(map_odom, config_.map_frame, config_.odom_frame, tf_stamp));
}

void EkfSlamNode::publishVisualization() {
  if (!visualization_dirty_) return;
  visualization_dirty_ = false;
  if (path_pub_.getNumSubscribers() > 0) path_pub_.publish(path_);
  if (markers_pub_.getNumSubscribers() > 0) {
    markers_pub_.publish(markers_.build(*pipeline_, config_.map_frame, last_stamp_));
  }
}

void EkfSlamNode::onVisualizationTimer(const ros::WallTimerEvent&) { publishVisualization(); }

void EkfSlamNode::onInputTimer(const ros::WallTimerEvent&) {
  // Inputs stopped (end of a bag, a dead driver): what waits for odometry is used now.
  if (sequencer_->pending() == 0) return;
  if ((ros::WallTime::now() - last_input_).toSec() < config_.input_timeout) return;
  ++flushes_;
  ROS_INFO("ekf_slam: no input for %.1f s: processing %zu pending messages", config_.input_timeout,
           sequencer_->pending());
  sequencer_->flush();
  drain();
}

void EkfSlamNode::resetAll(const std::string& why) {
  ROS_WARN("ekf_slam: reset (%s)", why.c_str());
  pipeline_->reset();
  path_.poses.clear();
  markers_.reset();
  have_odometry_ = false;
  tf_buffer_.clear();
  visualization_dirty_ = true;
  publishVisualization();
}

// --- services -------------------------------------------------------------------------------

bool EkfSlamNode::resetService(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  // Inputs already queued belong to the old run.
  const std::size_t dropped = sequencer_->pending();
  sequencer_->clear();
  resetAll("~reset called; " + std::to_string(dropped) + " queued inputs discarded");
  return true;
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
    pipeline_->loadMap(path, req.reset_pose);
    res.success = true;
    res.message =
        "loaded " + std::to_string(pipeline_->ekf().numLandmarks()) + " landmarks from " + path;
    ROS_INFO("ekf_slam: %s", res.message.c_str());
    markers_.reset();
    if (map_pub_.getNumSubscribers() > 0) {
      map_pub_.publish(toLandmarkArray(*pipeline_, config_.map_frame, last_stamp_));
    }
    visualization_dirty_ = true;
    publishVisualization();
  } catch (const std::exception& e) {
    res.success = false;
    res.message = e.what();
    ROS_ERROR("ekf_slam: load_map: %s", e.what());
  }
  return true;
}

std::string EkfSlamNode::summary() const {
  const PipelineCounters& c = pipeline_->counters();
  const SequencerCounters& s = sequencer_->counters();
  std::ostringstream out;
  out << "scans received " << scans_received_ << ", processed " << scans_processed_
      << ", missing upstream (seq gaps) " << upstream_gaps_ << ", skipped without tf "
      << skipped_no_tf_ << ", zero stamps " << skipped_bad_stamp_ << "; odometry " << c.odometry
      << "; late odometry " << s.late_odometry << ", late scans " << s.late_scans << ", time jumps "
      << s.time_jumps << ", released by latency " << s.released_by_latency
      << ", input-timeout flushes " << flushes_ << "; empty scans " << c.empty_scans
      << ", rejected updates " << c.rejected_updates << "; landmarks "
      << pipeline_->ekf().numLandmarks();
  return out.str();
}

int runEkfSlamNode() {
  // Handles that outlive a failed construction: when the last NodeHandle goes, roscpp shuts
  // down and takes rosconsole with it, and the fatal message below would vanish.
  ros::NodeHandle nh, pnh("~");
  std::unique_ptr<EkfSlamNode> node;
  try {
    node = std::make_unique<EkfSlamNode>(nh, pnh);
  } catch (const std::exception& e) {
    // Unknown associator names come with the list of available ones.
    ROS_FATAL("ekf_slam: cannot start: %s", e.what());
    return 1;
  }
  ros::spin();
  // rosconsole is gone once roscpp has shut down (Ctrl-C): plain stderr for the last words.
  std::fprintf(stderr, "ekf_slam: %s\n", node->summary().c_str());
  return 0;
}

}  // namespace ekf_slam
