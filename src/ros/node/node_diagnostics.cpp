// The node's /diagnostics (inputs: anything lost or skipped; processing: tracking or LOST, the
// map, the latency) and its one-line summary at exit.
#include <algorithm>
#include <mutex>
#include <sstream>
#include <string>

#include <diagnostic_msgs/DiagnosticArray.h>

#include "ekf_slam/ros/node/ekf_slam_node.h"

namespace ekf_slam {

namespace {

diagnostic_msgs::KeyValue keyValue(const std::string& key, const std::string& value) {
  diagnostic_msgs::KeyValue kv;
  kv.key = key;
  kv.value = value;
  return kv;
}

template <typename T>
diagnostic_msgs::KeyValue keyValue(const std::string& key, T value) {
  std::ostringstream os;
  os << value;
  return keyValue(key, os.str());
}

}  // namespace

void EkfSlamNode::onDiagnosticsTimer(const ros::WallTimerEvent&) {
  const ros::WallTime now = ros::WallTime::now();
  const double period = std::max(1e-3, (now - last_diagnostics_).toSec());
  last_diagnostics_ = now;
  std::uint64_t overflow = 0;
  std::size_t inbox = 0, peak = 0;
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    overflow = inbox_overflow_;
    inbox = inbox_.size();
    peak = inbox_peak_;
  }
  const PipelineCounters& c = pipeline_->counters();
  const SequencerCounters& q = sequencer_->counters();
  const auto rate = [period](RateWindow* w) {
    const double hz = static_cast<double>(w->count - w->at_last_report) / period;
    w->at_last_report = w->count;
    return hz;
  };

  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = ros::Time::now();
  const std::string hw = ros::this_node::getName();

  // Inputs: anything lost or skipped is a warning (a lost message changes the map).
  diagnostic_msgs::DiagnosticStatus in;
  in.name = hw + ": inputs";
  in.hardware_id = hw;
  const std::uint64_t lost =
      overflow + odom_gaps_.missing + scan_gaps_.missing + observation_gaps_.missing;
  const std::uint64_t skipped = skipped_no_tf_ + skipped_bad_stamp_ + q.invalid_stamps +
                                q.dropped_out_of_range + c.implausible_odometry +
                                c.invalid_orientations + c.inconsistent_scans + c.duplicate_scans;
  in.level = diagnostic_msgs::DiagnosticStatus::OK;
  in.message = "no input lost";
  if (lost > 0 || skipped > 0) {
    in.level = diagnostic_msgs::DiagnosticStatus::WARN;
    in.message = std::to_string(lost) + " messages lost, " + std::to_string(skipped) + " skipped";
  }
  in.values = {
      keyValue("odometry rate [Hz]", rate(&odom_rate_)),
      keyValue("scan rate [Hz]", rate(&scan_rate_)),
      keyValue("odometry received", odometry_received_),
      keyValue("scans received", scans_received_),
      keyValue("odometry missing (seq gaps)", odom_gaps_.missing),
      keyValue("scans missing (seq gaps)", scan_gaps_.missing),
      keyValue("observations missing (seq gaps)", observation_gaps_.missing),
      keyValue("odometry before the first received (seq)", odom_gaps_.before_first),
      keyValue("scans before the first received (seq)",
               scan_gaps_.before_first + observation_gaps_.before_first),
      keyValue("inbox overflow drops", overflow),
      keyValue("skipped without tf", skipped_no_tf_),
      keyValue("skipped zero stamps", skipped_bad_stamp_),
      keyValue("dropped non-finite stamps", q.invalid_stamps),
      keyValue("out-of-range stamps dropped (one stream jumped)", q.dropped_out_of_range),
      keyValue("late odometry (skipped)", c.late_odometry),
      keyValue("late scans (used at filter time)", c.late_scans),
      keyValue("odometry frame mismatches", odom_frame_mismatches_),
      keyValue("implausible odometry (beyond max_speed / max_yaw_rate)", c.implausible_odometry),
      keyValue("odometry without orientation (pose_delta)", c.invalid_orientations),
      keyValue("inconsistent scans (angles vs beams)", c.inconsistent_scans),
      keyValue("duplicate scans dropped", c.duplicate_scans)};
  array.status.push_back(in);

  diagnostic_msgs::DiagnosticStatus proc;
  proc.name = hw + ": processing";
  proc.hardware_id = hw;
  const double mean_latency = latency_count_ ? latency_sum_ / latency_count_ : 0.0;
  proc.level = diagnostic_msgs::DiagnosticStatus::OK;
  proc.message =
      (pipeline_->lost() ? "LOST since scan " + std::to_string(lost_since_scan_) + " (relocalising)"
                         : std::string("tracking")) +
      ", " + std::to_string(pipeline_->ekf().numLandmarks()) + " landmarks";
  if (pipeline_->lost()) proc.level = diagnostic_msgs::DiagnosticStatus::WARN;
  if (c.rejected_updates > 0 || c.rejected_odometry > 0) {
    proc.level = diagnostic_msgs::DiagnosticStatus::WARN;
    proc.message += "; " + std::to_string(c.rejected_updates) + " updates and " +
                    std::to_string(c.rejected_odometry) + " odometry messages rejected";
  }
  proc.values = {keyValue("associator", parts_.associator_name),
                 keyValue("mode", pipeline_config_.mode),
                 keyValue("scans processed", scans_processed_),
                 keyValue("latency mean [ms]", 1e3 * mean_latency),
                 keyValue("latency max [ms]", 1e3 * latency_max_),
                 keyValue("inbox now", inbox),
                 keyValue("inbox peak", peak),
                 keyValue("sequencer pending", sequencer_->pending()),
                 keyValue("landmarks", pipeline_->ekf().numLandmarks()),
                 keyValue("resets", resets_),
                 keyValue("time jumps", q.time_jumps),
                 keyValue("rejected updates", c.rejected_updates),
                 keyValue("rejected odometry", c.rejected_odometry),
                 keyValue("empty scans", c.empty_scans),
                 keyValue("invalid ranges", c.invalid_ranges),
                 keyValue("invalid observations", c.invalid_observations),
                 keyValue("map frozen: new landmarks not added", c.frozen_new),
                 keyValue("map frozen: removals not applied", c.frozen_removals),
                 keyValue("map -> odom from the Odometry pose (no tf)", odom_tf_fallbacks_),
                 keyValue("relocaliser", pipeline_config_.relocaliser),
                 keyValue("lost events", c.lost_events),
                 keyValue("relocalisations", c.relocalisations),
                 keyValue("relocalisation attempts", c.relocalisation_attempts)};
  array.status.push_back(proc);
  latency_sum_ = latency_max_ = 0.0;
  latency_count_ = 0;
  diagnostics_pub_.publish(array);
}

std::string EkfSlamNode::summary() const {
  const PipelineCounters& c = pipeline_->counters();
  const SequencerCounters& s = sequencer_->counters();
  std::ostringstream out;
  std::uint64_t overflow = 0;
  {
    std::lock_guard<std::mutex> lock(inbox_mutex_);
    overflow = inbox_overflow_;
  }
  out << "scans received " << scans_received_ << ", processed " << scans_processed_
      << ", missing upstream (seq gaps) " << scan_gaps_.missing + observation_gaps_.missing
      << ", before the first (seq) " << scan_gaps_.before_first + observation_gaps_.before_first
      << ", skipped without tf " << skipped_no_tf_ << ", zero stamps " << skipped_bad_stamp_
      << "; odometry received " << odometry_received_ << ", missing (seq gaps) "
      << odom_gaps_.missing << ", before the first (seq) " << odom_gaps_.before_first << ", used "
      << c.odometry << "; inbox overflow " << overflow << "; late odometry " << s.late_odometry
      << ", late scans " << s.late_scans << ", time jumps " << s.time_jumps
      << ", out-of-range stamps dropped " << s.dropped_out_of_range << ", released by latency "
      << s.released_by_latency << ", input-timeout flushes " << flushes_ << "; empty scans "
      << c.empty_scans << ", inconsistent scans " << c.inconsistent_scans << ", duplicate scans "
      << c.duplicate_scans << ", rejected odometry " << c.rejected_odometry << " (non-finite), "
      << c.implausible_odometry << " (implausible), " << c.invalid_orientations
      << " (no orientation), rejected updates " << c.rejected_updates << "; landmarks "
      << pipeline_->ekf().numLandmarks();
  return out.str();
}

}  // namespace ekf_slam
