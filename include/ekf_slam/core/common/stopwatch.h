// Wall time since a point, for the timings the pipeline reports (ScanReport, metrics.json).
#pragma once

#include <chrono>

namespace ekf_slam {

using SteadyClock = std::chrono::steady_clock;

/// Seconds elapsed since `t0` on the steady clock.
inline double secondsSince(SteadyClock::time_point t0) {
  return std::chrono::duration<double>(SteadyClock::now() - t0).count();
}

}  // namespace ekf_slam
