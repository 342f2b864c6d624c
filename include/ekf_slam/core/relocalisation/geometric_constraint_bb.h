// Geometric-constraint branch and bound relocalisation (seed 001 paper 2; ALGORITHMS.md
// section 6): the search FGCBB and GCBB share. The two plugins differ only in their defaults:
// FGCBB splits the observations into compact groups of at most N and takes map pairs only where
// C_ij = 1 (closer than the sensor range R); GCBB searches all observations at once over every
// landmark.
//
// One call:
//  1. Observations -> points on base_link (dropped: invalid ones, those beyond
//     max_observation_range). Fewer than
//     min_observations points, or fewer than 3 landmarks: kNotFound with the reason.
//  2. Candidates per observation: every landmark (no prior) or those whose predicted position
//     passes the prior's chi-square gate (grid query around it); then the unary constraint.
//  3. Per group, branch and bound over the interpretation tree (observation -> landmark or none).
//     A pairing enters only if it meets the unary constraint, the binary constraint with every
//     pairing already in the hypothesis (chi2(1) gate on the pairwise distance, with the
//     covariances) and, with locality, C_jl = 1 with each of them (candidates then come from the
//     anchor landmark's neighbour list: no scan of the map). The bound keeps every hypothesis
//     within ambiguity_margin pairings of the best (subsets of a kept one are not kept), so the
//     runner-up is known.
//  4. Each kept hypothesis with >= min_group_pairings pairings proposes a pose: 2D alignment,
//     refined, and the joint compatibility test D^2 <= chi2(2k - 3). Proposals whose poses agree
//     (distinct_distance, distinct_angle) form one candidate pose, seeded with the best proposal
//     of each group.
//  5. Verification: each candidate pose is refined from its seeds, tested jointly, and extended to
//     every observation that exactly one free landmark explains at that pose (kept if the whole
//     set stays jointly compatible). Its score is the number of observations it explains. The
//     best candidate must explain at least max(min_pairings, min_paired_fraction of the usable
//     observations) (else kNotFound: a random constellation elsewhere explains few of them), at
//     least min_seen_fraction of the map landmarks in view of the sensor at that pose (within
//     max_observation_range, or the farthest observation, and field_of_view; negative
//     information: a wrong place shows landmarks the scan does not have), and more than
//     ambiguity_margin more than the runner-up (else kAmbiguous).
//
// Parameters (section FGCBB or GCBB; defaults in brackets, FGCBB / GCBB where they differ):
//   sensor_range        [16]     R [m]: C_ij = 1 iff |m_i - m_j| < R (the paper's 16 m)
//   max_observation_range [0]    observations farther from the sensor are not used [m]; 0: all
//   group_size          [6 / 0]  N: at most N observations per group; 0 = one group (GCBB)
//   overlapping_groups  [false]  every observation seeds a group of its N - 1 nearest (instead
//                                of a partition): a scene whose mapped trees do not fall in
//                                one partition group is still found, at m searches per call
//   group_coverage      [0]      with overlapping_groups: a point seeds a group only while it
//                                is in fewer than this many groups; 0: every point seeds one.
//                                Bounds the searches of a scan with many observations
//   use_locality        [true / false]  C_ij = 1 required for map pairs
//   unary_probability   [0.95]   unary gate chi2(1, p)
//   descriptor_sigma    [0.1]    std dev of one descriptor (trunk diameter) [m]
//   range_sigma         [0]      range noise of one observation for the constraints [m]; 0: the
//                                observation's own R (see
//                                docs/notes/2026-11-to-12-relocalisation-record.md: a filter's R
//                                may be inflated, which blunts the binary constraint)
//   bearing_sigma       [0]      bearing noise likewise [rad]; 0: the observation's own R
//   landmark_sigma_cap  [0]      a map landmark's covariance is capped at this std dev for the
//                                constraints [m]; 0: as given. A saved map's covariances are
//                                absolute (mostly the vehicle's pose uncertainty when it mapped
//                                them, shared by neighbours), but the constraints compare
//                                neighbours, whose relative error is far smaller
//   binary_probability  [0.99]   binary gate chi2(1, p)
//   joint_probability   [0.95]   joint compatibility chi2(2k - 3, p)
//   prior_probability   [0.999]  prior gate chi2(2, p)
//   min_observations    [3]      fewer usable observations: kNotFound
//   min_pairings        [5]      a pose needs at least this many jointly compatible pairings
//   min_group_pairings  [4]      a group's hypothesis needs this many to propose a pose
//   min_paired_fraction [0.3]    ... and to explain this share of the usable observations
//   min_seen_fraction   [0.6]    ... and this share of the map landmarks in view at the pose
//   field_of_view       [2 pi]   the sensor's field of view about its x axis, for "in view" [rad]
//   ambiguity_margin    [1]      the winner must beat the runner-up by more than this
//   distinct_distance   [2.0]    poses farther apart [m] ...
//   distinct_angle      [0.2]    ... or turned more [rad] are different hypotheses
//   max_hypotheses      [256]    more hypotheses kept in one group: kAmbiguous
//   max_nodes           [200000] search budget per call; spent: kAmbiguous
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/common/chi2.h"
#include "ekf_slam/core/relocalisation/geometric_constraints.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace ekf_slam {

struct GeometricConstraintParams {
  double sensor_range = 16.0;
  double max_observation_range = 0.0;
  int group_size = 6;
  bool overlapping_groups = false;
  int group_coverage = 0;
  bool use_locality = true;
  double unary_probability = 0.95;
  double descriptor_sigma = 0.1;
  double range_sigma = 0.0;
  double bearing_sigma = 0.0;
  double landmark_sigma_cap = 0.0;
  double binary_probability = 0.99;
  double joint_probability = 0.95;
  double prior_probability = 0.999;
  int min_observations = 3;
  int min_pairings = 5;
  int min_group_pairings = 4;
  double min_paired_fraction = 0.3;
  double min_seen_fraction = 0.6;
  double field_of_view = 2.0 * M_PI;
  int ambiguity_margin = 1;
  double distinct_distance = 2.0;
  double distinct_angle = 0.2;
  int max_hypotheses = 256;
  int max_nodes = 200000;
};

class GeometricConstraintBB : public Relocaliser {
 public:
  void configure(const ParameterSource& params) override;
  void setMap(const std::vector<MapLandmark>& map) override;
  RelocalisationResult relocalise(const std::vector<Observation>& observations,
                                  const Eigen::Vector3d& sensor_offset,
                                  const PosePrior* prior) override;
  /// Every scan's observations carried into the current base_link (older sightings of a tree a
  /// newer scan saw, within the prior_probability gate, dropped); "in view" for the negative
  /// information is from any of the scans' poses.
  RelocalisationResult relocaliseWindow(const std::vector<CarriedScan>& scans,
                                        const Eigen::Vector3d& sensor_offset,
                                        const PosePrior* prior) override;

  const GeometricConstraintParams& params() const { return params_; }
  /// Groups of the last call (indices into its observations), for tests and the benchmark.
  const std::vector<std::vector<int>>& lastGroups() const { return last_groups_; }

 protected:
  /// The plugin's defaults (FGCBB: grouping and locality; GCBB: neither).
  explicit GeometricConstraintBB(const GeometricConstraintParams& defaults);

 private:
  struct Hypothesis {
    std::vector<int> landmark;  // per point of the group: map index or -1
    int size = 0;
  };
  /// A candidate pose checked against every observation.
  struct Verified {
    std::vector<std::pair<int, int>> pairs;  // (point, map index); empty: not jointly compatible
    PoseFit fit;
    int expected = 0;  // map landmarks in view of the sensor at fit.pose
  };
  struct Scored {
    int group = 0;
    std::vector<std::pair<int, int>> pairs;  // (point, map index)
    PoseFit fit;
  };

  /// Resets the per-call state and checks the inputs (false: `result` says why).
  bool begin(const Eigen::Vector3d& sensor_offset, const PosePrior* prior,
             RelocalisationResult* result);
  double maxRange() const;
  /// Steps 2-5 on points_ and views_.
  RelocalisationResult solve(const PosePrior* prior, RelocalisationResult result);
  void makeGroups();
  /// map_ from given_map_ with the current parameters.
  void buildMap();
  void candidatesFor(const PosePrior* prior);
  void searchGroup(const std::vector<int>& group);
  void search(int level);
  void record();
  bool compatible(int point, int landmark) const;
  PoseFit fit(const std::vector<std::pair<int, int>>& pairs) const;
  bool jointlyCompatible(const PoseFit& fit, std::size_t k) const;
  /// Seeds (the best proposal of each group for one pose) refined, tested jointly, and extended
  /// to every observation that one free landmark explains at that pose.
  Verified verify(const std::vector<std::pair<int, int>>& seeds) const;
  bool samePose(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
  /// Landmarks whose position passes the chi2(2) `gate` for point i seen from `pose` with
  /// covariance `cov`, and the unary constraint (grid query, then the exact test).
  void gatedCandidates(int point, const Eigen::Vector3d& pose, const Eigen::Matrix3d& cov,
                       double gate, std::vector<int>* out) const;
  int threshold() const;
  double localityRange() const;
  // The observations with range_sigma / bearing_sigma in place of their own R, where set.
  std::vector<Observation> withOwnNoise(const std::vector<Observation>& observations) const;

  GeometricConstraintParams defaults_;
  GeometricConstraintParams params_;
  std::vector<MapLandmark> given_map_;  // as setMap got it (map_ holds it capped)
  MapPairTable map_;
  Chi2Table joint_chi2_;
  double unary_gate_ = 0.0, binary_gate_ = 0.0, prior_gate_ = 0.0;

  // Per call.
  std::vector<ObservedPoint> points_;
  Eigen::Vector3d sensor_offset_ = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> views_;        // base_link of each scan in the current base_link
  double view_range_ = 0.0;                   // landmarks within it of the sensor are "in view"
  std::vector<std::vector<int>> candidates_;  // per point: map indices passing unary (+ prior)
  std::vector<std::vector<char>> allowed_;    // per point, per landmark: in candidates_ (prior)
  bool have_prior_ = false;
  std::vector<std::vector<int>> last_groups_;  // indices into points_ (then into observations)
  std::uint64_t nodes_ = 0;
  bool budget_exhausted_ = false;
  bool too_many_ = false;

  // Per group search.
  const std::vector<int>* group_ = nullptr;
  std::vector<int> current_;  // per level: map index or -1
  std::vector<int> paired_levels_;
  std::vector<char> used_;  // per landmark
  int paired_ = 0;
  int best_ = 0;
  std::vector<Hypothesis> kept_;
};

}  // namespace ekf_slam
