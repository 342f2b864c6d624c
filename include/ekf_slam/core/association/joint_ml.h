// Joint maximum-likelihood assignment of a scan's observations to map landmarks or to "not in the
// map" (an unmapped landmark or clutter), by branch and bound over each observation's gated
// candidates. Used by DJNN at loop closures (docs/djnn.md, "A joint decision at loop closures").
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "ekf_slam/core/association/data_association.h"

namespace ekf_slam {

/// D^2 + ln|S| of the joint innovation of `pairs` (observation, landmark state index): -2 ln
/// N(v; 0, S) less its 2 pi term. Infinite when S is not positive definite, 0 for no pairs.
double jointInnovationCost(const AssociationContext& ctx,
                           const std::vector<std::pair<int, int>>& pairs);

/// A density of "not in the map" given per m^2 of the plane (-2 ln of it: `cost_per_m2`), as -2 ln
/// of the density in observation o's measurement space, where the pairings' likelihoods N(v; 0, S)
/// are: a range-bearing return spreads the plane's r dr dphi over dr dphi, so its density there
/// is r times the planar one (a Cartesian one's is the planar one).
double unmappedCostAt(double cost_per_m2, const Observation& o);

/// A pairing with something other than a map landmark itself (a remembered feature, docs/djnn.md
/// "Remembered sightings"): observation `obs` of the context (e.g. a virtual one) with landmark
/// `landmark`, exclusive under the key `target` (>= 0, one per remembered feature), at `cost`
/// (>= 0, -2 ln) on top of the pairing's own.
struct JointMlExtra {
  int obs = -1;
  int landmark = -1;
  int target = -1;
  double cost = 0.0;
};

struct JointMlProblem {
  std::vector<int> obs;                      ///< observation indices of the scan
  std::vector<std::vector<int>> candidates;  ///< per entry of obs: landmark state indices
  /// Optional (empty, or one list per entry of obs): further options of each entry; taking one
  /// is reported in JointMlDecision::best as -2 - target.
  std::vector<std::vector<JointMlExtra>> extra;
  /// -2 ln(density per m^2) of "not in the map" for one observation (taken to its measurement
  /// space by unmappedCostAt).
  double null_cost = 0.0;
  /// Optional (empty, or one per entry of obs): that entry's own cost of "not in the map" (per
  /// m^2, as null_cost), instead of null_cost.
  std::vector<double> null_costs;
  std::size_t max_nodes = 200000;  ///< search budget per search (all searches: m + 1)
};

struct JointMlDecision {
  bool complete = false;  ///< every search finished within the budget
  /// Per entry of obs: landmark state index, -1 (not in the map) or -2 - target (an extra option).
  std::vector<int> best;
  double best_cost = 0.0;  ///< -2 ln of the best hypothesis' likelihood
  /// Per entry of obs: the least cost of a hypothesis deciding that observation otherwise than
  /// `best` (infinite if there is none within `best_cost + margin`).
  std::vector<double> alternative_cost;
  /// Per entry of obs: that hypothesis (as `best`), empty when there is none.
  std::vector<std::vector<int>> alternative;
  std::size_t nodes = 0;
};

/// One-to-one hypotheses: each observation takes one of its candidates or none. Cost of a
/// hypothesis: -2 ln N(v; 0, S) of its pairs jointly (full covariance) plus `null_cost` per
/// observation left out. Alternatives are searched only up to `best_cost + margin`.
JointMlDecision jointMaximumLikelihood(const AssociationContext& ctx, const JointMlProblem& problem,
                                       double margin);

}  // namespace ekf_slam
