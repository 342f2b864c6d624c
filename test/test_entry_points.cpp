// Every entry point builds its pipeline with the one builder (app/pipeline_builder.h), so
//  - a misspelt key in any plugin's section is the same clear error in each of them
//    (ekf_slam_offline, evaluate, relocalisation_experiment, detect_trees, replay_association;
//    the node's is in test_node.cpp), and
//  - `simulate` + ekf_slam_offline and evaluate give the same run: the same decision for every
//    observation, the same removals, the same final map to the last bit and the same scores
//    (issue 35: the offline runner's associator wrapper dropped poseCorrected, and DJNN's
//    tentative features did not follow the pose corrections in arena and fiducials).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nav_msgs/Odometry.h>
#include <nlohmann/json.hpp>

#include "ekf_slam/ros/conversions.h"
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/ros/plugin_loader.h"
#include "ekf_slam/tools/evaluate.h"
#include "ekf_slam/tools/simulation_bag.h"
#include "offline_test_options.h"
#include "test_files.h"

namespace ekf_slam {
namespace test_entry_points {

using test_files::TempDir;

// --- a misspelt key, entry point by entry point --------------------------------------------------

struct Misspelling {
  const char* yaml;
  const char* expected;  // in the error, after the file's name
};
const Misspelling kMisspellings[] = {
    {"DJNN:\n  individual_probabilty: 0.9\n",
     ":DJNN/individual_probabilty (did you mean individual_probability?)"},
    {"TreeExtractor:\n  range_jmp: 1.0\n", ":TreeExtractor/range_jmp (did you mean range_jump?)"},
    {"relocaliser: ekf_slam/FGCBB\nFGCBB:\n  sensor_rnage: 20\n",
     ":FGCBB/sensor_rnage (did you mean sensor_range?)"},
};

// The output and exit code of a command.
int run(const std::string& command, std::string* output) {
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return -1;
  output->clear();
  char buf[512];
  while (fgets(buf, sizeof buf, pipe) != nullptr) *output += buf;
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class MisspeltKey : public testing::TestWithParam<Misspelling> {
 protected:
  void SetUp() override {
    params_ = dir_.file("params.yaml");
    std::ofstream(params_) << GetParam().yaml;
    expected_ = params_ + GetParam().expected;
  }
  // The message of what `f` throws, "" when nothing.
  template <class F>
  static std::string errorOf(F f) {
    try {
      f();
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  }
  TempDir dir_{"ekf_slam_entry_points"};
  std::string params_, expected_;
};

TEST_P(MisspeltKey, OfflineRunner) {
  OfflineOptions o = test_files::quietOfflineOptions("/nonexistent.bag", params_, dir_.file("out"));
  std::ostringstream log;
  EXPECT_NE(errorOf([&] { runOffline(o, log); }).find(expected_), std::string::npos) << expected_;
}

TEST_P(MisspeltKey, Evaluate) {
  EvaluateOptions o;
  o.worlds = {"tiny"};
  o.runs = 1;
  o.associators = {"ekf_slam/DJNN"};
  o.params_path = params_;
  o.progress = false;
  std::ostringstream log;
  EXPECT_NE(errorOf([&] { runEvaluation(o, log); }).find(expected_), std::string::npos)
      << expected_;
}

TEST_P(MisspeltKey, RelocalisationExperiment) {
  std::string out;
  EXPECT_EQ(run(std::string(RELOCALISATION_EXPERIMENT_BIN) + " --bag /nonexistent.bag --params " +
                    params_ + " --out " + dir_.file("out"),
                &out),
            1);
  EXPECT_NE(out.find(expected_), std::string::npos) << out;
}

TEST_P(MisspeltKey, DetectTrees) {
  std::string out;
  EXPECT_EQ(run(std::string(DETECT_TREES_BIN) + " --bag /nonexistent.bag --params " + params_ +
                    " --out " + dir_.file("trees.csv"),
                &out),
            1);
  EXPECT_NE(out.find(expected_), std::string::npos) << out;
}

TEST_P(MisspeltKey, ReplayAssociation) {
  std::string out;
  EXPECT_EQ(
      run(std::string(REPLAY_ASSOCIATION_BIN) +
              " --problem " EKF_SLAM_TEST_DATA "/clear.json --associator DJNN --params " + params_,
          &out),
      1);
  EXPECT_NE(out.find(expected_), std::string::npos) << out;
}

INSTANTIATE_TEST_SUITE_P(EverySection, MisspeltKey, testing::ValuesIn(kMisspellings));

// --- offline against evaluate --------------------------------------------------------------------

// A direct run feeds what the bag gives back: stamps as ros::Time holds them, yaw through the
// odometry message's quaternion.
TEST(BagRoundTrip, DirectRunsSeeWhatTheBagHolds) {
  sim::Simulation simulation(sim::makeWorld("fiducials"), 1);
  int samples = 0;
  for (auto e = simulation.next(); e != sim::Simulation::Event::kEnd; e = simulation.next()) {
    if (e != sim::Simulation::Event::kOdometry) continue;
    const sim::OdometrySample& o = simulation.odometry();
    nav_msgs::Odometry msg;
    msg.header.stamp = ros::Time(o.stamp + sim::kStampOffset);
    msg.pose.pose = toPoseMsg(o.pose);
    msg.twist.twist.linear.x = o.twist.x();
    msg.twist.twist.angular.z = o.twist.y();
    const OdometryInput from_bag = toOdometryInput(msg), direct = sim::odometryOnBag(o);
    ASSERT_EQ(direct.stamp, from_bag.stamp) << "sample " << samples;
    ASSERT_EQ(direct.pose, from_bag.pose) << "sample " << samples;
    ASSERT_EQ(direct.twist, from_bag.twist);
    ASSERT_EQ(sim::stampOnBag(o.stamp), from_bag.stamp);
    msg.pose.pose = toPoseMsg(o.true_pose);
    ASSERT_EQ(sim::poseOnBag(o.true_pose), toOdometryInput(msg).pose);
    ++samples;
  }
  EXPECT_GT(samples, 2000);
}

// One scan as associations.csv has it: "obs decision id" per observation, then "removed id".
std::string scanRow(const ScanReport& r) {
  std::ostringstream row;
  for (std::size_t i = 0; i < r.observations.size(); ++i) {
    const Decision d = r.association.decision[i];
    const LandmarkId id =
        d == Decision::kPaired || d == Decision::kNew ? r.association.landmark[i] : kNoLandmark;
    row << i << ' ' << toString(d) << ' ' << id << ';';
  }
  for (const LandmarkId id : r.removed) row << "removed " << id << ';';
  return row.str();
}

// The same from the offline runner's associations.csv, by scan.
std::map<std::uint32_t, std::string> scanRows(const std::string& csv) {
  std::map<std::uint32_t, std::string> rows;
  std::istringstream in(test_files::readFile(csv));
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::istringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) f.push_back(cell);
    std::string& row = rows[static_cast<std::uint32_t>(std::stoul(f.at(0)))];
    row += f.at(6) == "removed" ? "removed " + f.at(7) + ";"
                                : f.at(2) + ' ' + f.at(6) + ' ' + f.at(7) + ';';
  }
  return rows;
}

class OfflineAgainstEvaluate : public testing::TestWithParam<const char*> {};

TEST_P(OfflineAgainstEvaluate, SameDecisionsSameMapSameScores) {
  const std::string world_name = GetParam();
  TempDir dir("ekf_slam_parity");
  std::ostringstream log;
  SimulationBagOptions s;
  s.world = world_name;
  s.seed = 1;
  s.out_path = dir.file(world_name + ".bag");
  s.markers = false;
  const SimulationBagSummary bag = writeSimulationBag(s, log);

  // simulate + ekf_slam_offline.
  OfflineOptions o =
      test_files::quietOfflineOptions(bag.bag_path, bag.params_path, dir.file("off"));
  o.associator = "ekf_slam/DJNN";
  const OfflineSummary offline = runOffline(o, log);

  // evaluate's run of the same world and seed, every scan recorded.
  const sim::World world = sim::makeWorld(world_name);
  const PipelineParts parts = buildPipeline(
      evaluationConfiguration(EvaluateOptions(), world, "ekf_slam/DJNN"), PluginlibFactory());
  std::map<std::uint32_t, std::string> direct;
  std::vector<std::string> final_map;
  const RunMetrics m = evaluateRun(
      parts, world, 1, nullptr, nullptr, [&](const ScanReport& r, const SlamPipeline& p) {
        // associations.csv has no row for a scan without observations or removals.
        if (const std::string row = scanRow(r); !row.empty()) direct[r.scan] = row;
        if (r.scan + 1 != offline.scans) return;
        const EkfSlam& ekf = p.ekf();
        for (std::size_t k = 0; k < ekf.numLandmarks(); ++k) {
          std::ostringstream l;
          l.precision(17);
          l << ekf.landmarkIds()[k] << ',' << ekf.landmark(static_cast<int>(k)).x() << ','
            << ekf.landmark(static_cast<int>(k)).y();
          final_map.push_back(l.str());
        }
      });

  // Every decision of every scan.
  const std::map<std::uint32_t, std::string> from_file = scanRows(o.out_dir + "/associations.csv");
  ASSERT_EQ(from_file.size(), direct.size());
  for (const auto& [scan, row] : direct) {
    ASSERT_EQ(from_file.at(scan), row) << world_name << ": first difference at scan " << scan;
  }
  // The final map, to the last bit (landmarks.csv holds 17 digits).
  std::vector<std::string> offline_map;
  std::istringstream lm(test_files::readFile(o.out_dir + "/landmarks.csv"));
  std::string line;
  std::getline(lm, line);
  while (std::getline(lm, line)) {
    std::istringstream cells(line);
    std::string id, x, y;
    std::getline(cells, id, ',');
    std::getline(cells, x, ',');
    std::getline(cells, y, ',');
    std::ostringstream l;
    l.precision(17);
    l << id << ',' << std::strtod(x.c_str(), nullptr) << ',' << std::strtod(y.c_str(), nullptr);
    offline_map.push_back(l.str());
  }
  EXPECT_EQ(offline_map, final_map);
  // The scores.
  const nlohmann::json t = nlohmann::json::parse(offline.metrics_json).at("truth");
  EXPECT_EQ(t.at("accuracy").get<double>(), m.counts.accuracy());
  EXPECT_EQ(t.at("f1").get<double>(), m.counts.f1());
  EXPECT_EQ(t.at("landmarks_created").get<std::uint64_t>(), m.map.landmarks_created);
  EXPECT_EQ(t.at("duplicates").get<std::uint64_t>(), m.map.duplicates);
  EXPECT_EQ(t.at("pose_ate_aligned_m").get<double>(), m.pose_ate_aligned_m);
  EXPECT_EQ(t.at("anees").get<double>(), m.anees);
}

// The two worlds whose DJNN moves its tentative features with the pose (tentative_follow_pose).
INSTANTIATE_TEST_SUITE_P(Worlds, OfflineAgainstEvaluate, testing::Values("arena", "fiducials"));

}  // namespace test_entry_points
}  // namespace ekf_slam
