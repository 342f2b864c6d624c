#include "ekf_slam/core/association/djnn/density_test.h"

#include <cmath>
#include <utility>
#include <vector>

#include "ekf_slam/core/association/joint_ml.h"

namespace ekf_slam {

void DensityTest::read(const ParameterReader& r) {
  const Params def;
  p_.landmark_density = r.nonNegative("landmark_density", def.landmark_density);
  p_.estimate_landmark_density = r.flag("estimate_landmark_density", def.estimate_landmark_density);
  p_.density_test = r.flag("density_test", def.density_test || p_.landmark_density > 0.0);
}

void DensityTest::configure(const SensorModel& sensor) {
  // The region's area by counting a fine grid over its bounding box: any wedge, annulus and
  // polygon alike, once per configure.
  constexpr int kCells = 400;
  const double R = sensor.max_range;
  const double cell = 2.0 * R / kCells;
  int inside = 0;
  for (int a = 0; a < kCells; ++a) {
    for (int b = 0; b < kCells; ++b) {
      inside += sensor.contains({-R + (a + 0.5) * cell, -R + (b + 0.5) * cell}, 0.0, 0.0);
    }
  }
  region_area_ = inside * cell * cell;
  reset();
}

void DensityTest::reset() { landmarks_seen_ = area_seen_ = 0.0; }

double DensityTest::density() const {
  if (!estimating()) return p_.landmark_density;
  return area_seen_ > 0.0 ? landmarks_seen_ / area_seen_ : 0.0;
}

void DensityTest::observe(const AssociationContext& ctx, const DjnnPaper& paper,
                          const LocalScan& scan) {
  if (!estimating() || !(region_area_ > 0.0)) return;
  int inside = 0;
  for (int j : scan.cand) {
    inside += paper.inRegion(DjnnPaper::inSensorFrame(scan, ctx.ekf().landmark(j)), 0.0, 0.0);
  }
  // A region without a mapped landmark is new ground (or bare): it says nothing of how many
  // landmarks are there, only that none is mapped yet.
  if (inside == 0) return;
  landmarks_seen_ += inside;
  area_seen_ += region_area_;
}

void DensityTest::apply(const AssociationContext& ctx, double null_cost, LocalScan* scan,
                        DjnnStats* stats) const {
  if (!on()) return;
  std::vector<int>& assign = scan->assign;
  const int m = static_cast<int>(assign.size());
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
  // with it less the joint cost without it) against "not in the map" in its measurement space: a
  // marker never seen before paired with an old one a metre off, next to pairings that fix the
  // pose, stands out; withdrawn worst first.
  while (true) {
    const double all = cost(-1);
    int worst = -1;
    double worst_excess = 0.0;
    for (int i = 0; i < m; ++i) {
      if (assign[i] < 0) continue;
      const double excess = all - cost(i) - unmappedCostAt(null_cost, ctx.observations()[i]);
      if (!(excess <= worst_excess)) {
        worst_excess = excess;
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
