// The simulator's ground-truth ids, as the scorers read them (ROS-free). A simulated
// observation, and a simulated bag's, carries the id of what it saw.
#pragma once

#include "ekf_slam/core/association/data_association.h"

namespace ekf_slam {
namespace sim {

// Static landmark k has truth id k (>= 0). Moving object k has id moverId(k) = -1 - k. Clutter
// returns get distinct ids kClutterIdBase, kClutterIdBase - 1, ... (far below any mover id).
inline LandmarkId moverId(int k) { return -1 - static_cast<LandmarkId>(k); }
constexpr LandmarkId kClutterIdBase = -1000000000;
inline bool isStaticLandmark(LandmarkId truth) { return truth >= 0; }
inline bool isClutter(LandmarkId truth) { return truth <= kClutterIdBase; }

}  // namespace sim
}  // namespace ekf_slam
