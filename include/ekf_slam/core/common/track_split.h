// Where a recorded track (e.g. GPS fixes) may be drawn as a line: not across a dropout of the
// receiver, and not across a jump no vehicle could have driven, or the line crosses the whole map
// (issue 33). ROS-free; the gps_track node draws the runs (docs/node.md).
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace ekf_slam {

struct TrackFix {
  double stamp = 0.0;                                  ///< [s]
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< [m]
};

/// What a user knows about the receiver and the vehicle (docs/parameters.md, "GPS track").
struct TrackSplitOptions {
  /// Consecutive fixes further apart in time are a dropout [s]: a few periods of the receiver's
  /// fix rate (5 Hz: 0.2 s).
  double max_gap = 1.0;
  /// The vehicle's top speed [m/s]: in dt it moves at most max_speed * dt ...
  double max_speed = 10.0;
  /// ... plus what the receiver's noise adds to one step [m].
  double position_tolerance = 3.0;
};

/// Throws std::invalid_argument unless max_gap > 0, max_speed > 0, position_tolerance >= 0, all
/// finite.
void validate(const TrackSplitOptions& options);

/// Fixes [begin, end) of `fixes` drawn as one line.
struct TrackRun {
  std::size_t begin = 0;
  std::size_t end = 0;
  std::size_t size() const { return end - begin; }
};

/// Splits `fixes` (in arrival order) into runs of consecutive fixes. A fix starts a new run when
/// it comes more than max_gap after the previous one or not after it (dt <= 0: a restart or
/// reordering), or lies farther from it than max_speed * dt + position_tolerance (a jump). A
/// non-finite fix ends the run and belongs to none; every other fix is in exactly one run, which
/// may hold that fix alone. Runs are in order and do not overlap. O(n).
std::vector<TrackRun> splitTrack(const std::vector<TrackFix>& fixes,
                                 const TrackSplitOptions& options = {});

}  // namespace ekf_slam
