#include "ekf_slam/ros/offline/run_record.h"

#include <cstdio>

#include "ekf_slam/ros/conversions.h"  // kNoTruthId

namespace ekf_slam {

std::string stampText(double stamp) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.9f", stamp);
  return buf;
}

RunRecord::RunRecord(const OfflineOptions& options, const BagContents& bag, std::ostream& log)
    : o_(options), bag_(bag), log_(log), true_map_(bag.true_map.begin(), bag.true_map.end()) {
  const std::size_t n = bag.scans.size() + bag.observation_sets.size();
  association_us.reserve(n);
  update_us.reserve(n);
  laser_track.reserve(n);
  online_track.reserve(n);
  poses.reserve(n);
  rows.reserve(8 * n);
  // Ground-truth scoring (simulated bags): every observation must carry its truth id.
  // A simulated scan bag (simulate --world beacons) has no truth ids: its extracted features get
  // the /true_map landmark they point at from the true sensor pose (truthByProximity, as evaluate
  // scores the same run).
  score_scans = !bag.scans.empty() && bag.observation_sets.empty() && !bag.ground_truth.empty() &&
                !bag.true_map.empty();
  score = score_scans ||
          (bag.has_truth_ids && bag.observations_without_truth == 0 && bag.scans.empty());
  if (bag.has_truth_ids && !score) {
    log << "warning: the bag has truth ids, but " << bag.observations_without_truth
        << " observations lack one" << (bag.scans.empty() ? "" : " and it has laser scans")
        << ": no truth metrics\n";
  }
  restartScoring();
}

void RunRecord::restartScoring() {
  scorer = std::make_unique<RunScorer>();
  scorer->setTrueMap(true_map_);
}

void RunRecord::add(const ScanReport& r, const SlamPipeline& pipeline,
                    const ObservationsInput* input) {
  if (r.became_lost) {
    log_ << "lost at scan " << r.scan << " (stamp " << std::fixed << r.stamp << std::defaultfloat
         << "): " << r.lost_reason << "\n";
    LostEvent e;
    e.scan = r.scan;
    e.stamp = r.stamp;
    e.reason = r.lost_reason;
    lost_events.push_back(e);
  }
  if (r.relocalised || r.lost_timeout) {
    // A run started lost (--unknown-pose) has no lost rule firing: its event opens here.
    if (lost_events.empty() || lost_events.back().end != "lost at end")
      lost_events.push_back({r.scan, r.stamp, "started lost"});
    LostEvent& e = lost_events.back();
    e.end = r.relocalised ? "relocalised" : "timeout";
    e.end_scan = r.scan;
    e.end_stamp = r.stamp;
    e.scans_lost = r.relocalised ? r.lost_scans : r.scan - e.scan;
    e.correction = r.fix_correction;
    e.pairings = r.fix_pairings;
    if (r.onset_rolled_back_from > 0 || r.onset_scan > 0) {
      e.onset_scan = r.onset_scan;
      e.rolled_back_to = r.onset_rolled_back_from;
    }
  }
  if (r.lost && !pipeline.lost() && !r.relocalised)
    log_ << "scan " << r.scan << ": " << r.lost_reason << "\n";
  if (r.relocalisation_attempted) {
    relocalisation_us.push_back(1e6 * r.relocalisation_s);
    if (r.relocalised) {
      const RelocalisationResult& x = r.relocalisation;
      log_ << "relocalised at scan " << r.scan << ": pose " << x.pose.transpose() << ", "
           << x.hypothesis_size << " pairings; correction " << r.fix_correction.head<2>().norm()
           << " m, " << r.fix_correction.z() << " rad, " << r.fix_pairings
           << " pairings in the update; from the lost scans " << r.lost_map_landmarks
           << " landmarks mapped, " << r.lost_map_pairings << " pairings";
      if (r.onset_scan > 0)
        log_ << "; the kidnap began about scan " << r.onset_scan << ": map rolled back to scan "
             << r.onset_rolled_back_from;
      log_ << "\n";
      relocalisations.push_back({r.scan, r.stamp, x.pose, x.hypothesis_size, x.joint_mahalanobis,
                                 x.nodes, 1e6 * r.relocalisation_s});
    }
  }
  extraction_s += r.extraction_s;
  association_s += r.association_s;
  update_s += r.update_s;
  association_us.push_back(1e6 * r.association_s);
  update_us.push_back(1e6 * r.update_s);
  const Eigen::Vector3d x = pipeline.pose();
  const Eigen::Matrix3d P = pipeline.poseCovariance();
  // Pose and correction states only: activeEkf() does not bring a compressed filter up to date.
  const EkfSlam& filter = pipeline.activeEkf();
  poses.push_back({r.stamp, x, P.diagonal(), filter.correction(),
                   filter.correctionCovariance().diagonal().cwiseSqrt()});
  laser_track.push_back({r.stamp, pipeline.observationModel().sensorPose(x).head<2>()});
  online_track.push_back(laser_track.back());
  if (o_.smooth) smoothing.add(r, pipeline);  // applies r's lost path to its own scans
  // Relocalised: the rows of the scans processed while lost, and of those tracked before it
  // that the fix contradicts, take their re-derived poses.
  applyLostPath(
      r.lost_path, poses.size() - 1, [this](std::size_t i) { return poses[i].stamp; },
      [&](std::size_t i, const Eigen::Vector3d& p) {
        poses[i].pose = p;
        laser_track[i].position = pipeline.observationModel().sensorPose(p).head<2>();
      });
  Eigen::Vector3d true_pose;
  const bool have_pose = score && truePoseAt(bag_.ground_truth, r.stamp, &true_pose);
  std::vector<LandmarkId> scan_truth;
  if (score_scans && have_pose) {
    scan_truth = truthByProximity(pipeline.observationModel().sensorPose(true_pose), r.observations,
                                  bag_.true_map, &next_clutter_);
  }
  truth_.clear();
  for (std::size_t i = 0; i < r.observations.size(); ++i) {
    const Observation& ob = r.observations[i];
    const Decision d =
        i < r.association.decision.size() ? r.association.decision[i] : Decision::kRejected;
    const LandmarkId id =
        (d == Decision::kPaired || d == Decision::kNew) ? r.association.landmark[i] : kNoLandmark;
    const std::int64_t truth_id = input && i < r.input_index.size()
                                      ? input->truth_ids[r.input_index[i]]
                                  : i < scan_truth.size() ? scan_truth[i]
                                                          : kNoTruthId;
    truth_.push_back(truth_id);
    rows.push_back({r.scan, static_cast<std::uint32_t>(i), r.stamp, ob.z.x(), ob.z.y(),
                    ob.descriptor, d, id, truth_id});
  }
  // Removals, so that the scores can be recomputed from associations.csv alone.
  for (const LandmarkId id : r.removed)
    rows.push_back({r.scan, 0, r.stamp, 0.0, 0.0, 0.0, Decision::kRejected, id, kNoTruthId, true});
  // A scan without a true pose has no truth for its features either.
  if (score && (!score_scans || have_pose))
    scorer->addScan(r, truth_, x, P, have_pose ? &true_pose : nullptr);
  if (o_.landmark_trace) {
    const EkfSlam& f = pipeline.ekf();
    for (std::size_t k = 0; k < f.numLandmarks(); ++k) {
      const Eigen::Matrix2d C = f.landmarkCovariance(static_cast<int>(k));
      trace.push_back({r.scan, r.stamp, f.landmarkIds()[k], f.landmark(static_cast<int>(k)),
                       Eigen::Vector3d(C(0, 0), C(0, 1), C(1, 1))});
    }
  }
  ++scans;
}

}  // namespace ekf_slam
