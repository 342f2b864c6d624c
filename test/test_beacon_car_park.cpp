// The `beacons` car park (sim::beaconCarPark): scans ray-cast with intensities, the pipeline with
// BeaconExtractor and DJNN, 20 seeds. Every beacon mapped exactly once, nothing else in the map,
// map error < 0.3 m, pose RMSE < 0.3 m, association accuracy >= 0.99 (docs/feature_extraction.md).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <vector>

#include "ekf_slam/core/association/djnn.h"
#include "ekf_slam/core/feature_extraction/beacon_extractor.h"
#include "ekf_slam/core/pose2d.h"
#include "ekf_slam/core/simulated_run.h"
#include "ekf_slam/core/simulation/laser_scan_simulator.h"
#include "ekf_slam/core/trajectory_metrics.h"

using namespace ekf_slam;

namespace {

struct CarParkRun {
  RunMetrics metrics;
  double map_error_rms = 0.0;      ///< after rigid alignment [m]
  double map_error_max = 0.0;      ///< farthest map landmark from its beacon, aligned [m]
  double map_error_raw_max = 0.0;  ///< the same without the alignment [m]
};

CarParkRun runCarPark(std::uint64_t seed) {
  const sim::CarPark park = sim::beaconCarPark();
  const sim::World& world = park.world;
  auto djnn = std::make_shared<DJNN>();
  djnn->configure(MapParameterSource(sim::associatorParametersFor(world, "DJNN")));
  SlamPipeline pipeline(sim::pipelineConfigFor(world), djnn);
  pipeline.setSensorOffset(world.sensor.offset);
  BeaconExtractorParams beacon;
  beacon.beacon_radius = 0.05;
  beacon.sigma_range = 0.03;
  pipeline.setFeatureExtractor(std::make_shared<BeaconExtractor>(beacon));
  const sim::LaserScanSimulator laser(park.laser, park.scene);
  sim::Random noise(sim::Random::streamSeed(seed, 100));

  sim::Simulation simulation(world, seed);
  RunScorer scorer;
  std::vector<LandmarkId> truth;
  LandmarkId clutter = sim::kClutterIdBase;
  for (auto e = simulation.next(); e != sim::Simulation::Event::kEnd; e = simulation.next()) {
    if (e == sim::Simulation::Event::kOdometry) {
      // As runSimulation feeds it (and the offline runner a simulated bag).
      const sim::OdometrySample& o = simulation.odometry();
      pipeline.addOdometry({o.stamp + sim::kStampOffset, o.twist, o.pose});
      continue;
    }
    // The simulator's point observations are ignored: the laser sees the scene at the true pose.
    const Eigen::Vector3d true_pose = simulation.observations().true_pose;
    const Eigen::Vector3d sensor = composePose(true_pose, world.sensor.offset);
    const ScanReport report = pipeline.processScan(
        simulation.observations().stamp + sim::kStampOffset, laser.scan(sensor, &noise));
    // Truth of an extracted beacon: the beacon within 0.5 m of where it truly points, else clutter.
    truth.clear();
    for (const Observation& o : report.observations) {
      const Eigen::Vector3d p = composePose(
          sensor, Eigen::Vector3d(o.z(0) * std::cos(o.z(1)), o.z(0) * std::sin(o.z(1)), 0));
      LandmarkId id = clutter--;
      for (std::size_t k = 0; k < world.landmarks.size(); ++k) {
        if ((world.landmarks[k] - p.head<2>()).norm() < 0.5) id = static_cast<LandmarkId>(k);
      }
      truth.push_back(id);
    }
    scorer.addScan(report, truth, pipeline.pose(), pipeline.poseCovariance(), &true_pose);
  }
  CarParkRun run;
  run.metrics = scorer.metrics(&pipeline);
  // Each map landmark against its nearest beacon, after the best rigid alignment of the map
  // onto the beacons (and before: the map frame is the world frame here, the filter starts at
  // the true start pose).
  const EkfSlam& ekf = pipeline.ekf();
  std::vector<Eigen::Vector2d> mapped, beacons;
  for (std::size_t k = 0; k < ekf.numLandmarks(); ++k) {
    const Eigen::Vector2d m = ekf.landmark(static_cast<int>(k));
    const auto nearest = std::min_element(world.landmarks.begin(), world.landmarks.end(),
                                          [&m](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
                                            return (a - m).squaredNorm() < (b - m).squaredNorm();
                                          });
    mapped.push_back(m);
    beacons.push_back(*nearest);
    run.map_error_raw_max = std::max(run.map_error_raw_max, (m - *nearest).norm());
  }
  const RigidTransform2 t = alignRigid2D(mapped, beacons);
  double sum = 0.0;
  for (std::size_t k = 0; k < mapped.size(); ++k) {
    const double e = (t.apply(mapped[k]) - beacons[k]).norm();
    sum += e * e;
    run.map_error_max = std::max(run.map_error_max, e);
  }
  run.map_error_rms = mapped.empty() ? 0.0 : std::sqrt(sum / mapped.size());
  return run;
}

}  // namespace

TEST(BeaconCarPark, TwentySeeds) {
  double worst_map = 0.0, worst_rmse = 0.0, worst_accuracy = 1.0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const CarParkRun r = runCarPark(seed);
    const RunMetrics& m = r.metrics;
    EXPECT_EQ(m.map.landmarks, 15u) << "seed " << seed;
    EXPECT_EQ(m.map.true_landmarks_mapped, 15u) << "seed " << seed;
    EXPECT_EQ(m.map.spurious, 0u) << "seed " << seed;
    EXPECT_LT(r.map_error_rms, 0.3) << "seed " << seed;
    EXPECT_LT(m.pose_rmse_m, 0.3) << "seed " << seed;
    EXPECT_GE(m.counts.accuracy(), 0.99) << "seed " << seed;
    worst_map = std::max(worst_map, r.map_error_rms);
    worst_rmse = std::max(worst_rmse, m.pose_rmse_m);
    worst_accuracy = std::min(worst_accuracy, m.counts.accuracy());
    std::printf(
        "seed %2u: %lu scans, %lu observations, %zu landmarks (%zu beacons, %zu spurious), map "
        "error aligned RMS %.3f / max %.3f m (raw max %.3f m), pose RMSE %.3f m, accuracy "
        "%.4f\n",
        static_cast<unsigned>(seed), static_cast<unsigned long>(m.scans),
        static_cast<unsigned long>(m.observations), m.map.landmarks, m.map.true_landmarks_mapped,
        m.map.spurious, r.map_error_rms, r.map_error_max, r.map_error_raw_max, m.pose_rmse_m,
        m.counts.accuracy());
  }
  std::printf("worst of 20: map error (aligned RMS) %.3f m, pose RMSE %.3f m, accuracy %.4f\n",
              worst_map, worst_rmse, worst_accuracy);
}

TEST(LaserScanSimulator, BeaconIsBrightCarIsDull) {
  sim::Scene scene;
  scene.walls = false;
  scene.poles.push_back({Eigen::Vector2d(10.0, 0.0), 0.1, true});
  scene.blocks.push_back({Eigen::Vector2d(5.0, 5.0), Eigen::Vector2d(0.9, 2.25), 0.0});
  sim::LaserSpec spec;
  spec.sigma_range = 0.0;
  spec.sigma_intensity = 0.0;
  const sim::LaserScanSimulator laser(spec, scene);
  sim::Random rng(1);
  const LaserScanData s = laser.scan(Eigen::Vector3d::Zero(), &rng);
  ASSERT_EQ(s.ranges.size(), 361u);
  EXPECT_NEAR(s.ranges[180], 9.9, 1e-5);  // straight ahead: the pole's surface
  EXPECT_EQ(s.intensities[180], 5000.0f);
  const int car = 180 + 90;  // 45 deg: towards the car's corner region (4.1..5.9, 2.75..7.25)
  EXPECT_NEAR(s.ranges[car], std::sqrt(2.0) * 4.1, 1e-4);
  EXPECT_EQ(s.intensities[car], 200.0f);
  EXPECT_TRUE(std::isinf(s.ranges[0]));  // nothing to the right, no walls
  const BeaconExtractor beacons;
  EXPECT_EQ(beacons.detect(s).size(), 1u);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
