// The `city` world. See city_world.h and docs/simulation.md.
#include "ekf_slam/evaluation/simulation/city_world.h"

#include "ekf_slam/core/common/angles.h"

namespace ekf_slam {
namespace sim {

namespace {

constexpr int kStreets = 11;            // per direction
constexpr double kBlock = 150.0;        // street spacing [m]
constexpr double kSpacing = 5.0;        // landmarks along a side of a street [m]
constexpr double kSideOffset = 7.0;     // from the street's centre line [m]
constexpr double kCrossingClear = 9.0;  // none this close to a crossing street's centre line [m]

}  // namespace

World cityWorld() {
  World w;
  w.name = "city";
  w.description =
      "11 x 11 streets 150 m apart, ~12 000 landmarks on both sides every 5 m, a 10 m/s car "
      "driving every street once (36 km, an hour), 30 m 180 deg sensor at 10 Hz";
  const double extent = (kStreets - 1) * kBlock;
  w.area_min = {-30.0, -30.0};
  w.area_max = {extent + 30.0, extent + 30.0};
  // Trees / poles: both sides of every street, jittered so that the rows are not perfectly
  // regular (fixed layout seed: the map is the same for every run seed).
  Random rng(20260001);
  for (int axis = 0; axis < 2; ++axis) {
    for (int s = 0; s < kStreets; ++s) {
      const double c = s * kBlock;
      for (double t = -20.0; t <= extent + 20.0 + 1e-9; t += kSpacing) {
        for (const double side : {-kSideOffset, kSideOffset}) {
          const double along = t + rng.uniform(-1.0, 1.0);
          const double across = c + side + rng.uniform(-0.5, 0.5);
          // Nearest crossing street's centre line: keep the intersection free.
          const double to_crossing = std::abs(along - kBlock * std::round(along / kBlock));
          if (along >= -1.0 && along <= extent + 1.0 && to_crossing < kCrossingClear) continue;
          w.landmarks.push_back(axis == 0 ? Eigen::Vector2d(along, across)
                                          : Eigen::Vector2d(across, along));
        }
      }
    }
  }
  // Every street along x (serpentine), then every street along y: each street once, the second
  // half crossing the whole mapped grid again (loop closures every block).
  w.start_pose = {0.0, 0.0, 0.0};
  for (int s = 0; s < kStreets; ++s) {
    const double y = s * kBlock;
    const bool east = s % 2 == 0;
    w.waypoints.push_back({east ? extent : 0.0, y});
    if (s + 1 < kStreets) w.waypoints.push_back({east ? extent : 0.0, y + kBlock});
  }
  // Ends at (extent or 0, extent); the streets along y from there, serpentine.
  const bool from_east = (kStreets - 1) % 2 == 0;
  for (int s = 0; s < kStreets; ++s) {
    const double x = from_east ? extent - s * kBlock : s * kBlock;
    const bool south = s % 2 == 0;
    w.waypoints.push_back({x, south ? 0.0 : extent});
    if (s + 1 < kStreets) {
      const double next = from_east ? x - kBlock : x + kBlock;
      w.waypoints.push_back({next, south ? 0.0 : extent});
    }
  }
  w.vehicle.speed = 10.0;
  w.vehicle.wheelbase = 2.7;
  w.vehicle.max_steer = deg2rad(35.0);
  w.vehicle.max_steer_rate = deg2rad(60.0);
  w.vehicle.waypoint_tolerance = 6.0;
  w.vehicle.track_width = 1.6;
  w.sensor.max_range = 30.0;
  w.sensor.field_of_view = M_PI;
  w.noise.sigma_speed = 0.2;
  w.noise.sigma_steer = deg2rad(1.0);
  w.noise.sigma_range = 0.1;
  w.noise.sigma_bearing = deg2rad(0.5);
  w.control_period = 0.02;     // 50 Hz odometry
  w.observation_period = 0.1;  // 10 Hz scans
  w.max_duration = 4500.0;
  return w;
}

}  // namespace sim
}  // namespace ekf_slam
