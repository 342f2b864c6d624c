// Association scorer and pose metrics (ALGORITHMS.md section 9).
#include "ekf_slam/evaluation/scoring/association_metrics.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>

#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {

const char* toString(Outcome o) {
  switch (o) {
    case Outcome::kTruePositive:
      return "TP";
    case Outcome::kFalsePositive:
      return "FP";
    case Outcome::kFalseNegative:
      return "FN";
    case Outcome::kTrueNegative:
      return "TN";
  }
  return "?";
}

// --- AssociationCounts
// ----------------------------------------------------------------------------

double AssociationCounts::accuracy() const {
  const std::uint64_t n = total();
  return n == 0 ? 1.0 : static_cast<double>(tp + tn) / static_cast<double>(n);
}

double AssociationCounts::precision() const {
  return tp + fp == 0 ? 1.0 : static_cast<double>(tp) / static_cast<double>(tp + fp);
}

double AssociationCounts::recall() const {
  return tp + fn == 0 ? 1.0 : static_cast<double>(tp) / static_cast<double>(tp + fn);
}

double AssociationCounts::f1() const {
  const double p = precision();
  const double r = recall();
  return p + r == 0.0 ? 0.0 : 2.0 * p * r / (p + r);
}

void AssociationCounts::add(Outcome o) {
  switch (o) {
    case Outcome::kTruePositive:
      ++tp;
      break;
    case Outcome::kFalsePositive:
      ++fp;
      break;
    case Outcome::kFalseNegative:
      ++fn;
      break;
    case Outcome::kTrueNegative:
      ++tn;
      break;
  }
}

AssociationCounts& AssociationCounts::operator+=(const AssociationCounts& o) {
  tp += o.tp;
  fp += o.fp;
  fn += o.fn;
  tn += o.tn;
  return *this;
}

// --- AssociationScorer
// ----------------------------------------------------------------------------

AssociationCounts AssociationScorer::addScan(const std::vector<LandmarkId>& truth,
                                             const std::vector<Decision>& decision,
                                             const std::vector<LandmarkId>& landmark,
                                             const std::vector<LandmarkId>& removed,
                                             std::vector<Outcome>* outcomes) {
  if (decision.size() != truth.size() || landmark.size() != truth.size()) {
    throw std::invalid_argument("AssociationScorer::addScan: " + std::to_string(truth.size()) +
                                " truth ids but " + std::to_string(decision.size()) +
                                " decisions and " + std::to_string(landmark.size()) +
                                " landmark ids");
  }
  ++scans_;
  AssociationCounts scan;
  if (outcomes) outcomes->assign(truth.size(), Outcome::kTrueNegative);

  // Judge every observation against the identities as they stood before this scan.
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const LandmarkId t = truth[i];
    TruthTally* tally = t >= 0 ? &seen_[t] : nullptr;
    if (tally) ++tally->observations;
    Outcome o;
    if (decision[i] == Decision::kPaired) {
      const auto it = tracks_.find(landmark[i]);
      if (it == tracks_.end()) {
        ++unknown_pairings_;
        o = Outcome::kFalsePositive;
      } else if (t >= 0 && it->second.identity == t) {
        // The true landmark is represented by its oldest map landmark; a younger duplicate (a
        // second map of the same place, e.g. after a kidnapping) is not the right pairing.
        const bool original = *holders_.at(t).begin() == landmark[i];
        o = original ? Outcome::kTruePositive : Outcome::kFalsePositive;
        duplicate_pairings_ += !original;
      } else {
        o = Outcome::kFalsePositive;
      }
    } else {
      const auto it = holders_.find(t);
      const bool mapped = t >= 0 && it != holders_.end() && !it->second.empty();
      o = mapped ? Outcome::kFalseNegative : Outcome::kTrueNegative;
    }
    scan.add(o);
    if (tally && o == Outcome::kTruePositive) {
      ++tally->true_positives;
      ++tally->used;
    }
    if (outcomes) (*outcomes)[i] = o;
  }

  // Then let the scan's observations vote for the identities of what they created / updated.
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const bool created = decision[i] == Decision::kNew && landmark[i] != kNoLandmark;
    landmarks_created_ += created;
    if (decision[i] == Decision::kPaired || created) vote(landmark[i], truth[i]);
    if (created) countUsed(landmark[i], truth[i]);
  }
  for (LandmarkId id : removed) {
    const auto it = tracks_.find(id);
    if (it == tracks_.end()) continue;
    holders_[it->second.identity].erase(id);
    tracks_.erase(it);
  }
  counts_ += scan;
  return scan;
}

bool AssociationScorer::represents(LandmarkId id, LandmarkId truth) const {
  const auto it = holders_.find(truth);
  return truth >= 0 && it != holders_.end() && !it->second.empty() && *it->second.begin() == id;
}

void AssociationScorer::countUsed(LandmarkId id, LandmarkId truth) {
  if (represents(id, truth)) ++seen_[truth].used;
}

void AssociationScorer::addDelayedSightings(
    const std::vector<std::pair<LandmarkId, LandmarkId>>& landmark_truth) {
  for (const auto& [id, truth] : landmark_truth) countUsed(id, truth);
}

void AssociationScorer::setIdentity(LandmarkId id, Track* t, LandmarkId truth, bool is_new) {
  if (!is_new) {
    holders_[t->identity].erase(id);
    ++identity_switches_;
  }
  t->identity = truth;
  holders_[truth].insert(id);
}

void AssociationScorer::vote(LandmarkId id, LandmarkId truth) {
  auto [it, inserted] = tracks_.try_emplace(id);
  Track& t = it->second;
  if (inserted) {
    t.votes.emplace_back(truth, 1);
    setIdentity(id, &t, truth, true);
    return;
  }
  std::uint32_t mine = 0, leader = 0;
  bool found = false;
  for (auto& v : t.votes) {
    if (v.first == truth) {
      mine = ++v.second;
      found = true;
    }
    if (v.first == t.identity) leader = v.second;
  }
  if (!found) {
    t.votes.emplace_back(truth, 1);
    mine = 1;
  }
  if (truth != t.identity && mine > leader) setIdentity(id, &t, truth, false);  // ties keep it
}

void AssociationScorer::addKnownLandmark(LandmarkId id, LandmarkId truth) {
  const auto it = tracks_.find(id);
  if (it != tracks_.end()) {
    holders_[it->second.identity].erase(id);
    tracks_.erase(it);
  }
  vote(id, truth);
}

void AssociationScorer::reset() { *this = AssociationScorer(); }

bool AssociationScorer::identity(LandmarkId id, LandmarkId* truth) const {
  const auto it = tracks_.find(id);
  if (it == tracks_.end()) return false;
  if (truth) *truth = it->second.identity;
  return true;
}

MapScore AssociationScorer::mapScore() const {
  MapScore s;
  s.landmarks = tracks_.size();
  std::size_t sole_holders = 0;
  s.true_landmarks_seen = seen_.size();
  for (const auto& [truth, ids] : holders_) {
    const std::size_t n = ids.size();
    if (n == 0) continue;
    if (truth >= 0) {
      ++s.true_landmarks_mapped;
      s.duplicates += n - 1;
      sole_holders += n == 1;
    } else {
      s.non_landmarks += n;
    }
  }
  s.spurious = s.non_landmarks + s.duplicates;

  // Landmark level: held exactly once = correct; recall over the landmarks seen often enough
  // to be mapped; coverage over every observation of the landmarks the map holds.
  s.landmarks_created = landmarks_created_;
  std::uint64_t observations = 0, paired = 0, used = 0;
  for (const auto& [truth, tally] : seen_) {
    const auto it = holders_.find(truth);
    const std::size_t n = it == holders_.end() ? 0 : it->second.size();
    if (tally.observations >= kMinObservationsToFind) {
      ++s.true_landmarks_findable;
      s.true_landmarks_found += n == 1;
    }
    if (n > 0) {
      observations += tally.observations;
      paired += tally.true_positives;
      used += tally.used;
    }
  }
  const auto ratio = [](double a, double b) { return b > 0 ? a / b : 1.0; };
  s.landmark_precision = ratio(sole_holders, s.landmarks);
  s.landmark_recall = ratio(s.true_landmarks_found, s.true_landmarks_findable);
  s.pairing_coverage = ratio(paired, observations);
  s.sightings_used = ratio(used, observations);
  return s;
}

// --- pose metrics
// ---------------------------------------------------------------------------------

double poseNees(const Eigen::Vector3d& estimate, const Eigen::Matrix3d& cov,
                const Eigen::Vector3d& truth) {
  Eigen::Vector3d e = estimate - truth;
  e(2) = wrapAngle(e(2));
  if (!e.allFinite() || !cov.allFinite()) return std::numeric_limits<double>::quiet_NaN();
  const Eigen::LLT<Eigen::Matrix3d> llt(0.5 * (cov + cov.transpose()));
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  return e.dot(llt.solve(e));
}

double PoseErrorStats::add(const Eigen::Vector3d& estimate, const Eigen::Matrix3d& cov,
                           const Eigen::Vector3d& truth) {
  ++n_;
  sum_pos2_ += (estimate.head<2>() - truth.head<2>()).squaredNorm();
  const double dyaw = wrapAngle(estimate(2) - truth(2));
  sum_yaw2_ += dyaw * dyaw;
  const double nees = poseNees(estimate, cov, truth);
  if (std::isfinite(nees)) {
    sum_nees_ += nees;
    ++nees_n_;
  } else {
    ++invalid_nees_;
  }
  return nees;
}

double PoseErrorStats::positionRmse() const {
  return n_ == 0 ? 0.0 : std::sqrt(sum_pos2_ / static_cast<double>(n_));
}

double PoseErrorStats::headingRmse() const {
  return n_ == 0 ? 0.0 : std::sqrt(sum_yaw2_ / static_cast<double>(n_));
}

double PoseErrorStats::meanNees() const {
  return nees_n_ == 0 ? std::numeric_limits<double>::quiet_NaN()
                      : sum_nees_ / static_cast<double>(nees_n_);
}

NeesBand neesBand(int runs, int dof, double probability) {
  if (runs < 1 || dof < 1 || !(probability > 0.0 && probability < 1.0)) {
    throw std::invalid_argument("neesBand: need runs >= 1, dof >= 1 and 0 < probability < 1");
  }
  const int n = runs * dof;
  NeesBand b;
  b.lower = chi2Quantile(0.5 * (1.0 - probability), n) / runs;
  b.upper = chi2Quantile(0.5 * (1.0 + probability), n) / runs;
  return b;
}

void MonteCarloNees::add(std::size_t scan, double nees) {
  if (!std::isfinite(nees)) return;
  if (scan >= sum_.size()) {
    sum_.resize(scan + 1, 0.0);
    n_.resize(scan + 1, 0);
  }
  sum_[scan] += nees;
  ++n_[scan];
}

double MonteCarloNees::average(std::size_t scan) const {
  return runs(scan) == 0 ? std::numeric_limits<double>::quiet_NaN() : sum_[scan] / n_[scan];
}

double MonteCarloNees::fractionInBand(int dof, double probability) const {
  std::size_t inside = 0, used = 0;
  for (std::size_t k = 0; k < sum_.size(); ++k) {
    if (n_[k] == 0) continue;
    ++used;
    if (neesBand(n_[k], dof, probability).contains(average(k))) ++inside;
  }
  return used == 0 ? 0.0 : static_cast<double>(inside) / static_cast<double>(used);
}

}  // namespace ekf_slam
