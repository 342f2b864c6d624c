#include "ekf_slam/core/simulated_run.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <utility>

#include "ekf_slam/core/angles.h"
#include "ekf_slam/core/pipeline_config.h"

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
  if (world.pose_delta_odometry) {
    // The same per-step noise as the twist's, per metre of the step: sigma dt = (sigma / v) d.
    const double v = world.vehicle.speed;
    p["odometry_mode"] = "pose_delta";
    p["pose_delta_alpha_trans_per_trans"] = text(t.sigma_v / v + t.sigma_v_per_v);
    p["pose_delta_alpha_rot_per_trans"] = text(t.sigma_w / v + t.sigma_w_per_v);
    p["pose_delta_alpha_trans_per_rot"] = "0";
    p["pose_delta_alpha_rot_per_rot"] = "0";
  }
  // What odometry_correction: wheel_factors needs to match the simulated wheels.
  if (world.noise.odometry_wheel_factors != Eigen::Vector2d::Ones())
    p["correction_track_width"] = text(world.vehicle.track_width);
  return p;
}

PipelineConfig pipelineConfigFor(const World& world) {
  return readPipelineConfig(MapParameterSource(pipelineParametersFor(world)));
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
  if (pd < 1.0) p["detection_probability"] = text(pd);
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

void RunScorer::addScan(const ScanReport& report, const std::vector<LandmarkId>& truth,
                        const Eigen::Vector3d& estimate, const Eigen::Matrix3d& cov,
                        const Eigen::Vector3d* true_pose) {
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
  if (kidnap_pending_) {
    kidnap_pending_ = false;
    kidnapped_ = true;
    kidnap_scan_ = scans_ - 1;
    kidnap_stamp_ = report.stamp;
  }
  if (report.relocalised) {
    ++relocalisations_;
    if (true_pose != nullptr) {
      const Eigen::Vector3d& p = report.relocalisation.pose;
      const bool wrong =
          (p.head<2>() - true_pose->head<2>()).norm() > kWrongRelocalisationDistance ||
          std::abs(wrapAngle(p.z() - true_pose->z())) > kWrongRelocalisationAngle;
      wrong_relocalisations_ += wrong;
    }
  }
  double nees = std::numeric_limits<double>::quiet_NaN();
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
    nees = pose_.add(estimate, cov, *true_pose);
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
  }
  m.relocalisations = relocalisations_;
  m.wrong_relocalisations = wrong_relocalisations_;
  m.recovery_scans = recovery_scans_;
  m.recovery_s = recovery_s_;
  m.pose_rmse_after_recovery_m =
      after_n_ > 0 ? std::sqrt(after_sum_ / static_cast<double>(after_n_)) : nan;
  return m;
}

// --- runSimulation -------------------------------------------------------------------------------

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
  int kidnaps = 0;
  sim::Simulation simulation(world, seed);
  RunScorer scorer;
  std::vector<LandmarkId> truth;
  // Fed exactly as the offline runner feeds a simulated bag: odometry, then the set of the same
  // stamp, with the bag's stamp offset.
  for (auto e = simulation.next(); e != sim::Simulation::Event::kEnd; e = simulation.next()) {
    if (e == sim::Simulation::Event::kOdometry) {
      const sim::OdometrySample& o = simulation.odometry();
      OdometryInput in;
      in.stamp = o.stamp + sim::kStampOffset;
      in.twist = o.twist;
      in.pose = o.pose;
      pipeline.addOdometry(in);
      continue;
    }
    const sim::ObservationSet& set = simulation.observations();
    const std::vector<LandmarkId> all = set.truthIds();
    if (known != nullptr) known->setTruth(all);  // the pipeline keeps every valid observation
    if (simulation.kidnapsApplied() > kidnaps) {
      kidnaps = simulation.kidnapsApplied();
      scorer.markKidnap();
    }
    const ScanReport report =
        pipeline.processObservations(set.stamp + sim::kStampOffset, set.toObservations());
    truth.clear();
    for (const std::uint32_t i : report.input_index) truth.push_back(all[i]);
    scorer.addScan(report, truth, pipeline.pose(), pipeline.poseCovariance(), &set.true_pose);
  }
  RunMetrics m = scorer.metrics(&pipeline);
  m.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (nees_per_scan != nullptr) *nees_per_scan = scorer.neesPerScan();
  if (errors_per_scan != nullptr) *errors_per_scan = scorer.errorsPerScan();
  return m;
}

}  // namespace ekf_slam
