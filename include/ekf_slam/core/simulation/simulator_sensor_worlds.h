// Simulated worlds for sensors that miss landmarks (issue 13): `arena`, a small room seen by a
// narrow camera with a low detection probability, other robots moving through it. Registered
// in simulator.cpp's world list; values and reasoning in docs/simulation.md.
#pragma once

#include "ekf_slam/core/simulation/simulator.h"

namespace ekf_slam {
namespace sim {

/// 6 x 8 m room, 15 landmarks, 60 deg camera (0.3..6 m, P_D 0.6 near .. 0.2 far), odometry at
/// 67 Hz, four other robots (movers), 20 minutes.
World arenaWorld();

/// Downward camera reading floor markers: trapezoid 0.8..4.5 m ahead, P_D 0.7, Cartesian
/// observations, ~600 markers along a corridor grid, a ~480 m route with many loop closures,
/// 0.2 s steps, pose-increment odometry, a few % false detections.
World fiducialsWorld();

}  // namespace sim
}  // namespace ekf_slam
