// NN + JCBB hybrid (seed 003 section 2.2).
#include "ekf_slam/core/association/nnjcbb.h"

#include <climits>

namespace ekf_slam {

void NNJCBB::configure(const ParameterSource& params) {
  const ParameterReader reader(params);
  gating_.read(reader);
  JcbbOptions options;
  options.read(reader, /*default_prefer_least_distance=*/true);
  search_.setOptions(options);
  interference_threshold_ = reader.inRange("interference_threshold", 0.0, 0.0, 1.0);
  every_n_ = reader.integer("jcbb_every_n_scans", 0, 0, INT_MAX);
  reset();
}

void NNJCBB::reset() {
  steps_ = 0;
  since_jcbb_ = 0;
  jcbb_runs_ = 0;
  budget_exhaustions_ = 0;
  last_ran_jcbb_ = false;
}

AssociationResult NNJCBB::associate(const AssociationContext& ctx) {
  ++steps_;
  ++since_jcbb_;
  table_.build(ctx, gating_);
  const int m = static_cast<int>(ctx.numObservations());

  // NN (seed 000 eq. 4-5) on the shared gating table: the first entry is the least-score landmark.
  choice_.assign(m, -1);
  int paired = 0;
  for (int i = 0; i < m; ++i) {
    const auto& list = table_.compatible(i);
    if (!list.empty()) {
      choice_[i] = list.front().landmark;
      ++paired;
    }
  }
  const int interfering = countInterfering(table_, choice_, &counts_);
  const double share = paired > 0 ? static_cast<double>(interfering) / paired : 0.0;

  last_ran_jcbb_ = (interfering > 0 && share > interference_threshold_) ||
                   (every_n_ > 0 && since_jcbb_ >= every_n_);
  if (last_ran_jcbb_) {
    // JCBB's hypotheses use each landmark at most once (the paper's mutual exclusion) and, with
    // prefer_least_distance, the least D^2 among the largest (its optimal criterion).
    choice_ = search_.run(ctx, table_);
    since_jcbb_ = 0;
    ++jcbb_runs_;
    if (search_.stats().budget_exhausted) ++budget_exhaustions_;
  } else if (interfering > 0) {
    exclusiveNearestNeighbour(table_, &choice_);
  }
  AssociationResult result;
  applyHypothesis(ctx, table_, gating_, choice_, &result);
  return result;
}

}  // namespace ekf_slam
