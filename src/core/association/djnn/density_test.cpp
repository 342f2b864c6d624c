#include "ekf_slam/core/association/djnn/density_test.h"

#include <cmath>
#include <utility>
#include <vector>

#include "ekf_slam/core/association/joint_ml.h"

namespace ekf_slam {

void DensityTest::read(const ParameterReader& r) {
  p_.landmark_density = r.nonNegative("landmark_density", Params().landmark_density);
}

double DensityTest::unmappedCost(double clutter_density) const {
  return -2.0 * std::log(p_.landmark_density + clutter_density);
}

void DensityTest::apply(const AssociationContext& ctx, double clutter_density, LocalScan* scan,
                        DjnnStats* stats) const {
  if (!on()) return;
  std::vector<int>& assign = scan->assign;
  const int m = static_cast<int>(assign.size());
  const double null_cost = unmappedCost(clutter_density);
  const double log_2pi = std::log(2.0 * M_PI);
  // -2 ln N(v; 0, S) of the pairings of assign but `skip` (-1: none).
  std::vector<std::pair<int, int>> pairs;
  auto cost = [&](int skip) {
    pairs.clear();
    for (int i = 0; i < m; ++i) {
      if (assign[i] >= 0 && i != skip) pairs.emplace_back(i, scan->cand[assign[i]]);
    }
    return jointInnovationCost(ctx, pairs) + 2.0 * static_cast<double>(pairs.size()) * log_2pi;
  };
  // Each pairing is judged given the others (-2 ln of its conditional likelihood: the joint cost
  // with it less the joint cost without it): a marker never seen before paired with an old one a
  // metre off, next to pairings that fix the pose, stands out; withdrawn worst first.
  while (true) {
    const double all = cost(-1);
    int worst = -1;
    double worst_cost = null_cost;
    for (int i = 0; i < m; ++i) {
      if (assign[i] < 0) continue;
      const double c = all - cost(i);
      if (!(c <= worst_cost)) {
        worst_cost = c;
        worst = i;
      }
    }
    if (worst < 0) return;
    assign[worst] = -1;
    scan->gated[worst] = 1;
    ++stats->density_withdrawn;
  }
}

}  // namespace ekf_slam
