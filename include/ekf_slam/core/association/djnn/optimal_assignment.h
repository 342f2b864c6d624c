// DJNN extension "optimal assignment" (optimal_assignment; docs/djnn.md): the paper resolves
// interference greedily, each contested landmark keeping its closest observation and the losers
// taking their next nearest. Where returns of landmarks closer than the noise cross, that can
// leave two returns swapped although the other way round fits both better. After the paper's
// resolution this part re-pairs the same observations with the local region's landmarks so that
// the sum of their eq. 5 scores (with the scan's compensation) is least, within the paper's gate:
// the joint maximum-likelihood pairing of the observations the paper pairs. It changes which
// landmark an observation goes to, never whether it is paired.
// With assign_unpaired, the returns the resolution left unpaired although a landmark lies within
// the gate join the assignment too, each with "not in the map" as its alternative (at the cost
// the density test weighs, eq. 5's units): an interference loser whose landmark another return
// fits worse takes it, and the paired ones keep a landmark each.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/association_context.h"
#include "ekf_slam/core/association/djnn/djnn_paper.h"
#include "ekf_slam/core/association/djnn/local_scan.h"
#include "ekf_slam/core/common/assignment_solver.h"
#include "ekf_slam/core/common/parameters.h"

namespace ekf_slam {

class OptimalAssignment {
 public:
  struct Params {
    bool optimal_assignment = true;
    bool assign_unpaired = true;
  };
  void read(const ParameterReader& r);
  const Params& params() const { return p_; }
  /// Re-pairs scan->assign's paired observations at least total score; counts the changes.
  /// null_cost: -2 ln of the density of "not in the map" at an unpaired observation (the
  /// density test's), +inf when unknown (then no unpaired observation joins).
  void apply(const AssociationContext& ctx, const DjnnPaper& paper, double null_cost,
             LocalScan* scan, DjnnStats* stats);

 private:
  Params p_;
  AssignmentSolver solver_;
  std::vector<int> rows_, row_to_col_;
  std::vector<double> unpaired_scores_;  ///< per unpaired row: its n candidates' scores
  Eigen::MatrixXd cost_;
};

}  // namespace ekf_slam
