#include "ekf_slam/core/association/djnn/remembered_features.h"

#include <algorithm>
#include <limits>

#include <Eigen/LU>

namespace ekf_slam {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kMaxSightings = 1000000;
}  // namespace

void RememberedFeatures::read(const ParameterReader& r) {
  const Params def;
  p_.remembered_sightings =
      r.integer("remembered_sightings", def.remembered_sightings, 0, kMaxSightings);
  p_.held_birth_cost = r.nonNegative("held_birth_cost", def.held_birth_cost);
}

void RememberedFeatures::reset() {
  remembered_.clear();
  keys_ = 0;
}

void RememberedFeatures::anchor(const AssociationContext& ctx, const LocalScan& scan, Tentative* t,
                                const std::function<bool(LandmarkId)>& recently_paired,
                                double tentative_gate) const {
  if (!on()) return;
  double best = kInf;
  t->anchor = kNoLandmark;
  for (int j : scan.cand) {
    // Only a landmark paired recently moves with the pose the feature was placed from; an old one
    // (at a loop closure) is off by the whole pose error.
    if (!recently_paired(ctx.landmarkId(j))) continue;
    const Eigen::Vector2d off = t->position - ctx.ekf().landmark(j);
    if (off.squaredNorm() >= best) continue;
    best = off.squaredNorm();
    t->anchor = ctx.landmarkId(j);
    t->anchor_offset = off;
  }
  const Eigen::Matrix3d P = ctx.ekf().poseCovariance();
  if (t->anchor != kNoLandmark) {
    // The feature's fused observation noise, as much again for the anchor's estimate relative to
    // the pose it was seen from, and the offset turned by the heading's uncertainty.
    const Eigen::Vector2d perp(-t->anchor_offset.y(), t->anchor_offset.x());
    t->anchor_cov = 2.0 * t->cov + std::max(0.0, P(2, 2)) * perp * perp.transpose();
    // Within its gate of the anchor it is that landmark seen again (a held observation): no
    // feature of its own.
    if (t->anchor_offset.dot(t->anchor_cov.inverse() * t->anchor_offset) <= tentative_gate) {
      t->anchor = kNoLandmark;
    }
  }
  if (t->anchor == kNoLandmark) {
    // Left without an anchor, it may be anchored at its timeout (timedOut) with the pose's
    // uncertainty at this sighting.
    const Eigen::Vector2d lever = t->position - scan.sensor_pose.head<2>();
    const Eigen::Vector2d perp_lever(-lever.y(), lever.x());
    t->pose_cov =
        P.topLeftCorner<2, 2>() + std::max(0.0, P(2, 2)) * perp_lever * perp_lever.transpose();
  }
}

void RememberedFeatures::timedOut(const AssociationContext& ctx, const Tentative& t, double radius,
                                  double tentative_gate, DjnnStats* stats) {
  if (!on() || t.sightings < p_.remembered_sightings) return;
  if (t.anchor != kNoLandmark) {
    remembered_[t.anchor].push_back({t.anchor_offset, t.anchor_cov, keys_++});
    ++stats->remembered;
    return;
  }
  // No landmark moved with the pose it was seen from (none in view, or none yet: the markers
  // passed in the first seconds of a run, which a loop closure back to the start needs). Its
  // place in the map frame is known to its noise plus the pose's uncertainty then; so is the
  // nearest landmark's now. Their offset, with both, anchors it.
  const EkfSlam& ekf = ctx.ekf();
  int k = -1;
  double best = kInf;
  for (int j : ctx.landmarksNear(t.position, radius)) {
    const double d2 = (t.position - ekf.landmark(j)).squaredNorm();
    if (d2 < best) {
      best = d2;
      k = j;
    }
  }
  if (k < 0) return;
  const Eigen::Vector2d offset = t.position - ekf.landmark(k);
  const Eigen::Matrix2d cov = 2.0 * t.cov + t.pose_cov + ekf.landmarkCovariance(k);
  // Within its gate of that landmark it is that landmark seen (or it is too vague to tell).
  if (offset.dot(cov.inverse() * offset) <= tentative_gate) return;
  remembered_[ctx.landmarkId(k)].push_back({offset, cov, keys_++});
  ++stats->remembered;
  ++stats->remembered_late_anchor;
}

// Remembered features enter as virtual observations paired with their anchor landmark: the
// observation moved by the offset (z' = h(anchor) + z - h(anchor + offset)), its noise grown by
// the offset's covariance, so that the joint covariance keeps the anchor's correlations.
void RememberedFeatures::options(const AssociationContext& ctx, const LocalScan& scan,
                                 const TentativeSet& tentatives, const std::vector<int>& live,
                                 JointOptions* out) const {
  const int m = static_cast<int>(ctx.numObservations());
  out->observations.clear();
  out->extra.assign(m, {});
  out->key_anchor.clear();
  if (!on()) return;
  out->observations = ctx.observations();
  const Eigen::Vector3d pose = ctx.robotPose();
  const auto addOption = [&](int j, const Eigen::Vector2d& offset, const Eigen::Matrix2d& cov,
                             int key, double cost) {
    const Eigen::Vector2d at = ctx.ekf().landmark(j) + offset;
    for (int i = 0; i < m; ++i) {
      const Observation& o = ctx.observations()[i];
      Eigen::Matrix2d H_m;
      const Eigen::Vector2d z_hat = ctx.model().predict(pose, at, o.kind, nullptr, &H_m);
      Observation v = o;
      v.z = ctx.prediction(j, o.kind).z_hat + RangeBearingModel::innovation(o.z, z_hat, o.kind);
      v.R = o.R + H_m * cov * H_m.transpose();
      out->observations.push_back(v);
      out->extra[i].push_back({static_cast<int>(out->observations.size()) - 1, j, key, cost});
    }
  };
  std::unordered_map<LandmarkId, int> local;  // anchor id -> state index
  for (int j : scan.cand) {
    local[ctx.landmarkId(j)] = j;
    const auto it = remembered_.find(ctx.landmarkId(j));
    if (it == remembered_.end()) continue;
    for (const Remembered& r : it->second) {
      addOption(j, r.offset, r.cov, r.key, 0.0);
      out->key_anchor[r.key] = it->first;
    }
  }
  // The live tentative features in view are options too: a marker seen a few times on this
  // pass is likelier itself than an old landmark a pose shift away.
  for (int slot : live) {
    const Tentative& t = tentatives[slot];
    const auto it = local.find(t.anchor);
    if (it == local.end() || t.sightings < p_.remembered_sightings) continue;
    addOption(it->second, t.anchor_offset, t.anchor_cov, kLiveKeyBase + slot,
              t.held_birth ? p_.held_birth_cost : 0.0);
  }
}

void RememberedFeatures::admitted(int key, const JointOptions& options) {
  std::vector<Remembered>& list = remembered_[options.key_anchor.at(key)];
  list.erase(
      std::remove_if(list.begin(), list.end(), [key](const Remembered& r) { return r.key == key; }),
      list.end());
}

}  // namespace ekf_slam
