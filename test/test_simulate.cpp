// The simulate command (ekf_slam/tools/simulation_bag.h): the tiny world's bag carries exactly what
// a Simulation of the same world and seed emits, with offset stamps, truth ids, latched
// /true_map and /tf_static; the YAML beside it parses and holds the pipeline parameters; the
// same seed gives the same bag; the offline runner maps the world from it; bad arguments are
// refused with a clear message.
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>
#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "ekf_slam/LandmarkArray.h"
#include "ekf_slam/LandmarkObservationArray.h"
#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/evaluation/simulated_run.h"
#include "ekf_slam/evaluation/simulation/simulator.h"
#include "ekf_slam/evaluation/world_parameters.h"
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/tools/simulation_bag.h"
#include "offline_test_options.h"
#include "test_files.h"

namespace test_simulate {

namespace fs = std::filesystem;
using test_files::TempDir;
using namespace ekf_slam;

// What a Simulation of a world + seed emits, for comparison with the bag.
struct Expected {
  std::vector<sim::OdometrySample> odometry;
  std::vector<sim::ObservationSet> sets;
};

Expected simulate(const sim::World& world, std::uint64_t seed) {
  Expected e;
  sim::Simulation s(world, seed);
  for (auto ev = s.next(); ev != sim::Simulation::Event::kEnd; ev = s.next()) {
    if (ev == sim::Simulation::Event::kOdometry) {
      e.odometry.push_back(s.odometry());
    } else {
      e.sets.push_back(s.observations());
    }
  }
  return e;
}

// Everything of a simulated bag, in View order.
struct BagData {
  std::map<std::string, int> counts;
  std::vector<nav_msgs::Odometry> odom, truth;
  std::vector<LandmarkObservationArray> observations;
  std::vector<LandmarkArray> true_map, movers;
  std::vector<tf2_msgs::TFMessage> tf_static;
  std::vector<visualization_msgs::MarkerArray> true_map_markers;
  std::map<std::string, std::string> latching;  ///< topic -> connection header "latching"
  std::vector<ros::Time> bag_times;             ///< View order
  bool header_equals_bag_time = true;
};

BagData readBag(const std::string& path) {
  rosbag::Bag bag(path, rosbag::bagmode::Read);
  rosbag::View view(bag);
  BagData d;
  for (const rosbag::ConnectionInfo* c : view.getConnections()) {
    const auto it = c->header->find("latching");
    d.latching[c->topic] = it == c->header->end() ? "" : it->second;
  }
  for (const rosbag::MessageInstance& m : view) {
    const std::string& topic = m.getTopic();
    ++d.counts[topic];
    d.bag_times.push_back(m.getTime());
    auto check_stamp = [&](const ros::Time& stamp) {
      d.header_equals_bag_time = d.header_equals_bag_time && stamp == m.getTime();
    };
    if (topic == "/odom" || topic == "/ground_truth") {
      const auto msg = m.instantiate<nav_msgs::Odometry>();
      check_stamp(msg->header.stamp);
      (topic == "/odom" ? d.odom : d.truth).push_back(*msg);
    } else if (topic == "/observations") {
      const auto msg = m.instantiate<LandmarkObservationArray>();
      check_stamp(msg->header.stamp);
      d.observations.push_back(*msg);
    } else if (topic == "/true_map" || topic == "/movers") {
      const auto msg = m.instantiate<LandmarkArray>();
      check_stamp(msg->header.stamp);
      (topic == "/true_map" ? d.true_map : d.movers).push_back(*msg);
    } else if (topic == "/tf_static") {
      d.tf_static.push_back(*m.instantiate<tf2_msgs::TFMessage>());
    } else if (topic == "/true_map_markers") {
      d.true_map_markers.push_back(*m.instantiate<visualization_msgs::MarkerArray>());
    }
  }
  return d;
}

// Bit-for-bit equal (the messages' operator== fails on the NaN descriptors).
bool sameObservations(const LandmarkObservationArray& a, const LandmarkObservationArray& b) {
  if (a.header != b.header || a.observations.size() != b.observations.size()) return false;
  for (std::size_t i = 0; i < a.observations.size(); ++i) {
    const LandmarkObservation& x = a.observations[i];
    const LandmarkObservation& y = b.observations[i];
    if (x.range != y.range || x.bearing != y.bearing || x.covariance != y.covariance ||
        x.truth_id != y.truth_id || x.has_truth_id != y.has_truth_id) {
      return false;
    }
  }
  return true;
}

double parseNumber(const std::string& text) { return std::strtod(text.c_str(), nullptr); }

class SimulateTiny : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    options_.world = "tiny";
    options_.out_path = (dir_->path() / "tiny.bag").string();
    std::ostringstream log;
    summary_ = writeSimulationBag(options_, log);
    data_ = new BagData(readBag(options_.out_path));
  }
  static void TearDownTestSuite() {
    delete data_;
    delete dir_;
  }

  static TempDir* dir_;
  static SimulationBagOptions options_;
  static SimulationBagSummary summary_;
  static BagData* data_;
};
TempDir* SimulateTiny::dir_ = nullptr;
SimulationBagOptions SimulateTiny::options_;
SimulationBagSummary SimulateTiny::summary_;
BagData* SimulateTiny::data_ = nullptr;

TEST_F(SimulateTiny, CountsMatchTheSimulation) {
  const sim::World world = sim::makeWorld("tiny");
  const Expected e = simulate(world, world.default_seed);
  ASSERT_GT(e.sets.size(), 100u);
  EXPECT_EQ(summary_.seed, world.default_seed);
  EXPECT_EQ(summary_.odometry, e.odometry.size());
  EXPECT_EQ(summary_.observation_sets, e.sets.size());
  std::size_t observations = 0;
  for (const auto& s : e.sets) observations += s.observations.size();
  EXPECT_EQ(summary_.observations, observations);
  EXPECT_EQ(
      summary_.landmark_observations + summary_.mover_observations + summary_.clutter_observations,
      observations);
  EXPECT_GT(summary_.mover_observations, 0u);
  EXPECT_GT(summary_.clutter_observations, 0u);
  EXPECT_EQ(summary_.landmarks, world.landmarks.size());
  EXPECT_EQ(summary_.movers, 1u);
  EXPECT_NEAR(summary_.duration_s, e.odometry.back().stamp, 1e-9);
  EXPECT_EQ(summary_.params_path, (dir_->path() / "tiny.yaml").string());

  const BagData& d = *data_;
  EXPECT_EQ(d.counts.at("/odom"), static_cast<int>(e.odometry.size()));
  EXPECT_EQ(d.counts.at("/ground_truth"), static_cast<int>(e.odometry.size()));
  EXPECT_EQ(d.counts.at("/observations"), static_cast<int>(e.sets.size()));
  EXPECT_EQ(d.counts.at("/movers"), static_cast<int>(e.sets.size()));
  EXPECT_EQ(d.counts.at("/movers_markers"), static_cast<int>(e.sets.size()));
  EXPECT_EQ(d.counts.at("/true_map"), 1);
  EXPECT_EQ(d.counts.at("/true_map_markers"), 1);
  EXPECT_EQ(d.counts.at("/tf_static"), 1);
  EXPECT_EQ(d.counts.size(), 8u);
}

TEST_F(SimulateTiny, StampsAreOffsetAndOrdered) {
  const sim::World world = sim::makeWorld("tiny");
  const Expected e = simulate(world, world.default_seed);
  const BagData& d = *data_;
  EXPECT_TRUE(d.header_equals_bag_time);
  ASSERT_FALSE(d.bag_times.empty());
  EXPECT_NEAR(d.bag_times.front().toSec(), sim::kStampOffset, 1e-9);
  for (std::size_t i = 1; i < d.bag_times.size(); ++i) {
    ASSERT_LE(d.bag_times[i - 1], d.bag_times[i]) << "message " << i << " goes back in time";
  }
  ASSERT_EQ(d.odom.size(), e.odometry.size());
  for (std::size_t i = 0; i < d.odom.size(); ++i) {
    EXPECT_NEAR(d.odom[i].header.stamp.toSec(), e.odometry[i].stamp + sim::kStampOffset, 1e-9);
    EXPECT_EQ(d.odom[i].header.seq, i);
    EXPECT_EQ(d.truth[i].header.stamp, d.odom[i].header.stamp);
    EXPECT_EQ(d.truth[i].header.seq, i);
  }
  ASSERT_EQ(d.observations.size(), e.sets.size());
  for (std::size_t i = 0; i < d.observations.size(); ++i) {
    EXPECT_NEAR(d.observations[i].header.stamp.toSec(), e.sets[i].stamp + sim::kStampOffset, 1e-9);
    EXPECT_EQ(d.observations[i].header.seq, i);
    EXPECT_EQ(d.movers[i].header.stamp, d.observations[i].header.stamp);
  }
  // Every observation set has the odometry sample of its stamp (the simulator emits it first;
  // the node's and the runner's sequencer put odometry first at equal stamps).
  std::size_t k = 0;
  for (const auto& set : d.observations) {
    while (k < d.odom.size() && d.odom[k].header.stamp < set.header.stamp) ++k;
    ASSERT_LT(k, d.odom.size());
    EXPECT_EQ(d.odom[k].header.stamp, set.header.stamp);
  }
}

TEST_F(SimulateTiny, MessagesCarryTheSimulation) {
  const sim::World world = sim::makeWorld("tiny");
  const Expected e = simulate(world, world.default_seed);
  const BagData& d = *data_;
  const TwistParams noise = sim::twistNoiseFor(world);
  ASSERT_EQ(d.odom.size(), e.odometry.size());
  for (std::size_t i = 0; i < d.odom.size(); ++i) {
    const nav_msgs::Odometry& o = d.odom[i];
    const sim::OdometrySample& s = e.odometry[i];
    ASSERT_EQ(o.header.frame_id, "odom");
    ASSERT_EQ(o.child_frame_id, "base_link");
    EXPECT_DOUBLE_EQ(o.pose.pose.position.x, s.pose.x());
    EXPECT_DOUBLE_EQ(o.pose.pose.position.y, s.pose.y());
    const double yaw = 2.0 * std::atan2(o.pose.pose.orientation.z, o.pose.pose.orientation.w);
    EXPECT_NEAR(std::remainder(yaw - s.pose.z(), 2.0 * M_PI), 0.0, 1e-12);
    EXPECT_DOUBLE_EQ(o.twist.twist.linear.x, s.twist.x());
    EXPECT_DOUBLE_EQ(o.twist.twist.angular.z, s.twist.y());
    const double sv = noise.sigma_v + noise.sigma_v_per_v * std::abs(s.twist.x());
    const double sw = noise.sigma_w + noise.sigma_w_per_v * std::abs(s.twist.x());
    EXPECT_DOUBLE_EQ(o.twist.covariance[0], sv * sv);
    EXPECT_DOUBLE_EQ(o.twist.covariance[35], sw * sw);
    // The dead-reckoning covariance starts at zero and its yaw variance only grows (the yaw row
    // of the twist model's Jacobian is (0, 0, 1)).
    EXPECT_GE(o.pose.covariance[35], i == 0 ? 0.0 : d.odom[i - 1].pose.covariance[35]);
    EXPECT_EQ(o.pose.covariance[1], o.pose.covariance[6]);
    EXPECT_GE(o.pose.covariance[0], 0.0);

    const nav_msgs::Odometry& t = d.truth[i];
    ASSERT_EQ(t.header.frame_id, "map");
    ASSERT_EQ(t.child_frame_id, "base_link");
    EXPECT_DOUBLE_EQ(t.pose.pose.position.x, s.true_pose.x());
    EXPECT_DOUBLE_EQ(t.pose.pose.position.y, s.true_pose.y());
    EXPECT_DOUBLE_EQ(t.twist.twist.linear.x, s.true_twist.x());
    EXPECT_DOUBLE_EQ(t.twist.twist.angular.z, s.true_twist.y());
  }
  EXPECT_GT(d.odom.back().pose.covariance[0], 0.0);

  ASSERT_EQ(d.observations.size(), e.sets.size());
  for (std::size_t i = 0; i < e.sets.size(); ++i) {
    const LandmarkObservationArray& msg = d.observations[i];
    const sim::ObservationSet& set = e.sets[i];
    ASSERT_EQ(msg.header.frame_id, "laser");
    ASSERT_EQ(msg.observations.size(), set.observations.size()) << "set " << i;
    for (std::size_t j = 0; j < set.observations.size(); ++j) {
      const LandmarkObservation& o = msg.observations[j];
      const sim::SimObservation& z = set.observations[j];
      EXPECT_EQ(o.range, z.z.x());
      EXPECT_EQ(o.bearing, z.z.y());
      EXPECT_TRUE(o.has_truth_id);
      EXPECT_EQ(o.truth_id, z.truth_id);
      EXPECT_TRUE(std::isnan(o.descriptor));
      EXPECT_EQ(o.covariance[0], z.R(0, 0));
      EXPECT_EQ(o.covariance[1], z.R(0, 1));
      EXPECT_EQ(o.covariance[2], z.R(1, 0));
      EXPECT_EQ(o.covariance[3], z.R(1, 1));
    }
    ASSERT_EQ(d.movers[i].landmarks.size(), 1u);
    EXPECT_EQ(d.movers[i].landmarks[0].id, sim::moverId(0));
    EXPECT_EQ(d.movers[i].header.frame_id, "map");
  }

  ASSERT_EQ(d.true_map.size(), 1u);
  const LandmarkArray& map = d.true_map[0];
  EXPECT_EQ(map.header.frame_id, "map");
  ASSERT_EQ(map.landmarks.size(), world.landmarks.size());
  for (std::size_t k = 0; k < world.landmarks.size(); ++k) {
    EXPECT_EQ(map.landmarks[k].id, static_cast<std::int64_t>(k));
    EXPECT_EQ(map.landmarks[k].x, world.landmarks[k].x());
    EXPECT_EQ(map.landmarks[k].y, world.landmarks[k].y());
    EXPECT_TRUE(std::isnan(map.landmarks[k].diameter));
    for (double c : map.landmarks[k].covariance) EXPECT_EQ(c, 0.0);
  }
  ASSERT_EQ(d.true_map_markers.size(), 1u);
  ASSERT_EQ(d.true_map_markers[0].markers.size(), 1u);
  EXPECT_EQ(d.true_map_markers[0].markers[0].points.size(), world.landmarks.size());

  ASSERT_EQ(d.tf_static.size(), 1u);
  ASSERT_EQ(d.tf_static[0].transforms.size(), 1u);
  const auto& tf = d.tf_static[0].transforms[0];
  EXPECT_EQ(tf.header.frame_id, "base_link");
  EXPECT_EQ(tf.child_frame_id, "laser");
  EXPECT_EQ(tf.transform.translation.x, world.sensor.offset.x());
  EXPECT_EQ(tf.transform.translation.y, world.sensor.offset.y());
  EXPECT_NEAR(tf.transform.rotation.w, std::cos(world.sensor.offset.z() / 2), 1e-15);
}

TEST_F(SimulateTiny, StaticTopicsAreLatched) {
  const BagData& d = *data_;
  EXPECT_EQ(d.latching.at("/true_map"), "1");
  EXPECT_EQ(d.latching.at("/tf_static"), "1");
  EXPECT_EQ(d.latching.at("/true_map_markers"), "1");
  EXPECT_NE(d.latching.at("/odom"), "1");
  EXPECT_NE(d.latching.at("/observations"), "1");
}

TEST_F(SimulateTiny, ParameterFileHoldsThePipelineParameters) {
  const sim::World world = sim::makeWorld("tiny");
  std::ifstream in(summary_.params_path);
  std::string first_line;
  std::getline(in, first_line);
  EXPECT_EQ(first_line.rfind("# ", 0), 0u);
  EXPECT_NE(first_line.find("world tiny, seed " + std::to_string(world.default_seed)),
            std::string::npos)
      << first_line;

  YAML::Node root;
  ASSERT_NO_THROW(root = YAML::LoadFile(summary_.params_path));
  ASSERT_TRUE(root.IsMap());
  EXPECT_EQ(root["associator"].as<std::string>(), "ekf_slam/DJNN");
  const auto pipeline = sim::pipelineParametersFor(world);
  ASSERT_FALSE(pipeline.empty());
  for (const auto& [name, value] : pipeline) {
    ASSERT_TRUE(root[name]) << name << " missing";
    char* end = nullptr;
    const double number = std::strtod(value.c_str(), &end);
    if (*end == '\0') {
      EXPECT_EQ(root[name].as<double>(), number) << name;
    } else {
      EXPECT_EQ(root[name].as<std::string>(), value) << name;
    }
  }
  ASSERT_TRUE(root["DJNN"]);
  ASSERT_TRUE(root["DJNN"].IsMap());
  for (const auto& [name, value] : sim::associatorParametersFor(world, "DJNN")) {
    ASSERT_TRUE(root["DJNN"][name]) << "DJNN/" << name << " missing";
    EXPECT_EQ(root["DJNN"][name].as<double>(), parseNumber(value)) << name;
  }
}

TEST(SimulateYaml, NumbersReadBackAsNumbersInBothYamlDialects) {
  const std::string text =
      simulationParamsYaml("w",
                           {{"a", "1e-05"},
                            {"b", "inf"},
                            {"c", "3"},
                            {"d", "twist"},
                            {"e", "0.10000000000000001"},
                            {"f", "a b: c"}},
                           {{"DJNN", {}}, {"JCBB", {{"x", "2.5"}}}}, {"header"});
  // PyYAML (rosparam) reads a float only with a dot and a signed exponent, infinity as .inf.
  EXPECT_NE(text.find("a: 1.0e-05\n"), std::string::npos) << text;
  EXPECT_NE(text.find("b: .inf\n"), std::string::npos) << text;
  EXPECT_NE(text.find("c: 3\n"), std::string::npos) << text;
  EXPECT_NE(text.find("e: 0.1\n"), std::string::npos) << text;
  EXPECT_NE(text.find("DJNN: {}\n"), std::string::npos) << text;
  EXPECT_EQ(text.rfind("# header\n", 0), 0u);
  const YAML::Node root = YAML::Load(text);
  EXPECT_EQ(root["a"].as<double>(), 1e-05);
  EXPECT_TRUE(std::isinf(root["b"].as<double>()));
  EXPECT_EQ(root["c"].as<int>(), 3);
  EXPECT_EQ(root["d"].as<std::string>(), "twist");
  EXPECT_EQ(root["e"].as<double>(), 0.1);
  EXPECT_EQ(root["f"].as<std::string>(), "a b: c");
  EXPECT_EQ(root["JCBB"]["x"].as<double>(), 2.5);
  EXPECT_EQ(root["DJNN"].size(), 0u);
}

// config/arena.yaml and config/fiducials.yaml are what `simulate` writes for their world: a key
// added to a world's parameters and not to the shipped file would give roslaunch users another
// filter than `evaluate` scores. Comment lines (the header) may differ.
// Issue 31: a world's parameter file holds what a user knows (the sensor's datasheet, the
// vehicle), never what only the simulator knows. Every world's file is the same after its truth
// (where the landmarks are, how many, the clutter, the movers) is changed, and names none of the
// keys the oracle configuration computes from it.
TEST(SimulateYaml, NoWorldsParameterFileHoldsTheTruth) {
  const std::vector<std::string> truth_keys = {
      "landmark_density",      "landmark_spacing",     "clutter_density",    "static_min_speed",
      "tentative_follow_pose", "static_heading",       "bias_keep_pairings", "admit_evidence",
      "loop_closure_age",      "remembered_sightings", "held_birth_cost",    "held_confirmations"};
  for (const std::string& name : sim::worldNames()) {
    const sim::World world = sim::makeWorld(name);
    const std::string written = worldParamsYaml(world, {});
    for (const std::string& key : truth_keys)
      EXPECT_EQ(written.find(key + ":"), std::string::npos) << name << " writes " << key;
    sim::World other = world;
    for (Eigen::Vector2d& l : other.landmarks)
      l = 0.5 * (l + world.area_min) + Eigen::Vector2d(0.3, 0.1);
    other.landmarks.resize(other.landmarks.size() / 2 + 1, world.area_min);
    other.clutter_rate = 2.0 * world.clutter_rate + 1.0;
    other.movers.count = world.movers.count + 3;
    other.movers.min_speed = 0.5 * world.movers.min_speed + 0.1;
    EXPECT_EQ(written, worldParamsYaml(other, {}))
        << name << ": the parameters depend on the truth";
  }
  // The oracle's configuration, for comparison, does (evaluate --oracle).
  const sim::World fiducials = sim::makeWorld("fiducials");
  EXPECT_EQ(sim::associatorParametersFor(fiducials, "DJNN", sim::Knowledge::kOracle)
                .count("landmark_density"),
            1u);
}

TEST(SimulateYaml, ShippedWorldConfigsAreWhatSimulateWrites) {
  const auto without_comments = [](std::istream& in) {
    std::string line, body;
    while (std::getline(in, line)) {
      if (!line.empty() && line[0] != '#') body += line + "\n";
    }
    return body;
  };
  for (const std::string name : {"arena", "fiducials"}) {
    const std::string path = std::string(EKF_SLAM_SOURCE_DIR) + "/config/" + name + ".yaml";
    std::ifstream shipped(path);
    ASSERT_TRUE(shipped) << path;
    std::istringstream written(worldParamsYaml(sim::makeWorld(name), {}));
    EXPECT_EQ(without_comments(shipped), without_comments(written))
        << path << " is out of date: regenerate its body with `rosrun ekf_slam simulate --world "
        << name << " --out /tmp/" << name << ".bag` (keep the header comment)";
  }
}

TEST(Simulate, SameSeedSameBagOtherSeedOtherBag) {
  TempDir dir("ekf_slam_simulate");
  ASSERT_FALSE(dir.path().empty());
  std::ostringstream log;
  SimulationBagOptions o;
  o.world = "tiny";
  o.seed = 7;
  o.write_params = false;
  o.out_path = (dir.path() / "a.bag").string();
  const SimulationBagSummary a = writeSimulationBag(o, log);
  o.out_path = (dir.path() / "b.bag").string();
  writeSimulationBag(o, log);
  o.seed = 8;
  o.out_path = (dir.path() / "c.bag").string();
  writeSimulationBag(o, log);
  EXPECT_TRUE(a.params_path.empty());
  EXPECT_FALSE(fs::exists(dir.path() / "a.yaml"));

  const BagData da = readBag((dir.path() / "a.bag").string());
  const BagData db = readBag((dir.path() / "b.bag").string());
  const BagData dc = readBag((dir.path() / "c.bag").string());
  ASSERT_EQ(da.observations.size(), db.observations.size());
  for (std::size_t i = 0; i < da.observations.size(); ++i) {
    ASSERT_TRUE(sameObservations(da.observations[i], db.observations[i])) << "set " << i;
  }
  ASSERT_EQ(da.odom.size(), db.odom.size());
  for (std::size_t i = 0; i < da.odom.size(); ++i) ASSERT_EQ(da.odom[i], db.odom[i]);
  bool differ = da.observations.size() != dc.observations.size();
  for (std::size_t i = 0; !differ && i < da.observations.size(); ++i) {
    differ = !sameObservations(da.observations[i], dc.observations[i]);
  }
  EXPECT_TRUE(differ) << "seeds 7 and 8 gave the same observations";
}

TEST(Simulate, OverridesAndParamsPath) {
  TempDir dir("ekf_slam_simulate");
  std::ostringstream log;
  SimulationBagOptions o;
  o.world = "tiny";
  o.movers = 0;
  o.clutter_rate = 0.0;
  o.markers = false;
  o.out_path = (dir.path() / "quiet.bag").string();
  o.params_path = (dir.path() / "custom.yaml").string();
  const SimulationBagSummary s = writeSimulationBag(o, log);
  EXPECT_EQ(s.mover_observations, 0u);
  EXPECT_EQ(s.clutter_observations, 0u);
  EXPECT_EQ(s.movers, 0u);
  EXPECT_EQ(s.params_path, o.params_path);
  EXPECT_TRUE(fs::exists(o.params_path));
  const BagData d = readBag(o.out_path);
  EXPECT_EQ(d.counts.count("/movers"), 0u);
  EXPECT_EQ(d.counts.count("/movers_markers"), 0u);
  EXPECT_EQ(d.counts.count("/true_map_markers"), 0u);
  std::ifstream in(o.params_path);
  std::string first_line;
  std::getline(in, first_line);
  EXPECT_NE(first_line.find("clutter rate 0, 0 movers"), std::string::npos) << first_line;
}

// writeSimulationBag refuses `o` with a std::invalid_argument whose message holds `what`.
void expectRefused(const SimulationBagOptions& o, const std::string& what) {
  std::ostringstream log;
  try {
    writeSimulationBag(o, log);
    ADD_FAILURE() << "accepted: world " << o.world;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

TEST(Simulate, ErrorsLeaveNoFiles) {
  TempDir dir("ekf_slam_simulate");
  std::ostringstream log;
  SimulationBagOptions o;
  o.world = "no_such_world";
  o.out_path = (dir.path() / "x.bag").string();
  expectRefused(o, "djnn_weak");  // the message lists the known worlds
  EXPECT_FALSE(fs::exists(o.out_path));
  o.world = "tiny";
  o.out_path = (dir.path() / "missing" / "x.bag").string();
  EXPECT_THROW(writeSimulationBag(o, log), std::runtime_error);
}

// --detection-probability: the sensor misses landmarks at that rate, and the parameter file states
// it as the datasheet's P_D (DJNN's detection_probability).
TEST(Simulate, DetectionProbabilityOverride) {
  TempDir dir("ekf_slam_simulate");
  std::ostringstream log;
  SimulationBagOptions o;
  o.world = "tiny";
  o.markers = false;
  o.out_path = (dir.path() / "all.bag").string();
  const SimulationBagSummary all = writeSimulationBag(o, log);
  o.detection_probability = 0.5;
  o.out_path = (dir.path() / "half.bag").string();
  const SimulationBagSummary half = writeSimulationBag(o, log);
  const double share = static_cast<double>(half.landmark_observations) /
                       static_cast<double>(all.landmark_observations);
  EXPECT_GT(share, 0.45);
  EXPECT_LT(share, 0.55);
  const YAML::Node root = YAML::LoadFile(half.params_path);
  EXPECT_DOUBLE_EQ(root["DJNN"]["detection_probability"].as<double>(), 0.5);
  const YAML::Node plain = YAML::LoadFile(all.params_path);
  EXPECT_FALSE(plain["DJNN"]["detection_probability"]);  // tiny's sensor sees everything
}

// The laser world's scans are ray-cast: movers, clutter or a detection probability asked of it
// would be in the truth but in no scan, so they are refused rather than dropped.
TEST(Simulate, LaserWorldRefusesMoversAndClutter) {
  TempDir dir("ekf_slam_simulate");
  std::ostringstream log;
  SimulationBagOptions o;
  o.world = "beacons";
  o.out_path = (dir.path() / "b.bag").string();
  o.movers = 10;
  expectRefused(o, "ray-cast");
  o.movers.reset();
  o.clutter_rate = 2.0;
  EXPECT_THROW(writeSimulationBag(o, log), std::invalid_argument);
  o.clutter_rate.reset();
  o.detection_probability = 0.5;
  EXPECT_THROW(writeSimulationBag(o, log), std::invalid_argument);
  EXPECT_FALSE(fs::exists(o.out_path));
}

TEST(Simulate, OfflineRunnerMapsTheWorld) {
  TempDir dir("ekf_slam_simulate");
  std::ostringstream log;
  SimulationBagOptions o;
  o.world = "tiny";
  o.out_path = (dir.path() / "tiny.bag").string();
  const SimulationBagSummary s = writeSimulationBag(o, log);

  const OfflineOptions offline =
      test_files::quietOfflineOptions(s.bag_path, s.params_path, dir.file("offline"));
  std::ostringstream offline_log;
  OfflineSummary r;
  ASSERT_NO_THROW(r = runOffline(offline, offline_log)) << offline_log.str();
  EXPECT_EQ(r.associator, "DJNN");
  EXPECT_EQ(r.scans, s.observation_sets);
  EXPECT_EQ(r.odometry, s.odometry);
  // 8 landmarks; a mover or clutter return may add one or two.
  EXPECT_GE(r.landmarks, 7u) << offline_log.str();
  EXPECT_LE(r.landmarks, 11u);

  // The mapped landmarks lie on the true ones (the map frame is the world frame: the YAML's
  // initial pose is the start pose).
  const sim::World world = sim::makeWorld("tiny");
  std::vector<Eigen::Vector2d> mapped;
  for (const auto& [x, y] : test_files::landmarkPositions(offline.out_dir + "/landmarks.csv"))
    mapped.emplace_back(x, y);
  int found = 0;
  for (const auto& p : world.landmarks) {
    for (const auto& m : mapped) {
      if ((m - p).norm() < 1.0) {
        ++found;
        break;
      }
    }
  }
  EXPECT_GE(found, 7) << "of " << world.landmarks.size() << " true landmarks within 1 m";

  // Scored against the bag's truth (regression guard, generous on purpose) ...
  const nlohmann::json metrics = nlohmann::json::parse(r.metrics_json);
  ASSERT_TRUE(metrics.contains("truth")) << r.metrics_json;
  const nlohmann::json& t = metrics["truth"];
  EXPECT_GT(t["accuracy"].get<double>(), 0.95) << t.dump();
  EXPECT_EQ(t["scored_scans"].get<std::uint64_t>(), s.observation_sets);
  EXPECT_EQ(t["ground_truth_poses"].get<std::uint64_t>(), s.odometry);
  EXPECT_LT(t["pose_rmse_m"].get<double>(), 1.0);
  // ... with the numbers evaluate gets for the same world and seed without a bag.
  auto djnn = std::make_shared<DJNN>();
  djnn->configure(MapParameterSource(sim::associatorParametersFor(world, "DJNN")));
  const RunMetrics direct =
      runSimulation(world, world.default_seed, sim::pipelineConfigFor(world), djnn);
  EXPECT_EQ(t["tp"].get<std::uint64_t>(), direct.counts.tp);
  EXPECT_EQ(t["fp"].get<std::uint64_t>(), direct.counts.fp);
  EXPECT_EQ(t["fn"].get<std::uint64_t>(), direct.counts.fn);
  EXPECT_EQ(t["tn"].get<std::uint64_t>(), direct.counts.tn);
  EXPECT_EQ(t["spurious_landmarks"].get<std::size_t>(), direct.map.spurious);
  EXPECT_NEAR(t["pose_rmse_m"].get<double>(), direct.pose_rmse_m, 1e-6);
  EXPECT_EQ(t["landmarks_created"].get<std::uint64_t>(), direct.map.landmarks_created);
  EXPECT_NEAR(t["pairing_coverage"].get<double>(), direct.map.pairing_coverage, 1e-12);
  EXPECT_NEAR(t["landmark_recall"].get<double>(), direct.map.landmark_recall, 1e-12);
  EXPECT_NEAR(t["pose_ate_aligned_m"].get<double>(), direct.pose_ate_aligned_m, 1e-6);
  EXPECT_NEAR(t["map_rmse_aligned_m"].get<double>(), direct.map_rmse_aligned_m, 1e-6);
  // The aligned error cannot exceed the unaligned one (the identity is one of the transforms).
  EXPECT_LE(direct.pose_ate_aligned_m, direct.pose_rmse_m + 1e-12);
  EXPECT_LT(direct.map_rmse_aligned_m, 1.0);

  // associations.csv alone (with its removal rows) gives the same scores again.
  std::ifstream assoc(offline.out_dir + "/associations.csv");
  std::string line;
  std::getline(assoc, line);
  ASSERT_EQ(line, "scan,stamp,obs,range,bearing,diameter,decision,landmark_id,truth_id");
  AssociationScorer rescored;
  std::vector<LandmarkId> truth, ids, removed;
  std::vector<Decision> decisions;
  const auto flush = [&]() {
    rescored.addScan(truth, decisions, ids, removed);
    truth.clear(), ids.clear(), removed.clear(), decisions.clear();
  };
  std::string scan = "", field;
  while (std::getline(assoc, line)) {
    std::vector<std::string> f;
    std::istringstream row(line);
    while (std::getline(row, field, ',')) f.push_back(field);
    if (line.back() == ',') f.emplace_back();
    ASSERT_EQ(f.size(), 9u) << line;
    if (f[0] != scan && !scan.empty()) flush();
    scan = f[0];
    if (f[6] == "removed") {
      removed.push_back(std::stoll(f[7]));
      continue;
    }
    truth.push_back(std::stoll(f[8]));
    ids.push_back(std::stoll(f[7]));
    decisions.push_back(f[6] == "paired"      ? Decision::kPaired
                        : f[6] == "new"       ? Decision::kNew
                        : f[6] == "tentative" ? Decision::kTentative
                                              : Decision::kRejected);
  }
  flush();
  EXPECT_EQ(rescored.counts().tp, direct.counts.tp);
  EXPECT_EQ(rescored.counts().fp, direct.counts.fp);
  EXPECT_EQ(rescored.counts().fn, direct.counts.fn);
  EXPECT_EQ(rescored.counts().tn, direct.counts.tn);
  EXPECT_EQ(rescored.mapScore().landmarks, direct.map.landmarks);
  EXPECT_EQ(rescored.mapScore().landmarks_created, direct.map.landmarks_created);
  EXPECT_EQ(rescored.mapScore().duplicates, direct.map.duplicates);
}

TEST(SimulateArguments, Parse) {
  auto parse = [](std::vector<std::string> args, SimulationBagOptions* o, SimulateAction* a,
                  std::string* error) { return parseSimulateArguments(args, o, a, error); };
  SimulationBagOptions o;
  SimulateAction a;
  std::string error;
  ASSERT_TRUE(parse({"--world", "djnn_weak", "--out", "x.bag"}, &o, &a, &error)) << error;
  EXPECT_EQ(a, SimulateAction::kRun);
  EXPECT_EQ(o.world, "djnn_weak");
  EXPECT_EQ(o.out_path, "x.bag");
  EXPECT_FALSE(o.seed.has_value());
  EXPECT_TRUE(o.write_params);
  EXPECT_TRUE(o.params_path.empty());

  o = SimulationBagOptions();
  ASSERT_TRUE(parse({"--world", "tiny", "--seed", "42", "--out", "x.bag", "--params-out", "p.yaml",
                     "--clutter-rate", "1.5", "--movers", "3", "--no-markers"},
                    &o, &a, &error))
      << error;
  EXPECT_EQ(*o.seed, 42u);
  EXPECT_EQ(o.params_path, "p.yaml");
  EXPECT_EQ(*o.clutter_rate, 1.5);
  EXPECT_EQ(*o.movers, 3);
  EXPECT_FALSE(o.markers);

  o = SimulationBagOptions();
  ASSERT_TRUE(parse({"--list"}, &o, &a, &error));
  EXPECT_EQ(a, SimulateAction::kList);
  ASSERT_TRUE(parse({"--help"}, &o, &a, &error));
  EXPECT_EQ(a, SimulateAction::kHelp);

  o = SimulationBagOptions();
  ASSERT_TRUE(parse({"--world", "fiducials", "--out", "x.bag", "--detection-probability", "0.4"},
                    &o, &a, &error))
      << error;
  EXPECT_EQ(*o.detection_probability, 0.4);
  for (const char* bad : {"0", "1.5", "x"}) {
    EXPECT_FALSE(parse({"--world", "fiducials", "--out", "x.bag", "--detection-probability", bad},
                       &o, &a, &error));
    EXPECT_NE(error.find("--detection-probability"), std::string::npos) << error;
  }

  // The laser world refuses movers and clutter (its scans are ray-cast); 0 is what it has.
  o = SimulationBagOptions();
  EXPECT_FALSE(parse({"--world", "beacons", "--out", "x.bag", "--movers", "5"}, &o, &a, &error));
  EXPECT_NE(error.find("ray-cast"), std::string::npos) << error;
  o = SimulationBagOptions();
  EXPECT_TRUE(parse({"--world", "beacons", "--out", "x.bag", "--movers", "0"}, &o, &a, &error));

  // Unknown world: the message lists the known ones.
  o = SimulationBagOptions();
  EXPECT_FALSE(parse({"--world", "nowhere", "--out", "x.bag"}, &o, &a, &error));
  EXPECT_NE(error.find("unknown world 'nowhere'"), std::string::npos) << error;
  for (const std::string& name : sim::worldNames()) {
    EXPECT_NE(error.find(name), std::string::npos) << name << " not listed: " << error;
  }

  const std::vector<std::vector<std::string>> bad = {
      {"--out", "x.bag"},                                      // no world
      {"--world", "tiny"},                                     // no output
      {"--world", "tiny", "--out"},                            // value missing
      {"--world", "tiny", "--out", "x.bag", "--seed", "-1"},   // negative seed
      {"--world", "tiny", "--out", "x.bag", "--seed", "1.5"},  // not an integer
      {"--world", "tiny", "--out", "x.bag", "--clutter-rate", "-1"},
      {"--world", "tiny", "--out", "x.bag", "--clutter-rate", "nan"},
      {"--world", "tiny", "--out", "x.bag", "--movers", "two"},
      {"--world", "tiny", "--out", "x.bag", "--params-out", "p.yaml", "--no-params"},
      {"--world", "tiny", "--out", "x.bag", "--frobnicate"},
  };
  for (const auto& args : bad) {
    o = SimulationBagOptions();
    error.clear();
    std::string joined;
    for (const auto& s : args) joined += s + " ";
    EXPECT_FALSE(parse(args, &o, &a, &error)) << joined;
    EXPECT_FALSE(error.empty()) << joined;
  }
}

TEST(SimulateArguments, ExitCodes) {
  TempDir dir("ekf_slam_simulate");
  auto run = [](std::vector<std::string> args) {
    std::vector<char*> argv;
    static std::string program = "simulate";
    argv.push_back(program.data());
    for (auto& a : args) argv.push_back(a.data());
    return simulateMain(static_cast<int>(argv.size()), argv.data());
  };
  EXPECT_EQ(run({"--world", "nowhere", "--out", "x.bag"}), 2);
  EXPECT_EQ(run({"--world", "tiny"}), 2);
  EXPECT_EQ(run({"--world", "tiny", "--out", (dir.path() / "no" / "x.bag").string()}), 1);
  EXPECT_EQ(run({"--world", "tiny", "--out", (dir.path() / "ok.bag").string()}), 0);
  EXPECT_TRUE(fs::exists(dir.path() / "ok.bag"));
  EXPECT_TRUE(fs::exists(dir.path() / "ok.yaml"));
}

TEST(SimulateArguments, DefaultParamsPath) {
  EXPECT_EQ(defaultParamsPath("/tmp/run.bag"), "/tmp/run.yaml");
  EXPECT_EQ(defaultParamsPath("dir.bag/run"), "dir.bag/run.yaml");
  EXPECT_EQ(defaultParamsPath(".bag"), ".bag.yaml");
}

}  // namespace test_simulate
