// `simulate --world beacons`: a bag with sensor_msgs/LaserScan (intensities) on /scan instead of
// /observations and a YAML selecting BeaconExtractor; ekf_slam_offline maps it and scores it as
// evaluate scores the same seed (truth of the extracted features by proximity to /true_map).
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include <memory>
#include <sstream>
#include <string>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/evaluation/simulated_run.h"
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/tools/simulation_bag.h"
#include "offline_test_options.h"
#include "test_files.h"

namespace ekf_slam {
namespace test_simulate_beacons {

using test_files::TempDir;

TEST(SimulateBeacons, ScanBagIsMappedAndScoredLikeEvaluate) {
  TempDir dir("ekf_slam_simulate_beacons");
  std::ostringstream log;
  SimulationBagOptions o;
  o.world = "beacons";
  o.seed = 2;
  o.out_path = (dir.path() / "beacons.bag").string();
  const SimulationBagSummary s = writeSimulationBag(o, log);
  EXPECT_EQ(s.observation_sets, 0u);
  EXPECT_GT(s.scans, 500u);

  {
    rosbag::Bag bag(s.bag_path, rosbag::bagmode::Read);
    rosbag::View observations(bag, rosbag::TopicQuery(std::vector<std::string>{"/observations"}));
    EXPECT_EQ(observations.size(), 0u);
    rosbag::View scans(bag, rosbag::TopicQuery(std::vector<std::string>{"/scan"}));
    EXPECT_EQ(scans.size(), s.scans);
    const auto first = scans.begin()->instantiate<sensor_msgs::LaserScan>();
    ASSERT_TRUE(first);
    EXPECT_EQ(first->header.frame_id, "laser");
    EXPECT_EQ(first->ranges.size(), 361u);
    EXPECT_EQ(first->intensities.size(), first->ranges.size());
    for (const char* topic : {"/odom", "/ground_truth", "/true_map", "/tf_static"}) {
      rosbag::View v(bag, rosbag::TopicQuery(std::vector<std::string>{topic}));
      EXPECT_GT(v.size(), 0u) << topic;
    }
  }
  const YAML::Node yaml = YAML::LoadFile(s.params_path);
  EXPECT_EQ(yaml["extractor"].as<std::string>(), "ekf_slam/BeaconExtractor");
  EXPECT_DOUBLE_EQ(yaml["BeaconExtractor"]["beacon_radius"].as<double>(), 0.05);

  const OfflineOptions offline =
      test_files::quietOfflineOptions(s.bag_path, s.params_path, dir.file("offline"));
  std::ostringstream offline_log;
  OfflineSummary r;
  ASSERT_NO_THROW(r = runOffline(offline, offline_log)) << offline_log.str();
  EXPECT_EQ(r.scans, s.scans);
  EXPECT_EQ(r.landmarks, 15u) << offline_log.str();

  const nlohmann::json metrics = nlohmann::json::parse(r.metrics_json);
  ASSERT_TRUE(metrics.contains("truth")) << r.metrics_json;
  const nlohmann::json& t = metrics["truth"];
  EXPECT_EQ(t["scored_scans"].get<std::uint64_t>(), s.scans);
  EXPECT_EQ(t["true_landmarks_mapped"].get<std::uint64_t>(), 15u);
  EXPECT_EQ(t["spurious_landmarks"].get<std::uint64_t>(), 0u);

  // The same seed through evaluate's path: the same associations; the pose within what the bag's
  // float32 scan angles change.
  const sim::World world = sim::makeWorld("beacons");
  auto djnn = std::make_shared<DJNN>();
  djnn->configure(MapParameterSource(sim::associatorParametersFor(world, "DJNN")));
  const RunMetrics m = runSimulation(world, 2, sim::pipelineConfigFor(world), djnn);
  EXPECT_EQ(t["tp"].get<std::uint64_t>(), m.counts.tp);
  EXPECT_EQ(t["tn"].get<std::uint64_t>(), m.counts.tn);
  EXPECT_EQ(t["fp"].get<std::uint64_t>(), m.counts.fp);
  EXPECT_NEAR(t["pose_rmse_m"].get<double>(), m.pose_rmse_m, 0.01);
}

}  // namespace test_simulate_beacons
}  // namespace ekf_slam
