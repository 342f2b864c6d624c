#include "ekf_slam/core/pipeline/map_updater.h"

#include <chrono>

#include "ekf_slam/core/common/stopwatch.h"

namespace ekf_slam {

void MapUpdater::associate(DataAssociation& associator, double stamp, ScanReport* report,
                           const ScanOcclusion* occlusion) {
  EkfSlam& ekf = filter_.ekf();
  index_.sync(ekf);
  // filter cekf: the associators read only the active area's entries, so a landmark outside
  // it within their reach brings everything up to date first (docs/cekf.md).
  if (filter_.prepare(index_, model_.sensorPose(ekf.pose()).head<2>(),
                      config_.max_observation_range + config_.cekf_margin))
    index_.sync(ekf);
  const auto t0 = std::chrono::steady_clock::now();
  {
    const AssociationContext context(ekf, model_, index_, report->observations, stamp, occlusion);
    report->association = associator.associate(context);
  }
  report->association_s = secondsSince(t0);
  report->invalid_decisions = sanitise(report->observations.size(), &report->association);
  if (report->invalid_decisions > 0) ++counters_.invalid_associations;
}

int MapUpdater::sanitise(std::size_t n, AssociationResult* r) const {
  const EkfSlam& ekf = filter_.ekf();
  int fixes = 0;
  if (r->decision.size() != n || r->landmark.size() != n) {
    r->resize(n);  // unusable: everything rejected, nothing removed
    return static_cast<int>(n) + 1;
  }
  // Feature keys are optional: without them nothing is kept back.
  if (r->feature.size() != n) r->feature.assign(n, kNoFeature);
  for (std::size_t i = 0; i < n; ++i) {
    switch (r->decision[i]) {
      case Decision::kPaired:
        if (!ekf.contains(r->landmark[i])) {
          r->decision[i] = Decision::kRejected;
          r->landmark[i] = kNoLandmark;
          ++fixes;
        }
        break;
      case Decision::kNew:
      case Decision::kTentative:
      case Decision::kRejected:
        r->landmark[i] = kNoLandmark;
        break;
      default:  // not a Decision at all
        r->decision[i] = Decision::kRejected;
        r->landmark[i] = kNoLandmark;
        ++fixes;
    }
  }
  std::size_t kept = 0;
  for (std::size_t k = 0; k < r->remove.size(); ++k) {
    const LandmarkId id = r->remove[k];
    bool duplicate = false;
    for (std::size_t j = 0; j < kept; ++j) duplicate = duplicate || r->remove[j] == id;
    if (!ekf.contains(id) || duplicate) {
      ++fixes;
      continue;
    }
    r->remove[kept++] = id;
  }
  r->remove.resize(kept);
  return fixes;
}

void MapUpdater::apply(DataAssociation& associator, const std::vector<Pairing>& carried,
                       ScanReport* report) {
  const std::vector<Observation>& obs = report->observations;
  const std::size_t n = obs.size();
  AssociationResult& result = report->association;
  if (config_.mode == "localization") {
    // The map is used, not rebuilt: what the associator would add or delete is only counted.
    for (Decision& d : result.decision) {
      if (d != Decision::kNew) continue;
      d = Decision::kRejected;
      ++counters_.frozen_new;
    }
    counters_.frozen_removals += result.remove.size();
    result.remove.clear();
  }
  const auto t0 = std::chrono::steady_clock::now();
  EkfSlam& ekf = filter_.ekf();
  // 1. One batch update with every paired observation (the original measurements).
  pairings_.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (result.decision[i] == Decision::kPaired)
      pairings_.push_back(Pairing{result.landmark[i], obs[i].z, obs[i].R, obs[i].kind});
  }
  pairings_.insert(pairings_.end(), carried.begin(), carried.end());
  report->nis_dof = 2 * static_cast<int>(pairings_.size());
  const Eigen::Vector3d prior = ekf.pose();
  report->update_ok = filter_.update(pairings_, model_, &report->nis);
  counters_.clamped_corrections = ekf.correctionClamps();
  counters_.refused_correction_updates = ekf.correctionRefusals();
  if (!report->update_ok) {
    ++counters_.rejected_updates;
    report->nis = 0.0;
  } else {
    if (!pairings_.empty()) associator.poseCorrected(prior, ekf.pose());
    for (std::size_t i = 0; i < n; ++i) {
      if (result.decision[i] == Decision::kPaired)
        book_.paired(result.landmark[i], obs[i].descriptor);
    }
  }

  // 2. New landmarks, from the updated pose.
  for (std::size_t i = 0; i < n; ++i) {
    if (result.decision[i] != Decision::kNew) continue;
    const LandmarkId id = filter_.addLandmark(obs[i].z, obs[i].R, model_, obs[i].kind);
    if (id == kNoLandmark) {
      ++counters_.failed_initialisations;
      result.decision[i] = Decision::kRejected;
      continue;
    }
    associator.landmarkAdded(static_cast<int>(i), id);
    result.landmark[i] = id;
    book_.created(id, obs[i].descriptor, report->scan);
  }
  // ... and their earlier sightings, against the poses they were taken from.
  if (delayed_.enabled()) {
    const Eigen::Vector3d before = ekf.pose();
    if (delayed_.admit(report)) associator.poseCorrected(before, ekf.pose());
  }

  // 3. Removals.
  for (const LandmarkId id : result.remove) {
    if (filter_.removeLandmark(id)) {
      report->removed.push_back(id);
      book_.erase(id);
    }
  }
  index_.sync(ekf);
  // 4. This scan's sightings of features not admitted yet, against a clone of its pose.
  if (delayed_.enabled()) delayed_.keep(*report);
  report->update_s = secondsSince(t0);
}

void MapUpdater::discard(const std::vector<LandmarkId>& ids, ScanReport* report) {
  for (const LandmarkId id : ids) {
    if (filter_.removeLandmark(id)) {
      book_.erase(id);
      report->removed.push_back(id);
      ++counters_.discarded_landmarks;
    }
  }
  index_.sync(filter_.ekf());
}

}  // namespace ekf_slam
