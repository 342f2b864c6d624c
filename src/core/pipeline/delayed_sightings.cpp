#include "ekf_slam/core/pipeline/delayed_sightings.h"

#include <algorithm>

namespace ekf_slam {

bool DelayedSightings::enabled() const {
  return config_.delayed_sightings && config_.filter == "ekf" && config_.mode == "slam";
}

bool DelayedSightings::admit(ScanReport* report) {
  const AssociationResult& a = report->association;
  batch_.clear();
  admitted_.clear();
  report->delayed_sightings.clear();
  for (std::size_t i = 0; i < a.decision.size(); ++i) {
    const bool joins = a.decision[i] == Decision::kNew || a.decision[i] == Decision::kPaired;
    if (!joins || i >= a.feature.size() || a.feature[i] == kNoFeature) continue;
    const auto it = features_.find(a.feature[i]);
    if (it == features_.end()) continue;
    admitted_.push_back(it->first);
    // Not initialised, or removed in this scan: nothing to apply.
    if (a.landmark[i] == kNoLandmark || !filter_.ekf().contains(a.landmark[i])) continue;
    for (const Kept& k : it->second) {
      batch_.push_back(Pairing{a.landmark[i], k.z, k.R, k.kind, k.clone});
      report->delayed_sightings.push_back({k.scan, k.observation, a.landmark[i]});
    }
  }
  bool applied = false;
  if (!batch_.empty()) {
    report->delayed_nis_dof = 2 * static_cast<int>(batch_.size());
    applied = filter_.update(batch_, model_, &report->delayed_nis);
    if (applied) {
      counters_.delayed_sightings += batch_.size();
    } else {
      // The landmarks stay as their last sighting made them.
      ++counters_.rejected_delayed_updates;
      report->delayed_sightings.clear();
      report->delayed_nis = 0.0;
    }
  }
  // Their clones go only now: the batch needed them.
  for (const FeatureKey f : admitted_) {
    const auto it = features_.find(f);
    release(&it->second);
    features_.erase(it);
  }
  return applied;
}

void DelayedSightings::keep(const ScanReport& report) {
  const AssociationResult& a = report.association;
  CloneId clone = kNoClone;
  for (std::size_t i = 0; i < a.decision.size() && i < a.feature.size(); ++i) {
    if (a.decision[i] != Decision::kTentative || a.feature[i] == kNoFeature) continue;
    if (clone == kNoClone) clone = filter_.ekf().addClone(report.stamp);
    const Observation& o = report.observations[i];
    features_[a.feature[i]].push_back({clone, report.scan, static_cast<int>(i), o.z, o.R, o.kind});
    ++uses_[clone];
  }
  for (const FeatureKey f : a.ended_features) {
    const auto it = features_.find(f);
    if (it == features_.end()) continue;
    release(&it->second);
    features_.erase(it);
  }
  while (filter_.ekf().numClones() > static_cast<std::size_t>(config_.max_pose_clones))
    dropOldestClone();
}

void DelayedSightings::release(std::vector<Kept>* sightings) {
  for (const Kept& k : *sightings) {
    const auto it = uses_.find(k.clone);
    if (it == uses_.end() || --it->second > 0) continue;
    uses_.erase(it);
    filter_.ekf().removeClone(k.clone);
  }
  sightings->clear();
}

void DelayedSightings::dropOldestClone() {
  const CloneId oldest = filter_.ekf().cloneIds().front();
  for (auto it = features_.begin(); it != features_.end();) {
    std::vector<Kept>& v = it->second;
    const std::size_t before = v.size();
    v.erase(std::remove_if(v.begin(), v.end(), [&](const Kept& k) { return k.clone == oldest; }),
            v.end());
    counters_.dropped_sightings += before - v.size();
    it = v.empty() ? features_.erase(it) : std::next(it);
  }
  uses_.erase(oldest);
  filter_.ekf().removeClone(oldest);
}

void DelayedSightings::clear() {
  filter_.ekf().removeAllClones();
  features_.clear();
  uses_.clear();
}

}  // namespace ekf_slam
