// rostest (test/node_faults.test, issue 15): the node and the offline runner give the same map on
// the faulty window with every fault of the suite at once (fault_bags::allFaults): the bag is
// run through runOffline, then played at -r 10 into the node started by the launch file; the
// processed scans, the landmarks (ids and positions) and the fault counters must agree, and the
// node must have received every message of the bag.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "ekf_slam/LandmarkArray.h"
#include "ekf_slam/data/victoria_park.h"
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/ros/victoria_park_bag.h"
#include "fault_bags.h"
#include "offline_test_options.h"
#include "ros_test_wait.h"
#include "rosbag_play.h"
#include "test_files.h"

namespace vp = ekf_slam::victoria_park;
using test_files::waitFor;

namespace {

// landmarks.csv prints 10 significant digits (positions of up to a few hundred metres: 1e-7 m);
// both shells drive one pipeline, so the maps agree to the printed digits.
constexpr double kPositionTolerance = 1e-6;

std::size_t messages(const std::string& bag, const std::string& topic) {
  rosbag::Bag b(bag, rosbag::bagmode::Read);
  return rosbag::View(b, rosbag::TopicQuery(topic)).size();
}

// id -> (x, y) from the runner's landmarks.csv.
std::map<long, std::pair<double, double>> readLandmarks(const std::string& csv) {
  std::map<long, std::pair<double, double>> out;
  std::istringstream in(test_files::readFile(csv));
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::istringstream row(line);
    long id;
    double x, y;
    char comma;
    row >> id >> comma >> x >> comma >> y;
    out[id] = {x, y};
  }
  return out;
}

// The node's /diagnostics values, by key, over all its statuses.
std::map<std::string, std::string> values(const diagnostic_msgs::DiagnosticArray& a) {
  std::map<std::string, std::string> out;
  for (const auto& status : a.status) {
    for (const auto& kv : status.values) out[kv.key] = kv.value;
  }
  return out;
}

}  // namespace

TEST(NodeFaults, NodeAndOfflineRunnerGiveTheSameMapOnEveryFaultAtOnce) {
  const std::string data = vp::defaultDataDir();
  if (!std::ifstream(data + "/aa3_dr.mat")) {
    EKF_SLAM_SKIP_WITHOUT_DATA("Victoria Park data not found in " << data << " (set VP_DATA)");
  }
  test_files::TempDir dir("ekf_slam_node_faults");
  vp::BagOptions options;
  options.data_dir = data;
  options.out_path = dir.file("clean.bag");
  options.start_s = 20.0;
  options.end_s = 80.0;
  vp::writeVictoriaParkBag(options);
  const std::string bag = dir.file("all_faults.bag");
  fault_bags::writeFaultyBag(options.out_path, bag, fault_bags::allFaults());
  const std::size_t bag_scans = messages(bag, "/scan"), bag_odometry = messages(bag, "/odom");

  const ekf_slam::OfflineOptions offline = test_files::quietOfflineOptions(
      bag, std::string(EKF_SLAM_SOURCE_DIR) + "/config/victoria_park.yaml", dir.file("offline"));
  std::ostringstream log;
  nlohmann::json metrics;
  ASSERT_NO_THROW(metrics = nlohmann::json::parse(ekf_slam::runOffline(offline, log).metrics_json))
      << log.str();
  const auto runner_map = readLandmarks(offline.out_dir + "/landmarks.csv");
  const auto& counters = metrics.at("counters");

  ros::NodeHandle nh;
  diagnostic_msgs::DiagnosticArray diagnostics;
  ekf_slam::LandmarkArray node_map;
  ros::Subscriber diag_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10,
      [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) { diagnostics = *m; });
  ros::Subscriber map_sub = nh.subscribe<ekf_slam::LandmarkArray>(
      "/ekf_slam/map", 10, [&](const ekf_slam::LandmarkArray::ConstPtr& m) { node_map = *m; });
  ASSERT_TRUE(waitFor([&] { return map_sub.getNumPublishers() > 0; }, 20.0)) << "no node";
  {
    test_files::RosbagPlay play(bag, "10");
    ASSERT_TRUE(play.started());
    int code = 0;
    ASSERT_TRUE(waitFor([&] { return play.finished(&code); }, 30.0)) << "rosbag play hangs";
    EXPECT_EQ(code, 0) << "rosbag play failed";
  }
  // The last scans wait for odometry until the node's input timeout; diagnostics come each second.
  const std::string processed = std::to_string(metrics.at("scans").get<std::uint64_t>());
  waitFor([&] { return values(diagnostics)["scans processed"] == processed; }, 10.0);
  waitFor([&] { return node_map.landmarks.size() == runner_map.size(); }, 3.0);
  auto node = values(diagnostics);

  // The node kept up: every message of the bag arrived.
  EXPECT_EQ(node["scans received"], std::to_string(bag_scans));
  EXPECT_EQ(node["odometry received"], std::to_string(bag_odometry));
  EXPECT_EQ(node["inbox overflow drops"], "0");
  EXPECT_EQ(node["resets"], "0");

  // The same handling of every fault.
  const auto same = [&](const char* runner_key, const std::string& node_key) {
    EXPECT_EQ(node[node_key], std::to_string(counters.at(runner_key).get<std::uint64_t>()))
        << runner_key << " vs " << node_key;
  };
  EXPECT_EQ(node["scans processed"], processed);
  same("skipped_no_tf", "skipped without tf");
  same("inconsistent_scans", "inconsistent scans (angles vs beams)");
  same("duplicate_scans", "duplicate scans dropped");
  same("implausible_odometry", "implausible odometry (beyond max_speed / max_yaw_rate)");
  same("time_jumps", "time jumps");
  same("dropped_out_of_range", "out-of-range stamps dropped (one stream jumped)");
  same("rejected_updates", "rejected updates");
  // The runner counts zero stamps of both streams in one counter, the node its skipped ones
  // and the sequencer's non-finite ones.
  EXPECT_EQ(node["skipped zero stamps"],
            std::to_string(counters.at("zero_stamps").get<std::uint64_t>()));

  // The same map.
  EXPECT_EQ(node["landmarks"], std::to_string(runner_map.size()));
  ASSERT_EQ(node_map.landmarks.size(), runner_map.size());
  double max_difference = 0.0;
  for (const auto& l : node_map.landmarks) {
    const auto it = runner_map.find(l.id);
    ASSERT_NE(it, runner_map.end()) << "landmark " << l.id << " only in the node's map";
    EXPECT_NEAR(l.x, it->second.first, kPositionTolerance) << "landmark " << l.id;
    EXPECT_NEAR(l.y, it->second.second, kPositionTolerance) << "landmark " << l.id;
    max_difference = std::max(
        {max_difference, std::abs(l.x - it->second.first), std::abs(l.y - it->second.second)});
  }
  // Recorded for docs/faults.md.
  std::cout << "[node_faults] bag " << bag_scans << " scans, " << bag_odometry
            << " odometry; processed " << processed << ", landmarks " << runner_map.size()
            << "; skipped_no_tf " << counters.at("skipped_no_tf") << ", zero_stamps "
            << counters.at("zero_stamps") << ", inconsistent " << counters.at("inconsistent_scans")
            << ", duplicates " << counters.at("duplicate_scans") << ", implausible "
            << counters.at("implausible_odometry") << "; largest position difference "
            << max_difference << " m" << std::endl;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_faults");
  ros::NodeHandle nh;  // keeps the node alive across the test
  return RUN_ALL_TESTS();
}
