// detect_trees: runs ACFR's tree detector over every sensor_msgs/LaserScan of a bag (no roscore),
// or over the Victoria Park ASCII laser file, and writes one CSV row per detected tree.
#include <sensor_msgs/LaserScan.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <iostream>
#include <string>

#include <rosbag/bag.h>
#include <rosbag/view.h>

#include "ekf_slam/core/tree_extractor.h"
#include "ekf_slam/data/victoria_park.h"

namespace {

struct Counts {
  std::size_t scans = 0;
  std::size_t trees = 0;
};

void usage(std::ostream& out) {
  out << "Usage: rosrun ekf_slam detect_trees --bag FILE.bag --out trees.csv [--topic /scan]\n"
         "       rosrun ekf_slam detect_trees --data DIR --out trees.csv\n"
         "Runs ACFR's Victoria Park tree detector on every scan and writes\n"
         "scan,stamp,range,bearing,diameter (scan = header.seq, stamp [s], bearing in the\n"
         "LaserScan convention [rad], range to the trunk centre and diameter [m]).\n"
         "--data reads victoria_park_ascii/LASER.txt under DIR instead of a bag (scan = index,\n"
         "stamp = data milliseconds / 1000, as in the converted bag). DIR may be \"default\"\n"
         "($VP_DATA or the shared data folder).\n";
}

Counts fromBag(const std::string& path, const std::string& topic, std::ostream& csv) {
  const ekf_slam::TreeExtractor extractor;
  rosbag::Bag bag(path, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  Counts c;
  for (const rosbag::MessageInstance& m : view) {
    const auto scan = m.instantiate<sensor_msgs::LaserScan>();
    if (!scan) {
      throw std::runtime_error(topic + " carries " + m.getDataType() +
                               ", not sensor_msgs/LaserScan");
    }
    const auto trees = extractor.extract(scan->ranges, scan->angle_min, scan->angle_increment);
    ekf_slam::writeTreesCsvRows(csv, scan->header.seq, scan->header.stamp.toSec(), trees);
    ++c.scans;
    c.trees += trees.size();
  }
  return c;
}

Counts fromData(const std::string& dir, std::ostream& csv) {
  namespace vp = ekf_slam::victoria_park;
  const vp::LaserScans laser = vp::loadLaser(dir);
  const ekf_slam::TreeExtractor extractor;
  Counts c;
  for (std::size_t i = 0; i < laser.ranges.size(); ++i) {
    // The same geometry as the converted bag's LaserScans.
    const auto trees = extractor.extract(laser.ranges[i], -M_PI / 2, M_PI / 360);
    ekf_slam::writeTreesCsvRows(csv, static_cast<std::uint32_t>(i), laser.time_ms[i] / 1000.0,
                                trees);
    ++c.scans;
    c.trees += trees.size();
  }
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  std::string bag, data, out, topic = "/scan";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      usage(std::cout);
      return 0;
    }
    const bool known = arg == "--bag" || arg == "--data" || arg == "--out" || arg == "--topic";
    if (!known || i + 1 >= argc) {
      std::cerr << "detect_trees: " << (known ? "missing value for " : "unknown argument ") << arg
                << "\n";
      usage(std::cerr);
      return 2;
    }
    const std::string value = argv[++i];
    (arg == "--bag" ? bag : arg == "--data" ? data : arg == "--out" ? out : topic) = value;
  }
  if (out.empty() || bag.empty() == data.empty()) {
    std::cerr << "detect_trees: give --out and exactly one of --bag or --data\n";
    usage(std::cerr);
    return 2;
  }
  if (data == "default") data = ekf_slam::victoria_park::defaultDataDir();

  std::ofstream csv(out);
  if (!csv) {
    std::cerr << "detect_trees: cannot write " << out << ": " << std::strerror(errno) << "\n";
    return 1;
  }
  const auto start = std::chrono::steady_clock::now();
  Counts c;
  try {
    ekf_slam::writeTreesCsvHeader(csv);
    c = bag.empty() ? fromData(data, csv) : fromBag(bag, topic, csv);
  } catch (const std::exception& e) {
    std::cerr << "detect_trees: " << (bag.empty() ? data : bag) << ": " << e.what() << "\n";
    csv.close();
    std::remove(out.c_str());  // no half-written CSV that looks like a result
    return 1;
  }
  csv.close();
  if (!csv) {
    std::cerr << "detect_trees: error writing " << out << "\n";
    return 1;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (c.scans == 0) {
    std::cerr << "detect_trees: no sensor_msgs/LaserScan on " << topic << " in " << bag << "\n";
    std::remove(out.c_str());
    return 1;
  }
  std::cout << "detect_trees: " << c.scans << " scans, " << c.trees << " trees -> " << out << " ("
            << seconds << " s)\n";
  return 0;
}
