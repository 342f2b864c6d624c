// Puts odometry and scans (or observation sets) in stamp order before they reach the
// SlamPipeline, so that the node (live topics) and the offline runner (a bag) feed the pipeline
// the same sequence and give the same answer. ROS-free.
//
// Release rule (docs/parameters.md, "Input ordering"): a merge of two streams, each assumed
// in order, so that arrival jitter between the topics does not change the result:
//  - a scan is released once odometry with a stamp >= its stamp has arrived (the motion up to
//    the scan is known before it is used); an odometry message once a scan with a stamp >= its
//    stamp has arrived (no earlier scan can still come);
//  - or, either, once it is older than the newest stamp seen minus max_latency (nothing is held
//    forever when one stream stops); flush() releases everything (end of a bag);
//  - released items come out in (stamp, odometry before scan, arrival) order;
//  - an item older than the last released stamp is LATE: it is released at once, flagged `late`,
//    and the pipeline applies the shared decision (late odometry: skipped and counted, its
//    interval is already predicted; late scan: processed at the filter's current time, counted);
//  - one stream alone cannot restart the timeline (a bad publisher must not wipe the map): while
//    both streams are alive, an item whose stamp is more than time_jump_threshold away from the
//    other stream's newest stamp is HELD as a candidate of a new timeline. The other stream
//    decides: an item of it that agrees with the candidates (within the threshold) confirms them,
//    one that agrees with the old timeline refutes them, and they are dropped and counted
//    (dropped_out_of_range). Confirmed candidates earlier than the old timeline mean that time
//    jumped backwards (bag restarted, clock reset): everything pending is released first (in
//    order), then a kTimeJump marker, then the candidates start the new timeline; on the marker
//    the shells reset the pipeline with a warning. Confirmed candidates later than it are a gap
//    in the other stream: they are queued as usual.
//  - the other stream is silent when the candidates alone span more than time_jump_threshold:
//    they are confirmed. Candidates that disagree with each other restart the candidate set (the
//    older ones are dropped). With a single stream (the other never seen), its own jump back by
//    more than time_jump_threshold is a restart. At flush(), candidates later than the old
//    timeline are queued, earlier ones dropped.
//
// Usage (both shells):
//   InputSequencer<Scan> seq(config.sequencer);
//   seq.addOdometry(odom);  seq.addScan(stamp, scan);   // returns kQueued / kLate / kTimeJump
//   InputSequencer<Scan>::Item item;
//   while (seq.next(&item)) { switch (item.kind) ... }   // dispatch to the pipeline
//   seq.flush(); while (seq.next(&item)) ...             // at the end of the input
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <unordered_map>
#include <utility>

#include "ekf_slam/core/pipeline/odometry_input.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"

namespace ekf_slam {

/// Filled from PipelineConfig (max_latency, time_jump_threshold): see sequencerConfig().
struct InputSequencerConfig {
  /// Items older than (newest stamp seen - max_latency) are released without waiting for
  /// odometry [s].
  double max_latency = 0.5;
  /// A stamp this much older than the newest one seen is a jump back in time (restart) [s].
  double time_jump_threshold = 1.0;

  /// Throws ParameterError naming the first invalid setting.
  void validate() const;
};

inline InputSequencerConfig sequencerConfig(const PipelineConfig& c) {
  InputSequencerConfig s;
  s.max_latency = c.max_latency;
  s.time_jump_threshold = c.time_jump_threshold;
  return s;
}

/// What happened to an item handed to the sequencer.
enum class SequencerStatus : std::uint8_t {
  kQueued,        ///< in order (or within the ordering window): queued normally
  kLate,          ///< older than the last released stamp: released at once, flagged late
  kTimeJump,      ///< time jumped backwards: a kTimeJump marker precedes it in the output
  kInvalidStamp,  ///< non-finite stamp: dropped (the shell warns)
  kHeld,          ///< inconsistent with the other stream: held until that stream decides
};
const char* toString(SequencerStatus s);

/// Counters since construction / reset().
struct SequencerCounters {
  std::uint64_t odometry = 0;  ///< accepted (not counting invalid stamps)
  std::uint64_t scans = 0;
  std::uint64_t late_odometry = 0;
  std::uint64_t late_scans = 0;
  std::uint64_t time_jumps = 0;
  std::uint64_t invalid_stamps = 0;
  std::uint64_t released_by_latency = 0;   ///< items released by max_latency, not by the other
                                           ///< stream
  std::uint64_t held = 0;                  ///< items held as candidates of a new timeline
  std::uint64_t dropped_out_of_range = 0;  ///< candidates refuted by the other stream: dropped
};

/// The payload-free ordering logic. Scans are referred to by a handle; InputSequencer<Scan>
/// below stores the payloads.
class SequencerCore {
 public:
  /// kDropped: a refuted candidate (scans carry their handle, so the payload can be freed).
  enum class Kind : std::uint8_t { kOdometry, kScan, kTimeJump, kDropped };
  struct Entry {
    Kind kind = Kind::kOdometry;
    double stamp = 0.0;
    bool late = false;
    std::uint64_t order = 0;   ///< arrival number (tie-break)
    std::uint64_t handle = 0;  ///< scans: the payload's handle
    OdometryInput odometry;    ///< odometry entries
  };

  explicit SequencerCore(const InputSequencerConfig& config = InputSequencerConfig());

  SequencerStatus addOdometry(const OdometryInput& odom);
  SequencerStatus addScan(double stamp, std::uint64_t handle);
  /// Moves every pending item to the output (end of input).
  void flush();
  /// Pops the next released entry; false when none is ready.
  bool next(Entry* out);
  /// Drops everything (pending and released) and forgets the timeline; counters are kept.
  void clear();

  std::size_t pending() const { return pending_.size() + candidates_.size(); }
  std::size_t ready() const { return ready_.size(); }
  /// Stamp of the last released item (NaN before the first).
  double lastReleasedStamp() const { return last_released_; }
  const SequencerCounters& counters() const { return counters_; }
  const InputSequencerConfig& config() const { return config_; }

 private:
  SequencerStatus add(Entry e);
  /// The in-order part of add(): late items, the single-stream jump test, queueing.
  SequencerStatus accept(Entry e);
  /// The other stream's item `e` confirms or refutes the held candidates; true when confirming
  /// them was a jump back in time.
  bool decideCandidates(const Entry& e);
  void confirmCandidates();
  void dropCandidates();
  void timeJump(double stamp, std::uint64_t order);
  void insertPending(const Entry& e);
  void release();
  void moveToReady(const Entry& e);

  InputSequencerConfig config_;
  std::deque<Entry> pending_;  // sorted by (stamp, kind, order)
  std::deque<Entry> ready_;
  std::deque<Entry> candidates_;  // held items of one stream, in arrival order
  double newest_ = std::numeric_limits<double>::quiet_NaN();
  double newest_odometry_ = std::numeric_limits<double>::quiet_NaN();
  double newest_scan_ = std::numeric_limits<double>::quiet_NaN();
  double last_released_ = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t order_ = 0;
  SequencerCounters counters_;
};

/// SequencerCore plus the scan payloads (e.g. sensor_msgs::LaserScan::ConstPtr, or a vector of
/// Observations).
template <typename Scan>
class InputSequencer {
 public:
  using Kind = SequencerCore::Kind;
  struct Item {
    Kind kind = Kind::kOdometry;
    double stamp = 0.0;
    bool late = false;       ///< see the release rule; the pipeline handles it
    OdometryInput odometry;  ///< kOdometry
    Scan scan{};             ///< kScan
  };

  explicit InputSequencer(const InputSequencerConfig& config = InputSequencerConfig())
      : core_(config) {}

  SequencerStatus addOdometry(const OdometryInput& odom) { return core_.addOdometry(odom); }
  SequencerStatus addScan(double stamp, Scan scan) {
    const std::uint64_t h = next_handle_++;
    const SequencerStatus s = core_.addScan(stamp, h);
    if (s != SequencerStatus::kInvalidStamp) scans_.emplace(h, std::move(scan));
    return s;
  }
  void flush() { core_.flush(); }
  bool next(Item* out) {
    SequencerCore::Entry e;
    if (!core_.next(&e)) return false;
    while (e.kind == Kind::kDropped) {  // a refuted candidate: free its payload, skip it
      scans_.erase(e.handle);
      if (!core_.next(&e)) return false;
    }
    out->kind = e.kind;
    out->stamp = e.stamp;
    out->late = e.late;
    if (e.kind == Kind::kOdometry) out->odometry = e.odometry;
    if (e.kind == Kind::kScan) {
      const auto it = scans_.find(e.handle);
      out->scan = std::move(it->second);
      scans_.erase(it);
    }
    return true;
  }
  void clear() {
    core_.clear();
    scans_.clear();
  }

  std::size_t pending() const { return core_.pending(); }
  const SequencerCounters& counters() const { return core_.counters(); }
  const SequencerCore& core() const { return core_; }

 private:
  SequencerCore core_;
  std::unordered_map<std::uint64_t, Scan> scans_;
  std::uint64_t next_handle_ = 0;
};

}  // namespace ekf_slam
