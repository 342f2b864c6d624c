#include "ekf_slam/core/association/djnn/ambiguity_gate.h"

#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {

void AmbiguityGate::read(const ParameterReader& r, double individual_probability) {
  p_.ambiguity_probability = r.probability("ambiguity_probability", Params().ambiguity_probability);
  if (p_.ambiguity_probability < individual_probability) {
    r.fail("ambiguity_probability", "must be at least individual_probability");
  }
  p_.tentative_ambiguity = r.flag("tentative_ambiguity", Params().tentative_ambiguity);
  gate_ = chi2Quantile(p_.ambiguity_probability, 2);
}

void AmbiguityGate::apply(const AssociationContext& ctx, const DjnnPaper& paper,
                          LocalScan* scan) const {
  if (!scan->have_table && !(gate_ > paper.gate())) return;
  const int m = scan->observations();
  const int n = scan->candidates();
  for (int i = 0; i < m; ++i) {
    if (scan->assign[i] >= 0) continue;
    scan->gated[i] = 0;
    for (int c = 0; c < n && !scan->gated[i]; ++c) {
      if (scan->have_table) {
        double mah;
        paper.score(*scan, i, c, scan->v_bar, &mah);
        scan->gated[i] = scan->pair(i, c).mahalanobis <= gate_ || mah <= gate_;
      } else {
        scan->gated[i] = ctx.individual(i, scan->cand[c]).mahalanobis <= gate_;
      }
    }
  }
}

}  // namespace ekf_slam
