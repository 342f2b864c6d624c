// Victoria Park reader and bag converter. Tests that need the data set skip when it is absent.
#include <geometry_msgs/PointStamped.h>
#include <gtest/gtest.h>
#include <matio.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "ekf_slam/data/victoria_park.h"
#include "ekf_slam/ros/victoria_park_bag.h"
#include "test_files.h"

namespace test_victoria_park {

namespace vp = ekf_slam::victoria_park;
namespace fs = std::filesystem;

using test_files::TempDir;

constexpr double kL = 2.83;
constexpr double kH = 0.76;

void writeText(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// A MAT file with the given double column vectors (for malformed-file tests).
void writeMat(const std::string& path, const std::map<std::string, std::vector<double>>& vars) {
  mat_t* mat = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT5);
  ASSERT_NE(mat, nullptr);
  for (const auto& [name, values] : vars) {
    size_t dims[2] = {values.size(), 1};
    std::vector<double> copy = values;
    matvar_t* v = Mat_VarCreate(name.c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, copy.data(), 0);
    ASSERT_NE(v, nullptr);
    Mat_VarWrite(mat, v, MAT_COMPRESSION_NONE);
    Mat_VarFree(v);
  }
  Mat_Close(mat);
}

// Runs fn, which must throw std::runtime_error whose message contains every one of parts.
template <typename Fn>
void expectErrorMentioning(Fn fn, const std::vector<std::string>& parts) {
  try {
    fn();
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    for (const std::string& p : parts) {
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos)
          << "message '" << e.what() << "' lacks '" << p << "'";
    }
  }
}

std::string laserText(int scans, int extra_values) {
  std::string s;
  for (int i = 0; i < scans; ++i) {
    s += std::to_string(0.852 + 0.2 * i) + "\t";
    for (int b = 0; b < vp::kBeams; ++b) s += (b % 7 == 0 ? "81.91\t" : "12.34\t");
  }
  for (int i = 0; i < extra_values; ++i) s += "1.0\t";
  return s;
}

class WithData : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = vp::defaultDataDir();
    if (!fs::exists(fs::path(dir_) / "aa3_dr.mat")) {
      EKF_SLAM_SKIP_WITHOUT_DATA("Victoria Park data not found in " << dir_ << " (set VP_DATA)");
    }
  }
  std::string dir_;
};

// --------------------------------------------------------------------------------------------
// Loading

TEST_F(WithData, LoadsDeadReckoning) {
  const vp::DeadReckoning dr = vp::loadDeadReckoning(dir_);
  ASSERT_EQ(dr.time_ms.size(), 61945u);
  ASSERT_EQ(dr.speed.size(), 61945u);
  ASSERT_EQ(dr.steering.size(), 61945u);
  EXPECT_EQ(dr.time_ms.front(), 21940);
  EXPECT_EQ(dr.time_ms.back(), 1570540);
  for (std::size_t i = 1; i < dr.time_ms.size(); ++i)
    ASSERT_EQ(dr.time_ms[i] - dr.time_ms[i - 1], 25);
  const auto [smin, smax] = std::minmax_element(dr.speed.begin(), dr.speed.end());
  EXPECT_NEAR(*smin, -0.059, 0.001);
  EXPECT_NEAR(*smax, 6.63, 0.01);
  const auto [amin, amax] = std::minmax_element(dr.steering.begin(), dr.steering.end());
  EXPECT_NEAR(*amin, -0.592, 0.001);
  EXPECT_NEAR(*amax, 0.564, 0.001);
}

TEST_F(WithData, LoadsGps) {
  const vp::Gps gps = vp::loadGps(dir_);
  ASSERT_EQ(gps.time_ms.size(), 4466u);
  ASSERT_EQ(gps.x.size(), 4466u);
  ASSERT_EQ(gps.y.size(), 4466u);
  EXPECT_EQ(gps.time_ms.front(), 20967);
  EXPECT_EQ(gps.time_ms.back(), 1570193);
  EXPECT_NEAR(gps.x.front(), -67.649, 5e-4);
  EXPECT_NEAR(gps.y.front(), -41.714, 5e-4);
}

TEST_F(WithData, LoadsLaserWithTheOriginalStamps) {
  const vp::LaserScans scans = vp::loadLaser(dir_);
  ASSERT_EQ(scans.time_ms.size(), 7230u);
  ASSERT_EQ(scans.ranges.size(), 7230u);
  for (const auto& r : scans.ranges) ASSERT_EQ(r.size(), static_cast<std::size_t>(vp::kBeams));
  EXPECT_EQ(scans.time_ms.front(), 21819);
  EXPECT_EQ(scans.time_ms.back(), 1545182 + vp::kAsciiEpochMs);
  // The first values of the file: time 0.852, then 0.83 0.84 ...
  EXPECT_FLOAT_EQ(scans.ranges[0][0], 0.83f);
  EXPECT_FLOAT_EQ(scans.ranges[0][1], 0.84f);

  const std::vector<std::int64_t> tlsr = vp::loadLaserSampling(dir_);
  ASSERT_EQ(tlsr.size(), 7249u);
  EXPECT_EQ(tlsr.front(), 21819);
  EXPECT_EQ(tlsr.back(), 1570208);
  for (std::size_t i = 0; i < scans.time_ms.size(); ++i) ASSERT_EQ(scans.time_ms[i], tlsr[i]) << i;
}

TEST(VictoriaParkReader, DefaultDataDirHonoursVpData) {
  const char* old = std::getenv("VP_DATA");
  const std::string saved = old ? old : "";
  setenv("VP_DATA", "/some/where/../data/", 1);
  EXPECT_EQ(vp::defaultDataDir(), "/some/data");
  unsetenv("VP_DATA");
  const std::string fallback = vp::defaultDataDir();
  EXPECT_EQ(fallback,
            (fs::path(EKF_SLAM_SOURCE_DIR) / "../shared/data/victoria_park").lexically_normal());
  EXPECT_EQ(fallback.find("/.."), std::string::npos);
  if (old) setenv("VP_DATA", saved.c_str(), 1);
}

// --------------------------------------------------------------------------------------------
// Bad files (no data needed)

TEST(VictoriaParkReader, MissingFilesAreNamed) {
  TempDir tmp;
  expectErrorMentioning([&] { vp::loadDeadReckoning(tmp.path()); },
                        {tmp.file("aa3_dr.mat"), "not found"});
  expectErrorMentioning([&] { vp::loadGps(tmp.path()); }, {tmp.file("aa3_gpsx.mat"), "not found"});
  expectErrorMentioning([&] { vp::loadLaser(tmp.path()); }, {"LASER.txt", "not found"});
  vp::BagOptions options;
  options.data_dir = tmp.path();
  options.out_path = tmp.file("out.bag");
  expectErrorMentioning([&] { vp::writeVictoriaParkBag(options); }, {"aa3_dr.mat", "not found"});
}

TEST(VictoriaParkReader, MalformedMatFiles) {
  TempDir tmp;
  writeText(tmp.file("aa3_dr.mat"), "this is not a MAT file");
  expectErrorMentioning([&] { vp::loadDeadReckoning(tmp.path()); },
                        {tmp.file("aa3_dr.mat"), "MAT file"});

  writeMat(tmp.file("aa3_dr.mat"), {{"time", {25, 50, 75}}, {"steering", {0, 0, 0}}});
  expectErrorMentioning([&] { vp::loadDeadReckoning(tmp.path()); },
                        {tmp.file("aa3_dr.mat"), "missing variable 'speed'"});

  writeMat(tmp.file("aa3_dr.mat"),
           {{"time", {25, 50, 75}}, {"speed", {1, 2}}, {"steering", {0, 0, 0}}});
  expectErrorMentioning([&] { vp::loadDeadReckoning(tmp.path()); },
                        {tmp.file("aa3_dr.mat"), "wrong length", "'speed' has 2"});

  writeMat(tmp.file("aa3_dr.mat"),
           {{"time", {25, 75, 50}}, {"speed", {1, 2, 3}}, {"steering", {0, 0, 0}}});
  expectErrorMentioning([&] { vp::loadDeadReckoning(tmp.path()); }, {"not increasing"});

  writeMat(tmp.file("aa3_gpsx.mat"), {{"timeGps", {1, 2}}, {"Lo_m", {1, 2}}});
  expectErrorMentioning([&] { vp::loadGps(tmp.path()); },
                        {tmp.file("aa3_gpsx.mat"), "missing variable 'La_m'"});

  writeMat(tmp.file("aa3_dr.mat"),
           {{"time", {25, 50, 75}}, {"speed", {1, 2, 3}}, {"steering", {0, 0.1, 0}}});
  const vp::DeadReckoning dr = vp::loadDeadReckoning(tmp.path());
  EXPECT_EQ(dr.time_ms, (std::vector<std::int64_t>{25, 50, 75}));
  EXPECT_DOUBLE_EQ(dr.steering[1], 0.1);
}

TEST(VictoriaParkReader, MalformedLaserFile) {
  TempDir tmp;
  const std::string laser = tmp.file("victoria_park_ascii/LASER.txt");

  writeText(laser, laserText(2, 0));
  const vp::LaserScans ok = vp::loadLaser(tmp.path());
  ASSERT_EQ(ok.time_ms.size(), 2u);
  EXPECT_EQ(ok.time_ms[0], 852 + vp::kAsciiEpochMs);
  EXPECT_EQ(ok.time_ms[1], 1052 + vp::kAsciiEpochMs);
  EXPECT_FLOAT_EQ(ok.ranges[1][1], 12.34f);

  writeText(laser, laserText(2, 5));
  expectErrorMentioning([&] { vp::loadLaser(tmp.path()); },
                        {laser, "not a multiple of 362", "729"});

  std::string text = laserText(2, 0);
  text.replace(text.find("12.34"), 5, "12,34");
  writeText(laser, text);
  expectErrorMentioning([&] { vp::loadLaser(tmp.path()); }, {laser, "non-numeric token '12,34'"});

  writeText(laser, "");
  expectErrorMentioning([&] { vp::loadLaser(tmp.path()); }, {laser, "no numbers"});

  // Stamps that disagree with lasersampling.txt.
  writeText(laser, laserText(2, 0));
  writeText(tmp.file("lasersampling.txt"), "2.1819000e+004\r\n2.2040000e+004\r\n");
  expectErrorMentioning([&] { vp::loadLaser(tmp.path()); }, {laser, "lasersampling.txt", "scan 1"});
}

// --------------------------------------------------------------------------------------------
// Command line

TEST(VictoriaParkBagArgs, Parses) {
  vp::BagOptions o;
  bool help = false;
  std::string error;
  ASSERT_TRUE(vp::parseBagArguments(
      {"--data", "/d", "--out", "x.bag", "--start", "100", "--end", "110.5"}, &o, &help, &error))
      << error;
  EXPECT_FALSE(help);
  EXPECT_EQ(o.data_dir, "/d");
  EXPECT_EQ(o.out_path, "x.bag");
  EXPECT_DOUBLE_EQ(*o.start_s, 100.0);
  EXPECT_DOUBLE_EQ(*o.end_s, 110.5);

  vp::BagOptions h;
  EXPECT_TRUE(vp::parseBagArguments({"--help"}, &h, &help, &error));
  EXPECT_TRUE(help);

  for (const std::vector<std::string>& bad :
       std::vector<std::vector<std::string>>{{},
                                             {"--data", "/d"},
                                             {"--out"},
                                             {"--out", "x.bag", "--start", "abc"},
                                             {"--out", "x.bag", "--start", "5", "--end", "4"},
                                             {"--out", "x.bag", "--bogus"}}) {
    vp::BagOptions b;
    error.clear();
    EXPECT_FALSE(vp::parseBagArguments(bad, &b, &help, &error));
    EXPECT_FALSE(error.empty());
  }
}

// --------------------------------------------------------------------------------------------
// Conversion

TEST_F(WithData, ConvertsATimeWindow) {
  const double start = 100.0, end = 110.0;
  TempDir tmp;
  vp::BagOptions options;
  options.data_dir = dir_;
  options.out_path = tmp.file("window.bag");
  options.start_s = start;
  options.end_s = end;
  const vp::BagCounts counts = vp::writeVictoriaParkBag(options);

  // What the window should hold, straight from the data.
  const vp::DeadReckoning dr = vp::loadDeadReckoning(dir_);
  const vp::Gps gps = vp::loadGps(dir_);
  const vp::LaserScans scans = vp::loadLaser(dir_);
  auto inside = [&](std::int64_t ms) { return ms >= 100000 && ms <= 110000; };
  std::vector<std::size_t> odom_idx, gps_idx, scan_idx;
  for (std::size_t i = 0; i < dr.time_ms.size(); ++i)
    if (inside(dr.time_ms[i])) odom_idx.push_back(i);
  for (std::size_t i = 0; i < gps.time_ms.size(); ++i)
    if (inside(gps.time_ms[i])) gps_idx.push_back(i);
  for (std::size_t i = 0; i < scans.time_ms.size(); ++i)
    if (inside(scans.time_ms[i])) scan_idx.push_back(i);
  ASSERT_EQ(odom_idx.size(), 400u);  // 40 Hz: 100.015 ... 109.990
  ASSERT_GT(gps_idx.size(), 0u);
  ASSERT_GT(scan_idx.size(), 40u);
  EXPECT_EQ(counts.odometry, odom_idx.size());
  EXPECT_EQ(counts.gps, gps_idx.size());
  EXPECT_EQ(counts.scans, scan_idx.size());
  EXPECT_EQ(counts.tf_static, 1u);

  rosbag::Bag bag(options.out_path, rosbag::bagmode::Read);
  rosbag::View view(bag);
  std::vector<sensor_msgs::LaserScan::ConstPtr> got_scans;
  std::vector<nav_msgs::Odometry::ConstPtr> got_odom;
  std::vector<geometry_msgs::PointStamped::ConstPtr> got_gps;
  std::vector<tf2_msgs::TFMessage::ConstPtr> got_tf;
  ros::Time first_stamp, previous;
  bool latching = false;
  for (const rosbag::MessageInstance& m : view) {
    const ros::Time t = m.getTime();
    if (first_stamp.isZero()) first_stamp = t;
    EXPECT_GE(t, previous) << "bag not in time order";
    previous = t;
    EXPECT_GE(t.toSec(), start - 1e-9);
    EXPECT_LE(t.toSec(), end + 1e-9);
    if (auto s = m.instantiate<sensor_msgs::LaserScan>()) {
      EXPECT_EQ(m.getTopic(), "/scan");
      EXPECT_EQ(s->header.stamp, t);
      got_scans.push_back(s);
    } else if (auto o = m.instantiate<nav_msgs::Odometry>()) {
      EXPECT_EQ(m.getTopic(), "/odom");
      EXPECT_EQ(o->header.stamp, t);
      got_odom.push_back(o);
    } else if (auto g = m.instantiate<geometry_msgs::PointStamped>()) {
      EXPECT_EQ(m.getTopic(), "/gps");
      EXPECT_EQ(g->header.stamp, t);
      got_gps.push_back(g);
    } else if (auto tf = m.instantiate<tf2_msgs::TFMessage>()) {
      EXPECT_EQ(m.getTopic(), "/tf_static");
      got_tf.push_back(tf);
      const auto header = m.getConnectionHeader();
      latching = header && header->count("latching") && header->at("latching") == "1";
    } else {
      ADD_FAILURE() << "unexpected " << m.getDataType() << " on " << m.getTopic();
    }
  }
  ASSERT_EQ(got_scans.size(), scan_idx.size());
  ASSERT_EQ(got_odom.size(), odom_idx.size());
  ASSERT_EQ(got_gps.size(), gps_idx.size());
  ASSERT_EQ(got_tf.size(), 1u);

  // Stamps: data ms / 1000; scan seq = index in the whole data set.
  for (std::size_t k = 0; k < got_scans.size(); ++k) {
    const std::size_t i = scan_idx[k];
    EXPECT_EQ(got_scans[k]->header.stamp.toNSec(), scans.time_ms[i] * 1000000ull);
    EXPECT_EQ(got_scans[k]->header.seq, i);
    EXPECT_EQ(got_scans[k]->header.frame_id, "laser");
  }
  for (std::size_t k = 0; k < got_odom.size(); ++k) {
    EXPECT_EQ(got_odom[k]->header.stamp.toNSec(), dr.time_ms[odom_idx[k]] * 1000000ull);
  }
  for (std::size_t k = 0; k < got_gps.size(); ++k) {
    const std::size_t i = gps_idx[k];
    EXPECT_EQ(got_gps[k]->header.stamp.toNSec(), gps.time_ms[i] * 1000000ull);
    EXPECT_EQ(got_gps[k]->header.frame_id, "gps");
    EXPECT_DOUBLE_EQ(got_gps[k]->point.x, gps.x[i]);
    EXPECT_DOUBLE_EQ(got_gps[k]->point.y, gps.y[i]);
  }
  EXPECT_DOUBLE_EQ(counts.first_stamp, first_stamp.toSec());

  // Laser geometry and the no-return value.
  const sensor_msgs::LaserScan& s0 = *got_scans.front();
  ASSERT_EQ(s0.ranges.size(), 361u);
  EXPECT_FLOAT_EQ(s0.angle_min, static_cast<float>(-M_PI / 2));
  EXPECT_FLOAT_EQ(s0.angle_max, static_cast<float>(M_PI / 2));
  EXPECT_FLOAT_EQ(s0.angle_increment, static_cast<float>(M_PI / 360));
  EXPECT_FLOAT_EQ(s0.range_max, 80.0f);
  EXPECT_GT(s0.range_min, 0.0f);
  std::size_t no_returns = 0, finite = 0;
  for (std::size_t k = 0; k < got_scans.size(); ++k) {
    const auto& raw = scans.ranges[scan_idx[k]];
    for (int b = 0; b < vp::kBeams; ++b) {
      if (raw[b] == 81.91f) {
        ++no_returns;
        EXPECT_TRUE(std::isinf(got_scans[k]->ranges[b]) && got_scans[k]->ranges[b] > 0);
      } else {
        ++finite;
        EXPECT_EQ(got_scans[k]->ranges[b], raw[b]);
      }
    }
  }
  EXPECT_GT(no_returns, 0u);
  EXPECT_GT(finite, 0u);

  // First odometry twist by hand: v_c = v_e / (1 - tan(a) H / L), w = v_c tan(a) / L.
  const std::size_t i0 = odom_idx.front();
  const double v_e = dr.speed[i0], alpha = dr.steering[i0];
  ASSERT_GT(v_e, 1.0);              // the check means something only while driving...
  ASSERT_GT(std::abs(alpha), 0.1);  // ...and turning
  const double v_c = v_e / (1.0 - std::tan(alpha) * kH / kL);
  const nav_msgs::Odometry& o0 = *got_odom.front();
  EXPECT_EQ(o0.header.frame_id, "odom");
  EXPECT_EQ(o0.child_frame_id, "base_link");
  EXPECT_NEAR(o0.twist.twist.linear.x, v_c, 1e-9);
  EXPECT_NEAR(o0.twist.twist.angular.z, v_c * std::tan(alpha) / kL, 1e-9);
  EXPECT_GT(o0.twist.covariance[0], 0.0);
  EXPECT_GT(o0.twist.covariance[35], 0.0);
  EXPECT_GT(o0.pose.covariance[0], 0.0);

  // Consecutive poses follow the Ackermann model with the previous sample's inputs.
  for (std::size_t k = 1; k < got_odom.size(); ++k) {
    const nav_msgs::Odometry& a = *got_odom[k - 1];
    const nav_msgs::Odometry& b = *got_odom[k];
    const std::size_t i = odom_idx[k - 1];
    const double yaw = 2 * std::atan2(a.pose.pose.orientation.z, a.pose.pose.orientation.w);
    const double v = dr.speed[i] / (1.0 - std::tan(dr.steering[i]) * kH / kL);
    const double dt = 0.025;
    EXPECT_NEAR(b.pose.pose.position.x, a.pose.pose.position.x + v * std::cos(yaw) * dt, 1e-6);
    EXPECT_NEAR(b.pose.pose.position.y, a.pose.pose.position.y + v * std::sin(yaw) * dt, 1e-6);
    const double yaw_b = 2 * std::atan2(b.pose.pose.orientation.z, b.pose.pose.orientation.w);
    EXPECT_NEAR(std::remainder(yaw_b - yaw - v * std::tan(dr.steering[i]) / kL * dt, 2 * M_PI), 0.0,
                1e-6);
  }

  // Static transform base_link -> laser, stamped at the window's first message.
  ASSERT_EQ(got_tf[0]->transforms.size(), 1u);
  const geometry_msgs::TransformStamped& tf = got_tf[0]->transforms[0];
  EXPECT_EQ(tf.header.frame_id, "base_link");
  EXPECT_EQ(tf.child_frame_id, "laser");
  EXPECT_EQ(tf.header.stamp, first_stamp);
  EXPECT_DOUBLE_EQ(tf.transform.translation.x, 3.78);
  EXPECT_DOUBLE_EQ(tf.transform.translation.y, 0.5);
  EXPECT_DOUBLE_EQ(tf.transform.translation.z, 0.0);
  EXPECT_DOUBLE_EQ(tf.transform.rotation.w, 1.0);
  EXPECT_DOUBLE_EQ(tf.transform.rotation.x, 0.0);
  EXPECT_DOUBLE_EQ(tf.transform.rotation.y, 0.0);
  EXPECT_DOUBLE_EQ(tf.transform.rotation.z, 0.0);
  EXPECT_TRUE(latching) << "/tf_static must have a latching connection header";
}

TEST_F(WithData, OdometryStartsAtZeroAtTheFirstSample) {
  TempDir tmp;
  vp::BagOptions options;
  options.data_dir = dir_;
  options.out_path = tmp.file("start.bag");
  options.end_s = 22.0;
  const vp::BagCounts counts = vp::writeVictoriaParkBag(options);
  EXPECT_DOUBLE_EQ(counts.first_stamp, 20.967);  // the first GPS fix
  EXPECT_EQ(counts.odometry, 3u);                // 21.940, 21.965, 21.990
  rosbag::Bag bag(options.out_path, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery("/odom"));
  auto first = view.begin()->instantiate<nav_msgs::Odometry>();
  ASSERT_TRUE(first);
  EXPECT_DOUBLE_EQ(first->header.stamp.toSec(), 21.940);
  EXPECT_EQ(first->pose.pose.position.x, 0.0);
  EXPECT_EQ(first->pose.pose.position.y, 0.0);
  EXPECT_EQ(first->pose.pose.orientation.w, 1.0);
}

TEST_F(WithData, EmptyWindowIsAnError) {
  TempDir tmp;
  vp::BagOptions options;
  options.data_dir = dir_;
  options.out_path = tmp.file("empty.bag");
  options.start_s = 5000.0;
  expectErrorMentioning([&] { vp::writeVictoriaParkBag(options); }, {"no data"});
}

TEST_F(WithData, FullConversionCounts) {
  TempDir tmp;
  vp::BagOptions options;
  options.data_dir = dir_;
  options.out_path = tmp.file("full.bag");
  const vp::BagCounts counts = vp::writeVictoriaParkBag(options);
  EXPECT_EQ(counts.scans, 7230u);
  EXPECT_EQ(counts.odometry, 61945u);
  EXPECT_EQ(counts.gps, 4466u);
  rosbag::Bag bag(options.out_path, rosbag::bagmode::Read);
  EXPECT_EQ(rosbag::View(bag, rosbag::TopicQuery("/scan")).size(), 7230u);
  EXPECT_EQ(rosbag::View(bag, rosbag::TopicQuery("/odom")).size(), 61945u);
  EXPECT_EQ(rosbag::View(bag, rosbag::TopicQuery("/gps")).size(), 4466u);
  EXPECT_EQ(rosbag::View(bag, rosbag::TopicQuery("/tf_static")).size(), 1u);
  rosbag::View all(bag);
  EXPECT_DOUBLE_EQ(all.getBeginTime().toSec(), 20.967);
  EXPECT_DOUBLE_EQ(all.getEndTime().toSec(), 1570.540);
}

}  // namespace test_victoria_park
