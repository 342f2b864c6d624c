// rostests of the ekf_slam node (test/node.test, test/node_bad_input.test):
//  - VictoriaPark.*: the node, started by the launch file with the associator given there, is fed
//    a converted Victoria Park window by `rosbag play --clock`; it must publish pose, path,
//    markers, map, association reports (naming that associator) and map -> odom, all finite, and
//    process every scan of the window.
//  - BadInput.*: NaN / inf / empty scans, bad angles, late, zero and unknown-frame stamps, bad
//    observations: the node keeps running, reports every processed input and stays finite;
//    services work; an unknown associator name makes the node exit non-zero listing the names.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <signal.h>
#include <std_srvs/Empty.h>
#include <std_srvs/Trigger.h>
#include <sys/wait.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <unistd.h>
#include <visualization_msgs/MarkerArray.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <utility>

#include "ekf_slam/AssociationStats.h"
#include "ekf_slam/LandmarkArray.h"
#include "ekf_slam/LandmarkObservationArray.h"
#include "ekf_slam/LoadMap.h"
#include "ekf_slam/SaveMap.h"
#include "ekf_slam/data/victoria_park.h"
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/ros/victoria_park_bag.h"
#include "offline_test_options.h"
#include "ros_test_wait.h"
#include "rosbag_play.h"
#include "test_files.h"

namespace vp = ekf_slam::victoria_park;
namespace fs = std::filesystem;
using test_files::readFile;
using test_files::RosbagPlay;
using test_files::waitFor;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool finite(const geometry_msgs::Pose& p) {
  return std::isfinite(p.position.x) && std::isfinite(p.position.y) &&
         std::isfinite(p.orientation.z) && std::isfinite(p.orientation.w);
}

bool finite(const geometry_msgs::PoseWithCovarianceStamped& m) {
  if (!finite(m.pose.pose)) return false;
  for (double c : m.pose.covariance) {
    if (!std::isfinite(c)) return false;
  }
  return m.pose.covariance[0] >= 0.0 && m.pose.covariance[7] >= 0.0 && m.pose.covariance[35] >= 0.0;
}

// Everything the node publishes, with counts and the last message of each kind.
struct NodeOutputs {
  explicit NodeOutputs(ros::NodeHandle& nh) {
    pose = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
        "/ekf_slam/pose", 1000,
        [this](const geometry_msgs::PoseWithCovarianceStamped::ConstPtr& m) {
          ++poses;
          all_poses_finite = all_poses_finite && finite(*m);
          last_pose = *m;
          const auto& q = m->pose.pose.orientation;
          trajectory.push_back(
              {m->header.stamp.toSec(), m->pose.pose.position.x, m->pose.pose.position.y,
               std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))});
        });
    path = nh.subscribe<nav_msgs::Path>("/ekf_slam/path", 10,
                                        [this](const nav_msgs::Path::ConstPtr& m) {
                                          ++paths;
                                          last_path = *m;
                                        });
    markers = nh.subscribe<visualization_msgs::MarkerArray>(
        "/ekf_slam/landmarks", 10, [this](const visualization_msgs::MarkerArray::ConstPtr& m) {
          ++marker_arrays;
          for (const auto& mk : m->markers) {
            if (mk.ns == "landmarks" && mk.action == visualization_msgs::Marker::ADD) {
              ++landmark_markers;
              all_markers_finite = all_markers_finite && finite(mk.pose) &&
                                   std::isfinite(mk.scale.x) && mk.scale.x > 0.0;
            }
          }
        });
    map = nh.subscribe<ekf_slam::LandmarkArray>("/ekf_slam/map", 10,
                                                [this](const ekf_slam::LandmarkArray::ConstPtr& m) {
                                                  ++maps;
                                                  last_map = *m;
                                                });
    stats = nh.subscribe<ekf_slam::AssociationStats>(
        "/ekf_slam/associations", 1000, [this](const ekf_slam::AssociationStats::ConstPtr& m) {
          ++associations;
          last_stats = *m;
          associators_seen.insert(m->associator);
          for (auto d : m->decision) {
            if (d == ekf_slam::AssociationStats::PAIRED) ++paired;
            if (d == ekf_slam::AssociationStats::NEW) ++added;
          }
          for (const auto& o : m->observations) {
            observations_finite =
                observations_finite && std::isfinite(o.range) && std::isfinite(o.bearing);
          }
        });
  }
  /// All publishers of the node connected (it publishes only to subscribers).
  bool connected() const {
    return pose.getNumPublishers() > 0 && path.getNumPublishers() > 0 &&
           markers.getNumPublishers() > 0 && map.getNumPublishers() > 0 &&
           stats.getNumPublishers() > 0;
  }

  ros::Subscriber pose, path, markers, map, stats;
  int poses = 0, paths = 0, marker_arrays = 0, landmark_markers = 0, maps = 0, associations = 0;
  int paired = 0, added = 0;
  bool all_poses_finite = true, all_markers_finite = true, observations_finite = true;
  std::set<std::string> associators_seen;
  geometry_msgs::PoseWithCovarianceStamped last_pose;
  std::vector<std::array<double, 4>> trajectory;  ///< stamp, x, y, yaw of every ~pose
  nav_msgs::Path last_path;
  ekf_slam::LandmarkArray last_map;
  ekf_slam::AssociationStats last_stats;
};

}  // namespace

TEST(VictoriaPark, NodePublishesEverything) {
  ros::NodeHandle nh, pnh("~");
  std::string associator;
  ASSERT_TRUE(pnh.getParam("associator", associator)) << "the launch file sets ~associator";

  vp::BagOptions options;
  options.data_dir = vp::defaultDataDir();
  if (!fs::exists(fs::path(options.data_dir) / "aa3_dr.mat")) {
    EKF_SLAM_SKIP_WITHOUT_DATA("Victoria Park data not found in " << options.data_dir
                                                                  << " (set VP_DATA)");
  }
  std::string templ = (fs::temp_directory_path() / "ekf_slam_node_XXXXXX").string();
  ASSERT_NE(mkdtemp(templ.data()), nullptr);
  const fs::path tmp(templ);
  options.out_path = (tmp / "window.bag").string();
  options.start_s = 100.0;
  options.end_s = 115.0;
  const vp::BagCounts counts = vp::writeVictoriaParkBag(options);
  ASSERT_GT(counts.scans, 30u);

  NodeOutputs out(nh);
  ASSERT_TRUE(waitFor([&] { return out.connected(); }, 20.0)) << "node outputs not advertised";
  diagnostic_msgs::DiagnosticArray last_diagnostics;
  int diagnostics = 0;
  ros::Subscriber diag_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
        ++diagnostics;
        last_diagnostics = *m;
      });

  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  bool have_map_odom = false;
  geometry_msgs::TransformStamped map_odom;
  {
    RosbagPlay play(options.out_path, "3");
    ASSERT_TRUE(play.started());
    int code = 0;
    const bool done = waitFor([&] { return play.finished(&code); }, 40.0);
    ASSERT_TRUE(done) << "rosbag play did not finish";
    EXPECT_EQ(code, 0) << "rosbag play failed";
    // The last scans wait for later odometry; the node processes them after its input timeout.
    waitFor([&] { return out.associations >= static_cast<int>(counts.scans); }, 10.0);
    // Markers and the path come at the visualisation rate: wait for a set with the final map.
    waitFor([&] { return out.marker_arrays > 0 && out.paths > 0 && out.maps > 0; }, 5.0);
    try {
      map_odom = buffer.lookupTransform("map", "odom", ros::Time(0));
      have_map_odom = true;
    } catch (const tf2::TransformException& e) {
      ADD_FAILURE() << "no map -> odom: " << e.what();
    }
    // The transform is republished on a timer, stamped ahead: a lookup at now() succeeds after
    // the scans stopped (gmapping's and slam_toolbox's contract).
    std::string why;
    EXPECT_TRUE(buffer.canTransform("map", "odom", ros::Time::now(), ros::Duration(2.0), &why))
        << why;
  }

  // A subscriber that comes after the run gets the current map, landmarks and path: the
  // outputs are latched and published whoever listens.
  {
    int late_maps = 0, late_markers = 0, late_paths = 0;
    std::size_t late_map_size = 0, late_path_size = 0;
    ros::Subscriber m = nh.subscribe<ekf_slam::LandmarkArray>(
        "/ekf_slam/map", 1, [&](const ekf_slam::LandmarkArray::ConstPtr& msg) {
          ++late_maps;
          late_map_size = msg->landmarks.size();
        });
    ros::Subscriber k = nh.subscribe<visualization_msgs::MarkerArray>(
        "/ekf_slam/landmarks", 1,
        [&](const visualization_msgs::MarkerArray::ConstPtr&) { ++late_markers; });
    ros::Subscriber p =
        nh.subscribe<nav_msgs::Path>("/ekf_slam/path", 1, [&](const nav_msgs::Path::ConstPtr& msg) {
          ++late_paths;
          late_path_size = msg->poses.size();
        });
    EXPECT_TRUE(waitFor([&] { return late_maps > 0 && late_markers > 0 && late_paths > 0; }, 5.0))
        << "late subscriber: " << late_maps << " maps, " << late_markers << " marker arrays, "
        << late_paths << " paths";
    EXPECT_EQ(late_map_size, out.last_stats.landmarks);
    EXPECT_EQ(late_path_size, static_cast<std::size_t>(out.associations));
  }

  // /diagnostics: the node reports its inputs, and nothing was lost at this rate. Reports come
  // every second: wait for one made after the last input.
  const auto inputs_value = [&](const std::string& key) {
    for (const auto& status : last_diagnostics.status) {
      if (status.name.find("inputs") == std::string::npos) continue;
      for (const auto& kv : status.values) {
        if (kv.key == key) return kv.value;
      }
    }
    return std::string();
  };
  ASSERT_TRUE(waitFor([&] { return diagnostics > 0; }, 3.0)) << "no /diagnostics";
  waitFor(
      [&] {
        return inputs_value("scans received") == std::to_string(counts.scans) &&
               inputs_value("odometry received") == std::to_string(counts.odometry);
      },
      3.0);
  bool saw_inputs = false;
  for (const auto& status : last_diagnostics.status) {
    if (status.name.find("inputs") == std::string::npos) continue;
    saw_inputs = true;
    EXPECT_EQ(status.level, diagnostic_msgs::DiagnosticStatus::OK) << status.message;
    for (const auto& kv : status.values) {
      if (kv.key.find("missing") != std::string::npos) {
        EXPECT_EQ(kv.value, "0") << kv.key;
      }
      if (kv.key == "scans received") {
        EXPECT_EQ(kv.value, std::to_string(counts.scans));
      }
      if (kv.key == "odometry received") {
        EXPECT_EQ(kv.value, std::to_string(counts.odometry));
      }
    }
  }
  EXPECT_TRUE(saw_inputs);

  // The offline runner on the same bag, with the same parameters, gives the same trajectory:
  // both shells drive one pipeline through one sequencer.
  ekf_slam::OfflineOptions offline = test_files::quietOfflineOptions(
      options.out_path, std::string(EKF_SLAM_SOURCE_DIR) + "/config/victoria_park.yaml",
      (tmp / "offline").string());
  offline.associator = associator;
  std::ostringstream offline_log;
  ASSERT_NO_THROW(ekf_slam::runOffline(offline, offline_log)) << offline_log.str();
  std::ifstream csv(offline.out_dir + "/trajectory.csv");
  std::string line;
  std::getline(csv, line);  // header
  std::vector<std::array<double, 4>> offline_trajectory;
  while (std::getline(csv, line)) {
    std::array<double, 4> row{};
    char comma;
    std::istringstream in(line);
    in >> row[0] >> comma >> row[1] >> comma >> row[2] >> comma >> row[3];
    offline_trajectory.push_back(row);
  }
  fs::remove_all(tmp);
  ASSERT_EQ(out.trajectory.size(), offline_trajectory.size());
  for (std::size_t k = 0; k < offline_trajectory.size(); ++k) {
    EXPECT_NEAR(out.trajectory[k][0], offline_trajectory[k][0], 1e-6) << "stamp of scan " << k;
    EXPECT_NEAR(out.trajectory[k][1], offline_trajectory[k][1], 1e-6) << "x of scan " << k;
    EXPECT_NEAR(out.trajectory[k][2], offline_trajectory[k][2], 1e-6) << "y of scan " << k;
    EXPECT_NEAR(std::remainder(out.trajectory[k][3] - offline_trajectory[k][3], 2 * M_PI), 0.0,
                1e-6)
        << "yaw of scan " << k;
  }

  // Every scan of the window is processed and reported, by the plugin asked for.
  EXPECT_EQ(out.associations, static_cast<int>(counts.scans));
  ASSERT_EQ(out.associators_seen.size(), 1u);
  EXPECT_EQ(*out.associators_seen.begin(), associator);
  EXPECT_GT(out.added, 3) << "no landmarks initialised";
  EXPECT_GT(out.paired, 10) << "landmarks never re-observed";
  EXPECT_TRUE(out.observations_finite);
  EXPECT_EQ(out.last_stats.scan + 1, static_cast<unsigned>(out.associations));

  EXPECT_EQ(out.poses, out.associations);
  EXPECT_TRUE(out.all_poses_finite);
  EXPECT_EQ(out.last_pose.header.frame_id, "map");

  ASSERT_GT(out.paths, 0);
  EXPECT_EQ(out.last_path.header.frame_id, "map");
  EXPECT_GT(out.last_path.poses.size(), counts.scans / 2);
  for (const auto& p : out.last_path.poses) ASSERT_TRUE(finite(p.pose));

  EXPECT_GT(out.marker_arrays, 0);
  EXPECT_GT(out.landmark_markers, 0);
  EXPECT_TRUE(out.all_markers_finite);

  ASSERT_GT(out.maps, 0);
  EXPECT_EQ(out.last_map.header.frame_id, "map");
  EXPECT_GT(out.last_map.landmarks.size(), 3u);
  EXPECT_EQ(out.last_map.landmarks.size(), out.last_stats.landmarks);
  for (const auto& lm : out.last_map.landmarks) {
    ASSERT_TRUE(std::isfinite(lm.x) && std::isfinite(lm.y));
    ASSERT_GT(lm.covariance[0], 0.0);
    ASSERT_GT(lm.covariance[3], 0.0);
  }

  // The vehicle drives through the window: the estimate moves with the odometry.
  ASSERT_TRUE(have_map_odom);
  EXPECT_TRUE(std::isfinite(map_odom.transform.translation.x));
  EXPECT_TRUE(std::isfinite(map_odom.transform.rotation.w));
  if (out.last_path.poses.size() > 2) {
    const auto& a = out.last_path.poses.front().pose.position;
    const auto& b = out.last_path.poses.back().pose.position;
    EXPECT_GT(std::hypot(b.x - a.x, b.y - a.y), 5.0) << "the pose did not follow the drive";
  }
}

// --- bad input ------------------------------------------------------------------------------

class BadInput : public testing::Test {
 protected:
  void SetUp() override {
    scan_pub_ = nh_.advertise<sensor_msgs::LaserScan>("/scan", 100);
    odom_pub_ = nh_.advertise<nav_msgs::Odometry>("/odom", 100);
    obs_pub_ = nh_.advertise<ekf_slam::LandmarkObservationArray>("/observations", 100);
    ASSERT_TRUE(waitFor(
        [&] {
          return scan_pub_.getNumSubscribers() > 0 && odom_pub_.getNumSubscribers() > 0 &&
                 obs_pub_.getNumSubscribers() > 0;
        },
        20.0))
        << "the node does not subscribe to scan / odom / observations";
    t0_ = ros::Time::now();
  }

  void odom(double t) {
    nav_msgs::Odometry m;
    m.header.stamp = t0_ + ros::Duration(t);
    m.header.frame_id = "odom";
    m.child_frame_id = "base_link";
    m.pose.pose.position.x = t;  // 1 m/s straight ahead
    m.pose.pose.orientation.w = 1.0;
    m.twist.twist.linear.x = 1.0;
    odom_pub_.publish(m);
  }

  // A scan in base_link (no tf needed) seeing two "trunks" in front of a far wall.
  sensor_msgs::LaserScan scan(double t, const std::string& frame = "base_link") {
    sensor_msgs::LaserScan m;
    m.header.stamp = t0_ + ros::Duration(t);
    m.header.frame_id = frame;
    m.angle_min = -M_PI / 2;
    m.angle_increment = M_PI / 360;
    m.angle_max = M_PI / 2;
    m.range_min = 0.1;
    m.range_max = 80.0;
    m.ranges.assign(361, 40.0f);
    for (int b = 170; b < 174; ++b) m.ranges[b] = 10.0f;
    for (int b = 220; b < 226; ++b) m.ranges[b] = 8.0f;
    return m;
  }

  ros::NodeHandle nh_;
  ros::Publisher scan_pub_, odom_pub_, obs_pub_;
  ros::Time t0_;
};

TEST_F(BadInput, NodeKeepsRunningAndStaysFinite) {
  NodeOutputs out(nh_);
  ASSERT_TRUE(waitFor([&] { return out.connected(); }, 20.0));
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();

  int expected = 0;  // inputs the node must process and report
  auto send = [&](const sensor_msgs::LaserScan& s, bool counts) {
    scan_pub_.publish(s);
    if (counts) ++expected;
    ros::WallDuration(0.02).sleep();
    ros::spinOnce();
  };
  double t = 0.0;
  for (int k = 0; k < 5; ++k, t += 0.1) {
    odom(t);
    send(scan(t + 0.05), true);
  }
  {  // NaN and inf ranges
    odom(t);
    auto s = scan(t + 0.05);
    for (int b = 0; b < 361; b += 3) s.ranges[b] = nan;
    for (int b = 1; b < 361; b += 3) s.ranges[b] = inf;
    for (int b = 2; b < 361; b += 7) s.ranges[b] = -inf;
    send(s, true);
    t += 0.1;
  }
  {  // all NaN
    odom(t);
    auto s = scan(t + 0.05);
    s.ranges.assign(361, nan);
    send(s, true);
    t += 0.1;
  }
  {  // empty
    odom(t);
    auto s = scan(t + 0.05);
    s.ranges.clear();
    send(s, true);
    t += 0.1;
  }
  {  // non-finite angles
    odom(t);
    auto s = scan(t + 0.05);
    s.angle_increment = nan;
    send(s, true);
    t += 0.1;
  }
  {  // late: older than what the node already used (but no jump back in time)
    odom(t);
    send(scan(t - 0.35), true);
    t += 0.1;
  }
  {  // zero stamp: skipped with a warning (it would read as a jump back in time)
    auto s = scan(0.0);
    s.header.stamp = ros::Time(0);
    send(s, false);
  }
  {  // unknown sensor frame: no tf, skipped with a warning
    odom(t);
    send(scan(t + 0.05, "no_such_frame"), false);
    t += 0.1;
  }
  {  // external observations: one NaN, one without covariance, one inf covariance
    odom(t);
    ekf_slam::LandmarkObservationArray o;
    o.header.stamp = t0_ + ros::Duration(t + 0.05);
    o.header.frame_id = "base_link";
    o.observations.resize(3);
    o.observations[0].range = kNaN;
    o.observations[0].bearing = 0.1;
    o.observations[1].range = 12.0;
    o.observations[1].bearing = 0.2;
    o.observations[1].descriptor = kNaN;
    o.observations[2].range = 9.0;
    o.observations[2].bearing = -0.2;
    o.observations[2].covariance = {std::numeric_limits<double>::infinity(), 0, 0, 1e-4};
    obs_pub_.publish(o);
    ++expected;
    ros::WallDuration(0.02).sleep();
    t += 0.1;
  }
  for (int k = 0; k < 5; ++k, t += 0.1) {
    odom(t);
    send(scan(t + 0.05), true);
  }
  odom(t + 0.2);  // releases the last scan

  EXPECT_TRUE(waitFor([&] { return out.associations >= expected; }, 10.0))
      << out.associations << " of " << expected << " inputs reported";
  waitFor([&] { return out.maps > 0; }, 2.0);
  EXPECT_EQ(out.associations, expected);
  EXPECT_EQ(out.poses, expected);
  EXPECT_TRUE(out.all_poses_finite);
  EXPECT_TRUE(out.all_markers_finite);
  EXPECT_TRUE(out.observations_finite) << "a non-finite observation reached the report";
  EXPECT_TRUE(finite(out.last_pose));
  // 1 m/s for about 1.6 s along x.
  EXPECT_GT(out.last_pose.pose.pose.position.x, 0.5);
  EXPECT_LT(out.last_pose.pose.pose.position.x, 3.0);
  for (const auto& lm : out.last_map.landmarks) {
    EXPECT_TRUE(std::isfinite(lm.x) && std::isfinite(lm.y));
  }

  // Still alive: the services answer.
  std_srvs::Empty reset;
  EXPECT_TRUE(ros::service::waitForService("/ekf_slam/reset", ros::Duration(5.0)));
  EXPECT_TRUE(ros::service::call("/ekf_slam/reset", reset));
}

// ~relocalise needs recovery on: with `relocaliser: ""` (this node) it says so; a second node
// started with the defaults (recovery on, issue 34) succeeds and reports the lost state on
// /diagnostics.
TEST_F(BadInput, RelocaliseService) {
  std_srvs::Trigger none;
  ASSERT_TRUE(ros::service::call("/ekf_slam/relocalise", none));
  EXPECT_FALSE(none.response.success);
  EXPECT_NE(none.response.message.find("relocaliser"), std::string::npos) << none.response.message;

  const pid_t pid = fork();
  if (pid == 0) {
    execl(EKF_SLAM_NODE_BIN, EKF_SLAM_NODE_BIN, "__name:=ekf_slam_reloc", "odom:=/unused_odom",
          "scan:=/unused_scan", "observations:=/unused_observations", static_cast<char*>(nullptr));
    _exit(127);
  }
  ASSERT_GT(pid, 0);
  std::string lost_state;
  ros::Subscriber diag = nh_.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& m) {
        for (const auto& st : m->status) {
          if (st.name == "/ekf_slam_reloc: processing") lost_state = st.message;
        }
      });
  const bool up = ros::service::waitForService("/ekf_slam_reloc/relocalise", ros::Duration(20.0));
  std_srvs::Trigger trigger;
  const bool called = up && ros::service::call("/ekf_slam_reloc/relocalise", trigger);
  const bool reported = waitFor([&] { return lost_state.find("LOST") != std::string::npos; }, 5.0);
  kill(pid, SIGINT);
  waitpid(pid, nullptr, 0);
  ASSERT_TRUE(up) << "the node with the default recovery did not start";
  ASSERT_TRUE(called);
  EXPECT_TRUE(trigger.response.success) << trigger.response.message;
  EXPECT_TRUE(reported) << "diagnostics: '" << lost_state << "'";
}

TEST_F(BadInput, SaveAndLoadMap) {
  // Build a small map, save it, reset, load it back.
  double t = 100.0;  // after the previous test's inputs, which the reset left behind
  for (int k = 0; k < 3; ++k, t += 0.1) {
    odom(t);
    scan_pub_.publish(scan(t + 0.05));
    ros::WallDuration(0.02).sleep();
  }
  odom(t + 0.2);
  ros::WallDuration(0.5).sleep();

  const std::string path = (fs::temp_directory_path() / "ekf_slam_test_node_map.txt").string();
  ekf_slam::SaveMap save;
  save.request.path = path;
  ASSERT_TRUE(ros::service::call("/ekf_slam/save_map", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  EXPECT_TRUE(fs::exists(path));

  ekf_slam::SaveMap no_path;  // neither a path nor ~map_file: a clear failure
  ASSERT_TRUE(ros::service::call("/ekf_slam/save_map", no_path));
  EXPECT_FALSE(no_path.response.success);
  EXPECT_NE(no_path.response.message.find("map_file"), std::string::npos);

  ekf_slam::LoadMap load;
  load.request.path = path;
  load.request.reset_pose = true;
  ASSERT_TRUE(ros::service::call("/ekf_slam/load_map", load));
  EXPECT_TRUE(load.response.success) << load.response.message;

  ekf_slam::LoadMap missing;
  missing.request.path = path + ".does_not_exist";
  ASSERT_TRUE(ros::service::call("/ekf_slam/load_map", missing));
  EXPECT_FALSE(missing.response.success);
  EXPECT_NE(missing.response.message.find(".does_not_exist"), std::string::npos);
  fs::remove(path);
}

TEST(UnknownAssociator, ExitsNonZeroListingTheAvailableOnes) {
  const std::string log = (fs::temp_directory_path() / "ekf_slam_test_node_bad_name.log").string();
  // Its own name, so that it does not replace the node under test; the master is rostest's.
  const std::string cmd = std::string("'") + EKF_SLAM_NODE_BIN +
                          "' __name:=ekf_slam_bad_name _associator:=ekf_slam/NoSuchThing > '" +
                          log + "' 2>&1";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_NE(WEXITSTATUS(status), 0);
  const std::string text = readFile(log);
  EXPECT_NE(text.find("NoSuchThing"), std::string::npos) << text;
  for (const char* name :
       {"ekf_slam/DJNN", "ekf_slam/NN", "ekf_slam/JCBB", "ekf_slam/NNJCBB", "ekf_slam/Hungarian"}) {
    EXPECT_NE(text.find(name), std::string::npos) << "missing " << name << " in:\n" << text;
  }
  fs::remove(log);
}

// A misspelt parameter stops the node with the name it probably meant.
TEST(UnknownParameter, ExitsNonZeroNamingTheNearestName) {
  const std::string log = (fs::temp_directory_path() / "ekf_slam_test_node_misspelt.log").string();
  const std::string cmd = std::string("'") + EKF_SLAM_NODE_BIN +
                          "' __name:=ekf_slam_misspelt _sigma_rnage:=0.4 > '" + log + "' 2>&1";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_NE(WEXITSTATUS(status), 0);
  const std::string text = readFile(log);
  EXPECT_NE(text.find("sigma_rnage (did you mean sigma_range?)"), std::string::npos) << text;
  fs::remove(log);
}

// ... and so does one in any plugin's section (~DJNN/, ~TreeExtractor/, ~FGCBB/), the same error
// as every other entry point gives (app/pipeline_builder.h, test_entry_points.cpp).
TEST(UnknownParameter, InAnyPluginSectionExitsNonZeroNamingIt) {
  const std::string log = (fs::temp_directory_path() / "ekf_slam_test_node_section.log").string();
  const std::pair<const char*, const char*> cases[] = {
      {"_DJNN/individual_probabilty:=0.9",
       "/ekf_slam_section/DJNN/individual_probabilty (did you mean individual_probability?)"},
      {"_TreeExtractor/range_jmp:=1.0",
       "/ekf_slam_section/TreeExtractor/range_jmp (did you mean range_jump?)"},
      {"_relocaliser:=ekf_slam/FGCBB _FGCBB/sensor_rnage:=20",
       "/ekf_slam_section/FGCBB/sensor_rnage (did you mean sensor_range?)"},
  };
  for (const auto& [args, expected] : cases) {
    const std::string cmd = std::string("'") + EKF_SLAM_NODE_BIN + "' __name:=ekf_slam_section " +
                            args + " > '" + log + "' 2>&1";
    const int status = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_NE(WEXITSTATUS(status), 0) << args;
    const std::string text = readFile(log);
    EXPECT_NE(text.find(expected), std::string::npos) << args << ":\n" << text;
    // The parameters stay on the server: clear them for the next case.
    ros::param::del("/ekf_slam_section");
  }
  fs::remove(log);
}

// A frame with two parents breaks every tf consumer: such a configuration does not start.
TEST(TwoParents, MapToBaseWithOdomTfIsRefused) {
  const std::string log = (fs::temp_directory_path() / "ekf_slam_test_node_parents.log").string();
  const std::string cmd = std::string("'") + EKF_SLAM_NODE_BIN +
                          "' __name:=ekf_slam_two_parents _publish_map_to_base:=true "
                          "_publish_odom_tf:=true > '" +
                          log + "' 2>&1";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_NE(WEXITSTATUS(status), 0);
  const std::string text = readFile(log);
  EXPECT_NE(text.find("two parents"), std::string::npos) << text;
  fs::remove(log);
}

// hold_odom_tf (victoria_park.launch): once the odometry stops, odom -> base_link stays in tf at
// later stamps with the last pose, so that rviz started after a replay has the vehicle's frames.
// The second node (node_hold_tf.test: frames odom_b -> base_b, without hold_odom_tf) shows that
// otherwise the transform ends with the last message.
TEST(HoldOdomTf, LastOdometryPoseStaysAfterTheOdometryStops) {
  ros::NodeHandle nh;
  ros::Publisher held = nh.advertise<nav_msgs::Odometry>("/odom", 10);
  ros::Publisher plain = nh.advertise<nav_msgs::Odometry>("/odom_b", 10);
  ASSERT_TRUE(
      waitFor([&] { return held.getNumSubscribers() > 0 && plain.getNumSubscribers() > 0; }, 20.0));
  tf2_ros::Buffer buffer;  // before the messages: tf is not latched
  tf2_ros::TransformListener listener(buffer);
  ros::WallDuration(0.5).sleep();
  const ros::Time t0 = ros::Time::now();
  for (int k = 0; k <= 4; ++k) {
    nav_msgs::Odometry m;
    m.header.stamp = t0 + ros::Duration(0.1 * k);
    m.pose.pose.position.x = 0.1 * k;
    m.pose.pose.orientation.w = 1.0;
    m.twist.twist.linear.x = 1.0;
    m.header.frame_id = "odom";
    m.child_frame_id = "base_link";
    held.publish(m);
    m.header.frame_id = "odom_b";
    m.child_frame_id = "base_b";
    plain.publish(m);
    ros::WallDuration(0.1).sleep();
  }
  const ros::Time last = t0 + ros::Duration(0.4);
  const ros::Time later = last + ros::Duration(2.0);  // input_timeout is 0.5 s
  ASSERT_TRUE(waitFor([&] { return buffer.canTransform("odom", "base_link", later); }, 10.0))
      << "odom -> base_link not held after the odometry stopped";
  EXPECT_NEAR(buffer.lookupTransform("odom", "base_link", later).transform.translation.x, 0.4,
              1e-9);
  EXPECT_TRUE(buffer.canTransform("odom_b", "base_b", last));
  EXPECT_FALSE(buffer.canTransform("odom_b", "base_b", later));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
