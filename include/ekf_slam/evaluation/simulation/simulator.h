// Simulated worlds of the papers (ALGORITHMS.md section 10) with ground truth, ROS-free.
//
//   sim::World world = sim::makeWorld("djnn_weak");      // or any of sim::worldNames()
//   sim::Simulation s(world, seed);
//   for (auto e = s.next(); e != sim::Simulation::Event::kEnd; e = s.next()) {
//     if (e == sim::Simulation::Event::kOdometry) use(s.odometry());   // control period
//     else use(s.observations());                                       // observation period
//   }
//
// Events come in stamp order; at a stamp carrying both, odometry comes first. The twist of an
// odometry sample drives the vehicle from its stamp to the next one (held, like the pipeline's
// "twist" mode), so a filter that predicts with TwistModel from sample to sample integrates
// exactly the way the truth moved. A world plus a seed gives the same output bit for bit: all
// randomness comes from std::mt19937_64 (its sequence is fixed by the standard) through our own
// uniform and normal transforms (std::*_distribution are implementation-defined). The choices
// the papers leave open are documented in docs/notes/2026-11-to-12-simulation-record.md.
#pragma once

#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/common/sensor_model.h"
#include "ekf_slam/core/filter/ekf_slam.h"
#include "ekf_slam/core/filter/motion_models.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/evaluation/scoring/truth_ids.h"

namespace ekf_slam {
namespace sim {

/// Deterministic random numbers: mt19937_64 plus portable transforms.
class Random {
 public:
  explicit Random(std::uint64_t seed = 1) : engine_(seed) {}
  /// A seed for an independent stream `stream` of a run seeded with `seed` (splitmix64).
  static std::uint64_t streamSeed(std::uint64_t seed, std::uint64_t stream);

  std::uint64_t bits() { return engine_(); }
  /// [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Standard normal (Marsaglia's polar method: only log and sqrt).
  double normal();
  /// Poisson with mean `mean` (Knuth; fine for the small means used here).
  int poisson(double mean);
  /// Integer in [0, n).
  int index(int n) { return static_cast<int>(uniform() * n); }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

// --- world description --------------------------------------------------------------------------

struct VehicleSpec {
  double speed = 3.0;                         ///< constant forward speed [m/s]
  double wheelbase = 4.0;                     ///< [m]
  double max_steer = 30.0 * M_PI / 180;       ///< steering angle limit [rad]
  double max_steer_rate = 20.0 * M_PI / 180;  ///< steering rate limit [rad/s]
  double waypoint_tolerance = 2.0;            ///< a waypoint is reached within this distance [m]
  /// Distance between the left and right wheels whose encoders give the odometry when
  /// NoiseSpec::odometry_wheel_factors is not (1, 1) [m].
  double track_width = 2.0;
};

struct SensorSpec {
  /// Returns farther than this are not produced; infinity = the whole map is visible.
  double max_range = 30.0;
  double min_range = 0.0;
  /// Full field of view centred on the sensor x axis [rad]; >= 2 pi = all around.
  double field_of_view = M_PI;
  /// Sensor pose on the vehicle (x, y, yaw); the observations are in the sensor frame.
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  /// Chance that an object in view is detected in one observation set: `detection_probability`
  /// at min_range, falling linearly to `detection_probability_far` at max_range (NaN: the same).
  double detection_probability = 1.0;
  double detection_probability_far = std::numeric_limits<double>::quiet_NaN();
  /// Detection probability at range r.
  double detectionProbability(double r) const;
  /// Convex polygon in the sensor frame the object must also lie in (e.g. the floor trapezoid of
  /// a downward camera); empty = none.
  std::vector<Eigen::Vector2d> polygon;
  /// Report (x, y) in the sensor frame with the full covariance J R J^T of the range-bearing
  /// noise at the true point (J = d(x, y) / d(range, bearing)), noise drawn in (x, y).
  bool cartesian = false;
};

/// Noise of the odometry (control) and of the observations, as standard deviations.
struct NoiseSpec {
  double sigma_speed = 0.3;                 ///< on the odometry speed [m/s]
  double sigma_steer = 3.0 * M_PI / 180;    ///< on the odometry steering angle [rad]
  double sigma_range = 0.1;                 ///< [m]
  double sigma_bearing = 1.0 * M_PI / 180;  ///< [rad]
  /// Systematic odometry errors: reported speed = scale * true speed (+ noise); reported
  /// steering = true steering + bias (+ noise).
  double odometry_speed_scale = 1.0;
  double odometry_steer_bias = 0.0;
  /// Wheel-speed factors (d_l, d_r) of AEKF (seed 001 paper 5): the wheels really turn d times
  /// as fast as their encoders report. The odometry is then the differential-drive twist of the
  /// reported wheel speeds v_l,r / d_l,r (wheels at -/+ track_width / 2 of the true twist), so
  /// unequal factors bias the yaw rate as well as the speed; the random noise is added on top,
  /// as without factors (speed, and steering equivalent to that yaw rate).
  Eigen::Vector2d odometry_wheel_factors = Eigen::Vector2d::Ones();
};

/// Objects that move at random and are seen by the sensor like landmarks (seed 000).
struct MoverSpec {
  int count = 0;
  double min_speed = 0.5;  ///< each mover draws a constant speed in [min, max] [m/s]
  double max_speed = 1.5;
  double heading_diffusion = 0.5;  ///< heading random walk [rad / sqrt(s)]
};

/// Dynamic occlusion (seed 004): `count` landmarks in view are hidden; the hidden set is redrawn
/// every `hold` seconds (occluders move).
struct OcclusionSpec {
  int count = 0;
  double hold = 1.0;
};

/// At `time` the true pose jumps by `distance` in a random direction and the heading by a value
/// uniform in [-max_heading_jump, max_heading_jump]; odometry does not report it (seed 004).
struct KidnapEvent {
  double time = 0.0;
  double distance = 0.0;
  double max_heading_jump = M_PI;
};

struct World {
  std::string name;
  std::string description;
  Eigen::Vector2d area_min = Eigen::Vector2d::Zero();  ///< the world's extent [m]
  Eigen::Vector2d area_max = Eigen::Vector2d::Zero();
  std::vector<Eigen::Vector2d> landmarks;  ///< static landmarks; truth id = index
  Eigen::Vector3d start_pose = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector2d> waypoints;  ///< route, driven in order `laps` times
  int laps = 1;
  VehicleSpec vehicle;
  SensorSpec sensor;
  NoiseSpec noise;
  MoverSpec movers;
  double clutter_rate = 0.0;  ///< mean number of clutter returns per observation set (Poisson)
  OcclusionSpec occlusion;
  std::vector<KidnapEvent> kidnaps;
  double control_period = 0.025;    ///< odometry period [s]
  double observation_period = 0.2;  ///< a multiple of control_period [s]
  double max_duration = 2000.0;     ///< safety stop if the route is never completed [s]
  /// The filter should use the odometry poses' increments (pipeline odometry_mode pose_delta)
  /// rather than the twist.
  bool pose_delta_odometry = false;
  /// A relocaliser can tell its places apart (landmark geometry differs from place to place).
  /// false (a user who laid the markers out in a repeating pattern knows it): lost-robot
  /// recovery is off in the world's parameters (docs/relocalisation.md, "Known limits").
  bool recognisable_places = true;
  std::uint64_t default_seed = 1;  ///< the paper's seed where it gives one

  /// Throws std::invalid_argument naming the first bad field.
  void validate() const;
  /// Observation noise covariance diag(sigma_range^2, sigma_bearing^2).
  Eigen::Matrix2d observationCovariance() const;
  /// Control steps per observation (observation_period / control_period, rounded).
  int controlStepsPerObservation() const;
};

/// Names accepted by makeWorld(): tiny, djnn_weak, djnn_strong, hybrid, aekf, beacons (scans:
/// sim::laserWorld), arena, fiducials, fiducials_lattice, city, rrw_noise_1..10,
/// rrw_kidnap_1..10, rrw_occlusion_2, 4, ..., 20.
std::vector<std::string> worldNames();
/// World names matching `patterns`, in registry order without repeats: an exact name, or a
/// prefix ending in '*' ("rrw_noise_*", "*"). Throws std::invalid_argument listing the names when
/// a pattern matches none.
std::vector<std::string> expandWorldNames(const std::vector<std::string>& patterns);
/// Builds a world by name; throws std::invalid_argument listing the names on an unknown one.
World makeWorld(const std::string& name);

/// TwistModel noise covering a world's odometry noise: speed noise as is, speed and steering
/// noise mapped to yaw rate through w = v tan(steer) / L, bounded at the steering limit (so a
/// little conservative on straights). Systematic errors (speed scale, steering bias) are not
/// covered: estimating them is AEKF's job. What a filter on a simulated bag should use.
TwistParams twistNoiseFor(const World& world);

/// Speed and steering angle the odometry reports for the true steering angle `steer` at the
/// world's speed, before the random noise: the systematic errors of NoiseSpec alone.
Eigen::Vector2d biasedOdometry(const World& world, double steer);

/// The values the filter's odometry correction states should converge to in `world` for a
/// correction mode (odometry_correction.h): wheel_factors -> (d_l, d_r); speed_scale ->
/// 1 / odometry_speed_scale when the wheel factors are 1. NaN where the world's systematic error
/// has no exact counterpart in that mode (or the mode has fewer states).
Eigen::Vector2d trueCorrection(const World& world, const std::string& mode);

// --- simulation ---------------------------------------------------------------------------------

struct OdometrySample {
  double stamp = 0.0;
  Eigen::Vector2d twist = Eigen::Vector2d::Zero();       ///< noisy (v, w), held until the next
  Eigen::Vector3d pose = Eigen::Vector3d::Zero();        ///< integrated noisy odometry pose
  Eigen::Vector3d true_pose = Eigen::Vector3d::Zero();   ///< ground truth at `stamp`
  Eigen::Vector2d true_twist = Eigen::Vector2d::Zero();  ///< (v, w) the vehicle really drives
  double true_steer = 0.0;                               ///< steering angle the vehicle drives
};

struct SimObservation {
  Eigen::Vector2d z = Eigen::Vector2d::Zero();  ///< (range, bearing) or (x, y) in the sensor frame
  Eigen::Matrix2d R = Eigen::Matrix2d::Identity();
  LandmarkId truth_id = 0;  ///< landmark index, moverId(k), or a clutter id
  MeasurementKind kind = MeasurementKind::kRangeBearing;
};

struct ObservationSet {
  double stamp = 0.0;
  Eigen::Vector3d true_pose = Eigen::Vector3d::Zero();
  std::vector<SimObservation> observations;

  /// The observations as the associators take them, and their truth ids, in the same order.
  std::vector<Observation> toObservations() const;
  std::vector<LandmarkId> truthIds() const;
};

class Simulation {
 public:
  enum class Event { kOdometry, kObservations, kEnd };

  /// Throws std::invalid_argument when the world is invalid.
  Simulation(World world, std::uint64_t seed);

  /// Advances to the next event. After kEnd every further call returns kEnd.
  Event next();
  const OdometrySample& odometry() const { return odom_; }
  const ObservationSet& observations() const { return scan_; }

  const World& world() const { return world_; }
  std::uint64_t seed() const { return seed_; }
  /// Current true pose and mover positions (for visualisation).
  const Eigen::Vector3d& truePose() const { return pose_; }
  std::vector<Eigen::Vector2d> moverPositions() const;
  /// Number of kidnap events applied so far.
  int kidnapsApplied() const { return kidnaps_applied_; }

 private:
  struct Mover {
    Eigen::Vector2d p;
    double heading;
    double speed;
  };
  void emitOdometry();
  void emitObservations();
  void advance();
  bool routeDone() const {
    return wp_index_ >= world_.waypoints.size() * static_cast<std::size_t>(world_.laps);
  }
  /// (range, bearing) of a point seen from the true sensor pose, and whether it is in view.
  bool inView(const Eigen::Vector2d& z) const;
  void redrawOcclusion(const Eigen::Vector3d& sensor);

  World world_;
  std::uint64_t seed_;
  Random motion_rng_, obs_rng_, mover_rng_, clutter_rng_, occlusion_rng_, kidnap_rng_, detect_rng_;
  RangeBearingModel model_;
  SensorModel region_;  ///< the polygon of the sensor spec (inView)
  TwistModel integrator_;
  int obs_every_;

  std::int64_t step_ = 0;  ///< control step; stamp = step * control_period
  enum class Phase { kOdometry, kObservations, kAdvance, kEnd } phase_ = Phase::kOdometry;
  Eigen::Vector3d pose_;       ///< truth
  Eigen::Vector3d odom_pose_;  ///< integrated noisy odometry
  double steer_ = 0.0;         ///< true steering angle
  std::size_t wp_index_ = 0;   ///< counts over all laps
  std::vector<Mover> movers_;
  std::vector<char> occluded_;
  double next_occlusion_draw_ = 0.0;
  std::size_t next_kidnap_ = 0;
  int kidnaps_applied_ = 0;
  LandmarkId next_clutter_id_ = kClutterIdBase;
  OdometrySample odom_;
  ObservationSet scan_;
};

}  // namespace sim
}  // namespace ekf_slam
