// DJNN's working state of one scan, shared by the paper's steps (djnn_paper.h) and the
// extensions: the local region's candidates (eq. 10) and which lie in the valid region (eq. 7),
// the compatibility table, the pairing of each observation, and what the extensions decided
// about the observations left unpaired.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/association_context.h"

namespace ekf_slam {

/// LocalScan::force_new values: the joint decision admits the observation (on a remembered
/// feature), or holds it (neither paired nor admitted).
constexpr char kForceAdmit = 1;
constexpr char kForceHeld = 2;

struct LocalScan {
  double stamp = 0.0;
  Eigen::Vector3d sensor_pose = Eigen::Vector3d::Zero();
  std::vector<MeasurementKind> kind;  ///< per observation
  std::vector<int> near;              ///< landmarksNear() of the local region's query
  std::vector<int> cand;              ///< local region (eq. 10), state-order indices, sorted
  std::vector<char> cand_valid;       ///< in the valid region (eq. 7)
  std::vector<AssociationContext::Individual> table;  ///< m x |cand|, when have_table
  bool have_table = false;
  std::vector<int> assign;  ///< per observation: candidate slot or -1
  std::vector<int> count;   ///< per candidate: observations assigned
  std::vector<char> taken;  ///< per candidate
  /// Per observation: not a new feature either (within a gate of a landmark, or withdrawn).
  std::vector<char> gated;
  std::vector<int> winner;  ///< per candidate: closest contesting observation
  std::vector<double> winner_score;
  std::vector<char> force_new;  ///< per observation: kForceAdmit, kForceHeld or 0
  bool held = false;            ///< the joint decision held an observation of this scan
  /// Per candidate: unpaired and hidden behind a nearer return (OccludedMisses); may be empty.
  std::vector<char> hidden;
  /// Per candidate: the share of P_D the beams' spacing left it (BeamSpacingMisses); may be empty.
  std::vector<double> detectable;
  Eigen::Vector2d v_bar = Eigen::Vector2d::Zero();  ///< the compensation that decided (eq. 6-8)

  int observations() const { return static_cast<int>(assign.size()); }
  int candidates() const { return static_cast<int>(cand.size()); }
  const AssociationContext::Individual& pair(int obs, int c) const {
    return table[static_cast<std::size_t>(obs) * cand.size() + c];
  }
  bool isHidden(int c) const {
    return static_cast<std::size_t>(c) < hidden.size() && hidden[c] != 0;
  }
  double detectableAt(int c) const {
    return static_cast<std::size_t>(c) < detectable.size() ? detectable[c] : 1.0;
  }
  /// The candidate slot of landmark state index j (which must be a candidate).
  int slotOf(int j) const {
    return static_cast<int>(std::lower_bound(cand.begin(), cand.end(), j) - cand.begin());
  }
  /// Counts pairings per candidate; returns the number of contested candidates.
  int countPairings() {
    count.assign(cand.size(), 0);
    for (int a : assign) {
      if (a >= 0) ++count[a];
    }
    int contested = 0;
    for (int n : count) contested += n >= 2;
    return contested;
  }
};

}  // namespace ekf_slam
