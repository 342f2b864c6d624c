// Consistency of a laser scan's geometry (sensor_msgs/LaserScan's angle fields against its number
// of beams). One rule for the node and the offline runner: SlamPipeline::processScan applies it
// when given angle_max. ROS-free.
#pragma once

#include <cstddef>

namespace ekf_slam {

/// Why a scan of `beams` ranges with these angles cannot be placed, or nullptr when it can.
/// Beam i is at angle_min + i * angle_increment; angle_max must be the last beam's angle, within
/// one increment (drivers differ on whether angle_max is the last beam or one past it). Rejected:
/// non-finite angles, a zero increment, an increment whose sign contradicts angle_min ->
/// angle_max, more than a full turn, and a beam count or increment that does not fit the angles.
const char* scanGeometryError(std::size_t beams, double angle_min, double angle_max,
                              double angle_increment);

}  // namespace ekf_slam
