// Fault-injection suite (issue 15): faulty copies of a 60 s Victoria Park window through the
// offline runner. Each family must end as a clean error, or as its documented, counted handling
// with a map close to the clean run's and no NaN; corrupted bytes run in a child process under a
// memory limit and a time limit, so a regression fails instead of eating the machine.
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "ekf_slam/data/victoria_park.h"
#include "ekf_slam/ros/offline/checked_bag_reader.h"
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/ros/victoria_park_bag.h"
#include "fault_bags.h"
#include "offline_test_options.h"
#include "test_files.h"

#if defined(__SANITIZE_ADDRESS__)
#define EKF_SLAM_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define EKF_SLAM_ASAN 1
#endif
#endif

namespace vp = ekf_slam::victoria_park;
using fault_bags::Faults;

namespace ekf_slam {
namespace test_bag_faults {

const std::string kConfig = std::string(EKF_SLAM_SOURCE_DIR) + "/config/victoria_park.yaml";
// Bounds of a run on a corrupted bag (the window is 2.3 MB).
constexpr long kMaxRssKb = 300 * 1024;
constexpr double kMaxSeconds = 20.0;

struct RunResult {
  nlohmann::json metrics;  // empty on error
  std::string error;
  std::string log;
  std::string trajectory;  // trajectory.csv
};

class BagFaults : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string data = vp::defaultDataDir();
    if (!std::ifstream(data + "/aa3_dr.mat")) return;
    dir_ = new test_files::TempDir("ekf_slam_faults");
    vp::BagOptions options;
    options.data_dir = data;
    options.out_path = dir_->file("clean.bag");
    options.start_s = 20.0;
    options.end_s = 80.0;
    vp::writeVictoriaParkBag(options);
    clean_ = new RunResult(run(options.out_path, "clean"));
  }
  static void TearDownTestSuite() {
    delete clean_;
    delete dir_;
    clean_ = nullptr;
    dir_ = nullptr;
  }
  void SetUp() override {
    if (dir_ == nullptr) {
      EKF_SLAM_SKIP_WITHOUT_DATA("Victoria Park data not found in " << vp::defaultDataDir()
                                                                    << " (set VP_DATA)");
    }
    ASSERT_TRUE(clean_->error.empty()) << clean_->error;
  }

  static OfflineOptions options(const std::string& bag, const std::string& out,
                                const std::string& params = kConfig) {
    return test_files::quietOfflineOptions(bag, params, dir_->file(out));
  }
  static RunResult run(const std::string& bag, const std::string& out,
                       const std::string& params = kConfig) {
    RunResult r;
    std::ostringstream log;
    try {
      r.metrics = nlohmann::json::parse(runOffline(options(bag, out, params), log).metrics_json);
      r.trajectory = test_files::readFile(dir_->file(out) + "/trajectory.csv");
    } catch (const std::exception& e) {
      r.error = e.what();
    }
    r.log = log.str();
    return r;
  }
  // A faulty copy of the clean window, run.
  static RunResult runFaulty(const std::string& name, const Faults& faults,
                             const std::string& params = kConfig) {
    const std::string bag = dir_->file(name + ".bag");
    fault_bags::writeFaultyBag(dir_->file("clean.bag"), bag, faults);
    return run(bag, name, params);
  }
  static std::uint64_t counter(const RunResult& r, const char* name) {
    return r.metrics.at("counters").at(name).get<std::uint64_t>();
  }
  static int landmarks(const RunResult& r) { return r.metrics.at("landmarks").get<int>(); }
  // A usable map: no NaN anywhere, landmarks within a few of the clean run's.
  static void expectCloseToClean(const RunResult& r, int tolerance) {
    ASSERT_TRUE(r.error.empty()) << r.error;
    EXPECT_EQ(r.trajectory.find("nan"), std::string::npos);
    for (const auto& v : r.metrics.at("final_pose")) EXPECT_TRUE(std::isfinite(v.get<double>()));
    EXPECT_NEAR(landmarks(r), landmarks(*clean_), tolerance);
    EXPECT_LT(r.metrics.at("gps_rmse_m").get<double>(),
              clean_->metrics.at("gps_rmse_m").get<double>() + 0.5);
  }

  static test_files::TempDir* dir_;
  static RunResult* clean_;
};
test_files::TempDir* BagFaults::dir_ = nullptr;
RunResult* BagFaults::clean_ = nullptr;

// --- 1. corrupted bytes ------------------------------------------------------------------------

struct Isolated {
  int exit_code = -1;  // -1: killed by a signal
  int signal = 0;
  long max_rss_kb = 0;
  double seconds = 0.0;
  std::string error;
};

// runOffline in a child process with an address-space limit (not under ASan, which reserves
// terabytes) and an alarm: an unbounded allocation or a hang is a failed test, not a dead box.
Isolated runIsolated(const OfflineOptions& o) {
  int fd[2];
  if (pipe(fd) != 0) throw std::runtime_error("pipe failed");
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
#ifndef EKF_SLAM_ASAN
    const rlimit limit{3ul << 30, 3ul << 30};
    setrlimit(RLIMIT_AS, &limit);
#endif
    alarm(static_cast<unsigned>(kMaxSeconds * 3));
    std::string message;
    int code = 0;
    try {
      std::ostringstream log;
      runOffline(o, log);
    } catch (const std::exception& e) {
      message = e.what();
      code = 1;
    }
    if (write(fd[1], message.data(), message.size()) < 0) code = 3;
    _exit(code);
  }
  close(fd[1]);
  Isolated r;
  char buf[4096];
  for (ssize_t n; (n = read(fd[0], buf, sizeof buf)) > 0;) r.error.append(buf, n);
  close(fd[0]);
  int status = 0;
  rusage usage{};
  wait4(pid, &status, 0, &usage);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.max_rss_kb = usage.ru_maxrss;
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) r.signal = WTERMSIG(status);
  return r;
}

TEST_F(BagFaults, RandomBytesGiveAClearErrorInBoundedMemoryAndTime) {
  const std::string clean = dir_->file("clean.bag");
  const std::size_t size = fault_bags::readBytes(clean).size();
  for (unsigned seed = 0; seed < 8; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const std::string bag = dir_->file("random_" + std::to_string(seed) + ".bag");
    // 64 KiB somewhere in the middle half of the file (issue 15's fault).
    const std::size_t offset = size / 4 + (seed * 7919 * 97) % (size / 2);
    fault_bags::corruptBytes(clean, bag, offset, 64 * 1024, seed);
    const Isolated r = runIsolated(options(bag, "random_" + std::to_string(seed)));
    EXPECT_EQ(r.signal, 0) << "killed by signal " << r.signal << " after " << r.seconds << " s";
    EXPECT_EQ(r.exit_code, 1) << r.error;  // the bytes always hit something the run reads
    EXPECT_NE(r.error.find("corrupted bag " + bag), std::string::npos) << r.error;
    EXPECT_LT(r.max_rss_kb, kMaxRssKb);
    EXPECT_LT(r.seconds, kMaxSeconds);
  }
}

TEST_F(BagFaults, CorruptedArrayLengthInsideAScanIsCaughtBeforeAllocating) {
  const std::string bag = dir_->file("length.bag");
  // The 100th scan claims 2^30 beams (4 GiB of floats) in a record of the right size.
  ASSERT_TRUE(
      fault_bags::corruptRangesLength(dir_->file("clean.bag"), bag, "laser", 361, 100, 1u << 30));
  const Isolated r = runIsolated(options(bag, "length"));
  EXPECT_EQ(r.signal, 0);
  EXPECT_EQ(r.exit_code, 1) << r.error;
  // Where it stopped: the bag, the message, its topic and how far the reading got.
  EXPECT_NE(r.error.find("corrupted bag " + bag), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("topic /scan"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("ranges: 1073741824 elements"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("100 scans"), std::string::npos) << r.error;
  EXPECT_LT(r.max_rss_kb, kMaxRssKb);
}

TEST(BagStructure, NotABagIsNamedAndAnOlderFormatIsLeftToRosbag) {
  test_files::TempDir dir("ekf_slam_faults");
  std::ofstream(dir.file("text.bag")) << "hello, not a bag\n";
  EXPECT_THROW(checkBagStructure(dir.file("text.bag")), CorruptMessageError);
  std::ofstream(dir.file("old.bag")) << "#ROSBAG V1.2\n";
  EXPECT_NO_THROW(checkBagStructure(dir.file("old.bag")));
  // A truncated 2.0 bag: its first record overruns the file.
  std::ofstream(dir.file("cut.bag")) << "#ROSBAG V2.0\n\xff\xff\x00\x00op";
  EXPECT_THROW(checkBagStructure(dir.file("cut.bag")), CorruptMessageError);
}

// --- 2. inconsistent scan geometry -------------------------------------------------------------

TEST_F(BagFaults, InconsistentScansAreRejectedAndCounted) {
  // Every 10th scan broken in one of four ways (27 of 273).
  const RunResult r = runFaulty("geometry", {[](sensor_msgs::LaserScan s, std::size_t i) {
                                               if (i % 10 == 5)
                                                 fault_bags::breakGeometry(s, i / 10);
                                               return std::vector<sensor_msgs::LaserScan>{s};
                                             },
                                             nullptr});
  EXPECT_EQ(counter(r, "inconsistent_scans"), 27u);
  EXPECT_NE(r.log.find("used for prediction only"), std::string::npos) << r.log;
  expectCloseToClean(r, 5);
}

// --- 3. frames and stamps: the node's rules ----------------------------------------------------

TEST_F(BagFaults, ScansOfUnknownOrEmptyFramesAreSkippedNotPlacedAtTheOrigin) {
  const RunResult r = runFaulty("frames", {[](sensor_msgs::LaserScan s, std::size_t i) {
                                             if (i % 10 == 3) s.header.frame_id = "";
                                             if (i % 10 == 7) s.header.frame_id = "front_laser";
                                             return std::vector<sensor_msgs::LaserScan>{s};
                                           },
                                           nullptr});
  EXPECT_EQ(counter(r, "skipped_no_tf"), 54u);
  EXPECT_NE(r.log.find("base_link -> front_laser"), std::string::npos) << r.log;
  EXPECT_NE(r.log.find("(empty frame_id)"), std::string::npos) << r.log;
  EXPECT_DOUBLE_EQ(r.metrics.at("sensor_offset")[0].get<double>(), vp::kLaserX);
  expectCloseToClean(r, 6);
}

TEST_F(BagFaults, ZeroStampsAreSkippedWithoutReset) {
  const RunResult r = runFaulty("zero_stamps", {[](sensor_msgs::LaserScan s, std::size_t i) {
                                                  if (i % 20 == 4) s.header.stamp = ros::Time();
                                                  return std::vector<sensor_msgs::LaserScan>{s};
                                                },
                                                [](nav_msgs::Odometry o, std::size_t i) {
                                                  if (i % 50 == 9) o.header.stamp = ros::Time();
                                                  return std::vector<nav_msgs::Odometry>{o};
                                                }});
  EXPECT_EQ(counter(r, "zero_stamps"), 14u + 47u);
  EXPECT_EQ(counter(r, "time_jumps"), 0u);
  expectCloseToClean(r, 5);
}

// --- 5. duplicates and nonsense odometry -------------------------------------------------------

TEST_F(BagFaults, DuplicatedScansAreDroppedAndTheMapIsUnchanged) {
  const RunResult r = runFaulty("duplicates", {[](sensor_msgs::LaserScan s, std::size_t) {
                                                 return std::vector<sensor_msgs::LaserScan>{s, s};
                                               },
                                               nullptr});
  EXPECT_EQ(counter(r, "duplicate_scans"), clean_->metrics.at("scans").get<std::uint64_t>());
  EXPECT_EQ(r.metrics.at("scans"), clean_->metrics.at("scans"));
  EXPECT_EQ(landmarks(r), landmarks(*clean_));
  EXPECT_DOUBLE_EQ(r.metrics.at("gps_rmse_m").get<double>(),
                   clean_->metrics.at("gps_rmse_m").get<double>());
}

TEST_F(BagFaults, AbsurdTwistIsRejectedAsImplausibleNotNonFinite) {
  const RunResult r = runFaulty("twist", {nullptr, [](nav_msgs::Odometry o, std::size_t i) {
                                            if (i % 100 == 50) o.twist.twist.linear.x = 1e300;
                                            return std::vector<nav_msgs::Odometry>{o};
                                          }});
  EXPECT_EQ(counter(r, "implausible_odometry"), 23u);
  EXPECT_EQ(counter(r, "rejected_odometry"), 0u);
  EXPECT_NE(r.log.find("rejected (twist beyond max_speed"), std::string::npos) << r.log;
  expectCloseToClean(r, 5);
}

TEST_F(BagFaults, ZeroQuaternionIsRejectedInPoseDeltaMode) {
  std::string yaml = test_files::readFile(kConfig);
  yaml = std::regex_replace(yaml, std::regex("odometry_mode: twist"), "odometry_mode: pose_delta");
  const std::string params = dir_->file("pose_delta.yaml");
  std::ofstream(params) << yaml;
  const RunResult clean = run(dir_->file("clean.bag"), "pose_delta_clean", params);
  ASSERT_TRUE(clean.error.empty()) << clean.error;
  const RunResult r = runFaulty("quaternion",
                                {nullptr,
                                 [](nav_msgs::Odometry o, std::size_t i) {
                                   if (i % 100 == 50)
                                     o.pose.pose.orientation = geometry_msgs::Quaternion();
                                   return std::vector<nav_msgs::Odometry>{o};
                                 }},
                                params);
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(counter(r, "invalid_orientations"), 23u);
  EXPECT_EQ(r.trajectory.find("nan"), std::string::npos);
  EXPECT_NEAR(landmarks(r), landmarks(clean), 5);
}

// --- 4. one stream jumping back in time (kept from the earlier session) -----------------------

TEST_F(BagFaults, OneStreamJumpingBackDoesNotResetTheMap) {
  const RunResult r = runFaulty("odom_jump", {nullptr, [](nav_msgs::Odometry o, std::size_t i) {
                                                if (i >= 800 && i < 900)
                                                  o.header.stamp -= ros::Duration(10.0);
                                                return std::vector<nav_msgs::Odometry>{o};
                                              }});
  EXPECT_EQ(counter(r, "time_jumps"), 0u);
  EXPECT_GT(counter(r, "dropped_out_of_range"), 0u);
  expectCloseToClean(r, 8);
}

}  // namespace test_bag_faults
}  // namespace ekf_slam
