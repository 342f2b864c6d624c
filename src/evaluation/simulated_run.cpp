#include "ekf_slam/evaluation/simulated_run.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/coverage_grid.h"
#include "ekf_slam/evaluation/scoring/trajectory_metrics.h"
#include "ekf_slam/core/feature_extraction/beacon_extractor.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"
#include "ekf_slam/core/common/pose2d.h"
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
// Worlds with more landmarks than this run the compressed EKF (filter cekf).
constexpr std::size_t kCompressedFilterLandmarks = 5000;
// ... with areas this long [m] (cekf_area_size).
constexpr double kLargeWorldAreaSize = 150.0;
// ... and this much slack [m] (cekf_area_slack): crossing the mapped grid after half an hour of
// exploring corrects the pose by metres per scan, which closed areas again within 1-4 scans.
constexpr double kLargeWorldAreaSlack = 5.0;

double coveringRange(const World& w) {
  if (std::isfinite(w.sensor.max_range)) return w.sensor.max_range;
  return std::ceil(1.5 * (w.area_max - w.area_min).norm());
}

}  // namespace

double stampOnBag(double sim_stamp) {
  // ros::TimeBase::fromSec and toSec, without ROS.
  const double t = sim_stamp + kStampOffset;
  std::uint64_t sec = static_cast<std::uint32_t>(static_cast<std::int64_t>(std::floor(t)));
  std::uint64_t nsec = static_cast<std::uint32_t>(std::round((t - static_cast<double>(sec)) * 1e9));
  sec += nsec / 1000000000ull;
  nsec %= 1000000000ull;
  return static_cast<double>(sec) + 1e-9 * static_cast<double>(nsec);
}

Eigen::Vector3d poseOnBag(const Eigen::Vector3d& pose) {
  const Eigen::Vector4d q = yawQuaternion(pose.z());
  return {pose.x(), pose.y(), quaternionYaw(q(0), q(1), q(2), q(3))};
}

OdometryInput odometryOnBag(const OdometrySample& sample) {
  return {stampOnBag(sample.stamp), sample.twist, poseOnBag(sample.pose)};
}

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
  if (world.first_estimate_jacobians) p["jacobians"] = "first_estimate";
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
  if (world.landmarks.size() > kCompressedFilterLandmarks) {
    p["filter"] = "cekf";
    p["cekf_area_size"] = text(kLargeWorldAreaSize);
    p["cekf_area_slack"] = text(kLargeWorldAreaSlack);
  }
  if (world.noise.odometry_wheel_factors != Eigen::Vector2d::Ones()) {
    // What odometry_correction: wheel_factors needs to match the simulated wheels: their track,
    // and no random walk (the world's factors are constant). This world's consistency is what
    // it is for (AEKF, docs/results.md), so it also gets its odometry noise exactly: the speed
    // and steering-angle noise of each control step on its wheelbase, where twistNoiseFor's
    // bound at the steering limit is 3.3 times the yaw-rate noise of a straight and, with it
    // read on a straight, the turns' noise (1.7 times the variance) was missing.
    const double L = world.vehicle.wheelbase;
    p["correction_track_width"] = text(world.vehicle.track_width);
    p["correction_wheel_factor_noise"] = "0";
    p["twist_sigma_w"] = "0";
    p["twist_sigma_w_per_v"] = text(world.noise.sigma_steer / L);
    p["twist_steering_wheelbase"] = text(L);
  }
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
                                                           const std::string& short_name) {
  if (short_name == "FGCBB" || short_name == "GCBB")
    return {{"sensor_range", text(coveringRange(world))}};
  if (short_name != "DJNN") return {};
  // DJNN's local region (eq. 10) and its evidence counter need the sensor's real extent: a
  // landmark outside it must not be counted as missed.
  std::map<std::string, std::string> p = {
      {"sensor_range", text(coveringRange(world))},
      {"field_of_view", text(std::min(world.sensor.field_of_view, 2.0 * M_PI))}};
  // Sensors that are not the papers' (keys added only then, so the papers' worlds read exactly
  // what they did): a minimum range, a detection probability (the lowest in the region: DJNN's
  // threshold sits halfway to it), margins scaled to a short range.
  const SensorSpec& s = world.sensor;
  if (s.min_range > 0.0) p["min_range"] = text(s.min_range);
  const double pd =
      std::min(s.detectionProbability(s.min_range), s.detectionProbability(coveringRange(world)));
  if (pd < 1.0) {
    p["detection_probability"] = text(pd);
    // Sparse detections let movers pass close to landmarks between sightings: a landmark with two
    // bias windows of unbiased pairings stays when the bias test fires (docs/djnn.md).
    p["bias_keep_pairings"] = "10";
    // Other robots among sparse detections: admission needs sightings spanning the time in which
    // the slowest of them shows its motion (docs/djnn.md, "A minimum speed for the static test").
    if (world.movers.count > 0) p["static_min_speed"] = text(world.movers.min_speed);
    // A camera that misses landmarks keeps many of them tentative while the pose is corrected:
    // the features follow the corrections and the static test allows for the heading error
    // (docs/djnn.md, "Tentative features and the pose error"). Pairings are weighed jointly against
    // a shifted scan and against unmapped landmarks at their density where the sensor looks.
    p["tentative_follow_pose"] = "true";
    p["static_heading"] = "true";
    p["shift_test"] = "true";
    // "Where the sensor looks": per m^2 of the ground the route's views cover, not of the
    // world's bounding box (corridors hold their markers in a third of the grid's area).
    if (!world.landmarks.empty()) p["landmark_density"] = text(coveredLandmarkDensity(world));
    if (world.movers.count == 0) {
      // Without movers, a few static sightings tell a landmark from clutter (the 7-sighting
      // admission is the static test's span for walking-pace movers), and loop closures get the
      // joint decision with the features seen but not admitted remembered as evidence
      // (docs/djnn.md, "Closing the loops"); the route of `fiducials` never returns within 60 s.
      p["admit_evidence"] = "3";
      p["loop_closure_age"] = "60";
      p["remembered_sightings"] = "2";
      p["held_birth_cost"] = "4";
      // Two markers are never closer than this: a source that close to a mapped one is that
      // marker or clutter (docs/djnn.md, "The other failing seeds").
      if (world.clutter_rate > 0.0) p["landmark_spacing"] = text(leastSpacing(world.landmarks));
      // One held scan's noise passing the margin no longer decides a closure: its lead must
      // have led the held scan before (docs/djnn.md, "A held closure decided only on a lead
      // that repeats").
      p["held_confirmations"] = "1";
    }
  }
  const double R = coveringRange(world);
  if (R < 15.0) p["range_margin"] = text(0.2 * R);
  if (s.polygon.size() >= 3) {
    std::string poly;
    for (const Eigen::Vector2d& v : s.polygon) {
      poly += (poly.empty() ? "" : "; ") + text(v.x()) + "," + text(v.y());
    }
    p["fov_polygon"] = poly;
  }
  if (pd < 1.0 && world.clutter_rate > 0.0) {
    // Clutter is uniform over the sensor's sector (min..max range, field of view).
    const double half = 0.5 * std::min(s.field_of_view, 2.0 * M_PI);
    const double area = half * (R * R - s.min_range * s.min_range);
    p["clutter_density"] = text(world.clutter_rate / area);
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

// --- KnownAssociation ----------------------------------------------------------------------------

AssociationResult KnownAssociation::associate(const AssociationContext& context) {
  AssociationResult r;
  r.resize(context.numObservations());
  for (std::size_t i = 0; i < context.numObservations() && i < truth_.size(); ++i) {
    if (!sim::isStaticLandmark(truth_[i])) continue;  // movers and clutter: rejected
    const auto it = landmark_of_.find(truth_[i]);
    if (it != landmark_of_.end() && context.ekf().contains(it->second)) {
      r.pair(i, it->second);
    } else {
      r.decision[i] = Decision::kNew;
    }
  }
  return r;
}

void KnownAssociation::landmarkAdded(int obs, LandmarkId id) {
  if (obs >= 0 && static_cast<std::size_t>(obs) < truth_.size()) landmark_of_[truth_[obs]] = id;
}

// --- RunScorer -----------------------------------------------------------------------------------

namespace {

PoseError errorAfter(const RigidTransform2& align, const Eigen::Vector3d& estimate,
                     const Eigen::Vector3d& true_pose) {
  PoseError e;
  e.position = (align.apply(estimate.head<2>()) - true_pose.head<2>()).norm();
  e.heading = std::abs(wrapAngle(estimate.z() + align.yaw - true_pose.z()));
  return e;
}

}  // namespace

std::optional<RigidTransform2> RunScorer::mapAlignment(const EkfSlam& map) const {
  // Per static truth identity, the oldest landmark holding it (its position). After a kidnap only
  // landmarks made before it count: a map rebuilt around the kidnapped pose (DJNN's exit rule
  // removing the old one) must not make a displaced pose look recovered.
  const bool after_kidnap = kidnapped_ || kidnap_pending_;
  std::unordered_map<LandmarkId, std::pair<LandmarkId, Eigen::Vector2d>> oldest;
  for (std::size_t k = 0; k < map.numLandmarks(); ++k) {
    const LandmarkId id = map.landmarkIds()[k];
    if (after_kidnap && id > last_id_before_kidnap_) continue;
    LandmarkId truth = -1;
    if (!scorer_.identity(id, &truth) || true_map_.count(truth) == 0) continue;
    const Eigen::Vector2d position = map.landmark(static_cast<int>(k));
    const auto [it, added] = oldest.try_emplace(truth, id, position);
    if (!added && id < it->second.first) it->second = {id, position};
  }
  if (oldest.size() < kMinAlignmentLandmarks) return std::nullopt;
  std::vector<Eigen::Vector2d> from, to;
  from.reserve(oldest.size());
  to.reserve(oldest.size());
  for (const auto& [truth, landmark] : oldest) {
    from.push_back(landmark.second);
    to.push_back(true_map_.at(truth));
  }
  return alignRigid2D(from, to);
}

PoseError RunScorer::mapRelativeError(const EkfSlam& map, const Eigen::Vector3d& estimate,
                                      const Eigen::Vector3d& true_pose) const {
  const std::optional<RigidTransform2> align = mapAlignment(map);
  return align ? errorAfter(*align, estimate, true_pose) : PoseError();
}

bool RunScorer::needsMap(const ScanReport& report) const {
  const bool before = expect_kidnap_ && !kidnapped_ && !kidnap_pending_;
  const bool after = (kidnapped_ || kidnap_pending_) && !(recovered_map_ && map_window_passed_);
  return !true_map_.empty() && (report.relocalised || before || after);
}

void RunScorer::addScan(const ScanReport& report, const std::vector<LandmarkId>& truth,
                        const Eigen::Vector3d& estimate, const Eigen::Matrix3d& cov,
                        const Eigen::Vector3d* true_pose, const EkfSlam* map) {
  if (truth.size() != report.observations.size()) {
    throw std::invalid_argument("RunScorer: " + std::to_string(truth.size()) + " truth ids for " +
                                std::to_string(report.observations.size()) + " observations");
  }
  scorer_.addScan(truth, report.association, report.removed);
  ++scans_;
  observations_ += truth.size();
  association_s_ += report.association_s;
  update_s_ += report.update_s;
  if (!have_first_) {
    have_first_ = true;
    first_stamp_ = report.stamp;
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Decided before this scan changes the kidnap state, as the caller decided.
  const std::optional<RigidTransform2> align =
      map != nullptr && true_pose != nullptr && needsMap(report) ? mapAlignment(*map)
                                                                 : std::nullopt;
  if (kidnap_pending_) {
    kidnap_pending_ = false;
    kidnapped_ = true;
    kidnap_scan_ = scans_ - 1;
    kidnap_stamp_ = report.stamp;
    error_before_kidnap_ = last_error_;
    error_before_kidnap_map_ = last_error_map_;
  }
  if (report.relocalised) {
    ++relocalisations_;
    if (true_pose != nullptr) {
      const auto wrong = [&](const PoseError& e) {
        return e.position > kWrongRelocalisationDistance || e.heading > kWrongRelocalisationAngle;
      };
      const Eigen::Vector3d& p = report.relocalisation.pose;
      wrong_relocalisations_ += wrong(errorAfter(RigidTransform2(), p, *true_pose));
      if (align) wrong_relocalisations_map_ += wrong(errorAfter(*align, p, *true_pose));
    }
  }
  // NaN where not measured (no map, or too few identified landmarks).
  const double in_map = align ? errorAfter(*align, estimate, *true_pose).position : nan;
  if (!kidnapped_ && map != nullptr) {
    last_error_map_ = in_map;
    // Landmark ids only grow: the newest one so far bounds the map made before the kidnap.
    for (const LandmarkId id : map->landmarkIds())
      last_id_before_kidnap_ = std::max(last_id_before_kidnap_, id);
  }
  if (kidnapped_ && !recovered_map_ && in_map < kRecoveredDistance) {
    recovered_map_ = true;
    recovery_scans_map_ = static_cast<std::int64_t>(scans_ - 1 - kidnap_scan_);
    recovery_s_map_ = report.stamp - kidnap_stamp_;
  }
  if (kidnapped_ && !map_window_passed_ && report.stamp - kidnap_stamp_ >= kRecoveryWindow - 1e-6) {
    map_window_passed_ = true;
    error_after_kidnap_map_ = in_map;
  }
  double nees = nan;
  Eigen::Vector2d error = Eigen::Vector2d::Constant(nees);
  if (true_pose != nullptr) {
    const double distance = (estimate.head<2>() - true_pose->head<2>()).norm();
    if (kidnapped_ && !recovered_ && distance < kRecoveredDistance) {
      recovered_ = true;
      recovery_scans_ = static_cast<std::int64_t>(scans_ - 1 - kidnap_scan_);
      recovery_s_ = report.stamp - kidnap_stamp_;
    }
    if (recovered_) {
      after_sum_ += distance * distance;
      ++after_n_;
    }
    if (kidnapped_ && std::isnan(error_after_kidnap_) &&
        report.stamp - kidnap_stamp_ >= kRecoveryWindow - 1e-6)
      error_after_kidnap_ = distance;
    last_error_ = distance;
    nees = pose_.add(estimate, cov, *true_pose);
    estimates_.push_back(estimate);
    truths_.push_back(*true_pose);
    error << distance, std::abs(wrapAngle(estimate(2) - (*true_pose)(2)));
    if (std::isfinite(nees) && report.stamp - first_stamp_ >= nees_skip_s_) {
      nees_sum_ += nees;
      ++nees_n_;
    }
  }
  nees_.push_back(nees);
  errors_.push_back(error);
}

void RunScorer::markKidnap() {
  if (!kidnapped_) kidnap_pending_ = true;  // the first kidnap is the one timed
}

RunMetrics RunScorer::metrics(const SlamPipeline* pipeline) const {
  RunMetrics m;
  m.counts = scorer_.counts();
  m.map = scorer_.mapScore();
  m.scans = scans_;
  m.observations = observations_;
  m.unknown_pairings = scorer_.unknownPairings();
  m.identity_switches = scorer_.identitySwitches();
  const bool have_pose = pose_.count() > 0;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  m.pose_rmse_m = have_pose ? pose_.positionRmse() : nan;
  m.heading_rmse_rad = have_pose ? pose_.headingRmse() : nan;
  m.anees = nees_n_ > 0 ? nees_sum_ / static_cast<double>(nees_n_) : nan;
  // Aligned trajectory (ATE) and map: one rigid transform, fitted on the positions.
  RigidTransform2 align;
  if (!estimates_.empty()) {
    std::vector<Eigen::Vector2d> from, to;
    from.reserve(estimates_.size());
    to.reserve(truths_.size());
    for (std::size_t i = 0; i < estimates_.size(); ++i) {
      from.push_back(estimates_[i].head<2>());
      to.push_back(truths_[i].head<2>());
    }
    align = alignRigid2D(from, to);
    double sum_pos2 = 0.0, sum_yaw2 = 0.0;
    for (std::size_t i = 0; i < from.size(); ++i) {
      sum_pos2 += (align.apply(from[i]) - to[i]).squaredNorm();
      const double dyaw = wrapAngle(estimates_[i].z() + align.yaw - truths_[i].z());
      sum_yaw2 += dyaw * dyaw;
    }
    const double n_pose = static_cast<double>(from.size());
    m.pose_ate_aligned_m = std::sqrt(sum_pos2 / n_pose);
    m.heading_rmse_aligned_rad = std::sqrt(sum_yaw2 / n_pose);
  }
  m.nees_scans = nees_n_;
  const double n = scans_ > 0 ? static_cast<double>(scans_) : 1.0;
  m.association_us_mean = 1e6 * association_s_ / n;
  m.update_us_mean = 1e6 * update_s_ / n;
  if (pipeline != nullptr) {
    m.rejected_updates = pipeline->counters().rejected_updates;
    const EkfSlam& ekf = pipeline->ekf();
    m.correction_names = pipeline->odometryCorrection().names();
    m.correction = ekf.correction();
    m.correction_sigma = ekf.correctionCovariance().diagonal().cwiseSqrt();
    m.lost_events = pipeline->counters().lost_events;
    double sum2 = 0.0;
    for (std::size_t k = 0; k < ekf.numLandmarks() && !true_map_.empty(); ++k) {
      LandmarkId truth = -1;
      if (!scorer_.identity(ekf.landmarkIds()[k], &truth)) continue;
      const auto it = true_map_.find(truth);
      if (it == true_map_.end()) continue;
      sum2 += (align.apply(ekf.landmark(static_cast<int>(k))) - it->second).squaredNorm();
      ++m.map_rmse_landmarks;
    }
    if (m.map_rmse_landmarks > 0)
      m.map_rmse_aligned_m = std::sqrt(sum2 / static_cast<double>(m.map_rmse_landmarks));
  }
  m.relocalisations = relocalisations_;
  m.wrong_relocalisations = wrong_relocalisations_;
  m.recovery_scans = recovery_scans_;
  m.recovery_s = recovery_s_;
  m.pose_rmse_after_recovery_m =
      after_n_ > 0 ? std::sqrt(after_sum_ / static_cast<double>(after_n_)) : nan;
  m.error_before_kidnap_m = error_before_kidnap_;
  m.error_after_kidnap_m = error_after_kidnap_;
  m.recovery_scans_map = recovery_scans_map_;
  m.recovery_s_map = recovery_s_map_;
  m.error_before_kidnap_map_m = error_before_kidnap_map_;
  m.error_after_kidnap_map_m = error_after_kidnap_map_;
  m.wrong_relocalisations_map = wrong_relocalisations_map_;
  return m;
}

// --- runSimulation -------------------------------------------------------------------------------

std::vector<LandmarkId> truthByProximity(
    const Eigen::Vector3d& true_sensor_pose, const std::vector<Observation>& observations,
    const std::vector<std::pair<LandmarkId, Eigen::Vector2d>>& landmarks,
    LandmarkId* next_clutter) {
  std::vector<LandmarkId> truth;
  truth.reserve(observations.size());
  for (const Observation& o : observations) {
    const Eigen::Vector2d p =
        composePose(true_sensor_pose,
                    Eigen::Vector3d(o.z(0) * std::cos(o.z(1)), o.z(0) * std::sin(o.z(1)), 0.0))
            .head<2>();
    LandmarkId id = (*next_clutter)--;
    for (const auto& [landmark, position] : landmarks) {
      if ((position - p).norm() < kLaserTruthDistance) id = landmark;
    }
    truth.push_back(id);
  }
  return truth;
}

void feedSimulation(sim::Simulation& simulation, SlamPipeline& pipeline,
                    const std::function<bool(const sim::ObservationSet&)>& on_set) {
  for (auto e = simulation.next(); e != sim::Simulation::Event::kEnd; e = simulation.next()) {
    if (e == sim::Simulation::Event::kOdometry) {
      pipeline.addOdometry(sim::odometryOnBag(simulation.odometry()));
    } else if (!on_set(simulation.observations())) {
      return;
    }
  }
}

RunMetrics runSimulationOn(SlamPipeline* pipeline, const sim::World& world, std::uint64_t seed,
                           KnownAssociation* known, std::vector<double>* nees_per_scan,
                           std::vector<Eigen::Vector2d>* errors_per_scan,
                           const ScanObserver& on_scan) {
  const std::optional<sim::CarPark> laser_world = sim::laserWorld(world.name);
  if (laser_world && known != nullptr) {
    throw std::invalid_argument("the true associations need truth ids before association; world '" +
                                world.name + "' extracts its features from scans");
  }
  std::optional<sim::LaserScanSimulator> laser;
  if (laser_world) laser.emplace(laser_world->laser, laser_world->scene);
  sim::Random laser_noise(sim::Random::streamSeed(seed, sim::kLaserNoiseStream));
  LandmarkId clutter = sim::kClutterIdBase;
  std::vector<std::pair<LandmarkId, Eigen::Vector2d>> beacons;
  for (std::size_t k = 0; k < world.landmarks.size(); ++k)
    beacons.emplace_back(static_cast<LandmarkId>(k), world.landmarks[k]);

  int kidnaps = 0;
  sim::Simulation simulation(world, seed);
  RunScorer scorer;
  scorer.setTrueMap({beacons.begin(), beacons.end()});
  if (!world.kidnaps.empty()) scorer.expectKidnap();
  std::vector<LandmarkId> truth;
  feedSimulation(simulation, *pipeline, [&](const sim::ObservationSet& set) {
    if (simulation.kidnapsApplied() > kidnaps) {
      kidnaps = simulation.kidnapsApplied();
      scorer.markKidnap();
    }
    truth.clear();
    ScanReport report;
    // Scored against the true pose as a bag's /ground_truth holds it (the offline runner's).
    const Eigen::Vector3d true_pose = sim::poseOnBag(set.true_pose);
    if (laser) {
      // The simulator's point observations are ignored: the laser sees the scene.
      const Eigen::Vector3d sensor = composePose(set.true_pose, world.sensor.offset);
      report = pipeline->processScan(sim::stampOnBag(set.stamp), laser->scan(sensor, &laser_noise));
      truth = truthByProximity(composePose(true_pose, world.sensor.offset), report.observations,
                               beacons, &clutter);
    } else {
      const std::vector<LandmarkId> all = set.truthIds();
      if (known != nullptr) known->setTruth(all);  // the pipeline keeps every valid observation
      report = pipeline->processObservations(sim::stampOnBag(set.stamp), set.toObservations());
      for (const std::uint32_t i : report.input_index) truth.push_back(all[i]);
    }
    // activeEkf(): after a processed scan no motion is pending, so reading it changes nothing
    // (a dropped duplicate scan returns before the prediction: not read then).
    const bool read_map = scorer.needsMap(report) && !report.duplicate;
    scorer.addScan(report, truth, pipeline->pose(), pipeline->poseCovariance(), &true_pose,
                   read_map ? &pipeline->activeEkf() : nullptr);
    if (on_scan) on_scan(report, *pipeline);
    return true;
  });
  if (nees_per_scan != nullptr) *nees_per_scan = scorer.neesPerScan();
  if (errors_per_scan != nullptr) *errors_per_scan = scorer.errorsPerScan();
  return scorer.metrics(pipeline);
}

RunMetrics runSimulation(const sim::World& world, std::uint64_t seed, const PipelineConfig& config,
                         std::shared_ptr<DataAssociation> associator,
                         std::vector<double>* nees_per_scan,
                         std::vector<Eigen::Vector2d>* errors_per_scan,
                         std::shared_ptr<Relocaliser> relocaliser) {
  const auto t0 = std::chrono::steady_clock::now();
  associator->reset();
  auto* known = dynamic_cast<KnownAssociation*>(associator.get());
  SlamPipeline pipeline(config, std::move(associator));
  pipeline.setSensorOffset(world.sensor.offset);
  pipeline.setRelocaliser(std::move(relocaliser));
  const sim::ExtractorSetup extractor = sim::extractorFor(world);
  if (extractor.name == "BeaconExtractor") {
    auto beacons = std::make_shared<BeaconExtractor>();
    beacons->configure(MapParameterSource(extractor.parameters));
    pipeline.setFeatureExtractor(beacons);
  }
  RunMetrics m = runSimulationOn(&pipeline, world, seed, known, nees_per_scan, errors_per_scan);
  m.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return m;
}

}  // namespace ekf_slam
