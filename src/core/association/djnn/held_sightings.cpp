#include "ekf_slam/core/association/djnn/held_sightings.h"

#include <limits>
#include <vector>

namespace ekf_slam {

void HeldSightings::read(const ParameterReader& r) {
  p_.held_sightings = r.flag("held_sightings", Params().held_sightings);
}

void HeldSightings::join(const AssociationContext& ctx, const LocalScan& scan, FeatureRules* rules,
                         DjnnPaper* paper, AssociationResult* result, DjnnStats* stats) const {
  if (!on()) return;
  TentativeSet& set = paper->tentatives();
  if (set.empty()) return;
  const DjnnPaperParams& pp = paper->params();
  std::vector<int> near;
  set.query(scan.sensor_pose.head<2>(), pp.sensor.max_range + pp.range_margin, &near);
  bool any_held = false;
  for (int slot : near) any_held = any_held || set[slot].held_birth;
  if (!any_held) return;

  const Eigen::Vector3d pose = ctx.robotPose();
  const Eigen::Matrix3d P_vv = ctx.ekf().poseCovariance();
  const int m = static_cast<int>(ctx.numObservations());
  for (int i = 0; i < m; ++i) {
    if (result->decision[i] != Decision::kPaired) continue;
    // The gate of the paper's tentative step.
    Sighting s{};
    double lever_var = 0.0;
    const Eigen::Matrix2d C = DjnnPaper::sightingGate(ctx, i, pose, P_vv, *rules, &s, &lever_var);
    int best = -1;
    double best_d2 = std::numeric_limits<double>::infinity();
    for (int slot : near) {
      const Tentative& t = set[slot];
      if (!t.alive || !t.held_birth || t.last_seen >= scan.stamp) continue;
      const double d2 = DjnnPaper::tentativeDistance2(ctx, i, s, C, lever_var, t);
      if (d2 <= paper->tentativeGate() && d2 < best_d2) {
        best = slot;
        best_d2 = d2;
      }
    }
    if (best < 0) continue;
    result->feature[i] = set[best].key;
    paper->dropFeature(ctx, best, false, rules);
    ++stats->held_joined;
  }
}

}  // namespace ekf_slam
