// The EKF's arithmetic against a stored reference: a Victoria Park window (20-220 s, about 1000
// scans) run offline with every associator; the trajectory (every 10th scan: pose and its
// covariance) and the final map (ids, means, covariances) must equal the ones the dense EKF of
// before the storage and update rework produced (test/data/ekf_reference_vp.txt) within 1e-9.
// The reference was made by, and is only ever regenerated with (after an intended change of the
// results, never to make this test pass):
//
//   EKF_SLAM_WRITE_REFERENCE=test/data/ekf_reference_vp.txt devel/lib/ekf_slam/test_ekf_reference
//
// Skips without the data set (VP_DATA).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "ekf_slam/data/victoria_park.h"
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/ros/victoria_park_bag.h"
#include "offline_test_options.h"
#include "test_files.h"

namespace fs = std::filesystem;
namespace vp = ekf_slam::victoria_park;

namespace ekf_slam {
namespace test_ekf_reference {

const std::string kConfig = std::string(EKF_SLAM_SOURCE_DIR) + "/config/victoria_park.yaml";
const std::string kReference = std::string(EKF_SLAM_TEST_DATA) + "/ekf_reference_vp.txt";
const std::vector<std::string> kAssociators = {"NN",     "JCBB",      "DJNN",
                                               "NNJCBB", "Hungarian", "RRWSC"};
constexpr double kTolerance = 1e-9;
constexpr int kPoseEvery = 10;

// One labelled row of numbers, e.g. "pose 35 x y yaw Pxx ..." or "lm 12 x y Pxx Pxy Pyy".
struct Row {
  std::string kind;
  long key = 0;
  std::vector<double> values;
};

std::string format(const Row& r) {
  std::string s = r.kind + " " + std::to_string(r.key);
  char buf[32];
  for (double v : r.values) {
    std::snprintf(buf, sizeof buf, " %.14g", v);
    s += buf;
  }
  return s;
}

// Runs the window with one associator: its rows (poses, then the final map).
std::vector<Row> runWindow(const fs::path& bag, const fs::path& out, const std::string& name) {
  OfflineOptions o = test_files::quietOfflineOptions(bag.string(), kConfig, out.string());
  o.associator = name;
  std::vector<Row> rows;
  const EkfSlam* last = nullptr;
  std::vector<Row> map;
  o.on_scan = [&](const ScanReport& report, const SlamPipeline& pipeline) {
    const EkfSlam& ekf = pipeline.ekf();
    last = &ekf;
    if (report.scan % kPoseEvery == 0) {
      const Eigen::Vector3d x = ekf.pose();
      const Eigen::Matrix3d P = ekf.poseCovariance();
      rows.push_back({"pose",
                      static_cast<long>(report.scan),
                      {x(0), x(1), x(2), P(0, 0), P(0, 1), P(0, 2), P(1, 1), P(1, 2), P(2, 2)}});
    }
    map.clear();  // the map after the last scan is kept
    for (std::size_t i = 0; i < ekf.numLandmarks(); ++i) {
      const Eigen::Vector2d m = ekf.landmark(static_cast<int>(i));
      const Eigen::Matrix2d C = ekf.landmarkCovariance(static_cast<int>(i));
      map.push_back(
          {"lm", static_cast<long>(ekf.landmarkIds()[i]), {m(0), m(1), C(0, 0), C(0, 1), C(1, 1)}});
    }
  };
  std::ostringstream log;
  runOffline(o, log);
  EXPECT_NE(last, nullptr);
  rows.insert(rows.end(), map.begin(), map.end());
  return rows;
}

std::map<std::string, std::vector<Row>> readReference(const std::string& path) {
  std::map<std::string, std::vector<Row>> ref;
  std::ifstream in(path);
  std::string current;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    Row r;
    ss >> r.kind;
    if (r.kind == "associator") {
      ss >> current;
      ref[current];
      continue;
    }
    ss >> r.key;
    for (double v; ss >> v;) r.values.push_back(v);
    ref[current].push_back(r);
  }
  return ref;
}

class EkfReferenceTest : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::string data = vp::defaultDataDir();
    if (!fs::exists(fs::path(data) / "aa3_dr.mat")) return;
    dir_ = new test_files::TempDir("ekf_slam_reference");
    vp::BagOptions options;
    options.data_dir = data;
    options.out_path = dir_->file("window.bag");
    options.start_s = 20.0;  // the start of the run: some 1000 scans, loops, removals
    options.end_s = 220.0;
    vp::writeVictoriaParkBag(options);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  void SetUp() override {
    if (dir_ == nullptr) {
      EKF_SLAM_SKIP_WITHOUT_DATA("Victoria Park data not found in " << vp::defaultDataDir()
                                                                    << " (set VP_DATA)");
    }
  }
  static test_files::TempDir* dir_;
};
test_files::TempDir* EkfReferenceTest::dir_ = nullptr;

TEST_F(EkfReferenceTest, EveryAssociatorMatchesTheStoredTrajectoryAndMap) {
  const fs::path bag = dir_->file("window.bag");
  std::map<std::string, std::vector<Row>> runs;
  for (const std::string& a : kAssociators) runs[a] = runWindow(bag, dir_->path() / a, a);

  if (const char* write = std::getenv("EKF_SLAM_WRITE_REFERENCE")) {
    std::ofstream out(write);
    out << "# test_ekf_reference: VP 20-220 s, config/victoria_park.yaml; pose every " << kPoseEvery
        << " scans (x y yaw, upper pose covariance), final map (x y Pxx Pxy Pyy)\n";
    for (const std::string& a : kAssociators) {
      out << "associator " << a << "\n";
      for (const Row& r : runs[a]) out << format(r) << "\n";
    }
    ASSERT_TRUE(out.good()) << write;
    GTEST_SKIP() << "reference written to " << write;
  }

  const auto ref = readReference(kReference);
  for (const std::string& a : kAssociators) {
    SCOPED_TRACE(a);
    ASSERT_TRUE(ref.count(a)) << kReference << " lacks " << a;
    const std::vector<Row>& want = ref.at(a);
    const std::vector<Row>& got = runs[a];
    ASSERT_EQ(got.size(), want.size());
    double worst = 0.0;
    for (std::size_t i = 0; i < got.size(); ++i) {
      ASSERT_EQ(got[i].kind, want[i].kind) << "row " << i;
      ASSERT_EQ(got[i].key, want[i].key) << format(want[i]);
      ASSERT_EQ(got[i].values.size(), want[i].values.size());
      for (std::size_t k = 0; k < got[i].values.size(); ++k) {
        const double e = std::abs(got[i].values[k] - want[i].values[k]);
        worst = std::max(worst, e);
        EXPECT_LE(e, kTolerance) << "value " << k << " of " << format(want[i]) << "\n  got "
                                 << format(got[i]);
      }
    }
    std::printf("%-10s %zu rows, largest difference %.3g\n", a.c_str(), got.size(), worst);
  }
}

}  // namespace test_ekf_reference
}  // namespace ekf_slam
