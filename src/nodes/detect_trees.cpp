// detect_trees: runs a feature extractor plugin (ACFR's tree detector by default) over every
// sensor_msgs/LaserScan of a bag (no roscore), or over the Victoria Park ASCII laser file, and
// writes one CSV row per detected feature.
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

#include "ekf_slam/app/pipeline_builder.h"
#include "ekf_slam/app/yaml_configuration.h"
#include "ekf_slam/core/feature_extraction/tree_extractor.h"
#include "ekf_slam/data/victoria_park.h"
#include "ekf_slam/ros/extractor_loader.h"
#include "ekf_slam/ros/plugin_loader.h"

namespace {

struct Counts {
  std::size_t scans = 0;
  std::size_t trees = 0;
};

// The extractor and the scan filters, as the offline runner sets them up from the same YAML.
struct Frontend {
  std::shared_ptr<ekf_slam::FeatureExtractor> extractor;
  ekf_slam::ScanFilterChain filters;

  std::vector<ekf_slam::DetectedTree> detect(ekf_slam::LaserScanData scan) const {
    filters.apply(&scan, Eigen::Vector3d::Zero());  // the box filter's box: laser frame here
    extractor->checkScan(scan);
    std::vector<ekf_slam::DetectedTree> out;
    for (const ekf_slam::Observation& o : extractor->extract(scan))
      out.push_back({o.z(0), o.z(1), o.descriptor, -1, -1});
    return out;
  }
};

void writeRows(const Frontend& f, const ekf_slam::LaserScanData& scan, std::uint32_t seq,
               double stamp, std::ostream& csv, Counts* c) {
  const auto trees = f.detect(scan);
  ekf_slam::writeTreesCsvRows(csv, seq, stamp, trees);
  ++c->scans;
  c->trees += trees.size();
}

void usage(std::ostream& out) {
  out << "Usage: rosrun ekf_slam detect_trees --bag FILE.bag --out trees.csv [--topic /scan]\n"
         "       rosrun ekf_slam detect_trees --data DIR --out trees.csv\n"
         "       [--extractor NAME] [--params FILE.yaml]\n"
         "Runs a feature extractor (default: the YAML's `extractor`, else\n"
         "ekf_slam/TreeExtractor, ACFR's Victoria Park tree detector) on every scan and writes\n"
         "scan,stamp,range,bearing,diameter (scan = header.seq, stamp [s], bearing in the\n"
         "LaserScan convention [rad], range to the\n"
         "feature's centre and its descriptor, e.g. the trunk diameter [m]).\n"
         "--params: the node's YAML (every key is checked; the extractor's section and\n"
         "scan_filter_chain are used; the box filter's box is in the laser frame here).\n"
         "--data reads victoria_park_ascii/LASER.txt under DIR instead of a bag (scan = index,\n"
         "stamp = data milliseconds / 1000, as in the converted bag). DIR may be \"default\"\n"
         "($VP_DATA or the shared data folder).\n";
}

Counts fromBag(const Frontend& f, const std::string& path, const std::string& topic,
               std::ostream& csv) {
  rosbag::Bag bag(path, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  Counts c;
  for (const rosbag::MessageInstance& m : view) {
    const auto scan = m.instantiate<sensor_msgs::LaserScan>();
    if (!scan) {
      throw std::runtime_error(topic + " carries " + m.getDataType() +
                               ", not sensor_msgs/LaserScan");
    }
    writeRows(f, ekf_slam::toScanData(*scan), scan->header.seq, scan->header.stamp.toSec(), csv,
              &c);
  }
  return c;
}

Counts fromData(const Frontend& f, const std::string& dir, std::ostream& csv) {
  namespace vp = ekf_slam::victoria_park;
  const vp::LaserScans laser = vp::loadLaser(dir);
  Counts c;
  ekf_slam::LaserScanData scan;
  scan.angle_min = -M_PI / 2;  // the same geometry as the converted bag's LaserScans
  scan.angle_increment = M_PI / 360;
  for (std::size_t i = 0; i < laser.ranges.size(); ++i) {
    scan.ranges = laser.ranges[i];
    writeRows(f, scan, static_cast<std::uint32_t>(i), laser.time_ms[i] / 1000.0, csv, &c);
  }
  return c;
}

// The extractor and the scan filters from the YAML, checked as every entry point checks it
// (app/pipeline_builder.h); --extractor replaces the file's `extractor`.
Frontend makeFrontend(const std::string& extractor, const std::string& params) {
  ekf_slam::YamlConfiguration configuration(params);
  if (!extractor.empty()) configuration.setOverride("", "extractor", extractor);
  const ekf_slam::PipelineParts parts =
      ekf_slam::buildPipeline(configuration, ekf_slam::PluginlibFactory());
  return {parts.extractor, parts.scan_filter};
}

}  // namespace

int main(int argc, char** argv) {
  std::string bag, data, out, topic = "/scan", extractor, params;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      usage(std::cout);
      return 0;
    }
    const bool known = arg == "--bag" || arg == "--data" || arg == "--out" || arg == "--topic" ||
                       arg == "--extractor" || arg == "--params";
    if (!known || i + 1 >= argc) {
      std::cerr << "detect_trees: " << (known ? "missing value for " : "unknown argument ") << arg
                << "\n";
      usage(std::cerr);
      return 2;
    }
    const std::string value = argv[++i];
    (arg == "--bag"         ? bag
     : arg == "--data"      ? data
     : arg == "--out"       ? out
     : arg == "--extractor" ? extractor
     : arg == "--params"    ? params
                            : topic) = value;
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
    const Frontend frontend = makeFrontend(extractor, params);
    ekf_slam::writeTreesCsvHeader(csv);
    c = bag.empty() ? fromData(frontend, data, csv) : fromBag(frontend, bag, topic, csv);
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
