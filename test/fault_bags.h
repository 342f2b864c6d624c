// Fault injection for bags (issue 15): faulty copies of a clean bag, made at test time so that
// no binary file is committed. Message faults go through rosbag (each scan / odometry message
// replaced by what a callback returns); byte faults overwrite the written file.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>

namespace fault_bags {

/// What to write instead of each message (index: 0-based per topic); empty drops it.
struct Faults {
  std::function<std::vector<sensor_msgs::LaserScan>(sensor_msgs::LaserScan, std::size_t)> scan;
  std::function<std::vector<nav_msgs::Odometry>(nav_msgs::Odometry, std::size_t)> odom;
};

/// Copies `in` to `out` with the faults applied to /scan and /odom; other topics as they are.
inline void writeFaultyBag(const std::string& in, const std::string& out, const Faults& faults) {
  rosbag::Bag src(in, rosbag::bagmode::Read);
  rosbag::Bag dst(out, rosbag::bagmode::Write);
  std::size_t scans = 0, odoms = 0;
  for (const rosbag::MessageInstance& m : rosbag::View(src)) {
    if (m.getTopic() == "/scan" && faults.scan) {
      for (const auto& s : faults.scan(*m.instantiate<sensor_msgs::LaserScan>(), scans++))
        dst.write("/scan", m.getTime(), s);
    } else if (m.getTopic() == "/odom" && faults.odom) {
      for (const auto& o : faults.odom(*m.instantiate<nav_msgs::Odometry>(), odoms++))
        dst.write("/odom", m.getTime(), o);
    } else {
      dst.write(m.getTopic(), m.getTime(), m, m.getConnectionHeader());
    }
  }
}

/// Breaks a scan's geometry in one of four ways (`kind` % 4): 3x the beams for the same angles,
/// an increment whose sign contradicts the angles, an absurd increment, a NaN angle_max.
inline void breakGeometry(sensor_msgs::LaserScan& s, std::size_t kind) {
  switch (kind % 4) {
    case 0:
      s.ranges.insert(s.ranges.end(), s.ranges.begin(), s.ranges.end());
      s.ranges.insert(s.ranges.end(), s.ranges.begin(), s.ranges.begin() + s.ranges.size() / 2);
      break;
    case 1:
      s.angle_increment = -s.angle_increment;
      break;
    case 2:
      s.angle_increment = 1.0f;
      break;
    default:
      s.angle_max = NAN;
  }
}

/// Every message fault of the suite at once, on disjoint messages: scans with an empty and an
/// unknown frame, a zero stamp, a broken geometry, duplicated; odometry with a zero stamp and a
/// 1e300 m/s twist (the node-versus-runner check of docs/faults.md).
inline Faults allFaults() {
  return {[](sensor_msgs::LaserScan s, std::size_t i) {
            if (i % 10 == 3) s.header.frame_id = "";
            if (i % 10 == 7) s.header.frame_id = "front_laser";
            if (i % 20 == 9) s.header.stamp = ros::Time();
            if (i % 10 == 5) breakGeometry(s, i / 10);
            if (i % 10 == 1) return std::vector<sensor_msgs::LaserScan>{s, s};
            return std::vector<sensor_msgs::LaserScan>{s};
          },
          [](nav_msgs::Odometry o, std::size_t i) {
            if (i % 50 == 9) o.header.stamp = ros::Time();
            if (i % 100 == 50) o.twist.twist.linear.x = 1e300;
            return std::vector<nav_msgs::Odometry>{o};
          }};
}

inline std::vector<char> readBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<char>(std::istreambuf_iterator<char>(f), {});
}

inline void writeBytes(const std::string& path, const std::vector<char>& bytes) {
  std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<long>(bytes.size()));
}

/// Overwrites `count` bytes at `offset` of a copy of `in` with seeded random bytes.
inline void corruptBytes(const std::string& in, const std::string& out, std::size_t offset,
                         std::size_t count, unsigned seed) {
  std::vector<char> bytes = readBytes(in);
  std::mt19937 rng(seed);
  for (std::size_t i = offset; i < offset + count && i < bytes.size(); ++i)
    bytes[i] = static_cast<char>(rng() & 0xff);
  writeBytes(out, bytes);
}

/// Sets the `ranges` length field of the `which`-th scan in frame `frame` with `beams` ranges
/// to `length` (record lengths stay intact: only the message's own layout is broken). Returns
/// false when no such scan was found.
inline bool corruptRangesLength(const std::string& in, const std::string& out,
                                const std::string& frame, std::uint32_t beams, std::size_t which,
                                std::uint32_t length) {
  std::vector<char> bytes = readBytes(in);
  // Serialized: frame_id (length + chars), 7 float32 (angles, times, range limits), ranges.
  std::string pattern(4, '\0');
  const auto n = static_cast<std::uint32_t>(frame.size());
  std::memcpy(&pattern[0], &n, 4);
  pattern += frame;
  std::size_t found = 0;
  for (std::size_t i = 0; i + pattern.size() + 32 <= bytes.size(); ++i) {
    if (std::memcmp(&bytes[i], pattern.data(), pattern.size()) != 0) continue;
    const std::size_t at = i + pattern.size() + 28;
    std::uint32_t len;
    std::memcpy(&len, &bytes[at], 4);
    if (len != beams || found++ != which) continue;
    std::memcpy(&bytes[at], &length, 4);
    writeBytes(out, bytes);
    return true;
  }
  return false;
}

}  // namespace fault_bags
