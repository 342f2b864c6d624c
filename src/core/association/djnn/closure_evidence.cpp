#include "ekf_slam/core/association/djnn/closure_evidence.h"

#include <algorithm>

#include <Eigen/LU>

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

std::vector<ClosureEvidence::Source> ClosureEvidence::sources(const AssociationContext& ctx,
                                                              const JointMlProblem& problem) const {
  std::vector<Source> src(problem.obs.size());
  for (std::size_t k = 0; k < problem.obs.size(); ++k) {
    const Observation& o = ctx.observations()[problem.obs[k]];
    Matrix23d G_pose;
    Eigen::Matrix2d G_obs;
    src[k].point = ctx.model().inverse(ctx.robotPose(), o.z, o.kind, &G_pose, &G_obs);
    src[k].cov = G_obs * o.R * G_obs.transpose();
  }
  return src;
}

ClosureEvidence::Correction ClosureEvidence::correctionOf(
    const AssociationContext& ctx, const JointMlProblem& problem, const std::vector<Source>& src,
    const std::vector<int>& hypothesis, const std::function<bool(int)>& old) const {
  Correction c;
  int n = 0;
  for (std::size_t k = 0; k < problem.obs.size(); ++k) {
    const int j = hypothesis[k];
    if (j < 0 || !old(j)) continue;  // no landmark, or one the local frame already holds
    c.offset += src[k].point - ctx.ekf().landmark(j);
    c.cov += src[k].cov + ctx.ekf().landmarkCovariance(j);
    ++n;
  }
  c.paired = n > 0;
  if (n > 0) {
    c.offset /= n;
    c.cov /= static_cast<double>(n) * n;
  }
  return c;
}

bool ClosureEvidence::agree(const Correction& a, const Correction& b, double gate) {
  if (a.paired != b.paired) return false;
  if (!a.paired) return true;
  const Eigen::Vector2d e = a.offset - b.offset;
  return e.dot((a.cov + b.cov).inverse() * e) <= gate;
}

bool ClosureEvidence::add(const AssociationContext& ctx, const JointMlProblem& problem,
                          const JointMlDecision& d, const std::function<bool(int)>& old,
                          double gate, double search_margin) {
  if (!d.complete) return false;
  const std::vector<Source> src = sources(ctx, problem);
  // The scan's hypotheses, each with its cost above the best: its best and, per observation, the
  // best that decides that observation otherwise.
  std::vector<std::pair<Correction, double>> hypotheses;
  hypotheses.emplace_back(correctionOf(ctx, problem, src, d.best, old), 0.0);
  const bool closes = hypotheses.front().first.paired;
  // A hypothesis the scan did not report costs at least the least of those it did (it differs
  // from the best somewhere), and at least the search's reach.
  double unreported = search_margin;
  for (std::size_t k = 0; k < d.alternative.size(); ++k) {
    if (d.alternative[k].empty()) continue;
    const double cost = d.alternative_cost[k] - d.best_cost;
    unreported = std::min(unreported, cost);
    hypotheses.emplace_back(correctionOf(ctx, problem, src, d.alternative[k], old), cost);
  }
  std::vector<double> cost(entries_.size(), unreported);
  int leader = -1;
  for (std::size_t h = 0; h < hypotheses.size(); ++h) {
    // Leaving the old landmarks out of the map is no correction: the scan's own margin weighs
    // it (a duplicate, not a wrong closure).
    const Correction& c = hypotheses[h].first;
    if (!c.paired) continue;
    int match = -1;
    for (std::size_t e = 0; e < entries_.size() && match < 0; ++e) {
      if (agree(entries_[e].correction, c, gate)) match = static_cast<int>(e);
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
