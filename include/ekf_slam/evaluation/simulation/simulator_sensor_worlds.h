// Simulated worlds for sensors that miss landmarks (issue 13): `arena`, a small room seen by a
// narrow camera with a low detection probability, other robots moving through it; `fiducials`
// (and `fiducials_lattice`), a downward camera reading floor markers along corridors. Registered
// in simulator.cpp's world list; values and reasoning in
// docs/notes/2026-11-to-12-simulation-record.md, "Sensors that miss landmarks".
#pragma once

#include <cstdint>

#include "ekf_slam/evaluation/simulation/simulator.h"

namespace ekf_slam {
namespace sim {

/// 6 x 8 m room, 15 landmarks, 60 deg camera (0.3..6 m, P_D 0.6 near .. 0.2 far), odometry at
/// 67 Hz, four other robots (movers), 20 minutes.
World arenaWorld();

/// Downward camera reading floor markers: trapezoid 0.8..4.5 m ahead, P_D 0.7, Cartesian
/// observations, ~600 markers along a corridor grid, a ~480 m route with many loop closures,
/// 0.2 s steps, pose-increment odometry, a few % false detections. The markers are laid by
/// hand: each is off its nominal place on the corridors' pattern by `placement_sigma` per axis
/// (one fixed draw). fiducialsWorld() = `fiducials` (kMarkerPlacementSigma);
/// fiducialsWorld(0) = `fiducials_lattice`, the exact periodic pattern (docs/simulation.md).
World fiducialsWorld();
World fiducialsWorld(double placement_sigma);

/// Placement error of a hand-laid floor marker [m, per axis]: markers taped down along a corridor
/// at nominal 0.4 m intervals, by eye and tape measure.
constexpr double kMarkerPlacementSigma = 0.05;
/// The one draw of the placement errors.
constexpr std::uint64_t kMarkerPlacementSeed = 13;

}  // namespace sim
}  // namespace ekf_slam
