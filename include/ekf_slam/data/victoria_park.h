// Reader for ACFR's Victoria Park data set (the MATLAB dead-reckoning and GPS files and the ASCII
// laser file). ROS-free; uses libmatio. Every loader throws std::runtime_error naming the file and
// what is wrong with it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace ekf_slam {
namespace victoria_park {

constexpr int kBeams = 361;                    ///< 0.5 deg apart, 180 deg, beam 0 to the right
constexpr double kNoReturn = 81.91;            ///< masked 13-bit value 8191 cm: no return
constexpr std::int64_t kAsciiEpochMs = 20967;  ///< t_ascii = (t_ms - 20967) / 1000

/// aa3_dr.mat: 40 Hz encoder speed (rear-left wheel) and front steering angle.
struct DeadReckoning {
  std::vector<std::int64_t> time_ms;
  std::vector<double> speed;     ///< [m/s]
  std::vector<double> steering;  ///< [rad], positive = counter-clockwise turn
};

/// aa3_gpsx.mat: GPS fixes in local metres.
struct Gps {
  std::vector<std::int64_t> time_ms;
  std::vector<double> x;  ///< Lo_m
  std::vector<double> y;  ///< La_m
};

/// victoria_park_ascii/LASER.txt: 7230 scans of 361 ranges in metres (81.91 = no return, kept).
struct LaserScans {
  std::vector<std::int64_t> time_ms;       ///< on the MATLAB clock (t_ascii*1000 + 20967)
  std::vector<std::vector<float>> ranges;  ///< kBeams values per scan
};

/// $VP_DATA when set, else ../shared/data/victoria_park relative to the repository root.
std::string defaultDataDir();

DeadReckoning loadDeadReckoning(const std::string& data_dir);
Gps loadGps(const std::string& data_dir);
/// Loads LASER.txt; when lasersampling.txt is present too, also checks that every scan time
/// equals the original TLsr stamp (throws naming both files if not).
LaserScans loadLaser(const std::string& data_dir);
/// lasersampling.txt: the 7249 original TLsr stamps [ms] (the ASCII laser file has the first 7230).
std::vector<std::int64_t> loadLaserSampling(const std::string& data_dir);

}  // namespace victoria_park
}  // namespace ekf_slam
