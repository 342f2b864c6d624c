// Ray casting against poles (circles), parked cars (rectangles) and the car park's walls.
#include "ekf_slam/evaluation/simulation/laser_scan_simulator.h"

#include <cmath>
#include <limits>

namespace ekf_slam {
namespace sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Distance along the unit ray (o, d) to the circle, or +inf.
double hitCircle(const Eigen::Vector2d& o, const Eigen::Vector2d& d, const Pole& p) {
  const Eigen::Vector2d c = p.centre - o;
  const double along = c.dot(d);
  const double d2 = c.squaredNorm() - along * along;
  if (along <= 0.0 || d2 > p.radius * p.radius) return kInf;
  return along - std::sqrt(p.radius * p.radius - d2);
}

// Slab test in the block's frame; +inf when missed or when the origin is inside.
double hitBlock(const Eigen::Vector2d& o, const Eigen::Vector2d& d, const Block& b) {
  const double c = std::cos(b.yaw), s = std::sin(b.yaw);
  const Eigen::Vector2d rel = o - b.centre;
  const Eigen::Vector2d lo(c * rel.x() + s * rel.y(), -s * rel.x() + c * rel.y());
  const Eigen::Vector2d ld(c * d.x() + s * d.y(), -s * d.x() + c * d.y());
  double t0 = -kInf, t1 = kInf;
  for (int k = 0; k < 2; ++k) {
    if (std::fabs(ld(k)) < 1e-12) {
      if (std::fabs(lo(k)) > b.half_size(k)) return kInf;
      continue;
    }
    double a = (-b.half_size(k) - lo(k)) / ld(k), e = (b.half_size(k) - lo(k)) / ld(k);
    if (a > e) std::swap(a, e);
    t0 = std::max(t0, a);
    t1 = std::min(t1, e);
  }
  return t0 <= t1 && t0 > 0.0 ? t0 : kInf;
}

// The walls from inside the area: the exit distance of the ray.
double hitWalls(const Eigen::Vector2d& o, const Eigen::Vector2d& d, const Scene& s) {
  double t = kInf;
  for (int k = 0; k < 2; ++k) {
    if (d(k) > 1e-12) t = std::min(t, (s.area_max(k) - o(k)) / d(k));
    if (d(k) < -1e-12) t = std::min(t, (s.area_min(k) - o(k)) / d(k));
  }
  return t > 0.0 ? t : kInf;
}

}  // namespace

LaserScanSimulator::LaserScanSimulator(const LaserSpec& laser, Scene scene)
    : laser_(laser), scene_(std::move(scene)) {}

LaserScanData LaserScanSimulator::scan(const Eigen::Vector3d& pose, Random* rng) const {
  LaserScanData out;
  out.angle_min = laser_.angle_min;
  out.angle_increment = laser_.angle_increment;
  out.range_min = 0.0;
  out.range_max = laser_.range_max;
  out.ranges.resize(laser_.beams);
  out.intensities.resize(laser_.beams);
  const Eigen::Vector2d o = pose.head<2>();
  for (int i = 0; i < laser_.beams; ++i) {
    const double a = pose.z() + laser_.angle_min + i * laser_.angle_increment;
    const Eigen::Vector2d d(std::cos(a), std::sin(a));
    double best = scene_.walls ? hitWalls(o, d, scene_) : kInf;
    bool reflective = false;
    for (const Pole& p : scene_.poles) {
      const double t = hitCircle(o, d, p);
      if (t < best) {
        best = t;
        reflective = p.reflective;
      }
    }
    for (const Block& b : scene_.blocks) {
      const double t = hitBlock(o, d, b);
      if (t < best) {
        best = t;
        reflective = false;
      }
    }
    const double range = best + laser_.sigma_range * rng->normal();
    if (!(best < laser_.range_max) || !(range > 0.0)) {
      out.ranges[i] = std::numeric_limits<float>::infinity();
      out.intensities[i] = 0.0f;
      continue;
    }
    const double mean = reflective ? laser_.reflective_intensity : laser_.dull_intensity;
    out.ranges[i] = static_cast<float>(range);
    out.intensities[i] =
        static_cast<float>(std::max(0.0, mean + laser_.sigma_intensity * rng->normal()));
  }
  return out;
}

CarPark beaconCarPark() {
  CarPark park;
  World& w = park.world;
  w.name = "beacons";
  w.description = "car park 60 x 40 m, 15 reflective beacons, parked cars, laser with intensities";
  w.area_min = Eigen::Vector2d(0.0, 0.0);
  w.area_max = Eigen::Vector2d(60.0, 40.0);
  // Beacons along the walls and on the islands between the parking rows.
  const double beacons[15][2] = {{3, 3},   {20, 2},  {40, 2},  {57, 3},  {58, 20},
                                 {57, 37}, {40, 38}, {20, 38}, {3, 37},  {2, 20},
                                 {15, 20}, {14, 12}, {30, 24}, {45, 20}, {22, 14}};
  for (const auto& b : beacons) {
    w.landmarks.emplace_back(b[0], b[1]);
    park.scene.poles.push_back({Eigen::Vector2d(b[0], b[1]), 0.05, true});
  }
  // Two rows of parked cars (nose to the aisle) in the middle, each car 4.5 x 1.8 m.
  for (double x = 18.0; x <= 42.0; x += 3.0) {
    if (std::fabs(x - 30.0) < 1.0) continue;  // the beacons' island
    park.scene.blocks.push_back({Eigen::Vector2d(x, 18.0), Eigen::Vector2d(0.9, 2.25), 0.0});
    park.scene.blocks.push_back({Eigen::Vector2d(x, 22.6), Eigen::Vector2d(0.9, 2.25), 0.0});
  }
  park.scene.area_min = w.area_min;
  park.scene.area_max = w.area_max;
  // Loops round the rows, counter-clockwise.
  w.start_pose = Eigen::Vector3d(10.0, 8.0, 0.0);
  w.waypoints = {{50, 8}, {52, 20}, {50, 32}, {10, 32}, {8, 20}, {10, 8}};
  w.laps = 3;
  w.vehicle.speed = 3.0;
  w.vehicle.wheelbase = 2.83;  // Victoria Park's vehicle
  w.vehicle.waypoint_tolerance = 2.0;
  w.sensor.offset = Eigen::Vector3d(3.78, 0.5, 0.0);
  w.sensor.max_range = 30.0;
  w.sensor.field_of_view = M_PI;
  w.noise.sigma_speed = 0.1;
  w.noise.sigma_steer = 1.0 * M_PI / 180;
  w.noise.sigma_range = 0.05;
  w.noise.sigma_bearing = 0.5 * M_PI / 180;
  w.observation_period = 0.2;  // 5 Hz
  w.max_duration = 150.0;
  return park;
}

std::optional<CarPark> laserWorld(const std::string& name) {
  if (name == "beacons") return beaconCarPark();
  return std::nullopt;
}

}  // namespace sim
}  // namespace ekf_slam
