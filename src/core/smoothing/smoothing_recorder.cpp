#include "ekf_slam/core/smoothing/smoothing_recorder.h"

#include <algorithm>
#include <unordered_set>

namespace ekf_slam {

void SmoothingRecorder::add(const ScanReport& r, const SlamPipeline& pipeline) {
  SmoothingScan s;
  s.stamp = r.stamp;
  s.pose = pipeline.pose();
  s.pose_covariance = pipeline.poseCovariance();
  s.linked = r.has_motion;
  s.motion = r.motion;
  s.motion_covariance = r.motion_covariance;
  s.motion_translation = r.motion_covariance_translation;
  s.motion_rotation = r.motion_covariance_rotation;
  const RangeBearingModel& model = pipeline.observationModel();
  for (std::size_t i = 0; i < r.observations.size() && i < r.association.decision.size(); ++i) {
    const Decision d = r.association.decision[i];
    if (d != Decision::kPaired && d != Decision::kNew) continue;
    const Observation& ob = r.observations[i];
    const LandmarkId id = r.association.landmark[i];
    s.observations.push_back({id, ob.z, ob.R, ob.kind, ob.default_covariance});
    // The smoother's start for a landmark removed later.
    if (d == Decision::kNew) created_.emplace(id, model.inverse(s.pose, ob.z, ob.kind));
  }
  scans_.push_back(std::move(s));

  std::size_t first = scans_.size();
  applyLostPath(
      r.lost_path, scans_.size() - 1, [this](std::size_t i) { return scans_[i].stamp; },
      [&](std::size_t i, const Eigen::Vector3d& p) {
        scans_[i].pose = p;
        scans_[i].observations.clear();  // lost scans pair nothing; tracked ones pair wrongly
        first = std::min(first, i);
      });
  if (r.relocalised) {
    SmoothingScan& k = scans_[std::min(first, scans_.size() - 1)];
    k.linked = false;
    k.pose_covariance = kUninformative * Eigen::Matrix3d::Identity();
  }
}

std::vector<SmoothingLandmark> SmoothingRecorder::landmarks(const SlamPipeline& pipeline) const {
  // The pairings of a landmark removed later (missed, or made again under a new id) were the
  // filter's evidence too: every landmark of the run is an unknown.
  std::vector<SmoothingLandmark> start;
  std::unordered_set<LandmarkId> in_map;
  for (const MapLandmark& l : pipeline.mapLandmarks()) {
    start.push_back({l.id, l.position});
    in_map.insert(l.id);
  }
  const std::size_t final_landmarks = start.size();
  for (const auto& [id, p] : created_)
    if (in_map.count(id) == 0) start.push_back({id, p});
  // In id order, so that the result does not depend on the hash map's order.
  std::sort(start.begin() + final_landmarks, start.end(),
            [](const SmoothingLandmark& a, const SmoothingLandmark& b) { return a.id < b.id; });
  return start;
}

SmoothingResult SmoothingRecorder::smooth(const SlamPipeline& pipeline,
                                          SmootherParams params) const {
  const std::vector<SmoothingLandmark> start = landmarks(pipeline);
  const int wanted = static_cast<int>(pipeline.mapLandmarks().size());
  if (params.landmark_covariances < 0 || params.landmark_covariances > wanted)
    params.landmark_covariances = wanted;
  return smoothRun(scans_, start, pipeline.observationModel(), params);
}

}  // namespace ekf_slam
