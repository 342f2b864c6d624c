// DJNN extension "remembered sightings" (remembered_sightings, held_birth_cost; docs/djnn.md,
// "Closing the loops"). A marker seen a few times on a first pass but never admitted leaves a hole
// in the map; back there after a loop, "not in the map" would cost its observation the density of
// unmapped landmarks while a hypothesis shifted by a marker spacing pairs it: the likelihood
// would prefer the shift. A tentative feature that times out with at least remembered_sightings
// static sightings is kept instead as its position relative to the recently paired landmark
// nearest to it (its anchor), known to the observation noise, and the joint decision may pair an
// observation with it (the feature is then admitted). Live tentative features anchored the same
// way are options too; one started by a held observation may be a duplicate of the old landmark
// the closure is about, placed from the uncorrected pose: held_birth_cost charges it.
#pragma once

#include <functional>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/association/djnn/tentative_set.h"
#include "ekf_slam/core/association/joint_ml.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

/// What the joint decision weighs beyond the map's landmarks: virtual observations of anchored
/// features (after the scan's own), per observation its options.
struct JointOptions {
  std::vector<Observation> observations;         ///< empty: none beyond the scan's
  std::vector<std::vector<JointMlExtra>> extra;  ///< per observation of the scan
  std::unordered_map<int, LandmarkId> key_anchor;
};

class RememberedFeatures {
 public:
  struct Params {
    int remembered_sightings = 0;  ///< 0: off
    double held_birth_cost = 0.0;  ///< -2 ln; 0: off
  };
  /// Keys of live tentative features in the joint decision (remembered features count from 0).
  static constexpr int kLiveKeyBase = 1 << 28;

  void read(const ParameterReader& r);
  const Params& params() const { return p_; }
  /// Parameters read elsewhere (DJNN switching to the missed-detection profile mid-run).
  void setParams(const Params& p) { p_ = p; }
  bool on() const { return p_.remembered_sightings > 0; }
  void reset();

  /// Anchors tentative feature t to the nearest candidate landmark that `recently_paired`;
  /// within its gate of the anchor (`tentative_gate`) it is that landmark seen again: no anchor.
  void anchor(const AssociationContext& ctx, const LocalScan& scan, Tentative* t,
              const std::function<bool(LandmarkId)>& recently_paired, double tentative_gate) const;
  /// A tentative feature timed out with evidence left: remembered if seen often enough. One
  /// seen when no landmark was paired near it (the start of a run, before the first landmark)
  /// is anchored now to the nearest landmark within `radius`, with both estimates' uncertainty.
  void timedOut(const AssociationContext& ctx, const Tentative& t, double radius,
                double tentative_gate, DjnnStats* stats);
  /// The joint decision's options: the remembered features anchored to the scan's candidates,
  /// and the live features in `live` (slots) anchored to one.
  void options(const AssociationContext& ctx, const LocalScan& scan, const TentativeSet& tentatives,
               const std::vector<int>& live, JointOptions* out) const;
  /// The joint decision admitted an observation on remembered feature `key`: forgotten as such.
  void admitted(int key, const JointOptions& options);
  /// Landmark `id` left the map: the features anchored to it go too.
  void forgetAnchor(LandmarkId id) { remembered_.erase(id); }

 private:
  struct Remembered {
    Eigen::Vector2d offset;
    Eigen::Matrix2d cov;
    int key;  ///< unique, for the joint decision's one-to-one rule
  };
  Params p_;
  std::unordered_map<LandmarkId, std::vector<Remembered>> remembered_;
  int keys_ = 0;
};

}  // namespace ekf_slam
