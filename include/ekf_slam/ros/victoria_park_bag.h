// Converts the Victoria Park data set (see ekf_slam/data/victoria_park.h) into a ROS bag:
//   /scan        sensor_msgs/LaserScan     frame laser, header.seq = 0-based scan index
//   /odom        nav_msgs/Odometry         frame odom -> base_link (rear-axle centre), 40 Hz
//   /gps         geometry_msgs/PointStamped frame gps, x = Lo_m, y = La_m [m]
//   /tf_static   tf2_msgs/TFMessage        base_link -> laser, latched
// All stamps (header and bag time) are the data's milliseconds / 1000.
#pragma once

#include <cstddef>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace ekf_slam {
namespace victoria_park {

/// Laser mounting in base_link (rear-axle centre): README "Vehicle geometry", a and b.
constexpr double kLaserX = 3.78;
constexpr double kLaserY = 0.50;
/// Shortest range the converter calls valid: the data has 13 readings below it (of 2.6 M),
/// isolated and implausible (the vehicle's own front is at about 0.8 m).
constexpr double kRangeMin = 0.10;
/// ACFR treats everything above 80 m as no reflection. Readings in (80, 81.91) are SICK error
/// codes; they are kept as they are and are invalid because they exceed range_max (REP-117).
constexpr double kRangeMax = 80.0;

/// Noise of the dead-reckoning inputs used for the /odom covariances (1 sigma).
struct OdometryNoise {
  double speed = 0.1;      ///< encoder speed v_e [m/s]
  double steering = 0.02;  ///< steering angle alpha [rad]
};

struct BagOptions {
  std::string data_dir;           ///< empty: defaultDataDir()
  std::string out_path;           ///< the .bag to write (overwritten)
  std::optional<double> start_s;  ///< keep messages with stamp >= start [s, data clock]
  std::optional<double> end_s;    ///< keep messages with stamp <= end [s, data clock]
  OdometryNoise odometry_noise;
};

struct BagCounts {
  std::size_t scans = 0;
  std::size_t odometry = 0;
  std::size_t gps = 0;
  std::size_t tf_static = 0;
  double first_stamp = 0.0;  ///< [s]
  double last_stamp = 0.0;   ///< [s]
};

/// Writes the bag. Throws std::runtime_error on missing/malformed data (naming the file), on an
/// empty or inverted window and when the bag cannot be written.
BagCounts writeVictoriaParkBag(const BagOptions& options);

/// Command line of victoria_park_to_bag (args without the program name). Returns false and sets
/// *error on bad arguments; sets *help when --help was given.
bool parseBagArguments(const std::vector<std::string>& args, BagOptions* options, bool* help,
                       std::string* error);
void printBagUsage(std::ostream& out, const std::string& program);

/// The whole tool: parse, convert, print counts and run time. Returns the process exit code.
int victoriaParkToBagMain(int argc, char** argv);

}  // namespace victoria_park
}  // namespace ekf_slam
