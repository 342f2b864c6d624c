// RRW&SC graph matching (seed 004; ALGORITHMS.md section 7), shared by the ekf_slam/RRWSC
// associator and relocaliser: observed points and map landmarks are two graphs; node affinity
// from shape context (optionally times a Mahalanobis position term), edge affinity from the
// agreement of pairwise distances, a sparse affinity over pruned candidate pairs, reweighted
// random walks, and a one-to-one discretisation with the package's Hungarian solver.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/common/assignment_solver.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/filter/observation.h"
#include "ekf_slam/core/graph_matching/reweighted_random_walks.h"
#include "ekf_slam/core/graph_matching/shape_context.h"

namespace ekf_slam {

struct RrwscParams {
  ShapeContextParams context;
  RrwParams walk;
  /// Node affinity exp(-chi2 / descriptor_scale) (chi2 in [0, 1]).
  double descriptor_scale = 0.2;
  /// Node affinity times exp(-position_weight M_ij / 2) when a prior gives M_ij; 0 = pure graph
  /// matching (the prior then only bounds which landmarks take part).
  double position_weight = 0.0;
  /// M_ij is capped here in that term (default chi2(2, 0.9999)): beyond it every landmark is
  /// equally implausible, so a wrong prior leaves the ranking to the shape contexts instead of
  /// driving every affinity to zero.
  double position_cap = 18.420680743952367;
  /// Pairwise distances agree within sigma = sqrt(var_obs + var_map + edge_sigma^2) [m]: the
  /// variances along the pair's direction from the points' covariances, plus this floor.
  double edge_sigma = 0.5;
  /// Edge affinity exp(-e^2 / 2 sigma^2), set to 0 beyond e > edge_gate sigma (sparsity).
  double edge_gate = 3.0;
  /// Edges link each observation's edge_neighbours nearest observations (symmetrised); 0 = all
  /// pairs.
  int edge_neighbours = 10;
  /// Candidates kept per observation: the landmarks of highest node affinity (plus, with a prior,
  /// the one of least M_ij). The position term is capped, so a wrong prior cannot push the right
  /// landmark out.
  int candidates_per_observation = 8;
  /// A match whose walk score is below this share of the best score stays unmatched.
  double min_relative_score = 1e-3;

  /// Reads every parameter (names in docs/association.md, "RRWSC"); the associator and the
  /// relocaliser differ in the default of position_weight.
  void read(const ParameterReader& reader, double position_weight_default);
};

/// One matching problem: observed points (any frame, e.g. the sensor's) and landmarks (map frame).
struct MatchInput {
  std::vector<Eigen::Vector2d> observed;
  std::vector<Eigen::Matrix2d> observed_cov;
  std::vector<Eigen::Vector2d> landmarks;
  std::vector<Eigen::Matrix2d> landmark_cov;
  /// Optional prior: M_ij (observations x landmarks); empty = no prior. Pairs with +inf are
  /// never candidates.
  Eigen::MatrixXd mahalanobis;
};

/// Fills in->observed and in->observed_cov from range-bearing observations: the points in the
/// sensor frame and their covariances G R G^T.
void setObservedPoints(const std::vector<Observation>& observations, MatchInput* in);

struct MatchStats {
  int candidates = 0;
  std::size_t entries = 0;  ///< non-zeros of the affinity matrix
  int iterations = 0;       ///< of the random walk
};

class RrwscMatcher {
 public:
  /// Matches observations to landmarks one-to-one; landmark_of_obs[i] = landmark index or -1.
  void match(const MatchInput& in, const RrwscParams& p, std::vector<int>* landmark_of_obs);

  /// Discretises the last walk again with some candidates forbidden (forbidden[c] != 0), e.g.
  /// to find the runner-up matching.
  void discretise(const std::vector<char>* forbidden, std::vector<int>* landmark_of_obs);

  const MatchGraph& graph() const { return graph_; }
  /// Walk score of each candidate of graph() (sums to 1).
  const Eigen::VectorXd& scores() const { return x_; }
  const MatchStats& stats() const { return stats_; }

 private:
  void buildCandidates(const MatchInput& in, const RrwscParams& p);
  void buildAffinity(const MatchInput& in, const RrwscParams& p);

  /// A landmark compared with an observation: log of its node affinity, the two parts of it, and
  /// the affinity itself once shortlisted.
  struct Ranked {
    double log_node;
    double log_position;
    double distance;  ///< of the shape contexts
    double node;
    int landmark;
  };

  RrwscParams p_;
  ShapeContextBuilder contexts_;
  std::vector<ShapeContext> obs_sc_, map_sc_;
  std::vector<ShapeContextSupport> obs_support_, map_support_;
  std::vector<RingHistogram> obs_rings_, map_rings_;
  std::vector<int> cand_begin_;    ///< candidates of observation i: [begin[i], begin[i+1])
  std::vector<double> cand_node_;  ///< node affinity per candidate
  std::vector<double> node_root_;  ///< its square root
  std::vector<Ranked> best_;
  std::vector<double> top_keys_;
  Eigen::MatrixXd obs_dist_, obs_var_, map_dist_, map_var_;
  std::vector<char> linked_;  ///< observation pairs that carry edges
  std::vector<std::pair<double, int>> near_;
  std::vector<int> used_, local_of_;  ///< landmarks among the candidates, and back
  std::vector<int> cand_local_;       ///< per candidate: its landmark's index in used_
  /// Edge between candidates c < d: exp(-e^2 / 2 sigma^2), before the node weighting.
  struct Edge {
    int c, d;
    double affinity;
  };
  std::vector<Edge> edges_;
  std::vector<int> fill_;  ///< next free entry per row while filling the graph
  MatchGraph graph_;
  ReweightedRandomWalks walk_;
  Eigen::VectorXd x_;
  AssignmentSolver solver_;
  Eigen::MatrixXd cost_;
  std::vector<int> col_of_landmark_, landmark_of_col_, row_to_col_, obs_of_row_;
  MatchStats stats_;
};

}  // namespace ekf_slam
