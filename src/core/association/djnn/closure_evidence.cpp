#include "ekf_slam/core/association/djnn/closure_evidence.h"

#include <algorithm>

namespace ekf_slam {

namespace {
// Corrections kept per closure: each scan proposes at most one per observation, and one far
// behind the leader never decides anything again.
constexpr std::size_t kMaxEntries = 64;
}  // namespace

void ClosureEvidence::read(const ParameterReader& r) {
  p_.closure_margin = r.nonNegative("closure_margin", Params().closure_margin);
}

double ClosureEvidence::searchMargin(double joint_margin) const {
  return std::max(joint_margin, p_.closure_margin);
}

bool ClosureEvidence::add(const AssociationContext& ctx, const JointMlProblem& problem,
                          const std::vector<CorrectionSource>& sources, const JointMlDecision& d,
                          const std::function<bool(int)>& old, double gate, double search_margin) {
  if (!d.complete) return false;
  // The scan's hypotheses, each with its cost above the best: its best and, per observation, the
  // best that decides that observation otherwise.
  std::vector<std::pair<PoseCorrection, double>> hypotheses;
  hypotheses.emplace_back(poseCorrection(ctx, problem, sources, d.best, old), 0.0);
  const bool closes = hypotheses.front().first.paired;
  // A hypothesis the scan did not report costs at least the least of those it did (it differs
  // from the best somewhere), and at least the search's reach.
  double unreported = search_margin;
  for (std::size_t k = 0; k < d.alternative.size(); ++k) {
    if (d.alternative[k].empty()) continue;
    const double cost = d.alternative_cost[k] - d.best_cost;
    unreported = std::min(unreported, cost);
    hypotheses.emplace_back(poseCorrection(ctx, problem, sources, d.alternative[k], old), cost);
  }
  std::vector<double> cost(entries_.size(), unreported);
  int leader = -1;
  for (std::size_t h = 0; h < hypotheses.size(); ++h) {
    // Leaving the old landmarks out of the map is no correction: the scan's own margin weighs
    // it (a duplicate, not a wrong closure).
    const PoseCorrection& c = hypotheses[h].first;
    if (!c.paired) continue;
    int match = -1;
    for (std::size_t e = 0; e < entries_.size() && match < 0; ++e) {
      if (correctionsAgree(entries_[e].correction, c, gate)) match = static_cast<int>(e);
    }
    if (match < 0) {
      if (entries_.size() >= kMaxEntries) continue;
      entries_.push_back({c, unseen_});  // its earlier scans at their bound
      cost.push_back(hypotheses[h].second);
      match = static_cast<int>(entries_.size()) - 1;
    } else if (h == 0 || hypotheses[h].second < cost[match]) {
      cost[match] = std::min(cost[match], hypotheses[h].second);
      entries_[match].correction = c;  // the latest: the pose moves on by odometry
    }
    if (h == 0) leader = match;
  }
  for (std::size_t e = 0; e < entries_.size(); ++e) entries_[e].score += cost[e];
  unseen_ += unreported;
  if (!closes) return true;  // the best closes nothing
  if (leader < 0) return false;
  for (std::size_t e = 0; e < entries_.size(); ++e) {
    if (static_cast<int>(e) == leader) continue;
    if (entries_[e].score - entries_[leader].score < p_.closure_margin) return false;
  }
  return true;
}

}  // namespace ekf_slam
