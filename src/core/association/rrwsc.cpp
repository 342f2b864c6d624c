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
  joint_refinement_ = reader.flag("joint_refinement", true);
  stale_scans_ = reader.integer("stale_scans", 10, 0, 1000000);
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
      min_mahalanobis_[i] = std::min(min_mahalanobis_[i], mij);
    }
  }
  matcher_.match(input_, params_, &match_);
  stats_.iterations += matcher_.stats().iterations;
  // The graph's recognitions the filter refuses are the lost-robot evidence (step 8), counted
  // on the graph's own matching whatever the refinement then picks.
  int gated = 0, refused = 0;
  for (int i = 0; i < m; ++i) {
    if (match_[i] < 0) continue;
    ++stats_.matched;
    if (input_.mahalanobis(i, match_[i]) <= gating_.individual_gate) {
      ++gated;
    } else {
      ++refused;
    }
  }
  stats_.incompatible += refused;
  result.gate_refused += refused;
  graph_match_ = match_;
  const bool confirmed = gated > refused;
  if (joint_refinement_ && confirmed) refine(m, n);
  // Claimed = paired through the gate: a landmark the graph gave to an observation the filter
  // then refused is still unexplained.
  claimed_.assign(n, 0);
  for (int i = 0; i < m; ++i) {
    if (match_[i] >= 0 && input_.mahalanobis(i, match_[i]) <= gating_.individual_gate) {
      claimed_[match_[i]] = 1;
    }
  }
  held_.assign(n, 0);
  for (int i = 0; i < m; ++i) {
    const int j = match_[i];
    if (j < 0) {
      // An unmatched observation the graph recognised as a landmark, or within unclaimed_gate
      // of a landmark nobody claimed, is most likely that landmark's return, farther off than
      // the filter expects (far, noisy): rejected rather than a duplicate.
      const int g = graph_match_[i];
      const int u = g >= 0 && !claimed_[g] ? g : nearestUnclaimed(i, n);
      if (u >= 0) held_[u] = 1;
      if (g >= 0) {
        result.decision[i] = Decision::kRejected;
      } else if (u >= 0) {
        ++stats_.unclaimed;
        result.decision[i] = Decision::kRejected;
      } else {
        result.decision[i] = unpairedDecision(min_mahalanobis_[i], gating_);
      }
      continue;
    }
    if (input_.mahalanobis(i, j) <= gating_.individual_gate) {
      result.pair(i, ctx.landmarkId(candidates_[j]));
    } else {
      // The graph says landmark j, the filter disagrees (e.g. the pose is lost): neither an
      // update nor a new landmark, which would duplicate j.
      result.decision[i] = Decision::kRejected;
    }
  }
  if (stale_scans_ > 0 && confirmed) retireStale(ctx, n, &result);
  return result;
}

int RRWSC::nearestUnclaimed(int i, int n) const {
  int best = -1;
  double best_m = unclaimed_gate_;
  for (int j = 0; j < n; ++j) {
    const double mij = input_.mahalanobis(i, j);
    if (!claimed_[j] && mij <= best_m) {
      best = j;
      best_m = mij;
    }
  }
  return best;
}

void RRWSC::retireStale(const AssociationContext& ctx, int n, AssociationResult* result) {
  // With the prior confirmed by the rest of the scan, a landmark left unclaimed next to a return
  // held back for it, scan after scan, is an estimate the filter has lost (wrong and too
  // certain): its returns would be refused for the rest of the run. Removing it lets the return
  // start the landmark afresh.
  for (int j = 0; j < n; ++j) {
    const LandmarkId id = ctx.landmarkId(candidates_[j]);
    if (claimed_[j]) {
      stale_.erase(id);
    } else if (held_[j] && ++stale_[id] >= stale_scans_) {
      stale_.erase(id);
      result->remove.push_back(id);
      ++stats_.retired;
    }
  }
}

void RRWSC::refine(int m, int n) {
  // The graph matching, confirmed by the prior (most of its matches pass the gate), says the
  // filter's prediction is where the scan is; there the filter's joint likelihood ranks the
  // landmarks better than the shape contexts, whose bins blur with the bearing noise. Each
  // observation may stay unpaired at the gate's cost, as in ekf_slam/Hungarian.
  // Only landmarks gated to some observation take part: the others are unpaired in every
  // assignment, and the solver's time grows with the columns.
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const double gate = gating_.individual_gate;
  landmark_of_col_.clear();
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < m; ++i) {
      if (input_.mahalanobis(i, j) <= gate) {
        landmark_of_col_.push_back(j);
        break;
      }
    }
  }
  const int nl = static_cast<int>(landmark_of_col_.size());
  cost_.setConstant(m, nl + m, kInf);
  for (int c = 0; c < nl; ++c) {
    for (int i = 0; i < m; ++i) {
      const double mij = input_.mahalanobis(i, landmark_of_col_[c]);
      if (mij <= gate) cost_(i, c) = mij;
    }
  }
  for (int i = 0; i < m; ++i) cost_(i, nl + i) = gate;  // its own "unpaired" column
  solver_.solve(cost_, &row_to_col_);
  ++stats_.refined;
  for (int i = 0; i < m; ++i) {
    const int c = row_to_col_[i];
    const int j = c >= 0 && c < nl ? landmark_of_col_[c] : -1;
    stats_.changed += j != match_[i];
    match_[i] = j;
  }
}

}  // namespace ekf_slam
