#include "ekf_slam/evaluation/world_parameters.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "ekf_slam/core/common/coverage_grid.h"
#include "ekf_slam/core/common/pose2d.h"
#include "ekf_slam/core/common/sensor_model.h"
#include "ekf_slam/evaluation/simulation/laser_scan_simulator.h"

namespace ekf_slam {
namespace sim {
namespace {

std::string text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

// A range that covers every landmark of the world from anywhere in it: what "the whole map is
// visible" means to range-limited code (the pipeline's filter, DJNN's local region).
// Sites larger than this [m^2] run the compressed EKF (filter cekf): a user knows the size of
// the site, not how many landmarks it holds.
constexpr double kCompressedFilterSiteArea = 1.0e6;
// ... with areas this long [m] (cekf_area_size).
constexpr double kLargeWorldAreaSize = 150.0;
// ... and this much slack [m] (cekf_area_slack): crossing the mapped grid after half an hour of
// exploring corrects the pose by metres per scan, which closed areas again within 1-4 scans.
constexpr double kLargeWorldAreaSlack = 5.0;

// A polygon as the parameters write it: "x1,y1; x2,y2; ...".
std::string polygonText(const std::vector<Eigen::Vector2d>& polygon) {
  std::string out;
  for (const Eigen::Vector2d& v : polygon) {
    out += (out.empty() ? "" : "; ") + text(v.x()) + "," + text(v.y());
  }
  return out;
}

double coveringRange(const World& w) {
  if (std::isfinite(w.sensor.max_range)) return w.sensor.max_range;
  return std::ceil(1.5 * (w.area_max - w.area_min).norm());
}

}  // namespace

std::map<std::string, std::string> pipelineParametersFor(const World& world) {
  const TwistParams t = twistNoiseFor(world);
  std::map<std::string, std::string> p = {
      {"odometry_mode", "twist"},
      {"twist_sigma_v", text(t.sigma_v)},
      {"twist_sigma_v_per_v", text(t.sigma_v_per_v)},
      {"twist_sigma_w", text(t.sigma_w)},
      {"twist_sigma_w_per_v", text(t.sigma_w_per_v)},
      {"sigma_range", text(world.noise.sigma_range)},
      {"sigma_bearing", text(world.noise.sigma_bearing)},
      {"max_observation_range", text(coveringRange(world))},
      {"min_observation_range", "0"},
      {"initial_pose_x", text(world.start_pose.x())},
      {"initial_pose_y", text(world.start_pose.y())},
      {"initial_pose_yaw", text(world.start_pose.z())},
      // Lost rule 1 counts the landmarks the sensor should see.
      {"lost_field_of_view", text(std::min(world.sensor.field_of_view, 2.0 * M_PI))},
  };
  // ... and a scan pairing fewer than half of the detections expected of them counts as
  // unpaired (docs/relocalisation.md): the sensor's lowest detection probability in its region.
  const SensorSpec& s = world.sensor;
  const double pd =
      std::min(s.detectionProbability(s.min_range), s.detectionProbability(coveringRange(world)));
  p["lost_min_paired_share"] = text(0.5 * pd);
  // Places a relocaliser cannot tell apart: recovery off (World::recognisable_places).
  if (!world.recognisable_places) p["relocaliser"] = "";
  // A camera's footprint: landmarks beside or behind it are not in view.
  if (s.polygon.size() >= 3) p["lost_view_polygon"] = polygonText(s.polygon);
  if (world.pose_delta_odometry) {
    // The simulator's noise on one increment of length d = v dt turning by a = w dt, with
    // w = v tan(steer) / L: translation sigma_v dt = (sigma_v / v) d; rotation
    // (tan(steer) / L) sigma_v dt + (v dt / (L cos^2 steer)) sigma_steer
    //   = (sigma_v / v) a + (sigma_steer / L) d + tan(steer) sigma_steer a,
    // bounded at the steering limit in the last term only. (twistNoiseFor's bound, read per metre,
    // charged the turn-only speed term to every metre: 5x the heading noise on straights.)
    const double v = world.vehicle.speed;
    const NoiseSpec& n = world.noise;
    p["odometry_mode"] = "pose_delta";
    p["pose_delta_alpha_trans_per_trans"] = text(n.sigma_speed / v);
    p["pose_delta_alpha_rot_per_trans"] = text(n.sigma_steer / world.vehicle.wheelbase);
    p["pose_delta_alpha_trans_per_rot"] = "0";
    p["pose_delta_alpha_rot_per_rot"] =
        text(n.sigma_speed / v + std::tan(world.vehicle.max_steer) * n.sigma_steer);
  }
  // Second-order observation terms where they matter (docs/consistency.md): a range-bearing
  // sensor whose second-order range spread at its reach, r sigma_b^2 / sqrt(2), exceeds half its
  // range noise (the rrw worlds: 425 m, 3 deg, 0.1 m), i.e. far landmarks known mostly across.
  const double spread =
      coveringRange(world) * std::pow(world.noise.sigma_bearing, 2) / std::sqrt(2.0);
  if (!world.sensor.cartesian && spread > 0.5 * world.noise.sigma_range)
    p["second_order_observations"] = "true";
  // A map this large is beyond the full EKF's per-scan budget (docs/cekf.md; the `city` world).
  // Its areas a block long: at this size a global update (N^2 n_A) costs far more than the steps
  // on A, and a 150 m area closes once per block of the city's grid where a 50 m one closes
  // twice (docs/benchmarks.md, "city: both filters at N >= 20 000").
  if ((world.area_max - world.area_min).prod() > kCompressedFilterSiteArea) {
    p["filter"] = "cekf";
    p["cekf_area_size"] = text(kLargeWorldAreaSize);
    p["cekf_area_slack"] = text(kLargeWorldAreaSlack);
  }
  if (world.noise.odometry_wheel_factors != Eigen::Vector2d::Ones()) {
    // What odometry_correction: wheel_factors needs to match the simulated wheels: their track,
    // and no random walk (the world's factors are constant). This world's consistency is what
    // it is for (AEKF, docs/notes/2026-11-to-12-results-record.md), so it also gets its odometry
    // noise exactly: the speed and steering-angle noise of each control step on its wheelbase,
    // where twistNoiseFor's bound at the steering limit is 3.3 times the yaw-rate noise of a
    // straight and, with it read on a straight, the turns' noise (1.7 times the variance) was
    // missing.
    const double L = world.vehicle.wheelbase;
    p["correction_track_width"] = text(world.vehicle.track_width);
    p["correction_wheel_factor_noise"] = "0";
    p["twist_sigma_w"] = "0";
    p["twist_sigma_w_per_v"] = text(world.noise.sigma_steer / L);
    p["twist_steering_wheelbase"] = text(L);
  }
  return p;
}

std::map<std::string, std::string> trueNoiseParametersFor(const World& world) {
  std::map<std::string, std::string> p = {{"sigma_range", text(world.noise.sigma_range)},
                                          {"sigma_bearing", text(world.noise.sigma_bearing)}};
  // pose_delta's isotropic translation noise has no exact counterpart of a speed noise: its
  // odometry keeps pipelineParametersFor's values.
  if (world.pose_delta_odometry) return p;
  // Each /odom message is one control step: per-message noise of its speed, and of its yaw rate
  // through the steering angle (TwistModel's steering form, as the aekf world's file has it).
  const double L = world.vehicle.wheelbase;
  p["twist_sigma_v"] = text(world.noise.sigma_speed);
  p["twist_sigma_v_per_v"] = "0";
  p["twist_sigma_w"] = "0";
  p["twist_sigma_w_per_v"] = text(world.noise.sigma_steer / L);
  p["twist_steering_wheelbase"] = text(L);
  p["process_noise"] = "per_message";
  return p;
}

PipelineConfig pipelineConfigFor(const World& world) {
  return readPipelineConfig(MapParameterSource(pipelineParametersFor(world)));
}

// The least distance between two landmarks (O(n^2): only for the small worlds that need it).
static double leastSpacing(const std::vector<Eigen::Vector2d>& landmarks) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t a = 0; a < landmarks.size(); ++a) {
    for (std::size_t b = a + 1; b < landmarks.size(); ++b) {
      best = std::min(best, (landmarks[a] - landmarks[b]).squaredNorm());
    }
  }
  return std::sqrt(best);
}

double coveredLandmarkDensity(const World& world, double cell) {
  SensorModel region;
  region.min_range = world.sensor.min_range;
  region.max_range = coveringRange(world);  // finite: the grid visits the region's bounding box
  region.field_of_view = std::min(world.sensor.field_of_view, 2.0 * M_PI);
  region.polygon = world.sensor.polygon;
  // A view visits the cells of its bounding box: at most about 200 x 200 of them, however far the
  // sensor reaches.
  cell = std::max(cell, region.max_range / 100.0);
  CoverageGrid grid(cell);
  Simulation simulation(world, 1);
  for (auto e = simulation.next(); e != Simulation::Event::kEnd; e = simulation.next()) {
    if (e == Simulation::Event::kObservations)
      grid.addView(region, composePose(simulation.observations().true_pose, world.sensor.offset));
  }
  // Only the ground inside the world's area: a camera looking out of a room sees no landmark
  // beyond its walls.
  std::size_t covered = 0, seen = 0;
  for (double x = world.area_min.x() + 0.5 * cell; x < world.area_max.x(); x += cell) {
    for (double y = world.area_min.y() + 0.5 * cell; y < world.area_max.y(); y += cell)
      covered += grid.count({x, y}) > 0;
  }
  for (const Eigen::Vector2d& l : world.landmarks) seen += grid.count(l) > 0;
  return covered == 0 ? 0.0
                      : static_cast<double>(seen) / (static_cast<double>(covered) * cell * cell);
}

std::map<std::string, std::string> associatorParametersFor(const World& world,
                                                           const std::string& short_name,
                                                           Knowledge knowledge) {
  if (short_name == "FGCBB" || short_name == "GCBB")
    return {{"sensor_range", text(coveringRange(world))}};
  if (short_name != "DJNN") return {};
  // DJNN's local region (eq. 10) and its evidence counter need the sensor's real extent: a
  // landmark outside it must not be counted as missed.
  std::map<std::string, std::string> p = {
      {"sensor_range", text(coveringRange(world))},
      {"field_of_view", text(std::min(world.sensor.field_of_view, 2.0 * M_PI))}};
  // Sensors that are not the papers' (keys added only then, so the papers' worlds read exactly
  // what they did): a minimum range, a nominal detection probability (the lowest in the region:
  // DJNN's threshold sits halfway to it), margins scaled to a short range.
  const SensorSpec& s = world.sensor;
  if (s.min_range > 0.0) p["min_range"] = text(s.min_range);
  const double pd =
      std::min(s.detectionProbability(s.min_range), s.detectionProbability(coveringRange(world)));
  if (pd < 1.0) p["detection_probability"] = text(pd);
  const double R = coveringRange(world);
  if (R < 15.0) p["range_margin"] = text(0.2 * R);
  if (s.polygon.size() >= 3) p["fov_polygon"] = polygonText(s.polygon);
  if (knowledge == Knowledge::kOracle) {
    for (const auto& [key, value] : oracleDjnnParameters(world)) p[key] = value;
  }
  return p;
}

std::map<std::string, std::string> oracleDjnnParameters(const World& world) {
  std::map<std::string, std::string> p;
  const SensorSpec& s = world.sensor;
  const double R = coveringRange(world);
  const double pd = std::min(s.detectionProbability(s.min_range), s.detectionProbability(R));
  if (pd >= 1.0) return p;
  // Sparse detections let movers pass close to landmarks between sightings: a landmark with two
  // bias windows of unbiased pairings stays when the bias test fires (docs/djnn.md).
  p["bias_keep_pairings"] = "10";
  // Other robots among sparse detections: admission needs sightings spanning the time in which
  // the slowest of them shows its motion (the movers' true speed).
  if (world.movers.count > 0) p["static_min_speed"] = text(world.movers.min_speed);
  // A camera that misses landmarks keeps many of them tentative while the pose is corrected: the
  // features follow the corrections and the static test allows for the heading error. Pairings
  // are weighed jointly against unmapped landmarks at their true density where the sensor looks.
  p["tentative_follow_pose"] = "true";
  p["static_heading"] = "true";
  if (!world.landmarks.empty()) p["landmark_density"] = text(coveredLandmarkDensity(world));
  if (world.movers.count == 0) {
    // Knowing there are no movers: a few static sightings tell a landmark from clutter, and loop
    // closures get the joint decision with the features seen but not admitted remembered as
    // evidence (docs/notes/2026-11-to-12-djnn-record.md, "Closing the loops").
    p["admit_evidence"] = "3";
    p["loop_closure_age"] = "60";
    p["remembered_sightings"] = "2";
    p["held_birth_cost"] = "4";
    // The true least spacing of two landmarks.
    if (world.clutter_rate > 0.0) p["landmark_spacing"] = text(leastSpacing(world.landmarks));
    p["held_confirmations"] = "1";
  }
  if (world.clutter_rate > 0.0) {
    // The simulator's clutter rate, uniform over the sensor's sector.
    const double half = 0.5 * std::min(s.field_of_view, 2.0 * M_PI);
    p["clutter_density"] = text(world.clutter_rate / (half * (R * R - s.min_range * s.min_range)));
  }
  return p;
}

ExtractorSetup extractorFor(const World& world) {
  if (!laserWorld(world.name)) return {};
  // The car park's poles (radius 0.05 m) and its laser's range noise (LaserSpec::sigma_range
  // 0.01 m, with margin for the beam's discrete angles).
  return {"BeaconExtractor", {{"beacon_radius", "0.05"}, {"sigma_range", "0.03"}}};
}

}  // namespace sim
}  // namespace ekf_slam
