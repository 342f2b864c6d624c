#include "ekf_slam/ros/offline/offline_report.h"

#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <numeric>
#include <vector>

#include <ros/package.h>
#include <nlohmann/json.hpp>

#include "ekf_slam/app/output_files.h"
#include "ekf_slam/core/common/stopwatch.h"
#include "ekf_slam/evaluation/scoring/trajectory_metrics.h"

namespace ekf_slam {

namespace {

using Clock = std::chrono::steady_clock;

// --- statistics ----------------------------------------------------------------------------------

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// JSON has no NaN: unknown numbers become null.
nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

// --- output --------------------------------------------------------------------------------------

std::string plotScript() {
  const std::string pkg = ros::package::getPath("ekf_slam");
  if (!pkg.empty()) return pkg + "/scripts/plot_map.py";
  return std::string(EKF_SLAM_SOURCE_DIR) + "/scripts/plot_map.py";
}

std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (const char ch : s) out += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
  return out + "'";
}

// --- smoothing (--smooth) ------------------------------------------------------------------------

// Smooths the run and writes trajectory_smoothed.csv and map_smoothed.txt; returns metrics.json's
// "smoothing" object (with the smoothed trajectory's GPS error when the bag has GPS, and its
// error against the true poses beside the filter's, the same way, when it has them).
nlohmann::json writeSmoothed(const std::string& dir, const SlamPipeline& pipeline,
                             const SmoothingRecorder& recorder,
                             const std::vector<StampedPoint>& gps,
                             const std::vector<std::pair<double, Eigen::Vector3d>>& truth,
                             std::ostream& log) {
  const SmoothingResult r = recorder.smooth(pipeline);
  const std::vector<SmoothingScan>& scans = recorder.scans();    // their poses: the filter's
  const std::vector<MapLandmark> map = pipeline.mapLandmarks();  // the result's first landmarks
  if (!r.ok) {
    log << "warning: --smooth: " << r.error << "; no smoothed outputs\n";
    return {{"ok", false}, {"error", r.error}};
  }
  std::ofstream traj = openOutput(dir + "/trajectory_smoothed.csv");
  traj.precision(17);
  traj << "stamp,x,y,yaw\n";
  std::vector<StampedPoint> track;
  for (std::size_t i = 0; i < r.poses.size(); ++i) {
    const Eigen::Vector3d& p = r.poses[i];
    traj << stampText(scans[i].stamp) << ',' << p.x() << ',' << p.y() << ',' << p.z() << '\n';
    track.push_back({scans[i].stamp, pipeline.observationModel().sensorPose(p).head<2>()});
  }
  std::vector<MapLandmark> smoothed = map;
  for (std::size_t k = 0; k < smoothed.size(); ++k) {
    smoothed[k].position = r.landmarks[k].position;
    // A landmark nothing observed keeps the filter's covariance with its estimate.
    if (r.landmark_covariances[k].allFinite()) smoothed[k].covariance = r.landmark_covariances[k];
  }
  pipeline.saveMap(dir + "/map_smoothed.txt", smoothed);
  double moved = 0.0;
  for (std::size_t k = 0; k < map.size(); ++k)
    moved = std::max(moved, (smoothed[k].position - map[k].position).norm());
  nlohmann::json j = {{"ok", true},
                      {"converged", r.converged},
                      {"iterations", r.iterations},
                      {"initial_cost", r.initial_cost},
                      {"final_cost", r.final_cost},
                      {"degrees_of_freedom", r.degrees_of_freedom},
                      {"cost_per_dof", number(r.final_cost / r.degrees_of_freedom)},
                      {"observation_cost_per_residual", r.observation_cost_per_residual},
                      {"odometry_cost_per_residual", r.odometry_cost_per_residual},
                      {"observations", r.observations},
                      {"dropped_observations", r.dropped_observations},
                      {"removed_landmarks", r.landmarks.size() - map.size()},
                      {"largest_landmark_move_m", moved},
                      {"seconds", r.seconds}};
  if (!gps.empty()) {
    const TrajectoryError e = compareTrajectories(track, gps);
    j["gps_rmse_m"] = number(e.rmse_aligned);
    j["gps_median_error_m"] = number(e.median_aligned);
    j["gps_p95_error_m"] = number(e.p95_aligned);
    j["gps_alignment"] = {{"yaw", e.alignment.yaw},
                          {"x", e.alignment.translation.x()},
                          {"y", e.alignment.translation.y()}};
  }
  if (!truth.empty()) {
    // base_link positions, smoothed and as the filter wrote them, against the true ones.
    std::vector<StampedPoint> reference, smoothed_base, filter_base;
    for (const auto& [t, p] : truth) reference.push_back({t, p.head<2>()});
    for (std::size_t i = 0; i < r.poses.size(); ++i) {
      smoothed_base.push_back({scans[i].stamp, r.poses[i].head<2>()});
      filter_base.push_back({scans[i].stamp, scans[i].pose.head<2>()});
    }
    const TrajectoryError es = compareTrajectories(smoothed_base, reference);
    const TrajectoryError ef = compareTrajectories(filter_base, reference);
    j["truth_ate_aligned_m"] = number(es.rmse_aligned);
    j["truth_rmse_unaligned_m"] = number(es.rmse_unaligned);
    j["truth_ate_aligned_filter_m"] = number(ef.rmse_aligned);
    j["truth_rmse_unaligned_filter_m"] = number(ef.rmse_unaligned);
  }
  log << "smoothed in " << r.seconds << " s (" << r.iterations << " iterations, cost per dof "
      << r.final_cost / r.degrees_of_freedom << ")\n";
  return j;
}

}  // namespace

OfflineSummary writeOfflineReport(const OfflineOptions& o, const BagContents& bag,
                                  const RunRecord& record, const SlamPipeline& pipeline,
                                  const LoopStats& loop, std::ostream& log) {
  const auto t_write = Clock::now();
  const std::vector<PoseRow>& poses = record.poses;
  const bool truth_column = bag.has_truth_ids || record.score_scans;
  {
    std::ofstream traj = openOutput(o.out_dir + "/trajectory.csv");
    traj.precision(17);  // doubles round-trip: runs can be compared to rounding (bench_cekf.sh)
    // Odometry correction states (AEKF), when configured: estimate and std dev columns.
    const std::vector<std::string> names = pipeline.odometryCorrection().names();
    traj << "stamp,x,y,yaw,var_x,var_y,var_yaw";
    for (const std::string& n : names) traj << ',' << n << ',' << n << "_sd";
    traj << '\n';
    for (const PoseRow& p : poses) {
      traj << stampText(p.stamp) << ',' << p.pose.x() << ',' << p.pose.y() << ',' << p.pose.z()
           << ',' << p.variance.x() << ',' << p.variance.y() << ',' << p.variance.z();
      for (std::size_t i = 0; i < names.size(); ++i)
        traj << ',' << p.correction(i) << ',' << p.correction_sd(i);
      traj << '\n';
    }
    std::ofstream assoc = openOutput(o.out_dir + "/associations.csv");
    assoc << "scan,stamp,obs,range,bearing,diameter,decision,landmark_id"
          << (truth_column ? ",truth_id" : "") << "\n";
    for (const AssociationRow& a : record.rows) {
      assoc << a.scan << ',' << stampText(a.stamp) << ',';
      if (a.removal) {
        assoc << ",,,,removed," << a.landmark << (truth_column ? "," : "") << '\n';
        continue;
      }
      assoc << a.obs << ',' << a.range << ',' << a.bearing << ',' << a.diameter << ','
            << toString(a.decision) << ',' << a.landmark;
      if (truth_column) assoc << ',' << a.truth_id;
      assoc << '\n';
    }
  }
  if (o.landmark_trace) {
    std::ofstream lt = openOutput(o.out_dir + "/landmark_trace.csv");
    lt.precision(10);
    lt << "scan,stamp,id,x,y,var_x,cov_xy,var_y\n";
    for (const LandmarkTraceRow& t : record.trace) {
      lt << t.scan << ',' << stampText(t.stamp) << ',' << t.id << ',' << t.mean.x() << ','
         << t.mean.y() << ',' << t.cov(0) << ',' << t.cov(1) << ',' << t.cov(2) << '\n';
    }
  }
  if (o.dump_problem_scan && !loop.problem_dumped) {
    throw std::runtime_error("--dump-problem " + std::to_string(*o.dump_problem_scan) +
                             ": the run has only " + std::to_string(record.scans) + " scans");
  }

  // --- landmarks -------------------------------------------------------------------------------
  const EkfSlam& ekf = pipeline.ekf();
  {
    std::ofstream lm = openOutput(o.out_dir + "/landmarks.csv");
    lm.precision(17);
    lm << "id,x,y,var_x,cov_xy,var_y,diameter,times_observed\n";
    for (std::size_t k = 0; k < ekf.numLandmarks(); ++k) {
      const LandmarkId id = ekf.landmarkIds()[k];
      const Eigen::Vector2d m = ekf.landmark(static_cast<int>(k));
      const Eigen::Matrix2d P = ekf.landmarkCovariance(static_cast<int>(k));
      const LandmarkInfo& info = pipeline.landmarkInfo(id);
      lm << id << ',' << m.x() << ',' << m.y() << ',' << P(0, 0) << ',' << P(0, 1) << ',' << P(1, 1)
         << ',' << info.diameter << ',' << info.times_observed << '\n';
    }
  }

  // The update's shapes (N, d) and their counts: bench_rank_update --replay times the run's rank
  // downdates alone, the floor of docs/benchmarks_vp.md at the run's exact sizes.
  {
    std::ofstream sh = openOutput(o.out_dir + "/update_shapes.csv");
    sh << "n,d,updates\n";
    for (const auto& [shape, count] : ekf.updateStats().shapes)
      sh << shape.first << ',' << shape.second << ',' << count << '\n';
  }

  // The final map in the ~save_map format, so that runs chain (--load-map).
  pipeline.saveMap(o.out_dir + "/map.txt");

  // --- ground truth (simulated bags), for the picture ------------------------------------------
  if (!bag.ground_truth.empty()) {
    std::ofstream g = openOutput(o.out_dir + "/ground_truth.csv");
    g << "stamp,x,y,yaw\n";
    for (const auto& [t, p] : bag.ground_truth)
      g << stampText(t) << ',' << p.x() << ',' << p.y() << ',' << p.z() << '\n';
  }
  if (!bag.true_map.empty()) {
    std::ofstream g = openOutput(o.out_dir + "/true_landmarks.csv");
    g << "truth_id,x,y\n";
    for (const auto& [id, p] : bag.true_map) g << id << ',' << p.x() << ',' << p.y() << '\n';
  }

  // --- GPS -------------------------------------------------------------------------------------
  TrajectoryError gps_error, gps_clean_error, gps_online_error;
  std::vector<bool> gps_faulty;
  if (!bag.gps.empty()) {
    gps_error = compareTrajectories(record.laser_track, bag.gps);
    gps_online_error =
        pipeline.counters().lost_path_poses + pipeline.counters().rederived_tracked_poses > 0
            ? compareTrajectories(record.online_track, bag.gps)
            : gps_error;
    // The same without the fixes the GPS track itself shows faulty (judged from the GPS and the
    // odometry only: trajectory_metrics.h, faultyGpsFixes).
    std::vector<StampedPoint> gps = bag.gps;
    std::vector<StampedSpeed> speeds;
    speeds.reserve(bag.odometry.size());
    for (const OdometryInput& od : bag.odometry) speeds.push_back({od.stamp, od.twist(0)});
    std::sort(gps.begin(), gps.end(),
              [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
    std::sort(speeds.begin(), speeds.end(),
              [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
    gps_faulty = faultyGpsFixes(gps, speeds);
    std::vector<StampedPoint> clean;
    for (std::size_t i = 0; i < gps.size(); ++i)
      if (!gps_faulty[i]) clean.push_back(gps[i]);
    gps_clean_error = compareTrajectories(record.laser_track, clean);
    // The fixes also in the map frame (inverse alignment), so the picture overlays them.
    const Eigen::Matrix2d Rt = gps_error.alignment.rotation().transpose();
    std::ofstream g = openOutput(o.out_dir + "/gps.csv");
    g << "stamp,x,y,x_map,y_map,faulty\n";
    for (std::size_t i = 0; i < gps.size(); ++i) {
      const StampedPoint& f = gps[i];
      const Eigen::Vector2d m = Rt * (f.position - gps_error.alignment.translation);
      g << stampText(f.stamp) << ',' << f.position.x() << ',' << f.position.y() << ',' << m.x()
        << ',' << m.y() << ',' << (gps_faulty[i] ? 1 : 0) << '\n';
    }
  }

  // --- metrics ---------------------------------------------------------------------------------
  const PipelineCounters& k = pipeline.counters();
  nlohmann::json j;
  j["associator"] = loop.associator;
  j["bag"] = o.bag_path;
  j["params"] = o.params_path;
  j["scans"] = record.scans;
  j["odometry_messages"] = bag.odometry.size();
  j["landmarks"] = ekf.numLandmarks();
  j["wall_time_s"] = loop.wall_time_s;
  j["loop_cpu_s"] = loop.loop_cpu_s;
  j["bag_read_s"] = loop.bag_read_s;
  j["extraction_time_s"] = record.extraction_s;
  j["association_time_s"] = record.association_s;
  j["update_time_s"] = record.update_s;
  j["association_us_median"] = number(quantile(record.association_us, 0.5));
  j["association_us_p99"] = number(quantile(record.association_us, 0.99));
  j["update_us_median"] = number(quantile(record.update_us, 0.5));
  j["update_us_p99"] = number(quantile(record.update_us, 0.99));
  {
    // The EKF update's arithmetic, for its floor (docs/benchmarks_vp.md, scripts/bench_vp.sh).
    const UpdateStats& u = ekf.updateStats();
    const double w = u.rank_flops > 0.0 ? 1.0 / u.rank_flops : 0.0;
    j["update_flops"] = u.flops;
    j["update_rank_flops"] = u.rank_flops;
    j["update_rank_n"] = u.weighted_n * w;  // rank-flop-weighted state size N ...
    j["update_rank_d"] = u.weighted_d * w;  // ... and measurement dimension d
  }
  if (const CompressedEkf* c = pipeline.compressedEkf()) {
    // filter cekf (docs/cekf.md): its areas and global updates.
    const CompressedEkfStats& s = c->stats();
    j["cekf"] = {{"areas", s.phases},
                 {"compressed_areas", s.compressed_phases},
                 {"global_updates", s.global_updates},
                 {"closed_grown", s.grown},
                 {"closed_landmark_in_reach", s.landmark_in_reach},
                 {"closed_pairing_outside", s.pairing_outside},
                 {"closed_flush", s.flushes},
                 {"global_update_s", s.global_update_s},
                 {"global_update_flops", s.global_update_flops},
                 {"active_update_flops", c->activeUpdateFlops()},
                 {"max_active_states", s.max_active_states}};
  }
  j["sensor_offset"] = {loop.sensor_offset.x(), loop.sensor_offset.y(), loop.sensor_offset.z()};
  const Eigen::Vector3d final_pose = ekf.pose();
  j["final_pose"] = {final_pose.x(), final_pose.y(), final_pose.z()};
  {
    // Final odometry correction estimates and std devs, by name (empty for mode none).
    nlohmann::json c = {{"mode", pipeline.odometryCorrection().params().mode}};
    const std::vector<std::string> names = pipeline.odometryCorrection().names();
    const Eigen::Vector2d sd = ekf.correctionCovariance().diagonal().cwiseSqrt();
    for (std::size_t i = 0; i < names.size(); ++i) {
      c[names[i]] = number(ekf.correction()(i));
      c[names[i] + "_sd"] = number(sd(i));
    }
    j["odometry_correction"] = c;
  }
  if (!bag.gps.empty()) {
    j["gps_rmse_m"] = number(gps_error.rmse_aligned);
    j["gps_rmse_online_m"] = number(gps_online_error.rmse_aligned);  // lost path not re-derived
    j["gps_rmse_clean_m"] = number(gps_clean_error.rmse_aligned);
    j["gps_faulty_fixes"] = std::count(gps_faulty.begin(), gps_faulty.end(), true);
    j["gps_median_error_clean_m"] = number(gps_clean_error.median_aligned);
    j["gps_p95_error_clean_m"] = number(gps_clean_error.p95_aligned);
    j["gps_rmse_unaligned_m"] = number(gps_error.rmse_unaligned);
    j["gps_max_error_m"] = number(gps_error.max_aligned);
    j["gps_median_error_m"] = number(gps_error.median_aligned);
    j["gps_p95_error_m"] = number(gps_error.p95_aligned);
    j["gps_points"] = gps_error.points;
    j["gps_fixes"] = bag.gps.size();
    j["gps_alignment"] = {{"yaw", gps_error.alignment.yaw},
                          {"x", gps_error.alignment.translation.x()},
                          {"y", gps_error.alignment.translation.y()}};
  }
  j["counters"] = {{"odometry", k.odometry},
                   {"scans", k.scans},
                   {"odometry_gaps", k.odometry_gaps},
                   {"rejected_odometry", k.rejected_odometry},
                   {"rejected_updates", k.rejected_updates},
                   {"invalid_ranges", k.invalid_ranges},
                   {"scans_before_odometry", k.scans_before_odometry},
                   {"late_odometry", k.late_odometry},
                   {"late_scans", k.late_scans},
                   {"empty_scans", k.empty_scans},
                   {"invalid_observations", k.invalid_observations},
                   {"invalid_associations", k.invalid_associations},
                   {"failed_initialisations", k.failed_initialisations},
                   {"clamped_corrections", k.clamped_corrections},
                   {"refused_correction_updates", k.refused_correction_updates},
                   {"sequencer_late_odometry", loop.sequencer.late_odometry},
                   {"sequencer_late_scans", loop.sequencer.late_scans},
                   {"released_by_latency", loop.sequencer.released_by_latency},
                   {"invalid_stamps", loop.invalid_stamps},
                   {"zero_stamps", loop.zero_stamps},
                   {"skipped_no_tf", loop.skipped_no_tf},
                   {"inconsistent_scans", k.inconsistent_scans},
                   {"duplicate_scans", k.duplicate_scans},
                   {"implausible_odometry", k.implausible_odometry},
                   {"invalid_orientations", k.invalid_orientations},
                   {"held_stamps", loop.sequencer.held},
                   {"dropped_out_of_range", loop.sequencer.dropped_out_of_range},
                   {"time_jumps", loop.time_jumps},
                   {"lost_events", k.lost_events},
                   {"relocalisation_requests", k.relocalisation_requests},
                   {"relocalisation_attempts", k.relocalisation_attempts},
                   {"probes", k.probes},
                   {"lost_timeouts", k.lost_timeouts},
                   {"relocalisations", k.relocalisations},
                   {"relocalisations_ambiguous", k.relocalisations_ambiguous},
                   {"relocalisations_not_found", k.relocalisations_not_found},
                   {"relocalisations_unconfirmed", k.relocalisations_unconfirmed},
                   {"lost_path_poses", k.lost_path_poses},
                   {"rederived_tracked_poses", k.rederived_tracked_poses},
                   {"discarded_landmarks", k.discarded_landmarks},
                   {"suppressed_new", k.suppressed_new},
                   {"frozen_new", k.frozen_new},
                   {"frozen_removals", k.frozen_removals},
                   {"resets", k.resets},
                   {"delayed_sightings", k.delayed_sightings},
                   {"rejected_delayed_updates", k.rejected_delayed_updates},
                   {"dropped_sightings", k.dropped_sightings},
                   {"out_of_reach_sightings", k.out_of_reach_sightings},
                   {"lost_map_removed", k.lost_map_removed},
                   {"onset_rollbacks", k.onset_rollbacks}};
  j["relocaliser"] = loop.relocaliser;
  j["lost_at_end"] = pipeline.lost();
  j["relocalisation_us_median"] = number(quantile(record.relocalisation_us, 0.5));
  // The whole cost of recovery, probes included (docs/notes/2026-11-to-12-relocalisation-record.md,
  // "Victoria Park with --kidnap").
  j["relocalisation_time_s"] =
      1e-6 * std::accumulate(record.relocalisation_us.begin(), record.relocalisation_us.end(), 0.0);
  nlohmann::json events = nlohmann::json::array();
  for (const RelocalisationEvent& e : record.relocalisations) {
    events.push_back({{"scan", e.scan},
                      {"stamp", e.stamp},
                      {"pose", {e.pose.x(), e.pose.y(), e.pose.z()}},
                      {"pairings", e.pairings},
                      {"joint_mahalanobis", number(e.joint_mahalanobis)},
                      {"nodes", e.nodes},
                      {"time_us", e.time_us}});
  }
  j["relocalisation_events"] = events;
  // Each lost event (only when there was one: a run that never gets lost writes what it did
  // without recovery, docs/relocalisation.md).
  if (!record.lost_events.empty()) {
    nlohmann::json lost = nlohmann::json::array();
    for (const LostEvent& e : record.lost_events) {
      lost.push_back({{"scan", e.scan},
                      {"stamp", e.stamp},
                      {"reason", e.reason},
                      {"end", e.end},
                      {"end_scan", e.end_scan},
                      {"end_stamp", e.end_stamp},
                      {"scans_lost", e.scans_lost},
                      {"correction_m", number(e.correction.head<2>().norm())},
                      {"correction_rad", number(e.correction.z())},
                      {"pairings", e.pairings}});
      if (e.onset_scan >= 0) {
        lost.back()["onset_scan"] = e.onset_scan;
        lost.back()["rolled_back_to"] = e.rolled_back_to;
      }
    }
    j["lost_event_list"] = lost;
  }
  if (o.smooth)
    j["smoothing"] =
        writeSmoothed(o.out_dir, pipeline, record.smoothing, bag.gps, bag.ground_truth, log);
  if (record.score) {
    const RunMetrics m = record.scorer->metrics(&pipeline);
    const double created_per_true =
        m.map.true_landmarks_seen > 0
            ? static_cast<double>(m.map.landmarks_created) / m.map.true_landmarks_seen
            : std::nan("");
    j["truth"] = {{"accuracy", m.counts.accuracy()},
                  {"precision", m.counts.precision()},
                  {"recall", m.counts.recall()},
                  {"f1", m.counts.f1()},
                  {"tp", m.counts.tp},
                  {"fp", m.counts.fp},
                  {"fn", m.counts.fn},
                  {"tn", m.counts.tn},
                  {"scored_scans", m.scans},
                  {"landmarks", m.map.landmarks},
                  {"true_landmarks_seen", m.map.true_landmarks_seen},
                  {"true_landmarks_mapped", m.map.true_landmarks_mapped},
                  {"spurious_landmarks", m.map.spurious},
                  {"non_landmarks", m.map.non_landmarks},
                  {"duplicates", m.map.duplicates},
                  {"unknown_pairings", m.unknown_pairings},
                  {"landmarks_created", m.map.landmarks_created},
                  {"landmarks_created_per_true_landmark", number(created_per_true)},
                  {"true_landmarks_findable", m.map.true_landmarks_findable},
                  {"true_landmarks_found", m.map.true_landmarks_found},
                  {"landmark_precision", m.map.landmark_precision},
                  {"landmark_recall", m.map.landmark_recall},
                  {"pairing_coverage", m.map.pairing_coverage},
                  {"sightings_used", m.map.sightings_used},
                  {"pose_rmse_m", number(m.pose_rmse_m)},
                  {"heading_rmse_rad", number(m.heading_rmse_rad)},
                  {"pose_ate_aligned_m", number(m.pose_ate_aligned_m)},
                  {"heading_rmse_aligned_rad", number(m.heading_rmse_aligned_rad)},
                  {"map_rmse_aligned_m", number(m.map_rmse_aligned_m)},
                  {"map_rmse_landmarks", m.map_rmse_landmarks},
                  {"anees", number(m.anees)},
                  {"nees_scans", m.nees_scans},
                  {"association_us_mean", number(m.association_us_mean)},
                  {"ground_truth_poses", bag.ground_truth.size()}};
  }
  j["write_s"] = secondsSince(t_write);  // CSV files and this file, not the picture
  const std::string text = j.dump(2) + "\n";
  openOutput(o.out_dir + "/metrics.json") << text;

  // Nothing is dropped silently: every input that needed handling is reported.
  const std::uint64_t late = k.late_odometry + k.late_scans;
  const std::uint64_t out_of_range = loop.sequencer.dropped_out_of_range;
  if (k.rejected_odometry || k.rejected_updates || late || k.odometry_gaps || loop.invalid_stamps ||
      k.invalid_observations || k.invalid_associations || k.failed_initialisations ||
      out_of_range || k.invalid_ranges || k.empty_scans || loop.time_jumps ||
      k.clamped_corrections || loop.zero_stamps || loop.skipped_no_tf || k.inconsistent_scans ||
      k.duplicate_scans || k.implausible_odometry || k.invalid_orientations) {
    log << "warning: " << k.rejected_odometry << " odometry messages rejected (non-finite), "
        << k.implausible_odometry << " rejected (twist beyond max_speed / max_yaw_rate), "
        << k.invalid_orientations << " rejected (no orientation, pose_delta), " << loop.zero_stamps
        << " messages with a zero stamp skipped, " << loop.skipped_no_tf
        << " sensor messages skipped (no transform for their frame), " << k.inconsistent_scans
        << " scans with inconsistent angles (prediction only), " << k.duplicate_scans
        << " duplicate scans dropped, " << loop.invalid_stamps
        << " messages with invalid stamps dropped, " << out_of_range
        << " messages dropped (stamp out of range of the other input), " << loop.time_jumps
        << " time jumps (resets), " << k.empty_scans << " empty scans, " << k.invalid_ranges
        << " invalid ranges, " << k.late_odometry << " late odometry messages skipped, "
        << k.late_scans << " late scans, " << k.odometry_gaps << " odometry gaps, "
        << k.rejected_updates << " EKF updates refused, " << k.invalid_observations
        << " invalid observations, " << k.invalid_associations << " associator results fixed, "
        << k.failed_initialisations << " failed landmark initialisations, " << k.clamped_corrections
        << " odometry corrections clamped to their bounds (metrics.json: counters)\n";
  }

  // --- picture ---------------------------------------------------------------------------------
  if (o.plot) {
    const std::string cmd = "/usr/bin/python3 " + shellQuote(plotScript()) + " " +
                            shellQuote(o.out_dir) + " > /dev/null";
    const int rc = std::system(cmd.c_str());
    if (rc != 0) {
      log << "warning: map.png not written (" << plotScript() << " failed"
          << (WIFEXITED(rc) && WEXITSTATUS(rc) == 3 ? ": python3-matplotlib is missing" : "")
          << ")\n";
    }
  }

  OfflineSummary s;
  s.associator = loop.associator;
  s.scans = record.scans;
  s.odometry = bag.odometry.size();
  s.landmarks = ekf.numLandmarks();
  s.wall_time_s = loop.wall_time_s;
  s.gps_rmse_m = bag.gps.empty() ? -1.0 : gps_error.rmse_aligned;
  s.relocalisations = k.relocalisations;
  s.metrics_json = text;
  return s;
}

}  // namespace ekf_slam
