#include "ekf_slam/ros/node/ekf_slam_node.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <sstream>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <std_msgs/Float64MultiArray.h>
#include <visualization_msgs/MarkerArray.h>

#include "ekf_slam/AssociationStats.h"
#include "ekf_slam/LandmarkArray.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/common/pose2d.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/ros/conversions.h"
#include "ekf_slam/ros/extractor_loader.h"  // toScanData
#include "ekf_slam/ros/ros_configuration.h"

namespace ekf_slam {

namespace {

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

// How long the first message of a sensor frame waits for its transform [wall s].
constexpr double kFirstTfWait = 1.0;
// How long map -> odom waits for odom -> base_frame at the scan stamp before it falls back to
// the Odometry message's pose [wall s].
constexpr double kOdomTfWait = 0.5;

}  // namespace

EkfSlamNode::EkfSlamNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), tf_listener_(tf_buffer_) {
  readParameters();

  // Scan -> observations -> association -> EKF update: the pipeline owns the whole flow.
  pipeline_ = makePipeline(parts_);
  if (parts_.extractor->needsIntensities() || parts_.scan_filter.needsIntensities()) {
    ROS_INFO(
        "ekf_slam: extractor %s%s needs the scans' intensity channel; a scan without one is "
        "an error",
        parts_.extractor->name().c_str(),
        parts_.scan_filter.needsIntensities() ? " (or a scan filter)" : "");
  }
  if (!config_.initial_map.empty()) {
    // Throws (the node does not start) when the file is bad or a relocaliser is missing.
    pipeline_->loadMap(config_.initial_map, true, config_.initial_map_unknown_pose);
    ROS_INFO("ekf_slam: loaded %zu landmarks from %s%s", pipeline_->ekf().numLandmarks(),
             config_.initial_map.c_str(),
             config_.initial_map_unknown_pose ? "; pose unknown: relocalising" : "");
  }
  InputSequencerConfig seq;
  seq.max_latency = pipeline_config_.max_latency;
  seq.time_jump_threshold = pipeline_config_.time_jump_threshold;
  sequencer_ = std::make_unique<InputSequencer<SensorInput>>(seq);
  markers_ = LandmarkMarkers(config_.markers);

  pose_pub_ = pnh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 10);
  diagnostics_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
  path_pub_ = pnh_.advertise<nav_msgs::Path>("path", 1, true);
  markers_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("landmarks", 1, true);
  map_pub_ = pnh_.advertise<LandmarkArray>("map", 1, true);
  associations_pub_ = pnh_.advertise<AssociationStats>("associations", 100);
  correction_pub_ = pnh_.advertise<std_msgs::Float64MultiArray>("odometry_correction", 10);

  reset_srv_ = pnh_.advertiseService("reset", &EkfSlamNode::resetService, this);
  save_srv_ = pnh_.advertiseService("save_map", &EkfSlamNode::saveMapService, this);
  load_srv_ = pnh_.advertiseService("load_map", &EkfSlamNode::loadMapService, this);
  relocalise_srv_ = pnh_.advertiseService("relocalise", &EkfSlamNode::relocaliseService, this);

  // Reception on its own thread and callback queue: roscpp drops on a full subscriber queue
  // without telling anyone, so its callbacks only hand the message over; processing (a scan can
  // take milliseconds) happens in spin(). header.seq gaps still reveal any loss upstream.
  const auto hints = ros::TransportHints().tcpNoDelay();
  ros::NodeHandle in_nh(nh_);
  in_nh.setCallbackQueue(&input_queue_);
  odom_sub_ = in_nh.subscribe<nav_msgs::Odometry>(
      "odom", config_.queue_size,
      [this](const nav_msgs::Odometry::ConstPtr& m) {
        receive(Inbound{m, nullptr, nullptr, ros::WallTime::now()});
      },
      ros::VoidConstPtr(), hints);
  scan_sub_ = in_nh.subscribe<sensor_msgs::LaserScan>(
      "scan", config_.queue_size,
      [this](const sensor_msgs::LaserScan::ConstPtr& m) {
        receive(Inbound{nullptr, m, nullptr, ros::WallTime::now()});
      },
      ros::VoidConstPtr(), hints);
  observations_sub_ = in_nh.subscribe<LandmarkObservationArray>(
      "observations", config_.queue_size,
      [this](const LandmarkObservationArray::ConstPtr& m) {
        receive(Inbound{nullptr, nullptr, m, ros::WallTime::now()});
      },
      ros::VoidConstPtr(), hints);
  input_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &input_queue_);
  input_spinner_->start();

  last_input_ = ros::WallTime::now();
  const double check = std::min(0.25, 0.5 * config_.input_timeout);
  input_timer_ = nh_.createWallTimer(ros::WallDuration(check), &EkfSlamNode::onInputTimer, this);
  if (config_.visualization_rate > 0.0) {
    visualization_timer_ = nh_.createWallTimer(ros::WallDuration(1.0 / config_.visualization_rate),
                                               &EkfSlamNode::onVisualizationTimer, this);
  }
  if (config_.publish_tf && config_.transform_publish_period > 0.0) {
    transform_timer_ = nh_.createWallTimer(ros::WallDuration(config_.transform_publish_period),
                                           &EkfSlamNode::onTransformTimer, this);
  }
  last_diagnostics_ = ros::WallTime::now();
  if (config_.diagnostics_period > 0.0) {
    diagnostics_timer_ = nh_.createWallTimer(ros::WallDuration(config_.diagnostics_period),
                                             &EkfSlamNode::onDiagnosticsTimer, this);
  }
  path_.header.frame_id = config_.map_frame;
  // Latched outputs hold the current state from the start: an empty map until the first scan.
  visualization_dirty_ = true;
  publishMapOutputs();

  ROS_INFO("ekf_slam: associator %s, odometry_mode %s, frames %s -> %s -> %s%s",
           parts_.associator_name.c_str(), pipeline_config_.odometry_mode.c_str(),
           config_.map_frame.c_str(), config_.odom_frame.c_str(), config_.base_frame.c_str(),
           config_.publish_map_to_base ? " (publishing map -> base)" : "");
}

EkfSlamNode::~EkfSlamNode() {
  if (input_spinner_) input_spinner_->stop();
}

void EkfSlamNode::readParameters() {
  // One builder for every entry point (app/pipeline_builder.h): ~ holds the node's and the
  // pipeline's parameters, ~<PLUGIN>/ each plugin's; a name nobody reads is an error.
  parts_ = buildPipeline(RosConfiguration(pnh_), plugins_);
  config_ = parts_.node;
  pipeline_config_ = parts_.config;
}

// --- inputs ---------------------------------------------------------------------------------

std::uint64_t EkfSlamNode::SeqGaps::check(std::uint32_t seq) {
  // seq 0 is what publishers that do not count leave; a huge step is a restarted publisher.
  std::uint64_t gap = 0;
  if (!seen && seq < 1000000u) before_first = seq;
  seen = true;
  if (have && seq > last + 1 && seq - last < 1000000u) gap = seq - last - 1;
  missing += gap;
  have = seq != 0;
  last = seq;
  return gap;
}

void EkfSlamNode::receive(Inbound in) {
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    if (inbox_.size() >= static_cast<std::size_t>(config_.queue_size)) {
      inbox_.pop_front();  // the oldest is the least useful; counted and warned about below
      ++inbox_overflow_;
    }
    inbox_.push_back(std::move(in));
    inbox_peak_ = std::max(inbox_peak_, inbox_.size());
  }
  inbox_cv_.notify_one();
}

void EkfSlamNode::spin() {
  ros::CallbackQueue* global = ros::getGlobalCallbackQueue();
  std::deque<Inbound> batch;
  std::uint64_t overflow_reported = 0;
  while (ros::ok()) {
    std::uint64_t overflow = 0;
    {
      std::unique_lock<std::mutex> lock(inbox_mutex_);
      inbox_cv_.wait_for(lock, std::chrono::milliseconds(5), [this] { return !inbox_.empty(); });
      batch.swap(inbox_);
      overflow = inbox_overflow_;
    }
    if (overflow > overflow_reported) {
      overflow_reported = overflow;
      ROS_WARN_THROTTLE(5.0,
                        "ekf_slam: processing cannot keep up: %lu messages dropped from the "
                        "inbox (queue_size %d)",
                        static_cast<unsigned long>(overflow), config_.queue_size);
    }
    for (const Inbound& in : batch) handle(in);
    batch.clear();
    global->callAvailable(ros::WallDuration(0));  // timers and services
  }
}

void EkfSlamNode::handle(const Inbound& in) {
  last_input_ = ros::WallTime::now();
  if (in.odom) handleOdometry(in.odom);
  if (in.scan) handleScan(in.scan, in.received);
  if (in.observations) handleObservations(in.observations, in.received);
}

void EkfSlamNode::handleOdometry(const nav_msgs::Odometry::ConstPtr& msg) {
  ++odometry_received_;
  ++odom_rate_.count;
  const bool first = !odom_gaps_.seen;
  if (const std::uint64_t gap = odom_gaps_.check(msg->header.seq)) {
    ROS_WARN_THROTTLE(5.0, "ekf_slam: %lu odometry messages missing (header.seq gaps; %lu so far)",
                      static_cast<unsigned long>(gap),
                      static_cast<unsigned long>(odom_gaps_.missing));
  }
  if (first && odom_gaps_.before_first > 0) {
    ROS_WARN(
        "ekf_slam: the first odometry message received has header.seq %lu: that many were "
        "published before (node started late, or the publisher did not wait for the "
        "subscription, e.g. rosbag play without -d)",
        static_cast<unsigned long>(odom_gaps_.before_first));
  }
  // The twist is taken as base_frame's motion and the pose as odom_frame -> base_frame: say so
  // when the message names other frames (empty names are accepted as "unspecified").
  const bool parent_ok = msg->header.frame_id.empty() || msg->header.frame_id == config_.odom_frame;
  const bool child_ok = msg->child_frame_id.empty() || msg->child_frame_id == config_.base_frame;
  if (!parent_ok || !child_ok) {
    if (odom_frame_mismatches_++ == 0) {
      ROS_WARN(
          "ekf_slam: odometry is %s -> %s, the node is configured for odom_frame %s -> "
          "base_frame %s: its twist is used as %s's (set odom_frame / base_frame to match)",
          msg->header.frame_id.c_str(), msg->child_frame_id.c_str(), config_.odom_frame.c_str(),
          config_.base_frame.c_str(), config_.base_frame.c_str());
    }
  }
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
    have_odom_tf_ = true;
    odom_tf_pose_ = odom.pose;
    odom_tf_stamp_ = msg->header.stamp;
    odom_tf_received_ = ros::WallTime::now();
    odom_tf_held_ = false;
  }
  warnStatus(sequencer_->addOdometry(odom), odom.stamp, "odometry");
  drain();
}

void EkfSlamNode::handleScan(const sensor_msgs::LaserScan::ConstPtr& msg, ros::WallTime received) {
  ++scans_received_;
  ++scan_rate_.count;
  // header.seq counts the publisher's messages: a gap means scans lost on the way (queue
  // overflow in transport, or upstream), which roscpp would not report.
  if (scan_gaps_.check(msg->header.seq) > 0) {
    ROS_WARN_THROTTLE(5.0, "ekf_slam: %lu scans missing so far (header.seq gaps)",
                      static_cast<unsigned long>(scan_gaps_.missing));
  }
  if (!acceptSensor(msg->header, "scan")) return;
  SensorInput in;
  in.scan = msg;
  in.received = received;
  enqueue(msg->header.stamp.toSec(), std::move(in));
}

void EkfSlamNode::handleObservations(const LandmarkObservationArray::ConstPtr& msg,
                                     ros::WallTime received) {
  ++scans_received_;
  ++scan_rate_.count;
  if (observation_gaps_.check(msg->header.seq) > 0) {
    ROS_WARN_THROTTLE(5.0, "ekf_slam: %lu observation messages missing so far (header.seq gaps)",
                      static_cast<unsigned long>(observation_gaps_.missing));
  }
  if (!acceptSensor(msg->header, "observations")) return;
  SensorInput in;
  in.observations = msg;
  in.received = received;
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
  // The first message of a frame often races the latched /tf_static (both are published at
  // start): give the listener's own thread a moment, once per frame, on the wall clock (sim
  // time may be paused).
  if (!header.frame_id.empty() && header.frame_id != config_.base_frame &&
      tf_waited_.insert(header.frame_id).second) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(kFirstTfWait);
    while (ros::WallTime::now() < deadline &&
           !tf_buffer_.canTransform(config_.base_frame, header.frame_id, ros::Time(0))) {
      ros::WallDuration(0.005).sleep();
    }
  }
  try {
    // The offline runner applies the same rule (conversions.h).
    const Eigen::Vector3d offset = sensorOffset(tf_buffer_, config_.base_frame, header.frame_id);
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
    case SequencerStatus::kHeld:
      // One stream disagrees with the other by more than time_jump_threshold: held until the
      // other confirms a restart (or a gap) or refutes it (then dropped and counted).
      ROS_WARN_THROTTLE(5.0,
                        "ekf_slam: %s stamped %.3f disagrees with the other input by more than "
                        "time_jump_threshold: held (%lu held, %lu dropped so far)",
                        what, stamp, static_cast<unsigned long>(c.held),
                        static_cast<unsigned long>(c.dropped_out_of_range));
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
        } else {
          warnRejectedOdometry();
        }
        break;
      case SequencerCore::Kind::kScan:
        process(item.scan, item.stamp);
        break;
      case SequencerCore::Kind::kTimeJump:
        resetAll("time jumped backwards in every input stream");
        break;
      case SequencerCore::Kind::kDropped:  // handled inside InputSequencer
        break;
    }
  }
}

void EkfSlamNode::warnRejectedOdometry() {
  const PipelineCounters& c = pipeline_->counters();
  if (c.implausible_odometry > warned_.implausible_odometry) {
    ROS_WARN_THROTTLE(5.0,
                      "ekf_slam: odometry twist beyond max_speed %.1f m/s or max_yaw_rate %.1f "
                      "rad/s rejected (%lu so far)",
                      pipeline_config_.max_speed, pipeline_config_.max_yaw_rate,
                      static_cast<unsigned long>(c.implausible_odometry));
  }
  if (c.invalid_orientations > warned_.invalid_orientations) {
    ROS_WARN_THROTTLE(5.0,
                      "ekf_slam: odometry without orientation (all-zero quaternion) rejected in "
                      "pose_delta mode (%lu so far)",
                      static_cast<unsigned long>(c.invalid_orientations));
  }
  if (c.rejected_odometry > warned_.rejected_odometry) {
    ROS_WARN_THROTTLE(5.0, "ekf_slam: non-finite odometry rejected (%lu so far)",
                      static_cast<unsigned long>(c.rejected_odometry));
  }
  warned_ = c;
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
      report = pipeline_->processScan(stamp, toScanData(*input.scan));
    } else {
      report = pipeline_->processObservations(stamp, toObservations(*input.observations));
    }
  } catch (const std::exception& e) {
    // The pipeline guards its state; whatever went wrong, this input is lost, not the node.
    ROS_ERROR_THROTTLE(5.0, "ekf_slam: input at %.3f failed: %s", stamp, e.what());
    return;
  }
  const PipelineCounters& c = pipeline_->counters();
  if (report.duplicate) {
    ROS_WARN_THROTTLE(5.0, "ekf_slam: scan at %.3f repeats the previous one: dropped (%lu so far)",
                      stamp, static_cast<unsigned long>(c.duplicate_scans));
    return;
  }
  ++scans_processed_;
  if (report.geometry_error) {
    ROS_WARN_THROTTLE(
        5.0, "ekf_slam: scan at %.3f rejected: %s; used for prediction only (%lu so far)", stamp,
        report.geometry_error, static_cast<unsigned long>(c.inconsistent_scans));
  }
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
  if (!report.association.notice.empty())
    ROS_WARN("ekf_slam: %s", report.association.notice.c_str());
  reportRecovery(report);
  const double latency = (ros::WallTime::now() - input.received).toSec();
  latency_sum_ += latency;
  latency_max_ = std::max(latency_max_, latency);
  ++latency_count_;
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
  // Relocalised: the scans processed while lost take the poses re-derived from the fix.
  applyLostPath(
      report.lost_path, path_.poses.size() - 1,
      [this](std::size_t i) { return path_.poses[i].header.stamp.toSec(); },
      [this](std::size_t i, const Eigen::Vector3d& p) { path_.poses[i].pose = toPoseMsg(p); });

  if (pose_pub_.getNumSubscribers() > 0) {
    geometry_msgs::PoseWithCovarianceStamped msg;
    msg.header = ps.header;
    msg.pose.pose = ps.pose;
    msg.pose.covariance = toCovarianceMsg(P);
    pose_pub_.publish(msg);
  }
  if (associations_pub_.getNumSubscribers() > 0) {
    associations_pub_.publish(toAssociationStats(report, parts_.associator_name,
                                                 pipeline_->activeEkf().numLandmarks(),
                                                 config_.map_frame, stamp));
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
    const EkfSlam& ekf = pipeline_->activeEkf();  // per scan: no cekf global update
    const Eigen::Vector2d sd = ekf.correctionCovariance().diagonal().cwiseSqrt();
    for (std::size_t i = 0; i < names.size(); ++i) msg.data.push_back(ekf.correction()(i));
    for (std::size_t i = 0; i < names.size(); ++i) msg.data.push_back(sd(i));
    correction_pub_.publish(msg);
  }

  if (config_.publish_tf && pipeline_->lost() && have_map_odom_ && !config_.publish_map_to_base) {
    // Lost: the estimate is dead reckoning from a pose in doubt. map -> odom stays where it was
    // (odom -> base carries the motion, as the filter's prediction does) until a fix moves it.
    map_base_pending_ = false;
  } else if (config_.publish_tf) {
    map_base_ = pose;
    map_base_stamp_ = stamp;
    map_base_since_ = ros::WallTime::now();
    map_base_pending_ = true;
    updateMapToOdom();
  }
  visualization_dirty_ = true;
  if (config_.visualization_rate <= 0.0) publishMapOutputs();
}

void EkfSlamNode::updateMapToOdom() {
  if (!map_base_pending_) return;
  const ros::Time tf_stamp = map_base_stamp_ + ros::Duration(config_.transform_tolerance);
  if (config_.publish_map_to_base) {
    map_base_pending_ = false;
    map_odom_ = map_base_;  // "odom" is base_frame here: the transform is map -> base_frame
    have_map_odom_ = true;
    sendMapTransform(tf_stamp);
    return;
  }
  // REP-105: map -> odom = (map -> base) * (odom -> base)^-1, both at the scan stamp. odom ->
  // base comes from tf, as whoever owns that transform publishes it (robot_localization, a
  // driver); from the Odometry message only when this node is that owner, or tf has nothing.
  Eigen::Vector3d odom_base;
  bool have = false;
  if (!config_.publish_odom_tf) {
    try {
      if (tf_buffer_.canTransform(config_.odom_frame, config_.base_frame, map_base_stamp_)) {
        odom_base = toPose2(
            tf_buffer_.lookupTransform(config_.odom_frame, config_.base_frame, map_base_stamp_)
                .transform);
        have = odom_base.allFinite();
      }
    } catch (const tf2::TransformException&) {
      have = false;
    }
    if (!have && (ros::WallTime::now() - map_base_since_).toSec() < kOdomTfWait) {
      return;  // tf at the scan stamp may still be on its way: the transform timer retries
    }
  }
  if (!have) {
    if (!have_odometry_) {
      ROS_WARN_THROTTLE(10.0, "ekf_slam: no odometry and no tf %s -> %s: %s -> %s not published",
                        config_.odom_frame.c_str(), config_.base_frame.c_str(),
                        config_.map_frame.c_str(), config_.odom_frame.c_str());
      return;
    }
    if (!config_.publish_odom_tf) {
      ++odom_tf_fallbacks_;
      ROS_WARN_THROTTLE(10.0,
                        "ekf_slam: no tf %s -> %s at the scan stamp: map -> odom from the "
                        "Odometry message's pose instead (%lu times)",
                        config_.odom_frame.c_str(), config_.base_frame.c_str(),
                        static_cast<unsigned long>(odom_tf_fallbacks_));
    }
    // The odometry pose of the last message, carried to the stamp with its twist.
    const double dt = map_base_stamp_.toSec() - last_odometry_.stamp;
    odom_base =
        dt > 0.0 ? extrapolate(last_odometry_.pose, last_odometry_.twist, dt) : last_odometry_.pose;
  }
  map_base_pending_ = false;
  const Eigen::Vector3d map_odom = composePose(map_base_, inversePose(odom_base));
  if (!map_odom.allFinite()) return;
  map_odom_ = map_odom;
  have_map_odom_ = true;
  sendMapTransform(tf_stamp);
}

void EkfSlamNode::sendMapTransform(const ros::Time& stamp) {
  // tf2 warns about repeated stamps and drops older ones: keep them strictly increasing.
  if (!have_map_odom_ || stamp <= last_tf_stamp_) return;
  last_tf_stamp_ = stamp;
  const std::string& child = config_.publish_map_to_base ? config_.base_frame : config_.odom_frame;
  tf_broadcaster_.sendTransform(toTransformMsg(map_odom_, config_.map_frame, child, stamp));
}

void EkfSlamNode::onTransformTimer(const ros::WallTimerEvent&) {
  updateMapToOdom();
  // Between scans the last map -> odom still holds (odom -> base carries the motion); stamped
  // ahead of now, as gmapping and slam_toolbox do, so lookups at now() succeed.
  const ros::Time now = ros::Time::now();
  if (now.isZero()) return;  // simulated time without /clock yet
  const ros::Time stamp = now + ros::Duration(config_.transform_tolerance);
  sendMapTransform(stamp);
  holdOdomTransform(stamp);
}

void EkfSlamNode::holdOdomTransform(const ros::Time& stamp) {
  // Only once the odometry has stopped: while it flows, a pose stamped ahead of it would be
  // interpolated against the next real one. A replay's end leaves a tf listener started later
  // with no odom -> base_frame at all (rviz: no vehicle frame to follow); this keeps it.
  if (!config_.publish_odom_tf || !config_.hold_odom_tf || !have_odom_tf_) return;
  if ((ros::WallTime::now() - odom_tf_received_).toSec() < config_.input_timeout) return;
  if (stamp <= odom_tf_stamp_) return;  // tf2 warns about repeated stamps
  if (!odom_tf_held_) {
    odom_tf_held_ = true;
    ROS_INFO("ekf_slam: no odometry for %.1f s: holding %s -> %s at its last pose (hold_odom_tf)",
             config_.input_timeout, config_.odom_frame.c_str(), config_.base_frame.c_str());
  }
  odom_tf_stamp_ = stamp;
  tf_broadcaster_.sendTransform(
      toTransformMsg(odom_tf_pose_, config_.odom_frame, config_.base_frame, stamp));
}

void EkfSlamNode::publishMapOutputs() {
  if (!visualization_dirty_) return;
  visualization_dirty_ = false;
  // Latched: a late subscriber (rviz started mid-run) gets today's map, not none. At the
  // visualisation rate, not per scan: the whole map is O(n) to copy, and with filter cekf reading
  // it forces the global update the compressed filter exists to defer.
  map_pub_.publish(toLandmarkArray(*pipeline_, config_.map_frame, last_stamp_));
  path_pub_.publish(path_);
  markers_pub_.publish(markers_.build(*pipeline_, config_.map_frame, last_stamp_));
}

void EkfSlamNode::onVisualizationTimer(const ros::WallTimerEvent&) { publishMapOutputs(); }

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
  ++resets_;
  pipeline_->reset();
  path_.poses.clear();
  markers_.reset();
  have_odometry_ = false;
  map_base_pending_ = false;
  have_map_odom_ = false;
  last_tf_stamp_ = ros::Time();
  tf_buffer_.clear();
  visualization_dirty_ = true;
  publishMapOutputs();
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
  node->spin();
  // rosconsole is gone once roscpp has shut down (Ctrl-C): plain stderr for the last words.
  std::fprintf(stderr, "ekf_slam: %s\n", node->summary().c_str());
  return 0;
}

}  // namespace ekf_slam
