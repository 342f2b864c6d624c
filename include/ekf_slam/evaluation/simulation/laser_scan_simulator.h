// A ray-casting 2D laser with an intensity channel, for worlds whose landmarks must be extracted
// from scans (retro-reflective beacons) rather than observed directly. ROS-free, deterministic
// (sim::Random). Kept apart from the point-observation simulator (simulator.h): a world's truth
// and route come from sim::World and sim::Simulation; this adds what the laser sees at a pose.
//
//   const sim::CarPark park = sim::beaconCarPark();           // world + scene + laser
//   sim::Simulation s(park.world, seed);                        // route, odometry, true poses
//   sim::LaserScanSimulator laser(park.laser, park.scene);
//   LaserScanData scan = laser.scan(composePose(true_pose, park.world.sensor.offset), &rng);
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/feature_extraction/feature_extractor.h"
#include "ekf_slam/evaluation/simulation/simulator.h"

namespace ekf_slam {
namespace sim {

/// A pole; `reflective`: wrapped in retro-reflective tape.
struct Pole {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double radius = 0.05;
  bool reflective = true;
};

/// A rectangle (a parked car): centre, half sizes along its own axes, heading. Never reflective.
struct Block {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d half_size = Eigen::Vector2d(2.25, 0.9);
  double yaw = 0.0;
};

struct Scene {
  std::vector<Pole> poles;
  std::vector<Block> blocks;
  /// Walls: the boundary of [area_min, area_max] is a dull wall when true.
  bool walls = true;
  Eigen::Vector2d area_min = Eigen::Vector2d::Zero();
  Eigen::Vector2d area_max = Eigen::Vector2d::Zero();
};

struct LaserSpec {
  double angle_min = -M_PI / 2;
  double angle_increment = M_PI / 360;   ///< 0.5 deg
  int beams = 361;                       ///< 180 deg
  double range_max = 40.0;               ///< no return beyond [m] (+inf)
  double sigma_range = 0.01;             ///< range noise [m]
  double reflective_intensity = 5000.0;  ///< mean intensity on tape
  double dull_intensity = 200.0;         ///< mean intensity elsewhere
  double sigma_intensity = 100.0;
};

class LaserScanSimulator {
 public:
  LaserScanSimulator(const LaserSpec& laser, Scene scene);
  /// The scan at `sensor_pose` (x, y, yaw in the world frame). Ranges are the nearest hit plus
  /// noise; no hit within range_max: +inf with intensity 0.
  LaserScanData scan(const Eigen::Vector3d& sensor_pose, Random* rng) const;
  const Scene& scene() const { return scene_; }

 private:
  LaserSpec laser_;
  Scene scene_;
};

/// The `beacons` car park (docs/feature_extraction.md): 60 x 40 m, 15 reflective beacons on
/// poles (radius 0.05 m), rows of parked cars as dull clutter, a vehicle with Victoria Park's
/// geometry (wheelbase 2.83 m, laser 3.78 m ahead and 0.5 m left of the rear axle) driving loops
/// at 3 m/s for about 2 minutes; a 180 deg laser at 5 Hz. world.landmarks = the beacons.
struct CarPark {
  World world;
  Scene scene;
  LaserSpec laser;
};
CarPark beaconCarPark();

/// The laser part of a world whose landmarks are extracted from scans: beaconCarPark() for
/// "beacons", nothing for the point-observation worlds (runSimulation and `simulate` ask).
std::optional<CarPark> laserWorld(const std::string& name);
/// Random::streamSeed(seed, this): the laser's noise in a run of a laser world, so runSimulation
/// and the bag `simulate` writes see the same scans.
constexpr std::uint64_t kLaserNoiseStream = 100;

}  // namespace sim
}  // namespace ekf_slam
