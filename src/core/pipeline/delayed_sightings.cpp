#include "ekf_slam/core/pipeline/delayed_sightings.h"

#include <algorithm>

#include <Eigen/Cholesky>

#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {

bool DelayedSightings::enabled() const {
  return config_.delayed_sightings && config_.filter == "ekf" && config_.mode == "slam";
}

bool DelayedSightings::admit(ScanReport* report) {
  const AssociationResult& a = report->association;
  batch_.clear();
  admitted_.clear();
  joined_.clear();
  report->delayed_sightings.clear();
  report->delayed_nis = 0.0;
  report->delayed_nis_dof = 0;
  for (std::size_t i = 0; i < a.decision.size(); ++i) {
    const bool joins = a.decision[i] == Decision::kNew || a.decision[i] == Decision::kPaired;
    if (!joins || i >= a.feature.size() || a.feature[i] == kNoFeature) continue;
    const auto it = features_.find(a.feature[i]);
    if (it == features_.end()) continue;
    admitted_.push_back(it->first);
    // Not initialised, or removed in this scan: nothing to apply.
    if (a.landmark[i] == kNoLandmark || !filter_.ekf().contains(a.landmark[i])) continue;
    joined_.emplace_back(it->first, a.landmark[i]);
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
      report->delayed_nis_dof = 0;
    }
  }
  applied = applyEarlierRuns(report) || applied;
  // Their clones go only now: the batches needed them.
  for (const FeatureKey f : admitted_) end(f);
  return applied;
}

bool DelayedSightings::applyEarlierRuns(ScanReport* report) {
  batch_.clear();
  std::vector<DelayedSighting> reported;
  const double gate = chi2Quantile(config_.restarted_sighting_probability, 2);
  for (const auto& [f, id] : joined_) {
    const auto it = earlier_.find(f);
    if (it == earlier_.end()) continue;
    // Gated against the landmark its own run made: a mover's earlier track lies off it.
    for (const Kept& k : it->second) {
      const Pairing p{id, k.z, k.R, k.kind, k.clone};
      Eigen::Vector2d v;
      Eigen::Matrix2d S;
      if (!filter_.ekf().innovation(p, model_, &v, &S)) continue;
      const Eigen::LLT<Eigen::Matrix2d> llt(S);
      if (llt.info() != Eigen::Success || v.dot(llt.solve(v)) > gate) continue;
      batch_.push_back(p);
      reported.push_back({k.scan, k.observation, id});
    }
  }
  if (batch_.empty()) return false;
  double nis = 0.0;
  if (!filter_.update(batch_, model_, &nis)) {
    ++counters_.rejected_delayed_updates;
    return false;
  }
  counters_.delayed_sightings += batch_.size();
  counters_.restarted_sightings += batch_.size();
  report->delayed_nis += nis;
  report->delayed_nis_dof += 2 * static_cast<int>(batch_.size());
  report->delayed_sightings.insert(report->delayed_sightings.end(), reported.begin(),
                                   reported.end());
  return true;
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
  // A restarted run's sightings, and its own earlier runs', wait beside the new run.
  for (const auto& [earlier, run] : a.restarted_features) {
    std::vector<Kept>& aside = earlier_[run];
    for (auto* from : {&features_, &earlier_}) {
      const auto it = from->find(earlier);
      if (it == from->end()) continue;
      aside.insert(aside.end(), it->second.begin(), it->second.end());
      from->erase(it);
    }
    if (aside.empty()) earlier_.erase(run);
  }
  for (const FeatureKey f : a.ended_features) end(f);
  if (config_.release_out_of_reach) {
    // Only a feature seen once: most likely clutter or a passer-by (a landmark in view is seen
    // again in the scans that follow). One seen more often is probably a landmark the vehicle
    // will come back to, and its sightings are worth their clones.
    for (const FeatureKey f : a.out_of_reach_features) {
      std::size_t kept = 0;
      for (auto* from : {&features_, &earlier_}) {
        const auto it = from->find(f);
        if (it != from->end()) kept += it->second.size();
      }
      if (kept != 1) continue;
      counters_.out_of_reach_sightings += kept;
      end(f);
    }
  }
  while (filter_.ekf().numClones() > static_cast<std::size_t>(config_.max_pose_clones))
    dropOldestClone();
}

void DelayedSightings::end(FeatureKey f) {
  for (auto* from : {&features_, &earlier_}) {
    const auto it = from->find(f);
    if (it == from->end()) continue;
    release(&it->second);
    from->erase(it);
  }
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
  for (auto* from : {&features_, &earlier_}) {
    for (auto it = from->begin(); it != from->end();) {
      std::vector<Kept>& v = it->second;
      const std::size_t before = v.size();
      v.erase(std::remove_if(v.begin(), v.end(), [&](const Kept& k) { return k.clone == oldest; }),
              v.end());
      counters_.dropped_sightings += before - v.size();
      it = v.empty() ? from->erase(it) : std::next(it);
    }
  }
  uses_.erase(oldest);
  filter_.ekf().removeClone(oldest);
}

void DelayedSightings::clear() {
  filter_.ekf().removeAllClones();
  features_.clear();
  earlier_.clear();
  uses_.clear();
}

}  // namespace ekf_slam
