// The `city` world (issue 14): a street grid lined with ~12 000 landmarks and an hour's drive
// through it, to show how the filters scale (docs/simulation.md, docs/benchmarks.md). Registered
// in simulator.cpp's world list.
#pragma once

#include "ekf_slam/evaluation/simulation/simulator.h"

namespace ekf_slam {
namespace sim {

/// 11 x 11 streets 150 m apart (1.5 x 1.5 km), trees / poles on both sides every 5 m, a 10 m/s
/// car with a 30 m, 180 deg range-bearing sensor at 10 Hz driving every street once (about
/// 36 km, an hour).
World cityWorld();

}  // namespace sim
}  // namespace ekf_slam
