// The association ceiling of a scan (docs/results.md, "The ceiling"): the associations an
// observer with perfect knowledge, the TRUE vehicle pose and the TRUE landmark positions, would
// choose. No SLAM filter knows as much, and the noise of one scan is independent of everything
// before it given the pose and the map, so no associator deciding the scan can beat these on
// average: what remains wrong is ambiguous by the physics of the noise. Evaluation side only.
//
//   sim::Random rng(seed);
//   ScanCeiling c = associationCeiling(model, true_pose, world.landmarks, observations, {}, &rng);
//   c.joint[i] == truth[i]  ...
//
// Every observation is a return of one of the landmarks (each landmark gives at most one) and
// its likelihood under landmark j is N(z; h(pose, l_j), R_i) with its own R_i. R_i is the same
// for every j, so the log-det terms are constant per observation and drop out: the costs are the
// Mahalanobis distances M_ij = v^T R_i^-1 v, v = z_i - h(pose, l_j) (bearing wrapped). Exact for
// the simulator's range-bearing scans (noise drawn in range and bearing with R, a wrapped
// bearing's other branches being negligible); for its Cartesian scans R depends on the true
// point, and the constant R_i is then an approximation.
#pragma once

#include <limits>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/filter/observation_model.h"
#include "ekf_slam/evaluation/simulation/simulator.h"

namespace ekf_slam {

struct CeilingOptions {
  /// Metropolis-Hastings sweeps (of one proposal per observation) over the one-to-one
  /// assignments, for the posterior marginals; 0 skips them (ScanCeiling::marginal stays empty).
  int sweeps = 200;
  /// Sweeps discarded before the marginals are counted (the chain starts at the joint optimum).
  int burn_in_sweeps = 20;
};

/// One scan's decisions: a landmark index per observation.
struct ScanCeiling {
  /// The joint maximum-likelihood one-to-one assignment (Hungarian on M_ij): the most probable
  /// whole scan. It maximises the chance that the whole scan is right, not the expected number
  /// of right observations.
  std::vector<int> joint;
  /// Each observation's own most likely landmark (least M_ij), ignoring the others.
  std::vector<int> individual;
  /// Each observation's most probable landmark under the posterior over the one-to-one
  /// assignments given the whole scan (uniform prior): the decision that maximises the expected
  /// number of right observations, the strict ceiling of that count (up to sampling error).
  std::vector<int> marginal;
  /// The posterior probability of each `marginal` choice (its sum over the scan: the expected
  /// number right).
  std::vector<double> marginal_probability;
};

/// The ceiling of one scan: `observations` are returns of `landmarks` seen by `model` (its sensor
/// offset) from vehicle pose `pose`. The marginals need `rng` (ignored when options.sweeps is
/// 0). Throws std::invalid_argument when there are more observations than landmarks or rng is
/// missing for the marginals.
ScanCeiling associationCeiling(const RangeBearingModel& model, const Eigen::Vector3d& pose,
                               const std::vector<Eigen::Vector2d>& landmarks,
                               const std::vector<Observation>& observations,
                               const CeilingOptions& options = {}, sim::Random* rng = nullptr);

}  // namespace ekf_slam
