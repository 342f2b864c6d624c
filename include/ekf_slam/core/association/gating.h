// What NN, JCBB, NNJCBB and Hungarian share: the individual chi-square gate (ALGORITHMS.md
// section 2, seed 000 eq. 4), the candidate search margin, the per-scan gating table, and the
// new-landmark policy for observations left unpaired (Bailey's GATE_AUGMENT rule, see
// docs/association.md).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "ekf_slam/core/association/data_association.h"

namespace ekf_slam {

/// Parameters common to the gated associators, read by GatingParameters::read():
///   individual_probability   (0.95)   gate M_ij <= chi2(2, p) for a pairing
///   candidate_margin         (5.0 m)  landmarks within max observed range + margin of the sensor
///                                     are candidates (spatial index query)
///   new_landmark_probability (0.9999) an unpaired observation becomes a new landmark only if
///                                     M_ij > chi2(2, p) for every candidate j; else rejected
struct GatingParameters {
  double individual_probability = 0.95;
  double individual_gate = 5.991464547107979;  ///< chi2(2, individual_probability)
  double candidate_margin = 5.0;
  double new_landmark_probability = 0.9999;
  double new_landmark_gate = 18.420680743952367;  ///< chi2(2, new_landmark_probability)

  /// Reads and validates the three parameters (new_landmark_probability must be >=
  /// individual_probability: a new landmark inside the pairing gate would duplicate one).
  /// `individual_default` is the default of individual_probability (RRWSC gates looser).
  void read(const ParameterReader& reader, double individual_default = 0.95);
};

/// One individually compatible pairing of an observation with a candidate landmark.
struct GatedPair {
  int landmark;        ///< state-order landmark index
  int local;           ///< position of the landmark in GatingTable::candidates()
  double mahalanobis;  ///< M_ij
  double score;        ///< M_ij + ln|S_ij| (seed 000 eq. 5)
  Eigen::Vector2d v;   ///< innovation
  Eigen::Matrix2d S;   ///< innovation covariance (incl. R)
};

/// Individual gating of one scan against the candidate landmarks, computed once per scan and
/// shared by the algorithm's steps. Storage is kept between scans (no per-scan reallocation once
/// warm).
class GatingTable {
 public:
  /// Evaluates every (observation, candidate) pair once: O(m x candidates).
  void build(const AssociationContext& ctx, const GatingParameters& params);

  /// Candidate landmarks (state-order indices, ascending).
  const std::vector<int>& candidates() const { return candidates_; }
  std::size_t numObservations() const { return num_obs_; }
  /// Individually compatible landmarks of observation `obs`, best (least score) first; ties by
  /// landmark index.
  const std::vector<GatedPair>& compatible(int obs) const { return compatible_[obs]; }
  /// Least M_ij of observation `obs` over all candidates (gated or not); +inf without candidates.
  double minMahalanobis(int obs) const { return min_mahalanobis_[obs]; }

 private:
  std::vector<int> candidates_;
  std::vector<std::vector<GatedPair>> compatible_;
  std::vector<double> min_mahalanobis_;
  std::size_t num_obs_ = 0;
};

/// The new-landmark policy: kNew when the observation is farther than the augment gate from every
/// candidate landmark, else kRejected (too close to a landmark to be a new one, too far or too
/// contested to be paired with it).
inline Decision unpairedDecision(double min_mahalanobis, const GatingParameters& params) {
  return min_mahalanobis > params.new_landmark_gate ? Decision::kNew : Decision::kRejected;
}

/// Fills `result` (resized to the scan) from a hypothesis: choice[i] = state-order landmark index
/// or -1; unpaired observations go through unpairedDecision().
void applyHypothesis(const AssociationContext& ctx, const GatingTable& table,
                     const GatingParameters& params, const std::vector<int>& choice,
                     AssociationResult* result);

/// Mutual exclusion by greedy assignment: every compatible pair of the table, least score first,
/// is accepted when neither its observation nor its landmark is taken yet. Observations keep
/// their choice when it is uncontested. choice[i] as in applyHypothesis().
void exclusiveNearestNeighbour(const GatingTable& table, std::vector<int>* choice);

/// Number of observations whose landmark in `choice` is also chosen by another observation.
/// `counts` is scratch storage (sized to the table's candidates).
int countInterfering(const GatingTable& table, const std::vector<int>& choice,
                     std::vector<int>* counts);

}  // namespace ekf_slam
