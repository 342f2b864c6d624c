// RRW&SC data association: graph matching of the scan against the landmarks in reach, then the
// filter gate; see the header and docs/association.md.
#include "ekf_slam/core/association/rrwsc.h"

#include <algorithm>
#include <limits>

namespace ekf_slam {

void RRWSC::configure(const ParameterSource& params) {
  const ParameterReader reader(params);
  // The gate only vetoes what the graph matching decided, so it can be wider than NN's 0.95.
  gating_.read(reader, 0.999);
  params_.read(reader, 1.0);
  unclaimed_gate_ = reader.nonNegative("unclaimed_gate", 100.0);
  reset();
}

AssociationResult RRWSC::associate(const AssociationContext& ctx) {
  const int m = static_cast<int>(ctx.numObservations());
  AssociationResult result;
  result.resize(m);
  // The spatial index bounds the map graph to the sensor's reach: the cost does not grow with
  // landmarks beyond it.
  candidates_ = ctx.candidateLandmarks(gating_.candidate_margin);
  const int n = static_cast<int>(candidates_.size());
  min_mahalanobis_.assign(m, std::numeric_limits<double>::infinity());
  nearest_.assign(m, -1);
  if (m == 0 || n == 0) {
    for (int i = 0; i < m; ++i) result.decision[i] = unpairedDecision(min_mahalanobis_[i], gating_);
    return result;
  }
  ++stats_.scans;
  setObservedPoints(ctx.observations(), &input_);
  input_.landmarks.resize(n);
  input_.landmark_cov.resize(n);
  input_.mahalanobis.resize(m, n);
  for (int j = 0; j < n; ++j) {
    input_.landmarks[j] = ctx.ekf().landmark(candidates_[j]);
    input_.landmark_cov[j] = ctx.ekf().landmarkCovariance(candidates_[j]);
    for (int i = 0; i < m; ++i) {
      const double mij = ctx.individual(i, candidates_[j]).mahalanobis;
      input_.mahalanobis(i, j) = mij;
      if (mij < min_mahalanobis_[i]) {
        min_mahalanobis_[i] = mij;
        nearest_[i] = j;
      }
    }
  }
  matcher_.match(input_, params_, &match_);
  stats_.iterations += matcher_.stats().iterations;
  // Claimed = paired through the gate: a landmark the graph gave to an observation the filter
  // then refused is still unexplained.
  claimed_.assign(n, 0);
  for (int i = 0; i < m; ++i) {
    if (match_[i] >= 0 && input_.mahalanobis(i, match_[i]) <= gating_.individual_gate) {
      claimed_[match_[i]] = 1;
    }
  }
  for (int i = 0; i < m; ++i) {
    const int j = match_[i];
    if (j < 0) {
      // An unmatched observation whose nearest landmark nobody claimed is most likely that
      // landmark's return, farther off than the filter expects (far, noisy): rejected rather
      // than a duplicate, up to unclaimed_gate.
      if (nearest_[i] >= 0 && !claimed_[nearest_[i]] && min_mahalanobis_[i] <= unclaimed_gate_) {
        ++stats_.unclaimed;
        result.decision[i] = Decision::kRejected;
      } else {
        result.decision[i] = unpairedDecision(min_mahalanobis_[i], gating_);
      }
      continue;
    }
    ++stats_.matched;
    if (input_.mahalanobis(i, j) <= gating_.individual_gate) {
      result.pair(i, ctx.landmarkId(candidates_[j]));
    } else {
      // The graph says landmark j, the filter disagrees (e.g. the pose is lost): neither an
      // update nor a new landmark, which would duplicate j.
      ++stats_.incompatible;
      ++result.gate_refused;
      result.decision[i] = Decision::kRejected;
    }
  }
  return result;
}

}  // namespace ekf_slam
