// rostest (test/simulation.test): launch/simulation.launch plays the tiny world's bag into the
// ekf_slam node. The test writes the bag and its YAML, starts the launch file with roslaunch on
// rostest's master (rviz off, 10x playback) and checks that the node processed every observation
// set and published a map whose landmarks lie on the true ones; and that it is the offline
// runner's run of the same bag and YAML: the same decision for every observation of every scan,
// the same removals, the same final map to the last bit (issue 35).
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "ekf_slam/AssociationStats.h"
#include "ekf_slam/LandmarkArray.h"
#include "ekf_slam/evaluation/simulated_run.h"
#include "ekf_slam/evaluation/simulation/simulator.h"
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/tools/simulation_bag.h"
#include "offline_test_options.h"
#include "ros_test_wait.h"
#include "roslaunch_child.h"
#include "test_files.h"

namespace fs = std::filesystem;
using test_files::readFile;
using test_files::waitFor;

using test_files::Roslaunch;

TEST(SimulationLaunch, NodeMapsTheTinyWorld) {
  std::string templ = (fs::temp_directory_path() / "ekf_slam_simlaunch_XXXXXX").string();
  ASSERT_NE(mkdtemp(templ.data()), nullptr);
  const fs::path tmp(templ);
  ekf_slam::SimulationBagOptions options;
  options.world = "tiny";
  options.out_path = (tmp / "tiny.bag").string();
  std::ostringstream log;
  const ekf_slam::SimulationBagSummary bag = ekf_slam::writeSimulationBag(options, log);
  ASSERT_GT(bag.observation_sets, 100u);

  ros::NodeHandle nh;
  ekf_slam::LandmarkArray map;
  int maps = 0;
  ros::Subscriber map_sub = nh.subscribe<ekf_slam::LandmarkArray>(
      "/ekf_slam/map", 10, [&](const ekf_slam::LandmarkArray::ConstPtr& m) {
        ++maps;
        map = *m;
      });
  ekf_slam::AssociationStats last;
  int reports = 0;
  std::set<std::string> associators;
  std::map<std::uint32_t, std::string> decisions;  // by scan, as associations.csv has them
  ros::Subscriber stats_sub = nh.subscribe<ekf_slam::AssociationStats>(
      "/ekf_slam/associations", 100000, [&](const ekf_slam::AssociationStats::ConstPtr& m) {
        ++reports;
        last = *m;
        associators.insert(m->associator);
        static const char* kNames[] = {"paired", "new", "tentative", "rejected"};
        std::string row;
        for (std::size_t i = 0; i < m->decision.size(); ++i) {
          row += std::to_string(i) + ' ' + kNames[m->decision[i]] + ' ' +
                 std::to_string(m->landmark_id[i]) + ';';
        }
        for (const auto id : m->removed) row += "removed " + std::to_string(id) + ';';
        if (!row.empty()) decisions[m->scan] = row;
      });

  const std::string launch_log = (tmp / "roslaunch.log").string();
  bool processed_all = false;
  {
    // params: the launch file's default, the YAML simulate wrote beside the bag.
    Roslaunch launch(
        {"ekf_slam", "simulation.launch", "bag:=" + bag.bag_path, "rviz:=false", "rate:=10"},
        launch_log);
    ASSERT_TRUE(launch.started());
    // roslaunch start-up, 2 s delay, 4 s of playback, the node's input timeout.
    const auto done = [&] {
      return reports > 0 && last.scan + 1 == bag.observation_sets && maps > 0 &&
             map.header.stamp == last.header.stamp;
    };
    bool ended = false;
    waitFor([&] { return done() || (ended = launch.exited()); }, 40.0, 0.01);
    processed_all = done();
    EXPECT_FALSE(ended) << "roslaunch ended early:\n" << readFile(launch_log);
  }
  const std::string launch_output = readFile(launch_log);
  // The offline runner on the same bag and YAML.
  const ekf_slam::OfflineOptions offline_options =
      test_files::quietOfflineOptions(bag.bag_path, bag.params_path, (tmp / "offline").string());
  std::ostringstream offline_log;
  const ekf_slam::OfflineSummary offline = ekf_slam::runOffline(offline_options, offline_log);
  const std::string offline_decisions = readFile(offline_options.out_dir + "/associations.csv");
  const std::string offline_map = readFile(offline_options.out_dir + "/landmarks.csv");
  fs::remove_all(tmp);
  ASSERT_TRUE(processed_all) << reports << " reports, last scan " << last.scan << " of "
                             << bag.observation_sets << "; roslaunch output:\n"
                             << launch_output;

  ASSERT_EQ(associators.size(), 1u);
  EXPECT_EQ(*associators.begin(), "ekf_slam/DJNN");
  // The last report's stamp is the last observation set's (sets come every observation period
  // from stamp 0).
  const ekf_slam::sim::World world = ekf_slam::sim::makeWorld("tiny");
  EXPECT_NEAR(last.header.stamp.toSec(),
              (bag.observation_sets - 1) * world.observation_period + ekf_slam::sim::kStampOffset,
              1e-6);

  EXPECT_EQ(map.header.frame_id, "map");
  EXPECT_GE(map.landmarks.size(), 7u);
  EXPECT_LE(map.landmarks.size(), 11u);
  int found = 0;
  for (const auto& p : world.landmarks) {
    for (const auto& lm : map.landmarks) {
      if (std::hypot(lm.x - p.x(), lm.y - p.y()) < 1.0) {
        ++found;
        break;
      }
    }
  }
  EXPECT_GE(found, 7) << "of " << world.landmarks.size() << " true landmarks mapped within 1 m";

  // The node's run is the offline runner's.
  EXPECT_EQ(offline.scans, bag.observation_sets);
  std::map<std::uint32_t, std::string> from_file;
  std::istringstream rows(offline_decisions);
  std::string line;
  std::getline(rows, line);  // header
  while (std::getline(rows, line)) {
    std::vector<std::string> f;
    std::istringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) f.push_back(cell);
    from_file[static_cast<std::uint32_t>(std::stoul(f.at(0)))] +=
        f.at(6) == "removed" ? "removed " + f.at(7) + ";"
                             : f.at(2) + ' ' + f.at(6) + ' ' + f.at(7) + ';';
  }
  ASSERT_EQ(decisions.size(), from_file.size());
  for (const auto& [scan, row] : from_file)
    ASSERT_EQ(decisions[scan], row) << "first difference at scan " << scan;
  std::istringstream landmarks(offline_map);
  std::getline(landmarks, line);
  std::size_t k = 0;
  for (; std::getline(landmarks, line); ++k) {
    ASSERT_LT(k, map.landmarks.size());
    std::istringstream cells(line);
    std::string id, x, y;
    std::getline(cells, id, ',');
    std::getline(cells, x, ',');
    std::getline(cells, y, ',');
    EXPECT_EQ(map.landmarks[k].id, std::stoll(id));
    EXPECT_EQ(map.landmarks[k].x, std::strtod(x.c_str(), nullptr)) << "landmark " << id;
    EXPECT_EQ(map.landmarks[k].y, std::strtod(y.c_str(), nullptr)) << "landmark " << id;
  }
  EXPECT_EQ(k, map.landmarks.size());
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_simulation_launch");
  ros::NodeHandle nh;  // keeps the node alive across the test
  return RUN_ALL_TESTS();
}
