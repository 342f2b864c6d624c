// Reweighted random walks for graph matching (Cho, Lee & Lee, ECCV 2010; seed 004 eq. 6-7;
// ALGORITHMS.md section 7) on a sparse affinity matrix over candidate correspondences.
//
// A candidate c = (row r_c, column s_c) pairs node r_c of the first graph (an observation) with
// node s_c of the second (a landmark). K is symmetric and non-negative: K_cc the node affinity,
// K_cd (c != d) the edge affinity of the two correspondences; entries of conflicting candidates
// (same row or same column) must be absent. One iteration, as in the authors' reference code:
//   y   = K (alpha x + (1 - alpha) r) / d_max      d_max = the largest degree (column sum of K):
//                                                  the mass a smaller degree loses goes to the
//                                                  absorbing state (eq. 6)
//   x'  = y / sum(y)
//   r'  = Sinkhorn(exp(beta x' / max x')) / sum    reweighting jump, pushed towards a one-to-one
//                                                  matching by alternating row and column
//                                                  normalisation (rows != columns: the missing
//                                                  side is padded with dummy nodes of ones, as the
//                                                  reference code pads the matrix to a square)
// until min(|x' - x|^2, |x' - x_prev|^2) < tolerance (the second term stops a 2-cycle) or
// max_iterations.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace ekf_slam {

struct RrwParams {
  double alpha = 0.2;  ///< share of the walk against the reweighting jump
  double beta = 30.0;  ///< inflation of the jump exp(beta x / max x)
  int max_iterations = 300;
  double tolerance = 1e-12;  ///< on the squared change of x between iterations
  /// Sinkhorn rounds per reweighting: the jump only needs to lean towards a one-to-one matching
  /// (5 and 100 rounds gave the same matchings on the paper's scenes; 100 cost 2x the time).
  int sinkhorn_iterations = 10;
  double sinkhorn_tolerance = 1e-3;  ///< on the largest deviation of a row sum from 1
};

/// Candidate correspondences and their affinity K in compressed sparse rows (symmetric, with the
/// diagonal). Build with addCandidate(), then for each candidate in order beginRow() followed by
/// its entries with addEntry().
struct MatchGraph {
  int rows = 0;               ///< nodes of the first graph
  int cols = 0;               ///< nodes of the second graph
  std::vector<int> row, col;  ///< per candidate
  std::vector<int> start;     ///< CSR row starts (size candidates + 1 once finished)
  std::vector<int> index;
  std::vector<double> value;

  void clear(int rows_, int cols_);
  int addCandidate(int r, int c);
  int size() const { return static_cast<int>(row.size()); }
  void beginRow() { start.push_back(static_cast<int>(index.size())); }
  void addEntry(int candidate, double v) {
    index.push_back(candidate);
    value.push_back(v);
  }
  void finish() { start.push_back(static_cast<int>(index.size())); }
  std::size_t entries() const { return index.size(); }
};

class ReweightedRandomWalks {
 public:
  /// Runs the walk; x receives one score per candidate (sums to 1; uniform when K is empty).
  /// Returns the number of iterations.
  int run(const MatchGraph& g, const RrwParams& p, Eigen::VectorXd* x);

  /// Sinkhorn normalisation of candidate weights `a` (in place) towards a doubly stochastic
  /// rows x cols matrix, the smaller side padded with dummy nodes of ones.
  void sinkhorn(const MatchGraph& g, const RrwParams& p, Eigen::VectorXd* a);

 private:
  /// Scales the aggregated dummy entries so that the dummies sum to one each (`dummies` of them).
  void normaliseDummies(double dummies);

  Eigen::VectorXd prev_, prev2_, assign_, mixed_, cur_;
  std::vector<double> row_sum_, col_sum_, slack_;
};

}  // namespace ekf_slam
