// PipelineConfig from parameters (one place for the node and the offline runner) and its checks.
#include "ekf_slam/core/pipeline/pipeline_config.h"

#include <cmath>
#include <sstream>
#include <string>

#include "ekf_slam/core/feature_extraction/tree_feature_extractor.h"

namespace ekf_slam {

namespace {

// Additive noise is given as per-axis standard deviations; the models take a covariance.
Eigen::Matrix3d diagonalCovariance(double sx, double sy, double syaw) {
  return Eigen::Vector3d(sx * sx, sy * sy, syaw * syaw).asDiagonal();
}

double sigmaOf(const Eigen::Matrix3d& cov, int axis) { return std::sqrt(cov(axis, axis)); }

void checkAdditive(const Eigen::Matrix3d& a, const std::string& prefix) {
  const char* axis[3] = {"x", "y", "yaw"};
  for (int i = 0; i < 3; ++i) {
    requireParameter(std::isfinite(a(i, i)) && a(i, i) >= 0.0,
                     prefix + "_additive_sigma_" + axis[i], "variance must be finite and >= 0",
                     a(i, i));
  }
  requireParameter(a.allFinite() && a.isApprox(a.transpose()), prefix + "_additive_sigma_x",
                   "additive covariance must be symmetric and finite", a(0, 1));
}

}  // namespace

void PipelineConfig::validate() const {
  if (odometry_mode != "twist" && odometry_mode != "pose_delta") {
    throw ParameterError("parameter odometry_mode: must be one of {twist, pose_delta}, got '" +
                         odometry_mode + "'");
  }
  if (mode != "slam" && mode != "localization") {
    throw ParameterError("parameter mode: must be one of {slam, localization}, got '" + mode + "'");
  }
  correction.validate();
  if (correction.mode != "none" && odometry_mode != "twist") {
    throw ParameterError("parameter odometry_correction: '" + correction.mode +
                         "' needs odometry_mode twist, got '" + odometry_mode + "'");
  }
  const auto nonNegative = [](double v, const std::string& name) {
    requireParameter(std::isfinite(v) && v >= 0.0, name, "must be finite and >= 0", v);
  };
  const auto positive = [](double v, const std::string& name) {
    requireParameter(std::isfinite(v) && v > 0.0, name, "must be finite and > 0", v);
  };
  nonNegative(twist.sigma_v, "twist_sigma_v");
  nonNegative(twist.sigma_v_per_v, "twist_sigma_v_per_v");
  nonNegative(twist.sigma_w, "twist_sigma_w");
  nonNegative(twist.sigma_w_per_v, "twist_sigma_w_per_v");
  nonNegative(twist.steering_wheelbase, "twist_steering_wheelbase");
  checkAdditive(twist.additive, "twist");
  nonNegative(pose_delta.alpha_trans_per_trans, "pose_delta_alpha_trans_per_trans");
  nonNegative(pose_delta.alpha_trans_per_rot, "pose_delta_alpha_trans_per_rot");
  nonNegative(pose_delta.alpha_rot_per_rot, "pose_delta_alpha_rot_per_rot");
  nonNegative(pose_delta.alpha_rot_per_trans, "pose_delta_alpha_rot_per_trans");
  checkAdditive(pose_delta.additive, "pose_delta");

  positive(sigma_range, "sigma_range");
  positive(sigma_bearing, "sigma_bearing");
  nonNegative(min_observation_range, "min_observation_range");
  positive(max_observation_range, "max_observation_range");
  requireParameter(min_observation_range < max_observation_range, "min_observation_range",
                   "must be < max_observation_range", min_observation_range);

  positive(extractor.max_range, "extractor_max_range");
  positive(extractor.range_jump, "extractor_range_jump");
  positive(extractor.angle_gap, "extractor_angle_gap");
  nonNegative(extractor.occlusion_distance, "extractor_occlusion_distance");
  requireParameter(extractor.occlusion_lookahead >= 0 && extractor.occlusion_lookahead <= 1000,
                   "extractor_occlusion_lookahead", "must lie in [0, 1000]",
                   extractor.occlusion_lookahead);
  nonNegative(extractor.neighbour_angle, "extractor_neighbour_angle");
  positive(extractor.max_extent, "extractor_max_extent");
  nonNegative(extractor.min_range, "extractor_min_range");
  nonNegative(extractor.edge_margin, "extractor_edge_margin");
  positive(extractor.max_range_difference_divisor, "extractor_max_range_difference_divisor");
  nonNegative(extractor.range_resolution, "extractor_range_resolution");

  const char* axis[3] = {"x", "y", "yaw"};
  for (int i = 0; i < 3; ++i) {
    requireParameter(std::isfinite(initial_pose(i)), std::string("initial_pose_") + axis[i],
                     "must be finite", initial_pose(i));
    nonNegative(initial_pose_sigma(i), std::string("initial_pose_sigma_") + axis[i]);
  }
  positive(index_cell_size, "index_cell_size");
  positive(max_odometry_gap, "max_odometry_gap");
  positive(max_speed, "max_speed");
  positive(max_yaw_rate, "max_yaw_rate");
  nonNegative(max_latency, "max_latency");
  positive(time_jump_threshold, "time_jump_threshold");

  const auto count = [](int v, const std::string& name) {
    requireParameter(v >= 0 && v <= 100000, name, "must lie in [0, 100000]", v);
  };
  count(lost_unpaired_scans, "lost_unpaired_scans");
  count(lost_min_observations, "lost_min_observations");
  count(lost_min_expected, "lost_min_expected");
  requireParameter(lost_min_paired_share >= 0.0 && lost_min_paired_share <= 1.0,
                   "lost_min_paired_share", "must lie in [0, 1]", lost_min_paired_share);
  count(lost_share_learning_scans, "lost_share_learning_scans");
  count(lost_recent_scans, "lost_recent_scans");
  nonNegative(lost_view_range, "lost_view_range");
  requireParameter(lost_field_of_view > 0.0 && lost_field_of_view <= 2.0 * M_PI,
                   "lost_field_of_view", "must lie in (0, 2 pi]", lost_field_of_view);
  if (!lost_view_polygon.empty()) {
    if (const std::string problem = polygonProblem(lost_view_polygon); !problem.empty())
      throw ParameterError("parameter lost_view_polygon: " + problem);
  }
  count(lost_nis_scans, "lost_nis_scans");
  count(lost_rejected_scans, "lost_rejected_scans");
  count(lost_share_window, "lost_share_window");
  requireParameter(lost_established_share >= 0.0 && lost_established_share <= 1.0,
                   "lost_established_share", "must lie in [0, 1]", lost_established_share);
  count(lost_max_scans, "lost_max_scans");
  count(relocalisation_confirmations, "relocalisation_confirmations");
  requireParameter(
      relocalisation_confirm_probability >= 0.0 && relocalisation_confirm_probability < 1.0,
      "relocalisation_confirm_probability", "must lie in [0, 1)",
      relocalisation_confirm_probability);
  requireParameter(relocalisation_held_fixes >= 1, "relocalisation_held_fixes",
                   "must be at least 1", relocalisation_held_fixes);
  requireParameter(relocalisation_window_scans >= 1, "relocalisation_window_scans",
                   "must be at least 1", relocalisation_window_scans);
  requireParameter(lost_map_pair_probability > 0.0 && lost_map_pair_probability < 1.0,
                   "lost_map_pair_probability", "must lie in (0, 1)", lost_map_pair_probability);
  requireParameter(
      lost_map_new_probability >= lost_map_pair_probability && lost_map_new_probability < 1.0,
      "lost_map_new_probability", "must lie in [lost_map_pair_probability, 1)",
      lost_map_new_probability);
  requireParameter(lost_map_min_sightings >= 1, "lost_map_min_sightings", "must be at least 1",
                   lost_map_min_sightings);
  requireParameter(relocalisation_confirm_distance > 0.0, "relocalisation_confirm_distance",
                   "must be positive", relocalisation_confirm_distance);
  requireParameter(relocalisation_confirm_angle > 0.0 && relocalisation_confirm_angle <= M_PI,
                   "relocalisation_confirm_angle", "must lie in (0, pi]",
                   relocalisation_confirm_angle);
  requireParameter(lost_nis_probability > 0.0 && lost_nis_probability < 1.0, "lost_nis_probability",
                   "must lie in (0, 1)", lost_nis_probability);
  if (filter != "ekf" && filter != "cekf") {
    throw ParameterError("parameter filter: must be one of {ekf, cekf}, got '" + filter + "'");
  }
  positive(cekf_area_size, "cekf_area_size");
  nonNegative(cekf_margin, "cekf_margin");
  nonNegative(cekf_area_slack, "cekf_area_slack");
  if (jacobians != "auto" && jacobians != "standard" && jacobians != "first_estimate" &&
      jacobians != "invariant") {
    throw ParameterError(
        "parameter jacobians: must be one of {auto, standard, first_estimate, invariant}, got '" +
        jacobians + "'");
  }
  // The compressed filter's private filter starts from the current estimates at every area
  // switch: it would need the first estimates carried through it (not done); the invariant
  // filter re-expresses the whole P after each update, which the compressed one defers.
  if ((jacobians == "first_estimate" || jacobians == "invariant") && filter == "cekf") {
    throw ParameterError("parameter jacobians: " + jacobians + " needs filter ekf, not cekf");
  }
}

PipelineConfig readPipelineConfig(const ParameterSource& params) {
  const ParameterReader r(params);
  PipelineConfig c;  // the defaults
  c.odometry_mode = r.text("odometry_mode", c.odometry_mode, {"twist", "pose_delta"});
  c.mode = r.text("mode", c.mode, {"slam", "localization"});

  TwistParams& t = c.twist;
  t.sigma_v = r.nonNegative("twist_sigma_v", t.sigma_v);
  t.sigma_v_per_v = r.nonNegative("twist_sigma_v_per_v", t.sigma_v_per_v);
  t.sigma_w = r.nonNegative("twist_sigma_w", t.sigma_w);
  t.sigma_w_per_v = r.nonNegative("twist_sigma_w_per_v", t.sigma_w_per_v);
  t.steering_wheelbase = r.nonNegative("twist_steering_wheelbase", t.steering_wheelbase);
  t.per_second = r.text("process_noise", t.per_second ? "per_second" : "per_message",
                        {"per_message", "per_second"}) == "per_second";
  t.additive =
      diagonalCovariance(r.nonNegative("twist_additive_sigma_x", sigmaOf(t.additive, 0)),
                         r.nonNegative("twist_additive_sigma_y", sigmaOf(t.additive, 1)),
                         r.nonNegative("twist_additive_sigma_yaw", sigmaOf(t.additive, 2)));

  PoseDeltaParams& d = c.pose_delta;
  d.alpha_trans_per_trans =
      r.nonNegative("pose_delta_alpha_trans_per_trans", d.alpha_trans_per_trans);
  d.alpha_trans_per_rot = r.nonNegative("pose_delta_alpha_trans_per_rot", d.alpha_trans_per_rot);
  d.alpha_rot_per_rot = r.nonNegative("pose_delta_alpha_rot_per_rot", d.alpha_rot_per_rot);
  d.alpha_rot_per_trans = r.nonNegative("pose_delta_alpha_rot_per_trans", d.alpha_rot_per_trans);
  d.additive =
      diagonalCovariance(r.nonNegative("pose_delta_additive_sigma_x", sigmaOf(d.additive, 0)),
                         r.nonNegative("pose_delta_additive_sigma_y", sigmaOf(d.additive, 1)),
                         r.nonNegative("pose_delta_additive_sigma_yaw", sigmaOf(d.additive, 2)));

  OdometryCorrectionParams& oc = c.correction;
  oc.mode = r.text("odometry_correction", oc.mode,
                   {"none", "speed_scale", "speed_scale_yaw_bias", "wheel_factors"});
  oc.speed_scale_initial = r.positive("correction_speed_scale_initial", oc.speed_scale_initial);
  oc.speed_scale_sigma = r.positive("correction_speed_scale_sigma", oc.speed_scale_sigma);
  oc.speed_scale_noise = r.nonNegative("correction_speed_scale_noise", oc.speed_scale_noise);
  oc.yaw_bias_initial = r.number("correction_yaw_bias_initial", oc.yaw_bias_initial);
  oc.yaw_bias_sigma = r.positive("correction_yaw_bias_sigma", oc.yaw_bias_sigma);
  oc.yaw_bias_noise = r.nonNegative("correction_yaw_bias_noise", oc.yaw_bias_noise);
  oc.wheel_factor_initial = r.positive("correction_wheel_factor_initial", oc.wheel_factor_initial);
  oc.wheel_factor_sigma = r.positive("correction_wheel_factor_sigma", oc.wheel_factor_sigma);
  oc.wheel_factor_noise = r.nonNegative("correction_wheel_factor_noise", oc.wheel_factor_noise);
  oc.track_width = r.positive("correction_track_width", oc.track_width);
  oc.factor_min = r.positive("correction_factor_min", oc.factor_min);
  oc.factor_max = r.positive("correction_factor_max", oc.factor_max);
  oc.yaw_bias_max = r.positive("correction_yaw_bias_max", oc.yaw_bias_max);

  c.sigma_range = r.positive("sigma_range", c.sigma_range);
  c.sigma_bearing = r.positive("sigma_bearing", c.sigma_bearing);
  c.max_observation_range = r.positive("max_observation_range", c.max_observation_range);
  c.min_observation_range = r.nonNegative("min_observation_range", c.min_observation_range);
  if (!(c.min_observation_range < c.max_observation_range)) {
    r.fail("min_observation_range",
           "must be < max_observation_range (" + std::to_string(c.max_observation_range) + ")");
  }

  // TreeExtractor's parameters under their historical top-level names.
  c.extractor = readTreeExtractorParams(params, "extractor_", c.extractor);
  c.feature_extractor = r.text("extractor", c.feature_extractor);

  c.initial_pose =
      Eigen::Vector3d(r.number("initial_pose_x", c.initial_pose.x()),
                      r.number("initial_pose_y", c.initial_pose.y()),
                      r.inRange("initial_pose_yaw", c.initial_pose.z(), -4.0 * M_PI, 4.0 * M_PI));
  c.initial_pose_sigma =
      Eigen::Vector3d(r.nonNegative("initial_pose_sigma_x", c.initial_pose_sigma.x()),
                      r.nonNegative("initial_pose_sigma_y", c.initial_pose_sigma.y()),
                      r.nonNegative("initial_pose_sigma_yaw", c.initial_pose_sigma.z()));
  c.index_cell_size = r.positive("index_cell_size", c.index_cell_size);
  c.max_odometry_gap = r.positive("max_odometry_gap", c.max_odometry_gap);
  c.max_speed = r.positive("max_speed", c.max_speed);
  c.max_yaw_rate = r.positive("max_yaw_rate", c.max_yaw_rate);
  c.max_latency = r.nonNegative("max_latency", c.max_latency);
  c.time_jump_threshold = r.positive("time_jump_threshold", c.time_jump_threshold);

  c.relocaliser = r.text("relocaliser", c.relocaliser);
  c.lost_unpaired_scans = r.integer("lost_unpaired_scans", c.lost_unpaired_scans, 0, 100000);
  c.lost_min_observations = r.integer("lost_min_observations", c.lost_min_observations, 0, 100000);
  c.lost_min_expected = r.integer("lost_min_expected", c.lost_min_expected, 0, 100000);
  c.lost_min_paired_share = r.inRange("lost_min_paired_share", c.lost_min_paired_share, 0.0, 1.0);
  c.lost_share_learning_scans =
      r.integer("lost_share_learning_scans", c.lost_share_learning_scans, 0, 100000);
  c.lost_recent_scans = r.integer("lost_recent_scans", c.lost_recent_scans, 0, 100000);
  c.lost_recent_informative = r.flag("lost_recent_informative", c.lost_recent_informative);
  c.lost_view_range = r.nonNegative("lost_view_range", c.lost_view_range);
  c.lost_field_of_view = r.inRange("lost_field_of_view", c.lost_field_of_view, 1e-6, 2.0 * M_PI);
  if (const std::string polygon = r.text("lost_view_polygon", ""); !polygon.empty()) {
    try {
      c.lost_view_polygon = parsePolygon(polygon);
    } catch (const std::invalid_argument& e) {
      r.fail("lost_view_polygon", e.what());
    }
    if (const std::string problem = polygonProblem(c.lost_view_polygon); !problem.empty())
      r.fail("lost_view_polygon", problem);
  }
  c.lost_nis_scans = r.integer("lost_nis_scans", c.lost_nis_scans, 0, 100000);
  c.lost_rejected_scans = r.integer("lost_rejected_scans", c.lost_rejected_scans, 0, 100000);
  c.lost_share_window = r.integer("lost_share_window", c.lost_share_window, 0, 100000);
  c.lost_established_share =
      r.inRange("lost_established_share", c.lost_established_share, 0.0, 1.0);
  c.lost_share_probe = r.flag("lost_share_probe", c.lost_share_probe);
  c.lost_max_scans = r.integer("lost_max_scans", c.lost_max_scans, 0, 100000);
  c.lost_nis_probability = r.probability("lost_nis_probability", c.lost_nis_probability);
  c.filter = r.text("filter", c.filter, {"ekf", "cekf"});
  c.jacobians =
      r.text("jacobians", c.jacobians, {"auto", "standard", "first_estimate", "invariant"});
  c.second_order_observations = r.flag("second_order_observations", c.second_order_observations);
  c.delayed_sightings = r.flag("delayed_sightings", c.delayed_sightings);
  c.max_pose_clones = r.integer("max_pose_clones", c.max_pose_clones, 1, 10000);
  c.release_out_of_reach = r.flag("release_out_of_reach", c.release_out_of_reach);
  c.restarted_sighting_probability =
      r.probability("restarted_sighting_probability", c.restarted_sighting_probability);
  c.cekf_area_size = r.positive("cekf_area_size", c.cekf_area_size);
  c.cekf_margin = r.nonNegative("cekf_margin", c.cekf_margin);
  c.cekf_area_slack = r.nonNegative("cekf_area_slack", c.cekf_area_slack);
  c.relocalisation_confirmations =
      r.integer("relocalisation_confirmations", c.relocalisation_confirmations, 0, 1000);
  c.relocalisation_confirm_probability = r.inRange(
      "relocalisation_confirm_probability", c.relocalisation_confirm_probability, 0.0, 0.999999);
  c.relocalisation_held_fixes =
      r.integer("relocalisation_held_fixes", c.relocalisation_held_fixes, 1, 100);
  c.relocalisation_window_scans =
      r.integer("relocalisation_window_scans", c.relocalisation_window_scans, 1, 100);
  c.lost_map_scans = r.flag("lost_map_scans", c.lost_map_scans);
  c.lost_rollback = r.flag("lost_rollback", c.lost_rollback);
  c.lost_onset_scans = r.integer("lost_onset_scans", c.lost_onset_scans, 0, 1000);
  c.lost_onset_snapshots = r.integer("lost_onset_snapshots", c.lost_onset_snapshots, 1, 1000);
  c.lost_onset_min_score = r.positive("lost_onset_min_score", c.lost_onset_min_score);
  c.lost_map_pair_probability =
      r.probability("lost_map_pair_probability", c.lost_map_pair_probability);
  c.lost_map_new_probability =
      r.probability("lost_map_new_probability", c.lost_map_new_probability);
  c.lost_map_min_sightings = r.integer("lost_map_min_sightings", c.lost_map_min_sightings, 1, 1000);
  c.relocalisation_confirm_distance =
      r.positive("relocalisation_confirm_distance", c.relocalisation_confirm_distance);
  c.relocalisation_confirm_angle =
      r.inRange("relocalisation_confirm_angle", c.relocalisation_confirm_angle, 1e-6, M_PI);

  c.validate();  // cross-field checks; the names are the parameter names
  return c;
}

}  // namespace ekf_slam
