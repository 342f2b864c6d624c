// rostest: a converted window played with `rosbag play` delivers /scan, /odom and the latched
// base_link -> laser transform.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <signal.h>
#include <sys/wait.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "ekf_slam/data/victoria_park.h"
#include "ekf_slam/ros/victoria_park_bag.h"
#include "test_files.h"

namespace vp = ekf_slam::victoria_park;
namespace fs = std::filesystem;

namespace {

// `rosbag play` as a child process in its own process group (it starts no children, but a group
// makes the cleanup independent of that).
class RosbagPlay {
 public:
  explicit RosbagPlay(const std::string& bag) {
    pid_ = fork();
    if (pid_ == 0) {
      setpgid(0, 0);
      // Debian's python must come first (ROS_ON_DEBIAN.md, pitfall 1).
      const char* path = std::getenv("PATH");
      setenv("PATH", (std::string("/usr/bin:") + (path ? path : "")).c_str(), 1);
      // -d: give our subscribers time to connect before the first message.
      execlp("rosbag", "rosbag", "play", "-q", "-d", "1", bag.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~RosbagPlay() {
    if (pid_ <= 0) return;
    kill(-pid_, SIGINT);
    kill(pid_, SIGINT);
    for (int i = 0; i < 50; ++i) {
      if (waitpid(pid_, nullptr, WNOHANG) == pid_) return;
      usleep(100000);
    }
    kill(-pid_, SIGKILL);
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  bool started() const { return pid_ > 0; }
  bool exitedWithError() {
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) != pid_) return false;
    const bool error = !WIFEXITED(status) || WEXITSTATUS(status) != 0;
    pid_ = -1;
    return error;
  }

 private:
  pid_t pid_ = -1;
};

}  // namespace

TEST(PlayBag, ScanOdomAndStaticTransformArrive) {
  vp::BagOptions options;
  options.data_dir = vp::defaultDataDir();
  if (!fs::exists(fs::path(options.data_dir) / "aa3_dr.mat")) {
    EKF_SLAM_SKIP_WITHOUT_DATA("Victoria Park data not found in " << options.data_dir
                                                                  << " (set VP_DATA)");
  }
  std::string templ = (fs::temp_directory_path() / "ekf_slam_play_XXXXXX").string();
  ASSERT_NE(mkdtemp(templ.data()), nullptr);
  const fs::path tmp(templ);
  options.out_path = (tmp / "window.bag").string();
  options.start_s = 100.0;
  options.end_s = 108.0;
  const vp::BagCounts counts = vp::writeVictoriaParkBag(options);
  ASSERT_GT(counts.scans, 10u);

  ros::NodeHandle nh;
  int scans = 0, odoms = 0;
  sensor_msgs::LaserScan last_scan;
  ros::Subscriber scan_sub = nh.subscribe<sensor_msgs::LaserScan>(
      "/scan", 100, [&](const sensor_msgs::LaserScan::ConstPtr& m) {
        ++scans;
        last_scan = *m;
      });
  ros::Subscriber odom_sub = nh.subscribe<nav_msgs::Odometry>(
      "/odom", 1000, [&](const nav_msgs::Odometry::ConstPtr&) { ++odoms; });
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);

  bool have_tf = false;
  geometry_msgs::TransformStamped tf;
  {
    RosbagPlay play(options.out_path);
    ASSERT_TRUE(play.started());
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(20.0);
    while (ros::ok() && ros::WallTime::now() < deadline &&
           !(scans >= 3 && odoms >= 20 && have_tf)) {
      ros::spinOnce();
      if (!have_tf && buffer.canTransform("base_link", "laser", ros::Time(0))) {
        tf = buffer.lookupTransform("base_link", "laser", ros::Time(0));
        have_tf = true;
      }
      ASSERT_FALSE(play.exitedWithError()) << "rosbag play failed";
      ros::WallDuration(0.01).sleep();
    }
  }
  fs::remove_all(tmp);

  EXPECT_GE(scans, 3);
  EXPECT_GE(odoms, 20);
  ASSERT_TRUE(have_tf) << "no base_link -> laser transform";
  EXPECT_DOUBLE_EQ(tf.transform.translation.x, 3.78);
  EXPECT_DOUBLE_EQ(tf.transform.translation.y, 0.5);
  EXPECT_DOUBLE_EQ(tf.transform.rotation.w, 1.0);
  if (scans > 0) {
    EXPECT_EQ(last_scan.header.frame_id, "laser");
    EXPECT_EQ(last_scan.ranges.size(), 361u);
    EXPECT_GE(last_scan.header.seq, 300u);  // the data set's scan index survives playback
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_play_bag");
  ros::NodeHandle nh;  // keeps the node alive across the test
  return RUN_ALL_TESTS();
}
