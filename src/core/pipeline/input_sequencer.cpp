// Stamp ordering of odometry and scans; the release rule is described in input_sequencer.h.
#include "ekf_slam/core/pipeline/input_sequencer.h"

#include <algorithm>
#include <string>

#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

void InputSequencerConfig::validate() const {
  if (!(std::isfinite(max_latency) && max_latency >= 0.0)) {
    throw ParameterError("parameter max_latency: must be finite and >= 0, got " +
                         std::to_string(max_latency));
  }
  if (!(std::isfinite(time_jump_threshold) && time_jump_threshold > 0.0)) {
    throw ParameterError("parameter time_jump_threshold: must be finite and > 0, got " +
                         std::to_string(time_jump_threshold));
  }
}

const char* toString(SequencerStatus s) {
  switch (s) {
    case SequencerStatus::kQueued:
      return "queued";
    case SequencerStatus::kLate:
      return "late";
    case SequencerStatus::kTimeJump:
      return "time jump";
    case SequencerStatus::kInvalidStamp:
      return "invalid stamp";
    case SequencerStatus::kHeld:
      return "held";
  }
  return "?";
}

SequencerCore::SequencerCore(const InputSequencerConfig& config) : config_(config) {
  config_.validate();
}

SequencerStatus SequencerCore::addOdometry(const OdometryInput& odom) {
  Entry e;
  e.kind = Kind::kOdometry;
  e.stamp = odom.stamp;
  e.odometry = odom;
  return add(e);
}

SequencerStatus SequencerCore::addScan(double stamp, std::uint64_t handle) {
  Entry e;
  e.kind = Kind::kScan;
  e.stamp = stamp;
  e.handle = handle;
  return add(e);
}

SequencerStatus SequencerCore::add(Entry e) {
  if (!std::isfinite(e.stamp)) {
    ++counters_.invalid_stamps;
    return SequencerStatus::kInvalidStamp;
  }
  const bool odom = e.kind == Kind::kOdometry;
  ++(odom ? counters_.odometry : counters_.scans);
  e.order = order_++;
  const double thr = config_.time_jump_threshold;
  const double other = odom ? newest_scan_ : newest_odometry_;

  bool jumped = false;
  if (!candidates_.empty()) {
    if (e.kind != candidates_.front().kind) {
      jumped = decideCandidates(e);
    } else if (std::isfinite(other) && std::abs(e.stamp - other) <= thr) {
      dropCandidates();  // the stream is back on the common timeline: they were outliers
    }
  }
  const double other_now = odom ? newest_scan_ : newest_odometry_;
  if (std::isfinite(other_now) && std::abs(e.stamp - other_now) > thr) {
    // Disagrees with the other stream: one stream alone does not move the timeline.
    if (!candidates_.empty() && std::abs(e.stamp - candidates_.back().stamp) > thr) {
      dropCandidates();  // not even consistent with the previous candidates
    }
    candidates_.push_back(e);
    ++counters_.held;
    if (candidates_.back().stamp - candidates_.front().stamp > thr ||
        candidates_.front().stamp - candidates_.back().stamp > thr) {
      // The other stream stayed silent over a whole threshold of this one: not a bad publisher
      // but the other stream stopped (or paused) while this one went on.
      const bool jump = candidates_.front().stamp < newest_ - thr;
      confirmCandidates();
      return jump ? SequencerStatus::kTimeJump : SequencerStatus::kQueued;
    }
    return SequencerStatus::kHeld;
  }
  const SequencerStatus status = accept(e);
  return jumped && status != SequencerStatus::kLate ? SequencerStatus::kTimeJump : status;
}

bool SequencerCore::decideCandidates(const Entry& e) {
  if (std::abs(e.stamp - candidates_.back().stamp) > config_.time_jump_threshold) {
    dropCandidates();  // the other stream is still on the old timeline
    return false;
  }
  // Both streams agree on the candidates' timeline.
  const bool jump = candidates_.front().stamp < newest_ - config_.time_jump_threshold;
  confirmCandidates();
  return jump;
}

void SequencerCore::confirmCandidates() {
  std::deque<Entry> held;
  held.swap(candidates_);
  if (held.front().stamp < newest_ - config_.time_jump_threshold) {
    timeJump(held.front().stamp, held.front().order);
  }
  for (const Entry& c : held) accept(c);
}

void SequencerCore::dropCandidates() {
  for (const Entry& c : candidates_) {
    ++counters_.dropped_out_of_range;
    if (c.kind != Kind::kScan) continue;
    Entry d = c;  // the payload of a scan is freed by InputSequencer
    d.kind = Kind::kDropped;
    ready_.push_back(d);
  }
  candidates_.clear();
}

void SequencerCore::timeJump(double stamp, std::uint64_t order) {
  // A new timeline: what is pending belongs to the old one and is released first, so nothing
  // is dropped; the marker tells the shell to reset before the new items.
  for (const Entry& p : pending_) moveToReady(p);
  pending_.clear();
  Entry marker;
  marker.kind = Kind::kTimeJump;
  marker.stamp = stamp;
  marker.order = order;
  ready_.push_back(marker);
  newest_ = newest_odometry_ = newest_scan_ = last_released_ =
      std::numeric_limits<double>::quiet_NaN();
  ++counters_.time_jumps;
}

SequencerStatus SequencerCore::accept(Entry e) {
  const bool odom = e.kind == Kind::kOdometry;
  const double other = odom ? newest_scan_ : newest_odometry_;
  SequencerStatus status = SequencerStatus::kQueued;
  if (!std::isfinite(other) && std::isfinite(newest_) &&
      e.stamp < newest_ - config_.time_jump_threshold) {
    // A single stream (the other never seen) jumped back: a restart.
    timeJump(e.stamp, e.order);
    status = SequencerStatus::kTimeJump;
  } else if (std::isfinite(last_released_) && e.stamp < last_released_) {
    // Its place in the sequence has gone: hand it over now, flagged, and let the pipeline apply
    // the shared decision.
    e.late = true;
    ready_.push_back(e);
    ++(odom ? counters_.late_odometry : counters_.late_scans);
    return SequencerStatus::kLate;
  }

  insertPending(e);
  newest_ = std::isfinite(newest_) ? std::max(newest_, e.stamp) : e.stamp;
  double& newest_of_kind = odom ? newest_odometry_ : newest_scan_;
  newest_of_kind = std::isfinite(newest_of_kind) ? std::max(newest_of_kind, e.stamp) : e.stamp;
  release();
  return status;
}

void SequencerCore::insertPending(const Entry& e) {
  // (stamp, odometry before scan, arrival). Input is almost always in order, so search from the
  // back: O(1) in the usual case.
  const auto before = [](const Entry& a, const Entry& b) {
    if (a.stamp != b.stamp) return a.stamp < b.stamp;
    if (a.kind != b.kind) return a.kind == Kind::kOdometry;
    return a.order < b.order;
  };
  auto it = pending_.end();
  while (it != pending_.begin() && before(e, *(it - 1))) --it;
  pending_.insert(it, e);
}

void SequencerCore::release() {
  while (!pending_.empty()) {
    const Entry& f = pending_.front();
    // The other stream has reached this stamp: nothing that belongs before it can still come.
    const double other = f.kind == Kind::kScan ? newest_odometry_ : newest_scan_;
    const bool by_other = std::isfinite(other) && f.stamp <= other;
    const bool by_latency = f.stamp < newest_ - config_.max_latency;
    if (!by_other && !by_latency) break;
    if (!by_other) ++counters_.released_by_latency;
    moveToReady(f);
    pending_.pop_front();
  }
}

void SequencerCore::moveToReady(const Entry& e) {
  ready_.push_back(e);
  last_released_ = std::isfinite(last_released_) ? std::max(last_released_, e.stamp) : e.stamp;
}

void SequencerCore::flush() {
  // End of input: nothing can decide any more. Candidates later than the old timeline (a stream
  // that went on after the other ended) are used; earlier ones (a lone jump back) are not.
  if (!candidates_.empty()) {
    if (candidates_.front().stamp >= newest_ - config_.time_jump_threshold) {
      confirmCandidates();
    } else {
      dropCandidates();
    }
  }
  for (const Entry& e : pending_) moveToReady(e);
  pending_.clear();
}

bool SequencerCore::next(Entry* out) {
  if (ready_.empty()) return false;
  *out = ready_.front();
  ready_.pop_front();
  return true;
}

void SequencerCore::clear() {
  pending_.clear();
  ready_.clear();
  candidates_.clear();
  newest_ = newest_odometry_ = newest_scan_ = last_released_ =
      std::numeric_limits<double>::quiet_NaN();
}

}  // namespace ekf_slam
