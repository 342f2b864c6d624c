// Runs of a track drawn as lines (track_split.h).
#include "ekf_slam/core/common/track_split.h"

#include <cmath>
#include <stdexcept>

namespace ekf_slam {

void validate(const TrackSplitOptions& o) {
  if (!(std::isfinite(o.max_gap) && o.max_gap > 0.0))
    throw std::invalid_argument("track split: max_gap must be finite and > 0");
  if (!(std::isfinite(o.max_speed) && o.max_speed > 0.0))
    throw std::invalid_argument("track split: max_speed must be finite and > 0");
  if (!(std::isfinite(o.position_tolerance) && o.position_tolerance >= 0.0))
    throw std::invalid_argument("track split: position_tolerance must be finite and >= 0");
}

std::vector<TrackRun> splitTrack(const std::vector<TrackFix>& fixes,
                                 const TrackSplitOptions& options) {
  std::vector<TrackRun> runs;
  bool open = false;  // the last run may be continued by the next fix
  for (std::size_t i = 0; i < fixes.size(); ++i) {
    const TrackFix& f = fixes[i];
    if (!std::isfinite(f.stamp) || !f.position.allFinite()) {
      open = false;  // never drawn, and no line across it
      continue;
    }
    if (open) {
      const TrackFix& prev = fixes[i - 1];
      const double dt = f.stamp - prev.stamp;
      // Written so that a NaN comparison (none can reach here) would split, not join.
      const bool joined = dt > 0.0 && dt <= options.max_gap &&
                          (f.position - prev.position).norm() <=
                              options.max_speed * dt + options.position_tolerance;
      if (joined) {
        runs.back().end = i + 1;
        continue;
      }
    }
    runs.push_back({i, i + 1});
    open = true;
  }
  return runs;
}

}  // namespace ekf_slam
