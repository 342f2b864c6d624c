// A user's config with `extractor: ekf_slam/BeaconExtractor` (test/data/beacons.yaml):
//  - NodeViaLaunchFile: the node, started by launch/ekf_slam.launch with that config
//    (test/node_beacons.test), maps four reflective beacons from synthetic scans with
//    intensities, each once and where it is; scans without intensities do not stop it.
//  - OfflineRunner: ekf_slam_offline with the same file on a bag of the same scans.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <sensor_msgs/LaserScan.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "beacon_scans.h"
#include "ekf_slam/LandmarkArray.h"
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ros_test_wait.h"
#include "test_files.h"

namespace {

// Beacons (radius 0.1 m) around the still vehicle, base_link = the laser's frame.
const std::vector<beacon_scans::Cylinder> kBeacons = {
    {6.0, 3.0, 0.1, 5000.0},
    {8.0, -3.0, 0.1, 5000.0},
    {12.0, 1.0, 0.1, 5000.0},
    {5.0, -6.0, 0.1, 5000.0},
    {0.5, 0.3, 0.05, 5000.0}};  // the last is on the vehicle: masked
constexpr std::size_t kMapped = 4;

sensor_msgs::LaserScan scanMessage(const ros::Time& stamp, std::uint32_t seq,
                                   bool intensities = true) {
  const ekf_slam::LaserScanData d = beacon_scans::scanOf(kBeacons);
  sensor_msgs::LaserScan m;
  m.header.stamp = stamp;
  m.header.seq = seq;
  m.header.frame_id = "base_link";
  m.angle_min = static_cast<float>(d.angle_min);
  m.angle_increment = static_cast<float>(d.angle_increment);
  m.angle_max = static_cast<float>(d.angle_min + 360 * d.angle_increment);
  m.range_min = 0.1f;
  m.range_max = 80.0f;
  m.ranges = d.ranges;
  if (intensities) m.intensities = d.intensities;
  return m;
}

nav_msgs::Odometry odometryMessage(const ros::Time& stamp, std::uint32_t seq) {
  nav_msgs::Odometry o;
  o.header.stamp = stamp;
  o.header.seq = seq;
  o.header.frame_id = "odom";
  o.child_frame_id = "base_link";
  o.pose.pose.orientation.w = 1.0;
  return o;
}

// Every beacon but the masked one mapped once, within 15 cm (the extractor's accuracy is
// test_beacon_extractor's business; this is about the configuration reaching it).
void expectBeacons(const std::vector<Eigen::Vector2d>& map) {
  ASSERT_EQ(map.size(), kMapped);
  for (std::size_t b = 0; b < kMapped; ++b) {
    const Eigen::Vector2d beacon(kBeacons[b].x, kBeacons[b].y);
    int near = 0;
    double nearest = 1e9;
    for (const Eigen::Vector2d& m : map) {
      nearest = std::min(nearest, (m - beacon).norm());
      if ((m - beacon).norm() < 0.15) ++near;
    }
    EXPECT_EQ(near, 1) << "beacon " << b << ": nearest landmark " << nearest << " m away";
  }
}

}  // namespace

TEST(BeaconConfig, NodeViaLaunchFile) {
  ros::NodeHandle nh;
  const auto odom_pub = nh.advertise<nav_msgs::Odometry>("odom", 100);
  const auto scan_pub = nh.advertise<sensor_msgs::LaserScan>("scan", 100);
  ekf_slam::LandmarkArray::ConstPtr map;
  const auto map_sub = nh.subscribe<ekf_slam::LandmarkArray>(
      "/ekf_slam/map", 10, [&map](const ekf_slam::LandmarkArray::ConstPtr& m) { map = m; });
  ASSERT_TRUE(test_files::waitFor(
      [&] { return scan_pub.getNumSubscribers() > 0 && odom_pub.getNumSubscribers() > 0; }, 20.0))
      << "the node did not subscribe";
  std::uint32_t seq = 0;
  const auto publish = [&](int scans, bool intensities) {
    for (int k = 0; k < scans; ++k, ++seq) {
      const ros::Time now = ros::Time::now();
      odom_pub.publish(odometryMessage(now, seq));
      scan_pub.publish(scanMessage(now, seq, intensities));
      ros::WallDuration(0.05).sleep();
      ros::spinOnce();
    }
  };
  publish(5, false);  // no intensities: an error per scan, the node carries on
  publish(30, true);
  ASSERT_TRUE(test_files::waitFor([&] { return map && map->landmarks.size() >= kMapped; }, 10.0))
      << "no beacon map (" << (map ? map->landmarks.size() : 0) << " landmarks)";
  std::vector<Eigen::Vector2d> positions;
  for (const auto& l : map->landmarks) positions.emplace_back(l.x, l.y);
  expectBeacons(positions);
}

TEST(BeaconConfig, OfflineRunner) {
  const test_files::TempDir dir("ekf_slam_beacons");
  const std::string bag_path = dir.file("beacons.bag");
  {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Write);
    for (std::uint32_t k = 0; k < 40; ++k) {
      const ros::Time t(1.0 + 0.1 * k);
      bag.write("/odom", t, odometryMessage(t, k));
      bag.write("/scan", t, scanMessage(t, k));
    }
  }
  ekf_slam::OfflineOptions o;
  o.bag_path = bag_path;
  o.out_dir = dir.file("out");
  o.params_path = std::string(EKF_SLAM_TEST_DATA) + "/beacons.yaml";
  std::ostringstream log;
  const ekf_slam::OfflineSummary s = ekf_slam::runOffline(o, log);
  EXPECT_EQ(s.scans, 40u);
  std::vector<Eigen::Vector2d> positions;
  for (const auto& [x, y] : test_files::landmarkPositions(o.out_dir + "/landmarks.csv"))
    positions.emplace_back(x, y);
  expectBeacons(positions);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_beacons");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
