#include "ekf_slam/core/association/djnn/joint_decision.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "ekf_slam/core/association/joint_ml.h"

namespace ekf_slam {

void JointDecision::read(const ParameterReader& r, bool unmapped_density, bool age_set) {
  const Params def;
  p_.loop_closure_age = r.nonNegative("loop_closure_age", def.loop_closure_age);
  p_.joint_margin = r.nonNegative("joint_margin", def.joint_margin);
  evidence_.read(r);
  if (p_.loop_closure_age > 0.0 && !unmapped_density) {
    if (age_set) {
      r.fail("loop_closure_age",
             "needs landmark_density (or its estimate) or clutter_density > 0 (the joint "
             "decision's \"not in the map\")");
    }
    p_.loop_closure_age = 0.0;  // the default, with no "not in the map" to weigh: off
  }
}

void JointDecision::reset() {
  evidence_.clear();
  last_paired_.clear();
  held_streak_ = 0;
}

bool JointDecision::recentlyPaired(LandmarkId id, double stamp) const {
  const auto it = last_paired_.find(id);
  return it != last_paired_.end() && !(stamp - it->second > p_.loop_closure_age);
}

void JointDecision::record(const AssociationResult& result, double stamp) {
  for (std::size_t i = 0; i < result.decision.size(); ++i) {
    if (result.decision[i] == Decision::kPaired) last_paired_[result.landmark[i]] = stamp;
  }
  for (LandmarkId id : result.remove) last_paired_.erase(id);
}

void JointDecision::endHeldStreak(HeldConfirmation* confirmation, DjnnStats* stats) {
  stats->held_streaks += held_streak_ > 0;
  stats->held_streak_scans += held_streak_;
  held_streak_ = 0;
  confirmation->clear();
  evidence_.clear();
}

namespace {
// The reach of the widened candidates: the local region's range grown by three standard
// deviations of the pose (position, and heading at the far range).
double widenedRadius(const AssociationContext& ctx, double R, double range_margin) {
  const Eigen::Matrix3d P = ctx.ekf().poseCovariance();
  return R + range_margin +
         3.0 *
             (std::sqrt(std::max(0.0, P(0, 0) + P(1, 1))) + R * std::sqrt(std::max(0.0, P(2, 2))));
}
}  // namespace

// The local region (eq. 10) is placed by the pose estimate with margins for a good pose; back on
// old landmarks with a pose error of metres, a true landmark in view can lie outside it, and the
// joint decision would then never weigh the true hypothesis. Landmarks within three standard
// deviations of the pose (position, and heading at the far range) that gate with an observation
// join the candidates.
void JointDecision::widenCandidates(const AssociationContext& ctx, const std::vector<int>& near,
                                    double gate, LocalScan* scan) const {
  const int m = scan->observations();
  std::vector<int> added;
  for (int j : near) {
    if (std::binary_search(scan->cand.begin(), scan->cand.end(), j)) continue;
    for (int i = 0; i < m; ++i) {
      if (ctx.individual(i, j).mahalanobis <= gate) {
        added.push_back(j);
        break;
      }
    }
  }
  if (added.empty()) return;
  std::vector<int> paired(m, -1);
  for (int i = 0; i < m; ++i) paired[i] = scan->assign[i] >= 0 ? scan->cand[scan->assign[i]] : -1;
  std::vector<std::pair<int, char>> merged;
  for (std::size_t c = 0; c < scan->cand.size(); ++c)
    merged.emplace_back(scan->cand[c], scan->cand_valid[c]);
  for (int j : added) merged.emplace_back(j, 0);  // outside eq. 10, so outside eq. 7
  std::sort(merged.begin(), merged.end());
  scan->cand.clear();
  scan->cand_valid.clear();
  for (const auto& e : merged) {
    scan->cand.push_back(e.first);
    scan->cand_valid.push_back(e.second);
  }
  for (int i = 0; i < m; ++i) {
    if (paired[i] >= 0) scan->assign[i] = scan->slotOf(paired[i]);
  }
}

bool JointDecision::decide(const AssociationContext& ctx, const Parts& parts, LocalScan* scan,
                           DjnnStats* stats) {
  const int m = scan->observations();
  const DjnnPaperParams& pp = parts.paper.params();
  const double gate = parts.ambiguity_gate;
  // A closure scan: an observation gates with a landmark last paired longer ago than
  // loop_closure_age (or never), in the local region or among the landmarks the widening would
  // add. The age first: most landmarks near were paired lately, and only a closure scan is
  // widened.
  const auto is_old = [&](int j) {
    const auto it = last_paired_.find(ctx.landmarkId(j));
    return it == last_paired_.end() || scan->stamp - it->second > p_.loop_closure_age;
  };
  const auto gates = [&](int j) {
    for (int i = 0; i < m; ++i) {
      if (!(ctx.individual(i, j).mahalanobis > gate)) return true;
    }
    return false;
  };
  // The landmarks the widening reaches, queried once: for the closure test when no candidate
  // is old, and for the widening of a closure scan.
  std::vector<int> near;
  bool near_queried = false;
  const auto nearby = [&]() -> const std::vector<int>& {
    if (!near_queried) {
      near = ctx.landmarksNear(scan->sensor_pose.head<2>(),
                               widenedRadius(ctx, pp.sensor.max_range, pp.range_margin));
      near_queried = true;
    }
    return near;
  };
  bool old = false;
  for (int j : scan->cand) {
    if (is_old(j) && gates(j)) {
      old = true;
      break;
    }
  }
  if (!old) {
    for (int j : nearby()) {
      if (std::binary_search(scan->cand.begin(), scan->cand.end(), j)) continue;
      if (is_old(j) && gates(j)) {
        old = true;
        break;
      }
    }
  }
  if (!old) {
    endHeldStreak(&parts.confirmation, stats);
    return false;
  }
  widenCandidates(ctx, nearby(), gate, scan);
  JointOptions options;
  if (parts.remembered.on()) {
    std::vector<int> live;
    parts.paper.tentatives().query(scan->sensor_pose.head<2>(),
                                   pp.sensor.max_range + pp.range_margin, &live);
    parts.remembered.options(ctx, *scan, parts.paper.tentatives(), live, &options);
  } else {
    options.extra.assign(m, {});
  }
  const AssociationContext ectx(
      ctx.ekf(), ctx.model(), ctx.landmarkIndex(),
      options.observations.empty() ? ctx.observations() : options.observations, ctx.stamp());
  JointMlProblem problem;
  problem.null_cost = parts.unmapped_cost;
  bool any_extra = false;
  for (int i = 0; i < m; ++i) {
    std::vector<int> gated;
    for (int j : scan->cand) {
      if (ctx.individual(i, j).mahalanobis <= gate) gated.push_back(j);
    }
    std::vector<JointMlExtra> kept;
    for (const JointMlExtra& e : options.extra[i]) {
      if (ectx.individual(e.obs, e.landmark).mahalanobis <= gate) kept.push_back(e);
    }
    if (gated.empty() && kept.empty()) continue;
    any_extra = any_extra || !kept.empty();
    if (parts.spacing.on()) {
      // Within the spacing of a gated landmark it is that landmark or clutter.
      problem.null_costs.push_back(parts.spacing.within(ctx, i, gated, parts.paper.gate())
                                       ? -2.0 * std::log(parts.clutter_density)
                                       : parts.unmapped_cost);
    }
    problem.obs.push_back(i);
    problem.candidates.push_back(std::move(gated));
    problem.extra.push_back(std::move(kept));
  }
  if (!any_extra) problem.extra.clear();
  ++stats->joint_scans;
  const double margin = p_.joint_margin;
  const double search_margin = evidence_.searchMargin(margin);
  const JointMlDecision d = jointMaximumLikelihood(ectx, problem, search_margin);
  // Both compare the scan's hypotheses by the pose corrections they imply (pose_correction.h).
  std::vector<CorrectionSource> sources;
  if (d.complete && (parts.confirmation.on() || evidence_.on()))
    sources = correctionSources(ctx, problem);
  // After held scans, a lead that did not lead them is one scan's noise: held again.
  HeldConfirmation::Lead lead;
  if (parts.confirmation.on()) lead = parts.confirmation.leadOf(ctx, problem, sources, d);
  const bool unconfirmed =
      !parts.confirmation.empty() && !parts.confirmation.repeats(lead, parts.paper.gate());
  // The closure's evidence summed over its held scans: held, on top of the scan's own margin,
  // until its best's pose correction leads the sum.
  const bool unresolved = evidence_.on() && !evidence_.add(ctx, problem, sources, d, is_old,
                                                           parts.paper.gate(), search_margin);
  const bool remember = parts.remembered.on();
  scan->held = false;
  stats->joint_incomplete += !d.complete;
  bool held = false;
  for (std::size_t k = 0; k < problem.obs.size(); ++k) {
    const int i = problem.obs[k];
    // A hold guards against a wrong closure. An observation whose best pairs a landmark
    // tracked within loop_closure_age, and whose only rival leaves it out of the map ("not in
    // the map", or a remembered or live feature, which would start a landmark of its own),
    // decides no closure: it is paired as tracking would pair it (held, the filter would lose
    // it).
    const bool local = d.best[k] >= 0 && recentlyPaired(ctx.landmarkId(d.best[k]), scan->stamp);
    const bool tracked = local && !d.alternative[k].empty() && d.alternative[k][k] < 0;
    const bool close = d.alternative_cost[k] < d.best_cost + margin;
    // An unresolved closure holds what would close it; a pairing of the local frame is kept.
    if (!d.complete || unconfirmed || (unresolved && !local) || (close && !tracked)) {
      held = true;
      scan->assign[i] = -1;
      ++stats->joint_held;
      scan->held = remember;
      // Held. With remembered features its sighting still feeds a tentative feature (never
      // admitted while held): a marker seen on this pass is then an option of the next scans'
      // decisions.
      scan->gated[i] = remember ? 0 : 1;
      if (remember) scan->force_new[i] = kForceHeld;
    } else if (d.best[k] >= 0) {
      scan->assign[i] = scan->slotOf(d.best[k]);
    } else if (d.best[k] <= -2 - RememberedFeatures::kLiveKeyBase) {
      scan->assign[i] = -1;  // a live tentative feature: not in the map, matched to it below
      scan->gated[i] = 0;
    } else if (d.best[k] <= -2) {
      // A remembered feature: admitted from this observation, and forgotten as such.
      parts.remembered.admitted(-2 - d.best[k], options);
      scan->assign[i] = -1;
      scan->gated[i] = 0;
      scan->force_new[i] = kForceAdmit;
    } else {
      scan->assign[i] = -1;  // decided: not in the map
      scan->gated[i] = 0;
    }
  }
  if (!held) {
    endHeldStreak(&parts.confirmation, stats);
  } else {
    ++held_streak_;
    if (parts.confirmation.on()) parts.confirmation.keep(lead);
  }
  return true;
}

}  // namespace ekf_slam
