// The `city` world (issue 14): its size and its drive are what the scale benchmarks need
// (docs/simulation.md, docs/benchmarks.md).
#include <gtest/gtest.h>

#include <cmath>

#include "ekf_slam/evaluation/simulated_run.h"
#include "ekf_slam/evaluation/simulation/simulator.h"

namespace ekf_slam {
namespace test_city_world {

TEST(CityWorld, TenToTwentyThousandLandmarksAndAnHourOfDriving) {
  const sim::World w = sim::makeWorld("city");
  EXPECT_GE(w.landmarks.size(), 10000u);
  EXPECT_LE(w.landmarks.size(), 20000u);
  double route = 0.0;
  Eigen::Vector2d at = w.start_pose.head<2>();
  for (const Eigen::Vector2d& p : w.waypoints) {
    route += (p - at).norm();
    at = p;
  }
  const double hours = route / w.vehicle.speed / 3600.0;
  EXPECT_GT(hours, 0.9);
  EXPECT_LT(hours, 1.2);
  EXPECT_GT(w.max_duration, route / w.vehicle.speed);
  EXPECT_DOUBLE_EQ(w.observation_period, 0.1);
  EXPECT_DOUBLE_EQ(w.sensor.max_range, 30.0);
  // The map is beyond the full EKF's per-scan budget: the pipeline parameters pick cekf.
  EXPECT_EQ(sim::pipelineParametersFor(w).at("filter"), "cekf");
  EXPECT_EQ(std::stod(sim::pipelineParametersFor(w).at("cekf_area_size")), 150.0);
  EXPECT_EQ(std::stod(sim::pipelineParametersFor(w).at("cekf_area_slack")), 5.0);
  EXPECT_EQ(sim::pipelineParametersFor(sim::makeWorld("djnn_weak")).count("filter"), 0u);
}

TEST(CityWorld, StreetsAreLinedWithLandmarksInView) {
  sim::Simulation s(sim::makeWorld("city"), 1);
  int sets = 0;
  std::size_t seen = 0;
  for (auto e = s.next(); e != sim::Simulation::Event::kEnd && sets < 300; e = s.next()) {
    if (e != sim::Simulation::Event::kObservations) continue;
    ++sets;
    seen += s.observations().observations.size();
    // The car stays on its street (a landmark row 7 m either side).
    EXPECT_LT(std::abs(s.observations().true_pose.y()), 5.0) << "set " << sets;
  }
  // Both sides every 5 m, 30 m ahead: about a dozen landmarks per scan.
  EXPECT_GT(seen / sets, 8u);
  EXPECT_LT(seen / sets, 30u);
}

}  // namespace test_city_world
}  // namespace ekf_slam
